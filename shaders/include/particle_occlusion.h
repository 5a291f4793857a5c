// GLSL-only: the particle occlusion test of the sprite pre-pass after convergence -- paper 000's
// Sect. 5 classification (depth test against d_cull, aggregated confidence of Eq. 23, class O
// when C_agg > C_occ), applied to one particle's glyph instead of a meshlet's box. The paper
// stops at meshlets: a meshlet of the potentially visible set is drawn whole, and of its ~16
// particles often only those on the surface of the data can be seen. Here each particle of
// such a meshlet is tested against the final confidence pyramid of the view, with the same
// rule as the meshlet (so it errs exactly as a meshlet test does: at confidence C_occ, not
// certainty), and a particle that is class O is not rasterized.
// The test, per particle: its screen rectangle (the sprite's, which includes the half-pixel
// margin and so every pixel the particle can reach under any jitter) selects the pyramid level
// where it covers at most kParticleExtent^2 texels; the particle's nearest view distance
// (centre distance - radius) is a conservative entry depth for every texel; it is occluded when
// that depth is >= d_cull on every covered texel (the pyramid keeps max depth per texel) and the
// mean confidence over them passes mds_classify_occlusion's O threshold.
// frame.occlusion.z = pyramid levels (0: test off: no culling, culling still running, frames
// that draw every meshlet). Needs bindings.h and culling_math.glsl.
#ifndef MDS_PARTICLE_OCCLUSION_H
#define MDS_PARTICLE_OCCLUSION_H
#ifndef __cplusplus

const int kParticleExtent = 4;  // texels per side at most: <= 16 pyramid reads per particle

uvec2 occ_level_size(uint l) {  // cull_bindings.h cull_level_size on the frame's viewport
  uint w = uint(frame.viewport.x), h = uint(frame.viewport.y);
  for (uint i = 0u; i < l; ++i) { w = (w + 1u) / 2u; h = (h + 1u) / 2u; }
  return uvec2(w, h);
}
uint occ_level_offset(uint l) {
  uint w = uint(frame.viewport.x), h = uint(frame.viewport.y), off = 0u;
  for (uint i = 0u; i < l; ++i) { off += w * h; w = (w + 1u) / 2u; h = (h + 1u) / 2u; }
  return off;
}

// True when the (visible, not hidden) sprite s is class O against the pyramid.
bool mds_particle_occluded(GpuSprite s) {
  uint levels = uint(frame.occlusion.z);
  if (levels == 0u) return false;
  vec2 size = frame.viewport.xy;
  vec2 lo = (s.rect.xy + 1.0) * 0.5 * size;
  vec2 hi = (s.rect.zw + 1.0) * 0.5 * size;
  ivec2 last = ivec2(size) - 1;
  ivec2 p0 = clamp(ivec2(floor(lo)), ivec2(0), last);
  ivec2 p1 = max(clamp(ivec2(ceil(hi)) - 1, ivec2(0), last), p0);
  uint level = 0u;
  int extent = max(p1.x - p0.x, p1.y - p0.y) + 1;
  while (extent > kParticleExtent && level + 1u < levels) {
    level++;
    extent = max((p1.x >> level) - (p0.x >> level), (p1.y >> level) - (p0.y >> level)) + 1;
  }
  uvec2 ls = occ_level_size(level);
  uint off = occ_level_offset(level);
  ivec2 t0 = p0 >> int(level), t1 = p1 >> int(level);
  float z_near = -s.center_radius.z - s.center_radius.w;  // nearest view distance of the sphere
  float csum = 0.0, n = 0.0;
  for (int y = t0.y; y <= t1.y; ++y)
    for (int x = t0.x; x <= t1.x; ++x) {
      vec2 dc = occ_pyramid[off + uint(y) * ls.x + uint(x)];
      if (z_near < dc.x) return false;  // in front of d_cull on this texel: potentially visible
      csum += dc.y;
      n += 1.0;
    }
  return mds_classify_occlusion(MDS_CULL_CLASS_P, true, csum / n, frame.occlusion.x, frame.occlusion.y) ==
         MDS_CULL_CLASS_O;
}

#endif
#endif  // MDS_PARTICLE_OCCLUSION_H
