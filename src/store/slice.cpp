#include "store/slice.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "store/format.h"
#include "store/spec_text.h"

namespace mds::store {
namespace {

// The signed distance n.p - d, summed in one order for points and box corners alike: rounding
// is monotonic, so a point inside a box never lies beyond the box's extreme corners.
double signed_distance(const Slice& s, const std::array<double, 3>& p) {
  return s.normal[0] * p[0] + s.normal[1] * p[1] + s.normal[2] * p[2] - s.distance;
}

// Whether a point at signed distance t is kept.
bool keeps_at(const Slice& s, double t) {
  const bool in = s.width > 0.0 ? std::abs(t) <= 0.5 * s.width : t <= 0.0;
  return in != s.invert;
}

}  // namespace

Result<Slice> parse_slice(std::string_view text) {
  std::vector<std::string_view> fields;
  for (size_t start = 0;;) {
    const size_t comma = text.find(',', start);
    fields.push_back(text.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  Slice s;
  if (!fields.empty() && trim_spec_field(fields.back()) == "invert") {
    s.invert = true;
    fields.pop_back();
  }
  if (fields.size() != 4 && fields.size() != 5)
    return make_error(Errc::invalid_argument, "'{}': expected NX,NY,NZ,DISTANCE[,WIDTH][,invert], e.g. 1,0,0,12.5", text);
  double v[5] = {0, 0, 0, 0, 0};
  static constexpr const char* kField[5] = {"NX", "NY", "NZ", "DISTANCE", "WIDTH"};
  for (size_t i = 0; i < fields.size(); ++i)
    if (!parse_spec_number(fields[i], v[i]))
      return make_error(Errc::invalid_argument, "'{}': {} '{}' is not a finite number", text, kField[i],
                        trim_spec_field(fields[i]));
  const double length = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(length > 0.0) || !std::isfinite(length))
    return make_error(Errc::invalid_argument, "'{}': the normal NX,NY,NZ must have a finite length > 0", text);
  if (v[4] < 0.0) return make_error(Errc::invalid_argument, "'{}': the slab WIDTH must be >= 0", text);
  s.normal = {v[0] / length, v[1] / length, v[2] / length};
  s.distance = v[3];
  s.width = v[4];
  return s;
}

Result<std::vector<Slice>> parse_slices(std::span<const std::string> specs, std::string_view option) {
  std::vector<Slice> slices;
  for (const std::string& spec : specs) {
    auto s = parse_slice(spec);
    if (!s) return make_error(Errc::invalid_argument, "{} {}", option, s.error().message);
    slices.push_back(*s);
  }
  return slices;
}

std::string slice_spec(const Slice& s) {
  // fmt's "{}": the shortest text that reads back as the same double.
  std::string out = fmt::format("{},{},{},{}", s.normal[0], s.normal[1], s.normal[2], s.distance);
  if (s.width > 0.0) out += fmt::format(",{}", s.width);
  if (s.invert) out += ",invert";
  return out;
}

bool slice_keeps(const Slice& s, const std::array<double, 3>& p) { return keeps_at(s, signed_distance(s, p)); }

bool slices_keep(std::span<const Slice> slices, const std::array<double, 3>& p) {
  for (const Slice& s : slices)
    if (!slice_keeps(s, p)) return false;
  return true;
}

SliceCover slices_cover(std::span<const Slice> slices, const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  SliceCover cover = SliceCover::all;
  for (const Slice& s : slices) {
    // The box's smallest and largest signed distances, at two of its corners.
    std::array<double, 3> near{}, far{};
    for (int a = 0; a < 3; ++a) {
      const bool up = s.normal[a] >= 0.0;
      near[a] = up ? lo[a] : hi[a];
      far[a] = up ? hi[a] : lo[a];
    }
    const double t0 = signed_distance(s, near), t1 = signed_distance(s, far);
    // The kept set of t is an interval (or, inverted, its complement): a box whose range of t
    // lies inside it or outside it is kept or left out whole.
    bool inside_all, inside_none;
    if (s.width > 0.0) {
      const double h = 0.5 * s.width;
      inside_all = t0 >= -h && t1 <= h;
      inside_none = t1 < -h || t0 > h;
    } else {
      inside_all = t1 <= 0.0;
      inside_none = t0 > 0.0;
    }
    const bool keep_all = s.invert ? inside_none : inside_all;
    const bool keep_none = s.invert ? inside_all : inside_none;
    if (keep_none) return SliceCover::none;
    if (!keep_all) cover = SliceCover::some;
  }
  return cover;
}

void decoded_box(const double center_min[3], const double center_max[3], std::array<double, 3>& lo,
                 std::array<double, 3>& hi) {
  for (int a = 0; a < 3; ++a) {
    const double step = (center_max[a] - center_min[a]) / double(kQuantMax);
    const double top = center_min[a] + double(kQuantMax) * step;  // may differ from center_max by rounding
    lo[a] = std::min(center_min[a], top);
    hi[a] = std::max(center_min[a], top);
  }
}

}  // namespace mds::store
