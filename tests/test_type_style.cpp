// The colours of particle types (store/type_style.h): the TYPE=COLOR syntax of --type-color and
// --background, the lookup of a type by name or input id, and the resolved table the renderer
// uploads (render::resolve_type_colors, render::set_type_colors).
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "render/culling/density_volume.h"
#include "render/scene.h"
#include "store/type_style.h"

using namespace mds;
using namespace mds::store;

namespace {

TypeEntry type(int32_t id, const char* name = "") {
  TypeEntry t{};
  t.input_id = id;
  t.radius = 0.5f;
  std::strncpy(t.name, name, sizeof(t.name) - 1);
  return t;
}

}  // namespace

TEST(TypeColors, ParsesHexAndDecimalTriples) {
  auto a = parse_srgb("#FF8000");
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_EQ(*a, (Srgb{1.0f, 128.0f / 255.0f, 0.0f}));
  auto b = parse_srgb("#0a0B0c");
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(*b, (Srgb{10 / 255.0f, 11 / 255.0f, 12 / 255.0f}));
  auto c = parse_srgb("0,0.5,1");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(*c, (Srgb{0.0f, 0.5f, 1.0f}));
  auto spaced = parse_srgb(" 0, 0.5 ,1 ");
  ASSERT_TRUE(spaced.ok()) << spaced.error().message;
  EXPECT_EQ(*spaced, *c);
  EXPECT_EQ(*parse_srgb(" #ff8000 "), *a);
  // Every byte survives the hex round trip.
  for (int v = 0; v < 256; ++v) {
    const std::string hex = srgb_hex({v / 255.0f, (255 - v) / 255.0f, (v * 7 % 256) / 255.0f});
    auto back = parse_srgb(hex);
    ASSERT_TRUE(back.ok()) << hex;
    EXPECT_EQ(srgb_hex(*back), hex);
  }
  EXPECT_EQ(srgb_hex({1.0f, 0.0f, 0.5f}), "#ff0080");
}

TEST(TypeColors, RejectsMalformedColours) {
  for (const char* bad : {"", "#", "#fff", "#ff00000", "#gg0000", "#ff 000", "1,0", "1,0,0,0", "0.5,,1", "2,0,0",
                          "-0.1,0,0", "nan,0,0", "0.1x,0,0", "0. 1,0,0", "red"}) {
    auto r = parse_srgb(bad);
    ASSERT_FALSE(r.ok()) << "'" << bad << "' parsed";
    EXPECT_EQ(r.error().code, Errc::invalid_argument);
    EXPECT_NE(r.error().message.find(std::string("'") + bad + "'"), std::string::npos) << r.error().message;
  }
}

TEST(TypeColors, ParsesTypeEqualsColour) {
  auto s = parse_type_color("Cu=0.72,0.45,0.2");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->key, "Cu");
  EXPECT_EQ(s->color, (Srgb{0.72f, 0.45f, 0.2f}));
  auto t = parse_type_color("2=#00ff00");
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(t->key, "2");
  for (const char* bad : {"2", "=#ff0000", "2=", "2=#ff00", "2:#ff0000"}) {
    auto r = parse_type_color(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find(bad), std::string::npos) << r.error().message;
  }
}

// A key is a type's name first, then its input id; anything else names the store's types.
TEST(TypeColors, FindsTypesByNameThenInputId) {
  const std::vector<TypeEntry> types = {type(1), type(7, "Cu"), type(3, "2")};
  EXPECT_EQ(*find_type(types, "1"), 0u);
  EXPECT_EQ(*find_type(types, "Cu"), 1u);
  EXPECT_EQ(*find_type(types, "7"), 1u);
  EXPECT_EQ(*find_type(types, "2"), 2u);  // the name "2" before an input id 2 (there is none)
  EXPECT_EQ(*find_type(types, "3"), 2u);
  for (const char* bad : {"cu", "9", "", "1.0", "01x"}) {
    auto r = find_type(types, bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, Errc::invalid_argument);
    EXPECT_NE(r.error().message.find("1, 7 (Cu), 3 (2)"), std::string::npos) << r.error().message;
  }
  auto none = find_type({}, "1");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("none"), std::string::npos);
}

TEST(TypeColors, ResolvesThePaletteWithOverrides) {
  std::vector<TypeEntry> types;
  for (int i = 0; i < 12; ++i) types.push_back(type(i + 1));
  auto d = type_colors(types, {});
  ASSERT_TRUE(d.ok());
  ASSERT_EQ(d->size(), 12u);
  EXPECT_EQ(srgb_hex((*d)[0]), "#4e79a7");
  EXPECT_EQ((*d)[10], (*d)[0]);  // the palette cycles after 10
  EXPECT_NE((*d)[1], (*d)[0]);
  const std::vector<TypeColorSpec> specs = {{"2", {1, 0, 0}}, {"12", {0, 0, 1}}};
  auto o = type_colors(types, specs);
  ASSERT_TRUE(o.ok()) << o.error().message;
  EXPECT_EQ((*o)[1], (Srgb{1, 0, 0}));
  EXPECT_EQ((*o)[11], (Srgb{0, 0, 1}));
  EXPECT_EQ((*o)[0], (*d)[0]);
  // A type given twice, by the same or another key, is an error naming both keys.
  types[3] = type(4, "Fe");
  const std::vector<TypeColorSpec> twice = {{"Fe", {1, 0, 0}}, {"4", {0, 1, 0}}};
  auto e = type_colors(types, twice);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("'Fe' and '4'"), std::string::npos) << e.error().message;
  const std::vector<TypeColorSpec> unknown = {{"13", {1, 0, 0}}};
  EXPECT_FALSE(type_colors(types, unknown).ok());
}

// The renderer's table: the resolved sRGB colours stored linear; types beyond the list keep theirs.
TEST(TypeColors, RendererTableTakesTheResolvedColours) {
  const std::vector<TypeEntry> types = {type(1), type(2, "O")};
  const std::vector<TypeColorSpec> specs = {{"O", {1.0f, 0.5f, 0.0f}}};
  auto colors = render::resolve_type_colors(types, specs);
  ASSERT_TRUE(colors.ok()) << colors.error().message;
  ASSERT_EQ(colors->size(), 2u);
  EXPECT_EQ((*colors)[0], render::type_color_srgb(0));
  EXPECT_EQ((*colors)[1], glm::vec3(1.0f, 0.5f, 0.0f));
  std::vector<gpu::GpuType> table(3);
  table[2].color = glm::vec4(0.25f);
  render::set_type_colors(table, *colors);
  EXPECT_EQ(table[1].color, glm::vec4(1.0f, render::srgb_to_linear(0.5f), 0.0f, 1.0f));
  EXPECT_EQ(table[0].color.b, render::srgb_to_linear(render::type_color_srgb(0).b));
  EXPECT_EQ(table[2].color, glm::vec4(0.25f));
}

// --hide-type's keys: the same lookup; hiding every type is an error.
TEST(HiddenTypes, ShownTypesFromKeys) {
  const std::vector<TypeEntry> types = {type(1), type(2, "Cu"), type(3)};
  auto none = shown_types(types, {});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  const std::vector<std::string> keys = {"Cu", "3"};
  auto some = shown_types(types, keys);
  ASSERT_TRUE(some.ok()) << some.error().message;
  EXPECT_EQ(*some, (std::vector<uint8_t>{1, 0, 0}));
  const std::vector<std::string> all = {"1", "2", "3"};
  auto e = shown_types(types, all);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("every type"), std::string::npos);
  const std::vector<std::string> unknown = {"Fe"};
  EXPECT_FALSE(shown_types(types, unknown).ok());
}

// load_scene's filter: per meshlet the shown particles in order (positions, types, radii), a
// meshlet left empty dropped; a malformed node is passed on whole for append_node to report.
TEST(HiddenTypes, FilterKeepsShownParticlesMeshletByMeshlet) {
  store::NodeData in;
  in.type_index = {0, 1, 0, 1, 1, 2, 0};
  in.meshlet_size = {3, 2, 2};
  for (uint16_t i = 0; i < 7; ++i) {
    in.qpos.insert(in.qpos.end(), {uint16_t(10 * i), uint16_t(10 * i + 1), uint16_t(10 * i + 2)});
    in.radius_q.push_back(uint16_t(100 + i));
  }
  const std::vector<uint8_t> shown = {1, 0, 1};
  store::NodeData out;
  render::filter_types(in, shown, out);
  EXPECT_EQ(out.meshlet_size, (std::vector<uint8_t>{2, 2}));
  EXPECT_EQ(out.type_index, (std::vector<uint8_t>{0, 0, 2, 0}));
  EXPECT_EQ(out.radius_q, (std::vector<uint16_t>{100, 102, 105, 106}));
  EXPECT_EQ(out.qpos, (std::vector<uint16_t>{0, 1, 2, 20, 21, 22, 50, 51, 52, 60, 61, 62}));
  // Without radii; every type shown keeps the node as it is.
  in.radius_q.clear();
  const std::vector<uint8_t> every = {1, 1, 1};
  render::filter_types(in, every, out);
  EXPECT_EQ(out.type_index, in.type_index);
  EXPECT_EQ(out.meshlet_size, in.meshlet_size);
  EXPECT_TRUE(out.radius_q.empty());
  // Meshlet sizes that overrun the node: passed on whole.
  in.meshlet_size = {3, 2, 9};
  render::filter_types(in, shown, out);
  EXPECT_EQ(out.meshlet_size, in.meshlet_size);
  EXPECT_EQ(out.type_index, in.type_index);
}

// The culling's density volume of a scene without some types: the store's grid, the scene's counts.
TEST(HiddenTypes, DensityOnTheStoreGridCountsTheScene) {
  std::vector<glm::dvec3> pos;
  std::vector<uint8_t> types;
  for (int i = 0; i < 500; ++i) {
    pos.emplace_back(i % 10, (i / 10) % 10, i / 100);
    types.push_back(uint8_t(i % 3 == 0));
  }
  const std::vector<float> radius = {0.4f, 0.4f};
  auto scene = render::scene_from_particles(pos, types, radius, 64, 8);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  render::culling::DensityVolume grid;
  grid.dims = {3, 2, 2};
  grid.origin = {-0.5, -0.5, -0.5};
  grid.cell = {4.0, 6.0, 3.0};
  grid.counts.assign(12, 1000);
  const render::culling::DensityVolume v = render::culling::density_on_grid(*scene, grid);
  EXPECT_EQ(v.dims, grid.dims);
  EXPECT_EQ(v.cell, grid.cell);
  EXPECT_EQ(v.origin, grid.origin);
  EXPECT_EQ(v.total(), 500u);
  // x in [-0.5, 3.5) -> cell 0: 4 of every 10 columns, y in [-0.5, 5.5) -> 6 of 10, z in [-0.5, 2.5) -> 3 of 5.
  EXPECT_EQ(v.counts[0], 4 * 6 * 3);
}

// The culling's footprint radius (the smallest particle) comes from the types drawn: a hidden
// small type (a solvent) must not shrink it.
TEST(HiddenTypes, SmallestRadiusOfTheShownTypes) {
  const std::vector<float> radius = {0.1f, 0.5f, 0.3f};
  render::SceneData s = render::begin_scene(glm::dvec3(0.0), glm::dvec3(1.0), radius, false, 0.0f, 0.0f);
  EXPECT_EQ(render::smallest_radius(s), 0.1f);
  s.shown_types = {0, 1, 1};
  EXPECT_EQ(render::smallest_radius(s), 0.3f);
  s.shown_types = {0, 1, 0};
  EXPECT_EQ(render::smallest_radius(s), 0.5f);
}

TEST(TypeRadii, ParsesAndResolvesOverrides) {
  auto a = parse_type_radius("Cu=1.28");
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_EQ(a->key, "Cu");
  EXPECT_EQ(a->radius, 1.28f);
  auto b = parse_type_radius("2= 0.5 ");
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_EQ(b->radius, 0.5f);
  for (const char* bad : {"2", "=1", "2=", "2=0", "2=-1", "2=nan", "2=inf", "2=1e39", "2=x", "2=1.5.1"}) {
    auto r = parse_type_radius(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find(bad), std::string::npos) << r.error().message;
  }
  std::vector<TypeEntry> types = {type(1), type(2, "Cu"), type(3)};
  types[2].radius = 0.9f;
  const std::vector<TypeRadiusSpec> specs = {{"Cu", 1.25f}, {"1", 0.1f}};
  auto r = type_radii(types, specs);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(*r, (std::vector<float>{0.1f, 1.25f, 0.9f}));
  const std::vector<TypeRadiusSpec> twice = {{"2", 1.0f}, {"Cu", 2.0f}};
  auto e = type_radii(types, twice);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("two radii"), std::string::npos);
  const std::vector<TypeRadiusSpec> unknown = {{"4", 1.0f}};
  EXPECT_FALSE(type_radii(types, unknown).ok());
}
