#version 460
// Per-pixel particle density histograms by volume ray casting (paper 000, Sect. 4.4, Eq. 9-10),
// GPU version of src/culling/density_histogram.cpp cast_density_histogram: the pixel-centre ray,
// parameterised by view depth z, is cut at every cell face of the density volume and every bin
// edge; each piece adds rho * (footprint area integrated over [z_a, z_b]) (mds_footprint_count)
// to its bin, with rho = count / cell volume of the cell holding the piece's midpoint (nearest
// cell, as the CPU reference). d_min / d_max: entry / exit depth of the volume box (>= near).
// Runs after every classification that moved meshlets to O (the volume was updated, Sect. 4.4)
// and unconditionally at the start of a view (push.mode = 1).
#extension GL_GOOGLE_include_directive : require
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  uint W = cull_width(), H = cull_height();
  if (p.x >= W || p.y >= H) return;
  if (push.mode == 0u && counters.volume_dirty == 0u) return;
  uint pix = p.y * W + p.x;
  int bins = int(cull.grid_dims.w);
  uint base = pix * uint(bins);
  float acc[MDS_CULL_HISTOGRAM_BINS];
  for (int b = 0; b < MDS_CULL_HISTOGRAM_BINS; ++b) acc[b] = 0.0;
  for (int b = 0; b < bins; ++b) hist_counts[base + uint(b)] = 0.0;
  hist_range[pix] = vec2(0.0);

  bool ortho = (cull.params.w & kCullOrtho) != 0u;
  vec2 ndc = (vec2(p) + 0.5) * cull.viewport.zw * 2.0 - 1.0;
  vec3 o_view, s_view;
  if (ortho) {
    o_view = vec3(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], 0.0);
    s_view = vec3(0.0, 0.0, -1.0);
  } else {
    o_view = vec3(0.0);
    s_view = vec3(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], -1.0);
  }
  vec3 ro = (cull.inv_view * vec4(o_view, 1.0)).xyz - cull.grid_origin.xyz;  // relative to the box
  vec3 rs = mat3(cull.inv_view) * s_view;
  vec3 cell = cull.grid_cell.xyz;
  ivec3 dims = ivec3(cull.grid_dims.xyz);
  vec3 hi = cell * vec3(dims);

  // Slab test, z in [near, inf).
  float z0 = cull.camera.z, z1 = 3.0e38;
  for (int a = 0; a < 3; ++a) {
    if (rs[a] == 0.0) {
      if (ro[a] < 0.0 || ro[a] >= hi[a]) return;
      continue;
    }
    float ta = (0.0 - ro[a]) / rs[a], tb = (hi[a] - ro[a]) / rs[a];
    z0 = max(z0, min(ta, tb));
    z1 = min(z1, max(ta, tb));
  }
  if (!(z1 > z0)) return;
  hist_range[pix] = vec2(z0, z1);

  float focal = cull.camera.x, pixel_area = cull.camera.y;
  float inv_cell_volume = cull.grid_cell.w;
  float bin_len = (z1 - z0) / float(bins);
  float z = z0;
  int max_steps = dims.x + dims.y + dims.z + bins + 8;
  for (int step = 0; step < max_steps && z < z1; ++step) {
    // Current cell and bin from a point just past z (the CPU reference uses piece midpoints;
    // the piece is found first, then classified by its midpoint below).
    float zn = z1;
    // next bin edge
    int b_here = clamp(int(floor((z - z0) / bin_len)), 0, bins - 1);
    float e = z0 + (z1 - z0) * float(b_here + 1) / float(bins);
    if (e <= z) e = z0 + (z1 - z0) * float(b_here + 2) / float(bins);
    zn = min(zn, e);
    // next cell face per axis
    for (int a = 0; a < 3; ++a) {
      if (rs[a] == 0.0) continue;
      float x = ro[a] + rs[a] * z;
      float fi = rs[a] > 0.0 ? floor(x / cell[a]) + 1.0 : ceil(x / cell[a]) - 1.0;
      float zf = (fi * cell[a] - ro[a]) / rs[a];
      if (zf <= z) zf = ((fi + sign(rs[a])) * cell[a] - ro[a]) / rs[a];
      zn = min(zn, zf);
    }
    zn = min(max(zn, z), z1);
    if (zn > z) {
      float zm = 0.5 * (z + zn);
      ivec3 c = clamp(ivec3(floor((ro + rs * zm) / cell)), ivec3(0), dims - 1);
      int b = clamp(int(floor((zm - z0) / (z1 - z0) * float(bins))), 0, bins - 1);
      int count = max(volume_counts[c.x + dims.x * (c.y + dims.y * c.z)], 0);
      float rho = float(count) * inv_cell_volume;
      if (rho > 0.0)
        acc[b] += mds_footprint_count(rho, z, zn, !ortho, focal, pixel_area);
    }
    z = zn;
  }
  for (int b = 0; b < bins; ++b) hist_counts[base + uint(b)] = acc[b];
}
