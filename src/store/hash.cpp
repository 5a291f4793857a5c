#include "store/hash.h"

#include <xxhash.h>

namespace mds::store {

uint64_t hash_bytes(std::span<const uint8_t> bytes) { return XXH3_64bits(bytes.data(), bytes.size()); }

}  // namespace mds::store
