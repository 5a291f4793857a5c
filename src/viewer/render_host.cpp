#include "viewer/render_host.h"

#include <algorithm>

#include "render/culling/density_volume.h"
#include "render/scene.h"

namespace mds::viewer {

Result<std::unique_ptr<RenderHost>> RenderHost::open(vk::Context& ctx, const ViewerOptions& options) {
  std::unique_ptr<RenderHost> h(new RenderHost());
  h->ctx_ = &ctx;
  h->settings_ = options.render;
  h->stream_ = options.stream;
  h->stream_.gpu_budget = options.gpu_budget;
  h->stream_.slices = options.slices;
  MDS_ASSIGN_OR_RETURN(h->reader_, store::StoreReader::open(options.store));
  const store::FileHeader& header = h->reader_->header();
  MDS_TRY(render::resolve_color_by(h->settings_.color_by, header.property_name,
                                   (header.flags & store::kFlagProperty) != 0, options.store));
  auto colors = render::resolve_type_colors(h->reader_->types(), options.type_colors);
  if (!colors) return make_error(Errc::invalid_argument, "--type-color: {}", colors.error().message);
  h->settings_.type_colors_srgb = std::move(*colors);
  MDS_ASSIGN_OR_RETURN(const render::SceneOptions so, render::resolve_scene_options(*h->reader_, options.hide_types,
                                                                                   options.type_radii, options.slices,
                                                                                   h->streaming()));
  h->shown_types_ = so.shown_types;
  // Bounds of the particle centres and the largest radius, from the node directory (the
  // in-memory scene replaces them with its decoded bounds).
  h->bounds_.min = glm::dvec3(1e300);
  h->bounds_.max = glm::dvec3(-1e300);
  for (const store::NodeEntry& n : h->reader_->nodes()) {
    h->bounds_.min = glm::min(h->bounds_.min, glm::dvec3(n.center_min[0], n.center_min[1], n.center_min[2]));
    h->bounds_.max = glm::max(h->bounds_.max, glm::dvec3(n.center_max[0], n.center_max[1], n.center_max[2]));
    h->bounds_.radius_max = std::max(h->bounds_.radius_max, double(n.max_radius));
    Box b;
    for (int k = 0; k < 3; ++k) {
      b.min[k] = n.center_min[k] - n.max_radius;
      b.max[k] = n.center_max[k] + n.max_radius;
    }
    h->node_boxes_.push_back(b);
  }
  if (!h->streaming()) {
    MDS_ASSIGN_OR_RETURN(render::SceneData scene, render::load_scene(*h->reader_, so));
    h->scene_ = std::make_unique<render::SceneData>(std::move(scene));
    h->bounds_ = h->scene_->bounds;
    MDS_ASSIGN_OR_RETURN(render::culling::DensityVolume vol,
                         render::culling::density_from_store(*h->reader_, *h->scene_));
    if (h->scene_->left_out()) vol = render::culling::density_on_grid(*h->scene_, std::move(vol));
    if (h->scene_->left_out() || !so.type_radius.empty()) {
      // Particles left out or other radii: the scene's nodes and boxes (nodes gone, shrunk or grown).
      h->node_boxes_.clear();
      for (const gpu::GpuNode& g : h->scene_->nodes) {
        Box b;
        for (int k = 0; k < 3; ++k) {
          b.min[k] = h->scene_->origin[k] + double(g.aabb_min[k]);
          b.max[k] = h->scene_->origin[k] + double(g.aabb_max[k]);
        }
        h->node_boxes_.push_back(b);
      }
    }
    h->density_ = std::make_shared<const render::culling::DensityVolume>(std::move(vol));
  }
  return h;
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
