// XXH3-64, the checksum of every stored section and node payload.
#pragma once

#include <cstdint>
#include <span>

namespace mds::store {

uint64_t hash_bytes(std::span<const uint8_t> bytes);

}  // namespace mds::store
