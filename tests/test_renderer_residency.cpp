// Renderer::resident_nodes (the viewer's resident-bounds view): on a real store streamed through a
// real pool on lavapipe, the per-node residency agrees with the cache's own accounting (count and
// device bytes of the resident nodes) after a view converged, and after a camera change; in memory
// it is empty.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "render/camera.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "store/store_reader.h"
#include "vk/context.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::render;

namespace {

int run(const std::string& args) {
  const std::string cmd = std::string(MDSTREAM_BIN) + " " + args + " >/dev/null 2>&1";
  const int r = std::system(cmd.c_str());
  return WIFEXITED(r) ? WEXITSTATUS(r) : -1;
}

// Resident count and device bytes by resident_nodes(), against the cache statistics.
void expect_consistent(const Renderer& r) {
  const std::vector<uint8_t> res = r.resident_nodes();
  const std::vector<uint64_t> bytes = r.node_device_bytes();
  ASSERT_EQ(res.size(), bytes.size());
  uint64_t n = 0, b = 0;
  for (size_t i = 0; i < res.size(); ++i) {
    ASSERT_LE(res[i], 1u);
    if (res[i]) {
      ++n;
      b += bytes[i];
    }
  }
  const CacheStats c = r.stats().cache;
  EXPECT_EQ(n, c.nodes_resident);
  EXPECT_EQ(b, c.resident_bytes);
  EXPECT_GT(n, 0u);
  EXPECT_LT(n, res.size()) << "the budget holds part of the store";
}

}  // namespace

TEST(RendererResidency, ResidentNodesMatchTheCacheAccounting) {
  const fs::path dir = fs::temp_directory_path() / ("mds_residency_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string dump = (dir / "p.dump").string(), store = (dir / "p.mds").string();
  ASSERT_EQ(run("synth --scene porous --particles 100000 -q -o " + dump), 0);
  ASSERT_EQ(run("convert " + dump + " --node-size 1000 -q -o " + store), 0);
  auto reader = store::StoreReader::open(store);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto ctx = vk::Context::create(vk::ContextOptions::from_env());
  ASSERT_TRUE(ctx.ok()) << ctx.error().message;
  RenderSettings rs;
  rs.width = 96;
  rs.height = 72;
  rs.spp = 2;
  rs.cull = true;
  StreamSettings ss;
  ss.gpu_budget = fs::file_size(store) / 4;
  auto r = Renderer::create_streaming(**ctx, **reader, rs, ss);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int view : {2, 0}) {
    SCOPED_TRACE(testing::Message() << "view " << view);
    auto cam = default_view(view, (*r)->bounds(), 40.0, 96.0 / 72.0);
    ASSERT_TRUE(cam.ok());
    ASSERT_TRUE((*r)->set_view(*cam).ok());
    bool converged = false;
    for (int f = 0; f < 400 && !converged; ++f) {
      auto rep = (*r)->step();
      ASSERT_TRUE(rep.ok()) << rep.error().message;
      converged = rep->converged;
    }
    EXPECT_TRUE(converged);
    expect_consistent(**r);
  }
  // In memory: no residency.
  auto scene = load_scene(**reader);
  ASSERT_TRUE(scene.ok());
  auto mem = Renderer::create(**ctx, *scene, rs);
  ASSERT_TRUE(mem.ok()) << mem.error().message;
  EXPECT_TRUE((*mem)->resident_nodes().empty());
  r->reset();
  mem->reset();
  fs::remove_all(dir);
}
