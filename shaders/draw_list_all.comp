#version 460
// No-cull draw-list builder: appends every meshlet to the draw list (one instance each).
// The culling pass will replace this by a classification that appends only visible meshlets;
// the list format (DrawListHeader + meshlet ids, consumed by vkCmdDrawIndexedIndirect) stays.
#extension GL_GOOGLE_include_directive : require
#define MDS_DRAW_LIST_WRITABLE
#include "bindings.h"

layout(local_size_x = 64) in;

void main() {
  uint m = gl_GlobalInvocationID.x;
  if (m >= frame.counts.x) return;
  uint slot = atomicAdd(draw_header.instance_count, 1u);
  draw_ids[slot] = m;
}
