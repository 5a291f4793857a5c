// Slices: which particles a user keeps by their position, as OVITO's Slice modifier does
// (`--slice` of render, view and bench). A slice is a plane n.p = d. With width 0 the particles
// on its positive side (n.p > d) are left out; with a width w > 0 only the slab |n.p - d| <= w/2
// is kept; `invert` keeps exactly what the slice would leave out. Several slices keep what each of
// them keeps. Particles are tested by their centre. No Vulkan: the renderer's scene loader
// (render/scene.h) applies them, `info`-like tools can too.
#pragma once

#include <array>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace mds::store {

struct Slice {
  std::array<double, 3> normal{0.0, 0.0, 1.0};  // unit length
  double distance = 0.0;  // signed distance of the plane from the origin along `normal` (world units)
  double width = 0.0;     // 0: a half-space; > 0: a slab of this thickness centred on the plane
  bool invert = false;    // keep what the slice leaves out

  bool operator==(const Slice&) const = default;
};

// "NX,NY,NZ,D[,WIDTH][,invert]" in world units: the plane's normal (any length > 0; normalized,
// D then the distance along the unit normal, as OVITO's Distance), the slab width (default 0)
// and the word `invert`. Spaces around each field are ignored. Errc::invalid_argument naming the
// text for a wrong field count, a field that is not a finite number, a zero normal or a negative
// width.
Result<Slice> parse_slice(std::string_view text);

// Every spec of an option given once per slice (`--slice A --slice B`), in order; the first
// error, prefixed with `option` ("--slice '1,0': expected ...").
Result<std::vector<Slice>> parse_slices(std::span<const std::string> specs, std::string_view option = "--slice");

// The spec that parse_slice reads back as `s` (each number in the shortest text that reads back
// as the same double).
std::string slice_spec(const Slice& s);

// Whether a particle centred at p is kept by s.
bool slice_keeps(const Slice& s, const std::array<double, 3>& p);
// Whether p is kept by every slice (true for none).
bool slices_keep(std::span<const Slice> slices, const std::array<double, 3>& p);

// What the slices do to every point of the box [lo, hi] (a node's or a meshlet's centres).
enum class SliceCover {
  none,  // every point is left out
  all,   // every point is kept
  some,  // it depends on the point
};
SliceCover slices_cover(std::span<const Slice> slices, const std::array<double, 3>& lo, const std::array<double, 3>& hi);

// The box holding every centre a node with this quantization frame decodes to
// (x = center_min + q * (center_max - center_min) / kQuantMax, q in [0, kQuantMax], the
// arithmetic of `export` and the renderer's scene), for slices_cover.
void decoded_box(const double center_min[3], const double center_max[3], std::array<double, 3>& lo,
                 std::array<double, 3>& hi);

}  // namespace mds::store
