// Thresholds on the per-particle property (see threshold.h).
#include "store/threshold.h"

#include <cmath>

#include <fmt/format.h>

#include "store/format.h"
#include "store/spec_text.h"

namespace mds::store {
namespace {

// An empty field: no bound (v keeps its value); else a finite number.
bool parse_bound(std::string_view field, double& v) {
  return trim_spec_field(field).empty() || parse_spec_number(field, v);
}

}  // namespace

Result<Threshold> parse_threshold(std::string_view text) {
  Threshold t;
  std::string_view range = text;
  if (const size_t comma = text.find(','); comma != std::string_view::npos) {
    if (trim_spec_field(text.substr(comma + 1)) != "invert")
      return make_error(Errc::invalid_argument, "'{}': expected LO:HI[,invert], e.g. -3.5:-2 or 0.1: (an open end)", text);
    t.invert = true;
    range = text.substr(0, comma);
  }
  const size_t colon = range.find(':');
  if (colon == std::string_view::npos || range.find(':', colon + 1) != std::string_view::npos)
    return make_error(Errc::invalid_argument, "'{}': expected LO:HI[,invert], e.g. -3.5:-2 or 0.1: (an open end)", text);
  const std::string_view lo = range.substr(0, colon), hi = range.substr(colon + 1);
  if (!parse_bound(lo, t.lo)) return make_error(Errc::invalid_argument, "'{}': LO '{}' is not a finite number", text, trim_spec_field(lo));
  if (!parse_bound(hi, t.hi)) return make_error(Errc::invalid_argument, "'{}': HI '{}' is not a finite number", text, trim_spec_field(hi));
  if (trim_spec_field(lo).empty() && trim_spec_field(hi).empty())
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
