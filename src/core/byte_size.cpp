// Byte sizes as users write them on the command line (--memory-budget, --gpu-budget).
#include "core/byte_size.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <string>

namespace mds {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool ieq(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

}  // namespace

Result<uint64_t> parse_byte_size(std::string_view text) {
  const std::string_view s = trim(text);
  size_t i = 0;
  while (i < s.size() && (std::isdigit(static_cast<unsigned char>(s[i])) || s[i] == '.')) ++i;
  const std::string_view num = s.substr(0, i);
  const std::string_view unit = trim(s.substr(i));
  if (num.empty())
    return make_error(Errc::invalid_argument, "byte size '{}': expected a number (e.g. 512MiB, 2GiB, 1.5G, 1048576)", text);
  double value = 0;
  auto [ptr, ec] = std::from_chars(num.data(), num.data() + num.size(), value);
  if (ec != std::errc() || ptr != num.data() + num.size() || !std::isfinite(value))
    return make_error(Errc::invalid_argument, "byte size '{}': '{}' is not a number", text, num);
  struct Unit {
    const char* name;
    double factor;
  };
  static constexpr Unit kUnits[] = {
      {"", 1.0},           {"b", 1.0},
      {"k", 1024.0},       {"ki", 1024.0},       {"kib", 1024.0},       {"kb", 1e3},
      {"m", 1048576.0},    {"mi", 1048576.0},    {"mib", 1048576.0},    {"mb", 1e6},
      {"g", 1073741824.0}, {"gi", 1073741824.0}, {"gib", 1073741824.0}, {"gb", 1e9},
      {"t", 1099511627776.0}, {"ti", 1099511627776.0}, {"tib", 1099511627776.0}, {"tb", 1e12},
  };
  for (const Unit& u : kUnits) {
    if (!ieq(unit, u.name)) continue;
    const double bytes = value * u.factor;
    if (bytes >= 18446744073709549568.0)  // largest double below 2^64
      return make_error(Errc::invalid_argument, "byte size '{}' is too large", text);
    if (!(bytes >= 1.0))
      return make_error(Errc::invalid_argument, "byte size '{}' must be at least one byte", text);
    const double rounded = std::floor(bytes);
    if (rounded != bytes && u.factor == 1.0)
      return make_error(Errc::invalid_argument, "byte size '{}': a count of bytes must be whole", text);
    return uint64_t(rounded);
  }
  return make_error(Errc::invalid_argument, "byte size '{}': unknown unit '{}' (use B, KiB, MiB, GiB, TiB, K, M, G, T, KB, MB, GB, TB)", text, unit);
}

std::string format_bytes(uint64_t bytes) {
  static constexpr const char* kNames[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  double v = double(bytes);
  int k = 0;
  while (v >= 1024.0 && k < 4) {
    v /= 1024.0;
    ++k;
  }
  return k == 0 ? fmt::format("{} B", bytes) : fmt::format("{:.2f} {}", v, kNames[k]);
}

}  // namespace mds
