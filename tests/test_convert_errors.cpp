// `mdstream convert` on bad input and bad options: non-zero exit, a message naming the
// file, no output file and no temporary files left behind.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "scoped_temp_dir.h"

using namespace std::string_literals;
namespace fs = std::filesystem;

namespace {

struct TmpDir : mds::test::ScopedTempDir {
  TmpDir() : ScopedTempDir("mds_convert_err_") {}
};

struct Run {
  int code;
  std::string err;
};

Run convert(const TmpDir& td, const std::string& args, const std::string& env = "") {
  const fs::path err = td.p / "stderr.txt.log";
  const std::string cmd = env + std::string(MDSTREAM_BIN) + " convert " + args + " 2>" + err.string() + " >/dev/null";
  const int st = std::system(cmd.c_str());
  std::ifstream f(err);
  std::string text((std::istreambuf_iterator<char>(f)), {});
  fs::remove(err);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, text};
}

// Everything in the directory except the given inputs.
std::vector<std::string> leftovers(const fs::path& dir, const std::vector<std::string>& inputs) {
  std::vector<std::string> v;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (std::find(inputs.begin(), inputs.end(), name) == inputs.end()) v.push_back(name);
  }
  return v;
}

// A valid LAMMPS dump of n particles on a jittered grid; `types` distinct types.
void write_dump(const fs::path& path, size_t n, int types = 2, size_t declared = 0, const char* bad_line = nullptr,
                size_t bad_at = 0) {
  FILE* f = std::fopen(path.c_str(), "w");
  std::fprintf(f, "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n%zu\nITEM: BOX BOUNDS pp pp pp\n0 100\n0 100\n0 100\n",
               declared ? declared : n);
  std::fprintf(f, "ITEM: ATOMS id type x y z\n");
  std::mt19937 rng(5);
  for (size_t i = 0; i < n; ++i) {
    if (bad_line && i == bad_at) {
      std::fprintf(f, "%s\n", bad_line);
      continue;
    }
    std::fprintf(f, "%zu %d %.4f %.4f %.4f\n", i + 1, 1 + int(i % size_t(types)), (rng() % 100000) * 1e-3,
                 (rng() % 100000) * 1e-3, (rng() % 100000) * 1e-3);
  }
  std::fclose(f);
}

}  // namespace

TEST(ConvertErrors, NonexistentInput) {
  TmpDir td;
  auto r = convert(td, (td.p / "missing.dump").string() + " -o " + (td.p / "o.mds").string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("missing.dump"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers(td.p, {}).empty());
}

TEST(ConvertErrors, MalformedInputsLeaveNothingBehind) {
  TmpDir td;
  struct Case {
    const char* name;
    size_t n;
    size_t declared;
    const char* bad_line;
    size_t bad_at;
  };
  const Case cases[] = {
      {"nan.dump", 2000, 0, "17 1 nan 2.0 3.0", 1500},
      {"inf.dump", 2000, 0, "17 1 1.0 inf 3.0", 10},
      {"short.dump", 2000, 2500, nullptr, 0},        // fewer atoms than declared
      {"cols.dump", 2000, 0, "17 1 1.0 2.0", 700},   // missing column
      {"garbage.dump", 2000, 0, "17 1 1.0 2.0 abc", 1999},
  };
  for (const auto& c : cases) {
    write_dump(td.p / c.name, c.n, 2, c.declared, c.bad_line, c.bad_at);
    auto r = convert(td, (td.p / c.name).string() + " -o " + (td.p / "o.mds").string());
    EXPECT_NE(r.code, 0) << c.name;
    EXPECT_NE(r.err.find(c.name), std::string::npos) << c.name << ": " << r.err;
    EXPECT_FALSE(fs::exists(td.p / "o.mds")) << c.name;
    EXPECT_TRUE(leftovers(td.p, {c.name}).empty()) << c.name;
    fs::remove(td.p / c.name);
  }
}

TEST(ConvertErrors, FailureAfterSpillingRemovesTemporaries) {
  // Large enough for a small budget to spill before the bad line near the end is reached.
  TmpDir td;
  write_dump(td.p / "late.dump", 200000, 2, 0, "5 1 1.0 2.0 nan", 199990);
  auto r = convert(td, (td.p / "late.dump").string() + " -o " + (td.p / "o.mds").string() +
                           " --memory-budget 2MiB --node-size 1000 --density-res 1000");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("late.dump"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers(td.p, {"late.dump"}).empty());
  // and with the temporary directory elsewhere
  fs::create_directories(td.p / "t");
  r = convert(td, (td.p / "late.dump").string() + " -o " + (td.p / "o.mds").string() +
                      " --memory-budget 2MiB --node-size 1000 --density-res 1000 --tmp-dir " + (td.p / "t").string());
  EXPECT_NE(r.code, 0);
  EXPECT_TRUE(fs::is_empty(td.p / "t"));
}

TEST(ConvertErrors, BadOptionsExitWithUsageCode) {
  TmpDir td;
  write_dump(td.p / "ok.dump", 100);
  const std::string base = (td.p / "ok.dump").string() + " -o " + (td.p / "o.mds").string() + " ";
  for (const std::string& opt :
       {"--node-size 0"s, "--node-size 70000"s, "--meshlet-size 0"s, "--meshlet-size 256"s, "--radius -1"s,
        "--radius-by-type 1=abc"s, "--density-res 0x4x4"s, "--density-res foo"s, "--memory-budget 12XB"s,
        "--format pdb"s, "--frame -3"s, "--frame first"s, "--threads 0"s, "--meshlet-builder kdtree"s}) {
    auto r = convert(td, base + opt);
    EXPECT_EQ(r.code, 2) << opt << ": " << r.err;
    EXPECT_NE(r.err.find("error"), std::string::npos) << opt;
    EXPECT_TRUE(leftovers(td.p, {"ok.dump"}).empty()) << opt;
  }
  // the output must never replace an input
  auto r = convert(td, (td.p / "ok.dump").string() + " -o " + (td.p / "ok.dump").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_TRUE(leftovers(td.p, {"ok.dump"}).empty());
  EXPECT_GT(fs::file_size(td.p / "ok.dump"), 100u);
}

TEST(ConvertErrors, BudgetTooSmallForOneNode) {
  TmpDir td;
  write_dump(td.p / "ok.dump", 1000);
  auto r = convert(td, (td.p / "ok.dump").string() + " -o " + (td.p / "o.mds").string() + " --memory-budget 100K");
  EXPECT_EQ(r.code, 4) << r.err;
  EXPECT_NE(r.err.find("memory-budget"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers(td.p, {"ok.dump"}).empty());
}

TEST(ConvertErrors, TooManyTypes) {
  TmpDir td;
  write_dump(td.p / "types.dump", 1000, 300);
  auto r = convert(td, (td.p / "types.dump").string() + " -o " + (td.p / "o.mds").string());
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("types.dump"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("256"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers(td.p, {"types.dump"}).empty());
}

TEST(ConvertErrors, SucceedsAndPrintsSummary) {
  // The same helper input converts fine: the failures above are caused by the defects only.
  TmpDir td;
  write_dump(td.p / "ok.dump", 5000, 3);
  auto r = convert(td, (td.p / "ok.dump").string() + " -o " + (td.p / "o.mds").string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("bytes/particle"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("max quant. error"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("pcl builder"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("x spacing"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(td.p / "o.mds"));
  EXPECT_TRUE(leftovers(td.p, {"ok.dump", "o.mds"}).empty());
}

// H5MD is read by a module loaded on demand (readers/h5md_module.h): found next to the
// executable or in the build folder, and when it cannot be loaded the conversion fails naming
// the input and every place looked in, with no output.
TEST(ConvertErrors, H5mdInputWithoutItsModule) {
  TmpDir td;
  const fs::path in = td.p / "in.h5md";
  const std::string py = std::string(MDSTREAM_PYTHON) +
                         " -c \"import h5py, numpy as np; f = h5py.File('" + in.string() +
                         "', 'w'); f.create_group('h5md'); "
                         "f.create_dataset('particles/all/position/value', data=np.random.rand(1, 50, 3).astype('f4')); "
                         "f.close()\"";
  ASSERT_EQ(std::system(py.c_str()), 0);
  auto ok = convert(td, in.string() + " -o " + (td.p / "ok.mds").string() + " --quiet");
  ASSERT_EQ(ok.code, 0) << ok.err;
  fs::remove(td.p / "ok.mds");
  fs::create_directory(td.p / "empty");
  // (octree meshlets: the default PCL builder is a module too, MeshletBuilderWithoutItsModule)
  auto r = convert(td, in.string() + " -o " + (td.p / "o.mds").string() + " --meshlet-builder octree",
                   "MDSTREAM_MODULE_DIR=" + (td.p / "empty").string() + " ");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("in.h5md"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find((td.p / "empty" / "libmdstream_h5md.so").string()), std::string::npos) << r.err;
  EXPECT_EQ(leftovers(td.p, {"in.h5md", "empty"}), std::vector<std::string>{});
}

// The PCL meshlet builder (the default) is a module as well (convert/meshlet_pcl_module.h):
// without it a conversion with it fails before reading, naming every place looked in, and
// leaves nothing; the octree builder needs no module.
TEST(ConvertErrors, MeshletBuilderWithoutItsModule) {
  TmpDir td;
  write_dump(td.p / "ok.dump", 3000);
  fs::create_directory(td.p / "empty");
  const std::string env = "MDSTREAM_MODULE_DIR=" + (td.p / "empty").string() + " ";
  auto r = convert(td, (td.p / "ok.dump").string() + " -o " + (td.p / "o.mds").string(), env);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("PCL meshlet builder"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find((td.p / "empty" / "libmdstream_pcl.so").string()), std::string::npos) << r.err;
  EXPECT_EQ(leftovers(td.p, {"ok.dump", "empty"}), std::vector<std::string>{});
  auto ok = convert(td, (td.p / "ok.dump").string() + " -o " + (td.p / "o.mds").string() +
                            " --meshlet-builder octree --quiet", env);
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_TRUE(fs::exists(td.p / "o.mds"));
}

// The CLI itself links neither HDF5 (its 34 libraries cost 12.7 ms of every process start on the
// 2-core VM), PCL, nor the Vulkan commands' libraries: only their modules do
// (readers/h5md_module.h, convert/meshlet_pcl_module.h, cli/vulkan_module.h).
TEST(ConvertErrors, CliLoadsOptionalLibrariesOnlyThroughModules) {
  TmpDir td;
  const fs::path out = td.p / "ldd.txt.log";
  ASSERT_EQ(std::system(("ldd " + std::string(MDSTREAM_BIN) + " > " + out.string()).c_str()), 0);
  std::ifstream f(out);
  const std::string libs((std::istreambuf_iterator<char>(f)), {});
  EXPECT_NE(libs.find("libc.so"), std::string::npos) << libs;  // ldd listed the libraries
  EXPECT_EQ(libs.find("libhdf5"), std::string::npos) << libs;
  EXPECT_EQ(libs.find("libpcl"), std::string::npos) << libs;  // nor PCL (meshlet_pcl_module.h)
  EXPECT_EQ(libs.find("libgomp"), std::string::npos) << libs;
  // nor Vulkan, GLFW/X11 or the image libraries (cli/vulkan_module.h)
  for (const char* lib : {"libvulkan", "libglfw", "libX11", "libpng", "libtinyexr"})
    EXPECT_EQ(libs.find(lib), std::string::npos) << lib << "\n" << libs;
}
