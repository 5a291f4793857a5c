// The viewer's threshold keys (Z / X move the --threshold's lower bound down / up, Shift+Z /
// Shift+X its upper bound, I inverts it), as ParaView's Threshold sliders: the moved threshold
// and its option text. No window: tests/test_viewer_parts.cpp checks them.
#pragma once

#include <optional>
#include <string>

#include "store/threshold.h"

namespace mds::viewer {

// A key press moves a bound by 1/50 of the store's property range (so that 50 presses cross it),
// rounded to two significant digits: once a bound is on the decimal grid that resolves 1/1000 of
// a step, steps keep it there, so presses applied one frame at a time give the bounds that the
// same presses in one frame give.
inline constexpr double kThresholdStepsPerRange = 50.0;
double threshold_step(double property_min, double property_max);

// `t` (none: every value kept, both ends open) with its lower bound moved by lower_steps key steps
// and its upper bound by upper_steps (threshold_step each; an open end moves from that end of
// the range), each moved bound rounded to the decimal places
// that resolve 1/1000 of a step, and inverted when `invert`. A bound moved past the other stops
// at it. An unmoved bound stays as it was (open or not).
store::Threshold step_threshold(const std::optional<store::Threshold>& t, double lower_steps, double upper_steps,
                                bool invert, double property_min, double property_max);

// "--threshold LO:HI[,invert]": the option that gives `render` (and `view`) this threshold.
std::string threshold_option(const store::Threshold& t);

}  // namespace mds::viewer
