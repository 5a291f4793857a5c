// GLSL-only: the payload a sphere.task workgroup hands to its sphere.mesh workgroups --
// entries[i] = meshlet id * kMeshChunksMax + chunk for mesh workgroup i (meshlet ids < 2^29).
#ifndef MDS_MESH_PAYLOAD_H
#define MDS_MESH_PAYLOAD_H
struct TaskPayload {
  uint entries[kMeshTaskMeshlets * kMeshChunksMax];
};
taskPayloadSharedEXT TaskPayload payload;
#endif
