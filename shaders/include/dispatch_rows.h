// GLSL-only: the flat invocation index of a dispatch in rows (gpu_types.h kDispatchRow; the
// host's vk::dispatch_rows), and the rows of a GPU-written indirect dispatch. For a dispatch of
// one row (g <= kDispatchRow) the index is gl_GlobalInvocationID.x. Local size (N, 1, 1).
#ifndef MDS_DISPATCH_ROWS_H
#define MDS_DISPATCH_ROWS_H
#ifndef __cplusplus

// A macro, not a function: gl_WorkGroupSize is the declared local size only after the shader's
// layout(local_size_x = ...) in, which may follow this include (a function compiled before it
// saw (1, 1, 1), and every culling test failed).
#define mds_flat_id() \
  ((gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationID.x)

// (x, y, z) workgroups for `groups` workgroups in rows of `row` (VkDispatchIndirectCommand,
// VkDrawMeshTasksIndirectCommandEXT): kDispatchRow, or 65535 (the guaranteed maximum) for
// counts that can pass 64 x 65535 workgroups (cull_sample: occluder meshlets x max meshlet
// size); mds_flat_id reads the row width from gl_NumWorkGroups.x.
uvec3 mds_dispatch_rows(uint groups, uint row) {
  return uvec3(min(groups, row), (groups + row - 1u) / row, 1u);
}

#endif
#endif  // MDS_DISPATCH_ROWS_H
