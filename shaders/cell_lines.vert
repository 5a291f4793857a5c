#version 460
// The simulation cell's twelve edges (render/cell_lines.h; docs/rendering.md, "Simulation cell")
// as screen-space quads frame.cell[4].w pixels wide and half a width longer at each end (so that
// edges meet at the corners): six vertices an edge, no vertex buffer (vkCmdDraw of 72). An edge
// is clipped to the near plane in view space first, so that no vertex has w <= 0. The quad keeps
// its end points' clip z and w: the depth along the line is the edge's, and the fragment stage
// tests it against the spheres (cell_lines.frag). The jittered projection (frame.proj) moves the
// lines with the spheres from sample to sample, which antialiases them.
#extension GL_GOOGLE_include_directive : require
#include "bindings.h"

// Corners k = bit 0: + a, bit 1: + b, bit 2: + c (core/cell.h SimulationCell::edges, same order).
const uint kEdges[24] = uint[](0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 0u, 2u, 1u, 3u, 4u, 6u, 5u, 7u,
                               0u, 4u, 1u, 5u, 2u, 6u, 3u, 7u);

vec3 corner(uint k) {
  return frame.cell[0].xyz + float(k & 1u) * frame.cell[1].xyz + float((k >> 1) & 1u) * frame.cell[2].xyz +
         float((k >> 2) & 1u) * frame.cell[3].xyz;
}

void main() {
  uint e = uint(gl_VertexIndex) / 6u;
  uint k = uint(gl_VertexIndex) - 6u * e;
  vec4 v0 = frame.view * vec4(corner(kEdges[2u * e]), 1.0);
  vec4 v1 = frame.view * vec4(corner(kEdges[2u * e + 1u]), 1.0);
  if (frame.cell[0].w == 0.0) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // not drawn: clipped
    return;
  }
  if ((frame.counts.z & kFrameOrtho) == 0u) {
    // Perspective: the part of the edge in front of the near plane (view space looks along -z),
    // a hair beyond it so that the clipper keeps the end.
    float zn = -frame.radius_range.z * (1.0 + 1e-4);
    if (v0.z > zn && v1.z > zn) {
      gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
      return;
    }
    if (v0.z > zn) v0 = mix(v1, v0, (zn - v1.z) / (v0.z - v1.z));
    if (v1.z > zn) v1 = mix(v0, v1, (zn - v0.z) / (v1.z - v0.z));
  }
  vec4 c0 = frame.proj * v0, c1 = frame.proj * v1;
  vec2 px = 0.5 * frame.viewport.xy;  // NDC -> pixels
  vec2 d = (c1.xy / c1.w - c0.xy / c0.w) * px;
  float len = length(d);
  vec2 dir = len > 1e-6 ? d / len : vec2(1.0, 0.0);
  vec2 nrm = vec2(-dir.y, dir.x);
  float hw = 0.5 * frame.cell[4].w;
  // Triangles (0, 1, 2) and (2, 1, 3) of the quad corners: bit 0 the far end, bit 1 the + side.
  uint q = k < 3u ? k : (k == 3u ? 2u : (k == 4u ? 1u : 3u));
  bool far_end = (q & 1u) != 0u;
  vec4 c = far_end ? c1 : c0;
  vec2 off = ((q & 2u) != 0u ? hw : -hw) * nrm + (far_end ? hw : -hw) * dir;  // pixels
  c.xy += off / px * c.w;  // to NDC, then to clip space
  gl_Position = c;
}
