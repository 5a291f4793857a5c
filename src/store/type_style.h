// Particle types as a user styles them: their colours -- a default palette by type index and the
// overrides given as TYPE=COLOR (`--type-color` of render, view and bench) --, their radii
// (TYPE=R, `--type-radius`) and the types left out (`--hide-type`). TYPE names a type as
// `mdstream info` lists it: its species name, or the id the input gave it (the LAMMPS type);
// COLOR is "#rrggbb" or "r,g,b" (sRGB, each in [0, 1]). No Vulkan: `info` prints the colours, the
// renderer uploads them (render/scene.h).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "store/format.h"

namespace mds::store {

struct Srgb {
  float r = 0.0f, g = 0.0f, b = 0.0f;  // sRGB-encoded, each in [0, 1]
  bool operator==(const Srgb&) const = default;
};

// The default colour of the type with this index: the Tableau 10 qualitative palette, cycled.
Srgb default_type_color(uint32_t type_index);

// "#rrggbb" (hex digits, either case) or "r,g,b" (three decimal numbers in [0, 1]); spaces
// around the colour and around each number are ignored.
// Errc::invalid_argument naming the text on anything else.
Result<Srgb> parse_srgb(std::string_view text);

// "#rrggbb" of a colour (each channel rounded to 8 bits).
std::string srgb_hex(const Srgb& c);

struct TypeColorSpec {
  std::string key;  // a type's name, or its input id in decimal
  Srgb color;
};

// "KEY=COLOR". Errc::invalid_argument naming the text when the '=' or the key is missing or the
// colour does not parse.
Result<TypeColorSpec> parse_type_color(std::string_view text);

// Which type a key names, by index into `types`: the type whose name equals the key (names are
// case-sensitive: "Cu"), else the type whose input id the key spells in decimal ("2"), else
// Errc::invalid_argument listing the store's types.
Result<uint32_t> find_type(std::span<const TypeEntry> types, std::string_view key);

// One colour per type of `types`: the default palette, then each spec in order; a type named
// twice is an error (Errc::invalid_argument), as is a key that names no type.
Result<std::vector<Srgb>> type_colors(std::span<const TypeEntry> types, std::span<const TypeColorSpec> specs);

struct TypeRadiusSpec {
  std::string key;  // as TypeColorSpec::key
  float radius = 0.0f;
};

// "KEY=R", R a finite number > 0. Errc::invalid_argument naming the text otherwise.
Result<TypeRadiusSpec> parse_type_radius(std::string_view text);

// One radius per type of `types`: the store's, then each spec in order; a type named twice or a
// key that names no type is an error (Errc::invalid_argument).
Result<std::vector<float>> type_radii(std::span<const TypeEntry> types, std::span<const TypeRadiusSpec> specs);

// Which types to draw when the keys (find_type) name the hidden ones: one entry per type, 0 =
// hidden; empty when no key is given. Errc::invalid_argument for a key that names no type, or
// when every type would be hidden.
Result<std::vector<uint8_t>> shown_types(std::span<const TypeEntry> types, std::span<const std::string> hidden_keys);

}  // namespace mds::store
