// Scalable Ambient Obscurance (McGuire, Mara, Luebke, HPG 2012); see ambient_occlusion.h.
#include "shading/ambient_occlusion.h"

#include <algorithm>
#include <cmath>

namespace mds::shading {

namespace {
constexpr double kTwoPi = 6.283185307179586;
}

uint32_t ao_hash(uint32_t x, uint32_t y) {
  // pcg_hash of Jarzynski & Olano, "Hash Functions for GPU Rendering" (JCGT 2020), over a
  // linear combination of the two coordinates.
  uint32_t v = x * 1664525u + y * 1013904223u;
  v = v * 747796405u + 2891336453u;
  const uint32_t w = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
  return (w >> 22u) ^ w;
}

double ao_spin(uint32_t x, uint32_t y, uint32_t sample) {
  // 24 bits: exact in float, so the GLSL mirror gets the same angle.
  const uint32_t turn = ((ao_hash(x, y) >> 8u) + sample * kAoSpinStep) & 0xffffffu;
  return double(turn) * (kTwoPi / 16777216.0);
}

void ao_tap_offset(int i, int taps, double spin, double radius_px, double& dx, double& dy) {
  const double alpha = (double(i) + 0.5) / double(taps);
  const double angle = alpha * (kTwoPi * kAoSpiralTurns) + spin;
  dx = alpha * radius_px * std::cos(angle);
  dy = alpha * radius_px * std::sin(angle);
}

double ao_tap(double ux, double uy, double uz, double nx, double ny, double nz) {
  const double uu = ux * ux + uy * uy + uz * uz;
  const double f = std::max(1.0 - uu, 0.0);
  const double un = ux * nx + uy * ny + uz * nz;
  return f * f * f * std::max(un - kAoBias, 0.0) / (uu + kAoEpsilon);
}

double ao_obscurance(double sum, int taps, double strength) {
  return std::clamp(1.0 - 5.0 * strength * sum / double(taps), 0.0, 1.0);
}

double ao_screen_radius(double r, double proj_y, double height, double depth, bool ortho) {
  const double px = r * proj_y * 0.5 * height;
  return ortho ? px : px / depth;
}

double packing_fraction(const int32_t* counts, uint64_t cells, double cell_volume, double particle_volume) {
  const double v = particle_volume;
  double n = 0.0, weighted = 0.0;
  for (uint64_t c = 0; c < cells; ++c) {
    const double k = std::max(counts[c], 0);
    n += k;
    weighted += k * k * v / cell_volume;
  }
  return n > 0.0 ? weighted / n : 0.0;
}

}  // namespace mds::shading
