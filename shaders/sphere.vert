#version 460
// Sphere billboards as quads, pulled from the pre-pass's sprite records (sphere_prepass.comp
// computes the conservative rectangle, its depth and the view-space sphere): one non-indexed,
// non-instanced draw, six vertices per sprite (two triangles), so the vertex stage only loads.
// kQuadList: vertex index / 6 indexes quad_ids[] (the sprites the point path cannot draw);
// otherwise it is the sprite index itself (quad-only path).
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "particle_color.h"

layout(constant_id = 0) const bool kQuadList = false;

layout(location = 0) flat out vec4 v_center_radius;  // view space
layout(location = 1) flat out vec3 v_color;
layout(location = 2) flat out uint v_sprite;  // the sprite's vis_id (the visibility route)

void main() {
  uint v = uint(gl_VertexIndex);
  uint q = v / 6u;
  uint k = v - 6u * q;
  uint sprite = kQuadList ? quad_ids[q] : q;
  GpuSprite s = sprites[sprite];
  if ((s.flags & (kSpriteHidden | kSpriteSmall)) != 0u) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // beyond x = w: clipped
    v_center_radius = vec4(0.0);
    v_color = vec3(0.0);
    v_sprite = 0u;
    return;
  }
  // Triangles (0, 1, 2) and (2, 1, 3) of the corners 0 = lo.x lo.y, 1 = hi.x lo.y, 2 = lo.x hi.y, 3 = hi.
  uint corner = k < 3u ? k : (k == 3u ? 2u : (k == 4u ? 1u : 3u));
  vec2 xy = vec2((corner & 1u) != 0u ? s.rect.z : s.rect.x, (corner & 2u) != 0u ? s.rect.w : s.rect.y);
  gl_Position = vec4(xy, s.zndc, 1.0);
  v_center_radius = s.center_radius;
  v_color = mds_particle_color(s.flags, s.color, s.center_radius.xyz);
  v_sprite = s.vis_id;
}
