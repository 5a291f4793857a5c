// GLSL-only: one occlusion sample of a sphere (paper 000, Sect. 3.2 and 4.1), shared by the two
// routes of the occlusion sampling pass: the rasterized billboards (cull_sample.vert/.frag) and
// the compute rasterization (cull_sample.comp). Needs bindings.h (frame uniforms), culling_math.glsl
// (mds_effective_particle_area, mds_disk_pixel_coverage) and sphere_shading.h (ray_sphere_ndc, the renderer's ray test)
// included first.
#ifndef MDS_CULL_SAMPLE_H
#define MDS_CULL_SAMPLE_H
#ifndef __cplusplus

// The sphere's projected disk in unjittered framebuffer coordinates, once per glyph: (centre x,
// centre y, radius r_px = r f / z_centre pixels, f the focal length in pixels; orthographic:
// r / pixel size). The centre is computed only where a sample may clip against its pixel
// (kFrameExactCoverage); the expected area needs only the radius.
vec3 mds_cull_sample_disk(vec4 center_radius) {
  vec3 c = center_radius.xyz;
  bool ortho = (frame.counts.z & kFrameOrtho) != 0u;
  // proj[1][1] = -g (perspective, g = 1/tan(fov/2)) or -1/half height (ortho).
  float px_per_unit = 0.5 * frame.viewport.y * abs(frame.proj[1][1]);
  float r_px = ortho ? center_radius.w * px_per_unit : center_radius.w * px_per_unit / max(-c.z, 1e-30);
  vec2 centre = vec2(0.0);
  if ((frame.counts.z & kFrameExactCoverage) != 0u) {
    vec4 cc = frame.proj * vec4(c, 1.0);
    centre = (cc.xy / cc.w * 0.5 + 0.5) * frame.viewport.xy;
  }
  return vec3(centre, r_px);
}

// The exact ray-sphere hit on the ray through `ndc` (the jittered sub-pixel sample position,
// unjittered projection): false when the ray misses the sphere or hits it in front of the near
// plane. Otherwise ndc_depth = the hit's depth-buffer value and sample = (view depth of the hit,
// alpha_s), alpha_s the particle's area inside the sample's pixel (Sect. 4.1 "Particle sizes")
// for its projected disk `disk` (mds_cull_sample_disk): the paper's expected area
// mds_effective_particle_area(r_px), or with kFrameExactCoverage exact clipping,
// mds_disk_pixel_coverage of the disk against `pixel`, the lower corner (integers, unjittered
// framebuffer coordinates) of the pixel the sample belongs to (the jitter keeps a pixel's samples
// inside it); with kFrameMixedCoverage too, exact below MDS_MIXED_EXACT_BELOW_PX
// (mds_mixed_pixel_coverage, --coverage auto).
bool mds_cull_sample(vec2 ndc, vec2 pixel, vec4 center_radius, vec3 disk, out float ndc_depth, out vec2 sample_value) {
  vec3 p, n, d;
  sample_value = vec2(0.0);
  if (!ray_sphere_ndc(ndc, center_radius, p, n, d, ndc_depth)) return false;
  float alpha;
  if ((frame.counts.z & kFrameExactCoverage) != 0u) {
    vec2 rel = disk.xy - pixel;  // the disk's centre in the pixel's frame
    alpha = (frame.counts.z & kFrameMixedCoverage) != 0u ? mds_mixed_pixel_coverage(rel.x, rel.y, disk.z)
                                                          : mds_disk_pixel_coverage(rel.x, rel.y, disk.z);
  } else {
    alpha = mds_effective_particle_area(disk.z);
  }
  sample_value = vec2(-p.z, alpha);
  return true;
}

#endif
#endif  // MDS_CULL_SAMPLE_H
