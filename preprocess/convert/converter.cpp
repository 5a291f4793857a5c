// The conversion pipeline driver (see converter.h): pass A (input_scan.h), pass B
// (Morton-prefix binning, binning.h), per bin: Morton keys + parallel radix sort
// (radix_sort.h), then nodes/meshlets/encoding on worker threads with an ordered append
// (node_encoder.h).
#include "convert/converter.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <thread>

#include "convert/big_buffer.h"
#include "convert/binning.h"
#include "convert/input_scan.h"
#include "convert/morton.h"
#include "convert/node_encoder.h"
#include "convert/progress.h"
#include "convert/radix_sort.h"
#include "convert/record_view.h"
#include "convert/spill.h"
#include "convert/xyz_sort.h"
#include "readers/raw_reader.h"
#include "store/store_writer.h"

namespace mds::convert {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double process_cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

// Memory model of the budget (bytes per particle of each working set). The readers' and the
// store writer's own fixed I/O buffers (about 8 MiB each) are outside this model.
// `extra`: bytes a particle carries beside its record (its side column: 4 with the property, 4
// with the colour).
constexpr uint64_t bin_bytes_per_particle(uint64_t extra) {  // records + keys/perm + sort scratch
  return sizeof(SpillRecord) + extra + 2 * (8 + 4);
}
// Out of core, the next bin is loaded and sorted while the current one is built: two bins of
// records + keys/perm, one sort scratch.
constexpr uint64_t overlapped_bin_bytes_per_particle(uint64_t extra) {
  return 2 * (sizeof(SpillRecord) + extra + 8 + 4) + (8 + 4);
}
constexpr uint64_t kBatchBytesPerParticle = 56;           // ParticleBatch (x,y,z,type,radius,id,property,color)
constexpr uint64_t kWorkerBytesPerParticle = 192;         // per-node scratch: xyz, qpos, types, voxels, payload, ...
constexpr uint64_t kInFlightBytesPerParticle = 24;        // an encoded node waiting to be appended
constexpr uint64_t kMaxBinRecords = std::numeric_limits<uint32_t>::max();  // permutation indices are uint32

// The budget split (see the memory model above).
struct BudgetPlan {
  size_t batch_particles = 0;
  size_t spill_buffer_bytes = 0;
  size_t partition_buffer_bytes = 0;
  uint64_t max_memory_records = 0;  // everything in one in-memory bin up to this count
  uint64_t max_bin_records = 0;     // out of core: bins (two alive at once) up to this count
};

SideLayout side_layout(const ConvertOptions& o) { return SideLayout{!o.reader.property.empty(), o.reader.color}; }

Status check_options(const ConvertOptions& o) {
  if (o.inputs.empty()) return make_error(Errc::invalid_argument, "no input files given");
  if (o.output.empty()) return make_error(Errc::invalid_argument, "no output file given (-o)");
  if (o.node_size < 1 || o.node_size > store::kMaxNodeParticles)
    return make_error(Errc::invalid_argument, "--node-size {} outside 1..{}", o.node_size, store::kMaxNodeParticles);
  if (o.meshlet_size < 1 || o.meshlet_size > store::kMaxMeshletParticles)
    return make_error(Errc::invalid_argument, "--meshlet-size {} outside 1..{}", o.meshlet_size,
                      store::kMaxMeshletParticles);
  if (!(o.radius > 0) || !std::isfinite(o.radius))
    return make_error(Errc::invalid_argument, "--radius {} must be a positive finite number", o.radius);
  for (const auto& [id, r] : o.radius_by_type)
    if (!(r > 0) || !std::isfinite(r))
      return make_error(Errc::invalid_argument, "--radius-by-type {}={}: radius must be positive and finite", id, r);
  if (o.reader.property.size() >= store::kPropertyNameBytes ||
      o.reader.property.find_first_of(std::string_view("\0 \t\n\r", 5)) != std::string::npos)
    return make_error(Errc::invalid_argument, "--property '{}': a name of 1..{} bytes without blanks", o.reader.property,
                      store::kPropertyNameBytes - 1);
  if (o.threads < 1 || o.threads > 256)
    return make_error(Errc::invalid_argument, "--threads {} outside 1..256", o.threads);
  if (o.memory_budget == 0) return make_error(Errc::invalid_argument, "--memory-budget must be positive");
  // Never overwrite an input with the output.
  std::error_code ec;
  const auto out_abs = std::filesystem::weakly_canonical(o.output, ec);
  for (const auto& in : o.inputs) {
    std::error_code ec2;
    const auto in_abs = std::filesystem::weakly_canonical(in, ec2);
    if (!ec && !ec2 && in_abs == out_abs)
      return make_error(Errc::invalid_argument, "{}: the output would overwrite an input", o.output.string());
  }
  return {};
}

Result<BudgetPlan> plan_budget(const ConvertOptions& o, uint64_t density_voxels) {
  BudgetPlan p;
  const uint64_t b = o.memory_budget;
  p.batch_particles = size_t(std::clamp<uint64_t>(b / 64 / kBatchBytesPerParticle / kReadAheadBatches, 256, 65536));
  p.spill_buffer_bytes = size_t(std::clamp<uint64_t>(b / 16, 64 << 10, 4 << 20));
  p.partition_buffer_bytes = size_t(std::clamp<uint64_t>(b / 4, 256 << 10, 256ull << 20));
  const uint64_t density_bytes = 2 * 4 * density_voxels;  // global counts + store summary copy
  // With colours a worker also holds them and their permutation (8 bytes a particle), and an
  // encoded node their 4 bytes.
  const uint64_t color = o.reader.color ? 1 : 0;
  const uint64_t workers = uint64_t(o.threads) * o.node_size * (kWorkerBytesPerParticle + 8 * color);
  const uint64_t in_flight =
      uint64_t(o.threads) * kWindowPerThread * o.node_size * (kInFlightBytesPerParticle + 4 * color);
  const uint64_t fixed = density_bytes + workers + in_flight +
                         kReadAheadBatches * p.batch_particles * kBatchBytesPerParticle + p.spill_buffer_bytes;
  const uint64_t extra = 4 * side_layout(o).words();  // the side column
  const uint64_t need = fixed + 2 * overlapped_bin_bytes_per_particle(extra) * o.node_size;
  if (b < need)
    return make_error(Errc::budget,
                      "--memory-budget {} bytes is too small: node size {}, {} threads and {} density voxels need at "
                      "least {} bytes ({:.1f} MiB)",
                      b, o.node_size, o.threads, density_voxels, need, double(need) / (1 << 20));
  p.max_memory_records = std::min((b - fixed) / bin_bytes_per_particle(extra), kMaxBinRecords);
  p.max_bin_records = std::min((b - fixed) / overlapped_bin_bytes_per_particle(extra), kMaxBinRecords);
  return p;
}

// Morton keys of the records and the sort permutation, sorted by key (both in `keys`/`perm`).
struct SortBuffers {
  BigVector<uint64_t> keys, keys_tmp;
  BigVector<uint32_t> perm, perm_tmp;
  void release() { *this = SortBuffers{}; }
};

// Wall seconds of the two steps of key_and_sort.
struct SortTimes {
  double keys = 0, radix = 0;
};

template <class Recs>
SortTimes key_and_sort(const Recs& recs, const MortonGrid& grid, unsigned threads, SortBuffers& sb) {
  SortTimes st;
  auto t = Clock::now();
  const size_t n = recs.size();
  sb.keys.resize(n);
  sb.perm.resize(n);
  sb.keys_tmp.resize(n);
  sb.perm_tmp.resize(n);
  auto fill = [&](size_t b, size_t e) {
    // Each thread maps its share of the four arrays' pages in bulk (no-op when already mapped).
    prefault(sb.keys.data() + b, (e - b) * sizeof(uint64_t));
    prefault(sb.perm.data() + b, (e - b) * sizeof(uint32_t));
    prefault(sb.keys_tmp.data() + b, (e - b) * sizeof(uint64_t));
    prefault(sb.perm_tmp.data() + b, (e - b) * sizeof(uint32_t));
    for (size_t i = b; i < e; ++i) {
      const SpillRecord r = recs[i];
      sb.keys[i] = grid.key(r.x, r.y, r.z);
      sb.perm[i] = uint32_t(i);
    }
  };
  if (threads > 1 && n >= (1u << 16)) {
    std::vector<std::thread> pool;
    for (unsigned k = 1; k < threads; ++k) pool.emplace_back(fill, n * k / threads, n * (k + 1) / threads);
    fill(0, n / threads);
    for (auto& th : pool) th.join();
  } else {
    fill(0, n);
  }
  st.keys = seconds_since(t);
  t = Clock::now();
  radix_sort_pairs(sb.keys, sb.perm, sb.keys_tmp, sb.perm_tmp, threads);
  st.radix = seconds_since(t);
  return st;
}

template <class T>
Status load_file(const std::filesystem::path& path, uint64_t count, BigVector<T>& out) {
  MDS_ASSIGN_OR_RETURN(SpillReaderOf<T> reader, SpillReaderOf<T>::open(path));
  if (reader.count() != count)
    return make_error(Errc::internal, "{}: expected {} records, found {}", path.string(), count, reader.count());
  out.resize(size_t(count));
  MDS_ASSIGN_OR_RETURN(size_t n, reader.read(out));
  if (n != out.size()) return make_error(Errc::internal, "{}: bin is short", path.string());
  return {};
}

// The bin's records, and its side column where it has one.
Status load_bin(const Bin& bin, BigVector<SpillRecord>& recs, BigVector<uint32_t>& side) {
  MDS_TRY(load_file(bin.path, bin.count, recs));
  if (bin.side_path.empty()) {
    side = {};
    return {};
  }
  return load_file(bin.side_path, uint64_t(bin.side_words) * bin.count, side);
}

// Contiguous stages of the calling thread: lap() closes the running stage (wall and process
// CPU) and starts the next, so the stages add up to the total.
class StageMeter {
 public:
  explicit StageMeter(ConvertReport& rep) : rep_(rep), t_(Clock::now()), cpu_(process_cpu_seconds()) {}
  // Ends the running stage, books it under `name` (accumulating), returns its wall seconds.
  double lap(const char* name) {
    const auto now = Clock::now();
    const double cpu = process_cpu_seconds();
    const double wall = std::chrono::duration<double>(now - t_).count();
    auto it = std::find_if(rep_.stages.begin(), rep_.stages.end(),
                           [&](const ConvertReport::Stage& s) { return std::strcmp(s.name, name) == 0; });
    if (it == rep_.stages.end()) it = rep_.stages.insert(rep_.stages.end(), ConvertReport::Stage{name});
    it->wall += wall;
    it->cpu += cpu - cpu_;
    t_ = now;
    cpu_ = cpu;
    return wall;
  }

 private:
  ConvertReport& rep_;
  Clock::time_point t_;
  double cpu_;
};

// A bin loaded, keyed and sorted (possibly on a helper thread while the previous bin is built).
struct PreparedBin {
  BigVector<SpillRecord> recs;
  BigVector<uint32_t> side;  // with a side column: SideLayout words per record of recs
  SortBuffers sb;
  SortTimes times;
  double load_seconds = 0;
  Status status;
};

void prepare_bin(const Bin& bin, const MortonGrid& grid, unsigned threads, PreparedBin& pb, SortBuffers& scratch) {
  const auto t = Clock::now();
  pb.status = load_bin(bin, pb.recs, pb.side);
  std::error_code ec;
  std::filesystem::remove(bin.path, ec);
  if (!bin.side_path.empty()) std::filesystem::remove(bin.side_path, ec);
  pb.load_seconds = seconds_since(t);
  if (!pb.status.ok()) return;
  // The sort scratch is shared by both slots (only one bin is sorted at a time).
  std::swap(pb.sb.keys_tmp, scratch.keys_tmp);
  std::swap(pb.sb.perm_tmp, scratch.perm_tmp);
  pb.times = key_and_sort(SpillRecords{pb.recs}, grid, threads, pb.sb);
  std::swap(pb.sb.keys_tmp, scratch.keys_tmp);
  std::swap(pb.sb.perm_tmp, scratch.perm_tmp);
  if (!pb.recs.empty() && morton_prefix(pb.sb.keys.front(), bin.prefix_bits) != bin.prefix)
    pb.status = make_error(Errc::internal, "bin {} holds a record outside its Morton cell", bin.path.string());
}

}  // namespace

// ---------------------------------------------------------------- driver

Result<ConvertReport> convert(const ConvertOptions& o) {
  const auto t_start = Clock::now();
  const double cpu_start = process_cpu_seconds();
  MDS_TRY(check_options(o));
  ConvertReport rep;
  StageMeter meter(rep);
  rep.memory_budget = o.memory_budget;
  rep.meshlet_builder = o.meshlet_builder;
  Progress progress(o.progress);

  // The meshlet builders first: the PCL one needs its module (meshlet_pcl_module.h), and without
  // it the conversion fails before any work.
  std::vector<std::unique_ptr<NodeWorker>> workers;
  for (unsigned i = 0; i < o.threads; ++i) {
    MDS_ASSIGN_OR_RETURN(auto builder, make_meshlet_builder(o.meshlet_builder));
    workers.push_back(std::make_unique<NodeWorker>(std::move(builder)));
  }

  // Open every input first: a missing or malformed file fails before any work.
  std::vector<std::unique_ptr<ParticleReader>> readers;
  uint64_t declared = 0;
  for (const auto& in : o.inputs) {
    MDS_ASSIGN_OR_RETURN(auto r, open_reader(in, o.reader));
    declared += r->info().particle_count;
    readers.push_back(std::move(r));
  }
  // The simulation cell the store keeps: the inputs' cell where every input has the same one.
  for (size_t i = 0; i < readers.size(); ++i) {
    const FrameInfo& fi = readers[i]->info();
    if (!fi.has_box || !fi.cell.finite()) {
      rep.cell.reset();
      break;
    }
    if (i > 0 && !(*rep.cell == fi.cell)) {
      rep.cell.reset();
      rep.cells_differ = true;
      break;
    }
    rep.cell = fi.cell;
  }
  // The density grid size enters the budget; with a target count it is known only
  // approximately before pass A (its count is an upper bound), which suffices here.
  const uint64_t density_budget_voxels =
      o.density.explicit_dims ? uint64_t(o.density.dims[0]) * o.density.dims[1] * o.density.dims[2]
                              : (o.density.target_voxels ? o.density.target_voxels : default_density_target(declared));
  MDS_ASSIGN_OR_RETURN(BudgetPlan plan, plan_budget(o, density_budget_voxels));

  MDS_ASSIGN_OR_RETURN(auto writer, store::StoreWriter::create(o.output));
  std::filesystem::path tmp_parent = o.tmp_dir;
  if (tmp_parent.empty()) tmp_parent = o.output.has_parent_path() ? o.output.parent_path() : ".";
  TempDir tmp(tmp_parent);

  rep.seconds_setup = meter.lap("setup");
  // One raw float32 input that fits in memory is validated and built in place from its
  // mapping (record_view.h, xyz_sort.h); everything else is read into records (or spilled).
  RawReader* raw_reader = o.inputs.size() == 1 ? dynamic_cast<RawReader*>(readers[0].get()) : nullptr;
  const bool raw_mapped = raw_reader && declared <= plan.max_memory_records;
  // When everything will fit in memory, the sort arrays (keys, permutation and their scratch;
  // for the raw input keys and sorted positions) are allocated now and their pages mapped on a
  // background thread during pass A, which leaves part of a core idle; the sort then runs on
  // mapped memory.
  SortBuffers sb;
  BigVector<float> xyz_sorted;
  std::unique_ptr<BackgroundPrefault> sort_prefault;
  if (raw_mapped) {
    const size_t n = size_t(declared);
    xyz_sorted.resize(3 * n);
    sort_prefault = std::make_unique<BackgroundPrefault>(xyz_sorted.data(), 3 * n * sizeof(float));
  } else if (declared <= plan.max_memory_records && declared >= (uint64_t(1) << 16)) {
    const size_t n = size_t(declared);
    sb.keys.resize(n);
    sb.perm.resize(n);
    sb.keys_tmp.resize(n);
    sb.perm_tmp.resize(n);
    sort_prefault = std::make_unique<BackgroundPrefault>(std::vector<std::pair<void*, size_t>>{
        {sb.keys.data(), n * sizeof(uint64_t)},
        {sb.perm.data(), n * sizeof(uint32_t)},
        {sb.keys_tmp.data(), n * sizeof(uint64_t)},
        {sb.perm_tmp.data(), n * sizeof(uint32_t)}});
  }
  // ---- pass A
  InputScan scan;
  RawXyzRecords raw_view;
  ScanOptions so;
  so.inputs = o.inputs;
  so.radius = o.radius;
  so.radius_by_type = o.radius_by_type;
  so.side = side_layout(o);
  so.batch_particles = plan.batch_particles;
  so.spill_buffer_bytes = plan.spill_buffer_bytes;
  so.max_memory_records = plan.max_memory_records;
  if (raw_mapped) {
    MDS_TRY(scan_raw_mapped(so, *raw_reader, o.threads, scan, raw_view, progress));
  } else {
    MDS_TRY(scan_inputs(so, readers, tmp, scan, progress));
  }
  if (sort_prefault) sort_prefault->stop();  // before the arrays are resized or freed
  sort_prefault.reset();
  if (!scan.in_memory) sb.release();
  rep.seconds_read = meter.lap("read");
  rep.particles = scan.count;
  rep.spilled = !scan.in_memory;

  const MortonGrid grid(scan.lo, scan.hi);
  BuildContext ctx;
  ctx.node_size = o.node_size;
  ctx.meshlet_size = o.meshlet_size;
  ctx.meshlet_builder = o.meshlet_builder;
  std::array<uint32_t, 3> dims =
      o.density.explicit_dims
          ? o.density.dims
          : choose_density_dims(scan.lo, scan.hi,
                                o.density.target_voxels ? o.density.target_voxels : default_density_target(scan.count));
  ctx.density = DensityGrid(scan.lo, scan.hi, dims);
  {
    // Nodes hold 1..node_size particles, mostly more than node_size/8 (an octree cell's
    // children, or merged siblings): a reserve for 8 x count / node_size nodes; a node touches
    // a few voxels per 1000 particles, a voxel a few nodes. (Only a reservation: tables grow.)
    const uint64_t voxels = uint64_t(dims[0]) * dims[1] * dims[2];
    writer->reserve(8 * scan.count / std::max<uint32_t>(o.node_size, 1) + 64,
                    std::min<uint64_t>(scan.count, 4 * voxels + 64 * (scan.count / std::max<uint32_t>(o.node_size, 1))));
  }
  std::vector<int32_t> ids;
  for (const auto& [id, st] : scan.types) ids.push_back(id);
  TypeLut lut(ids);
  ctx.lut = &lut;
  for (const auto& [id, st] : scan.types) ctx.type_radius.push_back(st.radius);
  ctx.per_particle_radius = scan.per_particle_radius;
  ctx.radius_min = scan.prad_min;
  ctx.radius_max = scan.prad_max;
  ctx.side = so.side;
  if (ctx.side.property && scan.count > 0) {
    ctx.property_min = scan.property_min;
    ctx.property_max = scan.property_max;
  }

  BuildTotals tot;
  tot.density.assign(size_t(ctx.density.voxel_count()), 0);
  rep.seconds_setup += meter.lap("setup");

  std::thread release_thread;
  struct ReleaseJoin {
    std::thread& t;
    ~ReleaseJoin() {
      if (t.joinable()) t.join();
    }
  } release_join{release_thread};
  if (scan.in_memory) {
    // ---- everything fits: one bin, the root cell (sb possibly allocated before pass A)
    progress.stage("build", scan.count);
    if (raw_mapped) {
      // The positions sorted by key (xyz_sort.h): the build reads them sequentially and
      // computes their keys where it needs them.
      const auto t = Clock::now();
      xyz_sorted.resize(3 * raw_view.size());
      sort_xyz_by_key(raw_view.xyz, raw_view.size(), grid, o.threads, xyz_sorted.data());
      rep.seconds_radix = seconds_since(t);
      rep.seconds_sort = meter.lap("sort");
      MDS_TRY(build_bin(ctx, workers,
                        SortedXyzRecords{xyz_sorted.data(), raw_view.size(), raw_view.type, raw_view.radius}, grid, 0,
                        *writer, tot, progress));
      // Unmapping the array (about 0.02 s per 10M particles) overlaps with the finish.
      release_thread = std::thread([x = std::move(xyz_sorted)]() mutable { x = {}; });
    } else {
      const SortTimes st = key_and_sort(SpillRecords{scan.memory}, grid, o.threads, sb);
      sb.keys_tmp = {};
      sb.perm_tmp = {};
      rep.seconds_keys = st.keys;
      rep.seconds_radix = st.radix;
      rep.seconds_sort = meter.lap("sort");
      MDS_TRY(build_bin(ctx, workers, sb.keys, sb.perm, SpillRecords{scan.memory, scan.memory_side}, 0, *writer,
                        tot, progress));
    }
    scan.memory = {};
    sb.release();
    rep.seconds_nodes = meter.lap("nodes");
    rep.bins = 1;
    rep.seconds_build = rep.seconds_sort + rep.seconds_nodes;
  } else {
    // ---- pass B
    progress.stage("partition", scan.count);
    PartitionOptions popt;
    popt.max_bin_records = plan.max_bin_records;
    popt.buffer_bytes = plan.partition_buffer_bytes;
    PartitionStats pstats;
    uint64_t scattered = 0;
    MDS_ASSIGN_OR_RETURN(
        std::vector<Bin> bins,
        partition(tmp, Bin{scan.spill_path, scan.count, 0, 0, scan.spill_side_path, so.side.words()}, grid, popt, pstats, [&](uint64_t n) {
          scattered += n;
          progress.update(std::min(scattered, scan.count));
        }));
    rep.seconds_partition = meter.lap("partition");
    rep.partition_passes = pstats.passes;
    rep.bins = bins.size();

    // Bin k+1 is loaded, keyed and sorted on a helper thread while bin k is built.
    progress.stage("build", scan.count);
    PreparedBin slots[2];
    SortBuffers scratch;
    std::thread prep;
    auto join_prep = [&] {
      if (prep.joinable()) prep.join();
    };
    struct JoinGuard {
      std::function<void()> f;
      ~JoinGuard() { f(); }
    } guard{join_prep};
    if (!bins.empty()) prepare_bin(bins[0], grid, o.threads, slots[0], scratch);
    for (size_t k = 0; k < bins.size(); ++k) {
      join_prep();
      PreparedBin& cur = slots[k % 2];
      rep.seconds_load += cur.load_seconds;
      rep.seconds_keys += cur.times.keys;
      rep.seconds_radix += cur.times.radix;
      rep.seconds_sort += meter.lap("load");
      MDS_TRY(cur.status);
      if (k + 1 < bins.size())
        prep = std::thread([&, k] { prepare_bin(bins[k + 1], grid, o.threads, slots[(k + 1) % 2], scratch); });
      MDS_TRY(build_bin(ctx, workers, cur.sb.keys, cur.sb.perm, SpillRecords{cur.recs, cur.side},
                        bins[k].prefix_bits / 3, *writer, tot, progress));
      rep.seconds_nodes += meter.lap("nodes");
    }
    join_prep();
    slots[0] = {};
    slots[1] = {};
    scratch.release();
    rep.seconds_build = rep.seconds_sort + rep.seconds_nodes;
  }
  progress.finish();
  workers.clear();
  if (tot.particles != scan.count)
    return make_error(Errc::internal, "built {} particles of {}", tot.particles, scan.count);

  // ---- summary and finish
  store::StoreSummary sum;
  sum.flags = (scan.per_particle_radius ? uint32_t(store::kFlagPerParticleRadius) : 0u) |
              (ctx.side.property ? uint32_t(store::kFlagProperty) : 0u) |
              (ctx.side.color ? uint32_t(store::kFlagColor) : 0u);
  if (ctx.side.property) {
    sum.property_name = o.reader.property;
    sum.property_min = ctx.property_min;
    sum.property_max = ctx.property_max;
  }
  sum.node_size_max = o.node_size;
  sum.meshlet_size_max = o.meshlet_size;
  for (int a = 0; a < 3; ++a) {
    sum.bounds_min[a] = scan.lo[a];
    sum.bounds_max[a] = scan.hi[a];
    sum.density_min[a] = ctx.density.lo()[a];
    sum.density_max[a] = ctx.density.hi()[a];
    sum.density_dims[a] = ctx.density.dims()[a];
  }
  if (scan.per_particle_radius) {
    sum.radius_min = scan.prad_min;
    sum.radius_max = scan.prad_max;
  } else {
    sum.radius_min = *std::min_element(ctx.type_radius.begin(), ctx.type_radius.end());
    sum.radius_max = *std::max_element(ctx.type_radius.begin(), ctx.type_radius.end());
  }
  sum.max_quantization_error = tot.error.max_abs;
  sum.max_error_over_half_step = tot.error.max_over_half_step;
  for (const auto& [id, st] : scan.types) {
    store::TypeEntry e{};
    e.input_id = id;
    e.radius = st.radius;
    e.particle_count = st.count;
    std::strncpy(e.name, st.name.c_str(), sizeof(e.name) - 1);
    sum.types.push_back(e);
  }
  sum.density_counts = std::move(tot.density);
  sum.cell = rep.cell;
  MDS_TRY(writer->finish(sum));
  if (release_thread.joinable()) release_thread.join();
  rep.seconds_finish = meter.lap("finish");

  std::error_code ec;
  rep.file_bytes = std::filesystem::file_size(o.output, ec);
  if (ec) rep.file_bytes = writer->bytes_written();
  rep.nodes = tot.nodes;
  rep.meshlets = tot.meshlets;
  rep.types = uint32_t(scan.types.size());
  rep.mean_meshlet_size = tot.meshlets ? double(tot.particles) / double(tot.meshlets) : 0;
  rep.meshlet_diag_over_spacing = tot.quality.mean_diag_over_spacing();
  rep.bytes_per_particle = double(rep.file_bytes) / double(rep.particles);
  rep.payload_bytes = tot.payload_bytes;
  rep.payload_raw_bytes = tot.payload_raw_bytes;
  rep.compression_ratio = tot.payload_bytes ? double(tot.payload_raw_bytes) / double(tot.payload_bytes) : 0;
  rep.max_quantization_error = tot.error.max_abs;
  rep.max_error_over_half_step = tot.error.max_over_half_step;
  for (int a = 0; a < 3; ++a) {
    rep.bounds_min[a] = scan.lo[a];
    rep.bounds_max[a] = scan.hi[a];
    rep.density_dims[a] = ctx.density.dims()[a];
  }
  rep.per_particle_radius = scan.per_particle_radius;
  rep.color = ctx.side.color;
  if (ctx.side.property) {
    rep.property = o.reader.property;
    rep.property_min = ctx.property_min;
    rep.property_max = ctx.property_max;
  }
  rep.seconds_gather = tot.t_gather;
  rep.seconds_meshlets = tot.t_meshlets;
  rep.seconds_encode = tot.t_encode;
  rep.seconds_append = tot.t_append;
  rep.seconds_total = seconds_since(t_start);
  rep.cpu_seconds = process_cpu_seconds() - cpu_start;
  rep.particles_per_second = rep.seconds_total > 0 ? double(rep.particles) / rep.seconds_total : 0;
  rep.peak_rss_bytes = peak_rss_bytes();
  return rep;
}

// ---------------------------------------------------------------- option parsing

Result<std::map<int32_t, float>> parse_radius_by_type(const std::string& text) {
  std::map<int32_t, float> out;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t comma = text.find(',', pos);
    if (comma == std::string::npos) comma = text.size();
    const std::string item = text.substr(pos, comma - pos);
    const size_t eq = item.find('=');
    if (eq == std::string::npos)
      return make_error(Errc::invalid_argument, "--radius-by-type '{}': expected TYPE=RADIUS pairs such as 1=0.5,2=0.7",
                        text);
    try {
      size_t u1 = 0, u2 = 0;
      const long long id = std::stoll(item.substr(0, eq), &u1);
      const float r = std::stof(item.substr(eq + 1), &u2);
      if (u1 != eq || u2 != item.size() - eq - 1 || id < std::numeric_limits<int32_t>::min() ||
          id > std::numeric_limits<int32_t>::max())
        throw std::invalid_argument("bad");
      if (!(r > 0) || !std::isfinite(r))
        return make_error(Errc::invalid_argument, "--radius-by-type '{}': radius must be positive", item);
      out[int32_t(id)] = r;
    } catch (const std::exception&) {
      return make_error(Errc::invalid_argument, "--radius-by-type: cannot parse '{}' as TYPE=RADIUS", item);
    }
    pos = comma + 1;
  }
  return out;
}

uint64_t peak_rss_bytes() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("VmHWM:", 0) == 0) {
      try {
        return uint64_t(std::stoull(line.substr(6))) * 1024;
      } catch (const std::exception&) {
        return 0;
      }
    }
  }
  return 0;
}

}  // namespace mds::convert
