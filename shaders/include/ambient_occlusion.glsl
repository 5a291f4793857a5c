// GLSL 460 mirror (float) of the CPU reference src/shading/ambient_occlusion.h: Scalable Ambient
// Obscurance (McGuire, Mara, Luebke, HPG 2012) with the taps' falloff of its reference code and
// the tap vector in units of the radius (see the header for the formula and its constants).
// Every function mirrors the C++ function of the same name without the mds_ prefix (float for
// double). Written in the scalar subset that also compiles as C++ (tests/glsl_float_shim.h):
// tests/test_ambient_occlusion.cpp compares the float algorithms with the double reference.
// The gathering of the taps from the visibility buffer is visibility_resolve.comp's.
#ifndef MDS_AMBIENT_OCCLUSION_GLSL
#define MDS_AMBIENT_OCCLUSION_GLSL

#ifndef MDS_INOUT
#define MDS_INOUT(T) inout T
#endif

const int MDS_AO_TAPS = 12;              // kAoTaps
const float MDS_AO_TWO_PI = 6.283185307179586f;
const float MDS_AO_SPIRAL_TURNS = 7.0f;  // kAoSpiralTurns
const float MDS_AO_BIAS = 0.01f;         // kAoBias
const float MDS_AO_EPSILON = 0.01f;      // kAoEpsilon
const uint MDS_AO_SPIN_STEP = 10368890u; // kAoSpinStep

uint mds_ao_hash(uint x, uint y) {
  uint v = x * 1664525u + y * 1013904223u;
  v = v * 747796405u + 2891336453u;
  uint w = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
  return (w >> 22u) ^ w;
}

float mds_ao_spin(uint x, uint y, uint sample_index) {
  uint turn = ((mds_ao_hash(x, y) >> 8u) + sample_index * MDS_AO_SPIN_STEP) & 0xffffffu;
  return float(turn) * (MDS_AO_TWO_PI / 16777216.0f);
}

// The offset of tap i in pixels (x in dx, y in dy).
void mds_ao_tap_offset(int i, int taps, float spin, float radius_px, MDS_INOUT(float) dx, MDS_INOUT(float) dy) {
  float alpha = (float(i) + 0.5f) / float(taps);
  float angle = alpha * (MDS_AO_TWO_PI * MDS_AO_SPIRAL_TURNS) + spin;
  dx = alpha * radius_px * cos(angle);
  dy = alpha * radius_px * sin(angle);
}

float mds_ao_tap(float ux, float uy, float uz, float nx, float ny, float nz) {
  float uu = ux * ux + uy * uy + uz * uz;
  float f = max(1.0f - uu, 0.0f);
  float un = ux * nx + uy * ny + uz * nz;
  return f * f * f * max(un - MDS_AO_BIAS, 0.0f) / (uu + MDS_AO_EPSILON);
}

float mds_ao_obscurance(float sum, int taps, float strength) {
  return clamp(1.0f - 5.0f * strength * sum / float(taps), 0.0f, 1.0f);
}

float mds_ao_screen_radius(float r, float proj_y, float height, float depth, bool ortho) {
  float px = r * proj_y * 0.5f * height;
  return ortho ? px : px / depth;
}

#endif  // MDS_AMBIENT_OCCLUSION_GLSL
