// render/pick.h on real stores (synth -> convert, a hand-written LAMMPS dump with a property
// column, the store writer with per-particle radii): the walk over the nodes against every
// particle tested in turn, with hidden types, slices and other radii; the property and the store
// index against `export`; the rendered depth of an unculled lavapipe frame (one unjittered
// sample) against the picks' distances; `render --pick`; the errors.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_test_util.h"
#include "render/camera.h"
#include "render/pick.h"
#include "render/pixel_rays.h"
#include "render/renderer.h"
#include "render/scene.h"
#include "render/visible_nodes.h"
#include "render_test_helpers.h"
#include "store/slice.h"
#include "store/store_reader.h"
#include "store_test_helpers.h"

namespace fs = std::filesystem;
using namespace mds;
using namespace mds::render;

namespace {

// Every particle of the store, decoded once, for the test that tries them all.
struct Particle {
  uint32_t node, k;
  uint8_t type;
  glm::dvec3 p;
  double r;
};

std::vector<Particle> all_particles(const store::StoreReader& reader) {
  std::vector<Particle> out;
  const store::FileHeader& h = reader.header();
  store::NodeData d;
  std::vector<uint8_t> scratch;
  for (uint32_t i = 0; i < reader.nodes().size(); ++i) {
    const store::NodeEntry& e = reader.nodes()[i];
    EXPECT_TRUE(reader.read_node(i, d, scratch).ok());
    for (uint32_t k = 0; k < d.particle_count(); ++k) {
      glm::dvec3 p;
      for (int a = 0; a < 3; ++a) p[a] = e.center_min[a] + double(d.qpos[3 * k + a]) * store::quant_step(e, a);
      const double r = (h.flags & store::kFlagPerParticleRadius)
                           ? h.radius_min + double(d.radius_q[k]) * (h.radius_max - h.radius_min) / store::kQuantMax
                           : double(reader.types()[d.type_index[k]].radius);
      out.push_back({i, k, d.type_index[k], p, r});
    }
  }
  return out;
}

// The nearest front-surface hit over every particle the options keep: node and index, or none.
struct Hit {
  bool any = false;
  uint32_t node = 0, k = 0;
  double distance = 0.0;
};
Hit try_every_particle(const std::vector<Particle>& all, const PixelRays& f, glm::dvec2 px, const SceneOptions& o) {
  glm::dvec3 ro, rd;
  f.ray(px.x, px.y, ro, rd);
  Hit best;
  double best_t = std::numeric_limits<double>::infinity();
  for (const Particle& q : all) {
    if (!o.shown_types.empty() && !o.shown_types[q.type]) continue;
    if (!store::slices_keep(o.slices, {q.p.x, q.p.y, q.p.z})) continue;
    const double r = o.type_radius.empty() ? q.r : double(o.type_radius[q.type]);
    const glm::dvec3 c = glm::dvec3(f.view * glm::dvec4(q.p, 1.0));
    if (before_near_plane(c, r, f.near)) continue;
    const double t = ray_sphere_front(ro, rd, c, r);
    if (t < 0.0 || !(t < best_t)) continue;
    best_t = t;
    best = {true, q.node, q.k, -(ro + t * rd).z};
  }
  return best;
}

class PickStore : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("mds_pick_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    const std::string dump = (*dir_ / "p.dump").string();
    ASSERT_EQ(mds::testing::run_mdstream("synth --scene porous --particles 20000 -q -o " + dump), 0) << mds::testing::cli_stderr();
    ASSERT_EQ(mds::testing::run_mdstream("convert " + dump + " --node-size 500 -q -o " + store()), 0)
        << mds::testing::cli_stderr();
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::string store() { return (*dir_ / "p.mds").string(); }
  static inline fs::path* dir_ = nullptr;
};

// Cameras of the default views (0, 1, 2, and 1 orthographic) at w x h, planes fitted.
std::vector<Camera> test_cameras(const Bounds& b, uint32_t w, uint32_t h) {
  std::vector<Camera> out;
  for (int v : {0, 1, 2, 1}) {
    auto c = default_view(v, b, 40.0, double(w) / h);
    EXPECT_TRUE(c.ok());
    if (out.size() == 3) c->ortho = true;
    fit_clip_planes(*c, b);
    out.push_back(*c);
  }
  return out;
}

// pick_particle against try_every_particle at every 3rd pixel of four views, for one set of options.
void expect_picks_match(const store::StoreReader& reader, const SceneOptions& o, size_t& hits) {
  constexpr uint32_t W = 64, H = 48;
  const std::vector<Particle> all = all_particles(reader);
  for (const Camera& cam : test_cameras(mds::testing::header_bounds(reader), W, H)) {
    const PixelRays f(cam, W, H);
    for (uint32_t y = 1; y < H; y += 3)
      for (uint32_t x = 1; x < W; x += 3) {
        const glm::dvec2 px(x + 0.5, y + 0.5);
        auto got = pick_particle(reader, cam, W, H, px, o);
        ASSERT_TRUE(got.ok()) << got.error().message;
        const Hit want = try_every_particle(all, f, px, o);
        ASSERT_EQ(got->has_value(), want.any) << "pixel " << x << "," << y << " ortho " << cam.ortho;
        if (!want.any) continue;
        ++hits;
        const PickedParticle& p = **got;
        EXPECT_EQ(p.node, want.node) << "pixel " << x << "," << y;
        EXPECT_EQ(p.index_in_node, want.k) << "pixel " << x << "," << y;
        EXPECT_NEAR(p.distance, want.distance, 1e-9 * want.distance);
        // The hit lies on the sphere, and in the slices and shown types.
        EXPECT_NEAR(glm::length(p.hit - p.position), p.radius, 1e-9 * (1.0 + p.radius + glm::length(p.position)));
        if (!o.shown_types.empty()) {
          EXPECT_TRUE(o.shown_types[p.type]);
        }
        EXPECT_TRUE(store::slices_keep(o.slices, {p.position.x, p.position.y, p.position.z}));
      }
  }
}

}  // namespace

TEST_F(PickStore, TheWalkOverTheNodesFindsTheParticleEveryParticleTestedInTurnFinds) {
  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  ASSERT_GT((*reader)->types().size(), 1u);
  size_t hits = 0;
  expect_picks_match(**reader, {}, hits);
  EXPECT_GT(hits, 500u);  // of 4 x 336 pixels: most rays meet the block
}

TEST_F(PickStore, HiddenTypesSlicesAndOtherRadiiChangeThePickAsTheyChangeTheImage) {
  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  const size_t types = (*reader)->types().size();
  const store::FileHeader& h = (*reader)->header();
  SceneOptions hide;
  hide.shown_types.assign(types, 1);
  hide.shown_types[0] = 0;
  SceneOptions slab;  // a slab through the middle along x, and a half-space cut along z
  slab.slices = {store::Slice{{1.0, 0.0, 0.0}, 0.5 * (h.bounds_min[0] + h.bounds_max[0]), 8.0, false},
                 store::Slice{{0.0, 0.0, 1.0}, 0.5 * (h.bounds_min[2] + h.bounds_max[2]), 0.0, false}};
  SceneOptions big;
  for (const auto& t : (*reader)->types()) big.type_radius.push_back(1.6f * t.radius);
  SceneOptions all_three = hide;
  all_three.slices = slab.slices;
  all_three.type_radius = big.type_radius;
  for (const SceneOptions* o : {&hide, &slab, &big, &all_three}) {
    size_t hits = 0;
    expect_picks_match(**reader, *o, hits);
    EXPECT_GT(hits, 100u);
  }
}

// A store written by the store writer with per-particle radii: the picked radius is the
// particle's, as every particle tested in turn has it.
TEST(Pick, PerParticleRadii) {
  const fs::path dir = mds::testing::temp_dir("pick_radii");
  mds::testing::SynthOptions so;
  so.particles = 3000;
  so.per_particle_radius = true;
  so.extent = 40.0;
  const mds::testing::SynthStore s = mds::testing::make_synthetic(so);
  ASSERT_EQ(mds::testing::write_store(s, dir / "r.mds"), "");
  auto reader = store::StoreReader::open(dir / "r.mds");
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  size_t hits = 0;
  expect_picks_match(**reader, {}, hits);
  EXPECT_GT(hits, 50u);
  fs::remove_all(dir);
}

// A LAMMPS dump whose property is each particle's id + 0.25, converted with --property: the
// pick's property is the particle's (within the property's quantization step), its position
// and store index are the row `export` writes for it.
TEST(Pick, PropertyAndStoreIndexAreThoseOfTheParticle) {
  const fs::path dir = mds::testing::temp_dir("pick_property");
  std::ofstream dump(dir / "grid.dump");
  const int n = 12;
  dump << "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n" << n * n * n << "\nITEM: BOX BOUNDS pp pp pp\n"
       << "0 12\n0 12\n0 12\nITEM: ATOMS id type x y z c_pe\n";
  int id = 1;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x, ++id)
        dump << id << " " << 1 + (id % 2) << " " << x + 0.5 << " " << y + 0.5 << " " << z + 0.5 << " " << id + 0.25
             << "\n";
  dump.close();
  const std::string store = (dir / "grid.mds").string(), xyz = (dir / "grid.xyz").string();
  ASSERT_EQ(mds::testing::run_mdstream(fmt::format("convert {} --property c_pe --radius 0.5 --node-size 200 -q -o {}",
                                              (dir / "grid.dump").string(), store)),
            0)
      << mds::testing::cli_stderr();
  ASSERT_EQ(mds::testing::run_mdstream("export " + store + " -o " + xyz), 0) << mds::testing::cli_stderr();
  std::vector<std::array<double, 4>> rows;  // x y z property, in export order
  {
    std::ifstream f(xyz);
    std::string line;
    std::getline(f, line);
    std::getline(f, line);
    while (std::getline(f, line)) {
      std::istringstream ss(line);
      std::string species;
      std::array<double, 4> r;
      ss >> species >> r[0] >> r[1] >> r[2] >> r[3];
      rows.push_back(r);
    }
  }
  ASSERT_EQ(rows.size(), size_t(n * n * n));
  auto reader = store::StoreReader::open(store);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  const double prop_step = (double((*reader)->header().property_max) - (*reader)->header().property_min) / 65535.0;
  constexpr uint32_t W = 40, H = 30;
  int picked = 0;
  for (const Camera& cam : test_cameras(mds::testing::header_bounds(**reader), W, H))
    for (uint32_t y = 2; y < H; y += 5)
      for (uint32_t x = 2; x < W; x += 5) {
        auto p = pick_particle(**reader, cam, W, H, glm::dvec2(x + 0.5, y + 0.5));
        ASSERT_TRUE(p.ok()) << p.error().message;
        if (!*p) continue;
        ++picked;
        const PickedParticle& q = **p;
        ASSERT_LT(q.index, rows.size());
        const auto& r = rows[q.index];
        EXPECT_EQ(q.position, glm::dvec3(r[0], r[1], r[2])) << "store index " << q.index;
        ASSERT_TRUE(q.property.has_value());
        EXPECT_EQ(*q.property, r[3]);
        // The input particle at that lattice site: id from its position, property id + 0.25.
        const int ix = int(std::floor(q.position.x)), iy = int(std::floor(q.position.y)), iz = int(std::floor(q.position.z));
        const int input_id = 1 + ix + n * (iy + n * iz);
        EXPECT_NEAR(*q.property, input_id + 0.25, 0.5 * prop_step + 1e-9) << "at " << q.position.x << "," << q.position.y;
        EXPECT_EQ((*reader)->types()[q.type].input_id, 1 + (input_id % 2));
        EXPECT_EQ(q.radius, 0.5);
        const std::string text = describe_pick(**reader, q);
        EXPECT_NE(text.find("c_pe"), std::string::npos) << text;
        EXPECT_NE(text.find(fmt::format("store index {}", q.index)), std::string::npos) << text;
      }
  EXPECT_GT(picked, 60);
  fs::remove_all(dir);
}

TEST_F(PickStore, EmptyPixelsAndErrors) {
  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  const Bounds b = mds::testing::header_bounds(**reader);
  Camera away = test_cameras(b, 32, 24)[0];
  const glm::dvec3 forward = away.target - away.eye;
  away.target = away.eye - forward;  // looking away from the data
  auto none = pick_particle(**reader, away, 32, 24, {16.5, 12.5});
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->has_value());

  const Camera cam = test_cameras(b, 32, 24)[0];
  for (const glm::dvec2 px : {glm::dvec2(-0.5, 3.0), glm::dvec2(32.5, 3.0), glm::dvec2(3.0, 24.5)}) {
    auto e = pick_particle(**reader, cam, 32, 24, px);
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.error().code, Errc::invalid_argument);
    EXPECT_NE(e.error().message.find("outside the 32x24 image"), std::string::npos) << e.error().message;
  }
  Camera unfitted = cam;
  unfitted.near = unfitted.far = 0.0;
  EXPECT_FALSE(pick_particle(**reader, unfitted, 32, 24, {3.0, 3.0}).ok());

  auto px = parse_pick_pixel(" 12 , 7");
  ASSERT_TRUE(px.ok());
  EXPECT_EQ(*px, glm::uvec2(12, 7));
  for (const char* bad : {"12", "12,", ",7", "-1,3", "1.5,3", "a,b", "1,2,3", "99999999999,1"})
    EXPECT_FALSE(parse_pick_pixel(bad).ok()) << bad;
}

// The picks' distances are the depths of an unculled render with one unjittered sample (the
// GPU's float ray test at every pixel centre): the CPU mirror of what the renderer shows.
class PickRender : public mds::testing::VulkanSuite {};

TEST_F(PickRender, DistancesAreTheRenderedDepths) {
  const fs::path dir = fs::temp_directory_path() / ("mds_pick_render_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string dump = (dir / "p.dump").string(), store = (dir / "p.mds").string();
  ASSERT_EQ(mds::testing::run_mdstream("synth --scene ablation --particles 20000 -q -o " + dump), 0) << mds::testing::cli_stderr();
  ASSERT_EQ(mds::testing::run_mdstream("convert " + dump + " --node-size 500 -q -o " + store), 0) << mds::testing::cli_stderr();
  auto reader = store::StoreReader::open(store);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto scene = load_scene(**reader);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  constexpr uint32_t W = 96, H = 72;
  RenderSettings rs;
  rs.width = W;
  rs.height = H;
  rs.spp = 1;  // sample 0 is the pixel centre
  rs.cull = false;
  auto r = Renderer::create(*ctx_, *scene, rs);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int view : {0, 1, 2}) {
    auto cam = default_view(view, scene->bounds, 40.0, double(W) / H);
    ASSERT_TRUE(cam.ok());
    ASSERT_TRUE((*r)->render(*cam).ok());
    auto depth = (*r)->read_last_depth();
    ASSERT_TRUE(depth.ok()) << depth.error().message;
    Camera fitted = *cam;
    fit_clip_planes(fitted, (*r)->bounds());
    const PixelRays f(fitted, W, H);
    size_t covered = 0, disagree = 0;
    for (uint32_t y = 0; y < H; ++y)
      for (uint32_t x = 0; x < W; ++x) {
        const float d = (*depth)[size_t(y) * W + x];
        auto p = pick_particle(**reader, fitted, W, H, {x + 0.5, y + 0.5});
        ASSERT_TRUE(p.ok()) << p.error().message;
        covered += d < 1.0f;
        // Float against double at a silhouette: a ray grazing a sphere may hit in one and not
        // the other; elsewhere the distances agree to float precision.
        if ((d < 1.0f) != p->has_value()) {
          ++disagree;
          continue;
        }
        if (!p->has_value()) continue;
        // Compared as z_ndc: a float depth near 1 holds the view distance to ~1e-4 of it when the
        // near plane is close (the close-up's camera lies inside the data).
        const glm::dvec4 clip = f.proj * glm::dvec4(0.0, 0.0, -(*p)->distance, 1.0);
        if (std::abs(clip.z / clip.w - double(d)) > kDepthSlack) ++disagree;
      }
    SCOPED_TRACE(fmt::format("view {}: {} covered pixels", view, covered));
    EXPECT_GT(covered, size_t(W * H) / 10);
    EXPECT_LE(disagree, 2 + covered / 1000) << disagree << " pixels disagree";  // 0-1 per view on lavapipe
  }
  fs::remove_all(dir);
}

// `render --pick`: one JSON line per pixel on stdout, the same under "picks" in --stats, the
// library's answer; a pixel outside the image or a malformed one is an error before anything
// is written.
TEST_F(PickStore, RenderPickPrintsTheParticleOfEachPixel) {
  const fs::path out = *dir_ / "pick.png", stats = *dir_ / "pick.json", lines = *dir_ / "pick.txt";
  ASSERT_EQ(mds::testing::run_mdstream(fmt::format("render {} -o {} --no-cull --spp 1 --width 64 --height 48 --view 2 "
                                              "--pick 32,24 --pick 0,0 --pick 63,47 --stats {} > {}",
                                              store(), out.string(), stats.string(), lines.string())),
            0)
      << mds::testing::cli_stderr();
  std::vector<nlohmann::json> printed;
  {
    std::ifstream f(lines);
    for (std::string line; std::getline(f, line);) printed.push_back(nlohmann::json::parse(line));
  }
  ASSERT_EQ(printed.size(), 3u);
  std::ifstream sf(stats);
  const nlohmann::json s = nlohmann::json::parse(sf);
  ASSERT_EQ(s["picks"].size(), 3u);
  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok());
  // The render's camera, as its stats give it (view 2 of the decoded scene's bounds, planes fitted).
  std::optional<Camera> cam = Camera{};
  const auto vec = [&](const char* k) {
    const auto& v = s["camera"][k];
    return glm::dvec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
  };
  cam->eye = vec("eye");
  cam->target = vec("target");
  cam->up = vec("up");
  cam->fov_y_deg = s["camera"]["fov_y_deg"].get<double>();
  cam->near = s["camera"]["near"].get<double>();
  cam->far = s["camera"]["far"].get<double>();
  const glm::uvec2 pixels[3] = {{32, 24}, {0, 0}, {63, 47}};
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(printed[i], s["picks"][i]);
    EXPECT_EQ(printed[i]["pixel"], nlohmann::json::array({pixels[i].x, pixels[i].y}));
    auto p = pick_particle(**reader, *cam, 64, 48, glm::dvec2(pixels[i]) + 0.5);
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p->has_value(), !printed[i]["particle"].is_null()) << printed[i];
    if (!*p) continue;
    EXPECT_EQ(printed[i]["particle"]["node"], (*p)->node);
    EXPECT_EQ(printed[i]["particle"]["index_in_node"], (*p)->index_in_node);
    EXPECT_EQ(printed[i]["particle"]["index"], (*p)->index);
    EXPECT_NEAR(printed[i]["particle"]["distance"].get<double>(), (*p)->distance, 1e-6 * (*p)->distance);
  }
  EXPECT_FALSE(printed[0]["particle"].is_null()) << "the close-up's centre shows a particle";

  fs::remove(out);
  for (const std::string bad : {"--pick 64,10", "--pick 3", "--pick 3,-1"}) {
    EXPECT_NE(mds::testing::run_mdstream(fmt::format("render {} -o {} --no-cull --spp 1 --width 64 --height 48 {}", store(),
                                                out.string(), bad)),
              0)
        << bad;
    EXPECT_NE(mds::testing::cli_stderr().find("--pick"), std::string::npos) << mds::testing::cli_stderr();
    EXPECT_FALSE(fs::exists(out)) << bad;
  }
  EXPECT_NE(mds::testing::run_mdstream(fmt::format("render {} -o {} --no-cull --width 64 --height 48 --path orbit "
                                              "--frames 2 --pick 3,3",
                                              store(), (*dir_ / "f_%04d.png").string())),
            0);
  EXPECT_NE(mds::testing::cli_stderr().find("--pick"), std::string::npos) << mds::testing::cli_stderr();
}

// A node the pick must read but cannot (a corrupted payload, skipped by the streamed render) is
// an error naming --pick and the store, and no image is left behind.
TEST_F(PickStore, AnUnreadableNodeOnTheRayIsAnErrorAndNoImage) {
  auto reader = store::StoreReader::open(store());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  auto cam = default_view(2, mds::testing::header_bounds(**reader), 40.0, 64.0 / 48.0);
  ASSERT_TRUE(cam.ok());
  const fs::path out = *dir_ / "bad.png", stats = *dir_ / "bad.json", bad = *dir_ / "bad.mds";
  // The node the centre pixel's ray ends in, from a render of the intact store (its camera).
  ASSERT_EQ(mds::testing::run_mdstream(fmt::format("render {} -o {} --no-cull --spp 1 --width 64 --height 48 --view 2 "
                                                   "--gpu-budget 64MiB --pick 32,24 --stats {} > /dev/null",
                                                   store(), out.string(), stats.string())),
            0)
      << mds::testing::cli_stderr();
  std::ifstream sf(stats);
  const nlohmann::json s = nlohmann::json::parse(sf);
  ASSERT_FALSE(s["picks"][0]["particle"].is_null());
  const uint32_t node = s["picks"][0]["particle"]["node"].get<uint32_t>();
  fs::copy_file(store(), bad, fs::copy_options::overwrite_existing);
  {
    std::fstream f(bad, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(std::streamoff((*reader)->nodes()[node].payload_offset + 16));
    f.put(char(0x5a ^ 0xff));
  }
  fs::remove(out);
  EXPECT_NE(mds::testing::run_mdstream(fmt::format("render {} -o {} --no-cull --spp 1 --width 64 --height 48 --view 2 "
                                                   "--gpu-budget 64MiB --pick 32,24 > /dev/null",
                                                   bad.string(), out.string())),
            0);
  const std::string err = mds::testing::cli_stderr();
  EXPECT_NE(err.find("--pick 32,24: " + bad.string()), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
}
