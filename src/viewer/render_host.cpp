#include "viewer/render_host.h"

#include <algorithm>

#include "render/ambient_occlusion_setup.h"
#include "render/culling/density_volume.h"
#include "render/scene.h"

namespace mds::viewer {

Result<std::unique_ptr<RenderHost>> RenderHost::open(vk::Context& ctx, const ViewerOptions& options) {
  std::unique_ptr<RenderHost> h(new RenderHost());
  h->ctx_ = &ctx;
  h->settings_ = options.render;
  h->stream_ = options.stream;
  h->stream_.gpu_budget = options.gpu_budget;
  h->hide_types_ = options.hide_types;
  h->type_radii_ = options.type_radii;
  MDS_ASSIGN_OR_RETURN(h->reader_, store::StoreReader::open(options.store));
  const store::FileHeader& header = h->reader_->header();
  MDS_TRY(render::resolve_color_by(h->settings_.color_by, header.property_name,
                                   (header.flags & store::kFlagProperty) != 0, options.store));
  auto colors = render::resolve_type_colors(h->reader_->types(), options.type_colors);
  if (!colors) return make_error(Errc::invalid_argument, "--type-color: {}", colors.error().message);
  h->settings_.type_colors_srgb = std::move(*colors);
  MDS_ASSIGN_OR_RETURN(const render::AoChoice ao, render::resolve_ao(options.ao, *h->reader_));
  h->settings_.ao_radius = ao.on ? ao.radius : 0.0;
  h->settings_.ao_strength = ao.strength;
  h->ao_radius_ = ao.radius;
  h->ao_strength_ = options.ao.strength > 0.0 ? options.ao.strength : 1.0;
  MDS_ASSIGN_OR_RETURN(Loaded loaded, h->load(options.slices));
  h->take(std::move(loaded));
  return h;
}

Result<RenderHost::Loaded> RenderHost::load(const std::vector<store::Slice>& slices) const {
  Loaded l;
  l.slices = slices;
  MDS_ASSIGN_OR_RETURN(const render::SceneOptions so,
                       render::resolve_scene_options(*reader_, hide_types_, type_radii_, slices, streaming()));
  l.shown_types = so.shown_types;
  // Bounds of the particle centres and the largest radius, from the node directory (the
  // in-memory scene replaces them with its decoded bounds).
  l.bounds.min = glm::dvec3(1e300);
  l.bounds.max = glm::dvec3(-1e300);
  for (const store::NodeEntry& n : reader_->nodes()) {
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
    MDS_ASSIGN_OR_RETURN(render::SceneData scene, render::load_scene(*reader_, so));
    l.scene = std::make_unique<render::SceneData>(std::move(scene));
    l.bounds = l.scene->bounds;
    MDS_ASSIGN_OR_RETURN(render::culling::DensityVolume vol, render::culling::density_from_store(*reader_, *l.scene));
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
    l.density = std::make_shared<const render::culling::DensityVolume>(std::move(vol));
  }
  return l;
}

void RenderHost::take(Loaded&& l) {
  stream_.slices = std::move(l.slices);
  shown_types_ = std::move(l.shown_types);
  scene_ = std::move(l.scene);
  density_ = std::move(l.density);
  bounds_ = l.bounds;
  node_boxes_ = std::move(l.node_boxes);
}

Status RenderHost::set_slices(const std::vector<store::Slice>& slices) {
  MDS_ASSIGN_OR_RETURN(Loaded loaded, load(slices));  // the current scene stays until this worked
  std::vector<store::Slice> before = stream_.slices;
  renderer_.reset();  // before the scene it drew goes
  take(std::move(loaded));
  Status st = recreate(settings_.width, settings_.height);
  if (st.ok()) return st;
  // Streaming: the cache refuses slices that leave no node. Back to the slices before.
  auto back = load(before);
  if (back) {
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

Status RenderHost::recreate(uint32_t width, uint32_t height) {
  renderer_.reset();
  settings_.width = width;
  settings_.height = height;
  render::RenderSettings rs = settings_;
  if (rs.cull && density_) rs.density = density_;
  if (streaming()) {
    MDS_ASSIGN_OR_RETURN(renderer_, render::Renderer::create_streaming(*ctx_, *reader_, rs, stream_));
    bounds_ = renderer_->bounds();
  } else {
    MDS_ASSIGN_OR_RETURN(renderer_, render::Renderer::create(*ctx_, *scene_, rs));
  }
  return {};
}

}  // namespace mds::viewer
