// Per-bin node building and encoding on worker threads (see node_encoder.h).
#include "convert/node_encoder.h"

#include <time.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include "convert/node_builder.h"

namespace mds::convert {

double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

TypeLut::TypeLut(const std::vector<int32_t>& sorted_ids) {
  if (sorted_ids.empty()) return;
  lo_ = sorted_ids.front();
  const int64_t span = int64_t(sorted_ids.back()) - lo_ + 1;
  if (span <= (1 << 16)) {
    dense_.assign(size_t(span), 0);
    for (size_t i = 0; i < sorted_ids.size(); ++i) dense_[size_t(int64_t(sorted_ids[i]) - lo_)] = uint8_t(i);
  } else {
    for (size_t i = 0; i < sorted_ids.size(); ++i) sparse_.push_back({sorted_ids[i], uint8_t(i)});
  }
}

uint8_t TypeLut::operator()(int32_t id) const {
  if (!dense_.empty()) return dense_[size_t(int64_t(id) - lo_)];
  auto it = std::lower_bound(sparse_.begin(), sparse_.end(), std::pair<int32_t, uint8_t>{id, 0},
                             [](const auto& a, const auto& b) { return a.first < b.first; });
  return it->second;  // every id of the input is in the table (pass A collected them)
}

namespace {

constexpr size_t kGatherPrefetch = 48;  // records prefetched ahead of the gather

struct NodeResult {
  store::EncodedNode encoded;
  QuantError error;
  MeshletQuality quality;
  uint32_t meshlets = 0;
  double t_gather = 0, t_meshlets = 0, t_encode = 0;
};

template <class Recs>
Result<NodeResult> build_node(const BuildContext& ctx, NodeWorker& w, std::span<const uint64_t> keys,
                              std::span<const uint32_t> perm, const Recs& recs) {
  NodeResult res;
  const size_t n = keys.size();
  const double t0 = thread_cpu_seconds();
  // Gather the node's records (sort permutation) into node-local arrays, in Morton order.
  w.xyz.resize(3 * n);
  w.type_index.resize(n);
  w.radius_q.resize(ctx.per_particle_radius ? n : 0);
  w.vcoords.resize(3 * n);
  uint32_t vlo[3] = {UINT32_MAX, UINT32_MAX, UINT32_MAX}, vhi[3] = {0, 0, 0};
  double lo[3], hi[3];
  {
    const SpillRecord& r0 = recs[perm[0]];
    lo[0] = hi[0] = r0.x;
    lo[1] = hi[1] = r0.y;
    lo[2] = hi[2] = r0.z;
  }
  float max_radius = 0;
  for (size_t i = 0; i < n; ++i) {
    // The records are in input order: the gather is a random access, prefetched a few ahead.
    if (i + kGatherPrefetch < n) __builtin_prefetch(recs.address(perm[i + kGatherPrefetch]));
    const SpillRecord& r = recs[perm[i]];
    w.xyz[3 * i] = r.x;
    w.xyz[3 * i + 1] = r.y;
    w.xyz[3 * i + 2] = r.z;
    lo[0] = std::min(lo[0], r.x), hi[0] = std::max(hi[0], r.x);
    lo[1] = std::min(lo[1], r.y), hi[1] = std::max(hi[1], r.y);
    lo[2] = std::min(lo[2], r.z), hi[2] = std::max(hi[2], r.z);
    const uint8_t t = (*ctx.lut)(r.type);
    w.type_index[i] = t;
    if (ctx.per_particle_radius) {
      w.radius_q[i] = quantize_radius(r.radius, ctx.radius_min, ctx.radius_max);
      max_radius = std::max(max_radius, r.radius);
    } else {
      max_radius = std::max(max_radius, ctx.type_radius[t]);
    }
    const double p[3] = {r.x, r.y, r.z};
    for (int a = 0; a < 3; ++a) {
      const uint32_t c = ctx.density.cell(a, p[a]);
      w.vcoords[3 * i + a] = c;
      vlo[a] = std::min(vlo[a], c);
      vhi[a] = std::max(vhi[a], c);
    }
  }
  const double t1 = thread_cpu_seconds();
  res.t_gather = t1 - t0;

  MDS_TRY(w.meshlets->build(keys, w.xyz, ctx.meshlet_size, w.order, w.sizes));
  const double t2 = thread_cpu_seconds();
  res.t_meshlets = t2 - t1;
  add_meshlet_quality(w.xyz, w.order, w.sizes, lo, hi, res.quality);

  // Quantize in meshlet order; permute types and radii alike (in place through scratch).
  const QuantFrame frame = make_frame(lo, hi);
  w.qpos.resize(3 * n);
  QuantError err;  // a local: stays in registers in the loop
  uint16_t* qpos = w.qpos.data();
  const double* xyz = w.xyz.data();
  const uint32_t* order = w.order.data();
  for (size_t k = 0; k < n; ++k) {
    const double* p = &xyz[3 * size_t(order[k])];
    for (int a = 0; a < 3; ++a) {
      const uint16_t q = quantize(frame, a, p[a]);
      qpos[3 * k + a] = q;
      err.add(frame, a, p[a], q);
    }
  }
  res.error = err;
  bool identity = true;
  for (size_t k = 0; k < n && identity; ++k) identity = w.order[k] == k;
  if (!identity) {
    auto& s = w.permute_scratch;
    s.resize(n);
    for (size_t k = 0; k < n; ++k) s[k] = w.type_index[w.order[k]];
    for (size_t k = 0; k < n; ++k) w.type_index[k] = uint8_t(s[k]);
    if (ctx.per_particle_radius) {
      for (size_t k = 0; k < n; ++k) s[k] = w.radius_q[w.order[k]];
      for (size_t k = 0; k < n; ++k) w.radius_q[k] = uint16_t(s[k]);
    }
  }
  voxel_refs_in_box(w.vcoords, ctx.density.dims(), vlo, vhi, w.voxel_scratch, w.refs);

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
  res.t_encode = thread_cpu_seconds() - t2;
  return res;
}

template <class Recs>
Status build_bin_impl(const BuildContext& ctx, std::vector<std::unique_ptr<NodeWorker>>& workers,
                      std::span<const uint64_t> keys, std::span<const uint32_t> perm, const Recs& recs,
                      int start_level, store::StoreWriter& writer, BuildTotals& tot, Progress& progress) {
  if (keys.empty()) return {};
  const std::vector<NodeRange> nodes = build_nodes(keys, start_level, ctx.node_size);
  const size_t window = workers.size() * kWindowPerThread;
  std::vector<std::optional<Result<NodeResult>>> slots(window);  // ring: node i in slot i % window
  std::mutex mu;
  std::condition_variable cv_ready, cv_space;
  size_t appended = 0;
  bool abort = false;
  std::atomic<size_t> next{0};

  auto work = [&](NodeWorker& w) {
    for (;;) {
      const size_t i = next.fetch_add(1);
      if (i >= nodes.size()) return;
      {
        std::unique_lock lock(mu);
        cv_space.wait(lock, [&] { return abort || i < appended + window; });
        if (abort) return;
      }
      const NodeRange nr = nodes[i];
      auto r = build_node(ctx, w, keys.subspan(nr.begin, nr.size()), perm.subspan(nr.begin, nr.size()), recs);
      {
        std::lock_guard lock(mu);
        slots[i % window].emplace(std::move(r));
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
      cv_ready.wait(lock, [&] { return slots[i % window].has_value(); });
      r = std::move(slots[i % window]);
      slots[i % window].reset();
    }
    if (!r->ok()) {
      status = r->error();
      break;
    }
    const double ta = thread_cpu_seconds();
    NodeResult& nr = r->value();
    tot.payload_bytes += nr.encoded.payload.size();
    tot.payload_raw_bytes += nr.encoded.entry.payload_raw_bytes;
    tot.meshlets += nr.meshlets;
    tot.particles += nodes[i].size();
    tot.error.merge(nr.error);
    tot.quality.merge(nr.quality);
    tot.t_gather += nr.t_gather;
    tot.t_meshlets += nr.t_meshlets;
    tot.t_encode += nr.t_encode;
    for (const auto& v : nr.encoded.voxels) tot.density[v.voxel] += v.count;
    Status st = writer.append(std::move(nr.encoded));
    tot.t_append += thread_cpu_seconds() - ta;
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

}  // namespace

Status build_bin(const BuildContext& ctx, std::vector<std::unique_ptr<NodeWorker>>& workers,
                 std::span<const uint64_t> keys, std::span<const uint32_t> perm, std::span<const SpillRecord> recs,
                 int start_level, store::StoreWriter& writer, BuildTotals& tot, Progress& progress) {
  return build_bin_impl(ctx, workers, keys, perm, SpillRecords{recs}, start_level, writer, tot, progress);
}

Status build_bin(const BuildContext& ctx, std::vector<std::unique_ptr<NodeWorker>>& workers,
                 std::span<const uint64_t> keys, std::span<const uint32_t> perm, const RawXyzRecords& recs,
                 int start_level, store::StoreWriter& writer, BuildTotals& tot, Progress& progress) {
  return build_bin_impl(ctx, workers, keys, perm, recs, start_level, writer, tot, progress);
}

}  // namespace mds::convert
