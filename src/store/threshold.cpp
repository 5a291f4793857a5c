// Thresholds on the per-particle property (see threshold.h).
#include "store/threshold.h"

#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "store/format.h"

namespace mds::store {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// An empty field: no bound (v keeps its value); else a finite number.
bool parse_bound(std::string_view field, double& v) {
  field = trim(field);
  if (field.empty()) return true;
  if (field.front() == '+') {
    field.remove_prefix(1);
    if (!field.empty() && field.front() == '-') return false;  // "+-5"
  }
  double x = 0.0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), x);
  if (field.empty() || ec != std::errc() || end != field.data() + field.size() || !std::isfinite(x)) return false;
  v = x;
  return true;
}

}  // namespace

Result<Threshold> parse_threshold(std::string_view text) {
  Threshold t;
  std::string_view range = text;
  if (const size_t comma = text.find(','); comma != std::string_view::npos) {
    if (trim(text.substr(comma + 1)) != "invert")
      return make_error(Errc::invalid_argument, "'{}': expected LO:HI[,invert], e.g. -3.5:-2 or 0.1: (an open end)", text);
    t.invert = true;
    range = text.substr(0, comma);
  }
  const size_t colon = range.find(':');
  if (colon == std::string_view::npos || range.find(':', colon + 1) != std::string_view::npos)
    return make_error(Errc::invalid_argument, "'{}': expected LO:HI[,invert], e.g. -3.5:-2 or 0.1: (an open end)", text);
  const std::string_view lo = range.substr(0, colon), hi = range.substr(colon + 1);
  if (!parse_bound(lo, t.lo)) return make_error(Errc::invalid_argument, "'{}': LO '{}' is not a finite number", text, trim(lo));
  if (!parse_bound(hi, t.hi)) return make_error(Errc::invalid_argument, "'{}': HI '{}' is not a finite number", text, trim(hi));
  if (trim(lo).empty() && trim(hi).empty())
    return make_error(Errc::invalid_argument, "'{}': give LO, HI or both (LO:HI with neither bounds nothing)", text);
  if (t.lo > t.hi) return make_error(Errc::invalid_argument, "'{}': LO {} is greater than HI {}", text, t.lo, t.hi);
  return t;
}

std::string threshold_spec(const Threshold& t) {
  std::string out = std::isfinite(t.lo) ? fmt::format("{}", t.lo) : "";
  out += ':';
  if (std::isfinite(t.hi)) out += fmt::format("{}", t.hi);
  if (t.invert) out += ",invert";
  return out;
}

bool threshold_keeps(const Threshold& t, double v) { return (t.lo <= v && v <= t.hi) != t.invert; }

std::vector<uint8_t> threshold_table(const Threshold& t, float property_min, float property_max) {
  std::vector<uint8_t> table(size_t(kQuantMax) + 1);
  for (uint32_t q = 0; q <= kQuantMax; ++q)
    table[q] = threshold_keeps(t, property_value(property_min, property_max, uint16_t(q))) ? 1 : 0;
  return table;
}

}  // namespace mds::store
