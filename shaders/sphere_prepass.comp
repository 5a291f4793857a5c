#version 460
// Sprite pre-pass: for every particle of the meshlets in the draw list, computes once what the
// vertex stage needs (compute runs on all of lavapipe's threads; its vertex stage mostly on one):
// the conservative screen rectangle of the projected sphere,
//  - perspective: per screen axis, the slopes of the two tangent planes through the eye,
//    s = (a z -/+ r sqrt(a^2 + z^2 - r^2)) / (z^2 - r^2) for centre (a, z) (z = view distance)
//    (Mara & McGuire 2013, "2D polyhedral bounds of a clipped, perspective-projected 3D sphere");
//  - orthographic: centre +- r;
// placed at the sphere's nearest view distance (z - r) so that the fragment shader's
// depth_greater promise holds, and grown by half a pixel on every side: sub-pixel spheres get a
// rectangle of at least one pixel, so every jittered sample that hits the sphere is rasterized
// and the exact ray test in the fragment shader keeps only those -- over spp jittered passes a
// sub-pixel sphere contributes exactly its expected covered area (its "effective sub-pixel area").
// One thread per list entry: one atomicAdd reserves the meshlet's run of sprites.
// kPoints: sprites whose rectangle centre lies on screen and whose square fits the point size
// are drawn as points (one vertex each); the others are appended to the quad list.
// kSmallPx > 0: sprites whose rectangle is at most kSmallPx pixels wide and high are rasterized
// here, in compute (sprite_raster.h, first pass: nearest depth), instead of by the rasterizer:
// lavapipe sets up primitives on one thread at ~1 us each, which dominates small glyphs.
#extension GL_GOOGLE_include_directive : require
#define MDS_SPRITES_WRITABLE
#include "bindings.h"
#include "sphere_shading.h"
#include "sprite_raster.h"

layout(local_size_x = 64) in;
layout(constant_id = 0) const bool kPoints = false;
layout(constant_id = 1) const float kMaxPointSize = 1.0;
layout(constant_id = 2) const float kSmallPx = 0.0;

vec3 project(vec3 v) {
  vec4 c = frame.proj * vec4(v, 1.0);
  return c.xyz / c.w;
}

void main() {
  uint e = gl_GlobalInvocationID.x;
  if (e >= draw_header.instance_count) return;
  GpuMeshlet m = meshlets[draw_ids[e]];
  GpuNode node = nodes[m.node];
  uint count = m.particle_count;
  uint base = kPoints ? atomicAdd(sprite_draw.point_vertex_count, count)
                      : atomicAdd(sprite_draw.quad_vertex_count, 6u * count) / 6u;
  if (base + count > sprite_draw.capacity) return;  // a list with repeated meshlets (never expected)
  quad_ids[sprite_draw.capacity + e] = base;        // for sprite_raster_id.comp
  float near = frame.radius_range.z;
  bool ortho = (frame.counts.z & kFrameOrtho) != 0u;
  bool per_particle_radius = (frame.counts.z & kFramePerParticleRadius) != 0u;

  for (uint local = 0u; local < count; ++local) {
    uint pi = mds_meshlet_particle(m, local);
    uvec2 raw = particles[pi];
    uvec3 q = uvec3(raw.x & 0xffffu, raw.x >> 16, raw.y & 0xffffu);
    uint type = (raw.y >> 16) & 0xffu;
    vec3 world = node.origin + vec3(q) * node.step;
    float r = types[type].radius;
    if (per_particle_radius) {
      uint w = radii_q[pi >> 1];
      uint rq = (pi & 1u) != 0u ? (w >> 16) : (w & 0xffffu);
      r = frame.radius_range.x + float(rq) * frame.radius_range.y / 65535.0;
    }
    vec3 c = (frame.view * vec4(world, 1.0)).xyz;
    float zc = -c.z;  // view distance of the centre
    GpuSprite s;
    s.center_radius = vec4(c, r);
    s.flags = type;
    s.pad0 = 0u;
    s.pad1 = 0u;
    s.rect = vec4(0.0);
    s.zndc = 0.0;
    if (zc + r <= near || r <= 0.0) {
      s.flags |= kSpriteHidden;
    } else {
      vec2 ndc_lo, ndc_hi;
      float zq = max(zc - r, near);
      if (ortho) {
        vec3 a = project(vec3(c.xy - r, -zq));
        vec3 b = project(vec3(c.xy + r, -zq));
        ndc_lo = min(a.xy, b.xy);
        ndc_hi = max(a.xy, b.xy);
      } else if (zc - r <= near) {
        // The sphere crosses the near plane: cover the whole viewport.
        ndc_lo = vec2(-1.0);
        ndc_hi = vec2(1.0);
      } else {
        float denom = zc * zc - r * r;
        vec2 t = sqrt(max(c.xy * c.xy + denom, 0.0));
        vec2 s_lo = (c.xy * zc - r * t) / denom;
        vec2 s_hi = (c.xy * zc + r * t) / denom;
        vec3 a = project(vec3(s_lo * zq, -zq));
        vec3 b = project(vec3(s_hi * zq, -zq));
        ndc_lo = min(a.xy, b.xy);
        ndc_hi = max(a.xy, b.xy);
      }
      // Half a pixel of margin on every side (viewport.zw = 1/size; 1 NDC unit = size/2 pixels).
      ndc_lo -= frame.viewport.zw;
      ndc_hi += frame.viewport.zw;
      ndc_lo = max(ndc_lo, vec2(-1.01));
      ndc_hi = min(ndc_hi, vec2(1.01));
      s.rect = vec4(ndc_lo, ndc_hi);
      s.zndc = max(project(vec3(0.0, 0.0, -zq)).z, 0.0);
      if (any(greaterThanEqual(ndc_lo, ndc_hi))) s.flags |= kSpriteHidden;  // entirely off screen
      if (s.zndc > 1.0) s.flags |= kSpriteHidden;  // beyond the far plane
      vec2 side_px = (ndc_hi - ndc_lo) * 0.5 * frame.viewport.xy;
      if (kSmallPx > 0.0 && (s.flags & kSpriteHidden) == 0u && max(side_px.x, side_px.y) <= kSmallPx) {
        s.flags |= kSpriteSmall;
        raster_small_sprite(s, base + local, false);
      } else if (kPoints && (s.flags & kSpriteHidden) == 0u) {
        vec2 mid = 0.5 * (ndc_lo + ndc_hi);
        bool on_screen = all(lessThan(abs(mid), vec2(1.0)));
        if (!on_screen || max(side_px.x, side_px.y) + 1.0 > kMaxPointSize) {
          s.flags |= kSpriteQuad;
          uint qi = atomicAdd(sprite_draw.quad_vertex_count, 6u) / 6u;
          quad_ids[qi] = base + local;
        }
      }
    }
    sprites[base + local] = s;
  }
}
