// Which nodes of a store hold a particle that is visible in a rendered frame -- the reference set
// of issue 4's target "bytes read to converge a dense view <= 1.25x the bytes of the nodes that
// hold a visible particle". Computed on the CPU in double from the store and the frame's depth
// buffer, independently of the renderer's culling and cache:
//   a particle is visible at pixel p when its sphere is hit by a ray through some point of p
//   (the pixel centre and its four corners: the frame's sub-pixel jitter lies within the pixel)
//   and the frame's depth at p (as a view distance) lies within the range of its front-surface
//   distances over those hits, +- a slack for the renderer's float arithmetic (kDistanceSlack of
//   the distance plus kRadiusSlack of the radius); a node is visible when one of its particles
//   is visible at a pixel.
// A particle hidden behind the visible surface by more than its own depth variation across one
// pixel is not visible, so the set is the visible one up to particles touching the visible
// surface within a pixel's depth range (a slight superset; it never misses a visible particle).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/result.h"
#include "render/camera.h"
#include "store/store_reader.h"

namespace mds::render {

// Slack on z_ndc comparisons of the early-outs: a few ulps of a float depth near 1 (D32 depth).
inline constexpr double kDepthSlack = 4e-6;
// Slack of the visibility test: the shader's float ray-sphere hit is good to ~1e-6 of the view
// distance; particles behind the visible one lie about a diameter deeper, far beyond 1 % of r.
inline constexpr double kDistanceSlack = 1e-5;
inline constexpr double kRadiusSlack = 0.01;

// depth_ndc: width * height z_ndc values, row-major from the top-left, 1 = background (as
// Renderer::read_last_depth). camera: the frame's camera with near/far fitted to the store's
// bounds (fit_clip_planes), in store coordinates. Returns one flag per node (1 = visible).
// Nodes whose bounds lie behind every depth in their screen rectangle are not decoded.
Result<std::vector<uint8_t>> visible_nodes(const store::StoreReader& reader, const Camera& camera, uint32_t width,
                                           uint32_t height, std::span<const float> depth_ndc);

// The same test per meshlet as well: which meshlets hold a visible particle (the smallest
// potentially visible set the occlusion culling could reach for this frame, issue 3's reference
// for the culled fraction). meshlets: one flag per global meshlet index (NodeEntry::first_meshlet
// + the meshlet's index in its node), filled only when `meshlets` is true (every particle of a
// node in front is tested then, not only up to its first visible one).
struct VisibleSet {
  std::vector<uint8_t> nodes;
  std::vector<uint8_t> meshlets;
};
Result<VisibleSet> visible_set(const store::StoreReader& reader, const Camera& camera, uint32_t width, uint32_t height,
                               std::span<const float> depth_ndc, bool meshlets);

}  // namespace mds::render
