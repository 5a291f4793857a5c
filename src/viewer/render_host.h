// The viewer's renderer and its inputs: the open store, the in-memory scene (when no GPU budget
// is given) with its density volume, the current render settings (width/height = the window),
// and re-creation of the render::Renderer when its fixed parameters change (culling on/off,
// the slices, the frame of a series). Size changes (window, dynamic resolution) use
// Renderer::resize instead. A series (store/series.h) shows one store at a time, with the
// colour range over all its frames (render/series_look.h).
#pragma once

#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/result.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render/series_look.h"
#include "store/series.h"
#include "store/store_reader.h"
#include "viewer/debug_views.h"
#include "viewer/viewer.h"
#include "vk/context.h"

namespace mds::viewer {

class RenderHost {
 public:
  // Opens the store; in memory (options.gpu_budget == 0) decodes it into a scene.
  static Result<std::unique_ptr<RenderHost>> open(vk::Context& ctx, const ViewerOptions& options);

  // (Re)creates the renderer at width x height with settings(); the old one is destroyed first.
  Status recreate(uint32_t width, uint32_t height);
  // Other slices (--slice; the viewer's slice keys): the scene is loaded again with them (in
  // memory) or the cache made again (streaming: what it held is read again), and the renderer
  // re-created at the current size. On an error (e.g. slices that leave no particle) the
  // slices before stay, with a renderer.
  Status set_slices(const std::vector<store::Slice>& slices);
  // Another colour choice (the viewer's colour keys; as --color-by, --color-range, --colormap
  // give it, resolved against each store shown): applied to the renderer in place
  // (Renderer::set_color_by), except that streaming, into or out of the particles' own colours,
  // the renderer is made again with a new cache (the pool holds colours only where they are
  // drawn; *remade says so: the new renderer needs a view). On an error the choice before stays.
  Status set_color_by(const render::ColorBy& color_by, bool* remade = nullptr);
  // The simulation cell on or off (the viewer's key U; --cell): on draws the cell of each store
  // shown (Renderer::set_cell, in place), off none. Errc::invalid_argument turning it on when the
  // store shown has no cell; the choice before then stays.
  Status set_cell_shown(bool on);
  bool cell_shown() const { return settings_.cell.has_value(); }
  const std::vector<store::Slice>& slices() const { return stream_.slices; }  // in memory too
  // Another threshold (--threshold; the viewer's threshold keys), or none: the scene loaded again
  // or the cache made again, as set_slices; on an error (one that keeps no particle) the
  // threshold before stays, with a renderer.
  Status set_threshold(const std::optional<store::Threshold>& threshold);
  const std::optional<store::Threshold>& threshold() const { return stream_.threshold; }  // in memory too
  // A series: which of its picked frames (--series-frames) is shown. set_series_position loads
  // that frame's store like set_slices (the slices and the camera stay); on an error the frame
  // before stays.
  bool is_series() const { return series_.has_value(); }
  size_t series_position() const { return series_pos_; }
  size_t series_positions() const { return series_frames_.size(); }
  int64_t series_frame() const { return series_frames_.empty() ? 0 : series_frames_[series_pos_]; }
  const store::SeriesFrame* series_entry() const;
  Status set_series_position(size_t position);
  // Reads and loads the store of series position `position` on a background thread (the viewer
  // asks for the next frame while the series plays), for set_series_position to take instead of
  // loading it then: the step keeps only the renderer's creation. A no-op for the shown position,
  // the one already asked for, or MDSTREAM_SERIES_PRELOAD=0 (A/B runs). Loaded with the slices of
  // the time of the call: set_series_position loads again when they changed since.
  void preload(size_t position);
  // The preload of `position` has finished (loaded or failed); false when none was asked for.
  bool preload_ready(size_t position) const;
  // The bounds the home camera frames: every picked frame's for a series, else bounds().
  const render::Bounds& view_bounds() const { return series_ ? look_.bounds : bounds_; }
  // The ambient occlusion the L key switches on: --ao-radius (or its default for the store) and
  // --ao-strength (1 where that is 0).
  double ao_radius() const { return ao_radius_; }
  double ao_strength() const { return ao_strength_; }
  render::RenderSettings& settings() { return settings_; }
  render::Renderer* renderer() { return renderer_.get(); }
  bool streaming() const { return stream_.gpu_budget > 0; }
  // What the colour keys can choose: per-particle colours and the property, of every picked frame
  // of a series (SeriesLook), else of the store.
  bool has_colors() const;
  bool has_property() const;
  const render::StreamSettings& stream_settings() const { return stream_; }
  const render::Bounds& bounds() const { return bounds_; }
  const render::SceneData* scene() const { return scene_ ? scene_.get() : nullptr; }
  const store::StoreReader& reader() const { return *reader_; }
  // One entry per type, 0 = hidden (--hide-type); empty: every type drawn.
  std::span<const uint8_t> shown_types() const { return shown_types_; }
  // What the shown store was loaded with (hidden types, --type-radius, slices): for picking.
  render::SceneOptions scene_options() const { return {shown_types_, type_radius_, stream_.slices, stream_.threshold}; }
  uint64_t meshlets() const;
  // Node boxes in world coordinates (from the store's node directory).
  const std::vector<Box>& node_boxes() const { return node_boxes_; }

 private:
  // What the scene options make of the store: the scene (in memory) and what goes with it.
  struct Loaded {
    std::vector<store::Slice> slices;
    std::vector<uint8_t> shown_types;
    std::vector<float> type_radius;
    std::unique_ptr<render::SceneData> scene;
    std::shared_ptr<const render::culling::DensityVolume> density;
    // In memory: the culling loop's scene of `scene` and `density` (RenderSettings::cull_scene),
    // made here so that a preloaded frame's step does not make it.
    std::shared_ptr<const render::culling::CullScene> cull_scene;
    render::Bounds bounds;
    std::vector<Box> node_boxes;
  };
  // A series frame's store, opened and loaded (on a preload thread or in set_series_position).
  struct Prepared {
    std::unique_ptr<store::StoreReader> reader;
    Loaded loaded;
  };
  RenderHost();
  Result<Loaded> load(const store::StoreReader& reader, const std::vector<store::Slice>& slices) const;
  // Reads only what open() set (the options, the series), so it runs beside the render thread.
  Result<Prepared> prepare(size_t position, const std::vector<store::Slice>& slices) const;
  // A preload was asked for `position` with the current slices (in flight or done).
  bool preloading(size_t position) const {
    return preload_.valid() && preload_pos_ == position && preload_slices_ == stream_.slices;
  }
  // The store's colours: --color-by resolved against it (the series' range), --type-color.
  Status resolve_colors(const store::StoreReader& reader, render::RenderSettings& rs) const;
  void take(Loaded&& loaded);
  // Streaming, before the renderer goes: what its cache knew of the view, for the next one's
  // first wave (StreamSettings::prior; kept in prior_ until recreate() uses it).
  void carry_prior();

  vk::Context* ctx_ = nullptr;
  std::unique_ptr<store::StoreReader> reader_;
  std::vector<std::string> hide_types_;           // --hide-type
  std::vector<store::TypeRadiusSpec> type_radii_;  // --type-radius
  std::vector<store::TypeColorSpec> type_colors_;  // --type-color
  render::ColorBy color_by_;                        // --color-by as given
  render::CellMode cell_mode_ = render::CellMode::automatic;  // --cell, resolved per store (resolve_colors)
  std::string store_arg_;                          // the store or series as given
  std::optional<store::Series> series_;
  std::vector<int64_t> series_frames_;  // --series-frames picked
  size_t series_pos_ = 0;
  render::SeriesLook look_;
  double ao_radius_ = 0.0, ao_strength_ = 1.0;
  std::vector<uint8_t> shown_types_;
  std::vector<float> type_radius_;
  std::unique_ptr<render::SceneData> scene_;
  std::shared_ptr<const render::culling::DensityVolume> density_;
  std::shared_ptr<const render::culling::CullScene> cull_scene_;
  render::RenderSettings settings_;
  render::StreamSettings stream_;  // also the slices and threshold in memory (load_scene applies them there)
  render::Bounds bounds_;
  std::vector<Box> node_boxes_;
  std::unique_ptr<render::Renderer> renderer_;
  std::shared_ptr<const streaming::PriorView> prior_;  // carry_prior() for the next recreate()
  // preload(): the position asked for, the slices it loads with, and the load in flight (or done).
  bool preload_enabled_ = true;
  size_t preload_pos_ = 0;
  std::vector<store::Slice> preload_slices_;
  std::future<Result<Prepared>> preload_;
};

}  // namespace mds::viewer
