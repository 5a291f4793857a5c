#version 460
// Test kernel for the Vulkan foundation: y[i] = a * x[i] + y[i], a a specialization constant.
layout(local_size_x = 64) in;
layout(constant_id = 0) const float kA = 1.0;
layout(push_constant) uniform Push { uint n; } pc;
layout(std430, set = 0, binding = 0) readonly buffer X { float x[]; };
layout(std430, set = 0, binding = 1) buffer Y { float y[]; };

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i < pc.n) y[i] = kA * x[i] + y[i];
}
