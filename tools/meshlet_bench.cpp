// Meshlet builders on their own (convert/meshlet_builder.h), on the nodes of a real input: thread
// CPU time per particle and meshlet quality (convert/meshlet_quality.h) of each builder, the
// builders interleaved node by node (A B C A B C ...) so that every one sees the same machine noise. For A/B of a
// change to the PCL builder: build the module before and after, copy each libmdstream_pcl.so to
// a folder of its own, and name the folders as variants; identical meshlets give identical
// quality columns. Results of a run go into docs/results/convert.md by hand.
//
// Built as build/tools/meshlet_bench; run:
//   meshlet_bench INPUT.f32 VARIANT... [--particles N] [--node-size 10000] [--meshlet-size 16]
//                 [--rounds 7]
// INPUT: raw little-endian float32 xyz (as `convert --format raw`). VARIANT: `octree`, `pcl` (the
// module next to this program or in the build folder, as for `mdstream convert`) or a folder
// holding a libmdstream_pcl.so.
// Nodes: the input's first N particles, sorted by Morton key over their bounding box and cut by
// the converter's octree partition at --node-size (octree_partition.h), one thread.
#include <dlfcn.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "convert/meshlet_builder.h"
#include "convert/meshlet_pcl_module.h"
#include "convert/meshlet_quality.h"
#include "convert/morton.h"
#include "convert/node_encoder.h"
#include "convert/octree_partition.h"

using namespace mds;
using namespace mds::convert;

namespace {

struct Variant {
  std::string name;
  std::unique_ptr<MeshletBuilder> builder;
  std::vector<double> ns_per_particle;  // one per round
  MeshletQuality quality;
};

// A builder from the PCL module in `dir` (dlopen'ed privately, so several builds can be compared
// in one process), or an error message.
std::unique_ptr<MeshletBuilder> module_builder(const std::string& dir, std::string& error) {
  const std::string path = dir + "/" + kPclModuleFile;
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    error = dlerror();
    return nullptr;
  }
  auto entry = reinterpret_cast<const void* (*)()>(dlsym(handle, kPclModuleSymbol));
  const auto* api = entry ? static_cast<const PclModuleApi*>(entry()) : nullptr;
  if (!api || api->abi != kPclModuleAbi || !api->make_builder) {
    error = path + ": not a PCL module of this build (symbol or ABI)";
    return nullptr;
  }
  return api->make_builder();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Meshlet builders alone on the nodes of a raw float32 xyz input"};
  std::string input;
  std::vector<std::string> variant_names;
  size_t particles = 2'000'000;
  uint32_t node_size = 10000, meshlet_size = 16, rounds = 7;
  app.add_option("input", input, "raw little-endian float32 xyz")->required();
  app.add_option("variants", variant_names, "octree, pcl, or a folder holding a libmdstream_pcl.so")->required();
  app.add_option("--particles", particles, "use the input's first N particles")->check(CLI::PositiveNumber);
  app.add_option("--node-size", node_size, "node capacity")->check(CLI::Range(1, 65535));
  app.add_option("--meshlet-size", meshlet_size, "meshlet capacity")->check(CLI::Range(1, 255));
  app.add_option("--rounds", rounds, "timed rounds per variant")->check(CLI::Range(1, 1000));
  CLI11_PARSE(app, argc, argv);

  // The positions, as the converter's node stage sees them: double, sorted by Morton key.
  std::ifstream f(input, std::ios::binary | std::ios::ate);
  if (!f) {
    std::fprintf(stderr, "%s: cannot open\n", input.c_str());
    return 1;
  }
  const size_t available = size_t(f.tellg()) / 12;
  particles = std::min(particles, available);
  if (particles == 0) {
    std::fprintf(stderr, "%s: no complete xyz triple\n", input.c_str());
    return 1;
  }
  std::vector<float> raw(3 * particles);
  f.seekg(0);
  f.read(reinterpret_cast<char*>(raw.data()), std::streamsize(raw.size() * sizeof(float)));
  if (size_t(f.gcount()) != raw.size() * sizeof(float)) {
    std::fprintf(stderr, "%s: read %lld of %zu bytes\n", input.c_str(), static_cast<long long>(f.gcount()),
                 raw.size() * sizeof(float));
    return 1;
  }
  double lo[3] = {raw[0], raw[1], raw[2]}, hi[3] = {raw[0], raw[1], raw[2]};
  for (size_t i = 0; i < particles; ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(raw[3 * i + a]));
      hi[a] = std::max(hi[a], double(raw[3 * i + a]));
    }
  const MortonGrid grid(lo, hi);
  std::vector<uint64_t> unsorted(particles);
  for (size_t i = 0; i < particles; ++i) unsorted[i] = grid.key(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);
  std::vector<uint32_t> perm(particles);
  std::iota(perm.begin(), perm.end(), 0u);
  std::sort(perm.begin(), perm.end(), [&](uint32_t a, uint32_t b) { return unsorted[a] < unsorted[b]; });
  std::vector<uint64_t> keys(particles);
  std::vector<double> xyz(3 * particles);
  for (size_t i = 0; i < particles; ++i) {
    keys[i] = unsorted[perm[i]];
    for (int a = 0; a < 3; ++a) xyz[3 * i + a] = raw[3 * size_t(perm[i]) + a];
  }
  std::vector<KeyRange> nodes;
  octree_partition(keys, common_cell_level(keys.front(), keys.back()), node_size, nodes);

  std::vector<Variant> variants;
  for (const std::string& name : variant_names) {
    Variant v{name, nullptr, {}, {}};
    std::string error;
    if (name == "octree" || name == "pcl") {
      auto b = make_meshlet_builder(name == "octree" ? MeshletBuilderKind::octree : MeshletBuilderKind::pcl);
      if (b) v.builder = std::move(*b);
      else error = b.error().message;
    } else {
      v.builder = module_builder(name, error);
    }
    if (!v.builder) {
      std::fprintf(stderr, "variant %s: %s\n", name.c_str(), error.c_str());
      return 1;
    }
    variants.push_back(std::move(v));
  }

  std::vector<uint32_t> order;
  std::vector<uint8_t> sizes;
  // Interleaved node by node: the machine's speed drifts within a second on a shared VM, and
  // every variant should see the same drift.
  std::vector<double> cpu(variants.size());
  for (uint32_t r = 0; r <= rounds; ++r) {  // round 0 warms up and measures quality
    std::fill(cpu.begin(), cpu.end(), 0.0);
    for (const KeyRange& node : nodes) {
      const std::span<const uint64_t> k(keys.data() + node.begin, node.size());
      const std::span<const double> p(xyz.data() + 3 * node.begin, 3 * node.size());
      for (size_t vi = 0; vi < variants.size(); ++vi) {
        Variant& v = variants[vi];
        const double t0 = thread_cpu_seconds();
        if (Status s = v.builder->build(k, p, meshlet_size, order, sizes); !s) {
          std::fprintf(stderr, "variant %s: %s\n", v.name.c_str(), s.error().message.c_str());
          return 1;
        }
        cpu[vi] += thread_cpu_seconds() - t0;
        if (r == 0) add_meshlet_quality(p, order, sizes, v.quality);
      }
    }
    if (r > 0)
      for (size_t vi = 0; vi < variants.size(); ++vi)
        variants[vi].ns_per_particle.push_back(1e9 * cpu[vi] / double(particles));
  }

  std::printf("%s: %zu particles, %zu nodes (node size %u), meshlet size %u, %u rounds (one thread)\n\n",
              input.c_str(), particles, nodes.size(), node_size, meshlet_size, rounds);
  std::printf("| variant | ns/particle (median) | min | max | vs first | meshlets | mean size | diag/spacing |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|\n");
  const double first = median(variants.front().ns_per_particle);
  for (const Variant& v : variants) {
    const double m = median(v.ns_per_particle);
    const auto [mn, mx] = std::minmax_element(v.ns_per_particle.begin(), v.ns_per_particle.end());
    std::printf("| %s | %.1f | %.1f | %.1f | %.3f | %llu | %.3f | %.4f |\n", v.name.c_str(), m, *mn, *mx, m / first,
                static_cast<unsigned long long>(v.quality.meshlets), v.quality.mean_size(),
                v.quality.mean_diag_over_spacing());
  }
  return 0;
}
