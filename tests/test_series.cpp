// Store series (store/series.h): the index's golden text, reading it back, its errors with
// their places; frame selections (core/frame_selection.h) with Python's slice semantics; and
// the store names of a series (convert/series_convert.h).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "convert/series_convert.h"
#include "core/frame_selection.h"
#include "scoped_temp_dir.h"
#include "store/series.h"

namespace mds {
namespace {

using ::testing::HasSubstr;

std::vector<int64_t> pick(const std::string& text, int64_t count) {
  auto sel = parse_frame_selection(text);
  EXPECT_TRUE(sel.ok()) << text << ": " << sel.error().message;
  if (!sel.ok()) return {};
  auto r = select_frames(*sel, count);
  EXPECT_TRUE(r.ok()) << text << ": " << r.error().message;
  return r.ok() ? *r : std::vector<int64_t>{};
}

std::string pick_error(const std::string& text, int64_t count) {
  auto sel = parse_frame_selection(text);
  if (!sel.ok()) return sel.error().message;
  auto r = select_frames(*sel, count);
  return r.ok() ? std::string() : r.error().message;
}

TEST(FrameSelection, PythonSliceSemantics) {
  using V = std::vector<int64_t>;
  EXPECT_EQ(pick("all", 4), (V{0, 1, 2, 3}));
  EXPECT_EQ(pick(":", 4), (V{0, 1, 2, 3}));
  EXPECT_EQ(pick("last", 4), (V{3}));
  EXPECT_EQ(pick("2", 4), (V{2}));
  EXPECT_EQ(pick("-1", 4), (V{3}));
  EXPECT_EQ(pick("-4", 4), (V{0}));
  EXPECT_EQ(pick("1:3", 10), (V{1, 2}));
  EXPECT_EQ(pick("::3", 10), (V{0, 3, 6, 9}));
  EXPECT_EQ(pick("1::4", 10), (V{1, 5, 9}));
  EXPECT_EQ(pick("-3:", 10), (V{7, 8, 9}));
  EXPECT_EQ(pick(":-8", 10), (V{0, 1}));
  EXPECT_EQ(pick("5:100", 7), (V{5, 6}));   // bounds clamp, as in Python
  EXPECT_EQ(pick("-100:2", 7), (V{0, 1}));
  EXPECT_EQ(pick("+1:+2", 7), (V{1}));
  // A step beyond int64 arithmetic's reach takes the first frame only (no overflow).
  EXPECT_EQ(pick("3::9223372036854775807", 10), (V{3}));
}

// Every slice with bounds in -6..6 (or empty) and steps 1..3 against Python's own list slicing,
// for sequences of 0..5 frames.
TEST(FrameSelection, AgreesWithPythonSlices) {
  std::vector<std::string> specs;
  std::vector<std::string> ends{""};
  for (int v = -6; v <= 6; ++v) ends.push_back(std::to_string(v));
  for (const auto& a : ends)
    for (const auto& b : ends)
      for (const char* st : {"", "1", "2", "3"}) specs.push_back(a + ":" + b + (*st ? std::string(":") + st : ""));
  test::ScopedTempDir dir("slices");
  const auto in = dir.p / "specs.txt", out = dir.p / "python.txt";
  {
    std::ofstream f(in);
    for (const auto& sp : specs) f << sp << "\n";
  }
  const std::string py = "import sys\n"
                         "out = open(sys.argv[2], 'w')\n"
                         "for spec in open(sys.argv[1]).read().split():\n"
                         "    parts = [int(p) if p else None for p in spec.split(':')]\n"
                         "    for n in range(6):\n"
                         "        out.write(' '.join(map(str, list(range(n))[slice(*parts)])) + '\\n')\n";
  const auto script = dir.p / "slices.py";
  std::ofstream(script) << py;
  ASSERT_EQ(std::system((std::string(MDSTREAM_PYTHON) + " " + script.string() + " " + in.string() + " " +
                         out.string()).c_str()),
            0);
  std::ifstream f(out);
  size_t checked = 0;
  for (const auto& sp : specs) {
    for (int64_t n = 0; n < 6; ++n) {
      std::string line;
      ASSERT_TRUE(std::getline(f, line)) << sp;
      std::string mine;
      auto sel = parse_frame_selection(sp);
      ASSERT_TRUE(sel.ok()) << sp;
      auto r = select_frames(*sel, n);
      if (r.ok())
        for (size_t i = 0; i < r->size(); ++i) mine += (i ? " " : "") + std::to_string((*r)[i]);
      EXPECT_EQ(mine, line) << "'" << sp << "' of " << n << " frames";  // empty: Python's [], our error
      ++checked;
    }
  }
  EXPECT_EQ(checked, specs.size() * 6);
}

TEST(FrameSelection, ErrorsNameTheTextAndTheCount) {
  EXPECT_THAT(pick_error("x", 4), HasSubstr("'x': not an index"));
  EXPECT_THAT(pick_error("1:2:3:4", 4), HasSubstr("more than two ':'"));
  EXPECT_THAT(pick_error("a:2", 4), HasSubstr("the start is not an index"));
  EXPECT_THAT(pick_error("1:b", 4), HasSubstr("the stop is not an index"));
  EXPECT_THAT(pick_error("::0", 4), HasSubstr("the step is not an integer >= 1"));
  EXPECT_THAT(pick_error("::-1", 4), HasSubstr("the step is not an integer >= 1"));
  EXPECT_THAT(pick_error("4", 4), HasSubstr("'4': out of range: there are 4 frames"));
  EXPECT_THAT(pick_error("-5", 4), HasSubstr("out of range"));
  EXPECT_THAT(pick_error("0", 0), HasSubstr("there are 0 frames"));
  EXPECT_THAT(pick_error("3:1", 4), HasSubstr("'3:1': selects none of the 4 frames"));
  EXPECT_THAT(pick_error("", 4), HasSubstr("not an index"));
}

// The golden bytes of an index: ParaView's layout, steps as integers, other times exactly.
TEST(StoreSeries, GoldenIndexText) {
  std::vector<store::SeriesFrame> f(3);
  f[0].name = "run.0000.mds";
  f[0].time = 0;
  f[1].name = "run.0001.mds";
  f[1].time = 1000;
  f[2].name = "a \"quoted\" name.mds";
  f[2].time = 0.1;
  EXPECT_EQ(store::series_json(f),
            "{\n"
            "  \"file-series-version\" : \"1.0\",\n"
            "  \"files\" : [\n"
            "    { \"name\" : \"run.0000.mds\", \"time\" : 0 },\n"
            "    { \"name\" : \"run.0001.mds\", \"time\" : 1000 },\n"
            "    { \"name\" : \"a \\\"quoted\\\" name.mds\", \"time\" : 0.1 }\n"
            "  ]\n"
            "}\n");
}

TEST(StoreSeries, RoundTripResolvesNamesAgainstTheIndexFolder) {
  test::ScopedTempDir dir("series");
  std::vector<store::SeriesFrame> f(2);
  f[0].name = "a.mds";
  f[0].time = -5;
  f[1].name = "/abs/b.mds";
  f[1].time = 1e300;
  const auto file = dir.p / "x.mds.series";
  ASSERT_TRUE(store::write_series(file, f).ok());
  auto s = store::read_series(file);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->frames.size(), 2u);
  EXPECT_EQ(s->frames[0].path, dir.p / "a.mds");
  EXPECT_EQ(s->frames[0].time, -5.0);
  EXPECT_EQ(s->frames[1].path, std::filesystem::path("/abs/b.mds"));
  EXPECT_EQ(s->frames[1].time, 1e300);
  EXPECT_TRUE(store::is_series_path(file));
  EXPECT_FALSE(store::is_series_path(dir.p / "x.mds"));
}

// Hostile indexes: each error names the file and the place (byte offset or JSON pointer).
TEST(StoreSeries, ErrorsNameTheFileAndThePlace) {
  test::ScopedTempDir dir("series");
  const auto file = dir.p / "bad.series";
  const auto error_of = [&](const std::string& text) {
    std::ofstream(file, std::ios::binary) << text;
    auto s = store::read_series(file);
    EXPECT_FALSE(s.ok()) << text;
    return s.ok() ? std::string() : s.error().message;
  };
  const std::string ok_head = R"({"file-series-version": "1.0", "files": )";
  EXPECT_THAT(error_of("{\"file-series-version\": \"1.0\",\n \"files\": [ }"), HasSubstr("byte offset 43: not JSON"));
  EXPECT_THAT(error_of("[]"), HasSubstr("/: expected an object"));
  EXPECT_THAT(error_of(R"({"files": []})"), HasSubstr("/file-series-version: missing"));
  EXPECT_THAT(error_of(R"({"file-series-version": "2.0", "files": []})"), HasSubstr("version \"2.0\" is not supported"));
  EXPECT_THAT(error_of(R"({"file-series-version": "1.0"})"), HasSubstr("/files: missing"));
  EXPECT_THAT(error_of(ok_head + "{}}"), HasSubstr("/files: expected an array"));
  EXPECT_THAT(error_of(ok_head + "[]}"), HasSubstr("/files: no files"));
  EXPECT_THAT(error_of(ok_head + R"([{"name": "a.mds", "time": 0}, 3]})"), HasSubstr("/files/1: expected an object"));
  EXPECT_THAT(error_of(ok_head + R"([{"name": "", "time": 0}]})"), HasSubstr("/files/0/name: expected a non-empty"));
  EXPECT_THAT(error_of(ok_head + R"([{"name": 7, "time": 0}]})"), HasSubstr("/files/0/name"));
  EXPECT_THAT(error_of(ok_head + R"([{"name": "a.mds"}]})"), HasSubstr("/files/0/time: expected a number"));
  EXPECT_THAT(error_of(ok_head + R"([{"name": "a.mds", "time": "0"}]})"), HasSubstr("/files/0/time"));
  EXPECT_THAT(error_of("{"), HasSubstr(file.string()));
  // A number beyond double's range throws out_of_range in nlohmann, not parse_error (fuzz_series).
  EXPECT_THAT(error_of(ok_head + R"([{"name": "a.mds", "time": 22222e0922}]})"), HasSubstr("number overflow"));
  EXPECT_THAT(error_of("22222e0922ee"), HasSubstr("not JSON"));
  auto missing = store::read_series(dir.p / "none.series");
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(missing.error().message, HasSubstr("cannot open"));
}

TEST(StoreSeries, StoreNamesOfASeries) {
  using convert::series_store_path;
  EXPECT_EQ(series_store_path("out/run.mds.series", 3, 10), std::filesystem::path("out/run.0003.mds"));
  EXPECT_EQ(series_store_path("run.series", 0, 1), std::filesystem::path("run.0000.mds"));
  EXPECT_EQ(series_store_path("run.series", 12345, 20000), std::filesystem::path("run.12345.mds"));
  EXPECT_EQ(series_store_path("run.series", 7, 10001), std::filesystem::path("run.00007.mds"));
  EXPECT_EQ(series_store_path(".series", 1, 2), std::filesystem::path(".series.0001.mds"));
}

}  // namespace
}  // namespace mds
