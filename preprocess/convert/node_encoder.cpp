// Per-bin node building and encoding on worker threads (see node_encoder.h).
#include "convert/node_encoder.h"

#include <emmintrin.h>
#include <time.h>

#include <algorithm>
#include <bit>
#include <climits>
#include <cstdint>
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include "convert/node_builder.h"
#include "convert/xyz_sort.h"

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

// The records of one node through the sort permutation (random access, prefetched), with their
// sorted keys.
template <class Recs>
struct PermSource {
  std::span<const uint64_t> keys;
  std::span<const uint32_t> perm;
  const Recs* recs;
  size_t size() const { return perm.size(); }
  PermSource slice(size_t b, size_t n) const { return {keys.subspan(b, n), perm.subspan(b, n), recs}; }
  std::span<const uint64_t> node_keys(NodeWorker&) const { return keys; }
};

// The positions of one node of the sorted raw input (sequential, one type, one radius); no key
// array: the node's keys are computed into the worker's scratch.
struct SortedSource {
  const float* xyz;
  size_t n;
  int32_t type;
  float radius;
  const MortonGrid* grid;
  size_t size() const { return n; }
  SortedSource slice(size_t b, size_t m) const { return {xyz + 3 * b, m, type, radius, grid}; }
  std::span<const uint64_t> node_keys(NodeWorker& w) const {
    w.keys.resize(n);
    morton_keys_of_xyz(xyz, n, *grid, w.keys.data());
    return w.keys;
  }
};

template <class Recs>
void gather(const BuildContext& ctx, NodeWorker& w, const PermSource<Recs>& src, double lo[3], double hi[3],
            uint32_t vlo[3], uint32_t vhi[3], float& max_radius) {
  const size_t n = src.size();
  const Recs& recs = *src.recs;
  const std::span<const uint32_t> perm = src.perm;
  {
    const SpillRecord& r0 = recs[perm[0]];
    lo[0] = hi[0] = r0.x;
    lo[1] = hi[1] = r0.y;
    lo[2] = hi[2] = r0.z;
  }
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
    if (ctx.side.words() > 0) {
      const uint32_t* side = recs.side.data() + size_t(ctx.side.words()) * perm[i];
      if (ctx.side.property)
        w.property_q[i] = quantize_property(std::bit_cast<float>(side[ctx.side.property_word()]), ctx.property_min,
                                            ctx.property_max);
      if (ctx.side.color) w.color[i] = side[ctx.side.color_word()];
    }
    const double p[3] = {r.x, r.y, r.z};
    for (int a = 0; a < 3; ++a) {
      const uint32_t c = ctx.density.cell(a, p[a]);
      w.vcoords[3 * i + a] = c;
      vlo[a] = std::min(vlo[a], c);
      vhi[a] = std::max(vhi[a], c);
    }
  }
}

// The same for the sorted raw positions: a sequential read, the one type and radius hoisted,
// x and y in one SSE2 vector. The same values as the scalar loop: min_pd(v, lo) keeps lo unless
// v < lo, as std::min(lo, v) does; the voxel cell clamps (c, 0, dims - 1) before truncating,
// which equals DensityGrid::cell for the finite c here; truncation is monotone, so the box of
// the cells is the truncated box of the clamped values.
void gather(const BuildContext& ctx, NodeWorker& w, const SortedSource& src, double lo[3], double hi[3],
            uint32_t vlo[3], uint32_t vhi[3], float& max_radius) {
  const size_t n = src.size();
  const float* xyz = src.xyz;
  const uint8_t t = (*ctx.lut)(src.type);
  std::fill(w.type_index.begin(), w.type_index.begin() + ptrdiff_t(n), t);
  max_radius = ctx.type_radius[t];  // the type's radius (per-particle radii do not occur here)
  double* out = w.xyz.data();
  uint32_t* vc = w.vcoords.data();
  const double* dlo = ctx.density.lo();
  const double* dsc = ctx.density.scale();
  const auto& dims = ctx.density.dims();
  const __m128d dlo_xy = _mm_setr_pd(dlo[0], dlo[1]), dlo_z = _mm_set_sd(dlo[2]);
  const __m128d dsc_xy = _mm_setr_pd(dsc[0], dsc[1]), dsc_z = _mm_set_sd(dsc[2]);
  const __m128d dmax_xy = _mm_setr_pd(double(dims[0] - 1), double(dims[1] - 1)), dmax_z = _mm_set_sd(double(dims[2] - 1));
  const __m128d zero = _mm_setzero_pd();
  __m128d lo_xy = _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(xyz))));
  __m128d lo_z = _mm_cvtss_sd(_mm_setzero_pd(), _mm_load_ss(xyz + 2));
  __m128d hi_xy = lo_xy, hi_z = lo_z;
  __m128d clo_xy = _mm_set1_pd(1e300), clo_z = clo_xy, chi_xy = _mm_set1_pd(-1.0), chi_z = chi_xy;
  for (size_t i = 0; i < 3 * n; i += 3) {
    const __m128d xy = _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(xyz + i))));
    const __m128d z = _mm_cvtss_sd(_mm_setzero_pd(), _mm_load_ss(xyz + i + 2));
    _mm_storeu_pd(out + i, xy);
    _mm_store_sd(out + i + 2, z);
    lo_xy = _mm_min_pd(xy, lo_xy), hi_xy = _mm_max_pd(xy, hi_xy);
    lo_z = _mm_min_sd(z, lo_z), hi_z = _mm_max_sd(z, hi_z);
    const __m128d c_xy = _mm_min_pd(_mm_max_pd(_mm_mul_pd(_mm_sub_pd(xy, dlo_xy), dsc_xy), zero), dmax_xy);
    const __m128d c_z = _mm_min_sd(_mm_max_sd(_mm_mul_sd(_mm_sub_sd(z, dlo_z), dsc_z), zero), dmax_z);
    clo_xy = _mm_min_pd(c_xy, clo_xy), chi_xy = _mm_max_pd(c_xy, chi_xy);
    clo_z = _mm_min_sd(c_z, clo_z), chi_z = _mm_max_sd(c_z, chi_z);
    _mm_storel_epi64(reinterpret_cast<__m128i*>(vc + i), _mm_cvttpd_epi32(c_xy));
    vc[i + 2] = uint32_t(_mm_cvttsd_si32(c_z));
  }
  alignas(16) double b[2];
  _mm_store_pd(b, lo_xy), lo[0] = b[0], lo[1] = b[1], lo[2] = _mm_cvtsd_f64(lo_z);
  _mm_store_pd(b, hi_xy), hi[0] = b[0], hi[1] = b[1], hi[2] = _mm_cvtsd_f64(hi_z);
  _mm_store_pd(b, clo_xy), vlo[0] = uint32_t(b[0]), vlo[1] = uint32_t(b[1]), vlo[2] = uint32_t(_mm_cvtsd_f64(clo_z));
  _mm_store_pd(b, chi_xy), vhi[0] = uint32_t(b[0]), vhi[1] = uint32_t(b[1]), vhi[2] = uint32_t(_mm_cvtsd_f64(chi_z));
}

// Quantizes the node's positions in meshlet order (quantize.h) and measures the error, x and y
// in one SSE2 vector: the same operations as quantize() and QuantError::add (clamping
// (t, 0, 65535) before truncating equals quantize()'s tests), the same maxima.
void quantize_node(const QuantFrame& f, const double* xyz, const uint32_t* order, size_t n, uint16_t* qpos,
                   QuantError& err) {
  const __m128d min_xy = _mm_setr_pd(f.min[0], f.min[1]), min_z = _mm_set_sd(f.min[2]);
  const __m128d inv_xy = _mm_setr_pd(f.inv_step[0], f.inv_step[1]), inv_z = _mm_set_sd(f.inv_step[2]);
  const __m128d step_xy = _mm_setr_pd(f.step[0], f.step[1]), step_z = _mm_set_sd(f.step[2]);
  const __m128d ihs_xy = _mm_setr_pd(f.inv_half_step[0], f.inv_half_step[1]), ihs_z = _mm_set_sd(f.inv_half_step[2]);
  const __m128d half = _mm_set1_pd(0.5), zero = _mm_setzero_pd(), qmax = _mm_set1_pd(double(store::kQuantMax));
  const __m128d sign = _mm_set1_pd(-0.0);
  __m128d abs_xy = zero, abs_z = zero, rel_xy = zero, rel_z = zero;
  for (size_t k = 0; k < n; ++k) {
    const double* p = xyz + 3 * size_t(order[k]);
    const __m128d xy = _mm_loadu_pd(p), z = _mm_load_sd(p + 2);
    const __m128d t_xy = _mm_min_pd(_mm_max_pd(_mm_add_pd(_mm_mul_pd(_mm_sub_pd(xy, min_xy), inv_xy), half), zero), qmax);
    const __m128d t_z = _mm_min_sd(_mm_max_sd(_mm_add_sd(_mm_mul_sd(_mm_sub_sd(z, min_z), inv_z), half), zero), qmax);
    const __m128i q_xy = _mm_cvttpd_epi32(t_xy);
    const int q_z = _mm_cvttsd_si32(t_z);
    qpos[3 * k] = uint16_t(_mm_cvtsi128_si32(q_xy));
    qpos[3 * k + 1] = uint16_t(_mm_cvtsi128_si32(_mm_srli_si128(q_xy, 4)));
    qpos[3 * k + 2] = uint16_t(q_z);
    const __m128d d_xy = _mm_andnot_pd(sign, _mm_sub_pd(_mm_add_pd(min_xy, _mm_mul_pd(_mm_cvtepi32_pd(q_xy), step_xy)), xy));
    const __m128d d_z =
        _mm_andnot_pd(sign, _mm_sub_sd(_mm_add_sd(min_z, _mm_mul_sd(_mm_cvtsi32_sd(zero, q_z), step_z)), z));
    abs_xy = _mm_max_pd(abs_xy, d_xy), abs_z = _mm_max_sd(abs_z, d_z);
    rel_xy = _mm_max_pd(rel_xy, _mm_mul_pd(d_xy, ihs_xy)), rel_z = _mm_max_sd(rel_z, _mm_mul_sd(d_z, ihs_z));
  }
  alignas(16) double a[2], r[2];
  _mm_store_pd(a, abs_xy), _mm_store_pd(r, rel_xy);
  err.max_abs = std::max({err.max_abs, a[0], a[1], _mm_cvtsd_f64(abs_z)});
  err.max_over_half_step = std::max({err.max_over_half_step, r[0], r[1], _mm_cvtsd_f64(rel_z)});
}

template <class Source>
Result<NodeResult> build_node(const BuildContext& ctx, NodeWorker& w, const Source& src) {
  NodeResult res;
  const size_t n = src.size();
  const double t0 = thread_cpu_seconds();
  // Gather the node's records (sort permutation) into node-local arrays, in Morton order.
  w.xyz.resize(3 * n);
  w.type_index.resize(n);
  w.radius_q.resize(ctx.per_particle_radius ? n : 0);
  w.property_q.resize(ctx.side.property ? n : 0);
  w.color.resize(ctx.side.color ? n : 0);
  w.vcoords.resize(3 * n);
  uint32_t vlo[3] = {UINT32_MAX, UINT32_MAX, UINT32_MAX}, vhi[3] = {0, 0, 0};
  double lo[3], hi[3];
  float max_radius = 0;
  gather(ctx, w, src, lo, hi, vlo, vhi, max_radius);
  const double t1 = thread_cpu_seconds();
  res.t_gather = t1 - t0;

  MDS_TRY(w.meshlets->build(src.node_keys(w), w.xyz, ctx.meshlet_size, w.order, w.sizes));
  const double t2 = thread_cpu_seconds();
  res.t_meshlets = t2 - t1;
  add_meshlet_quality(w.xyz, w.order, w.sizes, lo, hi, res.quality);

  // Quantize in meshlet order; permute types and radii alike (in place through scratch).
  const QuantFrame frame = make_frame(lo, hi);
  w.qpos.resize(3 * n);
  QuantError err;
  quantize_node(frame, w.xyz.data(), w.order.data(), n, w.qpos.data(), err);
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
    if (ctx.side.property) {
      for (size_t k = 0; k < n; ++k) s[k] = w.property_q[w.order[k]];
      for (size_t k = 0; k < n; ++k) w.property_q[k] = s[k];
    }
    if (ctx.side.color) {
      auto& c = w.color_scratch;
      c.resize(n);
      for (size_t k = 0; k < n; ++k) c[k] = w.color[w.order[k]];
      w.color.swap(c);
    }
  }
  voxel_refs_in_box(w.vcoords, ctx.density.dims(), vlo, vhi, w.voxel_scratch, w.refs);

  store::NodeInput in;
  in.qpos = w.qpos;
  in.type_index = w.type_index;
  in.radius_q = w.radius_q;
  in.property_q = w.property_q;
  in.color = w.color;
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

// `nodes` partition the source's sorted records.
template <class Source>
Status build_bin_impl(const BuildContext& ctx, std::vector<std::unique_ptr<NodeWorker>>& workers,
                      const std::vector<NodeRange>& nodes, const Source& src, store::StoreWriter& writer,
                      BuildTotals& tot, Progress& progress) {
  if (nodes.empty()) return {};
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
      auto r = build_node(ctx, w, src.slice(nr.begin, nr.size()));
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
                 std::span<const uint64_t> keys, std::span<const uint32_t> perm, const SpillRecords& recs,
                 int start_level, store::StoreWriter& writer, BuildTotals& tot, Progress& progress) {
  if (recs.side.size() != size_t(ctx.side.words()) * recs.size())
    return make_error(Errc::internal, "build_bin: {} side words for {} records of {} words", recs.side.size(),
                      recs.size(), ctx.side.words());
  return build_bin_impl(ctx, workers, build_nodes(keys, start_level, ctx.node_size),
                        PermSource<SpillRecords>{keys, perm, &recs}, writer, tot, progress);
}

Status build_bin(const BuildContext& ctx, std::vector<std::unique_ptr<NodeWorker>>& workers,
                 const SortedXyzRecords& recs, const MortonGrid& grid, int start_level, store::StoreWriter& writer,
                 BuildTotals& tot, Progress& progress) {
  if (ctx.per_particle_radius || ctx.side.words() > 0)
    return make_error(Errc::internal, "build_bin: sorted raw positions carry no radii, properties or colours");
  return build_bin_impl(ctx, workers, build_nodes(XyzMortonKeys{recs.xyz, recs.n, &grid}, start_level, ctx.node_size),
                        SortedSource{recs.xyz, recs.n, recs.type, recs.radius, &grid}, writer, tot, progress);
}

}  // namespace mds::convert
