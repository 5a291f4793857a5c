// The GLSL mirror of the culling formulas, shaders/include/culling_math.glsl, compiled as C++
// float code in namespace glslf (a few GLSL built-ins mapped to std::), so that tests compare its
// float algorithms with the double CPU reference (src/culling/).
#pragma once

#include <algorithm>
#include <cmath>

namespace glslf {
using std::acos;
using std::asin;
using std::ceil;
using std::exp;
using std::floor;
using std::log;
using std::sqrt;
inline float abs(float x) { return std::fabs(x); }
inline float atan(float y, float x) { return std::atan2(y, x); }
inline float min(float a, float b) { return std::min(a, b); }
inline int min(int a, int b) { return std::min(a, b); }
inline float max(float a, float b) { return std::max(a, b); }
inline int max(int a, int b) { return std::max(a, b); }
inline float clamp(float x, float lo, float hi) { return std::clamp(x, lo, hi); }
inline int clamp(int x, int lo, int hi) { return std::clamp(x, lo, hi); }
inline bool isinf(float x) { return std::isinf(x); }
#define MDS_GLSL_AS_CPP 1
#define MDS_INOUT(T) T&
#include "../shaders/include/culling_math.glsl"
#undef MDS_INOUT
}  // namespace glslf
