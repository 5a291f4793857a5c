#version 460
// Compile check of shaders/include/culling_math.glsl (glslangValidator -V --target-env vulkan1.3):
// calls every function with run-time inputs so that nothing is folded away. Also the skeleton
// of the CPU/GPU parity test: in[] holds arguments, out[] receives results in a fixed order.
#extension GL_GOOGLE_include_directive : require
#include "../include/culling_math.glsl"

layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Inputs { float in_values[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Outputs { float out_values[]; };

void main() {
  float a = in_values[0], n = in_values[1], k = in_values[2], N = in_values[3];
  float C = in_values[4], r = in_values[5], z = in_values[6], p = in_values[7];
  int o = 0;
  out_values[o++] = mds_log1p(-a);
  out_values[o++] = mds_expm1(-a);
  out_values[o++] = mds_log_m(N);
  out_values[o++] = mds_coverage_step(C, a);
  out_values[o++] = mds_coverage(a, n);
  out_values[o++] = mds_expected_unique_step(n, N);
  out_values[o++] = mds_expected_unique(k, N);
  out_values[o++] = mds_expected_unique_increment(k, N);
  out_values[o++] = mds_confidence_constant_size(a, k, N);
  out_values[o++] = mds_accumulate_confidence(C, a, k, N);
  out_values[o++] = mds_effective_particle_area(r);
  out_values[o++] = mds_disk_pixel_coverage(z, p, r);
  out_values[o++] = mds_mixed_pixel_coverage(z, p, r);
  out_values[o++] = mds_occluded_particles(N, C);
  float nn = mds_unique_particles_needed(n, N, C, a);
  out_values[o++] = nn;
  float kk = mds_samples_needed(nn, N);
  out_values[o++] = kk;
  out_values[o++] = mds_is_k_infinite(kk) ? 1.0 : 0.0;
  out_values[o++] = mds_front_probability(n, N);
  out_values[o++] = mds_normal_cdf_table_entry(int(k));
  out_values[o++] = mds_normal_cdf_lookup(z);
  out_values[o++] = mds_binomial_tail_normal(int(N), k, p);
  out_values[o++] = mds_binomial_tail(MDS_CULL_ACCEPT_RANDOM, int(N), k, p);
  out_values[o++] = mds_acceptance_probability(MDS_CULL_ACCEPT_NORMAL, MDS_CULL_N_BUDGET_DEFAULT,
                                               n, N, C, a, z, N);
  out_values[o++] = mds_accept_sample(p, C) ? 1.0 : 0.0;
  out_values[o++] = mds_pyramid_depth(a, n, k, N, a > 0.5, n > 0.5);
  out_values[o++] = mds_pyramid_confidence(a, n, k, N, a > 0.5, n > 0.5);
  out_values[o++] = float(mds_classify_occlusion(int(k), C > 0.0, C, MDS_CULL_C_OCC_DEFAULT,
                                                 MDS_CULL_C_MEDIUM_DEFAULT));
  out_values[o++] = mds_footprint_area(z, a > 0.5, N, p, r);
  out_values[o++] = mds_footprint_count(C, z, z + 1.0, a > 0.5, N, p, r);

  float counts[MDS_CULL_HISTOGRAM_BINS];
  for (int i = 0; i < MDS_CULL_HISTOGRAM_BINS; ++i) counts[i] = in_values[8 + i];
  int bins = int(in_values[72]);
  float d_min = in_values[73], d_max = in_values[74];
  out_values[o++] = mds_hist_coord(z, d_min, d_max, bins);
  out_values[o++] = mds_hist_total(counts, bins);
  out_values[o++] = mds_hist_front(counts, bins, d_min, d_max, z);
  out_values[o++] = mds_hist_between(counts, bins, d_min, d_max, z, z + 1.0);
  out_values[o++] = mds_hist_behind(counts, bins, d_min, d_max, z);
  out_values[o++] = mds_hist_occluded(counts, bins, d_min, d_max, z, C);

  float d = MDS_CULL_DEPTH_EMPTY, Ca = 0.0, ka = 0.0;
  float d_cull = MDS_CULL_DEPTH_EMPTY, C_cull = 0.0, k_cull = 0.0;
  for (int s = 0; s < 8; ++s) {
    float d_s = in_values[75 + 3 * s], alpha_s = in_values[76 + 3 * s], u = in_values[77 + 3 * s];
    mds_update_depth_and_confidence(d, Ca, ka, d_cull, C_cull, k_cull, counts, bins, d_min, d_max,
                                    d_s, alpha_s, u, MDS_CULL_ACCEPT_NORMAL,
                                    MDS_CULL_N_BUDGET_DEFAULT, u > 0.5);
  }
  out_values[o++] = d;
  out_values[o++] = Ca;
  out_values[o++] = ka;
  out_values[o++] = d_cull;
  out_values[o++] = C_cull;
  out_values[o++] = k_cull;
}
