#version 460
// Per-pixel particle density histograms by volume ray casting (paper 000, Sect. 4.4, Eq. 9-10),
// GPU version of src/culling/density_histogram.cpp cast_density_histogram: the pixel-centre ray,
// parameterised by view depth z, is cut at every cell face of the density volume and every bin
// edge; each piece adds rho * (footprint area integrated over [z_a, z_b]) (mds_footprint_count)
// to its bin, with rho = count / cell volume of the cell holding the piece's midpoint (nearest
// cell, as the CPU reference). d_min / d_max: entry / exit depth of the volume box (>= near).
// Output: the CUMULATIVE histogram hist_counts[pix * bins + i] = D(d_min, d_i+1), so that the
// update pass answers D(d_min, d) with two loads (cull_hist_front); the per-bin counts are the
// differences (CullLoop::read_histograms converts).
// Traversal: 3D-DDA (Amanatides & Woo) over the cell faces, merged with the bin edges; per step
// only the crossed axis advances its next face, and bins are flushed in order (no per-pixel array).
// Histogram blocks (cull.pyramid.y = stride s, CullSettings::histogram_stride): one invocation
// per s x s block of pixels, cast along the ray through the centre of the block's pixels; the
// update pass reads the block's histogram for each of its pixels (s = 1: per pixel, the paper).
// Runs after the classification of every culling iteration that moved meshlets to O (the volume
// was updated, Sect. 4.4) and unconditionally at the start of a view (push.mode = 1).
#extension GL_GOOGLE_include_directive : require
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;  // histogram block
  uint W = cull_width(), H = cull_height();
  uint s = cull.pyramid.y, bx = cull.pyramid.z, by = cull.pyramid.w;
  if (p.x >= bx || p.y >= by) return;
  if (push.mode == 0u && counters.volume_dirty == 0u) return;
  uint pix = p.y * bx + p.x;
  int bins = int(cull.grid_dims.w);
  uint base = pix * uint(bins);
  hist_range[pix] = vec2(0.0);

  bool ortho = (cull.params.w & kCullOrtho) != 0u;
  // Centre of the block's pixels (a partial block at the right / bottom edge: of those that exist).
  vec2 px_lo = vec2(p * s), px_hi = vec2(min((p + 1u) * s, uvec2(W, H)));
  vec2 ndc = 0.5 * (px_lo + px_hi) * cull.viewport.zw * 2.0 - 1.0;
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
  bool hit = true;
  for (int a = 0; a < 3; ++a) {
    if (rs[a] == 0.0) {
      if (ro[a] < 0.0 || ro[a] >= hi[a]) hit = false;
      continue;
    }
    float ta = (0.0 - ro[a]) / rs[a], tb = (hi[a] - ro[a]) / rs[a];
    z0 = max(z0, min(ta, tb));
    z1 = min(z1, max(ta, tb));
  }
  if (!hit || !(z1 > z0)) {
    for (int b = 0; b < bins; ++b) hist_counts[base + uint(b)] = 0.0;
    return;
  }
  hist_range[pix] = vec2(z0, z1);

  float focal = cull.camera.x, pixel_area = cull.camera.y;
  float radius = cull.thresholds.z;  // the footprint grown by the smallest particle radius
  float inv_cell_volume = cull.grid_cell.w;
  // DDA state: next face index and its depth per axis (3e38: the ray never crosses that axis).
  vec3 inv_rs, step_dir, face, znext;
  for (int a = 0; a < 3; ++a) {
    if (rs[a] == 0.0) {
      inv_rs[a] = 0.0;
      step_dir[a] = 0.0;
      face[a] = 0.0;
      znext[a] = 3.0e38;
      continue;
    }
    inv_rs[a] = 1.0 / rs[a];
    step_dir[a] = rs[a] > 0.0 ? 1.0 : -1.0;
    float x = ro[a] + rs[a] * z0;
    face[a] = rs[a] > 0.0 ? floor(x / cell[a]) + 1.0 : ceil(x / cell[a]) - 1.0;
    znext[a] = (face[a] * cell[a] - ro[a]) * inv_rs[a];
    if (znext[a] <= z0) {
      face[a] += step_dir[a];
      znext[a] = (face[a] * cell[a] - ro[a]) * inv_rs[a];
    }
  }
  float span = z1 - z0;
  int b_cur = 0;                 // bin being accumulated
  float bin_acc = 0.0, cum = 0.0;
  int e_idx = 1;                 // next bin edge d_e_idx
  float e_next = z0 + span / float(bins);
  float z = z0;
  int max_steps = dims.x + dims.y + dims.z + bins + 8;
  for (int step = 0; step < max_steps && z < z1; ++step) {
    float zn = min(min(min(znext.x, znext.y), min(znext.z, e_next)), z1);
    zn = max(zn, z);
    if (zn > z) {
      float zm = 0.5 * (z + zn);
      ivec3 c = clamp(ivec3(floor((ro + rs * zm) / cell)), ivec3(0), dims - 1);
      int b = clamp(int(floor((zm - z0) / span * float(bins))), 0, bins - 1);
      for (; b_cur < b; ++b_cur) {  // bins are visited in order: flush the finished ones
        cum += bin_acc;
        bin_acc = 0.0;
        hist_counts[base + uint(b_cur)] = cum;
      }
      int count = max(volume_counts[c.x + dims.x * (c.y + dims.y * c.z)], 0);
      if (count > 0)
        bin_acc += mds_footprint_count(float(count) * inv_cell_volume, z, zn, !ortho, focal, pixel_area,
                                       radius);
    }
    // Advance every event at zn (cell faces of the crossed axes, the bin edge).
    for (int a = 0; a < 3; ++a) {
      if (znext[a] <= zn) {
        face[a] += step_dir[a];
        znext[a] = (face[a] * cell[a] - ro[a]) * inv_rs[a];
      }
    }
    while (e_next <= zn && e_idx < bins) {
      ++e_idx;
      e_next = e_idx < bins ? z0 + span * float(e_idx) / float(bins) : 3.0e38;
    }
    z = zn;
  }
  for (; b_cur < bins; ++b_cur) {
    cum += bin_acc;
    bin_acc = 0.0;
    hist_counts[base + uint(b_cur)] = cum;
  }
}
