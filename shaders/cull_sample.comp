#version 460
// Occlusion sampling pass, compute route (paper 000, Sect. 3.2): the same samples as the
// rasterized route (cull_sample.vert/.frag), rasterized in compute. Lavapipe sets up every
// primitive on one thread (about 1 us each), and the sampling pass draws an occluder budget of
// meshlets (~125k sphere billboards at 1M particles) four times per culling iteration; here the
// particles are spread over all threads.
// push.mode 1: one invocation writes the indirect dispatch of mode 0 into the occluder list's
//   header (dispatch_x/y/z: one invocation per particle slot of the selected meshlets) and
//   empties the large-sprite list.
// push.mode 0: invocation t samples local particle t % max_meshlet of occluder t / max_meshlet:
//   the glyph of include/sprite_make.h shifted by the pass's jitter, every pixel whose centre
//   lies in it (the rasterizer's coverage of the same quad) tested with the exact ray of
//   include/cull_sample.h at the jittered sample position; the nearest hit wins per pixel by a
//   64-bit atomicMin of (view depth bits << 32 | alpha_s bits): positive floats order like their
//   bits, so the nearest depth wins (ties: the smaller alpha_s), whatever the order of the
//   threads. The buffer is cleared to all ones (= no sample: a NaN depth, which cull_update
//   skips). A sprite covering more than kCullSampleLargePixels pixels is appended to the
//   large-sprite list instead (one thread looping over a close-up sphere's hundreds of pixels
//   holds up its SIMD group; the rasterizer spreads them); when the list is full the thread
//   samples it itself.
// push.mode 2: one invocation turns the list's count into its indirect draw
//   (cull_sample.vert with kLargeList + cull_sample_atomic.frag, the same atomicMin per pixel).
// Needs shaderInt64 and 64-bit buffer atomics (the renderer falls back to the rasterized route).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#define MDS_DRAW_LIST_WRITABLE
#include "bindings.h"
#include "culling_math.glsl"
#include "cull_shared.h"
#include "sprite_make.h"
#include "cull_sample.h"

layout(local_size_x = 64) in;
layout(push_constant) uniform PushBlock { CullPush push; };
layout(std430, set = 1, binding = kCullSampleBuffer) coherent buffer SampleBlock { uint64_t samples[]; };
layout(std430, set = 1, binding = kCullSampleLarge) buffer LargeBlock {
  SampleLargeHeader large_header;
  uvec2 large[];
};

// The pixels (framebuffer, inclusive) whose centre lies in the sprite's quad as the rasterizer
// places it (rect + jitter), and the sprite's nearest possible view depth (bits) for the early test.
struct Coverage {
  ivec2 p0, p1;
  uint zmin_bits;
};
Coverage coverage(GpuSprite s, vec2 jitter) {
  vec2 size = frame.viewport.xy;
  vec2 lo = (s.rect.xy + jitter + 1.0) * 0.5 * size;
  vec2 hi = (s.rect.zw + jitter + 1.0) * 0.5 * size;
  Coverage c;
  c.p0 = max(ivec2(ceil(lo - 0.5)), ivec2(0));
  c.p1 = min(ivec2(ceil(hi - 0.5)) - 1, ivec2(size) - 1);
  // The sphere's nearest view depth bounds every hit from below (slack for rounding): a pixel
  // whose nearest sample so far is nearer cannot take this one.
  c.zmin_bits = floatBitsToUint(max((-s.center_radius.z - s.center_radius.w) * (1.0 - 1e-5), 0.0));
  return c;
}

void sample_pixel(GpuSprite s, Coverage c, ivec2 xy, vec2 jitter) {
  uint pix = uint(xy.y) * uint(frame.viewport.x) + uint(xy.x);
  if (c.zmin_bits > uint(samples[pix] >> 32)) return;
  vec2 ndc = (vec2(xy) + 0.5) * frame.viewport.zw * 2.0 - 1.0 - jitter;
  float depth;
  vec2 v;
  if (!mds_cull_sample(ndc, s.center_radius, depth, v) || !(depth < 1.0)) return;
  atomicMin(samples[pix], (uint64_t(floatBitsToUint(max(v.x, 0.0))) << 32) | uint64_t(floatBitsToUint(v.y)));
}

void main() {
  uint per = max(frame.counts.y, 1u);  // max particles per meshlet
  vec2 jitter = vec2(push.jitter_x, push.jitter_y);
  if (push.mode == 1u || push.mode == 2u) {
    if (gl_GlobalInvocationID.x != 0u) return;
    if (push.mode == 1u) {
      draw_header.dispatch_x = (draw_header.instance_count * per + 63u) / 64u;
      draw_header.dispatch_y = 1u;
      draw_header.dispatch_z = 1u;
      large_header.appended = 0u;
    } else {
      large_header.index_count = 6u;
      large_header.instance_count = min(large_header.appended, uint(large.length()));
      large_header.first_index = 0u;
      large_header.vertex_offset = 0;
      large_header.first_instance = 0u;
    }
    return;
  }
  uint t = gl_GlobalInvocationID.x;
  uint e = t / per, local = t % per;
  if (e >= draw_header.instance_count) return;
  uint meshlet_id = draw_ids[e];
  GpuMeshlet m = meshlets[meshlet_id];
  if (local >= m.particle_count) return;
  GpuSprite s = mds_make_sprite(m, nodes[m.node], local);
  if ((s.flags & kSpriteHidden) != 0u || !(s.zndc >= 0.0)) return;  // culled or clipped
  Coverage c = coverage(s, jitter);
  ivec2 ext = max(c.p1 - c.p0 + 1, ivec2(0));
  if (ext.x * ext.y > int(kCullSampleLargePixels)) {
    uint slot = atomicAdd(large_header.appended, 1u);
    if (slot < uint(large.length())) {
      large[slot] = uvec2(meshlet_id, local);
      return;
    }
  }
  for (int y = c.p0.y; y <= c.p1.y; ++y)
    for (int x = c.p0.x; x <= c.p1.x; ++x) sample_pixel(s, c, ivec2(x, y), jitter);
}
