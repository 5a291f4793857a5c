// GLSL-only: a particle's colour (linear RGB) -- its type's (GpuType.color), or with
// kFrameColorMap the viridis colormap of its coordinate along one world axis, t =
// dot(frame.color_plane.xyz, view-space centre) + frame.color_plane.w clamped to [0, 1], or with
// kFrameColorMap | kFrameColorProperty of its property, t = color_plane.x * q + color_plane.w
// for the quantized value q in bits 16..31 of its colour key (sprite_make.h). The
// CPU (double) original of both functions is render/colormap.cpp (viridis_srgb, srgb_to_linear
// in render/scene.cpp); test_colormap compares rendered pixels with it. Needs bindings.h (frame,
// types).
#ifndef MDS_PARTICLE_COLOR_H
#ifndef __cplusplus
#define MDS_PARTICLE_COLOR_H

// Matplotlib's viridis as a degree-6 polynomial in t (sRGB; Matt Zucker's least-squares fit,
// CC0): within 0.018 of matplotlib 3.6's table on every channel (ColorMap.ViridisIsCloseToMatplotlib).
vec3 mds_viridis_srgb(float t) {
  const vec3 c0 = vec3(0.2777273272234177, 0.005407344544966578, 0.3340998053353061);
  const vec3 c1 = vec3(0.1050930431085774, 1.404613529898575, 1.384590162594685);
  const vec3 c2 = vec3(-0.3308618287255563, 0.214847559468213, 0.09509516302823659);
  const vec3 c3 = vec3(-4.634230498983486, -5.799100973351585, -19.33244095627987);
  const vec3 c4 = vec3(6.228269936347081, 14.17993336680509, 56.69055260068105);
  const vec3 c5 = vec3(4.776384997670288, -13.74514537774601, -65.35303263337234);
  const vec3 c6 = vec3(-5.435455855934631, 4.645852612178535, 26.3124352495832);
  t = clamp(t, 0.0, 1.0);
  return clamp(c0 + t * (c1 + t * (c2 + t * (c3 + t * (c4 + t * (c5 + t * c6))))), 0.0, 1.0);
}

vec3 mds_srgb_to_linear(vec3 c) {
  return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThan(c, vec3(0.04045)));
}

// key: GpuSprite.flags (type in bits 0..7, property_q in bits 16..31).
vec3 mds_particle_color(uint key, vec3 center_view) {
  if ((frame.counts.z & kFrameColorMap) == 0u) return types[key & 0xffu].color.rgb;
  float t = (frame.counts.z & kFrameColorProperty) != 0u
                ? frame.color_plane.x * float(key >> 16) + frame.color_plane.w
                : dot(frame.color_plane.xyz, center_view) + frame.color_plane.w;
  return mds_srgb_to_linear(mds_viridis_srgb(t));
}

#endif
#endif
