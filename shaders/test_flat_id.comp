#version 460
// Test kernel of include/dispatch_rows.h: v[i] += i + 1 for every flat index i < n, so that an
// index two invocations share (2 (i + 1)) or that none reaches (0) shows (tests/test_vk_context.cpp).
#extension GL_GOOGLE_include_directive : require
#include "gpu_types.h"
#include "dispatch_rows.h"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { uint n; } pc;
layout(std430, set = 0, binding = 0) buffer V { uint v[]; };

void main() {
  uint i = mds_flat_id();
  if (i < pc.n) atomicAdd(v[i], i + 1u);
}
