// The colours of particle types (store/type_colors.h): the TYPE=COLOR syntax of --type-color and
// --background, the lookup of a type by name or input id, and the resolved table the renderer
// uploads (render::resolve_type_colors, render::set_type_colors).
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "render/scene.h"
#include "store/type_colors.h"

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
                          "-0.1,0,0", "nan,0,0", "0.1x,0,0", " 1,0,0", "red"}) {
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
