// Nodes holding a visible particle, on the CPU; see visible_nodes.h.
#include "render/visible_nodes.h"

#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>

#include "render/pixel_rays.h"

namespace mds::render {
namespace {

// Screen rectangle [x0, x1) x [y0, y1) and nearest z_ndc of a view-space box; false when it is
// entirely behind the eye or off screen.
bool screen_rect(const PixelRays& f, const glm::dvec3& lo, const glm::dvec3& hi, int& x0, int& x1, int& y0, int& y1,
                 double& zmin) {
  glm::dvec2 a(1e300), b(-1e300);
  zmin = 1e300;
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 v((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
    glm::dvec3 q;
    if (!f.project(v, q)) {  // a corner behind the eye: the whole screen, nearest depth 0
      a = glm::dvec2(0.0);
      b = glm::dvec2(f.w, f.h);
      zmin = 0.0;
      break;
    }
    a = glm::min(a, glm::dvec2(q));
    b = glm::max(b, glm::dvec2(q));
    zmin = std::min(zmin, q.z);
  }
  x0 = std::max(int(std::floor(a.x)), 0);
  y0 = std::max(int(std::floor(a.y)), 0);
  x1 = std::min(int(std::ceil(b.x)) + 1, int(f.w));
  y1 = std::min(int(std::ceil(b.y)) + 1, int(f.h));
  return x0 < x1 && y0 < y1;
}

// Whether the sphere (view-space centre c, radius r) is visible at some pixel of the frame.
bool sphere_visible(const PixelRays& f, std::span<const float> depth, const glm::dvec3& c, double r) {
  // Wholly on the eye's side of the near plane: clipped, as the renderer hides it
  // (sprite_make.h). Its box has corners behind the eye, so screen_rect would give the whole
  // screen: a camera inside the data used to test every such particle against every pixel
  // (a fly-in to the block's centre, 100k particles at 160x120: 107 s).
  if (before_near_plane(c, r, f.near)) return false;
  int x0, x1, y0, y1;
  double zmin;
  if (!screen_rect(f, c - r, c + r, x0, x1, y0, y1, zmin)) return false;
  static constexpr double kPts[5][2] = {{0.5, 0.5}, {0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}, {1.0, 1.0}};
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const double d = depth[size_t(y) * f.w + x];
      if (d >= 1.0 || zmin > d + kDepthSlack) continue;  // background, or the sphere is behind
      const double dist = f.view_distance(d);
      const double slack = kDistanceSlack * dist + kRadiusSlack * r;
      double lo = 1e300, hi = -1e300;
      for (const auto& p : kPts) {
        glm::dvec3 o, dir;
        f.ray(x + p[0], y + p[1], o, dir);
        const double t = ray_sphere_front(o, dir, c, r);
        if (t < 0.0) continue;
        const double z = -(o + t * dir).z;
        lo = std::min(lo, z);
        hi = std::max(hi, z);
      }
      if (lo <= hi && dist >= lo - slack && dist <= hi + slack) return true;
    }
  return false;
}

}  // namespace

Result<VisibleSet> visible_set(const store::StoreReader& reader, const Camera& camera, uint32_t width, uint32_t height,
                               std::span<const float> depth_ndc, bool meshlets) {
  if (width == 0 || height == 0 || depth_ndc.size() != size_t(width) * height)
    return make_error(Errc::invalid_argument, "visible_nodes: depth has {} values, expected {}x{}", depth_ndc.size(),
                      width, height);
  if (!(camera.near > 0.0 && camera.far > camera.near))
    return make_error(Errc::invalid_argument, "visible_nodes: the camera needs fitted near/far planes");
  const PixelRays f(camera, width, height);
  // Per-pixel maximum depth over screen tiles would be faster; nodes are few, rectangles small.
  const auto nodes = reader.nodes();
  const auto types = reader.types();
  const store::FileHeader& h = reader.header();
  const bool ppr = (h.flags & store::kFlagPerParticleRadius) != 0;
  VisibleSet out;
  out.nodes.assign(nodes.size(), 0);
  if (meshlets) out.meshlets.assign(size_t(h.meshlet_count), 0);
  store::NodeData data;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const store::NodeEntry& e = nodes[i];
    const glm::dvec3 lo(e.center_min[0] - e.max_radius, e.center_min[1] - e.max_radius, e.center_min[2] - e.max_radius);
    const glm::dvec3 hi(e.center_max[0] + e.max_radius, e.center_max[1] + e.max_radius, e.center_max[2] + e.max_radius);
    glm::dvec3 vlo, vhi;
    view_box(f.view, lo, hi, vlo, vhi);
    int x0, x1, y0, y1;
    double zmin;
    if (!screen_rect(f, vlo, vhi, x0, x1, y0, y1, zmin)) continue;
    bool in_front = false;  // some pixel of its rectangle shows something at or behind its nearest depth
    for (int y = y0; y < y1 && !in_front; ++y)
      for (int x = x0; x < x1 && !in_front; ++x) {
        const double d = depth_ndc[size_t(y) * width + x];
        in_front = d < 1.0 && d + kDepthSlack >= zmin;
      }
    if (!in_front) continue;
    MDS_TRY(reader.read_node(i, data, scratch));
    if (meshlets && e.first_meshlet + data.meshlet_size.size() > out.meshlets.size())
      return make_error(Errc::format, "visible_nodes: node {} has meshlets {}..{} beyond the header's {}", i,
                        e.first_meshlet, e.first_meshlet + data.meshlet_size.size(), out.meshlets.size());
    const double step[3] = {store::quant_step(e, 0), store::quant_step(e, 1), store::quant_step(e, 2)};
    // Particles are stored in meshlet order: meshlet m holds [start, start + meshlet_size[m]).
    size_t m = 0, meshlet_end = data.meshlet_size.empty() ? data.particle_count() : data.meshlet_size[0];
    for (size_t k = 0; k < data.particle_count(); ++k) {
      while (k >= meshlet_end && m + 1 < data.meshlet_size.size()) meshlet_end += data.meshlet_size[++m];
      if (!meshlets && out.nodes[i]) break;
      if (meshlets && out.meshlets[e.first_meshlet + m]) continue;
      const glm::dvec3 p(e.center_min[0] + data.qpos[3 * k] * step[0], e.center_min[1] + data.qpos[3 * k + 1] * step[1],
                         e.center_min[2] + data.qpos[3 * k + 2] * step[2]);
      double r = types[data.type_index[k]].radius;
      if (ppr) r = h.radius_min + double(data.radius_q[k]) * (h.radius_max - h.radius_min) / store::kQuantMax;
      const glm::dvec3 c = glm::dvec3(f.view * glm::dvec4(p, 1.0));
      if (sphere_visible(f, depth_ndc, c, r)) {
        out.nodes[i] = 1;
        if (meshlets) out.meshlets[e.first_meshlet + m] = 1;
      }
    }
  }
  return out;
}

Result<std::vector<uint8_t>> visible_nodes(const store::StoreReader& reader, const Camera& camera, uint32_t width,
                                           uint32_t height, std::span<const float> depth_ndc) {
  MDS_ASSIGN_OR_RETURN(VisibleSet v, visible_set(reader, camera, width, height, depth_ndc, false));
  return std::move(v.nodes);
}

}  // namespace mds::render
