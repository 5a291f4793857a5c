// GLSL-only: a particle's colour (linear RGB) -- its type's (GpuType.color), with
// kFrameColorParticle its own (the sRGB RGBA8 of GpuSprite.color), or with
// kFrameColorMap the frame's colormap (FrameUniforms::colormap) of its coordinate along one world axis, t =
// dot(frame.color_plane.xyz, view-space centre) + frame.color_plane.w clamped to [0, 1], or with
// kFrameColorMap | kFrameColorProperty of its property, t = color_plane.x * q + color_plane.w
// for the quantized value q in bits 16..31 of its colour key (sprite_make.h). The
// CPU (double) original of both functions is render/colormap.cpp (colormap_srgb, srgb_to_linear
// in render/scene.cpp); test_colormap compares rendered pixels with it. Needs bindings.h (frame,
// types).
#ifndef MDS_PARTICLE_COLOR_H
#ifndef __cplusplus
#define MDS_PARTICLE_COLOR_H

// The frame's colormap (FrameUniforms::colormap, the samples of --colormap) at t, clamped to
// [0, 1], as sRGB: the linear interpolation of its kColormapSamples samples
// (render::colormap_srgb in double).
vec3 mds_colormap_srgb(float t) {
  const float x = clamp(t, 0.0, 1.0) * float(kColormapSamples - 1u);
  const uint i = min(uint(x), kColormapSamples - 2u);
  return mix(frame.colormap[i].rgb, frame.colormap[i + 1u].rgb, x - float(i));
}

vec3 mds_srgb_to_linear(vec3 c) {
  return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThan(c, vec3(0.04045)));
}

// key: GpuSprite.flags (type in bits 0..7, property_q in bits 16..31); rgba: GpuSprite.color.
vec3 mds_particle_color(uint key, uint rgba, vec3 center_view) {
  if ((frame.counts.z & kFrameColorParticle) != 0u) return mds_srgb_to_linear(unpackUnorm4x8(rgba).rgb);
  if ((frame.counts.z & kFrameColorMap) == 0u) return types[key & 0xffu].color.rgb;
  float t = (frame.counts.z & kFrameColorProperty) != 0u
                ? frame.color_plane.x * float(key >> 16) + frame.color_plane.w
                : dot(frame.color_plane.xyz, center_view) + frame.color_plane.w;
  return mds_srgb_to_linear(mds_colormap_srgb(t));
}

#endif
#endif
