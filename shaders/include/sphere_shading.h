// GLSL-only: exact sphere ray casting for one pixel, shared by the raster path (sphere.frag)
// and the compute path for small sprites (sphere_prepass.comp via sprite_raster.h,
// sphere_resolve.frag), so both give the same coverage, depth and colour; the occlusion
// samples (cull_sample.h) use the same ray test.
// The ray of a pixel is the line through the unprojected near (z_ndc = 0) and far (z_ndc = 1)
// points of the sample position, which is right for perspective and orthographic projections
// alike (and includes the sub-pixel jitter, which lives in the projection matrix). Intersection
// uses the numerically stable form (Haines et al., Ray Tracing Gems ch. 7):
// disc = r^2 - |oc - (oc.d) d|^2. Depth: the hit point re-projected; shading: Lambert +
// Blinn-Phong with a headlight. Needs bindings.h (frame).
#ifndef MDS_SPHERE_SHADING_H
#ifndef __cplusplus
#define MDS_SPHERE_SHADING_H

// ndc: the sample position in normalized device coordinates (x, y).
// Returns false when the ray misses the sphere or hits it behind the near plane.
bool ray_sphere_ndc(vec2 ndc, vec4 center_radius, out vec3 p, out vec3 n, out vec3 d, out float depth) {
  vec4 pn = frame.inv_proj * vec4(ndc, 0.0, 1.0);
  vec4 pf = frame.inv_proj * vec4(ndc, 1.0, 1.0);
  vec3 o = pn.xyz / pn.w;
  d = normalize(pf.xyz / pf.w - o);
  vec3 c = center_radius.xyz;
  float r = center_radius.w;
  vec3 oc = o - c;
  float b = dot(oc, d);
  vec3 f = oc - b * d;
  float disc = r * r - dot(f, f);
  p = vec3(0.0);
  n = vec3(0.0);
  depth = 1.0;
  if (disc < 0.0) return false;
  float t = -b - sqrt(disc);
  if (t < 0.0) return false;  // front surface in front of the near plane
  p = o + t * d;
  n = (p - c) / r;
  vec4 clip = frame.proj * vec4(p, 1.0);
  depth = clip.z / clip.w;
  return true;
}

// frag_xy: framebuffer coordinates of the sample (pixel centre = integer + 0.5).
bool ray_sphere(vec2 frag_xy, vec4 center_radius, out vec3 p, out vec3 n, out vec3 d, out float depth) {
  return ray_sphere_ndc(frag_xy * frame.viewport.zw * 2.0 - 1.0, center_radius, p, n, d, depth);
}

vec4 shade_sphere(vec3 n, vec3 d, vec3 color) {
  vec3 l = -d;  // headlight: light from the eye; the half vector equals l
  float ndl = max(dot(n, l), 0.0);
  float spec = pow(ndl, 48.0);
  return vec4(color * (0.15 + 0.85 * ndl) + vec3(0.25 * spec), 1.0);
}

#endif
#endif  // MDS_SPHERE_SHADING_H
