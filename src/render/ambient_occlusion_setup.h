// --ao, --ao-radius and --ao-strength against a store (shading/ambient_occlusion.h): the radius
// when none is given, and whether `auto` turns ambient occlusion on (the store's packing
// fraction from its density grid). Shared by render, bench and view.
#pragma once

#include <string>

#include "core/result.h"
#include "shading/ambient_occlusion.h"
#include "store/store_reader.h"

namespace mds::render {

struct AoChoice {
  bool on = false;
  double radius = 0.0;    // world units
  double strength = 0.0;  // sigma (0 when off)
  double packing = -1.0;  // the store's packing fraction (-1: not needed: --ao on/off)
};

// "off", "on" or "auto"; Errc::invalid_argument naming --ao otherwise.
Result<shading::AoMode> parse_ao_mode(const std::string& text);
std::string ao_mode_name(shading::AoMode m);

// Precondition: settings.radius >= 0, settings.strength >= 0 (the CLI checks). Errors from
// reading the store's density grid.
Result<AoChoice> resolve_ao(const shading::AoSettings& settings, const store::StoreReader& reader);

}  // namespace mds::render
