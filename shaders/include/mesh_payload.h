// GLSL-only: the payload a sphere.task workgroup hands to its sphere.mesh workgroups --
// entries[i] = draw-list entry * kMeshChunksMax + chunk for mesh workgroup i (entries < 2^29).
#ifndef MDS_MESH_PAYLOAD_H
#define MDS_MESH_PAYLOAD_H
struct TaskPayload {
  uint entries[kMeshTaskMeshlets * kMeshChunksMax];
};
taskPayloadSharedEXT TaskPayload payload;
#endif
