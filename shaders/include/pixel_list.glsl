// GLSL-only: the pixel lists of the passes that run one thread per listed pixel instead of one
// per pixel (lavapipe executes both sides of every branch, docs/rendering.md): a
// CoveredPixelsHeader (gpu_types.h) followed by x | y << 16 per listed pixel. Written by
// visibility_compact.comp (covered pixels, for visibility_resolve.comp) and
// cull_sample_compact.comp (sampled pixels, for cull_update.comp); read back through an indirect
// dispatch of (kCoveredGroupsX, groups_y, 1) workgroups of 64 threads.
// Needs GL_KHR_shader_subgroup_ballot (writers) and gpu_types.h.
#ifndef MDS_PIXEL_LIST_GLSL
#define MDS_PIXEL_LIST_GLSL

// Appends p (x | y << 16) for every lane with `keep` to the list `pixels` of header `head`, one
// atomic per subgroup (the ballot's bit count reserves the subgroup's run), and grows the
// dispatch to ceil(count / (64 * kCoveredGroupsX)) rows. A macro: GLSL passes no buffers.
#define MDS_PIXEL_LIST_APPEND(head, pixels, keep, p)                                                \
  {                                                                                                 \
    uvec4 ballot_ = subgroupBallot(keep);                                                           \
    uint n_ = subgroupBallotBitCount(ballot_);                                                      \
    uint base_ = 0u;                                                                                \
    if (n_ > 0u && subgroupElect()) {                                                               \
      base_ = atomicAdd(head.count, n_);                                                            \
      atomicMax(head.dispatch_y, (base_ + n_ + 64u * kCoveredGroupsX - 1u) / (64u * kCoveredGroupsX)); \
    }                                                                                               \
    base_ = subgroupBroadcastFirst(base_);                                                          \
    if (keep) pixels[base_ + subgroupBallotExclusiveBitCount(ballot_)] = uint((p).x) | (uint((p).y) << 16); \
  }

// The list entry of this invocation in the indirect dispatch (local size 64 x 1).
uint mds_pixel_list_index() {
  return (gl_WorkGroupID.y * kCoveredGroupsX + gl_WorkGroupID.x) * 64u + gl_LocalInvocationIndex;
}
// x | y << 16 -> (x, y) (no integer division: lavapipe has no SIMD division).
uvec2 mds_pixel_list_xy(uint e) { return uvec2(e & 0xffffu, e >> 16); }

#endif
