// The occlusion-class-driven GPU cache; see stream_cache.h.
#include "render/streaming/stream_cache.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <tuple>

#include <glm/gtc/matrix_access.hpp>

#include "culling/culling_constants.h"
#include "render/scene.h"
#include "store/property_histogram.h"
#include "store/threshold.h"

namespace mds::render::streaming_gpu {

using mds::streaming::Residency;

namespace {
// The share of the box [lo, hi] that the slices keep, from a 6^3 grid of points at the centres
// of its cells (216 points: a plane through the box is placed to within 1/6 of its extent).
double kept_share(std::span<const store::Slice> slices, const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  constexpr int kSide = 6;
  int kept = 0;
  for (int k = 0; k < kSide; ++k)
    for (int j = 0; j < kSide; ++j)
      for (int i = 0; i < kSide; ++i) {
        const int idx[3] = {i, j, k};
        std::array<double, 3> p;
        for (int a = 0; a < 3; ++a) p[size_t(a)] = lo[size_t(a)] + (idx[a] + 0.5) / kSide * (hi[size_t(a)] - lo[size_t(a)]);
        kept += store::slices_keep(slices, p) ? 1 : 0;
      }
  return double(kept) / double(kSide * kSide * kSide);
}

// A node's voxel counts (voxel, count) made what the slices keep of it: all of them, none, or
// (cut) each count times the share of the voxel's part of the node's decoded box [lo, hi] they
// keep. h: the store's density grid.
void scale_voxel_counts(std::span<glm::uvec2> refs, store::SliceCover cover, std::span<const store::Slice> slices,
                        const std::array<double, 3>& lo, const std::array<double, 3>& hi, const store::FileHeader& h) {
  if (cover == store::SliceCover::all) return;
  const uint32_t dx = std::max(h.density_dims[0], 1u), dy = std::max(h.density_dims[1], 1u);
  for (glm::uvec2& ref : refs) {
    if (cover == store::SliceCover::none) {
      ref.y = 0;
      continue;
    }
    const uint32_t cell_index[3] = {ref.x % dx, (ref.x / dx) % dy, ref.x / (dx * dy)};
    std::array<double, 3> vlo = lo, vhi = hi;
    bool overlap = true;
    for (int a = 0; a < 3; ++a) {
      const double cell = (h.density_max[a] - h.density_min[a]) / std::max(h.density_dims[a], 1u);
      vlo[size_t(a)] = std::max(lo[size_t(a)], h.density_min[a] + cell_index[a] * cell);
      vhi[size_t(a)] = std::min(hi[size_t(a)], h.density_min[a] + (cell_index[a] + 1) * cell);
      overlap = overlap && vlo[size_t(a)] <= vhi[size_t(a)];
    }
    // Centres clamped into a border voxel lie outside it: then the node box stands for it.
    ref.y = uint32_t(std::llround(double(ref.y) * kept_share(slices, overlap ? vlo : lo, overlap ? vhi : hi)));
  }
}

// A node's voxel counts times `share` (a threshold's expected kept share of the node, from its
// property histogram): the total rounded, spread by largest remainder, so that a small share
// still counts its particles (rounding each voxel alone made most counts 0).
void scale_voxel_counts(std::span<glm::uvec2> refs, double share) {
  uint64_t total = 0;
  for (const glm::uvec2& r : refs) total += r.y;
  const uint64_t want = uint64_t(std::llround(double(total) * share));
  std::vector<std::pair<double, uint32_t>> rest;  // (fraction, ref index)
  rest.reserve(refs.size());
  uint64_t have = 0;
  for (uint32_t k = 0; k < refs.size(); ++k) {
    const double v = double(refs[k].y) * share;
    refs[k].y = uint32_t(std::floor(v));
    have += refs[k].y;
    rest.emplace_back(v - std::floor(v), k);
  }
  std::stable_sort(rest.begin(), rest.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  for (size_t k = 0; have < want && k < rest.size(); ++k, ++have) ++refs[rest[k].second].y;
}

store::SliceCover combine(store::SliceCover a, store::SliceCover b) {
  if (a == store::SliceCover::none || b == store::SliceCover::none) return store::SliceCover::none;
  if (a == store::SliceCover::all && b == store::SliceCover::all) return store::SliceCover::all;
  return store::SliceCover::some;
}
}  // namespace


Result<std::unique_ptr<StreamCache>> StreamCache::create(vk::Context& ctx, const store::StoreReader& reader,
                                                         const StreamSettings& settings, const glm::dvec3& origin) {
  std::unique_ptr<StreamCache> c(new StreamCache());
  c->reader_ = &reader;
  c->settings_ = settings;
  const store::FileHeader& h = reader.header();
  const auto nodes = reader.nodes();
  if (nodes.empty()) return make_error(Errc::invalid_argument, "{}: the store has no nodes", reader.path().string());
  const PoolLayout layout = pool_layout_for(h, settings.colors);
  std::vector<uint32_t> kept_prefix;  // with a threshold: store::kept_prefix_sums of its table
  if (settings.threshold) {
    if (!(h.flags & store::kFlagProperty))
      return make_error(Errc::invalid_argument, "--threshold {}: {} has no per-particle property (convert --property NAME)",
                        store::threshold_spec(*settings.threshold), reader.path().string());
    if (!(h.flags & store::kFlagPropertyHistogram))
      return make_error(Errc::invalid_argument, "--threshold {} with --gpu-budget: {} has no per-node property histograms "
                        "(a store converted before they were added); convert its input again, or render it without "
                        "--gpu-budget", store::threshold_spec(*settings.threshold), reader.path().string());
    c->property_kept_ = store::threshold_table(*settings.threshold, h.property_min, h.property_max);
    kept_prefix = store::kept_prefix_sums(c->property_kept_);
  }

  // Directory, sizes, voxel lists.
  c->directory_.resize(nodes.size());
  c->frames_.resize(nodes.size());
  c->node_bytes_.resize(nodes.size());
  c->node_meshlets_.resize(nodes.size());
  c->voxel_first_.assign(1, 0);
  c->cover_.assign(nodes.size(), uint8_t(store::SliceCover::all));
  c->left_out_.assign(nodes.size(), 0);
  c->measured_.assign(nodes.size(), 0);
  c->thinned_.assign(nodes.size(), 1.0f);
  uint64_t largest = 0, store_bytes = 0;
  uint32_t largest_node = 0;
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const store::NodeEntry& e = nodes[i];
    gpu::GpuNode& g = c->directory_[i];
    glm::dvec3 cmin(e.center_min[0], e.center_min[1], e.center_min[2]);
    glm::dvec3 cmax(e.center_max[0], e.center_max[1], e.center_max[2]);
    g.origin = glm::vec3(cmin - origin);
    g.step = glm::vec3((cmax - cmin) / double(store::kQuantMax));
    g.particle_count = e.particle_count;
    g.max_radius = e.max_radius;
    g.aabb_min = glm::vec3(cmin - origin - double(e.max_radius));
    g.aabb_max = glm::vec3(cmax - origin + double(e.max_radius));
    set_fine_occupancy(g, reader.occupancy(i).first<store::kOccupancyBytes>());  // the store's record (format.h)
    c->frames_[i] = node_frame(e);
    c->node_bytes_[i] = layout.node_bytes(e.particle_count, e.meshlet_count);
    c->node_meshlets_[i] = e.meshlet_count;
    store_bytes += e.payload_bytes;
    const size_t first_ref = c->voxel_refs_.size();
    for (const store::VoxelRef& v : reader.voxels(i)) c->voxel_refs_.push_back({v.voxel, v.count});
    c->voxel_first_.push_back(uint32_t(c->voxel_refs_.size()));
    if (!settings.slices.empty() || settings.threshold) {
      // What the slices and the threshold do to the node; its voxel counts become what it keeps:
      // none, all, or (cut) each voxel's count times the share of the voxel's part of the node
      // box the slices keep, times the share of the node's property values the threshold keeps
      // (its histogram; docs/streaming.md, "Thresholds").
      std::array<double, 3> lo, hi;
      store::decoded_box(e.center_min, e.center_max, lo, hi);
      const std::span<glm::uvec2> refs = std::span(c->voxel_refs_).subspan(first_ref);
      store::SliceCover cover = store::slices_cover(settings.slices, lo, hi);
      double share = cover == store::SliceCover::some ? kept_share(settings.slices, lo, hi) : 1.0;
      scale_voxel_counts(refs, cover, settings.slices, lo, hi, h);
      if (settings.threshold) {
        const store::PropertyCover pc = store::property_cover(reader.property_histograms()[i], kept_prefix);
        if (pc.cover == store::SliceCover::some) scale_voxel_counts(refs, pc.share);
        if (pc.cover == store::SliceCover::none)
          for (glm::uvec2& r : refs) r.y = 0;
        cover = combine(cover, pc.cover);
        share *= pc.share;
        c->thinned_[i] = float(pc.share);
      }
      c->cover_[i] = uint8_t(cover);
      if (cover == store::SliceCover::none) {
        c->left_out_[i] = 1;
        ++c->stats_.nodes_left_out;
        g.flags |= gpu::kGpuNodeLeftOut;
      }
      if (cover == store::SliceCover::some) {
        // Planned at the share the filters keep until it is read (then at what it keeps): at the
        // directory's size a thin slab's cut nodes filled a fraction of the pool. A slice keeps
        // whole meshlets where it keeps a region; a threshold thins every meshlet, and one keeps
        // its meshlet when any of its m particles passes: 1 - (1 - t)^m of them survive.
        const double mean = double(e.particle_count) / double(e.meshlet_count);
        const double t = double(c->thinned_[i]);
        const double meshlet_share = t > 0.0 && t < 1.0 ? share / t * (1.0 - std::pow(1.0 - t, mean)) : share;
        c->node_bytes_[i] = layout.node_bytes(uint64_t(std::ceil(share * e.particle_count)),
                                              uint64_t(std::ceil(meshlet_share * e.meshlet_count)));
      }
    }
  }
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    // The largest node that may be read, at its directory size (a cut node may keep all of it):
    // nodes the filters leave out are never read, so need no room.
    const uint64_t full = layout.node_bytes(nodes[i].particle_count, nodes[i].meshlet_count);
    if (!c->left_out_[i] && full > largest) largest = full, largest_node = i;
    // Packing fraction bound: n spheres of at most max_radius in the culling box (n times the
    // share a threshold keeps).
    const gpu::GpuNode& g = c->directory_[i];
    const glm::dvec3 ext = glm::dvec3(g.aabb_max) - glm::dvec3(g.aabb_min);
    const double r = nodes[i].max_radius, volume = ext.x * ext.y * ext.z;
    const double filled = c->thinned_[i] * double(nodes[i].particle_count) * (4.0 / 3.0) * 3.141592653589793 * r * r * r;
    c->dense_.push_back(volume > 0.0 && filled >= kDenseNodePacking * volume ? 1 : 0);
  }
  if (c->stats_.nodes_left_out == nodes.size())
    return make_error(Errc::invalid_argument, "{}: {} leaves no particle of the store", reader.path().string(),
                      settings.slices.empty()   ? "--threshold " + store::threshold_spec(*settings.threshold)
                      : settings.threshold ? "--slice with --threshold " + store::threshold_spec(*settings.threshold)
                                           : std::string("--slice"));
  c->max_meshlet_ = std::max<uint32_t>(1, std::min<uint32_t>(h.meshlet_size_max, store::kMaxMeshletParticles));
  if (settings.gpu_budget < largest)
    return make_error(Errc::budget,
                      "--gpu-budget {} cannot hold even one node: node {} of {} needs {} ({} particles, {} meshlets "
                      "in {}-byte pages); use at least {}",
                      format_bytes(settings.gpu_budget), largest_node, reader.path().string(), format_bytes(largest),
                      nodes[largest_node].particle_count, nodes[largest_node].meshlet_count, layout.page_bytes(),
                      format_bytes(largest));

  PoolScene ps = pool_scene_for(reader, layout, origin);
  const uint64_t staging = std::max<uint64_t>(settings.upload_bytes_per_frame, 2 * largest);
  // Every node resident at once, each at its directory size: a node the filters cut may keep
  // more than planned, and the pool must hold the largest node whole (a pool sized by the plans
  // of a threshold's thinned nodes was smaller than one node).
  uint64_t store_pages = 0;
  for (uint32_t i = 0; i < nodes.size(); ++i)
    if (!c->left_out_[i])  // never read
      store_pages += layout.node_bytes(nodes[i].particle_count, nodes[i].meshlet_count) / layout.page_bytes();
  MDS_ASSIGN_OR_RETURN(c->pool_, NodePool::create(ctx, layout, std::move(ps), uint32_t(nodes.size()),
                                                  settings.gpu_budget, store_pages, staging));
  if (c->pool_->budget().pool_bytes() < largest)
    return make_error(Errc::budget, "the device's maxStorageBufferRange ({}) limits the pool to {}, less than node {} ({})",
                      format_bytes(ctx.limits().maxStorageBufferRange), format_bytes(c->pool_->budget().pool_bytes()),
                      largest_node, format_bytes(largest));
  c->largest_node_bytes_ = largest;
  c->table_ = std::make_unique<mds::streaming::ResidencyTable>(c->node_bytes_, settings.policy);
  // The meshlet bounds of a node and its particle records are made by the reader thread that
  // decoded it (node_pool.h meshlet_bounds, pack_particles), not by the render loop: most of
  // NodePool::upload's per-node time on this VM (docs/streaming.md, "Placing a node"). frames_ and the pool's
  // scene are not changed after this; ~StreamCache stops the readers first.
  mds::streaming::IoOptions io = settings.io;
  const StreamCache* self = c.get();
  io.prepare = [self](uint32_t node, store::NodeData& data, mds::streaming::PreparedNode& out) -> Status {
    if (self->cover_[node] == uint8_t(store::SliceCover::some)) {
      // The slices or the threshold cut the node: keep its particles they keep (load_scene's filter).
      store::NodeData kept;
      filter_particles(data, self->filter(node), kept);
      data = std::move(kept);
      if (data.particle_count() == 0) return Status{};  // nothing kept: update() leaves the node out
    }
    MDS_TRY(meshlet_bounds(self->pool_->scene(), node, self->frames_[node], data, out.meshlet_bounds));
    pack_particles(data, out.particles);  // the staging copy becomes one memcpy
    return Status{};
  };
  MDS_ASSIGN_OR_RETURN(c->io_, mds::streaming::IoPool::create(reader, io));
  // With waves each wave is sampled before the next, so the window starts smaller.
  c->window_ = mds::streaming::ReadWindow(
      {.min = settings.wave_settle_frames > 0 ? std::max(1u, settings.wave_nodes) : 4u, .calm_frames = 3,
       .cap = settings.max_outstanding, .moving_waste_share = settings.moving_waste_share});
  if (settings.prior && !settings.prior->boxes.empty()) {
    // A series step: the nodes that match what the view before wanted are the first wave.
    c->carried_ = mds::streaming::carried_wanted(*settings.prior, mds::streaming::node_boxes(reader), kPriorMinIou);
    c->stats_.prior_wanted_nodes = settings.prior->wanted_count();
    c->stats_.carried_nodes = uint64_t(std::count(c->carried_.begin(), c->carried_.end(), uint8_t(1)));
    c->carried_wave_ = c->stats_.carried_nodes > 0;
  }
  c->placed_frame_.assign(nodes.size(), 0);
  c->requests_.assign(nodes.size(), 0);
  c->reads_.assign(nodes.size(), 0);
  c->first_request_.assign(nodes.size(), -1);
  c->placed_late_.assign(nodes.size(), 0);
  c->o_confirmed_.assign(nodes.size(), 0);

  CacheStats& s = c->stats_;
  s.enabled = true;
  s.gpu_budget_bytes = settings.gpu_budget;
  s.pool_bytes = c->pool_->budget().pool_bytes();
  s.pool_device_capped = c->pool_->device_capped();
  s.store_payload_bytes = store_bytes;
  s.nodes = nodes.size();
  return c;
}

StreamCache::~StreamCache() {
  io_.reset();  // its readers use frames_ and the pool's scene (IoOptions::prepare)
}

namespace {
// Waves at rest (StreamSettings::front_node_alone): a first node whose bounding sphere's radius
// is at least this share of half the image height (projected_size of set_view: a quarter of the
// image height) and whose spheres fill at least kDenseNodePacking of its box makes a wave alone.
// Porous / ablation stores of 1000-particle nodes: dense-block nodes fill 0.2-0.6 of their box,
// plume nodes of the ablation scene less than 0.1 (docs/streaming.md, "Wave size").
constexpr float kLoneFrontProjected = 0.5f;
// Conservative frustum test of a box: out when all 8 corners are outside one clip plane
// (-w <= x, y <= w, 0 <= z <= w). Each condition is linear in the corner, so "all 8 outside" is
// "the corner farthest inside is outside": a . c + |a| . e + a_w < 0 for the plane's row
// combination a, the box centre c and half extent e. 6 planes x 7 multiply-adds instead of
// 8 corners x 16: set_view tests every node of the store against the view and up to 3 look-ahead
// views, 0.36 ms per moving frame on this VM at 1443 nodes with the corners.
struct FrustumPlanes {
  glm::dvec4 a[6];
  explicit FrustumPlanes(const glm::dmat4& m) {
    const glm::dvec4 r0 = glm::row(m, 0), r1 = glm::row(m, 1), r2 = glm::row(m, 2), r3 = glm::row(m, 3);
    a[0] = r3 + r0;  // x >= -w
    a[1] = r3 - r0;  // x <= w
    a[2] = r3 + r1;
    a[3] = r3 - r1;
    a[4] = r2;       // z >= 0
    a[5] = r3 - r2;  // z <= w
  }
  bool box_in(const glm::dvec3& lo, const glm::dvec3& hi) const {
    const glm::dvec3 c = 0.5 * (lo + hi), e = 0.5 * (hi - lo);
    for (const glm::dvec4& p : a) {
      const glm::dvec3 n(p);
      if (glm::dot(n, c) + glm::dot(glm::abs(n), e) + p.w < 0.0) return false;
    }
    return true;
  }
};
}  // namespace

void StreamCache::set_view(const Camera& camera, double aspect, std::span<const Camera> next) {
  // Node boxes are relative to the scene origin: build the matrices relative to it too.
  const glm::dvec3 origin = glm::dvec3(reader_->header().bounds_min[0], reader_->header().bounds_min[1],
                                       reader_->header().bounds_min[2]);
  const glm::dmat4 view = view_matrix(camera, origin);
  const glm::dmat4 clip_from_world = projection_matrix(camera, aspect) * view;
  const glm::dvec3 eye = camera.eye - origin;
  const double tan_half = std::tan(glm::radians(camera.fov_y_deg) * 0.5);
  const double ortho_half_height = std::max(
      camera.ortho_half_height > 0.0 ? camera.ortho_half_height : glm::length(camera.target - camera.eye) * tan_half,
      1e-12);
  aspect_ = aspect;
  if (next.size() > size_t(kLookaheadFrames)) next = next.first(size_t(kLookaheadFrames));
  const bool known_moving =
      std::any_of(next.begin(), next.end(), [&](const Camera& c) { return !identical_cameras(c, camera); });
  // Restarts at rest, keeps its state while the camera moves (read_window.h).
  window_.new_view(known_moving);
  // Look-ahead while the camera moves: the known next views, else the views of the next frames
  // if the motion of the last one goes on (eye and target linearly; the near/far planes of this view).
  std::vector<FrustumPlanes> ahead;
  if (known_moving) {
    for (const Camera& c : next)
      if (glm::length(c.target - c.eye) > 0.0) ahead.emplace_back(projection_matrix(c, aspect) * view_matrix(c, origin));
  } else if (!next.empty()) {
    // The path holds this camera: nothing to look ahead to.
  } else if (has_view_ && window_.moving()) {
    const glm::dvec3 d_eye = camera.eye - last_camera_.eye, d_target = camera.target - last_camera_.target;
    if (glm::length(d_eye) + glm::length(d_target) > 0.0) {
      for (int k = 1; k <= kLookaheadFrames; ++k) {
        Camera c = camera;
        c.eye += double(k) * d_eye;
        c.target += double(k) * d_target;
        if (glm::length(c.target - c.eye) <= 0.0) continue;
        ahead.emplace_back(projection_matrix(c, aspect) * view_matrix(c, origin));
      }
    }
  }
  const FrustumPlanes frustum(clip_from_world);
  for (uint32_t i = 0; i < directory_.size(); ++i) {
    const glm::dvec3 lo(directory_[i].aabb_min), hi(directory_[i].aabb_max);
    const bool left_out = left_out_[i] != 0;  // in no view
    const bool in = !left_out && frustum.box_in(lo, hi);
    uint8_t frames_ahead = 0;
    for (const FrustumPlanes& a : ahead) frames_ahead += !left_out && a.box_in(lo, hi) ? 1 : 0;
    const bool is_ahead = !in && frames_ahead > 0;
    const glm::dvec3 nearest = glm::clamp(eye, lo, hi);
    const double dist = glm::length(nearest - eye);
    const double size = 0.5 * glm::length(hi - lo);
    // Radius in units of half the image height (orthographic: of the view's half height).
    const double projected = camera.ortho ? size / ortho_half_height : size / std::max(dist * tan_half, 1e-12);
    const bool was_in = table_->node(i).in_frustum && has_view_;
    table_->set_view(i, float(dist), float(projected), in);
    table_->set_ahead(i, frames_ahead);
    // Outside: O, except a look-ahead node (P, so that the occlusion policy evicts it after the
    // nodes no view wants; it is not wanted until it enters the frustum).
    if (!in) table_->set_class(i, is_ahead ? MDS_CULL_CLASS_P : MDS_CULL_CLASS_O);
    else if (!was_in) table_->set_class(i, MDS_CULL_CLASS_P);  // entering the frustum: wanted
  }
  last_camera_ = camera;
  has_view_ = true;
  plan_stale_ = true;
  exhausted_ = false;
}

void StreamCache::set_classes(std::span<const uint32_t> classes, bool mature) {
  const size_t n = std::min(classes.size(), directory_.size());
  for (uint32_t i = 0; i < n; ++i) {
    if (!table_->node(i).in_frustum) continue;  // stays O
    const uint8_t g = uint8_t(std::min<uint32_t>(classes[i], MDS_CULL_CLASS_O));
    const uint8_t c = table_->node(i).cls;
    uint8_t next = mature ? g : std::max(c, g);
    if (g == MDS_CULL_CLASS_O) {
      o_confirmed_[i] = frame_;
    } else if (!mature && c == MDS_CULL_CLASS_O && frame_ > o_confirmed_[i] + settings_.occluded_hold_frames) {
      next = g;  // an O no iteration confirmed for occluded_hold_frames frames expires
    }
    if (next != c) plan_stale_ = true;
    table_->set_class(i, next);
  }
}

mds::streaming::PriorView StreamCache::prior_view() const {
  mds::streaming::PriorView p;
  p.boxes = mds::streaming::node_boxes(*reader_);
  p.wanted.resize(p.boxes.size());
  for (uint32_t i = 0; i < p.wanted.size(); ++i) p.wanted[i] = demanded(i) ? 1 : 0;
  return p;
}

bool StreamCache::filling() const { return pool_->budget().free_bytes() >= largest_node_bytes_; }
bool StreamCache::holds_wanted() const { return stats_.wanted_bytes <= pool_->budget().pool_bytes(); }

bool StreamCache::demanded(uint32_t i) const {
  const auto& n = table_->node(i);
  return n.in_frustum && n.cls != MDS_CULL_CLASS_O && !n.failed;
}

Status StreamCache::evict_for(VkCommandBuffer cmd, uint32_t incoming, uint64_t frame, bool& stalled) {
  const uint64_t free = pool_->budget().free_bytes();
  auto victims = table_->choose_victims(node_bytes_[incoming], free, frame, incoming);
  if (!victims.ok()) {
    stalled = true;
    return {};
  }
  for (uint32_t v : victims.value()) {
    const uint8_t cls = table_->node(v).cls;
    MDS_TRY(pool_->evict(cmd, v));
    MDS_TRY(table_->mark_evicted(v));
    live_meshlets_ -= node_meshlets_[v];
    ++stats_.evictions[std::min<uint8_t>(cls, 3)];
  }
  stalled = false;
  return {};
}

bool StreamCache::keep_late_arrival(uint32_t i, const store::NodeData& data, uint64_t uploaded, uint64_t frame) const {
  if (!settings_.keep_late_arrivals || !table_->node(i).in_frustum) return false;
  const uint64_t staged = pool_->upload_bytes(data);
  if ((uploaded > 0 && uploaded + staged > settings_.upload_bytes_per_frame) || staged > pool_->staging_free()) return false;
  auto victims = table_->choose_victims(node_bytes_[i], pool_->budget().free_bytes(), frame, i);
  if (!victims.ok()) return false;
  for (uint32_t v : *victims)
    if (!table_->evicted_before(v, i, frame)) return false;
  return true;
}

Result<CacheFrame> StreamCache::update(VkCommandBuffer cmd, uint64_t frame) {
  CacheFrame out;
  frame_ = frame;
  const uint32_t n_nodes = uint32_t(directory_.size());
  exhausted_ = false;  // recomputed every frame: the pool cannot hold what this frame wants

  // Finished reads.
  while (auto done = io_->try_pop()) {
    plan_stale_ = true;
    const uint32_t i = done->node;
    stats_.bytes_read += done->compressed_bytes;
    ++reads_[i];
    if (!done->status.ok()) {
      stats_.errors.push_back(done->status.error().message);
      ++stats_.nodes_failed;
      MDS_TRY(table_->mark_failed(i));
      std::erase(requested_, i);
      continue;
    }
    if (cover_[i] == uint8_t(store::SliceCover::some)) {
      measured_[i] = 1;
      if (done->data.particle_count() == 0) {
        // The filters cut every particle of the node (its box straddles the slices, or none of
        // its values in range passes the threshold): never read again,
        // and no longer classified (the renderer copies the flag to the device's directory).
        left_out_[i] = 1;
        ++stats_.nodes_left_out;
        directory_[i].flags |= gpu::kGpuNodeLeftOut;
        out.left_out.push_back(i);
        MDS_TRY(table_->mark_failed(i));
        std::erase(requested_, i);
        continue;
      }
      // A threshold's share of the node is known now (the waves' coverage counts it).
      if (settings_.threshold)
        thinned_[i] = float(double(done->data.particle_count()) / double(reader_->nodes()[i].particle_count));
      // What the filters kept takes fewer pages than the directory's counts planned: from now on
      // the node is planned at its size (every read of it keeps the same particles).
      const uint64_t bytes = pool_->layout().node_bytes(done->data.particle_count(), done->data.meshlet_size.size());
      if (bytes != node_bytes_[i]) MDS_TRY(table_->set_bytes(i, bytes));
      node_bytes_[i] = bytes;
      node_meshlets_[i] = uint32_t(done->data.meshlet_size.size());  // live_meshlets_ counts what is placed
    }
    ready_.emplace(i, std::move(*done));
  }

  // Use: the resident nodes this frame draws are kept by the placement below (touch = drawn now),
  // and so are resident look-ahead nodes, except against nodes fetched before them (wanted ones:
  // ResidencyTable::displaces).
  for (const uint32_t i : table_->resident_nodes())
    if (demanded(i) || table_->fetchable(i)) table_->touch(i, frame);
  // Class-blind policies keep every resident node in the frustum in use.
  if (table_->policy() != mds::streaming::Policy::occlusion)
    for (const uint32_t i : table_->resident_nodes())
      if (table_->wanted(i)) table_->touch(i, frame);

  // Place finished reads, front first, within the frame's upload budget.
  pool_->begin_frame();
  std::vector<uint32_t> order;
  for (const auto& [i, c] : ready_) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return std::make_tuple(!table_->fetchable(a), table_->node(a).distance, a) <
           std::make_tuple(!table_->fetchable(b), table_->node(b).distance, b);
  });
  uint32_t occluded = 0, arrived = uint32_t(order.size());
  for (uint32_t i : order) {
    auto it = ready_.find(i);
    const bool late = !table_->fetchable(i);
    if (late) {  // became O (or left the frustum) while it was read
      if (table_->node(i).in_frustum) ++occluded;  // found O meanwhile (not: left the frustum)
      if (!keep_late_arrival(i, it->second.data, out.bytes_uploaded, frame)) {
        MDS_TRY(table_->mark_cancelled(i));
        std::erase(requested_, i);
        ready_.erase(it);
        continue;
      }
    }
    const uint64_t staged = pool_->upload_bytes(it->second.data);
    if (out.bytes_uploaded > 0 && out.bytes_uploaded + staged > settings_.upload_bytes_per_frame) break;
    if (staged > pool_->staging_free()) break;
    bool stalled = false;
    MDS_TRY(evict_for(cmd, i, frame, stalled));
    if (stalled) {  // the pool is full of nodes this frame draws: give the read up
      out.upload_stall = true;
      exhausted_ = true;
      MDS_TRY(table_->mark_cancelled(i));
      std::erase(requested_, i);
      ready_.erase(it);
      continue;
    }
    Status st = pool_->upload(i, frames_[i], it->second.data, it->second.prepared.meshlet_bounds,
                              it->second.prepared.particles);
    if (!st.ok()) {
      if (st.error().code == Errc::budget) break;  // staging full: next frame
      stats_.errors.push_back(reader_->path().string() + ": " + st.error().message);
      ++stats_.nodes_failed;
      MDS_TRY(table_->mark_failed(i));
    } else {
      MDS_TRY(table_->mark_loaded(i));
      table_->touch(i, frame);
      placed_frame_[i] = frame;
      placed_late_[i] = late;  // counted as waste on arrival, not again after the settle frames
      if (late) ++stats_.late_arrivals_kept;
      live_meshlets_ += node_meshlets_[i];
      ++out.nodes_uploaded;
      out.bytes_uploaded += staged;
    }
    std::erase(requested_, i);
    ready_.erase(it);
  }
  pool_->end_frame(cmd);
  out.copy_regions = pool_->take_copy_regions();
  // Demand of this frame: hits and misses, counted after the placement because the frame draws
  // after it (the uploads are recorded into the same command buffer before the draw): a node
  // placed now is drawn by this frame.
  stats_.wanted_nodes = stats_.wanted_bytes = 0;
  for (uint32_t i = 0; i < n_nodes; ++i) {
    if (!demanded(i)) continue;
    ++stats_.wanted_nodes;
    stats_.wanted_bytes += node_bytes_[i];
    const bool resident = table_->node(i).residency == Residency::resident;
    if (settings_.record_trace) {
      out.wanted.push_back(i);
      out.wanted_resident.push_back(resident ? 1 : 0);
    }
    if (resident)
      ++out.hits;
    else
      ++out.misses;
  }
  stats_.cache_hits += out.hits;
  stats_.cache_misses += out.misses;
  if (out.upload_stall) ++stats_.upload_stalls;
  stats_.nodes_loaded += out.nodes_uploaded;
  stats_.bytes_uploaded += out.bytes_uploaded;

  if (out.nodes_uploaded > 0 || !ready_.empty()) plan_stale_ = true;
  // Cancel queued reads of nodes no longer wanted.
  for (size_t k = 0; k < requested_.size();) {
    const uint32_t i = requested_[k];
    if (!table_->fetchable(i) && !ready_.count(i) && io_->cancel(i)) {
      MDS_TRY(table_->mark_cancelled(i));
      requested_.erase(requested_.begin() + std::ptrdiff_t(k));
    } else {
      ++k;
    }
  }
  // Prefetch in the policy's order, a window at a time.
  bool pending = false;
  // Waste = a read that arrived for a node found occluded meanwhile (a read of a node that left the
  // frustum is the camera's motion, not a window too wide).
  // Waves at rest: a wave is over when nothing is in flight and its nodes have been resident for
  // wave_settle_frames frames (sampled as occluders); a node of it that turned O by then is waste.
  const uint64_t settle = settings_.wave_settle_frames;
  const bool waves = settle > 0 && table_->policy() == mds::streaming::Policy::occlusion && !window_.moving();
  bool wave_open = false;
  if (waves) {
    wave_open = !requested_.empty();
    for (const uint32_t i : table_->resident_nodes()) {
      const auto& n = table_->node(i);
      if (placed_late_[i] || frame > placed_frame_[i] + settle) continue;
      if (frame == placed_frame_[i] + settle && n.in_frustum && n.cls == MDS_CULL_CLASS_O) ++occluded;
      if (frame < placed_frame_[i] + settle && demanded(i)) wave_open = true;
    }
  }
  window_.end_frame(arrived, occluded);
  const size_t window = window_.size();
  if (wave_open) {
    pending = true;  // the next wave waits for the classes that saw this one
  } else if (!plan_stale_ && plan_idle_ && requested_.empty() && ready_.empty()) {
    exhausted_ = plan_exhausted_;  // nothing changed since a plan that requested nothing
  } else if (requested_.size() < window) {
    plan_stale_ = false;
    // The first candidates in fetch order: the plan submits at most the window's cap and skips
    // only nodes a reader is still busy with (a few), so it rarely needs more; one that runs
    // past them continues in the whole order. (A full sort of every candidate was most of the
    // cache's update at 11,300 nodes.)
    const size_t limit = size_t(window_.settings().cap) + 64;
    // The first plan of a series step at rest: the wave is the nodes that match what the view
    // before wanted, front to back, all of them that the pool has room for: one layer of
    // occluders where the frame before had its visible surface, sampled before anything behind
    // it is chosen. Neither the window and its cap, nor the coverage, nor a lone front node
    // bounds it: it is the working set of the view before, which that pool held.
    const bool carried = waves && carried_wave_;
    std::vector<uint32_t> order_next = table_->prefetch_order(carried ? SIZE_MAX : limit);
    bool truncated = !carried && order_next.size() == limit;
    if (carried) std::erase_if(order_next, [&](uint32_t i) { return carried_[i] == 0; });
    carried_wave_ = false;  // one wave, in the store's first view
    std::vector<uint64_t> evictable = table_->evictable_bytes_in_order(order_next, frame);
    uint64_t planned = 0;
    double coverage = 0.0;  // images covered by this wave's bounding spheres (screen_share)
    double rank = 0.0;  // this frame's order (a re-submitted queued node gets its new rank)
    size_t skipped = 0;  // candidates passed over (a reader busy with them): still absent
    // The readers wake once, after the plan; until then a reader that finishes a read waits for
    // the pool's lock (tens of us; the rare fall-back to the whole order below, up to about a ms
    // at 11,300 nodes).
    mds::streaming::IoPool::Batch batch(*io_);
    for (size_t k = 0;; ++k) {
      if (k == order_next.size()) {
        if (!truncated) break;
        // The whole order, less the nodes requested above (their keys did not change): the
        // skipped ones come first, then the candidates not yet seen.
        order_next = table_->prefetch_order();
        evictable = table_->evictable_bytes_in_order(order_next, frame);
        truncated = false;
        k = skipped;
        if (k >= order_next.size()) break;
      }
      const uint32_t i = order_next[k];
      // Room: free pages plus what this node may displace (never a node fetched before it).
      const uint64_t room = pool_->budget().free_bytes() + evictable[k];
      if (planned + node_bytes_[i] > room) {
        exhausted_ = true;
        break;
      }
      // A wave at rest is full with the window's nodes and wave_coverage images of them.
      const bool full = !carried && requested_.size() >= window && !(waves && coverage < settings_.wave_coverage);
      if (full || (!carried && requested_.size() >= window_.settings().cap)) {
        pending = true;
        break;
      }
      if (!batch.submit(i, rank)) {
        ++skipped;
        continue;
      }
      ++out.reads_requested;
      rank += 1.0;
      planned += node_bytes_[i];
      MDS_TRY(table_->mark_requested(i));
      ++requests_[i];
      if (first_request_[i] < 0) first_request_[i] = int64_t(frame);
      requested_.push_back(i);
      // A node a threshold thins covers its share of what its bounding sphere would.
      if (waves) coverage += thinned_[i] * mds::streaming::screen_share(table_->node(i).projected_size, aspect_);
      if (waves && !carried && settings_.front_node_alone && rank == 1.0 && dense_[i] &&
          table_->node(i).projected_size >= kLoneFrontProjected) {
        pending = true;  // a large dense node first: alone in its wave (StreamSettings::front_node_alone)
        break;
      }
    }
  } else {
    pending = true;
  }
  if (!plan_stale_ && !pending && !wave_open) {
    plan_idle_ = out.reads_requested == 0;
    plan_exhausted_ = exhausted_;
  } else {
    plan_idle_ = false;
  }
  stats_.budget_exhausted = exhausted_;
  out.exhausted = exhausted_;
  out.complete = requested_.empty() && ready_.empty() && !pending;
  if (out.complete && !exhausted_) {
    // Every demanded node must be resident now (or failed).
    for (uint32_t i = 0; i < n_nodes && out.complete; ++i)
      if (table_->wanted(i) && table_->node(i).residency != Residency::resident) out.complete = false;
  }
  return out;
}

Result<std::vector<uint64_t>> StreamCache::node_device_bytes_kept() const {
  std::vector<uint64_t> bytes = node_bytes_;
  store::NodeData data, kept;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < bytes.size(); ++i) {
    if (left_out_[i]) bytes[i] = 0;
    if (cover_[i] != uint8_t(store::SliceCover::some) || measured_[i] || left_out_[i]) continue;
    MDS_TRY(reader_->read_node(i, data, scratch));
    filter_particles(data, filter(i), kept);
    bytes[i] = kept.particle_count() ? pool_->layout().node_bytes(kept.particle_count(), kept.meshlet_size.size()) : 0;
  }
  return bytes;
}

ParticleFilter StreamCache::filter(uint32_t node) const {
  return ParticleFilter{{}, settings_.slices, frames_[node].center_min, frames_[node].center_max, property_kept_};
}

void StreamCache::kept_density(culling::DensityVolume& v) const {
  if (settings_.slices.empty() && !settings_.threshold) return;
  std::fill(v.counts.begin(), v.counts.end(), 0);
  for (const glm::uvec2& r : voxel_refs_)
    if (r.x < v.counts.size()) v.counts[r.x] = int32_t(std::min<uint64_t>(uint64_t(v.counts[r.x]) + r.y, INT32_MAX));
}

std::vector<NodeLogEntry> StreamCache::node_log() const {
  std::vector<NodeLogEntry> log(table_->size());
  for (uint32_t i = 0; i < log.size(); ++i) {
    const auto& n = table_->node(i);
    NodeLogEntry& e = log[i];
    e.requests = requests_[i];
    e.reads = reads_[i];
    e.first_request_frame = first_request_[i];
    e.carried = !carried_.empty() && carried_[i] != 0;
    e.loaded = n.ever_loaded;
    e.resident = n.residency == Residency::resident;
    e.in_frustum = n.in_frustum;
    e.wanted = demanded(i);
    e.cls = n.cls;
  }
  return log;
}

CacheStats StreamCache::stats() const {
  CacheStats s = stats_;
  s.gpu_peak_bytes = pool_->budget().peak_bytes();
  s.resident_bytes = pool_->budget().used_bytes();
  s.nodes_resident = table_->resident_count();
  s.nodes_never_loaded = table_->never_loaded_count();
  s.in_flight = requested_.size() - ready_.size();
  return s;
}

}  // namespace mds::render::streaming_gpu
