#version 460
// Sphere billboards as point sprites, pulled from the pre-pass's sprite records: one vertex per
// sprite, a square of side max(rectangle width, height) + 1 pixel (the +1 absorbs point-size
// rounding) centred on the rectangle, so it covers every pixel centre the quad would. The
// pre-pass sends to the quad list (kSpriteQuad) every sprite whose rectangle centre is off
// screen -- a point whose vertex lies outside the view volume is discarded whole -- or whose
// square exceeds the device's point size range.
// Small sprites (kSpriteSmall) are rasterized by the pre-pass (sprite_raster.h), not here.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "particle_color.h"

layout(location = 0) flat out vec4 v_center_radius;  // view space
layout(location = 1) flat out vec3 v_color;
layout(location = 2) flat out uint v_sprite;  // the sprite's vis_id (the visibility route)

void main() {
  GpuSprite s = sprites[gl_VertexIndex];
  if ((s.flags & (kSpriteHidden | kSpriteQuad | kSpriteSmall)) != 0u) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the view volume: discarded
    gl_PointSize = 1.0;
    v_center_radius = vec4(0.0);
    v_color = vec3(0.0);
    v_sprite = 0u;
    return;
  }
  vec2 side_px = (s.rect.zw - s.rect.xy) * 0.5 * frame.viewport.xy;
  gl_Position = vec4(0.5 * (s.rect.xy + s.rect.zw), s.zndc, 1.0);
  gl_PointSize = max(side_px.x, side_px.y) + 1.0;
  v_center_radius = s.center_radius;
  v_color = mds_particle_color(s.flags, s.color, s.center_radius.xyz);
  v_sprite = s.vis_id;
}
