// Pass A with a read-ahead thread (see input_scan.h).
#include "convert/input_scan.h"

#include <emmintrin.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <bit>

#include <cmath>
#include <cstring>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "store/format.h"

namespace mds::convert {

namespace {

// A batch travelling from the reader thread to the consumer.
struct Filled {
  size_t slot = 0;
  size_t file = 0;
  size_t n = 0;              // 0: end of that file
  std::optional<Error> error;
};

// Ring of batches: the reader thread takes free slots and queues filled ones in order.
class ReadAhead {
 public:
  ReadAhead(std::vector<std::unique_ptr<ParticleReader>>& readers, size_t batch_particles)
      : readers_(readers), batch_particles_(batch_particles), batches_(kReadAheadBatches) {
    for (size_t i = 0; i < batches_.size(); ++i) {
      batches_[i].reserve(batch_particles);
      free_.push_back(i);
    }
    thread_ = std::thread([this] { run(); });
  }
  ~ReadAhead() {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  ReadAhead(const ReadAhead&) = delete;
  ReadAhead& operator=(const ReadAhead&) = delete;

  Filled next() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return !filled_.empty(); });
    Filled f = filled_.front();
    filled_.pop_front();
    return f;
  }
  const ParticleBatch& batch(size_t slot) const { return batches_[slot]; }
  void release(size_t slot) {
    {
      std::lock_guard lock(mu_);
      free_.push_back(slot);
    }
    cv_.notify_all();
  }

 private:
  void run() {
    for (size_t f = 0; f < readers_.size(); ++f) {
      for (;;) {
        size_t slot;
        {
          std::unique_lock lock(mu_);
          cv_.wait(lock, [&] { return stop_ || !free_.empty(); });
          if (stop_) return;
          slot = free_.front();
          free_.pop_front();
        }
        Filled item{slot, f, 0, std::nullopt};
        auto r = readers_[f]->read(batches_[slot], batch_particles_);
        if (r.ok()) item.n = *r;
        else item.error = r.error();
        const bool done = !r.ok() || item.n == 0;
        {
          std::lock_guard lock(mu_);
          filled_.push_back(std::move(item));
        }
        cv_.notify_all();
        if (!r.ok()) return;
        if (done) break;  // the consumer owns readers_[f] from here on
      }
    }
  }

  std::vector<std::unique_ptr<ParticleReader>>& readers_;
  size_t batch_particles_;
  std::vector<ParticleBatch> batches_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<size_t> free_;
  std::deque<Filled> filled_;
  bool stop_ = false;
  std::thread thread_;
};

// Bounds of n interleaved xyz particles (lo/hi start at the first particle) and whether any
// coordinate is not finite (exponent bits all ones); `lo = min(lo, v)` keeps the value seen first
// among equal ones. Returns non-zero when a coordinate is special.
uint32_t scan_xyz_scalar(const float* xyz, size_t n, float lo[3], float hi[3]) {
  uint32_t special = 0;
  for (size_t i = 0; i < n; ++i) {
    const float* q = &xyz[3 * i];
    for (int a = 0; a < 3; ++a) {
      uint32_t bits;
      std::memcpy(&bits, &q[a], 4);
      special |= uint32_t((bits & 0x7f800000u) == 0x7f800000u);
      lo[a] = std::min(lo[a], q[a]);
      hi[a] = std::max(hi[a], q[a]);
    }
  }
  return special;
}

// The same, 4 particles (3 SSE2 vectors) at a time. The results equal the scalar loop's up to the
// sign of a zero (see the caller), and exactly when no coordinate is -0.0 (all zeros then have the
// same bits); `negative_zero` says whether one is. minps(v, acc) keeps acc on ties, as
// std::min(acc, v) does.
uint32_t scan_xyz_sse2(const float* xyz, size_t n, float lo[3], float hi[3], bool& negative_zero) {
  const size_t blocks = n / 4;
  // Lane layout of the three vectors of a block: x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3.
  const __m128 l0 = _mm_setr_ps(lo[0], lo[1], lo[2], lo[0]), l1 = _mm_setr_ps(lo[1], lo[2], lo[0], lo[1]),
               l2 = _mm_setr_ps(lo[2], lo[0], lo[1], lo[2]);
  const __m128 h0 = _mm_setr_ps(hi[0], hi[1], hi[2], hi[0]), h1 = _mm_setr_ps(hi[1], hi[2], hi[0], hi[1]),
               h2 = _mm_setr_ps(hi[2], hi[0], hi[1], hi[2]);
  __m128 mn0 = l0, mn1 = l1, mn2 = l2, mx0 = h0, mx1 = h1, mx2 = h2;
  const __m128i expo = _mm_set1_epi32(0x7f800000);
  __m128i bad = _mm_setzero_si128(), nzero = _mm_setzero_si128();
  const __m128i sign = _mm_set1_epi32(int(0x80000000u));
  for (size_t k = 0; k < blocks; ++k) {
    const float* p = xyz + 12 * k;
    const __m128 v0 = _mm_loadu_ps(p), v1 = _mm_loadu_ps(p + 4), v2 = _mm_loadu_ps(p + 8);
    mn0 = _mm_min_ps(v0, mn0);
    mn1 = _mm_min_ps(v1, mn1);
    mn2 = _mm_min_ps(v2, mn2);
    mx0 = _mm_max_ps(v0, mx0);
    mx1 = _mm_max_ps(v1, mx1);
    mx2 = _mm_max_ps(v2, mx2);
    const __m128i e0 = _mm_cmpeq_epi32(_mm_and_si128(_mm_castps_si128(v0), expo), expo);
    const __m128i e1 = _mm_cmpeq_epi32(_mm_and_si128(_mm_castps_si128(v1), expo), expo);
    const __m128i e2 = _mm_cmpeq_epi32(_mm_and_si128(_mm_castps_si128(v2), expo), expo);
    bad = _mm_or_si128(bad, _mm_or_si128(e0, _mm_or_si128(e1, e2)));
    const __m128i z0 = _mm_cmpeq_epi32(_mm_castps_si128(v0), sign);
    const __m128i z1 = _mm_cmpeq_epi32(_mm_castps_si128(v1), sign);
    const __m128i z2 = _mm_cmpeq_epi32(_mm_castps_si128(v2), sign);
    nzero = _mm_or_si128(nzero, _mm_or_si128(z0, _mm_or_si128(z1, z2)));
  }
  negative_zero = _mm_movemask_epi8(nzero) != 0;
  for (size_t i = 12 * blocks; i < 3 * n; ++i) negative_zero = negative_zero || (std::signbit(xyz[i]) && xyz[i] == 0.0f);
  alignas(16) float a[12], b[12];
  _mm_store_ps(a, mn0), _mm_store_ps(a + 4, mn1), _mm_store_ps(a + 8, mn2);
  _mm_store_ps(b, mx0), _mm_store_ps(b + 4, mx1), _mm_store_ps(b + 8, mx2);
  for (int j = 0; j < 12; ++j) {
    lo[j % 3] = std::min(lo[j % 3], a[j]);
    hi[j % 3] = std::max(hi[j % 3], b[j]);
  }
  uint32_t special = uint32_t(_mm_movemask_epi8(bad));
  special |= scan_xyz_scalar(xyz + 12 * blocks, n - 4 * blocks, lo, hi);
  return special;
}

float type_radius(const ScanOptions& o, const FrameInfo& info, int32_t id) {
  if (auto it = o.radius_by_type.find(id); it != o.radius_by_type.end()) return it->second;
  if (auto it = info.type_radius.find(id); it != info.type_radius.end() && it->second > 0 && std::isfinite(it->second))
    return it->second;
  return o.radius;
}

Status spill_memory(InputScan& s, TempDir& tmp, const ScanOptions& o) {
  MDS_ASSIGN_OR_RETURN(s.spill_path, tmp.file("spill.rec"));
  MDS_ASSIGN_OR_RETURN(SpillWriter w, SpillWriter::create(s.spill_path, o.spill_buffer_bytes));
  MDS_TRY(w.append(s.memory));
  if (o.side.words() > 0) {
    MDS_ASSIGN_OR_RETURN(s.spill_side_path, tmp.file("spill.side"));
    MDS_ASSIGN_OR_RETURN(SideSpillWriter pw,
                         SideSpillWriter::create(s.spill_side_path, o.side.words() * o.spill_buffer_bytes / 8));
    MDS_TRY(pw.append(s.memory_side));
    s.spill_side.emplace(std::move(pw));
  }
  s.prefault.reset();  // before the memory goes
  s.memory = {};
  s.memory_side = {};
  s.spill.emplace(std::move(w));
  s.in_memory = false;
  return {};
}

// Validates and stores one batch (records of file `path`, particles from `index`).
Status consume(const ScanOptions& o, const FrameInfo& info, const std::filesystem::path& path, const ParticleBatch& batch,
               size_t n, uint64_t& index, TempDir& tmp, InputScan& s) {
  if (batch.x.size() != n || batch.y.size() != n || batch.z.size() != n || batch.type.size() != n ||
      (!batch.radius.empty() && batch.radius.size() != n) || (o.side.property && batch.property.size() != n) ||
      (o.side.color && batch.color.size() != n))
    return make_error(Errc::internal, "{}: reader returned inconsistent batch sizes", path.string());
  const bool has_radius = !batch.radius.empty();
  s.per_particle_radius = s.per_particle_radius || has_radius;
  if (s.in_memory && s.memory.size() + n > o.max_memory_records) MDS_TRY(spill_memory(s, tmp, o));
  SpillRecord* out = nullptr;
  const uint32_t W = o.side.words();
  uint32_t* out_side = nullptr;
  uint32_t side[2];  // one record's side words (W <= 2)
  if (s.in_memory) {
    const size_t at = s.memory.size();
    s.memory.resize(at + n);  // capacity reserved: no reallocation; default-init: no zero fill
    out = s.memory.data() + at;
    if (W > 0) {
      s.memory_side.resize(W * (at + n));
      out_side = s.memory_side.data() + W * at;
    }
  }
  double lo[3] = {s.lo[0], s.lo[1], s.lo[2]}, hi[3] = {s.hi[0], s.hi[1], s.hi[2]};
  float rmin = s.prad_min, rmax = s.prad_max, vmin = s.property_min, vmax = s.property_max;
  int32_t last_id = 0;
  TypeStat* last = nullptr;
  uint64_t last_count = 0;  // particles of `last` not yet added to its count
  for (size_t i = 0; i < n; ++i) {
    SpillRecord r{batch.x[i], batch.y[i], batch.z[i], batch.type[i], 0.0f};
    if (!std::isfinite(r.x) || !std::isfinite(r.y) || !std::isfinite(r.z))
      return make_error(Errc::range, "{}: particle {}: non-finite coordinate ({}, {}, {})", path.string(), index + i,
                        r.x, r.y, r.z);
    if (!last || r.type != last_id) {
      if (last) last->count += last_count;
      last_count = 0;
      auto it = s.types.find(r.type);
      if (it == s.types.end()) {
        if (s.types.size() >= store::kMaxTypes)
          return make_error(Errc::unsupported, "{}: particle {}: type {} is the {}th distinct type; at most {} are "
                            "supported", path.string(), index + i, r.type, s.types.size() + 1, store::kMaxTypes);
        it = s.types.emplace(r.type, TypeStat{type_radius(o, info, r.type), 0, {}}).first;
      }
      last = &it->second;
      last_id = r.type;
    }
    ++last_count;
    if (has_radius) {
      const float rad = batch.radius[i];
      if (!std::isfinite(rad) || rad < 0)
        return make_error(Errc::range, "{}: particle {}: invalid radius {}", path.string(), index + i, rad);
      r.radius = rad;
    } else {
      r.radius = last->radius;
    }
    rmin = std::min(rmin, r.radius);
    rmax = std::max(rmax, r.radius);
    if (o.side.property) {
      const float v = batch.property[i];
      if (!std::isfinite(v))  // the readers check; a broken reader must not reach the store
        return make_error(Errc::range, "{}: particle {}: non-finite property {}", path.string(), index + i, v);
      vmin = std::min(vmin, v);
      vmax = std::max(vmax, v);
      side[o.side.property_word()] = std::bit_cast<uint32_t>(v);
    }
    if (o.side.color) side[o.side.color_word()] = batch.color[i];
    if (out_side) std::copy(side, side + W, out_side + W * i);
    else if (W > 0) MDS_TRY(s.spill_side->append(std::span<const uint32_t>(side, W)));
    lo[0] = std::min(lo[0], r.x), hi[0] = std::max(hi[0], r.x);
    lo[1] = std::min(lo[1], r.y), hi[1] = std::max(hi[1], r.y);
    lo[2] = std::min(lo[2], r.z), hi[2] = std::max(hi[2], r.z);
    if (out) out[i] = r;
    else MDS_TRY(s.spill->append(r));
  }
  if (last) last->count += last_count;
  for (int a = 0; a < 3; ++a) s.lo[a] = lo[a], s.hi[a] = hi[a];
  s.prad_min = rmin;
  s.prad_max = rmax;
  s.property_min = vmin;
  s.property_max = vmax;
  index += n;
  s.count += n;
  return {};
}

}  // namespace

Status scan_inputs(const ScanOptions& o, std::vector<std::unique_ptr<ParticleReader>>& readers, TempDir& tmp,
                   InputScan& s, Progress& progress) {
  uint64_t declared = 0;
  std::vector<FrameInfo> infos;
  for (const auto& r : readers) {
    declared += r->info().particle_count;
    infos.push_back(r->info());
  }
  s.in_memory = declared <= o.max_memory_records;
  if (s.in_memory) {
    s.memory.reserve(size_t(declared));
    if (o.side.words() > 0) s.memory_side.reserve(size_t(o.side.words() * declared));
    s.prefault = std::make_unique<BackgroundPrefault>(s.memory.data(), s.memory.capacity() * sizeof(SpillRecord));
  } else {
    MDS_ASSIGN_OR_RETURN(s.spill_path, tmp.file("spill.rec"));
    MDS_ASSIGN_OR_RETURN(SpillWriter w, SpillWriter::create(s.spill_path, o.spill_buffer_bytes));
    s.spill.emplace(std::move(w));
    if (o.side.words() > 0) {
      MDS_ASSIGN_OR_RETURN(s.spill_side_path, tmp.file("spill.side"));
      MDS_ASSIGN_OR_RETURN(SideSpillWriter pw,
                           SideSpillWriter::create(s.spill_side_path, o.side.words() * o.spill_buffer_bytes / 8));
      s.spill_side.emplace(std::move(pw));
    }
  }
  progress.stage("read", declared);
  {
    ReadAhead ahead(readers, o.batch_particles);
    std::vector<uint64_t> index(readers.size(), 0);
    size_t files_done = 0;
    while (files_done < readers.size()) {
      const Filled f = ahead.next();
      const auto& path = o.inputs[f.file];
      if (f.error) return *f.error;
      if (f.n == 0) {
        if (index[f.file] != infos[f.file].particle_count)
          return make_error(Errc::format, "{}: frame declares {} particles but {} were read", path.string(),
                            infos[f.file].particle_count, index[f.file]);
        for (const auto& [id, name] : readers[f.file]->type_names()) {
          auto it = s.types.find(id);
          if (it != s.types.end() && it->second.name.empty()) it->second.name = name;
        }
        readers[f.file].reset();  // release the reader's buffers and file
        ahead.release(f.slot);
        ++files_done;
        continue;
      }
      Status st = consume(o, infos[f.file], path, ahead.batch(f.slot), f.n, index[f.file], tmp, s);
      ahead.release(f.slot);
      MDS_TRY(st);
      progress.update(s.count);
    }
  }
  s.prefault.reset();
  if (s.spill) MDS_TRY(s.spill->close());
  if (s.spill_side) MDS_TRY(s.spill_side->close());
  progress.finish();
  if (s.count == 0) {
    std::string names;
    for (const auto& p : o.inputs) names += (names.empty() ? "" : ", ") + p.string();
    return make_error(Errc::format, "{}: no particles in the input", names);
  }
  return {};
}

Status scan_raw_mapped(const ScanOptions& o, RawReader& reader, unsigned threads, InputScan& s, RawXyzRecords& view,
                       Progress& progress) {
  const FrameInfo info = reader.info();
  const size_t n = size_t(info.particle_count);
  if (n == 0) return make_error(Errc::format, "{}: no particles in the input", o.inputs.at(0).string());
  MDS_ASSIGN_OR_RETURN(std::span<const float> xyz, reader.map_coordinates());
  progress.stage("read", n);
  // Each thread maps its share of the file's pages in bulk, then takes bounds and checks that
  // every coordinate is finite (exponent bits not all ones), without branches.
  struct Part {
    float lo[3], hi[3];
    bool bad = false;
  };
  const unsigned parts = (threads > 1 && n >= (size_t(1) << 16)) ? threads : 1;
  std::vector<Part> part(parts);
  auto scan = [&](unsigned k) {
    const size_t b = n * k / parts, e = n * (k + 1) / parts;
    Part& p = part[k];
#ifdef MADV_POPULATE_READ
    const uintptr_t page = uintptr_t(::sysconf(_SC_PAGESIZE));
    const uintptr_t pb = uintptr_t(xyz.data() + 3 * b) / page * page, pe = uintptr_t(xyz.data() + 3 * e);
    if (pe > pb) (void)::madvise(reinterpret_cast<void*>(pb), pe - pb, MADV_POPULATE_READ);
#endif
    float lo[3] = {xyz[3 * b], xyz[3 * b + 1], xyz[3 * b + 2]}, hi[3] = {lo[0], lo[1], lo[2]};
    bool negative_zero = false;
    uint32_t special = scan_xyz_sse2(xyz.data() + 3 * b, e - b, lo, hi, negative_zero);
    // The vector lanes may meet the same extreme value in another order than the scalar loop;
    // that only shows for +0 and -0 (equal, different bits). Then the scalar loop decides. (A
    // bound of +0 alone is common, e.g. a box from 0, and needs no second pass.)
    bool zero = false;
    for (int a = 0; a < 3; ++a) zero = zero || lo[a] == 0.0f || hi[a] == 0.0f;
    if (zero && negative_zero) {
      for (int a = 0; a < 3; ++a) lo[a] = hi[a] = xyz[3 * b + a];
      special = scan_xyz_scalar(xyz.data() + 3 * b, e - b, lo, hi);
    }
    for (int a = 0; a < 3; ++a) p.lo[a] = lo[a], p.hi[a] = hi[a];
    p.bad = special != 0;
  };
  {
    std::vector<std::thread> pool;
    for (unsigned k = 1; k < parts; ++k) pool.emplace_back(scan, k);
    scan(0);
    for (auto& t : pool) t.join();
  }
  for (const Part& p : part)
    if (p.bad) {
      for (size_t i = 0; i < n; ++i)  // the first offending particle, as the reader names it
        if (!std::isfinite(xyz[3 * i]) || !std::isfinite(xyz[3 * i + 1]) || !std::isfinite(xyz[3 * i + 2]))
          return reader.non_finite_error(i);
    }
  for (const Part& p : part)
    for (int a = 0; a < 3; ++a) {
      s.lo[a] = std::min(s.lo[a], double(p.lo[a]));
      s.hi[a] = std::max(s.hi[a], double(p.hi[a]));
    }
  const int32_t type = 1;  // the raw reader's one type
  const float radius = type_radius(o, info, type);
  TypeStat st{radius, n, {}};
  if (auto names = reader.type_names(); names.count(type)) st.name = names[type];
  s.types.clear();
  s.types.emplace(type, st);
  s.per_particle_radius = false;
  s.prad_min = s.prad_max = radius;
  s.count = n;
  s.in_memory = true;
  view = RawXyzRecords{xyz.data(), n, type, radius};
  progress.update(n);
  progress.finish();
  return {};
}

}  // namespace mds::convert
