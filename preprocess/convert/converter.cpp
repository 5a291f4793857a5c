// The conversion pipeline driver (see converter.h): pass A (parse + spill), pass B
// (Morton-prefix binning), per-bin build on worker threads, ordered append to the store.
#include "convert/converter.h"

#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>
#include <unordered_map>

#include "convert/binning.h"
#include "convert/meshlet_builder.h"
#include "convert/morton.h"
#include "convert/node_builder.h"
#include "convert/progress.h"
#include "convert/quantize.h"
#include "convert/spill.h"
#include "store/store_writer.h"

namespace mds::convert {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// CPU time of the calling thread / of the whole process (robust to other load on the machine).
double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}
double process_cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

// Memory model of the budget (bytes per particle of each working set).
constexpr uint64_t kRecordBytes = sizeof(KeyedRecord);   // a bin in memory
constexpr uint64_t kBatchBytesPerParticle = 48;           // ParticleBatch (x,y,z,type,radius,id)
constexpr uint64_t kWorkerBytesPerParticle = 192;         // per-node scratch: xyz, PCL cloud + kd-tree, qpos, ...
constexpr uint64_t kInFlightBytesPerParticle = 24;        // an encoded node waiting to be appended
constexpr unsigned kWindowPerThread = 4;                  // encoded nodes in flight per worker

struct TypeStat {
  float radius = 0;
  uint64_t count = 0;
  std::string name;
};

// Input type id -> uint8 index: a dense table when the ids span a small range, else a hash map.
class TypeLut {
 public:
  explicit TypeLut(const std::vector<int32_t>& sorted_ids) {
    if (sorted_ids.empty()) return;
    lo_ = sorted_ids.front();
    const int64_t span = int64_t(sorted_ids.back()) - lo_ + 1;
    if (span <= (1 << 16)) {
      dense_.assign(size_t(span), 0);
      for (size_t i = 0; i < sorted_ids.size(); ++i) dense_[size_t(int64_t(sorted_ids[i]) - lo_)] = uint8_t(i);
    } else {
      for (size_t i = 0; i < sorted_ids.size(); ++i) map_[sorted_ids[i]] = uint8_t(i);
    }
  }
  uint8_t operator()(int32_t id) const {
    if (!dense_.empty()) return dense_[size_t(int64_t(id) - lo_)];
    return map_.at(id);
  }

 private:
  int64_t lo_ = 0;
  std::vector<uint8_t> dense_;
  std::unordered_map<int32_t, uint8_t> map_;
};

// Everything pass A learns about the input.
struct InputScan {
  uint64_t count = 0;
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                  -std::numeric_limits<double>::infinity()};
  bool per_particle_radius = false;
  float prad_min = std::numeric_limits<float>::infinity();
  float prad_max = 0;
  std::map<int32_t, TypeStat> types;
  bool in_memory = true;
  std::vector<KeyedRecord> memory;        // in-memory path
  std::optional<SpillWriter> spill;       // spill path
  std::filesystem::path spill_path;
};

// The budget split (see the memory model above).
struct BudgetPlan {
  size_t batch_particles = 0;
  size_t spill_buffer_bytes = 0;
  size_t partition_buffer_bytes = 0;
  uint64_t max_bin_records = 0;
};

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
  p.batch_particles = size_t(std::clamp<uint64_t>(b / 64 / kBatchBytesPerParticle, 256, 65536));
  p.spill_buffer_bytes = size_t(std::clamp<uint64_t>(b / 16, 64 << 10, 4 << 20));
  p.partition_buffer_bytes = size_t(std::clamp<uint64_t>(b / 4, 256 << 10, 256ull << 20));
  const uint64_t density_bytes = 2 * 4 * density_voxels;  // global counts + store summary copy
  const uint64_t workers = uint64_t(o.threads) * o.node_size * kWorkerBytesPerParticle;
  const uint64_t in_flight = uint64_t(o.threads) * kWindowPerThread * o.node_size * kInFlightBytesPerParticle;
  const uint64_t fixed = density_bytes + workers + in_flight + p.batch_particles * kBatchBytesPerParticle +
                         p.spill_buffer_bytes;
  const uint64_t need = fixed + 2 * kRecordBytes * o.node_size;
  if (b < need)
    return make_error(Errc::budget,
                      "--memory-budget {} bytes is too small: node size {}, {} threads and {} density voxels need at "
                      "least {} bytes ({:.1f} MiB)",
                      b, o.node_size, o.threads, density_voxels, need, double(need) / (1 << 20));
  p.max_bin_records = (b - fixed) / 2 / kRecordBytes;
  return p;
}

// ---------------------------------------------------------------- pass A

float type_radius(const ConvertOptions& o, const FrameInfo& info, int32_t id) {
  if (auto it = o.radius_by_type.find(id); it != o.radius_by_type.end()) return it->second;
  if (auto it = info.type_radius.find(id); it != info.type_radius.end() && it->second > 0 && std::isfinite(it->second))
    return it->second;
  return o.radius;
}

Status spill_memory(InputScan& s, TempDir& tmp, const BudgetPlan& plan) {
  MDS_ASSIGN_OR_RETURN(s.spill_path, tmp.file("spill.rec"));
  MDS_ASSIGN_OR_RETURN(SpillWriter w, SpillWriter::create(s.spill_path, plan.spill_buffer_bytes));
  for (const auto& kr : s.memory) MDS_TRY(w.append(kr.r));
  s.memory = {};
  s.spill.emplace(std::move(w));
  s.in_memory = false;
  return {};
}

Status pass_a(const ConvertOptions& o, std::vector<std::unique_ptr<ParticleReader>>& readers, const BudgetPlan& plan,
              TempDir& tmp, InputScan& s, Progress& progress) {
  uint64_t declared = 0;
  for (const auto& r : readers) declared += r->info().particle_count;
  s.in_memory = declared <= plan.max_bin_records;
  if (s.in_memory) {
    s.memory.reserve(size_t(declared));
  } else {
    MDS_ASSIGN_OR_RETURN(s.spill_path, tmp.file("spill.rec"));
    MDS_ASSIGN_OR_RETURN(SpillWriter w, SpillWriter::create(s.spill_path, plan.spill_buffer_bytes));
    s.spill.emplace(std::move(w));
  }
  progress.stage("read", declared);
  ParticleBatch batch;
  batch.reserve(plan.batch_particles);
  for (size_t f = 0; f < readers.size(); ++f) {
    ParticleReader& reader = *readers[f];
    const auto& path = o.inputs[f];
    const FrameInfo& info = reader.info();
    uint64_t index = 0;  // particle index within this input
    int32_t last_id = 0;
    TypeStat* last = nullptr;
    for (;;) {
      MDS_ASSIGN_OR_RETURN(size_t n, reader.read(batch, plan.batch_particles));
      if (n == 0) break;
      if (batch.x.size() != n || batch.y.size() != n || batch.z.size() != n || batch.type.size() != n ||
          (!batch.radius.empty() && batch.radius.size() != n))
        return make_error(Errc::internal, "{}: reader returned inconsistent batch sizes", path.string());
      const bool has_radius = !batch.radius.empty();
      s.per_particle_radius = s.per_particle_radius || has_radius;
      for (size_t i = 0; i < n; ++i, ++index) {
        SpillRecord r{batch.x[i], batch.y[i], batch.z[i], batch.type[i], 0.0f};
        if (!std::isfinite(r.x) || !std::isfinite(r.y) || !std::isfinite(r.z))
          return make_error(Errc::range, "{}: particle {}: non-finite coordinate ({}, {}, {})", path.string(), index,
                            r.x, r.y, r.z);
        if (!last || r.type != last_id) {
          auto it = s.types.find(r.type);
          if (it == s.types.end()) {
            if (s.types.size() >= store::kMaxTypes)
              return make_error(Errc::unsupported, "{}: particle {}: type {} is the {}th distinct type; at most {} are "
                                "supported", path.string(), index, r.type, s.types.size() + 1, store::kMaxTypes);
            it = s.types.emplace(r.type, TypeStat{type_radius(o, info, r.type), 0, {}}).first;
          }
          last = &it->second;
          last_id = r.type;
        }
        ++last->count;
        if (has_radius) {
          const float rad = batch.radius[i];
          if (!std::isfinite(rad) || rad < 0)
            return make_error(Errc::range, "{}: particle {}: invalid radius {}", path.string(), index, rad);
          r.radius = rad;
        } else {
          r.radius = last->radius;
        }
        s.prad_min = std::min(s.prad_min, r.radius);
        s.prad_max = std::max(s.prad_max, r.radius);
        s.lo[0] = std::min(s.lo[0], r.x);
        s.lo[1] = std::min(s.lo[1], r.y);
        s.lo[2] = std::min(s.lo[2], r.z);
        s.hi[0] = std::max(s.hi[0], r.x);
        s.hi[1] = std::max(s.hi[1], r.y);
        s.hi[2] = std::max(s.hi[2], r.z);
        if (s.in_memory) {
          if (s.memory.size() >= plan.max_bin_records) MDS_TRY(spill_memory(s, tmp, plan));
        }
        if (s.in_memory) {
          s.memory.push_back({0, r});
        } else {
          MDS_TRY(s.spill->append(r));
        }
      }
      s.count += n;
      progress.update(s.count);
    }
    if (index != info.particle_count)
      return make_error(Errc::format, "{}: frame declares {} particles but {} were read", path.string(),
                        info.particle_count, index);
    for (const auto& [id, name] : reader.type_names()) {
      auto it = s.types.find(id);
      if (it != s.types.end() && it->second.name.empty()) it->second.name = name;
    }
    readers[f].reset();  // release the reader's buffers and file
  }
  if (s.spill) MDS_TRY(s.spill->close());
  progress.finish();
  if (s.count == 0) {
    std::string names;
    for (const auto& p : o.inputs) names += (names.empty() ? "" : ", ") + p.string();
    return make_error(Errc::format, "{}: no particles in the input", names);
  }
  return {};
}

// ---------------------------------------------------------------- build

struct BuildContext {
  const ConvertOptions* options = nullptr;
  MortonGrid grid;
  DensityGrid density;
  TypeLut* lut = nullptr;
  std::vector<float> type_radius;  // by type index
  bool per_particle_radius = false;
  float radius_min = 0, radius_max = 0;
};

struct NodeResult {
  store::EncodedNode encoded;
  QuantError error;
  uint32_t meshlets = 0;
  double t_meshlets = 0, t_encode = 0;
};

// Per-worker scratch, reused across nodes.
struct Worker {
  MeshletBuilder meshlets;
  std::vector<double> xyz;
  std::vector<uint32_t> order;
  std::vector<uint8_t> sizes;
  std::vector<uint16_t> qpos;
  std::vector<uint8_t> type_index;
  std::vector<uint16_t> radius_q;
  std::vector<uint32_t> voxels;
  std::vector<store::VoxelRef> refs;
};

Result<NodeResult> build_node(const BuildContext& ctx, Worker& w, std::span<const KeyedRecord> recs) {
  NodeResult res;
  const size_t n = recs.size();
  const double t0 = thread_cpu_seconds();
  w.xyz.resize(3 * n);
  double lo[3] = {recs[0].r.x, recs[0].r.y, recs[0].r.z};
  double hi[3] = {lo[0], lo[1], lo[2]};
  for (size_t i = 0; i < n; ++i) {
    const SpillRecord& r = recs[i].r;
    w.xyz[3 * i] = r.x;
    w.xyz[3 * i + 1] = r.y;
    w.xyz[3 * i + 2] = r.z;
    lo[0] = std::min(lo[0], r.x), hi[0] = std::max(hi[0], r.x);
    lo[1] = std::min(lo[1], r.y), hi[1] = std::max(hi[1], r.y);
    lo[2] = std::min(lo[2], r.z), hi[2] = std::max(hi[2], r.z);
  }
  MDS_TRY(w.meshlets.build(w.xyz, ctx.options->meshlet_size, w.order, w.sizes));
  const double t1 = thread_cpu_seconds();
  res.t_meshlets = t1 - t0;

  const QuantFrame frame = make_frame(lo, hi);
  w.qpos.resize(3 * n);
  w.type_index.resize(n);
  w.radius_q.resize(ctx.per_particle_radius ? n : 0);
  w.voxels.resize(n);
  float max_radius = 0;
  for (size_t k = 0; k < n; ++k) {
    const SpillRecord& r = recs[w.order[k]].r;
    const double p[3] = {r.x, r.y, r.z};
    for (int a = 0; a < 3; ++a) {
      const uint16_t q = quantize(frame, a, p[a]);
      w.qpos[3 * k + a] = q;
      res.error.add(frame, a, p[a], q);
    }
    const uint8_t t = (*ctx.lut)(r.type);
    w.type_index[k] = t;
    if (ctx.per_particle_radius) {
      w.radius_q[k] = quantize_radius(r.radius, ctx.radius_min, ctx.radius_max);
      max_radius = std::max(max_radius, r.radius);
    } else {
      max_radius = std::max(max_radius, ctx.type_radius[t]);
    }
    w.voxels[k] = ctx.density.voxel(r.x, r.y, r.z);
  }
  voxel_refs(w.voxels, w.refs);

  store::NodeInput in;
  in.qpos = w.qpos;
  in.type_index = w.type_index;
  in.radius_q = w.radius_q;
  in.meshlet_size = w.sizes;
  for (int a = 0; a < 3; ++a) {
    in.center_min[a] = lo[a];
    in.center_max[a] = hi[a];
  }
  in.max_radius = max_radius;
  in.voxels = w.refs;
  MDS_ASSIGN_OR_RETURN(res.encoded, store::encode_node(in));
  res.meshlets = uint32_t(w.sizes.size());
  res.t_encode = thread_cpu_seconds() - t1;
  return res;
}

struct BuildTotals {
  uint64_t nodes = 0, meshlets = 0, particles = 0;
  uint64_t payload_bytes = 0, payload_raw_bytes = 0;
  QuantError error;
  double t_meshlets = 0, t_encode = 0;
  std::vector<uint32_t> density;
};

// Builds the nodes of one sorted bin on the worker threads; appends them in order.
Status build_bin(const BuildContext& ctx, std::vector<std::unique_ptr<Worker>>& workers,
                 std::span<const KeyedRecord> recs, int start_level, store::StoreWriter& writer, BuildTotals& tot,
                 Progress& progress) {
  const std::vector<NodeRange> nodes = build_nodes(recs, start_level, ctx.options->node_size);
  const size_t window = workers.size() * kWindowPerThread;
  std::vector<std::optional<Result<NodeResult>>> slots(nodes.size());
  std::mutex mu;
  std::condition_variable cv_ready, cv_space;
  size_t appended = 0;
  bool abort = false;
  std::atomic<size_t> next{0};

  auto work = [&](Worker& w) {
    for (;;) {
      const size_t i = next.fetch_add(1);
      if (i >= nodes.size()) return;
      {
        std::unique_lock lock(mu);
        cv_space.wait(lock, [&] { return abort || i < appended + window; });
        if (abort) return;
      }
      auto r = build_node(ctx, w, recs.subspan(nodes[i].begin, nodes[i].size()));
      {
        std::lock_guard lock(mu);
        slots[i].emplace(std::move(r));
      }
      cv_ready.notify_all();
    }
  };
  std::vector<std::thread> threads;
  threads.reserve(workers.size());
  for (auto& w : workers) threads.emplace_back(work, std::ref(*w));

  Status status;
  for (size_t i = 0; i < nodes.size(); ++i) {
    std::optional<Result<NodeResult>> r;
    {
      std::unique_lock lock(mu);
      cv_ready.wait(lock, [&] { return slots[i].has_value(); });
      r = std::move(slots[i]);
      slots[i].reset();
    }
    if (!r->ok()) {
      status = r->error();
      break;
    }
    NodeResult& nr = r->value();
    tot.payload_bytes += nr.encoded.payload.size();
    tot.payload_raw_bytes += nr.encoded.entry.payload_raw_bytes;
    tot.meshlets += nr.meshlets;
    tot.particles += nodes[i].size();
    tot.error.merge(nr.error);
    tot.t_meshlets += nr.t_meshlets;
    tot.t_encode += nr.t_encode;
    for (const auto& v : nr.encoded.voxels) tot.density[v.voxel] += v.count;
    Status st = writer.append(std::move(nr.encoded));
    if (!st.ok()) {
      status = st;
      break;
    }
    ++tot.nodes;
    {
      std::lock_guard lock(mu);
      appended = i + 1;
    }
    cv_space.notify_all();
    progress.update(tot.particles);
  }
  {
    std::lock_guard lock(mu);
    abort = true;
  }
  cv_space.notify_all();
  for (auto& t : threads) t.join();
  return status;
}

void fill_keys_and_sort(std::vector<KeyedRecord>& recs, const MortonGrid& grid) {
  for (auto& kr : recs) kr.key = grid.key(kr.r.x, kr.r.y, kr.r.z);
  std::sort(recs.begin(), recs.end(), [](const KeyedRecord& a, const KeyedRecord& b) { return a.key < b.key; });
}

Result<std::vector<KeyedRecord>> load_bin(const Bin& bin) {
  MDS_ASSIGN_OR_RETURN(SpillReader reader, SpillReader::open(bin.path));
  if (reader.count() != bin.count)
    return make_error(Errc::internal, "{}: expected {} records, found {}", bin.path.string(), bin.count,
                      reader.count());
  std::vector<KeyedRecord> recs(size_t(bin.count));
  std::vector<SpillRecord> chunk(std::min<size_t>(size_t(bin.count), 1 << 15));
  size_t at = 0;
  for (;;) {
    MDS_ASSIGN_OR_RETURN(size_t n, reader.read(chunk));
    if (n == 0) break;
    if (at + n > recs.size()) return make_error(Errc::internal, "{}: bin grew while reading", bin.path.string());
    for (size_t i = 0; i < n; ++i) recs[at + i].r = chunk[i];
    at += n;
  }
  if (at != recs.size()) return make_error(Errc::internal, "{}: bin is short", bin.path.string());
  return recs;
}

}  // namespace

// ---------------------------------------------------------------- driver

Result<ConvertReport> convert(const ConvertOptions& o) {
  const auto t_start = Clock::now();
  const double cpu_start = process_cpu_seconds();
  MDS_TRY(check_options(o));
  ConvertReport rep;
  rep.memory_budget = o.memory_budget;
  Progress progress(o.progress);

  // Open every input first: a missing or malformed file fails before any work.
  std::vector<std::unique_ptr<ParticleReader>> readers;
  uint64_t declared = 0;
  for (const auto& in : o.inputs) {
    MDS_ASSIGN_OR_RETURN(auto r, open_reader(in, o.reader));
    declared += r->info().particle_count;
    readers.push_back(std::move(r));
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

  // ---- pass A
  auto t = Clock::now();
  InputScan scan;
  MDS_TRY(pass_a(o, readers, plan, tmp, scan, progress));
  rep.seconds_read = seconds_since(t);
  rep.particles = scan.count;
  rep.spilled = !scan.in_memory;

  BuildContext ctx;
  ctx.options = &o;
  ctx.grid = MortonGrid(scan.lo, scan.hi);
  std::array<uint32_t, 3> dims =
      o.density.explicit_dims
          ? o.density.dims
          : choose_density_dims(scan.lo, scan.hi,
                                o.density.target_voxels ? o.density.target_voxels : default_density_target(scan.count));
  ctx.density = DensityGrid(scan.lo, scan.hi, dims);
  std::vector<int32_t> ids;
  for (const auto& [id, st] : scan.types) ids.push_back(id);
  TypeLut lut(ids);
  ctx.lut = &lut;
  for (const auto& [id, st] : scan.types) ctx.type_radius.push_back(st.radius);
  ctx.per_particle_radius = scan.per_particle_radius;
  ctx.radius_min = scan.prad_min;
  ctx.radius_max = scan.prad_max;

  BuildTotals tot;
  tot.density.assign(size_t(ctx.density.voxel_count()), 0);
  std::vector<std::unique_ptr<Worker>> workers;
  for (unsigned i = 0; i < o.threads; ++i) workers.push_back(std::make_unique<Worker>());

  if (scan.in_memory) {
    // ---- everything fits: one bin, the root cell
    t = Clock::now();
    progress.stage("build", scan.count);
    fill_keys_and_sort(scan.memory, ctx.grid);
    rep.seconds_sort += seconds_since(t);
    MDS_TRY(build_bin(ctx, workers, scan.memory, 0, *writer, tot, progress));
    scan.memory = {};
    rep.bins = 1;
    rep.seconds_build = seconds_since(t);
  } else {
    // ---- pass B
    t = Clock::now();
    progress.stage("partition", scan.count);
    PartitionOptions popt;
    popt.max_bin_records = plan.max_bin_records;
    popt.buffer_bytes = plan.partition_buffer_bytes;
    PartitionStats pstats;
    uint64_t scattered = 0;
    MDS_ASSIGN_OR_RETURN(
        std::vector<Bin> bins,
        partition(tmp, Bin{scan.spill_path, scan.count, 0, 0}, ctx.grid, popt, pstats, [&](uint64_t n) {
          scattered += n;
          progress.update(std::min(scattered, scan.count));
        }));
    rep.seconds_partition = seconds_since(t);
    rep.partition_passes = pstats.passes;
    rep.bins = bins.size();

    t = Clock::now();
    progress.stage("build", scan.count);
    for (const Bin& bin : bins) {
      auto ts = Clock::now();
      MDS_ASSIGN_OR_RETURN(std::vector<KeyedRecord> recs, load_bin(bin));
      std::error_code ec;
      std::filesystem::remove(bin.path, ec);
      fill_keys_and_sort(recs, ctx.grid);
      rep.seconds_sort += seconds_since(ts);
      if (!recs.empty() && morton_prefix(recs.front().key, bin.prefix_bits) != bin.prefix)
        return make_error(Errc::internal, "bin {} holds a record outside its Morton cell", bin.path.string());
      MDS_TRY(build_bin(ctx, workers, recs, bin.prefix_bits / 3, *writer, tot, progress));
    }
    rep.seconds_build = seconds_since(t);
  }
  progress.finish();
  workers.clear();
  if (tot.particles != scan.count)
    return make_error(Errc::internal, "built {} particles of {}", tot.particles, scan.count);

  // ---- summary and finish
  store::StoreSummary sum;
  sum.flags = scan.per_particle_radius ? uint32_t(store::kFlagPerParticleRadius) : 0u;
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
  MDS_TRY(writer->finish(sum));

  std::error_code ec;
  rep.file_bytes = std::filesystem::file_size(o.output, ec);
  if (ec) rep.file_bytes = writer->bytes_written();
  rep.nodes = tot.nodes;
  rep.meshlets = tot.meshlets;
  rep.types = uint32_t(scan.types.size());
  rep.mean_meshlet_size = tot.meshlets ? double(tot.particles) / double(tot.meshlets) : 0;
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
  rep.seconds_meshlets = tot.t_meshlets;
  rep.seconds_encode = tot.t_encode;
  rep.seconds_total = seconds_since(t_start);
  rep.cpu_seconds = process_cpu_seconds() - cpu_start;
  rep.particles_per_second = rep.seconds_total > 0 ? double(rep.particles) / rep.seconds_total : 0;
  rep.peak_rss_bytes = peak_rss_bytes();
  return rep;
}

// ---------------------------------------------------------------- option parsing

Result<uint64_t> parse_byte_size(const std::string& text) {
  size_t i = 0;
  while (i < text.size() && (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '.')) ++i;
  const std::string num = text.substr(0, i);
  std::string unit = text.substr(i);
  std::transform(unit.begin(), unit.end(), unit.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  double v = 0;
  try {
    size_t used = 0;
    v = std::stod(num, &used);
    if (used != num.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    return make_error(Errc::invalid_argument, "'{}' is not a size (examples: 512MiB, 2GiB, 1.5G, 65536)", text);
  }
  double mult = 0;
  if (unit.empty() || unit == "b") mult = 1;
  else if (unit == "k" || unit == "kb" || unit == "kib") mult = 1024.0;
  else if (unit == "m" || unit == "mb" || unit == "mib") mult = 1024.0 * 1024;
  else if (unit == "g" || unit == "gb" || unit == "gib") mult = 1024.0 * 1024 * 1024;
  else if (unit == "t" || unit == "tb" || unit == "tib") mult = 1024.0 * 1024 * 1024 * 1024;
  else return make_error(Errc::invalid_argument, "'{}': unknown size unit '{}' (use K, M, G, T, MiB, GiB, ...)", text, unit);
  const double bytes = v * mult;
  if (!(bytes >= 1) || bytes > 1.8e19)
    return make_error(Errc::invalid_argument, "'{}': size out of range", text);
  return uint64_t(bytes);
}

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
