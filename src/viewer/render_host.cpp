#include "viewer/render_host.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>

#include "render/ambient_occlusion_setup.h"
#include "render/culling/density_volume.h"
#include "core/frame_selection.h"
#include "render/scene.h"

namespace mds::viewer {

RenderHost::RenderHost() {
  const char* e = std::getenv("MDSTREAM_SERIES_PRELOAD");
  preload_enabled_ = !(e && std::string(e) == "0");
}

Result<std::unique_ptr<RenderHost>> RenderHost::open(vk::Context& ctx, const ViewerOptions& options) {
  std::unique_ptr<RenderHost> h(new RenderHost());
  h->ctx_ = &ctx;
  h->settings_ = options.render;
  h->stream_ = options.stream;
  h->stream_.gpu_budget = options.gpu_budget;
  h->hide_types_ = options.hide_types;
  h->type_radii_ = options.type_radii;
  h->stream_.threshold = options.threshold;  // in memory too; streaming, the cache applies it
  h->type_colors_ = options.type_colors;
  h->color_by_ = options.render.color_by;
  h->cell_mode_ = options.cell;
  h->store_arg_ = options.store;
  std::string store = options.store;
  if (store::is_series_path(options.store)) {
    MDS_ASSIGN_OR_RETURN(store::Series series, store::read_series(options.store));
    auto sel = parse_frame_selection(options.series_frames);
    if (!sel.ok()) return make_error(Errc::invalid_argument, "--series-frames {}", sel.error().message);
    auto picked = select_frames(*sel, int64_t(series.frames.size()));
    if (!picked.ok())
      return make_error(Errc::invalid_argument, "{}: --series-frames {}", options.store, picked.error().message);
    MDS_ASSIGN_OR_RETURN(h->look_, render::series_look(series, *picked));
    if (h->color_by_.axis == render::kColorByColor && !h->look_.has_color)  // as render refuses it
      return make_error(Errc::invalid_argument,
                        "--color-by color: not every picked frame of {} has per-particle colours (convert them with "
                        "--color)",
                        options.store);
    MDS_ASSIGN_OR_RETURN(h->cell_mode_, render::series_cell_mode(h->cell_mode_, h->look_, options.store));
    h->series_frames_ = std::move(*picked);
    store = series.frames[size_t(h->series_frames_.front())].path.string();
    h->series_ = std::move(series);
  }
  MDS_ASSIGN_OR_RETURN(h->reader_, store::StoreReader::open(store));
  MDS_TRY(h->resolve_colors(*h->reader_, h->settings_));
  // Ambient occlusion: the first store's choice (auto), kept for every frame of a series.
  MDS_ASSIGN_OR_RETURN(const render::AoChoice ao, render::resolve_ao(options.ao, *h->reader_));
  h->settings_.ao_radius = ao.on ? ao.radius : 0.0;
  h->settings_.ao_strength = ao.strength;
  h->ao_radius_ = ao.radius;
  h->ao_strength_ = options.ao.strength > 0.0 ? options.ao.strength : 1.0;
  MDS_ASSIGN_OR_RETURN(Loaded loaded, h->load(*h->reader_, options.slices));
  h->take(std::move(loaded));
  return h;
}

Status RenderHost::resolve_colors(const store::StoreReader& reader, render::RenderSettings& rs) const {
  const store::FileHeader& header = reader.header();
  render::ColorBy c = series_ ? render::series_color_by(color_by_, look_) : color_by_;  // one choice for every frame
  MDS_TRY(render::resolve_color_by(c, header.property_name, (header.flags & store::kFlagProperty) != 0,
                                   (header.flags & store::kFlagColor) != 0, reader.path().string()));
  if (series_ && !c.by_type()) {
    const glm::dvec2 range = render::series_color_range(c, look_);
    c.lo = range.x;
    c.hi = range.y;
  }
  auto colors = render::resolve_type_colors(reader.types(), type_colors_);
  if (!colors) return make_error(Errc::invalid_argument, "--type-color: {}", colors.error().message);
  rs.color_by = c;
  rs.type_colors_srgb = std::move(*colors);
  MDS_ASSIGN_OR_RETURN(rs.cell, render::resolve_cell(cell_mode_, reader));  // each frame of a series its own
  return {};
}

const store::SeriesFrame* RenderHost::series_entry() const {
  return series_ ? &series_->frames[size_t(series_frames_[series_pos_])] : nullptr;
}

Result<RenderHost::Prepared> RenderHost::prepare(size_t position, const std::vector<store::Slice>& slices) const {
  const store::SeriesFrame& f = series_->frames[size_t(series_frames_[position])];
  auto opened = store::StoreReader::open(f.path);
  if (!opened.ok()) {
    Error e = opened.error();
    e.message = fmt::format("{}: frame {} ({}): {}", store_arg_, series_frames_[position], f.name, e.message);
    return e;
  }
  Prepared p;
  p.reader = std::move(*opened);
  MDS_ASSIGN_OR_RETURN(p.loaded, load(*p.reader, slices));
  return p;
}

void RenderHost::preload(size_t position) {
  if (!preload_enabled_ || !series_ || position >= series_frames_.size() || position == series_pos_) return;
  if (preloading(position)) return;
  if (preload_.valid()) preload_.wait();  // one load at a time
  preload_pos_ = position;
  preload_slices_ = stream_.slices;
  preload_ = std::async(std::launch::async, [this, position, slices = preload_slices_] { return prepare(position, slices); });
}

bool RenderHost::preload_ready(size_t position) const {
  return preload_.valid() && preload_pos_ == position &&
         preload_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

Status RenderHost::set_series_position(size_t position) {
  if (!series_ || position >= series_frames_.size())
    return make_error(Errc::invalid_argument, "no series position {}", position);
  // The preloaded store when it is this position's with these slices, else loaded now; the
  // current frame stays until this worked.
  Result<Prepared> prepared = preloading(position) ? preload_.get() : prepare(position, stream_.slices);
  if (!prepared.ok()) return prepared.error();
  std::unique_ptr<store::StoreReader> reader = std::move(prepared->reader);
  Loaded loaded = std::move(prepared->loaded);
  render::RenderSettings rs = settings_;
  MDS_TRY(resolve_colors(*reader, rs));
  carry_prior();
  renderer_.reset();  // before the scene and the store it drew go
  std::unique_ptr<store::StoreReader> before = std::move(reader_);
  reader_ = std::move(reader);
  const store::StoreReader* kept = before.get();
  take(std::move(loaded));
  const render::RenderSettings settings_before = settings_;
  settings_.color_by = rs.color_by;
  settings_.type_colors_srgb = rs.type_colors_srgb;
  settings_.cell = rs.cell;  // this frame's cell
  Status st = recreate(settings_.width, settings_.height);
  if (st.ok()) {
    series_pos_ = position;
    return st;
  }
  // Back to the frame before (its store was kept open).
  reader_ = std::move(before);
  settings_ = settings_before;
  if (auto back = load(*kept, stream_.slices); back) {
    take(std::move(*back));
    (void)recreate(settings_.width, settings_.height);
  }
  return st;
}

Result<RenderHost::Loaded> RenderHost::load(const store::StoreReader& reader,
                                            const std::vector<store::Slice>& slices) const {
  Loaded l;
  l.slices = slices;
  MDS_ASSIGN_OR_RETURN(const render::SceneOptions so,
                       render::resolve_scene_options(reader, hide_types_, type_radii_, slices, streaming(),
                                                     stream_.threshold));
  l.shown_types = so.shown_types;
  l.type_radius = so.type_radius;
  // Bounds of the particle centres and the largest radius, from the node directory (the
  // in-memory scene replaces them with its decoded bounds).
  l.bounds.min = glm::dvec3(1e300);
  l.bounds.max = glm::dvec3(-1e300);
  for (const store::NodeEntry& n : reader.nodes()) {
    l.bounds.min = glm::min(l.bounds.min, glm::dvec3(n.center_min[0], n.center_min[1], n.center_min[2]));
    l.bounds.max = glm::max(l.bounds.max, glm::dvec3(n.center_max[0], n.center_max[1], n.center_max[2]));
    l.bounds.radius_max = std::max(l.bounds.radius_max, double(n.max_radius));
    Box b;
    for (int k = 0; k < 3; ++k) {
      b.min[k] = n.center_min[k] - n.max_radius;
      b.max[k] = n.center_max[k] + n.max_radius;
    }
    l.node_boxes.push_back(b);
  }
  if (!streaming()) {
    MDS_ASSIGN_OR_RETURN(render::SceneData scene, render::load_scene(reader, so));
    l.scene = std::make_unique<render::SceneData>(std::move(scene));
    l.bounds = l.scene->bounds;
    MDS_ASSIGN_OR_RETURN(render::culling::DensityVolume vol, render::culling::density_from_store(reader, *l.scene));
    if (l.scene->left_out()) vol = render::culling::density_on_grid(*l.scene, std::move(vol));
    if (l.scene->left_out() || !so.type_radius.empty()) {
      // Particles left out or other radii: the scene's nodes and boxes (nodes gone, shrunk or grown).
      l.node_boxes.clear();
      for (const gpu::GpuNode& g : l.scene->nodes) {
        Box b;
        for (int k = 0; k < 3; ++k) {
          b.min[k] = l.scene->origin[k] + double(g.aabb_min[k]);
          b.max[k] = l.scene->origin[k] + double(g.aabb_max[k]);
        }
        l.node_boxes.push_back(b);
      }
    }
    l.cull_scene = std::make_shared<const render::culling::CullScene>(render::culling::cull_scene(*l.scene, vol));
    l.density = std::make_shared<const render::culling::DensityVolume>(std::move(vol));
  }
  return l;
}

void RenderHost::take(Loaded&& l) {
  stream_.slices = std::move(l.slices);
  shown_types_ = std::move(l.shown_types);
  type_radius_ = std::move(l.type_radius);
  scene_ = std::move(l.scene);
  density_ = std::move(l.density);
  cull_scene_ = std::move(l.cull_scene);
  bounds_ = l.bounds;
  node_boxes_ = std::move(l.node_boxes);
}

bool RenderHost::has_colors() const {
  return series_ ? look_.has_color : (reader_->header().flags & store::kFlagColor) != 0;
}
bool RenderHost::has_property() const {
  return series_ ? look_.has_property : (reader_->header().flags & store::kFlagProperty) != 0;
}

Status RenderHost::set_color_by(const render::ColorBy& color_by, bool* remade) {
  if (remade) *remade = false;
  const render::ColorBy before = color_by_;
  color_by_ = color_by;
  render::RenderSettings rs = settings_;
  Status st = resolve_colors(*reader_, rs);
  // Streaming, the pool holds the colours only where they are drawn (StreamSettings::colors):
  // into or out of them the renderer is made again, with a new cache (the slices' way).
  const bool new_pool = st.ok() && streaming() && rs.color_by.by_color() != settings_.color_by.by_color();
  if (st.ok() && renderer_ && !new_pool) st = renderer_->set_color_by(rs.color_by);
  if (!st.ok()) {
    color_by_ = before;
    return st;
  }
  const render::ColorBy shown = settings_.color_by;
  settings_.color_by = rs.color_by;
  if (new_pool) {
    if (remade) *remade = true;
    if (Status made = recreate(settings_.width, settings_.height); !made.ok()) {
      color_by_ = before;
      settings_.color_by = shown;
      MDS_TRY(recreate(settings_.width, settings_.height));
      return made;
    }
  }
  return {};
}

Status RenderHost::set_cell_shown(bool on) {
  if (on && series_ && !look_.has_cell)
    return make_error(Errc::invalid_argument, "not every picked frame of {} has a simulation cell", store_arg_);
  if (on && !reader_->cell())
    return make_error(Errc::invalid_argument, "{} has no simulation cell", reader_->path().filename().string());
  // On: each store's own cell (every frame of a series has one).
  const std::optional<SimulationCell> cell = on ? reader_->cell() : std::nullopt;
  if (renderer_) MDS_TRY(renderer_->set_cell(cell));
  cell_mode_ = on ? render::CellMode::on : render::CellMode::off;
  settings_.cell = cell;
  return {};
}

Status RenderHost::set_slices(const std::vector<store::Slice>& slices) {
  MDS_ASSIGN_OR_RETURN(Loaded loaded, load(*reader_, slices));  // the current scene stays until this worked
  std::vector<store::Slice> before = stream_.slices;
  carry_prior();
  renderer_.reset();  // before the scene it drew goes
  take(std::move(loaded));
  Status st = recreate(settings_.width, settings_.height);
  if (st.ok()) return st;
  // Streaming: the cache refuses slices that leave no node. Back to the slices before.
  auto back = load(*reader_, before);
  if (back) {
    take(std::move(*back));
    (void)recreate(settings_.width, settings_.height);
  }
  return st;
}

Status RenderHost::set_threshold(const std::optional<store::Threshold>& threshold) {
  // A series' preload reads the threshold on its thread (load) and was made with the one before:
  // wait for it and drop it (the next step loads its frame with this threshold).
  if (preload_.valid()) preload_.wait();
  preload_ = {};
  const std::optional<store::Threshold> before = stream_.threshold;
  stream_.threshold = threshold;
  Result<Loaded> loaded = load(*reader_, stream_.slices);  // the current scene stays until this worked
  if (!loaded) {
    stream_.threshold = before;
    return loaded.error();
  }
  carry_prior();
  renderer_.reset();  // before the scene it drew goes
  take(std::move(*loaded));
  Status st = recreate(settings_.width, settings_.height);
  if (st.ok()) return st;
  // Streaming: the cache refuses a threshold that leaves no node. Back to the one before.
  stream_.threshold = before;
  if (auto back = load(*reader_, stream_.slices); back) {
    take(std::move(*back));
    (void)recreate(settings_.width, settings_.height);
  }
  return st;
}

uint64_t RenderHost::meshlets() const {
  if (scene_) return scene_->meshlets.size();
  uint64_t m = 0;
  for (const store::NodeEntry& n : reader_->nodes()) m += n.meshlet_count;
  return m;
}

void RenderHost::carry_prior() {
  if (renderer_ && streaming() && stream_.carry_view) prior_ = renderer_->prior_view();
}

Status RenderHost::recreate(uint32_t width, uint32_t height) {
  carry_prior();
  renderer_.reset();
  settings_.width = width;
  settings_.height = height;
  render::RenderSettings rs = settings_;
  if (rs.cull && density_) {
    rs.density = density_;
    rs.cull_scene = cull_scene_;  // made with the scene (load)
  }
  if (streaming()) {
    render::StreamSettings ss = stream_;
    ss.prior = std::move(prior_);  // what the renderer before knew of the view (carry_prior)
    prior_.reset();
    MDS_ASSIGN_OR_RETURN(renderer_, render::Renderer::create_streaming(*ctx_, *reader_, rs, ss));
    bounds_ = renderer_->bounds();
  } else {
    MDS_ASSIGN_OR_RETURN(renderer_, render::Renderer::create(*ctx_, *scene_, rs));
  }
  return {};
}

}  // namespace mds::viewer
