#version 460
// The simulation cell's edges (cell_lines.vert): flat colour frame.cell[4].rgb (linear), depth
// tested against the spheres. Attachment route: into the colour and depth attachments (the
// depth test of the pipeline). Visibility route (built as cell_lines_vis.frag with
// MDS_VISIBILITY_ROUTE): the fragment's depth and kVisCell into the visibility buffer
// (sprite_raster.h visibility_write: the nearest wins, whatever the order), and
// visibility_resolve.comp gives such a pixel the cell's colour.
#extension GL_GOOGLE_include_directive : require
#ifdef MDS_VISIBILITY_ROUTE
#define MDS_VISIBILITY
#endif
#include "bindings.h"
#ifdef MDS_VISIBILITY_ROUTE
#include "sphere_shading.h"
#include "sprite_raster.h"

void main() {
  uint pix = uint(gl_FragCoord.y) * uint(frame.viewport.x) + uint(gl_FragCoord.x);
  visibility_write(pix, gl_FragCoord.z, kVisCell);
}
#else
layout(location = 0) out vec4 o_color;

void main() { o_color = vec4(frame.cell[4].rgb, 1.0); }
#endif
