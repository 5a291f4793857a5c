// The viewer's slice keys (`,` `.` move the last --slice along its normal, `/` inverts it): the
// step along the normal and the moved slice. No window: tests/test_viewer.cpp checks them.
#pragma once

#include <string>
#include <vector>

#include "store/slice.h"

namespace mds::viewer {

// A key press moves the plane by 1/50 of the store's extent along the slice's normal (Shift:
// 1/500), so that 50 presses cross the data whatever its size and the normal's direction.
inline constexpr double kSliceStepsPerExtent = 50.0;

// The extent of the box [lo, hi] along the unit normal n: sum over the axes of |n_k| (hi_k - lo_k).
double extent_along(const store::Slice& s, const double lo[3], const double hi[3]);

// s moved by `steps` key steps (kSliceStepsPerExtent per extent of [lo, hi] along its normal;
// negative: against the normal), the distance rounded to the decimal places that resolve 1/1000
// of a step (3 for a step of 1.15); inverted when `invert`. Precondition: s.normal has unit length (parse_slice's).
store::Slice step_slice(const store::Slice& s, double steps, bool invert, const double lo[3], const double hi[3]);

// v rounded to the decimal places that resolve 1/1000 of `step` (so that a spec the viewer prints
// reads "0.349", not "0.34909999999999997"); unchanged for a step that is not > 0 or a v that is
// not finite. The slice and the threshold keys round what they move with it.
double round_to_step(double v, double step);

// "--slice A --slice B": the options that give `render` (and `view`) these slices.
std::string slice_options(const std::vector<store::Slice>& slices);

}  // namespace mds::viewer
