#version 460
// No-cull draw-list builder: appends every meshlet (every occupied slot of the streaming pool) to
// the draw list; with culling, cull_draw_list.comp appends the potentially visible set instead.
#extension GL_GOOGLE_include_directive : require
#define MDS_DRAW_LIST_WRITABLE
#include "bindings.h"
#include "dispatch_rows.h"

layout(local_size_x = 64) in;

void main() {
  uint m = mds_flat_id();
  if (m >= frame.counts.x) return;
  if (meshlets[m].particle_count == 0u) return;  // empty slot of the streaming pool
  uint slot = atomicAdd(draw_header.instance_count, 1u);
  draw_ids[slot] = m;
}
