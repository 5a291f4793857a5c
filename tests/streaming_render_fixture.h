// The fixture of the out-of-core rendering tests (test_streaming_render.cpp,
// test_streaming_resize.cpp): a real store (synth -> convert with the CLI, 400k porous particles
// in nodes of <= 1000), a real Vulkan context (lavapipe here), and the in-memory and streamed
// renders of its default views.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>

#include "render/camera.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render/streaming/node_pool.h"
#include "render_test_helpers.h"
#include "store/store_reader.h"
#include "vk/context.h"

namespace mds::testing::streaming_render {

namespace fs = std::filesystem;
using namespace mds::render;

constexpr uint32_t kW = 160, kH = 120;

inline int run(const std::string& args) { return mds::testing::run_mdstream_quietly(args); }

struct Image {
  FrameImage img;
  RenderStats stats;
};

using mds::testing::differing_pixels;

class StreamingRender : public ::testing::Test {
 protected:
  // A dense porous block of 400k particles in nodes of <= 1000 (about 580 nodes), so that a
  // close-up view needs a small part of the store.
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mds_streaming_render_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    ASSERT_EQ(run("synth --scene porous --particles 400000 -q -o " + (dir_ / "p.dump").string()), 0);
    ASSERT_EQ(run("convert " + (dir_ / "p.dump").string() + " --node-size 1000 -o " + store_path()), 0);
    auto c = vk::Context::create(vk::ContextOptions::from_env());
    ASSERT_TRUE(c.ok()) << c.error().message;
    ctx_ = std::move(c.value());
  }
  static void TearDownTestSuite() {
    ctx_.reset();
    fs::remove_all(dir_);
  }
  static std::string store_path() { return (dir_ / "p.mds").string(); }

  static RenderSettings settings(bool cull) {
    RenderSettings rs;
    rs.width = kW;
    rs.height = kH;
    rs.spp = 4;
    rs.cull = cull;
    return rs;
  }
  static Camera view(const store::StoreReader& reader, int index) {
    auto scene = load_directory_bounds(reader);
    auto cam = default_view(index, scene, 40.0, double(kW) / kH);
    EXPECT_TRUE(cam.ok());
    return cam.value();
  }
  static Bounds load_directory_bounds(const store::StoreReader& reader) { return mds::testing::header_bounds(reader); }
  static Image in_memory(const store::StoreReader& reader, bool cull, int view_index) {
    Image out;
    auto scene = load_scene(reader);
    EXPECT_TRUE(scene.ok());
    auto r = Renderer::create(*ctx_, scene.value(), settings(cull));
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
    auto img = r.value()->render(view(reader, view_index), &out.stats);
    EXPECT_TRUE(img.ok()) << (img.ok() ? "" : img.error().message);
    out.img = std::move(img.value());
    return out;
  }
  // sprite_capacity > 0: sprite records for that many sprites, drawn in chunks -- records exist
  // on the compute + indirect draw path only, so that path is chosen (the task/mesh path makes
  // its sprites in place).
  static Result<Image> streamed(const store::StoreReader& reader, bool cull, int view_index, uint64_t budget,
                                uint64_t sprite_capacity = 0, MeshShaderMode mesh = MeshShaderMode::automatic) {
    StreamSettings ss;
    ss.gpu_budget = budget;
    RenderSettings rs = settings(cull);
    rs.sprite_capacity = sprite_capacity;
    rs.mesh_shaders = sprite_capacity > 0 ? MeshShaderMode::off : mesh;
    MDS_ASSIGN_OR_RETURN(auto r, Renderer::create_streaming(*ctx_, reader, rs, ss));
    Image out;
    MDS_ASSIGN_OR_RETURN(out.img, r->render(view(reader, view_index), &out.stats));
    return out;
  }
  static uint64_t file_size() { return fs::file_size(store_path()); }
  // In-memory renders of the test store with 2 spp and at most 6 culling iterations (the
  // culling state at the same iteration count, quickly), and view 2's camera.
  static RenderSettings quick_settings() {
    RenderSettings rs = settings(true);
    rs.spp = 2;
    rs.cull_settings.max_iterations = 6;
    return rs;
  }
  struct QuickRenderer {
    std::unique_ptr<Renderer> r;
    Camera cam;
  };
  static Result<QuickRenderer> quick_renderer(const RenderSettings& rs = quick_settings()) {
    MDS_ASSIGN_OR_RETURN(auto reader, store::StoreReader::open(store_path()));
    MDS_ASSIGN_OR_RETURN(auto scene, load_scene(*reader));
    QuickRenderer q;
    MDS_ASSIGN_OR_RETURN(q.r, Renderer::create(*ctx_, scene, rs));
    q.cam = view(*reader, 2);
    return q;
  }
  // A node pool over the test store (pool_layout_for, pool_scene_for at origin 0) for
  // `budget` bytes, and one frame of its operations: begin_frame, body(cmd), end_frame, waited for.
  static Result<std::unique_ptr<streaming_gpu::NodePool>> make_pool(const store::StoreReader& reader, uint64_t budget) {
    const streaming_gpu::PoolLayout layout = streaming_gpu::pool_layout_for(reader.header());
    return streaming_gpu::NodePool::create(*ctx_, layout, streaming_gpu::pool_scene_for(reader, layout, glm::dvec3(0.0)),
                                           uint32_t(reader.nodes().size()), budget, 1000, 1 << 20);
  }
  template <class F>
  static Status pool_frame(streaming_gpu::NodePool& p, F&& body) {
    p.begin_frame();
    return ctx_->submit_and_wait([&](VkCommandBuffer cmd) {
      body(cmd);
      p.end_frame(cmd);
    });
  }

  inline static fs::path dir_;
  inline static std::unique_ptr<vk::Context> ctx_;
};

}  // namespace mds::testing::streaming_render
