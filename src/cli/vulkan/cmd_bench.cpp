// `mdstream bench STORE [options]`: what accuracy costs in time, for one view of a store. The
// view is rendered in memory at each of --spp-list samples per pixel: every particle drawn
// ("all"), with the probabilistic occlusion culling of paper 000 by meshlet ("culled"), and with
// the particle occlusion test after convergence on top ("culled+particles"; not with
// --particle-occlusion off), the culled modes once per sample-area model of --coverage
// (expected, exact, auto: CullSettings::coverage). Culled images are those of the converged
// classes (RenderSettings::converged_image: what the viewer shows once the loop has settled).
// Each image is compared with a reference: every particle at --reference-spp samples
// (render/image_compare.h).
// Per row: the renderer's CPU wall time for the image (render() of RenderStats::wall_ms: all
// passes and the read-back, not the upload), GPU ms per frame (timestamps), for culled rows the
// time to converge and the culled fraction, and the error: RMSE and PSNR of the linear RGB, and
// the pixels beyond the renderer's 0.1 tolerance. Table on stdout; --csv and --json files.
// The machine's load shows in the times; run it where nothing else runs, and compare rows of
// one run (they share the load).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "cli/vulkan/render_options.h"
#include "core/text_file.h"
#include "render/camera.h"
#include "render/culling/cull_loop.h"
#include "render/image_compare.h"
#include "render/image_io.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "store/store_reader.h"
#include "vk/context.h"

namespace mds::cli {
namespace {

struct BenchOptions {
  std::string store;
  int view = 2;
  uint32_t width = 480, height = 270;
  double fov = 40.0;
  std::vector<uint32_t> spp_list = {1, 4, 16};
  std::vector<std::string> coverages = {"expected", "exact"};
  uint32_t reference_spp = 64;
  CullingOptions cull;  // --no-cull: the "all" rows only
  AppearanceOptions look;  // --background, --type-color, --type-radius, --hide-type
  int device = -1;
  std::string csv, json, reference_image;
  std::string images;  // --images DIR: each row's image as DIR/<mode>_<spp>spp.png
};

struct BenchRow {
  std::string mode;  // "all" | "culled" | "culled+particles"
  std::string coverage;  // culled modes: "expected" | "exact"
  uint32_t spp = 0;
  double wall_ms = 0, gpu_frame_ms = 0;
  double converge_ms = 0, culled_fraction = 0;  // culled rows
  bool converged = true;
  render::ImageDifference error;
};

Status run_bench(const BenchOptions& o) {
  if (o.fov <= 0.0 || o.fov >= 180.0)
    return make_error(Errc::invalid_argument, "--fov {}: expected degrees in (0, 180)", o.fov);
  MDS_ASSIGN_OR_RETURN(const Appearance look, parse_appearance_options(o.look));
  MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(o.store));
  MDS_ASSIGN_OR_RETURN(const render::SceneOptions so, scene_options(look, *reader, false));
  MDS_ASSIGN_OR_RETURN(render::SceneData scene, render::load_scene(*reader, so));
  const uint64_t particles = scene.particle_count();  // drawn (what --hide-type, --slice, --threshold keep)
  MDS_ASSIGN_OR_RETURN(render::Camera camera,
                       render::default_view(o.view, scene.bounds, o.fov, double(o.width) / double(o.height)));
  vk::ContextOptions copt = vk::ContextOptions::from_env();
  copt.device_index = o.device;
  MDS_ASSIGN_OR_RETURN(auto ctx, vk::Context::create(copt));

  render::RenderSettings all;  // every particle
  CullingOptions co = o.cull;
  co.no_cull = true;
  MDS_TRY(apply_culling_options(co, all));
  render::AoChoice ao;
  MDS_TRY(apply_appearance(look, *reader, all, &ao));
  all.width = o.width;
  all.height = o.height;
  // The rows' modes: every particle, then per coverage meshlets only and, unless it is off, with
  // the particle occlusion test.
  struct Mode {
    std::string name, coverage;
    render::RenderSettings settings;
  };
  std::vector<Mode> modes = {{"all", "", all}};
  if (!o.cull.no_cull) {
    MDS_ASSIGN_OR_RETURN(render::culling::DensityVolume vol, render::culling::density_from_store(*reader, scene));
    // With particles left out the store's counts include particles the scene lacks: its grid, the scene's counts.
    if (scene.left_out()) vol = render::culling::density_on_grid(scene, std::move(vol));
    auto density = std::make_shared<const render::culling::DensityVolume>(std::move(vol));
    for (const std::string& coverage : o.coverages) {
      co = o.cull;
      co.no_cull = false;
      co.coverage = coverage;
      render::RenderSettings rs = all;
      MDS_TRY(apply_culling_options(co, rs));
      rs.converged_image = true;
      rs.density = density;
      rs.particle_occlusion = false;
      modes.push_back({"culled", coverage, rs});
      if (o.cull.particle_occlusion != "off") {
        rs.particle_occlusion = true;
        modes.push_back({"culled+particles", coverage, rs});
      }
    }
  }

  auto render_once = [&](const render::RenderSettings& base, uint32_t spp, render::RenderStats& st)
      -> Result<render::FrameImage> {
    render::RenderSettings rs = base;
    rs.spp = spp;
    MDS_ASSIGN_OR_RETURN(auto renderer, render::Renderer::create(*ctx, scene, rs));
    return renderer->render(camera, &st);
  };

  render::RenderStats ref_stats;
  MDS_ASSIGN_OR_RETURN(render::FrameImage reference, render_once(all, o.reference_spp, ref_stats));
  if (!o.reference_image.empty()) MDS_TRY(render::write_image(o.reference_image, reference));

  std::vector<BenchRow> rows;
  for (const Mode& mode : modes) {
    const bool cull = mode.settings.cull;
    for (const uint32_t spp : o.spp_list) {
      render::RenderStats st;
      MDS_ASSIGN_OR_RETURN(render::FrameImage image, render_once(mode.settings, spp, st));
      BenchRow r;
      r.mode = mode.name;
      r.coverage = mode.coverage;
      r.spp = spp;
      r.wall_ms = st.wall_ms;
      r.gpu_frame_ms = cull ? st.cull.frame_ms_after_convergence : st.frame_ms_median;
      if (cull) {
        r.converge_ms = st.cull.time_to_converge_ms;
        r.culled_fraction = st.meshlets ? double(st.cull.meshlets_culled) / double(st.meshlets) : 0.0;
        r.converged = st.cull.converged;
      }
      MDS_ASSIGN_OR_RETURN(r.error, render::compare_images(image, reference));
      if (!o.images.empty())
        MDS_TRY(render::write_image(
            fmt::format("{}/{}{}_{}spp.png", o.images, r.mode, r.coverage.empty() ? "" : "_" + r.coverage, spp), image));
      rows.push_back(r);
      std::fprintf(stderr, "mdstream bench: %s%s %u spp: %.1f ms, RMSE %.5f\n", r.mode.c_str(),
                   r.coverage.empty() ? "" : (" (" + r.coverage + ")").c_str(), spp, r.wall_ms, r.error.rmse);
    }
  }

  const auto psnr = [](double v) { return std::isfinite(v) ? fmt::format("{:.2f}", v) : std::string("inf"); };
  std::printf("%s, view %d, %ux%u, reference: every particle at %u spp (%.1f ms), %s\n", o.store.c_str(), o.view,
              o.width, o.height, o.reference_spp, ref_stats.wall_ms, ref_stats.device.c_str());
  std::printf("%-16s %-8s %6s %10s %12s %12s %8s %10s %9s %10s\n", "mode", "coverage", "spp", "wall ms",
              "GPU ms/frame", "converge ms", "culled", "RMSE", "PSNR dB", "pixels>0.1");
  for (const BenchRow& r : rows)
    std::printf("%-16s %-8s %6u %10.1f %12.2f %12s %8s %10.5f %9s %9.3f%%\n", r.mode.c_str(),
                r.coverage.empty() ? "-" : r.coverage.c_str(), r.spp, r.wall_ms,
                r.gpu_frame_ms, r.mode != "all" ? fmt::format("{:.1f}{}", r.converge_ms, r.converged ? "" : "*").c_str() : "-",
                r.mode != "all" ? fmt::format("{:.1f}%", 100.0 * r.culled_fraction).c_str() : "-", r.error.rmse,
                psnr(r.error.psnr_db).c_str(), 100.0 * r.error.differing_fraction);
  if (!o.csv.empty()) {
    std::string s =
        "mode,coverage,spp,wall_ms,gpu_frame_ms,time_to_converge_ms,converged,culled_fraction,rmse,psnr_db,max_abs,"
        "differing_pixels,differing_fraction\n";
    for (const BenchRow& r : rows)
      s += fmt::format("{},{},{},{:.3f},{:.4f},{:.3f},{},{:.6f},{:.8f},{},{:.6f},{},{:.6f}\n", r.mode, r.coverage, r.spp,
                       r.wall_ms,
                       r.gpu_frame_ms, r.converge_ms, r.converged ? 1 : 0, r.culled_fraction, r.error.rmse,
                       psnr(r.error.psnr_db), r.error.max_abs, r.error.differing_pixels, r.error.differing_fraction);
    MDS_TRY(write_text_atomically(o.csv, s));
  }
  if (!o.json.empty()) {
    nlohmann::json j;
    j["store"] = o.store;
    j["view"] = o.view;
    j["width"] = o.width;
    j["height"] = o.height;
    j["particles"] = particles;
    j["device"] = ref_stats.device;
    j["device_type"] = vk::device_type_name(ctx->info().type);  // "cpu" on lavapipe
    j["ambient_occlusion"] = {{"mode", render::ao_mode_name(look.ao.mode)}, {"on", ref_stats.ambient_occlusion},
                              {"radius", ao.radius},  {"strength", ao.strength}};
    j["reference"] = {{"spp", o.reference_spp}, {"wall_ms", ref_stats.wall_ms}, {"gpu_frame_ms", ref_stats.frame_ms_median}};
    j["rows"] = nlohmann::json::array();
    for (const BenchRow& r : rows) {
      nlohmann::json e = {{"mode", r.mode},
                          {"coverage", r.coverage},
                          {"spp", r.spp},
                          {"wall_ms", r.wall_ms},
                          {"gpu_frame_ms", r.gpu_frame_ms},
                          {"rmse", r.error.rmse},
                          {"max_abs", r.error.max_abs},
                          {"differing_pixels", r.error.differing_pixels},
                          {"differing_fraction", r.error.differing_fraction}};
      e["psnr_db"] = std::isfinite(r.error.psnr_db) ? nlohmann::json(r.error.psnr_db) : nlohmann::json(nullptr);
      if (r.mode != "all") {
        e["time_to_converge_ms"] = r.converge_ms;
        e["converged"] = r.converged;
        e["culled_fraction"] = r.culled_fraction;
      }
      j["rows"].push_back(e);
    }
    MDS_TRY(write_text_atomically(o.json, j.dump(2) + "\n"));
  }
  return {};
}

void setup_bench(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<BenchOptions>();
  sub.add_option("store", opt->store, "Store file (.mds)")->required();
  sub.add_option("--view", opt->view, "Default view: 0 front, 1 oblique top, 2 close-up of a corner")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  sub.add_option("--width", opt->width, "Image width")->check(CLI::Range(1u, 16384u))->capture_default_str();
  sub.add_option("--height", opt->height, "Image height")->check(CLI::Range(1u, 16384u))->capture_default_str();
  sub.add_option("--fov", opt->fov, "Vertical field of view in degrees")->capture_default_str();
  sub.add_option("--spp-list", opt->spp_list, "Samples per pixel of the measured rows")
      ->delimiter(',')
      ->check(CLI::Range(1u, 65536u))
      ->capture_default_str();
  sub.add_option("--reference-spp", opt->reference_spp, "Samples per pixel of the reference (every particle)")
      ->check(CLI::Range(1u, 65536u))
      ->capture_default_str();
  add_culling_options(sub, opt->cull, "Measure only the rows that draw every particle", false);
  sub.add_option("--coverage", opt->coverages,
                 "Sample-area models of the culled rows (docs/culling-math.md, \"Particle sizes\"): expected, exact, "
                 "auto")
      ->delimiter(',')
      ->check(CLI::IsMember({"auto", "expected", "exact"}))
      ->capture_default_str();
  add_appearance_options(sub, opt->look);
  sub.add_option("--device", opt->device, "Vulkan device index (default: automatic, discrete GPU first)");
  sub.add_option("--csv", opt->csv, "Write the rows as CSV");
  sub.add_option("--json", opt->json, "Write the rows and the reference as JSON");
  sub.add_option("--reference-image", opt->reference_image, "Also write the reference image (.png or .exr)");
  sub.add_option("--images", opt->images, "Also write each row's image into this existing folder as <mode>_<spp>spp.png")
      ->check(CLI::ExistingDirectory);
  sub.callback([opt, &exit_code] {
    Status st = run_bench(*opt);
    exit_code = st.ok() ? 0 : report("bench", st.error());
  });
}

Registrar reg("bench", "What accuracy costs in time: one view at several spp, culled and not, against a reference",
              setup_bench);

}  // namespace
}  // namespace mds::cli
