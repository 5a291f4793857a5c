#version 460
// Occlusion sampling pass (paper 000, Sect. 3.2): the selected occluder meshlets (set 0's draw
// list = the occluder list) as sphere billboards, one jittered sub-pixel depth sample per pixel;
// several passes per culling iteration, each with its own occluder subset and jitter.
// The same glyph as the draw (include/sprite_make.h: tangent-plane bounds, half a pixel of
// margin, so sub-pixel spheres are sampled with their exact covered area over the jittered
// passes), shifted by this pass's jitter; the fragment shader writes the sample's view depth and its effective area alpha_s.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"
#include "culling_math.glsl"
#include "cull_shared.h"
#include "sprite_make.h"
#include "sphere_shading.h"
#include "cull_sample.h"

// frame.proj is unjittered; this pass's sub-pixel jitter (NDC) comes as a push constant, so that
// several sampling passes per culling iteration share one frame uniform buffer.
layout(push_constant) uniform PushBlock { CullPush push; };

layout(location = 0) flat out vec4 v_center_radius;  // view space
layout(location = 1) flat out vec3 v_disk;           // mds_cull_sample_disk: once per glyph, not per pixel

void emit_outside() { gl_Position = vec4(2.0, 2.0, 2.0, 1.0); }

void main() {
  uint meshlet_id = draw_ids[gl_InstanceIndex];
  GpuMeshlet m = meshlets[meshlet_id];
  uint local = uint(gl_VertexIndex) >> 2;
  uint corner = uint(gl_VertexIndex) & 3u;
  v_center_radius = vec4(0.0);
  v_disk = vec3(0.0);
  if (local >= m.particle_count) { emit_outside(); return; }
  GpuSprite s = mds_make_sprite(m, nodes[m.node], local, 0u);
  if ((s.flags & kSpriteHidden) != 0u) { emit_outside(); return; }
  vec2 ndc_lo = s.rect.xy, ndc_hi = s.rect.zw;
  float zndc = s.zndc;
  vec2 xy = vec2((corner & 1u) != 0u ? ndc_hi.x : ndc_lo.x, (corner & 2u) != 0u ? ndc_hi.y : ndc_lo.y);
  gl_Position = vec4(xy + vec2(push.jitter_x, push.jitter_y), zndc, 1.0);
  v_center_radius = s.center_radius;
  v_disk = mds_cull_sample_disk(s.center_radius);
}
