#version 460
// Occlusion sampling pass (paper 000, Sect. 3.2): the selected occluder meshlets (set 0's draw
// list = the occluder list) as sphere billboards, one jittered sub-pixel depth sample per pixel;
// several passes per culling iteration, each with its own occluder subset and jitter.
// Same conservative billboard as sphere.vert (tangent-plane bounds, half a pixel of margin, so
// sub-pixel spheres are sampled with their exact covered area over the jittered passes); the
// fragment shader writes the sample's view depth and its effective area alpha_s.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "cull_shared.h"

// frame.proj is unjittered; this pass's sub-pixel jitter (NDC) comes as a push constant, so that
// several sampling passes per culling iteration share one frame uniform buffer.
layout(push_constant) uniform PushBlock { CullPush push; };

layout(location = 0) flat out vec4 v_center_radius;  // view space

void emit_outside() { gl_Position = vec4(2.0, 2.0, 2.0, 1.0); }

vec3 project(vec3 v) {
  vec4 c = frame.proj * vec4(v, 1.0);
  return c.xyz / c.w;
}

void main() {
  uint meshlet_id = draw_ids[gl_InstanceIndex];
  GpuMeshlet m = meshlets[meshlet_id];
  uint local = uint(gl_VertexIndex) >> 2;
  uint corner = uint(gl_VertexIndex) & 3u;
  v_center_radius = vec4(0.0);
  if (local >= m.particle_count) { emit_outside(); return; }
  uint pi = mds_meshlet_particle(m, local);
  uvec2 raw = particles[pi];
  uvec3 q = uvec3(raw.x & 0xffffu, raw.x >> 16, raw.y & 0xffffu);
  uint type = (raw.y >> 16) & 0xffu;
  GpuNode node = nodes[m.node];
  vec3 world = node.origin + vec3(q) * node.step;
  float r = types[type].radius;
  if ((frame.counts.z & kFramePerParticleRadius) != 0u) {
    uint w = radii_q[pi >> 1];
    uint rq = (pi & 1u) != 0u ? (w >> 16) : (w & 0xffffu);
    r = frame.radius_range.x + float(rq) * frame.radius_range.y / 65535.0;
  }
  vec3 c = (frame.view * vec4(world, 1.0)).xyz;
  float zc = -c.z;
  float near = frame.radius_range.z;
  bool ortho = (frame.counts.z & kFrameOrtho) != 0u;
  if (zc + r <= near || r <= 0.0) { emit_outside(); return; }
  vec2 ndc_lo, ndc_hi;
  float zq = max(zc - r, near);
  if (ortho) {
    vec3 a = project(vec3(c.xy - r, -zq));
    vec3 b = project(vec3(c.xy + r, -zq));
    ndc_lo = min(a.xy, b.xy);
    ndc_hi = max(a.xy, b.xy);
  } else if (zc - r <= near) {
    ndc_lo = vec2(-1.0);
    ndc_hi = vec2(1.0);
  } else {
    float denom = zc * zc - r * r;
    vec2 t = sqrt(max(c.xy * c.xy + denom, 0.0));
    vec2 s_lo = (c.xy * zc - r * t) / denom;
    vec2 s_hi = (c.xy * zc + r * t) / denom;
    vec3 a = project(vec3(s_lo * zq, -zq));
    vec3 b = project(vec3(s_hi * zq, -zq));
    ndc_lo = min(a.xy, b.xy);
    ndc_hi = max(a.xy, b.xy);
  }
  ndc_lo -= frame.viewport.zw;
  ndc_hi += frame.viewport.zw;
  ndc_lo = max(ndc_lo, vec2(-1.01));
  ndc_hi = min(ndc_hi, vec2(1.01));
  float zndc = max(project(vec3(0.0, 0.0, -zq)).z, 0.0);
  vec2 xy = vec2((corner & 1u) != 0u ? ndc_hi.x : ndc_lo.x, (corner & 2u) != 0u ? ndc_hi.y : ndc_lo.y);
  gl_Position = vec4(xy + vec2(push.jitter_x, push.jitter_y), zndc, 1.0);
  v_center_radius = vec4(c, r);
}
