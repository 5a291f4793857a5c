// GLSL-only: compute rasterization of one small sprite into the visibility buffer (two passes:
// the nearest depth per pixel by atomicMin on the depth's float bits -- non-negative floats
// order like their bits -- then the index of a sprite at that depth). Pixels are those whose
// centre lies in the sprite's rectangle (tight: Mara & McGuire bounds); the ray test is the fragment shader's
// (sphere_shading.h), and depths >= 1 are dropped as the depth test against the cleared 1.0
// would. Needs bindings.h and sphere_shading.h.
#ifndef MDS_SPRITE_RASTER_H
#define MDS_SPRITE_RASTER_H
#ifndef __cplusplus

void raster_small_sprite(GpuSprite s, uint sprite_index, bool write_index) {
  vec2 size = frame.viewport.xy;
  vec2 lo = (s.rect.xy + 1.0) * 0.5 * size;  // framebuffer coordinates
  vec2 hi = (s.rect.zw + 1.0) * 0.5 * size;
  // The rectangle carries half a pixel of margin for the rasterizer; the ray test here is exact,
  // so only pixel centres inside the tight bounds (margin removed, 1e-3 px of slack) are tested.
  ivec2 p0 = max(ivec2(ceil(lo - 1e-3)), ivec2(0));
  ivec2 p1 = min(ivec2(floor(hi - 1.0 + 1e-3)), ivec2(size) - 1);
  uint wh = uint(size.x) * uint(size.y);
  // Early depth test: the billboard depth (nearest view distance) bounds every hit's depth from
  // below; with a little slack for rounding, a pixel whose nearest depth so far is smaller
  // cannot take this sprite.
  uint zmin_bits = floatBitsToUint(s.zndc * (1.0 - 1e-5));
  for (int y = p0.y; y <= p1.y; ++y) {
    for (int x = p0.x; x <= p1.x; ++x) {
      uint pix = uint(y) * uint(size.x) + uint(x);
      uint nearest = visibility[pix];
      if (zmin_bits > nearest) continue;
      vec3 p, n, d;
      float depth;
      if (!ray_sphere(vec2(x, y) + 0.5, s.center_radius, p, n, d, depth)) continue;
      if (!(depth < 1.0)) continue;
      uint bits = floatBitsToUint(max(depth, 0.0));
      if (!write_index) {
        if (bits < nearest) atomicMin(visibility[pix], bits);  // plain read first: few atomics
      } else if (bits <= nearest) {
        visibility[wh + pix] = sprite_index;
      }
    }
  }
}

#endif
#endif  // MDS_SPRITE_RASTER_H
