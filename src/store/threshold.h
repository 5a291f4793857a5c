// Thresholds: which particles a user keeps by the store's per-particle property (`convert
// --property`), as ParaView's Threshold filter (lower and upper bound, "Invert") and OVITO's
// Expression selection followed by Delete selected: `--threshold LO:HI[,invert]` of render,
// view, bench and export keeps the particles whose property value v has LO <= v <= HI (an empty
// LO or HI: no bound on that side); `invert` keeps exactly the others. The value is the one the
// store decodes to (property_value: export's column, picking's `property`), so what is kept
// does not depend on where it is tested. No Vulkan: the renderer's scene loader
// (render/scene.h) applies it, export and picking too.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace mds::store {

struct Threshold {
  double lo = -std::numeric_limits<double>::infinity();  // kept: lo <= v
  double hi = std::numeric_limits<double>::infinity();   //   and v <= hi
  bool invert = false;                                   // keep the values outside [lo, hi]

  bool operator==(const Threshold&) const = default;
};

// "LO:HI[,invert]": LO and HI finite numbers or empty (open), LO <= HI; spaces around each field
// are ignored. Errc::invalid_argument naming the text otherwise (also for "" and ":", which
// would keep everything without `invert` and nothing with it).
Result<Threshold> parse_threshold(std::string_view text);
// The spec that parse_threshold reads back as `t` (shortest round-trip numbers).
std::string threshold_spec(const Threshold& t);
// Whether a particle with property value v is kept.
bool threshold_keeps(const Threshold& t, double v);

// Per quantized property value q in [0, kQuantMax]: 1 where t keeps property_value(min, max, q),
// else 0 (kQuantMax + 1 = 65536 bytes; filters test a particle by one lookup).
std::vector<uint8_t> threshold_table(const Threshold& t, float property_min, float property_max);

}  // namespace mds::store
