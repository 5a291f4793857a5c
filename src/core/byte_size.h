// Byte sizes as users write them on the command line (--memory-budget, --gpu-budget): one
// parser for every command, so "2GiB" means the same everywhere.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/result.h"

namespace mds {

// Parses a byte size: plain bytes ("1048576"), decimal/binary suffixes ("512MiB", "2GiB",
// "1.5G", "64k", "100MB", "3B"). K/M/G/T without "i" are powers of 1024 as well (memory
// convention); "KB/MB/GB/TB" are powers of 1000. Whitespace between number and unit is allowed.
// At least one byte. Errors (Errc::invalid_argument) quote the offending text.
Result<uint64_t> parse_byte_size(std::string_view text);

// Formats bytes for messages, e.g. "1.50 GiB".
std::string format_bytes(uint64_t bytes);

}  // namespace mds
