// Test helpers for the store tests: builds synthetic stores with the real writer.
// Positions come from std::mt19937_64 raw output (bit-identical on every platform), nodes are
// consecutive chunks after sorting particles along x, meshlets are consecutive chunks of a node,
// the density grid is counted over the centre bounds. Used by test_store*.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include "store/format.h"
#include "store/store_writer.h"

namespace mds::testing {

struct SynthParticle {
  double x[3];
  uint8_t type;
  float radius;
};

struct SynthNode {
  std::vector<uint16_t> qpos;
  std::vector<uint8_t> type_index;
  std::vector<uint16_t> radius_q;
  std::vector<uint8_t> meshlet_size;
  double cmin[3];
  double cmax[3];
  float max_radius = 0;
  std::vector<store::VoxelRef> voxels;
  std::vector<SynthParticle> original;  // in payload order
};

struct SynthStore {
  std::vector<SynthNode> nodes;
  store::StoreSummary summary;
  uint64_t particles = 0;
};

struct SynthOptions {
  uint64_t seed = 1;
  size_t particles = 1000;
  uint32_t node_size = 128;
  uint32_t meshlet_size = 32;
  bool per_particle_radius = false;
  uint32_t types = 3;
  uint32_t grid = 4;  // density dims grid^3; 0 = no density grid
  double extent = 100.0;
  std::vector<SynthParticle> explicit_particles;  // used instead of random ones when non-empty
};

inline double unit(std::mt19937_64& rng) { return double(rng() >> 11) * (1.0 / 9007199254740992.0); }

inline SynthStore make_synthetic(const SynthOptions& o) {
  std::vector<SynthParticle> ps = o.explicit_particles;
  if (ps.empty()) {
    std::mt19937_64 rng(o.seed);
    ps.resize(o.particles);
    for (auto& p : ps) {
      for (double& c : p.x) c = (unit(rng) - 0.25) * o.extent;
      p.type = uint8_t(rng() % o.types);
      p.radius = float(0.3 + 0.9 * unit(rng));
    }
  }
  std::stable_sort(ps.begin(), ps.end(), [](const SynthParticle& a, const SynthParticle& b) { return a.x[0] < b.x[0]; });

  SynthStore s;
  store::StoreSummary& sum = s.summary;
  sum.flags = o.per_particle_radius ? uint32_t(store::kFlagPerParticleRadius) : 0u;
  sum.node_size_max = o.node_size;
  sum.meshlet_size_max = o.meshlet_size;
  for (int a = 0; a < 3; ++a) {
    sum.bounds_min[a] = ps[0].x[a];
    sum.bounds_max[a] = ps[0].x[a];
  }
  float rmin = ps[0].radius, rmax = ps[0].radius;
  for (const auto& p : ps) {
    for (int a = 0; a < 3; ++a) {
      sum.bounds_min[a] = std::min(sum.bounds_min[a], p.x[a]);
      sum.bounds_max[a] = std::max(sum.bounds_max[a], p.x[a]);
    }
    rmin = std::min(rmin, p.radius);
    rmax = std::max(rmax, p.radius);
  }
  for (uint32_t t = 0; t < o.types; ++t) {
    store::TypeEntry te;
    std::memset(&te, 0, sizeof(te));
    te.input_id = int32_t(t + 1);
    te.radius = 0.5f + 0.25f * float(t);
    std::string nm = t == 0 ? "C" : t == 1 ? "O" : "T" + std::to_string(t);
    std::strncpy(te.name, nm.c_str(), sizeof(te.name) - 1);
    sum.types.push_back(te);
  }
  if (o.per_particle_radius) {
    sum.radius_min = rmin;
    sum.radius_max = rmax;
  } else {
    sum.radius_min = sum.types.front().radius;
    sum.radius_max = sum.types.back().radius;
  }
  const uint32_t g = o.grid;
  for (int a = 0; a < 3; ++a) {
    sum.density_dims[a] = g;
    sum.density_min[a] = sum.bounds_min[a];
    sum.density_max[a] = sum.bounds_max[a];
  }
  sum.density_counts.assign(size_t(g) * g * g, 0);
  auto voxel_of = [&](const SynthParticle& p) {
    uint32_t idx[3];
    for (int a = 0; a < 3; ++a) {
      double ext = sum.density_max[a] - sum.density_min[a];
      double f = ext > 0 ? (p.x[a] - sum.density_min[a]) / ext : 0.0;
      idx[a] = std::min<uint32_t>(g - 1, uint32_t(std::max(0.0, f * g)));
    }
    return idx[0] + g * (idx[1] + g * idx[2]);
  };

  for (size_t first = 0; first < ps.size(); first += o.node_size) {
    const size_t n = std::min<size_t>(o.node_size, ps.size() - first);
    SynthNode node;
    node.original.assign(ps.begin() + first, ps.begin() + first + n);
    for (int a = 0; a < 3; ++a) {
      node.cmin[a] = node.original[0].x[a];
      node.cmax[a] = node.original[0].x[a];
    }
    for (const auto& p : node.original)
      for (int a = 0; a < 3; ++a) {
        node.cmin[a] = std::min(node.cmin[a], p.x[a]);
        node.cmax[a] = std::max(node.cmax[a], p.x[a]);
      }
    for (const auto& p : node.original) {
      for (int a = 0; a < 3; ++a) {
        double step = (node.cmax[a] - node.cmin[a]) / 65535.0;
        double q = step > 0 ? std::round((p.x[a] - node.cmin[a]) / step) : 0.0;
        uint16_t qi = uint16_t(std::clamp(q, 0.0, 65535.0));
        node.qpos.push_back(qi);
        double err = std::abs(node.cmin[a] + qi * step - p.x[a]);
        sum.max_quantization_error = std::max(sum.max_quantization_error, err);
        if (step > 0) sum.max_error_over_half_step = std::max(sum.max_error_over_half_step, err / (step / 2));
      }
      node.type_index.push_back(p.type);
      float r = o.per_particle_radius ? p.radius : sum.types[p.type].radius;
      node.max_radius = std::max(node.max_radius, r);
      if (o.per_particle_radius) {
        double span = double(rmax) - double(rmin);
        double q = span > 0 ? std::round((double(p.radius) - rmin) / span * 65535.0) : 0.0;
        node.radius_q.push_back(uint16_t(std::clamp(q, 0.0, 65535.0)));
      }
    }
    for (size_t k = 0; k < n; k += o.meshlet_size) node.meshlet_size.push_back(uint8_t(std::min<size_t>(o.meshlet_size, n - k)));
    if (g > 0) {
      std::vector<uint32_t> vox;
      for (const auto& p : node.original) vox.push_back(voxel_of(p));
      std::sort(vox.begin(), vox.end());
      for (uint32_t v : vox) {
        if (node.voxels.empty() || node.voxels.back().voxel != v) node.voxels.push_back({v, 0});
        ++node.voxels.back().count;
        ++sum.density_counts[v];
      }
    }
    s.particles += n;
    s.nodes.push_back(std::move(node));
  }
  for (const auto& node : s.nodes)
    for (uint8_t t : node.type_index) sum.types[t].particle_count++;
  return s;
}

inline store::NodeInput node_input(const SynthNode& n) {
  store::NodeInput in;
  in.qpos = n.qpos;
  in.type_index = n.type_index;
  in.radius_q = n.radius_q;
  in.meshlet_size = n.meshlet_size;
  for (int a = 0; a < 3; ++a) {
    in.center_min[a] = n.cmin[a];
    in.center_max[a] = n.cmax[a];
  }
  in.max_radius = n.max_radius;
  in.voxels = n.voxels;
  return in;
}

// Writes `s` with the real StoreWriter. Returns an empty string on success, else the error.
inline std::string write_store(const SynthStore& s, const std::filesystem::path& path) {
  auto w = store::StoreWriter::create(path);
  if (!w.ok()) return w.error().message;
  for (const auto& n : s.nodes) {
    auto enc = store::encode_node(node_input(n));
    if (!enc.ok()) return enc.error().message;
    Status st = (*w)->append(std::move(enc).value());
    if (!st.ok()) return st.error().message;
  }
  Status st = (*w)->finish(s.summary);
  return st.ok() ? std::string() : st.error().message;
}

inline std::vector<uint8_t> read_bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

inline void write_bytes(const std::filesystem::path& p, const std::vector<uint8_t>& b) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

// A fresh, empty directory for one test. `in_memory` puts it on /dev/shm when that exists
// (the corruption tests write thousands of small files; on the build machine's disk each
// file costs milliseconds).
inline std::filesystem::path temp_dir(const std::string& name, bool in_memory = false) {
  std::error_code ec;
  std::filesystem::path base = std::filesystem::temp_directory_path();
  if (in_memory && std::filesystem::is_directory("/dev/shm", ec) && ::access("/dev/shm", W_OK) == 0) base = "/dev/shm";
  auto d = base / ("mdstream_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace mds::testing
