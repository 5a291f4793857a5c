// GLSL-only: the glyph of one particle -- its view-space sphere and the conservative screen
// rectangle of the projected sphere -- shared by the compute sprite pre-pass
// (sphere_prepass.comp) and the mesh shader path (sphere.mesh), so both draw the same glyphs.
//  - perspective: per screen axis, the slopes of the two tangent planes through the eye,
//    s = (a z -/+ r sqrt(a^2 + z^2 - r^2)) / (z^2 - r^2) for centre (a, z) (z = view distance)
//    (Mara & McGuire 2013, "2D polyhedral bounds of a clipped, perspective-projected 3D sphere");
//  - orthographic: centre +- r;
// placed at the sphere's nearest view distance (z - r) so that the fragment shader's
// depth_greater promise holds, and grown by half a pixel on every side: sub-pixel spheres get a
// rectangle of at least one pixel, so every jittered sample that hits the sphere is rasterized
// and the exact ray test in the fragment shader keeps only those -- over spp jittered passes a
// sub-pixel sphere contributes exactly its expected covered area (its "effective sub-pixel area").
// Needs bindings.h (frame, nodes, particles, types, radii_q; property_q and particle_rgba where
// the shader defines MDS_COLOR_KEY before including this: the colour key's property bits and the
// sprite's colour, else they stay 0).
#ifndef MDS_SPRITE_MAKE_H
#define MDS_SPRITE_MAKE_H

vec3 mds_project(vec3 v) {
  vec4 c = frame.proj * vec4(v, 1.0);
  return c.xyz / c.w;
}

// The view-space sphere (centre, radius) and the colour key of particle pi (buffer index) of a
// node with quantization frame (origin, step): its type in bits 0..7 and, with
// kFrameColorProperty, its property_q in bits 16..31 (GpuSprite.flags; particle_color.h). `precise`: no contraction into fused multiply-adds, so
// that every shader that includes this computes the same bits (the resolve rebuilds the sphere
// the pre-pass made, mds_vis_id_sphere).
vec4 mds_particle_sphere(uint pi, vec3 origin, vec3 step, out uint type) {
  uvec2 raw = particles[pi];
  uvec3 q = uvec3(raw.x & 0xffffu, raw.x >> 16, raw.y & 0xffffu);
  type = (raw.y >> 16) & 0xffu;
  precise vec3 world = origin + vec3(q) * step;
  float r = types[type].radius;
  if ((frame.counts.z & kFramePerParticleRadius) != 0u) {
    uint w = radii_q[pi >> 1];
    uint rq = (pi & 1u) != 0u ? (w >> 16) : (w & 0xffffu);
    r = frame.radius_range.x + float(rq) * frame.radius_range.y / 65535.0;
  }
#ifdef MDS_COLOR_KEY  // only the shaders that colour glyphs bind kBindProperty (not the culling loop's)
  if ((frame.counts.z & kFrameColorProperty) != 0u) {
    uint w = property_q[pi >> 1];
    type |= ((pi & 1u) != 0u ? (w >> 16) : (w & 0xffffu)) << 16;
  }
#endif
  precise vec3 c = (frame.view * vec4(world, 1.0)).xyz;
  return vec4(c, r);
}

// The particle's own RGBA8 colour with kFrameColorParticle (GpuSprite.color), else 0.
uint mds_particle_rgba(uint pi) {
#ifdef MDS_COLOR_KEY  // only the shaders that colour glyphs bind kBindColor
  if ((frame.counts.z & kFrameColorParticle) != 0u) return particle_rgba[pi];
#endif
  return 0u;
}

// The sphere and type of the particle a visibility-buffer id names (GpuSprite.vis_id: draw-list
// entry x max meshlet particles + local index), the same bits as its sprite's center_radius.
// Only the fields it needs are loaded (a GpuNode is 144 bytes): on lavapipe the full-screen
// resolve of a 1080p close-up paid ~27 ms for whole-struct loads.
vec4 mds_vis_id_sphere(uint vis_id, out uint type, out uint rgba) {
  uint e = vis_id / frame.counts.y;
  uint local = vis_id - e * frame.counts.y;
  uint id = draw_ids[e];
  uint split = meshlets[id].split;
  uint pi = local < split ? meshlets[id].first_particle + local : meshlets[id].second_particle + (local - split);
  uint node = meshlets[id].node;
  rgba = mds_particle_rgba(pi);
  return mds_particle_sphere(pi, nodes[node].origin, nodes[node].step, type);
}

// The sprite of local particle `local` of meshlet m (node = nodes[m.node]) at draw-list entry e.
// flags = colour key (type, property), plus kSpriteHidden when nothing can be drawn (behind the near plane, radius 0,
// off screen, beyond the far plane); rect = NDC (lo.x, lo.y, hi.x, hi.y); zndc = depth of the
// rectangle.
GpuSprite mds_make_sprite(GpuMeshlet m, GpuNode node, uint local, uint e) {
  uint type;
  const uint pi = mds_meshlet_particle(m, local);
  vec4 cr = mds_particle_sphere(pi, node.origin, node.step, type);
  vec3 c = cr.xyz;
  float r = cr.w;
  float near = frame.radius_range.z;
  bool ortho = (frame.counts.z & kFrameOrtho) != 0u;
  float zc = -c.z;  // view distance of the centre
  GpuSprite s;
  s.center_radius = cr;
  s.flags = type;
  s.vis_id = e * frame.counts.y + local;
  s.color = mds_particle_rgba(pi);
  s.rect = vec4(0.0);
  s.zndc = 0.0;
  if (zc + r <= near || r <= 0.0) {
    s.flags |= kSpriteHidden;
    return s;
  }
  vec2 ndc_lo, ndc_hi;
  float zq = max(zc - r, near);
  if (ortho) {
    vec3 a = mds_project(vec3(c.xy - r, -zq));
    vec3 b = mds_project(vec3(c.xy + r, -zq));
    ndc_lo = min(a.xy, b.xy);
    ndc_hi = max(a.xy, b.xy);
  } else if (zc - r <= near) {
    // The sphere crosses the near plane: its part in front of the plane lies in the view-space
    // box [c.xy - r, c.xy + r] x [near, zc + r] of view distances, whose screen rectangle has
    // the extreme slopes x / z at the box's corners (z > 0). Spheres beside the eye (a camera
    // inside the data) thus stay off screen instead of covering the whole viewport: at
    // 144x81 inside the porous block (a slab of ~9000 particles at the eye's depth) they cost
    // ~1.1 s of ray tests per frame.
    vec2 e_lo = c.xy - r, e_hi = c.xy + r;
    float z1 = zc + r;
    vec2 s_lo = min(e_lo / near, e_lo / z1);
    vec2 s_hi = max(e_hi / near, e_hi / z1);
    vec3 a = mds_project(vec3(s_lo * zq, -zq));
    vec3 b = mds_project(vec3(s_hi * zq, -zq));
    ndc_lo = min(a.xy, b.xy);
    ndc_hi = max(a.xy, b.xy);
  } else {
    float denom = zc * zc - r * r;
    vec2 t = sqrt(max(c.xy * c.xy + denom, 0.0));
    vec2 s_lo = (c.xy * zc - r * t) / denom;
    vec2 s_hi = (c.xy * zc + r * t) / denom;
    vec3 a = mds_project(vec3(s_lo * zq, -zq));
    vec3 b = mds_project(vec3(s_hi * zq, -zq));
    ndc_lo = min(a.xy, b.xy);
    ndc_hi = max(a.xy, b.xy);
  }
  // Half a pixel of margin on every side (viewport.zw = 1/size; 1 NDC unit = size/2 pixels).
  ndc_lo -= frame.viewport.zw;
  ndc_hi += frame.viewport.zw;
  ndc_lo = max(ndc_lo, vec2(-1.01));
  ndc_hi = min(ndc_hi, vec2(1.01));
  s.rect = vec4(ndc_lo, ndc_hi);
  s.zndc = max(mds_project(vec3(0.0, 0.0, -zq)).z, 0.0);
  if (any(greaterThanEqual(ndc_lo, ndc_hi))) s.flags |= kSpriteHidden;  // entirely off screen
  if (s.zndc > 1.0) s.flags |= kSpriteHidden;                           // beyond the far plane
  return s;
}

#endif
