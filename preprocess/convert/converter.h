// The conversion pipeline: simulation dumps -> the node/meshlet store (.mds).
//   Pass A  parse every input once, validate, spill 32-byte records to a temporary file (or
//           keep them in memory when they fit the budget); global bounds, counts, types.
//           Reading runs on its own thread, two batches ahead of the validation (input_scan.h).
//           One raw float32 input that fits the budget is not copied: it is mapped, validated
//           in place on all threads (scan_raw_mapped), and sorted into a new array of its
//           positions (xyz_sort.h), which the build reads (record_view.h).
//   Pass B  scatter the spill file into Morton-prefix bins that fit the budget (binning.h).
//   Build   per bin: Morton keys (split across the threads) + parallel radix sort of
//           (key, index) (radix_sort.h), nodes (node_builder.h), then on worker threads per
//           node: meshlets (meshlet_builder.h: PCL kd-tree or octree leaves), 16-bit
//           quantization (quantize.h), voxel lists (density.h), store::encode_node; the calling
//           thread appends in order (node_encoder.h). Out of core, bin k+1 is loaded, keyed and
//           sorted on a helper thread while bin k is built.
// The report's `stages` are contiguous (their wall times add up to the total), each with the
// process CPU time spent while it ran (CPU / wall ~ the cores actually used).
// Paper 000 §3.1, §4.4, §6, §7.4; paper 002 §3.3.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "convert/density.h"
#include "convert/meshlet_builder.h"
#include "core/result.h"
#include "readers/reader.h"

namespace mds::convert {

inline constexpr uint64_t kDefaultMemoryBudget = 2ull << 30;

struct ConvertOptions {
  std::vector<std::filesystem::path> inputs;
  std::filesystem::path output;
  ReaderOptions reader;                      // format, frame, h5md group
  uint32_t node_size = 10000;                // 1..65535
  uint32_t meshlet_size = 16;                // 1..255
  MeshletBuilderKind meshlet_builder = MeshletBuilderKind::pcl;
  float radius = 0.5f;                       // default radius of every type
  std::map<int32_t, float> radius_by_type;   // overrides per input type id
  DensitySpec density;                       // --density-res
  uint64_t memory_budget = kDefaultMemoryBudget;
  unsigned threads = 2;
  std::filesystem::path tmp_dir;             // empty: next to the output
  bool progress = false;                     // draw a progress bar on stderr
};

struct ConvertReport {
  uint64_t particles = 0;
  uint64_t nodes = 0;
  uint64_t meshlets = 0;
  uint32_t types = 0;
  MeshletBuilderKind meshlet_builder = MeshletBuilderKind::pcl;
  double mean_meshlet_size = 0;
  double meshlet_diag_over_spacing = 0;      // meshlet quality (meshlet_quality.h): mean meshlet AABB
                                             // diagonal / node particle spacing; lower is more compact
  uint64_t file_bytes = 0;
  double bytes_per_particle = 0;
  uint64_t payload_bytes = 0;
  uint64_t payload_raw_bytes = 0;
  double compression_ratio = 0;              // payload raw / compressed
  double max_quantization_error = 0;         // absolute, world units
  double max_error_over_half_step = 0;       // <= 1
  double bounds_min[3] = {0, 0, 0};
  double bounds_max[3] = {0, 0, 0};
  uint32_t density_dims[3] = {0, 0, 0};
  bool per_particle_radius = false;
  std::string property;                      // the per-particle scalar kept (--property), or empty
  float property_min = 0, property_max = 0;  // its range in the store
  bool color = false;                        // per-particle RGBA8 colours kept (--color)
  std::optional<SimulationCell> cell;        // the simulation cell kept (every input has the same one)
  bool cells_differ = false;                 // the inputs' cells differ: none kept
  bool spilled = false;                      // records went through temporary files
  uint64_t bins = 0;                         // bins built (1 when everything fitted in memory)
  uint64_t partition_passes = 0;
  uint64_t memory_budget = 0;
  uint64_t peak_rss_bytes = 0;               // VmHWM of the process
  // Stages in order; their wall times add up to seconds_total (every step of convert() is in one).
  //   setup      option checks, opening the inputs, creating the store, density grid, workers
  //   read       pass A: parse + validate (+ spill)
  //   partition  pass B (out of core only)
  //   load       reading bins back (out of core; overlapped with the build of the previous bin
  //              after the first, then only the wait for it counts here)
  //   sort       in memory: Morton keys + parallel radix sort (or the raw positions' sort);
  //              out of core the keys and the sort of each bin are in `load`
  //   nodes      node partition + workers (gather, meshlets, quantize, voxel lists, encode) + ordered append
  //   finish     store sections, fsync, rename
  struct Stage {
    const char* name;
    double wall = 0;
    double cpu = 0;  // process CPU (all threads) while the stage ran
  };
  std::vector<Stage> stages;
  double seconds_setup = 0;
  double seconds_load = 0;
  double seconds_keys = 0;
  double seconds_radix = 0;
  double seconds_nodes = 0;
  double seconds_read = 0;                   // pass A
  double seconds_partition = 0;              // pass B
  double seconds_build = 0;                  // sort + nodes + meshlets + encode + write
  double seconds_sort = 0;                   // load + keys + radix sort (wall; on the build's critical path)
  double seconds_gather = 0;                 // gathering node records, voxel index: CPU summed over workers
  double seconds_meshlets = 0;               // meshlet building: CPU time summed over workers
  double seconds_encode = 0;                 // quantize + voxel lists + quality + lz4: CPU summed over workers
  double seconds_append = 0;                 // appending encoded nodes to the store (CPU, calling thread)
  double seconds_finish = 0;                 // store sections, fsync and rename (wall)
  double seconds_total = 0;
  double cpu_seconds = 0;                    // process CPU time (user + system) of the conversion
  double particles_per_second = 0;
};

// Runs the whole conversion. On error nothing is left behind (no output, no temporaries).
Result<ConvertReport> convert(const ConvertOptions& options);

// "1=0.5,2=0.7"
Result<std::map<int32_t, float>> parse_radius_by_type(const std::string& text);

// Peak resident set size of this process (VmHWM), 0 when unknown.
uint64_t peak_rss_bytes();

}  // namespace mds::convert
