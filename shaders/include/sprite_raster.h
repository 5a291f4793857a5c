// GLSL-only: the visibility buffer's depth test (visibility_write), used by the rasterized
// sprites (sphere.frag and sphere.mesh built with MDS_VISIBILITY_ROUTE) and by the compute
// rasterization of one small sprite (raster_small_sprite: sprite_raster.comp, sphere_vis.mesh).
// Per pixel a 64-bit atomicMin of (depth's float bits << 32 | the sprite's vis_id, gpu_types.h):
// non-negative floats order like their bits, so the nearest depth wins and, at equal depths, the
// smaller id, whatever the order of the threads and the chunks. The ids themselves (sprite record
// index, or draw-list slot x max meshlet + local) are handed out by atomics (sphere_prepass.comp,
// cull_draw_list.comp), in an order a GPU does not fix: a pixel where two spheres' depths are
// exactly equal can go to either from run to run (4-5 pixels of a 120x90 close-up on an NVIDIA
// H200; none on lavapipe). Depths >= 1 are dropped, as the depth test against a depth buffer
// cleared to 1.0 would. Needs bindings.h with MDS_VISIBILITY defined,
// and sphere_shading.h.
#ifndef MDS_SPRITE_RASTER_H
#define MDS_SPRITE_RASTER_H
#ifndef __cplusplus

void visibility_write(uint pix, float depth, uint vis_id) {
  if (!(depth < 1.0)) return;
  uint bits = floatBitsToUint(max(depth, 0.0));
  if (bits <= uint(visibility[pix] >> 32))  // a plain read first: few atomics
    atomicMin(visibility[pix], (uint64_t(bits) << 32) | uint64_t(vis_id));
}

// Pixels are those whose centre lies in the sprite's rectangle (tight: Mara & McGuire bounds);
// the ray test is the fragment shader's (sphere_shading.h).

void raster_small_sprite(GpuSprite s, uint vis_id) {
  vec2 size = frame.viewport.xy;
  vec2 lo = (s.rect.xy + 1.0) * 0.5 * size;  // framebuffer coordinates
  vec2 hi = (s.rect.zw + 1.0) * 0.5 * size;
  // The rectangle carries half a pixel of margin for the rasterizer; the ray test here is exact,
  // so only pixel centres inside the tight bounds (margin removed, 1e-3 px of slack) are tested.
  ivec2 p0 = max(ivec2(ceil(lo - 1e-3)), ivec2(0));
  ivec2 p1 = min(ivec2(floor(hi - 1.0 + 1e-3)), ivec2(size) - 1);
  // Early depth test: the billboard depth (nearest view distance) bounds every hit's depth from
  // below; with a little slack for rounding, a pixel whose nearest depth so far is smaller
  // cannot take this sprite.
  uint zmin_bits = floatBitsToUint(s.zndc * (1.0 - 1e-5));
  for (int y = p0.y; y <= p1.y; ++y) {
    for (int x = p0.x; x <= p1.x; ++x) {
      uint pix = uint(y) * uint(size.x) + uint(x);
      if (zmin_bits > uint(visibility[pix] >> 32)) continue;
      vec3 p, n, d;
      float depth;
      if (!ray_sphere(vec2(x, y) + 0.5, s.center_radius, p, n, d, depth)) continue;
      visibility_write(pix, depth, vis_id);
    }
  }
}

#endif
#endif  // MDS_SPRITE_RASTER_H
