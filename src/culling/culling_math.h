// CPU reference (double precision) of the scalar formulas of probabilistic occlusion culling:
// Ibrahim, Rautek, Reina, Agus, Hadwiger, "Probabilistic Occlusion Culling using Confidence Maps
// for High-Quality Rendering of Large Particle Data", IEEE TVCG 2021 (paper 000), Sect. 4-5,
// Eq. 1-8, 12-23, and supplement A (paper 004: normal approximation of Eq. 21, lookup table).
//
// Every function is pure and mirrored 1:1 (same name with prefix mds_, float instead of double)
// in shaders/include/culling_math.glsl; both use culling/culling_constants.h. The derivations,
// edge cases and the choices we made where the paper is silent are in docs/culling-math.md.
//
// Conventions used throughout:
//  * Pixel area is normalised to A = 1, so particle areas a, alpha are fractions in [0, 1].
//  * N (a particle count from the density histogram) may be any value >= 0, including < 1 and 0
//    (empty pixel). Where a formula needs M = 1 - 1/N (Eq. 5, 6, 8, 18, 19) we use
//    N_eff = max(N, 1): the samples being counted are real hits of particles with depth <= d, so
//    at least one such particle exists; the coarse density volume may estimate fewer. N_eff = 1
//    is also the limit N -> 1+ of every closed form (M -> 0+), so the functions are continuous.
//  * log M = log1p(-1/N_eff) and M^k = exp(k log M), 1 - M^k = -expm1(k log M): exact for N up to
//    1e9 and far beyond (no 1 - 1/N rounding to 1).
#pragma once

#include <limits>

#include "culling/culling_constants.h"

namespace mds::culling {

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

// N_eff = max(N, 1) (NaN -> 1). See the convention above.
double effective_count(double N);

// log M with M = 1 - 1/N_eff (Eq. 5, 18), in (-inf, 0]: -inf for N_eff = 1, 0 for N = +inf.
double log_m(double N);

// ---- Sect. 4.1: probabilistic sub-pixel coverage ---------------------------------------------

// Eq. 1 with A = 1: A_n = A_{n-1} + (1 - A_{n-1}) a_n.  Pre: A_prev, a in [0, 1].
double coverage_step(double A_prev, double a);

// Eq. 2: A_n = 1 - (1 - a)^n for real n >= 0 (n = E(n(k)) is not an integer).
// Pre: a in [0, 1], n >= 0. a = 1 gives 1 for n > 0 and 0 for n = 0 (0^0 = 1).
double coverage(double a, double n);

// Eq. 3-4: E(n(k)) = E(n(k-1)) + (N - E(n(k-1))) / N, with N -> N_eff.  Pre: E_prev >= 0.
double expected_unique_step(double E_prev, double N);

// Eq. 5: E(n(k)) = (1 - M^k) / (1 - M) = N_eff (1 - M^k), k >= 0 real. N = +inf gives k.
// N <= 1 (including the empty pixel N = 0) gives min(k, 1).
double expected_unique(double k, double N);

// Eq. 6: Delta E(n(k)) = 1 - E(n(k-1)) / N = M^(k-1) for k >= 1 (0 for k < 1).
double expected_unique_increment(double k, double N);

// ---- Sect. 4.2: depth confidence --------------------------------------------------------------

// Eq. 7: C(k) = 1 - (1 - alpha)^E(n(k)) for constant particle size alpha.
double confidence_constant_size(double alpha, double k, double N);

// Eq. 8 as one step of Algorithm 1 ("accumulateConfidence(C, alpha_s, k)"): k samples have been
// accumulated into C so far; the new sample is the (k+1)-th, its unique-particle increment is
// Delta E(n(k+1)) = M^k, and 1 - C_new = (1 - C)(1 - alpha_s)^(M^k). Computed as
// C + (1 - C) * (-expm1(M^k log1p(-alpha_s))), which stays in [C, 1] for every input.
// N = the particle count in front of the depth whose confidence is accumulated, D(d_min, d).
// Pre: C, alpha_s in [0, 1], k >= 0.
double accumulate_confidence(double C, double alpha_s, double k, double N);

// Sect. 4.1 "Particle sizes": effective area alpha of a particle whose projected disk has radius
// r (in pixels): the expected area of disk n pixel when the disk centre is uniform in the pixel
// (the pixel footprint, Eq. 9, counts particles by centre). Equals the CDF of the distance of two
// uniform points in the unit square: pi r^2 - 8/3 r^3 + 1/2 r^4 for r <= 1, a closed form up to
// r = sqrt(2), and 1 beyond (the disk then covers the pixel wherever its centre lies).
// alpha(0) = 0, alpha ~ pi r^2 for tiny r, monotone, alpha <= min(pi r^2, 1).
double effective_particle_area(double radius_px);

// Sect. 4.1 "Particle sizes", exact clipping (CullSettings::coverage): the area of the disk of
// radius r centred at (cx, cy) inside the pixel [0, 1]^2 (pixel units: the pixel is the unit
// square, coordinates relative to its lower corner). The paper clips "probabilistically" with
// an expected area (effective_particle_area) and notes that exact clipping differs negligibly
// for its sub-pixel particles; at about a pixel per particle it does not (docs/culling-math.md,
// "Particle sizes"): a sample hits any particle whose disk overlaps the pixel, and most of
// those have their centre outside it, so the expected area over centres inside the pixel
// overstates what one sample covers (radius 1 px: 0.975 against a mean of 0.39 over
// overlapping disks). Summed over all pixels of the plane the coverage is pi r^2 for every
// centre. Result in [0, min(pi r^2, 1)];
// 0 for r <= 0 or a disk that misses the pixel. Pre: finite arguments.
// Exact up to r = kCoverageLineRadius; beyond, the circle is replaced inside the pixel by its
// tangent at the point nearest the pixel's centre (half_plane_pixel_coverage), off by at most
// 0.12 / r of the pixel: the exact strips subtract terms of size r^2, which in float lose
// r^2 * 1e-7 (0.003 at r = 64, 0.04 at 256, everything at 1024 -- close-ups reach that).
double disk_pixel_coverage(double cx, double cy, double r);
inline constexpr double kCoverageLineRadius = 32.0;  // px: float error <= 7e-4 below, line error <= 0.004 above

// Sect. 4.1 "Particle sizes", each sample by its own particle's size (--coverage auto): exact
// clipping (disk_pixel_coverage) for a projected radius below kMixedExactBelowPx, the expected
// area (effective_particle_area, which is 1 there) from it on. The expected area errs at the
// rims, where a pixel's share of the disk is below 1: the rim band (~1 px) holds most of a
// small particle's pixels and about 2 / r of a large one's. The expected area's 1 lets one
// sample settle a pixel that a large particle covers (exact clipping: its rim pixels settle
// only with the particles around it, which Eq. 1 counts as independent). Discontinuous at
// kMixedExactBelowPx for rim pixels. Pre: finite arguments.
double mixed_pixel_coverage(double cx, double cy, double r);
// px. Measured (docs/culling-math.md, "`--coverage auto`"): a larger switch brings the particle
// occlusion test close to exact's accuracy (ablation 1M close-up at 480x270: 3.99 % of the
// pixels beyond 0.1 at 2 px, 0.68 % at 8 px, exact 0.62 %), but a streamed close-up of particles
// of 2-8 px then reads what exact reads (porous 1M at 320x180 through 1/8 of the store: 6.0x the
// bytes of the nodes with a visible pixel at 8 px, 1.00x at 2 px). 2 px keeps the streaming, and
// the particle test stays off with auto.
inline constexpr double kMixedExactBelowPx = 2.0;

// Area of the unit pixel [0, 1]^2 on the side n . (x - (0.5, 0.5)) <= d of a line, n a unit
// normal: 0 for d <= -(|nx| + |ny|) / 2, 1 for d >= (|nx| + |ny|) / 2, linear in between except
// for the quadratic corner pieces. Pre: |n| = 1.
double half_plane_pixel_coverage(double nx, double ny, double d);

// ---- Sect. 4.5: estimating and improving occlusion ---------------------------------------------

// Eq. 12: OP(d, C) = B(d) C, with B(d) from Eq. 11 (see density_histogram.h).
double occluded_particles(double B, double C);

// Eq. 13 + 15: minimum number n(d_s) of unique particles at depth <= d_s such that
// OP(d_s, C_s(n)) > OP(d, C), with C_s(n) = 1 - (1 - a)^n (Eq. 14):
//   n(d_s) = log_(1-a)(1 - r),  r = C B(d) / B(d_s).
// Edge cases: r = 0 (C = 0 or B(d) = 0: nothing occluded now) -> 0; r >= 1 (cannot be beaten,
// e.g. C = 1 and no particles between d_s and d) -> +inf; a >= 1 and r < 1 -> 0 (one particle
// covering the pixel suffices); a <= 0 and r > 0 -> +inf.
// a: the effective size of the incoming sample's particle (alpha_s; Eq. 14 assumes one size).
double unique_particles_needed(double B_d, double B_ds, double C, double a);

// Eq. 18-20: k(d_s) = ceil(log_M(1 - n_max / N)), N = D(d_min, d_s), M = 1 - 1/N,
// n_max = min(n, eta N). If n would be clamped (n > eta N) the result is the symbolic infinity
// (+inf here, MDS_CULL_K_INFINITE in GLSL). n <= 0 -> 0. N -> N_eff; N_eff = 1 -> k = 1 for
// n in (0, eta] (the limit M -> 0+).
double samples_needed(double n, double N_front);

// True for the symbolic k(d_s) = infinity (either representation).
bool is_k_infinite(double k);

// Eq. 22: p(d_s) = D(d_min, d_s) / D(d_min, d_max), clamped to [0, 1]; 0 for an empty pixel.
double front_probability(double D_front, double D_total);

// Eq. 21 exactly: P(X >= k), X ~ Binomial(n_budget, p), via the regularized incomplete beta
// I_p(k, n_budget - k + 1) (Boost.Math). k is rounded up to an integer. k <= 0 -> 1,
// k > n_budget (incl. infinity) -> 0, p = 0 -> 0, p = 1 -> 1 (sigma = 0 cases).
double binomial_tail_exact(int n_budget, double k, double p);

// Supplement A table: entry i of Phi at z_i = -z_alpha + 2 z_alpha i / (size - 1).
double normal_cdf_table_entry(int i);

// Supplement A: Phi(z) by linear interpolation in the table; 0 below -z_alpha, 1 above z_alpha.
double normal_cdf_lookup(double z);

// Supplement A, Eq. 24-30: P(X >= k) ~ 1 - Phi((k - c - mu) / sigma), mu = N p,
// sigma^2 = N p (1 - p), c = 0.5, Phi from the lookup table. Same edge cases as the exact tail.
// Two deliberate readings of the supplement (docs/culling-math.md, "Normal approximation"):
//  - the lower limit is k - c (standard continuity correction for a sum starting at k
//    inclusive); the supplement's Eq. 26 writes k + c, which approximates P(X >= k + 1) and is
//    off by up to 0.145 where ours is off by 0.02 (N p q >= 10, measured in the tests);
//  - the upper term Phi(b) is dropped, as the supplement's final Eq. 30 does.
double binomial_tail_normal(int n_budget, double k, double p);

// Eq. 21 evaluated with the requested strategy (MDS_CULL_ACCEPT_NORMAL / _EXACT) or the 50:50
// coin (MDS_CULL_ACCEPT_RANDOM -> 0.5).
double binomial_tail(int mode, int n_budget, double k, double p);

// Sect. 4.5.2: the sample acceptance probability P(d_s) of Algorithm 1 line 2 from the
// histogram values it needs: B(d), B(d_s), C of the accumulation buffer, the sample's alpha_s,
// D(d_min, d_s), D(d_min, d_max). Chains Eq. 13/15 -> 20/19 -> 22 -> 21.
double acceptance_probability(int mode, int n_budget, double B_d, double B_ds, double C,
                              double alpha_s, double D_front, double D_total);

// Sect. 4.5.2: accept iff u <= P. Use u in (0, 1] so that P = 0 never and P = 1 always accepts.
bool accept_sample(double u, double P);

// ---- Sect. 4.6: depth confidence pyramid (Eq. 23) ----------------------------------------------
// One coarse pixel from the 2x2 block (x0,y0) (x1,y0) (x0,y1) (x1,y1) of the finer level.
// At an odd right/bottom border the block is partial (has_right / has_below false): depth is the
// max and confidence the mean over the pixels that exist (n = 4, 2 or 1), so every fine pixel
// contributes to exactly one coarse pixel and the coarse pixel stays conservative.
double pyramid_depth(double d00, double d10, double d01, double d11, bool has_right,
                     bool has_below);
double pyramid_confidence(double c00, double c10, double c01, double c11, bool has_right,
                          bool has_below);

// ---- Sect. 5.1: occlusion classes ---------------------------------------------------------------
// New class of a meshlet/node: depth test passed -> P; failed: C_agg > c_occ -> O,
// C_agg > c_medium -> M, else L. Classes only move upward: result = max(previous, new).
int classify_occlusion(int previous_class, bool depth_test_failed, double C_agg, double c_occ,
                       double c_medium);

// ---- Sect. 5: the box depth test, per texel of the cull pyramid --------------------------------
// The paper rasterizes a meshlet's/node's bounding box and depth-tests its fragments against
// d_cull. Per texel t of a pyramid level (s x s pixels), the conservative equivalent used here:
// grow the box by the texel's half diagonal at the box's farthest view distance
// (texel_half_diagonal) and cut it with t's centre ray o + t_v dir, parameterised by view
// distance t_v (dir = the view-space direction with z = -1, in world coordinates). Every point
// of the box inside t's pixel frustum lies within that half diagonal of the centre ray, so
//  - the ray misses the grown box  =>  the box covers no pixel of t (t takes no part in the test);
//  - it hits at t_entry            =>  t_entry <= the view distance of every box point in t,
// and "t_entry >= d_cull(t) for every covered texel" is a conservative failed depth test.

// Half diagonal of an s x s pixel texel at view distance z: s (z / focal_px) / sqrt(2)
// (perspective; focal_px = pixels per unit at distance 1) or s sqrt(ortho_pixel_area) / sqrt(2).
double texel_half_diagonal(double texel_px, double z, bool perspective, double focal_px, double ortho_pixel_area);

// Entry view distance (>= t_min) of the ray o + t dir into the box [lo - grow, hi + grow], or
// MDS_CULL_DEPTH_EMPTY when it misses (or the box lies entirely before t_min).
// o, dir, lo, hi: 3 values each (world coordinates); dir need not be normalised.
double ray_box_entry(const double o[3], const double dir[3], const double lo[3], const double hi[3], double grow,
                     double t_min);

// ---- Sect. 4.4, Eq. 9-10: pixel footprint ------------------------------------------------------
// The histogram depth is the view depth z (distance along the optical axis, linear). For a
// pinhole camera with focal length f (pixels) the pixel footprint in the plane z = const has area
// (z / f)^2; a slab [z, z + dz] of the pixel frustum holds rho (z / f)^2 dz particle centres,
// which is exactly Eq. 9-10 (footprint perpendicular to the ray, integrated along the ray).
// Orthographic: the constant world-space pixel area.
// The counts are those of the particles that can be hit in the pixel: a particle of radius R
// reaches it when its centre lies within R of the footprint, so the footprint is grown by R
// (Minkowski sum of the square of side w and the disk: w^2 + 4 w R + pi R^2). With the exact
// clipping of disk_pixel_coverage these are the particles whose samples the pixel receives
// (Eq. 4's N); R = 0 counts centres only, as the paper's Eq. 9 (with effective_particle_area,
// whose expectation is over centres inside the pixel). R: the scene's smallest particle radius
// (world units), so that N is not overestimated.
double footprint_area(double z, bool perspective, double focal_px, double ortho_pixel_area, double radius);

// Eq. 10 for constant density rho on [z_a, z_b]: rho * integral of footprint_area dz
// = rho [(z_b^3 - z_a^3) / (3 f^2) + 2 R (z_b^2 - z_a^2) / f + pi R^2 (z_b - z_a)] (perspective)
// or rho (A + 4 sqrt(A) R + pi R^2) (z_b - z_a) (orthographic, A the pixel's world area).
double footprint_count(double rho, double z_a, double z_b, bool perspective, double focal_px,
                       double ortho_pixel_area, double radius);

}  // namespace mds::culling
