// The coordinate tripod of rendered images: OVITO's "Coordinate tripod" layer, ParaView's
// orientation axes. `render --axes CORNER` draws the data's x, y and z axes as the camera sees
// them (red, green, blue; each labelled at its tip) on the legend's translucent panel in a
// corner, after the colour legend and the text label when they take the same corner.
// docs/rendering.md, "Coordinate tripod".
#pragma once

#include <array>
#include <cstdint>

#include <glm/glm.hpp>

#include "overlay/canvas.h"
#include "overlay/color_legend.h"
#include "render/camera.h"
#include "render/renderer.h"

namespace mds::overlay {

// One data axis as the camera sees it.
struct TripodAxis {
  char name = 'x';
  Rgba8 color;
  glm::dvec2 screen{0.0};  // its unit vector in the image plane: x right, y down (length <= 1: foreshortened)
  double toward = 0.0;     // its component toward the viewer (> 0: out of the image)
};

// The three axes in drawing order: the one pointing farthest away first, so nearer ones cover it.
// The camera's orientation alone counts (eye, target, up; not the projection). Precondition:
// eye != target; an up along the view direction is replaced by the axis least along it.
std::array<TripodAxis, 3> tripod_axes(const render::Camera& camera);

// Where the tripod's square panel goes in a width x height image (the legend's text scale s =
// max(1, height / 400): axes 20 s pixels long, room for the labels), placed as label_box places a
// label after `after`. Empty for LegendCorner::off; clipped to the image.
PixelBox tripod_box(uint32_t width, uint32_t height, LegendCorner corner, PixelBox after = {});
// Draws the tripod on an 8-bit canvas in tripod_box (the viewer's HUD). Returns the box.
PixelBox draw_tripod(Canvas& canvas, const render::Camera& camera, LegendCorner corner, PixelBox after = {});
// Draws the tripod over a linear image in tripod_box (draw_on_linear: every pixel outside the box
// stays as it was, to the bit). Returns the box.
PixelBox overlay_tripod(render::FrameImage& image, const render::Camera& camera, LegendCorner corner,
                        PixelBox after = {});

}  // namespace mds::overlay
