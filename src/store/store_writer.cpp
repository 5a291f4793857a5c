// Store writer: serializes (payload_codec.h) and LZ4-compresses node payloads (format.h /
// docs/store-format.md), appends them to "<path>.tmp.<pid>" through aligned 4 MiB blocks that a
// background thread writes (O_DIRECT where possible, see BlockStream), then writes the type table,
// the node directory, the LZ4-compressed voxel lists and density volume (section_codec.h) and the
// occupancy records, with a cell the cell record and with a property the per-node property
// histograms (property_histogram.h), each with its XXH3-64 hash, and finally the header (hashed
// with header_hash = 0), fsync and rename.
#include "store/store_writer.h"

#include <fcntl.h>
#include <lz4.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "core/huge_pages.h"
#include "culling/node_occupancy.h"
#include "store/file_io.h"
#include "store/hash.h"
#include "store/payload_codec.h"
#include "store/property_histogram.h"
#include "store/section_codec.h"

static_assert(std::endian::native == std::endian::little, "the store format is little-endian; port the I/O first");

namespace mds::store {

namespace {

bool finite3(const double v[3]) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

constexpr uint64_t kMaxDensityVoxels = uint64_t(1) << 28;

}  // namespace

Result<EncodedNode> encode_node(const NodeInput& node) {
  const uint64_t n = node.type_index.size();
  const uint64_t m = node.meshlet_size.size();
  if (n < 1 || n > kMaxNodeParticles)
    return make_error(Errc::internal, "encode_node: particle count {} outside [1, {}]", n, kMaxNodeParticles);
  if (node.qpos.size() != 3 * n)
    return make_error(Errc::internal, "encode_node: qpos has {} values, expected 3*{}", node.qpos.size(), n);
  if (!node.radius_q.empty() && node.radius_q.size() != n)
    return make_error(Errc::internal, "encode_node: radius_q has {} values, expected 0 or {}", node.radius_q.size(), n);
  if (!node.property_q.empty() && node.property_q.size() != n)
    return make_error(Errc::internal, "encode_node: property_q has {} values, expected 0 or {}", node.property_q.size(), n);
  if (!node.color.empty() && node.color.size() != n)
    return make_error(Errc::internal, "encode_node: color has {} values, expected 0 or {}", node.color.size(), n);
  if (m < 1 || m > n) return make_error(Errc::internal, "encode_node: meshlet count {} outside [1, {}]", m, n);
  uint64_t sum = 0;
  uint32_t max_meshlet = 0;
  for (uint64_t i = 0; i < m; ++i) {
    if (node.meshlet_size[i] == 0) return make_error(Errc::internal, "encode_node: meshlet {} is empty", i);
    sum += node.meshlet_size[i];
    max_meshlet = std::max<uint32_t>(max_meshlet, node.meshlet_size[i]);
  }
  if (sum != n) return make_error(Errc::internal, "encode_node: meshlet sizes sum to {}, expected {}", sum, n);
  if (!finite3(node.center_min) || !finite3(node.center_max))
    return make_error(Errc::internal, "encode_node: non-finite quantization frame");
  for (int a = 0; a < 3; ++a)
    if (node.center_min[a] > node.center_max[a])
      return make_error(Errc::internal, "encode_node: center_min > center_max on axis {}", a);
  if (!std::isfinite(node.max_radius) || node.max_radius < 0)
    return make_error(Errc::internal, "encode_node: max_radius {} is not a finite non-negative value", node.max_radius);
  if (!node.voxels.empty()) {
    uint64_t vsum = 0;
    for (size_t i = 0; i < node.voxels.size(); ++i) {
      if (node.voxels[i].count == 0) return make_error(Errc::internal, "encode_node: voxel ref {} has count 0", i);
      if (i > 0 && node.voxels[i].voxel <= node.voxels[i - 1].voxel)
        return make_error(Errc::internal, "encode_node: voxel refs not strictly sorted at {}", i);
      vsum += node.voxels[i].count;
    }
    if (vsum != n) return make_error(Errc::internal, "encode_node: voxel counts sum to {}, expected {}", vsum, n);
  }

  const bool radius = !node.radius_q.empty();
  thread_local std::vector<uint8_t> raw;
  encode_payload(node, raw);
  const uint64_t raw_size = raw.size();

  // Compressed into per-thread scratch, then copied out at its exact size (no zero fill of the
  // bound, no shrinking reallocation).
  thread_local std::vector<uint8_t> packed;
  const size_t bound = static_cast<size_t>(LZ4_compressBound(static_cast<int>(raw_size)));
  if (packed.size() < bound) packed.resize(bound);
  int c = LZ4_compress_default(reinterpret_cast<const char*>(raw.data()), reinterpret_cast<char*>(packed.data()),
                               static_cast<int>(raw_size), static_cast<int>(bound));
  if (c <= 0) return make_error(Errc::internal, "encode_node: LZ4 compression of {} bytes failed", raw_size);
  EncodedNode out;
  out.payload.assign(packed.begin(), packed.begin() + c);

  NodeEntry& e = out.entry;
  std::memset(&e, 0, sizeof(e));
  e.payload_bytes = static_cast<uint32_t>(c);
  e.payload_raw_bytes = static_cast<uint32_t>(raw_size);
  e.payload_hash = hash_bytes(out.payload);
  e.particle_count = static_cast<uint32_t>(n);
  e.meshlet_count = static_cast<uint32_t>(m);
  for (int a = 0; a < 3; ++a) {
    e.center_min[a] = node.center_min[a];
    e.center_max[a] = node.center_max[a];
  }
  e.max_radius = node.max_radius;
  e.voxel_count = static_cast<uint32_t>(node.voxels.size());
  out.voxels.assign(node.voxels.begin(), node.voxels.end());
  static_assert(sizeof(culling::FineOccupancy) == kOccupancyBytes);
  const culling::FineOccupancy occ =
      culling::fine_occupancy_of_quantized(node.center_min, node.center_max, double(node.max_radius), node.qpos);
  std::copy(occ.begin(), occ.end(), out.occupancy.begin());
  out.max_meshlet_size = max_meshlet;
  out.per_particle_radius = radius;
  out.property = !node.property_q.empty();
  if (out.property) out.property_histogram = make_property_histogram(node.property_q);
  out.color = !node.color.empty();
  uint32_t counts[256] = {};  // n <= 65535
  uint32_t top = 0;
  for (uint64_t i = 0; i < n; ++i) {
    const uint8_t t = node.type_index[i];
    ++counts[t];
    top = std::max<uint32_t>(top, t);
  }
  out.type_counts.assign(counts, counts + top + 1);
  return out;
}

// The output stream: the bytes of the file from offset 0 on, collected in aligned 4 MiB blocks
// that a background thread writes while the nodes are still being built. Where the file system
// allows it (ext4, xfs, ...), full blocks are written with O_DIRECT: no copy into the page cache
// (on the 2-core VM that copy of freshly allocated page-cache pages cost about 0.15 CPU-s per
// 56 MB store, on the appending thread) and no writeback left for the final fsync. Otherwise, and
// for the unaligned end of the file, plain pwrite on a second descriptor, with writeback started
// right away (sync_file_range), so that the fsync of commit() finds little left to write.
// The blocks are written in order; the bytes on disk are exactly those appended.
class BlockStream {
 public:
  static constexpr size_t kBlock = size_t(4) << 20;
  static constexpr size_t kBuffers = 3;
  static constexpr size_t kAlign = 4096;  // O_DIRECT offset/length/address alignment (any logical block size up to 4 KiB)

  explicit BlockStream(const std::filesystem::path& temp_path) : name_(temp_path.string()) {
    direct_fd_ = ::open(temp_path.c_str(), O_WRONLY | O_CLOEXEC | O_DIRECT);
    plain_fd_ = ::open(temp_path.c_str(), O_WRONLY | O_CLOEXEC);
    for (size_t i = 0; i < kBuffers; ++i) {
      // Two huge pages per block: two faults instead of 1024.
      void* p = allocate_huge_aligned(kBlock);
      if (!p) {
        buffers_ok_ = false;  // ok() is false; create() reports it
        return;
      }
      buffers_.emplace_back(static_cast<uint8_t*>(p));
      free_.push_back(buffers_.back().get());
    }
    cur_ = take_free();
    thread_ = std::thread([this] { run(); });
  }
  ~BlockStream() {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
    if (direct_fd_ >= 0) ::close(direct_fd_);
    if (plain_fd_ >= 0) ::close(plain_fd_);
  }
  BlockStream(const BlockStream&) = delete;
  BlockStream& operator=(const BlockStream&) = delete;

  // The temporary file opened and the write buffers allocated (else the stream is unusable).
  bool ok() const { return plain_fd_ >= 0 && buffers_ok_; }
  bool buffers_ok() const { return buffers_ok_; }
  uint64_t offset() const { return offset_; }

  Status write(const void* src, size_t n) {
    const auto* p = static_cast<const uint8_t*>(src);
    while (n > 0) {
      const size_t k = std::min(n, kBlock - used_);
      std::memcpy(cur_ + used_, p, k);
      used_ += k;
      offset_ += k;
      p += k;
      n -= k;
      if (used_ == kBlock) MDS_TRY(submit());
    }
    return {};
  }

  // Writes everything appended so far and waits for it; the stream stays usable.
  Status flush() {
    if (used_ > 0) MDS_TRY(submit());
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return queue_.empty() && !busy_; });
    return status_;
  }

 private:
  struct Job {
    uint8_t* data;
    size_t bytes;
    uint64_t offset;
  };
  struct FreeDeleter {
    void operator()(uint8_t* p) const { std::free(p); }
  };

  uint8_t* take_free() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return !free_.empty(); });
    uint8_t* b = free_.front();
    free_.pop_front();
    return b;
  }

  Status submit() {
    {
      std::lock_guard lock(mu_);
      if (!status_.ok()) return status_;
      queue_.push_back({cur_, used_, offset_ - used_});
    }
    cv_.notify_all();
    used_ = 0;
    cur_ = take_free();
    return {};
  }

  Status pwrite_fd(int fd, const uint8_t* p, size_t n, uint64_t off) {
    size_t done = 0;
    while (done < n) {
      const ssize_t r = ::pwrite(fd, p + done, n - done, off_t(off + done));
      if (r < 0) {
        if (errno == EINTR) continue;
        return make_error(Errc::io, "{}: write at byte {} failed: {}", name_, off + done, std::strerror(errno));
      }
      done += size_t(r);
    }
    return {};
  }

  Status write_job(const Job& j) {
    size_t direct = 0;
    if (direct_fd_ >= 0 && j.offset % kAlign == 0) direct = j.bytes / kAlign * kAlign;
    if (direct > 0) {
      const ssize_t r = ::pwrite(direct_fd_, j.data, direct, off_t(j.offset));
      if (r == ssize_t(direct)) {
        direct_bytes_ += direct;
      } else {
        // Not supported after all (or a short write): everything from here on goes through the
        // page cache; a real I/O error shows up again there.
        ::close(direct_fd_);
        direct_fd_ = -1;
        direct = 0;
      }
    }
    if (direct < j.bytes) {
      MDS_TRY(pwrite_fd(plain_fd_, j.data + direct, j.bytes - direct, j.offset + direct));
#ifdef SYNC_FILE_RANGE_WRITE
      (void)::sync_file_range(plain_fd_, off64_t(j.offset + direct), off64_t(j.bytes - direct), SYNC_FILE_RANGE_WRITE);
#endif
    }
    return {};
  }

  void run() {
    for (;;) {
      Job j;
      {
        std::unique_lock lock(mu_);
        cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (queue_.empty()) return;
        j = queue_.front();
        queue_.pop_front();
        busy_ = true;
      }
      Status st = status_.ok() ? write_job(j) : Status{};
      {
        std::lock_guard lock(mu_);
        if (!st.ok() && status_.ok()) status_ = st;
        free_.push_back(j.data);
        busy_ = false;
      }
      cv_.notify_all();
    }
  }

  std::string name_;
  int direct_fd_ = -1;
  int plain_fd_ = -1;
  std::vector<std::unique_ptr<uint8_t, FreeDeleter>> buffers_;
  uint8_t* cur_ = nullptr;
  size_t used_ = 0;
  uint64_t offset_ = 0;
  uint64_t direct_bytes_ = 0;  // written with O_DIRECT (writer thread only)
  bool buffers_ok_ = true;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<uint8_t*> free_;
  std::deque<Job> queue_;
  bool busy_ = false;
  bool stop_ = false;
  Status status_;
  std::thread thread_;
};

struct StoreWriter::Impl {
  AtomicOutput out;
  std::unique_ptr<BlockStream> writer;
  std::vector<NodeEntry> entries;
  std::vector<VoxelRef> voxels;
  std::vector<uint8_t> occupancy;  // kOccupancyBytes per node
  std::vector<PropertyHistogram> histograms;  // per node with a property
  std::vector<uint64_t> type_counts;
  uint64_t particles = 0;
  uint64_t meshlets = 0;
  uint64_t payload_bytes = 0;
  uint64_t payload_raw_bytes = 0;
  uint32_t max_node_particles = 0;
  uint32_t max_meshlet_size = 0;
  uint64_t radius_nodes = 0;    // nodes encoded with per-particle radii
  uint64_t property_nodes = 0;  // nodes encoded with property_q
  uint64_t color_nodes = 0;     // nodes encoded with color
  bool finished = false;
  bool failed = false;  // an I/O error left the temporary file in an unknown state

  std::string name() const { return out.final_path().string(); }
};

Result<std::unique_ptr<StoreWriter>> StoreWriter::create(const std::filesystem::path& path) {
  std::unique_ptr<StoreWriter> w(new StoreWriter());
  w->impl_ = std::make_unique<Impl>();
  MDS_ASSIGN_OR_RETURN(w->impl_->out, AtomicOutput::create(path));
  w->impl_->writer = std::make_unique<BlockStream>(w->impl_->out.temp_path());
  if (!w->impl_->writer->buffers_ok())
    return make_error(Errc::io, "{}: cannot allocate {} write buffers of {} bytes", w->impl_->out.temp_path().string(),
                      BlockStream::kBuffers, BlockStream::kBlock);
  if (!w->impl_->writer->ok())
    return make_error(Errc::io, "{}: cannot open for writing: {}", w->impl_->out.temp_path().string(),
                      std::strerror(errno));
  // Reserve the header; it is written last.
  std::vector<uint8_t> zeros(kHeaderBytes, 0);
  MDS_TRY(w->impl_->writer->write(zeros.data(), zeros.size()));
  return w;
}

StoreWriter::~StoreWriter() = default;  // AtomicOutput removes the temporary file unless committed

void StoreWriter::reserve(uint64_t nodes, uint64_t voxel_refs) {
  Impl& s = *impl_;
  nodes = std::min<uint64_t>(nodes, uint64_t(1) << 24);
  s.entries.reserve(size_t(nodes));
  s.occupancy.reserve(size_t(nodes) * kOccupancyBytes);
  s.voxels.reserve(size_t(std::min<uint64_t>(voxel_refs, kMaxVoxelRefs)));
}

Status StoreWriter::append(EncodedNode&& node) {
  Impl& s = *impl_;
  if (s.finished) return make_error(Errc::internal, "{}: append after finish", s.name());
  if (s.failed) return make_error(Errc::internal, "{}: append after a failed write", s.name());
  NodeEntry e = node.entry;
  const uint64_t index = s.entries.size();
  if (index >= 0xFFFFFFFFull) return make_error(Errc::range, "{}: more than 2^32-1 nodes", s.name());
  if (node.payload.size() != e.payload_bytes || e.payload_bytes == 0)
    return make_error(Errc::internal, "{}: node {}: payload has {} bytes, entry says {}", s.name(), index,
                      node.payload.size(), e.payload_bytes);
  if (node.voxels.size() != e.voxel_count)
    return make_error(Errc::internal, "{}: node {}: {} voxel refs, entry says {}", s.name(), index, node.voxels.size(),
                      e.voxel_count);
  if (s.voxels.size() + node.voxels.size() > kMaxVoxelRefs)
    return make_error(Errc::range,
                      "{}: node {}: more than {} voxel refs in the store (the format's limit; use a coarser --density-res "
                      "or larger nodes)",
                      s.name(), index, kMaxVoxelRefs);
  e.payload_offset = s.writer->offset();
  e.first_particle = s.particles;
  e.first_meshlet = s.meshlets;
  e.voxel_first = static_cast<uint32_t>(s.voxels.size());
  e.reserved = 0;
  Status st = s.writer->write(node.payload.data(), node.payload.size());
  if (!st.ok()) {
    s.failed = true;
    return st;
  }
  s.particles += e.particle_count;
  s.meshlets += e.meshlet_count;
  s.payload_bytes += e.payload_bytes;
  s.payload_raw_bytes += e.payload_raw_bytes;
  s.max_node_particles = std::max(s.max_node_particles, e.particle_count);
  s.max_meshlet_size = std::max(s.max_meshlet_size, node.max_meshlet_size);
  s.radius_nodes += node.per_particle_radius ? 1 : 0;
  s.property_nodes += node.property ? 1 : 0;
  s.color_nodes += node.color ? 1 : 0;
  if (node.type_counts.size() > s.type_counts.size()) s.type_counts.resize(node.type_counts.size(), 0);
  for (size_t t = 0; t < node.type_counts.size(); ++t) s.type_counts[t] += node.type_counts[t];
  s.voxels.insert(s.voxels.end(), node.voxels.begin(), node.voxels.end());
  s.occupancy.insert(s.occupancy.end(), node.occupancy.begin(), node.occupancy.end());
  if (node.property) s.histograms.push_back(node.property_histogram);
  s.entries.push_back(e);
  return {};
}

namespace {

Status check_summary(const std::string& name, const StoreSummary& sum) {
  if (sum.flags & ~kKnownFlags) return make_error(Errc::internal, "{}: unknown header flags {:#x}", name, sum.flags);
  if ((sum.flags & kFlagCell) && !sum.cell) return make_error(Errc::internal, "{}: flag kFlagCell without a cell", name);
  if (sum.cell && !sum.cell->finite())
    return make_error(Errc::internal, "{}: cell with a non-finite value or one beyond {}: {}", name,
                      SimulationCell::kMaxMagnitude, describe(*sum.cell));
  if (sum.flags & kFlagProperty) {
    if (sum.property_name.empty() || sum.property_name.size() >= kPropertyNameBytes ||
        sum.property_name.find('\0') != std::string::npos)
      return make_error(Errc::internal, "{}: property name '{}' is not 1..{} bytes without NUL", name, sum.property_name,
                        kPropertyNameBytes - 1);
    if (!std::isfinite(sum.property_min) || !std::isfinite(sum.property_max) || sum.property_min > sum.property_max)
      return make_error(Errc::internal, "{}: property range [{}, {}] invalid", name, sum.property_min, sum.property_max);
  }
  if (sum.node_size_max < 1 || sum.node_size_max > kMaxNodeParticles)
    return make_error(Errc::internal, "{}: node_size_max {} outside [1, {}]", name, sum.node_size_max, kMaxNodeParticles);
  if (sum.meshlet_size_max < 1 || sum.meshlet_size_max > kMaxMeshletParticles)
    return make_error(Errc::internal, "{}: meshlet_size_max {} outside [1, {}]", name, sum.meshlet_size_max,
                      kMaxMeshletParticles);
  if (sum.types.size() > kMaxTypes) return make_error(Errc::internal, "{}: {} types (max {})", name, sum.types.size(), kMaxTypes);
  for (size_t t = 0; t < sum.types.size(); ++t) {
    const TypeEntry& te = sum.types[t];
    if (!std::isfinite(te.radius) || te.radius < 0)
      return make_error(Errc::internal, "{}: type {} radius {} is not finite and non-negative", name, t, te.radius);
    if (std::memchr(te.name, 0, sizeof(te.name)) == nullptr)
      return make_error(Errc::internal, "{}: type {} name is not NUL-terminated", name, t);
  }
  if (!finite3(sum.bounds_min) || !finite3(sum.bounds_max) || !finite3(sum.density_min) || !finite3(sum.density_max))
    return make_error(Errc::internal, "{}: non-finite bounds", name);
  for (int a = 0; a < 3; ++a) {
    if (sum.bounds_min[a] > sum.bounds_max[a]) return make_error(Errc::internal, "{}: bounds_min > bounds_max on axis {}", name, a);
    if (sum.density_min[a] > sum.density_max[a])
      return make_error(Errc::internal, "{}: density_min > density_max on axis {}", name, a);
  }
  if (!std::isfinite(sum.radius_min) || !std::isfinite(sum.radius_max) || sum.radius_min < 0 || sum.radius_min > sum.radius_max)
    return make_error(Errc::internal, "{}: radius range [{}, {}] invalid", name, sum.radius_min, sum.radius_max);
  if (!std::isfinite(sum.max_quantization_error) || sum.max_quantization_error < 0 ||
      !std::isfinite(sum.max_error_over_half_step) || sum.max_error_over_half_step < 0)
    return make_error(Errc::internal, "{}: quantization error summary is not finite and non-negative", name);
  const uint64_t product = uint64_t(sum.density_dims[0]) * sum.density_dims[1] * sum.density_dims[2];
  const bool none = sum.density_dims[0] == 0 && sum.density_dims[1] == 0 && sum.density_dims[2] == 0;
  if (!none && product == 0)
    return make_error(Errc::internal, "{}: density dims {}x{}x{} mix zero and non-zero", name, sum.density_dims[0],
                      sum.density_dims[1], sum.density_dims[2]);
  if (product > kMaxDensityVoxels)
    return make_error(Errc::internal, "{}: density grid of {} voxels exceeds 2^28", name, product);
  if (sum.density_counts.size() != product)
    return make_error(Errc::internal, "{}: density has {} counts, dims give {}", name, sum.density_counts.size(), product);
  return {};
}

}  // namespace

Status StoreWriter::finish(const StoreSummary& sum) {
  Impl& s = *impl_;
  const std::string name = s.name();
  if (s.finished) return make_error(Errc::internal, "{}: finish called twice", name);
  if (s.failed) return make_error(Errc::internal, "{}: finish after a failed write", name);
  MDS_TRY(check_summary(name, sum));
  const bool radius = (sum.flags & kFlagPerParticleRadius) != 0;
  const bool property = (sum.flags & kFlagProperty) != 0;
  const bool color = (sum.flags & kFlagColor) != 0;
  if (s.max_node_particles > sum.node_size_max)
    return make_error(Errc::internal, "{}: a node has {} particles, node_size_max is {}", name, s.max_node_particles,
                      sum.node_size_max);
  if (s.max_meshlet_size > sum.meshlet_size_max)
    return make_error(Errc::internal, "{}: a meshlet has {} particles, meshlet_size_max is {}", name, s.max_meshlet_size,
                      sum.meshlet_size_max);
  if (s.type_counts.size() > sum.types.size())
    return make_error(Errc::internal, "{}: nodes use type index {}, but the type table has {} entries", name,
                      s.type_counts.size() - 1, sum.types.size());
  if (s.radius_nodes != (radius ? s.entries.size() : 0))
    return make_error(Errc::internal, "{}: {} of {} nodes carry per-particle radii, but the per-particle-radius flag is {}", name,
                      s.radius_nodes, s.entries.size(), radius ? "set" : "clear");
  if (s.property_nodes != (property ? s.entries.size() : 0))
    return make_error(Errc::internal, "{}: {} of {} nodes carry a property, but the property flag is {}", name,
                      s.property_nodes, s.entries.size(), property ? "set" : "clear");
  if (s.color_nodes != (color ? s.entries.size() : 0))
    return make_error(Errc::internal, "{}: {} of {} nodes carry colours, but the colour flag is {}", name, s.color_nodes,
                      s.entries.size(), color ? "set" : "clear");
  for (size_t i = 0; i < s.entries.size(); ++i) {
    const NodeEntry& e = s.entries[i];
    if (e.payload_raw_bytes < node_payload_fixed_bytes(e.particle_count, e.meshlet_count, sum.flags) ||
        e.payload_raw_bytes > node_payload_max_bytes(e.particle_count, e.meshlet_count, sum.flags))
      return make_error(Errc::internal, "{}: node {}: decoded payload size {} impossible for its counts", name, i,
                        e.payload_raw_bytes);
    if (std::all_of(s.occupancy.begin() + ptrdiff_t(i * kOccupancyBytes),
                    s.occupancy.begin() + ptrdiff_t((i + 1) * kOccupancyBytes), [](uint8_t b) { return b == 0; }))
      return make_error(Errc::internal, "{}: node {}: empty occupancy record", name, i);
  }
  // The payloads are complete: their blocks go to disk and their metadata into the journal
  // (File::sync, on a third thread) while the sections below are checked and encoded, so that
  // the fsync of commit() only has the sections and the header left. On the 2-core VM's ext4
  // that sync took 45 ms of a 10M-particle conversion when it all waited for commit().
  MDS_TRY(s.writer->flush());
  // Both helper threads are joined on every return path (std::jthread).
  std::optional<Status> early_sync;
  std::jthread sync_thread([&] { early_sync.emplace(s.out.file().sync()); });
  // The voxel section (the largest one to compress) is encoded on a second thread while this
  // one checks the density volume and encodes it.
  std::optional<Result<std::vector<uint8_t>>> voxel_result;
  std::jthread voxel_thread([&] { voxel_result.emplace(encode_voxel_section(s.voxels)); });
  // Density volume must equal the sum of all voxel lists.
  const uint64_t product = sum.density_counts.size();
  if (product == 0) {
    if (!s.voxels.empty()) return make_error(Errc::internal, "{}: nodes carry voxel refs but there is no density grid", name);
  } else {
    std::vector<uint32_t> rest = sum.density_counts;
    for (size_t i = 0; i < s.entries.size(); ++i) {
      const NodeEntry& e = s.entries[i];
      if (e.voxel_count == 0) return make_error(Errc::internal, "{}: node {} has no voxel refs", name, i);
      for (uint32_t k = 0; k < e.voxel_count; ++k) {
        const VoxelRef& v = s.voxels[e.voxel_first + k];
        if (v.voxel >= product) return make_error(Errc::internal, "{}: node {}: voxel {} outside the grid", name, i, v.voxel);
        if (rest[v.voxel] < v.count)
          return make_error(Errc::internal, "{}: node {}: voxel {} refs exceed the density count", name, i, v.voxel);
        rest[v.voxel] -= v.count;
      }
    }
    for (uint64_t v = 0; v < product; ++v)
      if (rest[v] != 0)
        return make_error(Errc::internal, "{}: density voxel {} counts {} particles not in any node's voxel refs", name, v,
                          rest[v]);
  }

  FileHeader h;
  std::memset(&h, 0, sizeof(h));
  std::memcpy(h.magic, kMagic, sizeof(kMagic));
  h.version = kFormatVersion;
  h.header_bytes = kHeaderBytes;
  h.flags = (sum.flags & ~uint32_t(kFlagPropertyHistogram)) | (sum.cell ? uint32_t(kFlagCell) : 0u) |
            (property ? uint32_t(kFlagPropertyHistogram) : 0u);
  h.node_size_max = sum.node_size_max;
  h.meshlet_size_max = sum.meshlet_size_max;
  h.node_count = static_cast<uint32_t>(s.entries.size());
  h.particle_count = s.particles;
  h.meshlet_count = s.meshlets;
  h.type_count = static_cast<uint32_t>(sum.types.size());
  for (int a = 0; a < 3; ++a) {
    h.density_dims[a] = sum.density_dims[a];
    h.bounds_min[a] = sum.bounds_min[a];
    h.bounds_max[a] = sum.bounds_max[a];
    h.density_min[a] = sum.density_min[a];
    h.density_max[a] = sum.density_max[a];
  }
  h.radius_min = sum.radius_min;
  h.radius_max = sum.radius_max;
  if (property) {
    std::memcpy(h.property_name, sum.property_name.data(), sum.property_name.size());  // checked < 48: stays terminated
    h.property_min = sum.property_min;
    h.property_max = sum.property_max;
  }
  h.max_quantization_error = sum.max_quantization_error;
  h.max_error_over_half_step = sum.max_error_over_half_step;
  h.payload_bytes = s.payload_bytes;
  h.payload_raw_bytes = s.payload_raw_bytes;

  // Type table: copy, zero unused name bytes (deterministic files), fill counts.
  std::vector<TypeEntry> types(sum.types.size());
  for (size_t t = 0; t < types.size(); ++t) {
    TypeEntry te;
    std::memset(&te, 0, sizeof(te));
    te.input_id = sum.types[t].input_id;
    te.radius = sum.types[t].radius;
    te.particle_count = t < s.type_counts.size() ? s.type_counts[t] : 0;
    // At most sizeof(name) - 1 bytes: the rest stays zero, so the name is always terminated.
    std::memcpy(te.name, sum.types[t].name, strnlen(sum.types[t].name, sizeof(te.name) - 1));
    types[t] = te;
  }

  // Voxel lists and density volume: LZ4 blocks of byte planes (section_codec.h).
  auto density_block = encode_density_section(sum.density_counts);
  voxel_thread.join();
  auto& voxel_block = *voxel_result;
  if (!voxel_block.ok()) return make_error(voxel_block.error().code, "{}: {}", name, voxel_block.error().message);
  if (!density_block.ok()) return make_error(density_block.error().code, "{}: {}", name, density_block.error().message);
  const std::vector<uint8_t>& density = *density_block;
  const uint64_t density_raw = 4 * product;

  auto write_section = [&](SectionId id, const void* data, uint64_t bytes, uint64_t raw) -> Status {
    Section& sec = h.sections[id];
    sec.offset = s.writer->offset();
    sec.bytes = bytes;
    sec.raw_bytes = raw;
    sec.hash = hash_bytes({static_cast<const uint8_t*>(data), static_cast<size_t>(bytes)});
    return s.writer->write(data, static_cast<size_t>(bytes));
  };
  s.failed = true;  // until everything below succeeded
  MDS_TRY(write_section(kSectionTypes, types.data(), types.size() * sizeof(TypeEntry), types.size() * sizeof(TypeEntry)));
  MDS_TRY(write_section(kSectionDirectory, s.entries.data(), s.entries.size() * sizeof(NodeEntry),
                        s.entries.size() * sizeof(NodeEntry)));
  MDS_TRY(write_section(kSectionVoxels, voxel_block->data(), voxel_block->size(), s.voxels.size() * sizeof(VoxelRef)));
  MDS_TRY(write_section(kSectionDensity, density.data(), density.size(), density_raw));
  MDS_TRY(write_section(kSectionOccupancy, s.occupancy.data(), s.occupancy.size(), s.occupancy.size()));
  if (sum.cell) {  // the cell section
    const CellRecord rec = encode_cell(*sum.cell);
    h.cell.offset = s.writer->offset();
    h.cell.bytes = h.cell.raw_bytes = sizeof(rec);
    h.cell.hash = hash_bytes({reinterpret_cast<const uint8_t*>(&rec), sizeof(rec)});
    MDS_TRY(s.writer->write(&rec, sizeof(rec)));
  }
  if (property) {  // the property histograms, last
    const uint64_t bytes = s.histograms.size() * sizeof(PropertyHistogram);
    Section& sec = h.property_histograms;
    sec.offset = s.writer->offset();
    sec.bytes = sec.raw_bytes = bytes;
    sec.hash = hash_bytes({reinterpret_cast<const uint8_t*>(s.histograms.data()), static_cast<size_t>(bytes)});
    MDS_TRY(s.writer->write(s.histograms.data(), static_cast<size_t>(bytes)));
  }
  MDS_TRY(s.writer->flush());
  sync_thread.join();
  if (!early_sync->ok()) return *early_sync;

  h.header_hash = 0;
  h.header_hash = hash_bytes({reinterpret_cast<const uint8_t*>(&h), sizeof(h)});
  MDS_TRY(s.out.file().pwrite_all(&h, sizeof(h), 0));
  MDS_TRY(s.out.commit());
  s.failed = false;
  s.finished = true;
  return {};
}

uint64_t StoreWriter::bytes_written() const { return impl_->writer->offset(); }
uint64_t StoreWriter::node_count() const { return impl_->entries.size(); }

}  // namespace mds::store
