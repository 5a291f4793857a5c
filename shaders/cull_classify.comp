#version 460
// Confidence-based occlusion classification (paper 000, Sect. 5, Fig. 10), hierarchical:
// push.mode 0 tests every node, push.mode 1 every meshlet (a meshlet of a node in O is O);
// push.mode 2 (MDS_COOPERATIVE_BOXES) every node with one subgroup per node.
// The box test: the axis-aligned box is projected (8 corners, unjittered projection); its pixel
// rectangle selects the pyramid level where it covers at most kNodeExtent^2 (nodes) or
// kMeshletExtent^2 (meshlets) texels. The paper rasterizes the box and depth-tests its fragments
// against d_cull; here, per texel of the rectangle, the box's conservative entry depth on the
// texel's centre ray (mds_ray_box_entry on the box grown by the texel's half diagonal, see
// culling_math.h): texels the box does not reach are skipped -- so the far depths seen through
// a neighbouring pore, at the corners of the rectangle, no longer keep a box visible -- and the
// depth test fails (occluded) when the entry depth is >= d_cull on every covered texel (the
// pyramid stores max depth, so coarser levels stay conservative); the aggregated confidence is
// the mean C_cull over the covered texels (Eq. 23 averages: the covered area's mean). The first
// texel where the box lies in front ends the test: the box is P whatever the confidence.
// A node's test is tightened by its sub-node occupancy (src/culling/node_occupancy.h): only the
// occupied cells of its box are tested (4^3 coarse cells; where a coarse cell lies in front on
// a texel, its occupied 2^3 sub-cells from the store's occupancy record decide), so a box that
// reaches into a pore with no particle of the node there can still be O (issue 4: nodes known
// O before they are read are never read).
// Boxes reaching behind the near plane pass unless their part in front of it projects outside
// the image. Boxes entirely outside the image are O (frustum
// culled: they cannot contribute to any pixel, and their particles are not on any pixel ray).
// Classes only move upward (mds_classify_occlusion keeps max(previous, new)). A meshlet that
// reaches O subtracts its voxel contributions from the density volume (Sect. 4.4); with
// kCullNodeDensity (streaming) a node reaching O subtracts the whole node instead, resident or not.
// Empty slots of the streaming pool (particle_count 0) are skipped and not counted.
// Built as cull_classify_coop.comp with MDS_COOPERATIVE_BOXES where the device has subgroup
// ballot, shuffle and arithmetic in compute: a box whose test covers more than
// kCooperativeTexels texels is then tested by its whole subgroup (each lane a share of the
// texels, the early "in front" exit and the confidence sums reduced over the subgroup), one
// box after the other. One thread walking the up to 128 x 128 texels of a node close to the eye
// held its subgroup's other lanes idle (docs/results/gpu-h200.md, "Where the slow frames go").
// The classes are those of one thread per box up to the summation order of the mean confidence.
#extension GL_GOOGLE_include_directive : require
#ifdef MDS_COOPERATIVE_BOXES
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#endif
#include "bindings.h"
#include "dispatch_rows.h"
#include "culling_math.glsl"
#include "cull_bindings.h"

layout(local_size_x = 64) in;
// Texels per side at most: kNodeExtentInMemory (32, <= 1024 ray tests per node) or, streaming,
// kNodeExtentStreaming (128) -- cull_loop.h.
layout(constant_id = 0) const int kNodeExtent = 32;
const int kMeshletExtent = 32;  // <= 1024 ray tests per meshlet
// Measured at 1920x1080 (1M, ablation v1 / porous v0): 16 makes the meshlet classification 3x
// cheaper (119 -> 41, 79 -> 28 ms) but keeps 5 % more meshlets (kept / visible 1.08 -> 1.13,
// 1.22 -> 1.28), which every frame after convergence pays; 32 stays.

// Pixel rectangle [lo, hi] of the box's 8 projected corners (all in front of the near plane).
void project_rect(vec3 bmin, vec3 bmax, out vec2 lo, out vec2 hi) {
  vec2 size = cull.viewport.xy;
  lo = vec2(3.0e38);
  hi = vec2(-3.0e38);
  for (int i = 0; i < 8; ++i) {
    vec3 c = vec3((i & 1) != 0 ? bmax.x : bmin.x, (i & 2) != 0 ? bmax.y : bmin.y,
                  (i & 4) != 0 ? bmax.z : bmin.z);
    vec4 clip = cull.proj * (cull.view * vec4(c, 1.0));
    vec2 px = (clip.xy / clip.w * 0.5 + 0.5) * size;
    lo = min(lo, px);
    hi = max(hi, px);
  }
}

// One texel of the shared texels_in_front (the same test as its one-thread loop): 0 the box does
// not reach the texel's centre ray, 1 the box lies behind d_cull there (its C_cull in c), 2 the
// box lies in front (the depth test passes). The one-thread loop keeps the test inline: called
// through this function there, lavapipe's floating-point code changed enough to move a node's
// class in one frame of the 100k porous jumps (StressCli's store), so the default variant keeps
// the code it had.
int texel_test(int x, int y, vec3 bmin, vec3 bmax, uint level, float grow, out float c) {
  c = 0.0;
  bool ortho = (cull.params.w & kCullOrtho) != 0u;
  vec2 ndc = (vec2(x, y) + 0.5) * float(1u << level) * cull.viewport.zw * 2.0 - 1.0;
  vec3 o, dir;
  if (ortho) {
    o = (cull.inv_view * vec4(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], 0.0, 1.0)).xyz;
    dir = mat3(cull.inv_view) * vec3(0.0, 0.0, -1.0);
  } else {
    o = (cull.inv_view * vec4(0.0, 0.0, 0.0, 1.0)).xyz;
    dir = mat3(cull.inv_view) * vec3(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], -1.0);
  }
  float t_entry = mds_ray_box_entry(o.x, o.y, o.z, dir.x, dir.y, dir.z, bmin.x, bmin.y, bmin.z,
                                    bmax.x, bmax.y, bmax.z, grow, cull.camera.z);
  if (!(t_entry < float(MDS_CULL_DEPTH_EMPTY))) return 0;
  vec2 dc = pyramid[cull_level_offset(level) + uint(y) * cull_level_size(level).x + uint(x)];
  if (!(t_entry >= dc.x)) return 2;
  c = dc.y;
  return 1;
}

// The depth/confidence test of the box over the pyramid texels [t0, t1] of `level`: per texel
// the box's conservative entry depth on the texel's centre ray (the box grown by `grow`, the
// texel's half diagonal at the far side, culling_math.h ray_box_entry); texels the box does not
// reach take no part. True when the box lies in front of d_cull on one texel (the depth test
// passes: P whatever the confidence); otherwise C_cull of the reached texels is summed into
// csum and their number into n. coop (MDS_COOPERATIVE_BOXES only): every lane of the subgroup
// calls with the same box; in rounds, lane l tests texel round * gl_SubgroupSize + l, and the
// first round with a texel in front ends the test on every lane (a box in front stops as early
// as one thread's test would); the result and the sums are the subgroup's, the same on every lane.
bool texels_in_front(vec3 bmin, vec3 bmax, uint level, ivec2 t0, ivec2 t1, float grow, inout float csum,
                     inout float n, bool coop) {
  float c;
#ifdef MDS_COOPERATIVE_BOXES
  if (coop) {
    int w = t1.x - t0.x + 1;
    int count = (w > 0 && t1.y >= t0.y) ? w * (t1.y - t0.y + 1) : 0;
    float cs = 0.0, cn = 0.0;
    for (int base = 0; base < count; base += int(gl_SubgroupSize)) {
      int k = base + int(gl_SubgroupInvocationID);
      int r = k < count ? texel_test(t0.x + k % w, t0.y + k / w, bmin, bmax, level, grow, c) : 0;
      if (subgroupBallot(r == 2) != uvec4(0u)) return true;
      if (r == 1) {
        cs += c;
        cn += 1.0;
      }
    }
    csum += subgroupAdd(cs);
    n += subgroupAdd(cn);
    return false;
  }
#endif
  uvec2 ls = cull_level_size(level);
  uint lo_off = cull_level_offset(level);
  bool ortho = (cull.params.w & kCullOrtho) != 0u;
  float texel_px = float(1u << level);
  vec3 eye = (cull.inv_view * vec4(0.0, 0.0, 0.0, 1.0)).xyz;
  for (int y = t0.y; y <= t1.y; ++y)
    for (int x = t0.x; x <= t1.x; ++x) {
      vec2 ndc = (vec2(x, y) + 0.5) * texel_px * cull.viewport.zw * 2.0 - 1.0;
      vec3 o = eye, dir;
      if (ortho) {
        o = (cull.inv_view * vec4(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], 0.0, 1.0)).xyz;
        dir = mat3(cull.inv_view) * vec3(0.0, 0.0, -1.0);
      } else {
        dir = mat3(cull.inv_view) * vec3(ndc.x / cull.proj[0][0], ndc.y / cull.proj[1][1], -1.0);
      }
      float t_entry = mds_ray_box_entry(o.x, o.y, o.z, dir.x, dir.y, dir.z, bmin.x, bmin.y, bmin.z,
                                        bmax.x, bmax.y, bmax.z, grow, cull.camera.z);
      if (!(t_entry < float(MDS_CULL_DEPTH_EMPTY))) continue;  // the box does not reach this texel
      vec2 dc = pyramid[lo_off + uint(y) * ls.x + uint(x)];
      if (!(t_entry >= dc.x)) return true;
      csum += dc.y;
      n += 1.0;
    }
  return false;
}

// Texel rectangle at `level` of the pixel rectangle [lo, hi] clipped to the image; false when
// the rectangle lies outside the image.
bool texel_rect(vec2 lo, vec2 hi, uint level, out ivec2 t0, out ivec2 t1) {
  float W = cull.viewport.x, H = cull.viewport.y;
  t0 = ivec2(0);
  t1 = ivec2(-1);
  if (hi.x <= 0.0 || hi.y <= 0.0 || lo.x >= W || lo.y >= H) return false;
  ivec2 p0 = clamp(ivec2(floor(lo)), ivec2(0), ivec2(W, H) - 1);
  ivec2 p1 = max(clamp(ivec2(ceil(hi)) - 1, ivec2(0), ivec2(W, H) - 1), p0);
  t0 = p0 >> int(level);
  t1 = p1 >> int(level);
  return true;
}

// Returns MDS_CULL_CLASS_* for the box without the "upward" rule (-1: outside the image).
// occupancy (nodes only): bit c set = cell c of the box's 4^3 cells holds part of a particle
// (src/culling/node_occupancy.h; 0 = unknown, treated as full). When the whole box lies behind
// d_cull on every texel it reaches, so do its cells: the box's mean confidence decides, as for
// a full mask (a cheaper and slightly different mean than the cells' own, never a P). Otherwise
// only occupied cells are tested, nearest first, at the pyramid level the whole box selects; a
// cell in front on a texel is refined into its occupied sub-cells (nodes[node].occupancy_fine;
// none known: P), and the box is P when one of them is in front on one texel, O (frustum
// culled) when no occupied cell reaches into the image; otherwise the class follows the mean
// confidence over the texels the tested cells reach (a refined cell's through its sub-cells).
// The fine occupancy byte of coarse cell c of node i (0: unknown; gpu_types.h GpuNode).
uint fine_cell_bits(uint i, int c) {
  return (nodes[i].occupancy_fine[c / 16][(c / 4) % 4] >> (8 * (c % 4))) & 0xffu;
}

// The texel test of a box (box_setup -> box_test): the box's texel rectangle at level 0, the
// pyramid level of the test and the ray grow of that level.
struct BoxTest {
  ivec2 t0, t1;
  uint level;
  float grow;
};
const int kBoxTexelTest = -2;  // box_setup: the class needs box_test

// The projection part of classify_box: returns the class decided without a texel test (-1:
// outside the image, P: the box reaches the near plane) or kBoxTexelTest with b filled in.
int box_setup(vec3 bmin, vec3 bmax, int max_extent, out BoxTest b) {
  b.t0 = ivec2(0);
  b.t1 = ivec2(-1);
  b.level = 0u;
  b.grow = 0.0;
  float W = cull.viewport.x, H = cull.viewport.y;
  vec2 lo = vec2(3.0e38), hi = vec2(-3.0e38);
  float znear = 3.0e38, zfar = 0.0;
  vec3 vlo = vec3(3.0e38), vhi = vec3(-3.0e38);  // view-space bounds of the corners
  for (int i = 0; i < 8; ++i) {
    vec3 c = vec3((i & 1) != 0 ? bmax.x : bmin.x, (i & 2) != 0 ? bmax.y : bmin.y,
                  (i & 4) != 0 ? bmax.z : bmin.z);
    vec4 v = cull.view * vec4(c, 1.0);
    vlo = min(vlo, v.xyz);
    vhi = max(vhi, v.xyz);
    float z = -v.z;
    znear = min(znear, z);
    zfar = max(zfar, z);
    vec4 clip = cull.proj * v;
    vec2 ndc = clip.xy / clip.w;
    vec2 px = (ndc * 0.5 + 0.5) * vec2(W, H);
    lo = min(lo, px);
    hi = max(hi, px);
  }
  if (znear <= cull.camera.z) {
    // The box reaches the near plane: no depth test (visible), unless its part in front of the
    // plane -- inside the view-space box of its corners cut at the plane -- projects outside
    // the image (a box beside the eye, as when the camera is inside the data).
    if (zfar <= cull.camera.z) return -1;  // entirely behind the near plane
    lo = vec2(3.0e38);
    hi = vec2(-3.0e38);
    for (int i = 0; i < 8; ++i) {
      vec4 v = vec4((i & 1) != 0 ? vhi.x : vlo.x, (i & 2) != 0 ? vhi.y : vlo.y,
                    -((i & 4) != 0 ? zfar : cull.camera.z), 1.0);
      vec4 clip = cull.proj * v;
      vec2 px = (clip.xy / clip.w * 0.5 + 0.5) * vec2(W, H);
      lo = min(lo, px);
      hi = max(hi, px);
    }
    if (hi.x <= 0.0 || hi.y <= 0.0 || lo.x >= W || lo.y >= H) return -1;
    return MDS_CULL_CLASS_P;
  }
  ivec2 t0, t1;
  if (!texel_rect(lo, hi, 0u, t0, t1)) return -1;
  int extent = max(t1.x - t0.x, t1.y - t0.y) + 1;
  uint level = 0u;
  while (extent > max_extent && level + 1u < cull.pyramid.x) {
    level++;
    extent = max((t1.x >> level) - (t0.x >> level), (t1.y >> level) - (t0.y >> level)) + 1;
  }
  bool ortho = (cull.params.w & kCullOrtho) != 0u;
  b.t0 = t0;
  b.t1 = t1;
  b.level = level;
  b.grow = 1.001 * mds_texel_half_diagonal(float(1u << level), zfar, !ortho, cull.camera.x, cull.camera.y);
  return kBoxTexelTest;
}

// Texels of the whole box's test (the work of box_test when the node is full or occluded).
int box_texels(BoxTest b) {
  ivec2 e = (b.t1 >> int(b.level)) - (b.t0 >> int(b.level)) + 1;
  return e.x * e.y;
}

// Texels of a box test above which its subgroup shares it (MDS_COOPERATIVE_BOXES; default a
// 16 x 16 rectangle of texels; a node's test covers up to kNodeExtent^2, a meshlet's up to
// kMeshletExtent^2).
layout(constant_id = 1) const int kCooperativeTexels = 256;

#ifdef MDS_COOPERATIVE_BOXES
// kSharedCells (constant_id 2): in a shared test (coop) of more than kCooperativeTexels
// texels the occupied cells go one after the other in front-to-back order, and each cell's texels -- a refined cell's sub-cells' -- are
// shared by the subgroup as a whole box's are (texels_in_front with coop). With one lane per
// cell a round of cells lasts as long as its slowest lane's cell (up to 32 x 32 texels), and a
// cell in front ends the loop only after that round; here a cell in front ends it within the
// rounds of its own texels, and unoccupied cells cost nothing. Every lane calls with the same
// arguments and gets the same result; csum, n and in_image are the subgroup's (no reduction
// after). Returns true when a cell lies in front on a texel (the box is P).
layout(constant_id = 2) const bool kSharedCells = false;  // the host sets it: on where box tests are shared

bool cells_in_front_shared(vec3 bmin, vec3 bmax, uvec2 occupancy, int node, bool fine, uint level, float grow,
                           bvec3 flip, int sub_flip, inout float csum, inout float n, inout bool in_image) {
  const int kCells = MDS_OCCUPANCY_CELLS;
  vec3 cell = (bmax - bmin) / float(kCells);
  for (int j = 0; j < kCells * kCells * kCells; ++j) {
    ivec3 ci = ivec3(j % kCells, (j / kCells) % kCells, j / (kCells * kCells));
    ci = mix(ci, ivec3(kCells - 1) - ci, flip);
    int c = ci.x + kCells * (ci.y + kCells * ci.z);
    uint bits = c < 32 ? occupancy.x : occupancy.y;
    if (((bits >> (c & 31)) & 1u) == 0u) continue;
    vec3 cmin = bmin + cell * vec3(ci);
    vec3 cmax = mix(bmin + cell * vec3(ci + 1), bmax, equal(ci, ivec3(kCells - 1)));
    vec2 clo, chi;
    project_rect(cmin, cmax, clo, chi);
    ivec2 c0, c1;
    if (!texel_rect(clo, chi, level, c0, c1)) continue;
    in_image = true;
    float cs = 0.0, cn = 0.0;
    if (!texels_in_front(cmin, cmax, level, c0, c1, grow, cs, cn, true)) {
      csum += cs;
      n += cn;
      continue;
    }
    // The cell lies in front somewhere: its occupied sub-cells decide, as in the lane loop.
    uint sub = fine ? fine_cell_bits(uint(node), c) : 0u;
    if (sub == 0u) return true;
    vec3 half_cell = (cmax - cmin) * 0.5;
    for (int t = 0; t < 8; ++t) {
      int s = t ^ sub_flip;
      if (((sub >> s) & 1u) == 0u) continue;
      bvec3 upper = bvec3((s & 1) != 0, (s & 2) != 0, (s & 4) != 0);
      vec3 smin = mix(cmin, cmin + half_cell, upper);
      vec3 smax = mix(cmin + half_cell, cmax, upper);
      vec2 slo, shi;
      project_rect(smin, smax, slo, shi);
      ivec2 s0, s1;
      if (!texel_rect(slo, shi, level, s0, s1)) continue;
      if (texels_in_front(smin, smax, level, s0, s1, grow, csum, n, true)) return true;
    }
  }
  return false;
}
#endif

// The texel part of classify_box, for a box box_setup returned kBoxTexelTest for.
// node: the node whose occupancy is passed (its fine level is read from nodes[]), -1 for meshlets.
// coop: see texels_in_front (every lane calls with the same box; the result is the subgroup's).
int box_test(vec3 bmin, vec3 bmax, BoxTest b, uvec2 occupancy, int node, bool coop) {
  uint level = b.level;
  ivec2 t0 = b.t0, t1 = b.t1;
  float grow = b.grow;
  float csum = 0.0, n = 0.0;
  bool fine = false;  // the node has a fine level that is not all set
  if (node >= 0) {
    uvec4 any_bits = uvec4(0u), all_bits = uvec4(0xffffffffu);
    for (int w = 0; w < 4; ++w) {
      any_bits |= nodes[node].occupancy_fine[w];
      all_bits &= nodes[node].occupancy_fine[w];
    }
    fine = any(notEqual(any_bits, uvec4(0u))) && any(notEqual(all_bits, uvec4(0xffffffffu)));
  }
  bool full = occupancy == uvec2(0u) || (occupancy == uvec2(0xffffffffu) && !fine);
  if (full) {
    if (texels_in_front(bmin, bmax, level, t0 >> int(level), t1 >> int(level), grow, csum, n, coop))
      return MDS_CULL_CLASS_P;
    // No texel's ray reaches the box: it covers no pixel of the image (its rectangle only
    // overlaps the image's border, the box itself lies beyond it), so it is frustum culled.
    if (n == 0.0) return -1;
  } else if (!texels_in_front(bmin, bmax, level, t0 >> int(level), t1 >> int(level), grow, csum, n, coop) && n > 0.0) {
    // The whole box lies behind d_cull on every texel it reaches, so every cell does too: the
    // box's mean confidence decides, as for a full mask (one test instead of one per cell).
  } else {
    csum = 0.0;
    n = 0.0;
    const int kCells = MDS_OCCUPANCY_CELLS;  // cell c = i + kCells (j + kCells k), node_occupancy.h
    vec3 cell = (bmax - bmin) / float(kCells);
    bool in_image = false;
    // Cells in front-to-back order (each axis from the eye's side: the cell index mirrored
    // where the eye lies on the high side), so a visible node stops at a near cell.
    bool ortho_view = (cull.params.w & kCullOrtho) != 0u;
    vec3 toward = ortho_view ? mat3(cull.inv_view) * vec3(0.0, 0.0, -1.0)
                             : 0.5 * (bmin + bmax) - (cull.inv_view * vec4(0.0, 0.0, 0.0, 1.0)).xyz;
    bvec3 flip = lessThan(toward, vec3(0.0));
    int sub_flip = (flip.x ? 1 : 0) | (flip.y ? 2 : 0) | (flip.z ? 4 : 0);
#ifdef MDS_COOPERATIVE_BOXES
    // Shared cells only for a test of more than kCooperativeTexels texels: below it a cell
    // covers a few texels, and 64 cells one after the other cost more rounds than lanes share.
    if (coop && kSharedCells && box_texels(b) > kCooperativeTexels) {
      if (cells_in_front_shared(bmin, bmax, occupancy, node, fine, level, grow, flip, sub_flip, csum, n, in_image))
        return MDS_CULL_CLASS_P;
      if (!in_image || n == 0.0) return -1;
      return mds_classify_occlusion(MDS_CULL_CLASS_P, true, csum / n, cull.thresholds.x, cull.thresholds.y);
    }
#endif
    // coop: the subgroup shares the cells in rounds (lane l takes cell round * gl_SubgroupSize
    // + l of the front-to-back order, tested by its lane alone); the first round in which a lane
    // finds its cell in front ends the loop on every lane: the node is P.
    int cells = kCells * kCells * kCells;
    int lane = 0, step = 1;
#ifdef MDS_COOPERATIVE_BOXES
    if (coop) {
      lane = int(gl_SubgroupInvocationID);
      step = int(gl_SubgroupSize);
    }
#endif
    bool front = false;
    for (int base = 0; base < cells; base += step) {
      int j = base + lane;
      bool mine = j < cells;
      ivec3 ci = ivec3(j % kCells, (j / kCells) % kCells, j / (kCells * kCells));
      ci = mix(ci, ivec3(kCells - 1) - ci, flip);
      int c = ci.x + kCells * (ci.y + kCells * ci.z);
      uint bits = c < 32 ? occupancy.x : occupancy.y;
      mine = mine && ((bits >> (c & 31)) & 1u) != 0u;
      vec3 cmin = bmin + cell * vec3(ci);
      vec3 cmax = mix(bmin + cell * vec3(ci + 1), bmax, equal(ci, ivec3(kCells - 1)));
      ivec2 c0, c1;
      if (mine) {
        vec2 clo, chi;
        project_rect(cmin, cmax, clo, chi);
        mine = texel_rect(clo, chi, level, c0, c1);
      }
      float cs = 0.0, cn = 0.0;
      if (mine) {
        in_image = true;
        if (!texels_in_front(cmin, cmax, level, c0, c1, grow, cs, cn, false)) {
          csum += cs;
          n += cn;
          mine = false;
        }
      }
      if (mine) {
        // The cell lies in front somewhere: its occupied sub-cells decide (P when one of them
        // lies in front on one texel; else their texels' confidence counts instead of the cell's).
        uint sub = fine ? fine_cell_bits(uint(node), c) : 0u;
        front = sub == 0u;
        vec3 half_cell = (cmax - cmin) * 0.5;
        for (int t = 0; t < 8 && !front; ++t) {
          int s = t ^ sub_flip;
          if (((sub >> s) & 1u) == 0u) continue;
          bvec3 upper = bvec3((s & 1) != 0, (s & 2) != 0, (s & 4) != 0);
          vec3 smin = mix(cmin, cmin + half_cell, upper);
          vec3 smax = mix(cmin + half_cell, cmax, upper);
          vec2 slo, shi;
          project_rect(smin, smax, slo, shi);
          ivec2 s0, s1;
          if (!texel_rect(slo, shi, level, s0, s1)) continue;
          front = texels_in_front(smin, smax, level, s0, s1, grow, csum, n, false);
        }
      }
#ifdef MDS_COOPERATIVE_BOXES
      if (coop) front = subgroupBallot(front) != uvec4(0u);
#endif
      if (front) break;
    }
#ifdef MDS_COOPERATIVE_BOXES
    if (coop) {
      in_image = subgroupBallot(in_image) != uvec4(0u);
      csum = subgroupAdd(csum);
      n = subgroupAdd(n);
    }
#endif
    if (front) return MDS_CULL_CLASS_P;
    // No occupied cell projects into the image, or none covers a pixel of it (a cell's
    // rectangle overlaps the image's border only): frustum culled.
    if (!in_image || n == 0.0) return -1;
  }
  return mds_classify_occlusion(MDS_CULL_CLASS_P, true, csum / n, cull.thresholds.x,
                                cull.thresholds.y);
}

void subtract_voxels(uint i) {  // Sect. 4.4: remove meshlet/node i's particles from the volume
  for (uint r = meshlet_voxel_first[i]; r < meshlet_voxel_first[i + 1u]; ++r)
    atomicAdd(volume_counts[voxel_refs[r].x], -int(voxel_refs[r].y));
  counters.volume_dirty = 1u;
}


// The class of box `index` (node: mode 0, meshlet: mode 1) without the upward rule, in `c` of
// the lanes with `test`; -1: outside the image. Every lane of the subgroup calls this (no early
// return before it): boxes of more than kCooperativeTexels texels are tested by the subgroup.
int box_class(uint index, bool test) {
  bool nodes_mode = push.mode == 0u;
  int max_extent = nodes_mode ? kNodeExtent : kMeshletExtent;
  int c = -1;
  bool cooperative = false;
  if (test) {
    vec3 bmin = nodes_mode ? nodes[index].aabb_min : meshlets[index].aabb_min;
    vec3 bmax = nodes_mode ? nodes[index].aabb_max : meshlets[index].aabb_max;
    BoxTest b;
    c = box_setup(bmin, bmax, max_extent, b);
    if (c == kBoxTexelTest) {
#ifdef MDS_COOPERATIVE_BOXES
      cooperative = box_texels(b) > kCooperativeTexels;
#endif
      if (!cooperative)
        c = nodes_mode ? box_test(bmin, bmax, b, uvec2(nodes[index].occupancy_lo, nodes[index].occupancy_hi),
                                  int(index), false)
                       : box_test(bmin, bmax, b, uvec2(0u), -1, false);
    }
  }
#ifdef MDS_COOPERATIVE_BOXES
  // The lanes whose box still waits for the subgroup; the lowest one leads each round.
  uvec4 waiting = subgroupBallot(cooperative);
  while (subgroupBallotBitCount(waiting) > 0u) {
    uint leader = subgroupBallotFindLSB(waiting);
    uint j = subgroupShuffle(index, leader);
    vec3 bmin = nodes_mode ? nodes[j].aabb_min : meshlets[j].aabb_min;
    vec3 bmax = nodes_mode ? nodes[j].aabb_max : meshlets[j].aabb_max;
    BoxTest b;
    box_setup(bmin, bmax, max_extent, b);  // the leader's
    int r = nodes_mode ? box_test(bmin, bmax, b, uvec2(nodes[j].occupancy_lo, nodes[j].occupancy_hi), int(j), true)
                       : box_test(bmin, bmax, b, uvec2(0u), -1, true);
    if (gl_SubgroupInvocationID == leader) c = r;
    waiting[leader / 32u] &= ~(1u << (leader % 32u));  // its box is done
  }
#endif
  return c;
}

// A node the slices leave out (GpuNode::flags): marked once per view (the view start clears the
// classes), then neither tested nor counted. Its voxel counts are what the slices keep of it
// (none for a box outside them), so nothing is subtracted.
bool node_left_out(uint i) {
  if ((nodes[i].flags & kGpuNodeLeftOut) == 0u) return false;
  node_class[i] = uint(MDS_CULL_NODE_LEFT_OUT);
  return true;
}

// The class of node i after its test (c: box_class's), the node counters and, reaching O with
// kCullNodeDensity, the node's density subtraction. One invocation per node.
void store_node_class(uint i, int c, bool node_density) {
  uint prev = node_class[i];
  uint now = prev;
  if (prev != uint(MDS_CULL_CLASS_O)) {
    now = c < 0 ? uint(MDS_CULL_CLASS_O) : max(prev, uint(c));
    node_class[i] = now;
  }
  if (now != prev) {
    atomicAdd(counters.node_changed, 1u);
    if (now == uint(MDS_CULL_CLASS_O) && node_density) subtract_voxels(i);
  }
  atomicAdd(counters.node_class_count[now], 1u);
}

#ifdef MDS_COOPERATIVE_BOXES
// push.mode 2: one subgroup per node, every test shared by its lanes whatever its size. Node i
// is subgroup gl_SubgroupID of flat workgroup i / gl_NumSubgroups (the host dispatches
// ceil(nodes / (64 / subgroupSize)) workgroups; a device that runs smaller subgroups has more per
// workgroup, and the extra ones find no node). Mode 0 walks a workgroup's 64 nodes with its two
// subgroups, one large test after the other: on the H200 the nodes of a 1M store kept 46 warps
// busy, one per SM, through up to 16384 texels each (docs/results/classify.md).
void classify_node_per_subgroup(bool node_density) {
  uint wg = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
  uint i = wg * gl_NumSubgroups + gl_SubgroupID;
  if (i >= cull.counts.y) return;  // the whole subgroup
  if (node_left_out(i)) return;  // the whole subgroup: i is the subgroup's
  int c = -1;
  if (node_class[i] != uint(MDS_CULL_CLASS_O)) {
    vec3 bmin = nodes[i].aabb_min, bmax = nodes[i].aabb_max;
    BoxTest b;
    c = box_setup(bmin, bmax, kNodeExtent, b);
    if (c == kBoxTexelTest)
      c = box_test(bmin, bmax, b, uvec2(nodes[i].occupancy_lo, nodes[i].occupancy_hi), int(i), true);
  }
  if (subgroupElect()) store_node_class(i, c, node_density);
}
#endif

void main() {
  uint i = mds_flat_id();
  bool node_density = (cull.params.w & kCullNodeDensity) != 0u;
#ifdef MDS_COOPERATIVE_BOXES
  if (push.mode == 2u) {
    classify_node_per_subgroup(node_density);
    return;
  }
#endif
  if (push.mode == 0u) {
    bool valid = i < cull.counts.y && !node_left_out(i);
    uint prev = valid ? node_class[i] : uint(MDS_CULL_CLASS_O);
    int c = box_class(i, prev != uint(MDS_CULL_CLASS_O));  // every lane (cooperative boxes)
    if (valid) store_node_class(i, c, node_density);
    return;
  }
  bool valid = i < cull.counts.x;
  uint count = valid ? meshlets[i].particle_count : 0u;  // 0: empty slot of the streaming pool
  uint node = valid ? meshlets[i].node : 0u;
  uint prev = valid ? meshlet_class[i] : uint(MDS_CULL_CLASS_O);
  // A meshlet of a node in O is O without a test.
  bool in_o_node = count != 0u && prev != uint(MDS_CULL_CLASS_O) && node_class[node] == uint(MDS_CULL_CLASS_O);
  int c = box_class(i, count != 0u && prev != uint(MDS_CULL_CLASS_O) && !in_o_node);
  if (count == 0u) return;
  uint now = prev;
  if (prev != uint(MDS_CULL_CLASS_O)) {
    if (in_o_node) {
      now = uint(MDS_CULL_CLASS_O);
    } else {
      now = c < 0 ? uint(MDS_CULL_CLASS_O) : max(prev, uint(c));  // classes only move upward
    }
  }
  if (now != prev) {
    meshlet_class[i] = now;
    atomicAdd(counters.changed, 1u);
    if (now == uint(MDS_CULL_CLASS_O)) {
      if (!node_density) subtract_voxels(i);
      atomicAdd(counters.newly_occluded, 1u);
    }
  }
  atomicAdd(counters.class_count[now], 1u);
}
