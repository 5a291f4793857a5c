// Screen-space ambient occlusion of the sphere glyphs: the CPU (double) reference of the formulas
// that shaders/include/ambient_occlusion.glsl mirrors in float (no Vulkan).
//
// The estimator is Scalable Ambient Obscurance (M. McGuire, M. Mara, D. Luebke, "Scalable
// Ambient Obscurance", HPG 2012), with the smooth falloff of its reference code ("variant B"):
// for the shaded point C with normal n and s taps Q_i of the depth buffer on a spiral within
// the world radius r around C,
//
//   A = max(0, 1 - (5 sigma / s) * sum_i f(u_i)^3 * max(0, u_i.n - beta) / (u_i.u_i + eps)),
//   u_i = (Q_i - C) / r,   f(u) = max(0, 1 - u.u),
//
// which is the paper's Eq. with v = r u and its intensity sigma scaled by r: A depends on the
// geometry in units of r only (the same image for a store in nm or in Angstrom with the radius
// scaled alike, and no r^6 that underflows float for tiny radii). beta (kAoBias) ignores taps
// nearly in the tangent plane (depth-buffer self-occlusion), eps (kAoEpsilon) bounds a tap at C.
// Tap i of s lies at the fraction alpha_i = (i + 1/2) / s of the screen radius, at the angle
// alpha_i * 2 pi * kAoSpiralTurns + phi. The spin phi of a pixel's sample k is a hash of the
// pixel plus k golden-ratio turns (a Weyl sequence, in 24-bit fixed point): each pixel's
// samples spread their rotations evenly over the circle, so the progressive super-sampling
// averages the taps' noise away faster than with a random spin per sample; neighbouring
// pixels start at unrelated rotations (no visible pattern).
#pragma once

#include <cstdint>

namespace mds::shading {

inline constexpr int kAoTaps = 12;             // taps per pixel and sample (SAO uses 9-11 at 1080p)
inline constexpr double kAoSpiralTurns = 7.0;  // turns of the tap spiral (SAO's for ~11 taps)
inline constexpr double kAoBias = 0.01;        // beta, in units of r
inline constexpr double kAoEpsilon = 0.01;     // eps, in units of r^2

// What a render asks for (--ao, --ao-radius, --ao-strength).
enum class AoMode { off, on, automatic };
struct AoSettings {
  AoMode mode = AoMode::off;
  double radius = 0.0;    // world units; 0: kAoRadiusPerParticleRadius x the largest particle radius
  double strength = 1.0;  // sigma
};
inline constexpr double kAoRadiusPerParticleRadius = 3.0;  // default r: 1.5 particle diameters

// Hash of pixel (x, y) (pcg_hash; the same bits in GLSL).
uint32_t ao_hash(uint32_t x, uint32_t y);
// The golden ratio's fractional part in 24-bit fixed point: round(0.6180339887 * 2^24).
inline constexpr uint32_t kAoSpinStep = 10368890u;
// phi in [0, 2 pi) of sample `sample` at pixel (x, y): ((hash >> 8) + sample * kAoSpinStep) mod
// 2^24 turns / 2^24 (integer arithmetic: exact in float too).
double ao_spin(uint32_t x, uint32_t y, uint32_t sample);
// Tap i of `taps`: its offset from the pixel in pixels for a screen radius of `radius_px`.
void ao_tap_offset(int i, int taps, double spin, double radius_px, double& dx, double& dy);
// One tap's term f(u)^3 max(0, u.n - beta) / (u.u + eps) for u = (Q - C) / r (n unit length).
double ao_tap(double ux, double uy, double uz, double nx, double ny, double nz);
// A from the sum of the taps' terms (clamped to [0, 1]).
double ao_obscurance(double sum, int taps, double strength);
// The screen radius in pixels of the world radius r at view depth `depth` (> 0, distance along
// the view axis) for a projection whose y scale is `proj_y` (|proj[1][1]|) on an image
// `height` pixels high; orthographic projections do not divide by depth.
double ao_screen_radius(double r, double proj_y, double height, double depth, bool ortho);

// The packing fraction around the average particle: sum over the cells of n_c * phi_c / N with
// phi_c = n_c * v / V_cell (v the mean particle volume), from a density grid of `cells` counts,
// each cell `cell_volume`. 0 for an empty grid.
double packing_fraction(const int32_t* counts, uint64_t cells, double cell_volume, double particle_volume);
// --ao auto turns ambient occlusion on at this packing fraction or more: particles that touch
// or nearly do. A dense liquid or solid is 0.4-0.74; the synthetic scenes from 50k to 1M
// particles: gas 0.04, shell 0.34-0.57, ablation 0.62-0.65, porous 0.67-0.70
// (docs/rendering.md, "Ambient occlusion").
inline constexpr double kAoAutoPacking = 0.1;

}  // namespace mds::shading
