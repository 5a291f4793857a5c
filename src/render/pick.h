// Picking: which particle a point of the image shows -- the first sphere that the ray through
// that point meets, as OVITO's particle inspection and ParaView's point picking answer it. On
// the CPU in double, from the store (not from the device), so it works in memory and streaming,
// on every pixel route and sprite path, and names particles the cache has not read yet:
//   - the ray is the renderer's (pixel_rays.h: from the near plane through the point);
//   - a particle is its decoded centre (the arithmetic of `export` and the renderer's scene) at
//     its type's radius (SceneOptions::type_radius when given) or its per-particle radius;
//   - hidden types (SceneOptions::shown_types) and particles the slices or the threshold leave
//     out are skipped, as the renderer leaves them out; spheres wholly in front of the near
//     plane too;
//   - nodes are visited in the order the ray enters their boxes, and the walk ends at the first
//     box the ray enters behind the nearest hit so far: a dense view decodes one or two nodes.
// The answer is what an unculled render shows at that point (a render whose culling dropped a
// visible particle shows what lies behind it). No Vulkan.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <glm/glm.hpp>

#include "core/result.h"
#include "render/camera.h"
#include "render/scene.h"
#include "store/store_reader.h"

namespace mds::render {

struct PickedParticle {
  uint32_t node = 0;           // store node
  uint32_t index_in_node = 0;  // in the node's payload (meshlet order)
  uint64_t index = 0;          // in the store: the particles of the nodes before plus index_in_node,
                               //   i.e. the particle's row in `mdstream export` without --slice
  uint64_t meshlet = 0;        // global meshlet (NodeEntry::first_meshlet + its meshlet in the node)
  uint32_t type = 0;           // type index (store::TypeEntry)
  glm::dvec3 position{0.0};    // decoded centre, world coordinates
  double radius = 0.0;         // as drawn
  std::optional<double> property;  // the store's per-particle property (kFlagProperty), dequantized
  std::optional<uint32_t> color;   // the store's per-particle colour (kFlagColor), RGBA8, R in bits 0-7
  glm::dvec3 hit{0.0};         // where the ray meets the sphere, world coordinates
  double distance = 0.0;       // view distance of the hit (-z in view space)
};

// "#rrggbb" of a PickedParticle::color (alpha left out).
std::string color_hex(uint32_t rgba);

// pixel: a point of the width x height image in pixel coordinates (x right, y down; pixel (i, j)
// spans [i, i + 1) x [j, j + 1), its centre at +0.5). camera: near/far set (fit_clip_planes, as
// the renderer fits them to its bounds). options: those the scene was loaded with (load_scene).
// Returns nothing where the ray meets no particle; Errc::invalid_argument for a point outside
// the image or a camera without clip planes; a node that cannot be read is its error.
Result<std::optional<PickedParticle>> pick_particle(const store::StoreReader& reader, const Camera& camera,
                                                    uint32_t width, uint32_t height, glm::dvec2 pixel,
                                                    const SceneOptions& options = {});

// "X,Y": a pixel of the image (two integers, spaces allowed around them); the ray goes through
// its centre. Errc::invalid_argument naming the text otherwise.
Result<glm::uvec2> parse_pick_pixel(const std::string& text);

// One line for people: "node N particle K (store index I) type NAME at (x, y, z) r R, PROP V,
// distance D".
std::string describe_pick(const store::StoreReader& reader, const PickedParticle& p);

}  // namespace mds::render
