// Numbers in the option specs of store/slice.h and store/threshold.h ("1,0,0,12.5", "-6:"):
// fields trimmed of spaces and tabs, a finite double with an optional leading '+'.
#pragma once

#include <charconv>
#include <cmath>
#include <string_view>

namespace mds::store {

inline std::string_view trim_spec_field(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// The whole (trimmed) field as a finite double into v; false (v unchanged) otherwise ("", "+-5",
// "1e999", "nan", "2x").
inline bool parse_spec_number(std::string_view field, double& v) {
  field = trim_spec_field(field);
  if (!field.empty() && field.front() == '+') {
    field.remove_prefix(1);
    if (!field.empty() && field.front() == '-') return false;
  }
  double x = 0.0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), x);
  if (field.empty() || ec != std::errc() || end != field.data() + field.size() || !std::isfinite(x)) return false;
  v = x;
  return true;
}

}  // namespace mds::store
