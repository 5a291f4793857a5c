// MMPLD reader tests: files written by tests/tools/write_mmpld.py (an independent
// writer following MegaMol's layout), every vertex and colour type, versions 100-103,
// several lists and frames, and hostile files (truncation, absurd counts, NaN).
#include <cmath>
#include <cstring>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "binreader_test_util.h"
#include "readers/mmpld_reader.h"
#include "readers/reader_factories.h"

namespace mds {
namespace {

using nlohmann::json;
using testing::TempDir;

struct Written {
  std::filesystem::path file;
  json expected;
};

// Writes each spec with one Python call; returns file + expected values per spec.
std::vector<Written> write_mmpld(const TempDir& dir, const std::vector<json>& specs) {
  std::vector<std::string> args{testing::source_path("tests/tools/write_mmpld.py")};
  std::vector<Written> out;
  for (size_t i = 0; i < specs.size(); ++i) {
    auto spec = dir / fmt::format("spec{}.json", i);
    auto file = dir / fmt::format("f{}.mmpld", i);
    auto exp = dir / fmt::format("f{}.expected.json", i);
    testing::write_text(spec, specs[i].dump());
    args.insert(args.end(), {spec.string(), file.string(), exp.string()});
    out.push_back({file, {}});
  }
  EXPECT_EQ(testing::run_python(args), 0);
  for (size_t i = 0; i < specs.size(); ++i) {
    std::ifstream f(dir / fmt::format("f{}.expected.json", i));
    out[i].expected = json::parse(f);
  }
  return out;
}

void expect_frame(const std::filesystem::path& file, int64_t frame, const json& exp, size_t batch) {
  SCOPED_TRACE(file.string() + " frame " + std::to_string(frame) + " batch " + std::to_string(batch));
  ReaderOptions opt;
  opt.frame = frame;
  auto r = open_mmpld_reader(file, opt);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const FrameInfo& info = (*r)->info();
  const size_t n = exp["x"].size();
  EXPECT_EQ(info.particle_count, n);
  EXPECT_EQ(info.has_radius, !exp["radius"].is_null());
  std::map<int32_t, float> tr;
  for (auto& [k, v] : exp["type_radius"].items()) tr[std::stoi(k)] = v.get<float>();
  EXPECT_EQ(info.type_radius, tr);
  auto all = testing::read_all(**r, batch);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->x.size(), n);
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(all->x[i], exp["x"][i].get<double>()) << i;
    ASSERT_EQ(all->y[i], exp["y"][i].get<double>()) << i;
    ASSERT_EQ(all->z[i], exp["z"][i].get<double>()) << i;
    ASSERT_EQ(all->type[i], exp["type"][i].get<int32_t>()) << i;
  }
  if (exp["radius"].is_null()) {
    EXPECT_TRUE(all->radius.empty());
  } else {
    ASSERT_EQ(all->radius.size(), n);
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(all->radius[i], exp["radius"][i].get<float>()) << i;
  }
}

// One list per colour type (plus a position-less list and an empty list) for a vertex type.
json all_colours_spec(int version, int vertex, int seed) {
  json lists = json::array();
  for (int c = 0; c <= 7; ++c) lists.push_back({{"vertex", vertex}, {"colour", c}, {"count", 5 + 3 * c}, {"radius", 0.25 * (c + 1)}});
  lists.push_back({{"vertex", 0}, {"colour", 0}, {"count", 17}});
  lists.push_back({{"vertex", vertex}, {"colour", 2}, {"count", 0}, {"radius", 1.0}});
  return {{"version", version}, {"seed", seed}, {"frames", json::array({{{"lists", lists}}})}};
}

TEST(MmpldReader, EveryVertexAndColourTypeAllVersions) {
  TempDir dir;
  std::vector<json> specs;
  for (int version = 100; version <= 103; ++version)
    for (int vertex = 1; vertex <= 4; ++vertex) specs.push_back(all_colours_spec(version, vertex, version * 10 + vertex));
  auto files = write_mmpld(dir, specs);
  for (size_t i = 0; i < files.size(); ++i) {
    auto r = open_mmpld_reader(files[i].file, {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    auto* m = dynamic_cast<MmpldReader*>(r->get());
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(m->version(), specs[i]["version"].get<int>());
    EXPECT_EQ(m->lists().size(), 10u);
    EXPECT_TRUE((*r)->info().has_box);
    EXPECT_EQ((*r)->info().box_lo[0], files[i].expected["bbox"][0].get<double>());
    EXPECT_EQ((*r)->info().box_hi[2], files[i].expected["bbox"][5].get<double>());
    // The data set's bounding box is the (non-periodic) cell.
    const SimulationCell& c = (*r)->info().cell;
    EXPECT_EQ(c.origin[1], files[i].expected["bbox"][1].get<double>());
    EXPECT_EQ(c.origin[1] + c.vectors[1][1], files[i].expected["bbox"][4].get<double>());
    EXPECT_TRUE(c.orthogonal());
    EXPECT_FALSE(c.periodic[0] || c.periodic[1] || c.periodic[2]);
    expect_frame(files[i].file, 0, files[i].expected["frames"][0], 1000);
    expect_frame(files[i].file, 0, files[i].expected["frames"][0], 7);  // batches cross list boundaries
  }
}

TEST(MmpldReader, MixedListsPerParticleAndGlobalRadius) {
  TempDir dir;
  json lists = json::array({{{"vertex", 1}, {"colour", 0}, {"count", 20}, {"radius", 0.7}},
                            {{"vertex", 2}, {"colour", 5}, {"count", 30}},
                            {{"vertex", 4}, {"colour", 7}, {"count", 10}, {"radius", 2.5}},
                            {{"vertex", 3}, {"colour", 6}, {"count", 10}, {"radius", 1.5}}});
  auto files = write_mmpld(dir, {{{"version", 102}, {"seed", 5}, {"frames", json::array({{{"lists", lists}}})}}});
  const json& exp = files[0].expected["frames"][0];
  ASSERT_FALSE(exp["radius"].is_null());
  expect_frame(files[0].file, 0, exp, 13);
  expect_frame(files[0].file, -1, exp, 64);
}

TEST(MmpldReader, FrameSelection) {
  TempDir dir;
  json frames = json::array();
  for (int f = 0; f < 4; ++f)
    frames.push_back({{"lists", json::array({{{"vertex", 1}, {"colour", 1}, {"count", 10 + f}, {"radius", 0.5}},
                                             {{"vertex", 2}, {"colour", 0}, {"count", 5 * f}}})}});
  std::vector<json> specs;
  for (int v = 100; v <= 103; ++v) specs.push_back({{"version", v}, {"seed", v}, {"frames", frames}});
  auto files = write_mmpld(dir, specs);
  for (auto& w : files) {
    for (int f = 0; f < 4; ++f) expect_frame(w.file, f, w.expected["frames"][f], 6);
    expect_frame(w.file, -1, w.expected["frames"][3], 6);
    ReaderOptions opt;
    opt.frame = 4;
    auto r = open_mmpld_reader(w.file, opt);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("4 frames"), std::string::npos) << r.error().message;
  }
}

// list_frames on MMPLD: the frame table's frames, each with its particle count (the sum of its
// lists), the index standing in for the step.
TEST(MmpldReader, ListFrames) {
  TempDir dir;
  json frames = json::array();
  for (int f = 0; f < 3; ++f)
    frames.push_back({{"lists", json::array({{{"vertex", 1}, {"colour", 1}, {"count", 10 + f}, {"radius", 0.5}},
                                             {{"vertex", 2}, {"colour", 0}, {"count", 5 * f}}})}});
  auto files = write_mmpld(dir, {{{"version", 103}, {"seed", 3}, {"frames", frames}}});
  auto list = list_frames(files[0].file, {});
  ASSERT_TRUE(list.ok()) << list.error().message;
  ASSERT_EQ(list->size(), 3u);
  for (int f = 0; f < 3; ++f) {
    EXPECT_EQ((*list)[size_t(f)].timestep, f);
    EXPECT_EQ((*list)[size_t(f)].particle_count, uint64_t(10 + f + 5 * f));
  }
}

TEST(MmpldReader, Legacy103WithoutTimestampIsAccepted) {
  TempDir dir;
  json lists = json::array({{{"vertex", 1}, {"colour", 3}, {"count", 9}, {"radius", 0.5}}});
  auto files = write_mmpld(
      dir, {{{"version", 103}, {"seed", 9}, {"omit_timestamp", true}, {"frames", json::array({{{"lists", lists}}, {{"lists", lists}}})}}});
  expect_frame(files[0].file, 0, files[0].expected["frames"][0], 4);
  expect_frame(files[0].file, 1, files[0].expected["frames"][1], 4);
}

class MmpldHostile : public ::testing::Test {
 protected:
  void SetUp() override {
    json lists = json::array({{{"vertex", 1}, {"colour", 2}, {"count", 40}, {"radius", 0.5}},
                              {{"vertex", 2}, {"colour", 0}, {"count", 25}}});
    files_ = write_mmpld(dir_, {{{"version", 100}, {"seed", 2}, {"frames", json::array({{{"lists", lists}}, {{"lists", lists}}})}}});
    bytes_ = testing::read_bytes(files_[0].file);
  }
  // Writes a modified copy and returns the error of open()+read-all (or "" on success).
  std::string error_of(const std::vector<char>& bytes, int64_t frame = 0) {
    auto p = dir_ / "bad.mmpld";
    testing::write_bytes(p, bytes.data(), bytes.size());
    ReaderOptions opt;
    opt.frame = frame;
    auto r = open_mmpld_reader(p, opt);
    if (!r.ok()) return r.error().message;
    auto all = testing::read_all(**r, 16);
    return all.ok() ? std::string() : all.error().message;
  }
  template <class T>
  void patch(std::vector<char>& b, uint64_t at, T v) { std::memcpy(b.data() + at, &v, sizeof(T)); }

  TempDir dir_;
  std::vector<Written> files_;
  std::vector<char> bytes_;
};

TEST_F(MmpldHostile, TruncatedAnywhereIsAnErrorWithByteOffset) {
  ASSERT_TRUE(error_of(bytes_, 1).empty());
  // Every truncation point in the header, frame table, list headers and data.
  for (size_t len = 0; len < bytes_.size(); len += (len < 200 ? 1 : 37)) {
    std::vector<char> b(bytes_.begin(), bytes_.begin() + static_cast<std::ptrdiff_t>(len));
    std::string e = error_of(b, 1);
    ASSERT_FALSE(e.empty()) << "truncated to " << len << " bytes was accepted";
    EXPECT_NE(e.find("byte offset"), std::string::npos) << e;
    EXPECT_NE(e.find("bad.mmpld"), std::string::npos) << e;
  }
}

TEST_F(MmpldHostile, AbsurdParticleCountRejectedBeforeAllocation) {
  auto b = bytes_;
  const uint64_t at = files_[0].expected["frames"][0]["count_offsets"][0];
  patch<uint64_t>(b, at, uint64_t{1} << 60);
  std::string e = error_of(b);
  EXPECT_NE(e.find(fmt::format("byte offset {}", at)), std::string::npos) << e;
  EXPECT_NE(e.find("particle count"), std::string::npos) << e;
  // A count just one too large for the frame also fails (it would overlap the next list).
  b = bytes_;
  patch<uint64_t>(b, at, 41);
  EXPECT_FALSE(error_of(b).empty());
}

TEST_F(MmpldHostile, AbsurdFrameCountAndOffsets) {
  auto b = bytes_;
  patch<uint32_t>(b, 8, 0xFFFFFFFFu);
  std::string e = error_of(b);
  EXPECT_NE(e.find("frame count 4294967295"), std::string::npos) << e;
  b = bytes_;
  const uint64_t table = files_[0].expected["table_offset"];
  patch<uint64_t>(b, table + 8, uint64_t{1} << 62);  // end of frame 0 far outside the file
  e = error_of(b);
  EXPECT_NE(e.find(fmt::format("byte offset {}", table)), std::string::npos) << e;
  b = bytes_;
  patch<uint64_t>(b, table, 3);  // frame inside the header
  EXPECT_FALSE(error_of(b).empty());
}

TEST_F(MmpldHostile, BadMagicVersionTypesAndNaN) {
  auto b = bytes_;
  b[0] = 'X';
  EXPECT_NE(error_of(b).find("not an MMPLD file"), std::string::npos);
  b = bytes_;
  patch<uint16_t>(b, 6, 104);
  EXPECT_NE(error_of(b).find("version 104"), std::string::npos);
  const uint64_t count_at = files_[0].expected["frames"][0]["count_offsets"][0];
  // list 0 (FLOAT_XYZ, UINT8_RGBA) header: vertex type, colour type, global radius, count.
  b = bytes_;
  b[count_at - 6] = 9;
  EXPECT_NE(error_of(b).find("unknown vertex type 9"), std::string::npos) << error_of(b);
  b = bytes_;
  b[count_at - 5] = 42;
  EXPECT_NE(error_of(b).find("unknown colour type 42"), std::string::npos);
  b = bytes_;
  const uint64_t particle3 = count_at + 8 + 3 * 16;  // FLOAT_XYZ + UINT8_RGBA = 16-byte stride
  patch<float>(b, particle3 + 4, std::nanf(""));
  std::string e = error_of(b);
  EXPECT_NE(e.find(fmt::format("byte offset {}", particle3)), std::string::npos) << e;
  EXPECT_NE(e.find("particle 3"), std::string::npos) << e;
  // Trailing bytes inside a frame.
  b = bytes_;
  const uint64_t table = files_[0].expected["table_offset"];
  uint64_t end0;
  std::memcpy(&end0, b.data() + table + 8, 8);
  patch<uint64_t>(b, table + 8, end0 + 16);
  EXPECT_NE(error_of(b).find("trailing"), std::string::npos);
}

}  // namespace
}  // namespace mds
