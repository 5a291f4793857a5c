#version 460
// Occlusion sampling pass, compute route (paper 000, Sect. 3.2): the same samples as the
// rasterized route (cull_sample.vert/.frag), rasterized in compute. Lavapipe sets up every
// primitive on one thread (about 1 us each), and the sampling pass draws an occluder budget of
// meshlets (~125k sphere billboards at 1M particles) four times per culling iteration; here every
// particle is one invocation on all threads.
// push.mode 1: one invocation writes the indirect dispatch of mode 0 into the occluder list's
//   header (dispatch_x/y/z: one invocation per particle slot of the selected meshlets).
// push.mode 0: invocation t rasterizes local particle t % max_meshlet of occluder t / max_meshlet:
//   the glyph of include/sprite_make.h shifted by the pass's jitter, every pixel whose centre
//   lies in it (the rasterizer's coverage of the same quad) tested with the exact ray of
//   include/cull_sample.h at the jittered sample position; the nearest hit wins per pixel by a
//   64-bit atomicMin of (view depth bits << 32 | alpha_s bits): positive floats order like their
//   bits, so the nearest depth wins (ties: the smaller alpha_s), independent of thread order.
//   The buffer is cleared to all ones (= no sample: NaN depth, which cull_update skips).
// Needs shaderInt64 and 64-bit buffer atomics (the renderer falls back to the rasterized route).
// Built as cull_sample_coop.comp with MDS_COOPERATIVE_GLYPHS where the device has subgroup
// ballot and shuffle in compute: glyphs of more than kCooperativePixels pixels are then
// rasterized by their whole subgroup. The samples are the same (atomicMin: order-independent).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#ifdef MDS_COOPERATIVE_GLYPHS
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
#endif
#define MDS_DRAW_LIST_WRITABLE
#include "bindings.h"
#include "dispatch_rows.h"
#include "culling_math.glsl"
#include "cull_shared.h"
#include "sprite_make.h"
#include "sphere_shading.h"
#include "cull_sample.h"

layout(local_size_x = 64) in;
layout(push_constant) uniform PushBlock { CullPush push; };
layout(std430, set = 1, binding = kCullSampleBuffer) coherent buffer SampleBlock { uint64_t samples[]; };

#ifdef MDS_COOPERATIVE_GLYPHS
// Glyphs of more pixels than this (16 x 16) are rasterized by the whole subgroup, one glyph after
// the other (each lane a pixel): one thread looping over a glyph of hundreds of pixels held its
// subgroup's other lanes idle. Measured (A/B, MDSTREAM_CULL_COOP=0): porous 1M close-up at
// 1920x1080, compute route: sampling pass 790 -> 559 ms; porous stress fly-through (320x180):
// passes inside the data 36-37 -> 29-30 ms; ablation view 1 (glyphs of a few pixels) 88.6 vs
// 88.5 ms. A threshold of 16 pixels cost that view 22 %: glyphs of 5 x 5 run faster per lane.
const int kCooperativePixels = 256;
#endif

// The sample of one glyph at pixel (x, y), if it is nearer than the pixel's (see the file comment).
void sample_pixel(int x, int y, vec4 center_radius, vec3 disk, uint zmin_bits, vec2 jitter) {
  uint pix = uint(y) * uint(frame.viewport.x) + uint(x);
  if (zmin_bits > uint(samples[pix] >> 32)) return;
  vec2 ndc = (vec2(x, y) + 0.5) * frame.viewport.zw * 2.0 - 1.0 - jitter;
  float depth;
  vec2 v;
  if (!mds_cull_sample(ndc, vec2(x, y), center_radius, disk, depth, v) || !(depth < 1.0)) return;
  uint64_t key = (uint64_t(floatBitsToUint(max(v.x, 0.0))) << 32) | uint64_t(floatBitsToUint(v.y));
  atomicMin(samples[pix], key);
}

void main() {
  uint per = max(frame.counts.y, 1u);  // max particles per meshlet
  if (push.mode == 1u) {
    if (gl_GlobalInvocationID.x == 0u) {
      uvec3 rows = mds_dispatch_rows((draw_header.instance_count * per + 63u) / 64u, 65535u);
      draw_header.dispatch_x = rows.x;
      draw_header.dispatch_y = rows.y;
      draw_header.dispatch_z = rows.z;
    }
    return;
  }
  // No early return below: every lane takes part in the subgroup's cooperative glyphs.
  uint t = mds_flat_id();
  uint e = t / per, local = t % per;
  bool valid = e < draw_header.instance_count;
  GpuMeshlet m;
  if (valid) {
    m = meshlets[draw_ids[e]];
    valid = local < m.particle_count;
  }
  GpuSprite s;
  if (valid) {
    s = mds_make_sprite(m, nodes[m.node], local, 0u);
    valid = (s.flags & kSpriteHidden) == 0u && s.zndc >= 0.0;  // culled or clipped
  }
  vec2 size = frame.viewport.xy;
  vec2 jitter = vec2(push.jitter_x, push.jitter_y);
  ivec2 p0 = ivec2(0), p1 = ivec2(-1);
  uint zmin_bits = 0u;
  vec3 disk = vec3(0.0);
  if (valid) {
    disk = mds_cull_sample_disk(s.center_radius);
    // The quad as the rasterizer places it (rect + jitter, framebuffer coordinates); pixel
    // centres x + 0.5 inside [lo, hi).
    vec2 lo = (s.rect.xy + jitter + 1.0) * 0.5 * size;
    vec2 hi = (s.rect.zw + jitter + 1.0) * 0.5 * size;
    p0 = max(ivec2(ceil(lo - 0.5)), ivec2(0));
    p1 = min(ivec2(ceil(hi - 0.5)) - 1, ivec2(size) - 1);
    // Early test: the sphere's nearest view depth bounds every hit from below (slack for
    // rounding); a pixel whose nearest sample so far is nearer cannot take this one.
    zmin_bits = floatBitsToUint(max((-s.center_radius.z - s.center_radius.w) * (1.0 - 1e-5), 0.0));
  }
  int w = max(p1.x - p0.x + 1, 0), h = max(p1.y - p0.y + 1, 0);
  int area = w * h;
#ifdef MDS_COOPERATIVE_GLYPHS
  bool cooperative = area > kCooperativePixels;
#else
  bool cooperative = false;
#endif
  if (area > 0 && !cooperative)
    for (int y = p0.y; y <= p1.y; ++y)
      for (int x = p0.x; x <= p1.x; ++x) sample_pixel(x, y, s.center_radius, disk, zmin_bits, jitter);
#ifdef MDS_COOPERATIVE_GLYPHS
  // The lanes whose glyph still waits for the subgroup; the lowest one leads each round.
  uvec4 waiting = subgroupBallot(cooperative);
  while (subgroupBallotBitCount(waiting) > 0u) {
    uint leader = subgroupBallotFindLSB(waiting);
    ivec2 q0 = subgroupShuffle(p0, leader);
    int qw = subgroupShuffle(w, leader), qa = subgroupShuffle(area, leader);
    vec4 cr = subgroupShuffle(valid ? s.center_radius : vec4(0.0), leader);
    vec3 qd = subgroupShuffle(disk, leader);
    uint zb = subgroupShuffle(zmin_bits, leader);
    for (int i = int(gl_SubgroupInvocationID); i < qa; i += int(gl_SubgroupSize))
      sample_pixel(q0.x + i % qw, q0.y + i / qw, cr, qd, zb, jitter);
    waiting[leader / 32u] &= ~(1u << (leader % 32u));  // its glyph is done
  }
#endif
}
