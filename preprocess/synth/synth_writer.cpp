// Writes a planned scene as a LAMMPS text dump: chunks are generated and formatted by worker
// threads and written in order (bounded window of chunks in flight), to a temporary file that
// is renamed when complete. ".gz" output: each chunk is an independent gzip member (RFC 1952
// allows concatenated members; zlib's gzread and gzip -d read them as one stream).
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <system_error>
#include <thread>

#include "synth/synth.h"
#include "synth/synth_scenes.h"

namespace mds::synth {

const char* scene_name(Scene s) {
  switch (s) {
    case Scene::ablation: return "ablation";
    case Scene::porous: return "porous";
    case Scene::gas: return "gas";
    case Scene::shell: return "shell";
  }
  return "?";
}

std::optional<Scene> parse_scene(const std::string& name) {
  for (Scene s : {Scene::ablation, Scene::porous, Scene::gas, Scene::shell}) {
    if (name == scene_name(s)) return s;
  }
  return std::nullopt;
}

std::vector<std::string> scene_names() { return {"ablation", "porous", "gas", "shell"}; }

Result<SceneSummary> describe_scene(const SynthOptions& options) {
  MDS_ASSIGN_OR_RETURN(Plan plan, plan_scene(options));
  return plan.summary;
}

namespace {

// Coordinates are written with 4 decimals (fixed point, rounded half away from zero).
inline char* put_fixed4(char* p, double v) {
  int64_t q = std::llround(v * 1e4);
  if (q < 0) {
    *p++ = '-';
    q = -q;
  }
  p = std::to_chars(p, p + 24, q / 10000).ptr;
  const int f = static_cast<int>(q % 10000);
  p[0] = '.';
  p[1] = static_cast<char>('0' + f / 1000);
  p[2] = static_cast<char>('0' + f / 100 % 10);
  p[3] = static_cast<char>('0' + f / 10 % 10);
  p[4] = static_cast<char>('0' + f % 10);
  return p + 5;
}

inline double wrap(double v, double lo, double len) {
  if (v >= lo && v < lo + len) return v;
  double w = std::fmod(v - lo, len);
  if (w < 0) w += len;
  if (w >= len) w = 0;  // fmod rounding at the top edge
  return lo + w;
}

std::string frame_header(const Plan& plan, int frame, uint64_t particles) {
  const SceneSummary& s = plan.summary;
  const double zhi = s.box_hi[2] + s.box_growth_z * frame;
  return fmt::format(
      "ITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS pp pp pp\n{:.6f} {:.6f}\n{:.6f} {:.6f}\n{:.6f} {:.6f}\n"
      "ITEM: ATOMS id type x y z\n",
      static_cast<int64_t>(frame) * 1000, particles, s.box_lo[0], s.box_hi[0], s.box_lo[1], s.box_hi[1], s.box_lo[2], zhi);
}

// A byte buffer whose growth does not zero-fill: large buffers come from mmap, so only the
// bytes actually written become resident (the capacity is a generous per-line bound).
class Bytes {
 public:
  char* data() { return p_.get(); }
  const char* data() const { return p_.get(); }
  size_t size() const { return size_; }
  void reserve_uninit(size_t n) {
    if (n > cap_) {
      p_.reset(new char[n]);
      cap_ = n;
    }
    size_ = 0;
  }
  void set_size(size_t n) { size_ = n; }
  size_t capacity() const { return cap_; }

 private:
  std::unique_ptr<char[]> p_;
  size_t cap_ = 0, size_ = 0;
};

Status gzip_member(const char* data, size_t size, int level, Bytes& out) {
  z_stream zs{};
  if (deflateInit2(&zs, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    return make_error(Errc::internal, "synth: deflateInit2 failed");
  }
  out.reserve_uninit(deflateBound(&zs, static_cast<uLong>(size)) + 64);
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data));
  zs.avail_in = static_cast<uInt>(size);
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.capacity());
  const int rc = deflate(&zs, Z_FINISH);
  const size_t produced = zs.total_out;
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) return make_error(Errc::internal, "synth: deflate failed ({})", rc);
  out.set_size(produced);
  return Status::success();
}

// RAII temporary output file: removed unless committed (renamed onto the target).
class TempFile {
 public:
  explicit TempFile(std::filesystem::path target) : target_(std::move(target)) {
    // An existing non-regular target (/dev/null, a FIFO, a terminal) is written directly:
    // renaming a temporary file onto it would replace the device node.
    std::error_code ec;
    const auto st = std::filesystem::status(target_, ec);
    direct_ = !ec && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st);
    tmp_ = target_;
    if (!direct_) tmp_ += fmt::format(".tmp-{}", static_cast<long>(::getpid()));
  }
  ~TempFile() {
    if (f_) std::fclose(f_);
    if (!committed_ && !direct_) {
      std::error_code ec;
      std::filesystem::remove(tmp_, ec);
    }
  }
  Status open() {
    f_ = std::fopen(tmp_.c_str(), "wb");
    if (!f_) return make_error(Errc::io, "{}: cannot create: {}", tmp_.string(), std::strerror(errno));
    std::setvbuf(f_, nullptr, _IOFBF, 1 << 20);
    return Status::success();
  }
  Status write(const char* data, size_t n) {
    if (n && std::fwrite(data, 1, n, f_) != n) {
      return make_error(Errc::io, "{}: write failed at byte {}: {}", tmp_.string(), offset_, std::strerror(errno));
    }
    offset_ += n;
    return Status::success();
  }
  Status commit() {
    const int rc = std::fclose(f_);
    f_ = nullptr;
    if (rc != 0) return make_error(Errc::io, "{}: close failed: {}", tmp_.string(), std::strerror(errno));
    if (direct_) {
      committed_ = true;
      return Status::success();
    }
    std::error_code ec;
    std::filesystem::rename(tmp_, target_, ec);
    if (ec) return make_error(Errc::io, "{}: cannot rename to {}: {}", tmp_.string(), target_.string(), ec.message());
    committed_ = true;
    return Status::success();
  }

 private:
  std::filesystem::path target_, tmp_;
  std::FILE* f_ = nullptr;
  uint64_t offset_ = 0;
  bool committed_ = false;
  bool direct_ = false;
};

struct Slot {
  Bytes data;
  bool ready = false;
};

}  // namespace

Result<SceneSummary> write_scene(const SynthOptions& options, const std::filesystem::path& path) {
  MDS_ASSIGN_OR_RETURN(Plan plan, plan_scene(options));
  const bool gz = path.extension() == ".gz";
  const int level = std::clamp(options.gzip_level, 1, 9);
  const SceneSummary& sum = plan.summary;
  const int natural = sum.natural_types, types = sum.types;
  double period[3];
  for (int a = 0; a < 3; ++a) period[a] = sum.box_hi[a] - sum.box_lo[a];

  TempFile out(path);
  if (Status st = out.open(); !st.ok()) return st.error();

  const int threads = resolve_threads(options.threads);
  const uint64_t per_frame = plan.chunks.size();
  const uint64_t tasks = per_frame * static_cast<uint64_t>(options.frames);
  const uint64_t window = static_cast<uint64_t>(2 * threads + 2);
  std::vector<Slot> slots(window);
  std::mutex mu;
  std::condition_variable cv;
  uint64_t next_task = 0, written = 0;
  bool abort = false;
  Status worker_error;

  auto worker = [&] {
    Buffer buf;
    Bytes text, packed;
    for (;;) {
      uint64_t t;
      {
        std::unique_lock lock(mu);
        cv.wait(lock, [&] { return abort || next_task >= tasks || next_task < written + window; });
        if (abort || next_task >= tasks) return;
        t = next_task++;
      }
      const int frame = static_cast<int>(t / per_frame);
      const Chunk& c = plan.chunks[t % per_frame];
      Status st;
      try {
        buf.clear();
        c.generate(frame, buf);
        if (buf.size() != c.count) {
          st = make_error(Errc::internal, "synth: chunk at particle {} produced {} particles instead of {}", c.first, buf.size(), c.count);
        } else {
          text.reserve_uninit(c.count * 96 + 64);
          char* p = text.data();
          for (size_t i = 0; i < buf.size(); ++i) {
            const uint64_t index = c.first + i;
            double x = buf.x[i], y = buf.y[i], z = buf.z[i];
            if (plan.periodic[0]) x = wrap(x, sum.box_lo[0], period[0]);
            if (plan.periodic[1]) y = wrap(y, sum.box_lo[1], period[1]);
            if (plan.periodic[2]) z = wrap(z, sum.box_lo[2], period[2]);
            const int type = map_type(buf.cls[i], natural, types, hash64(options.seed, index, 8));
            p = std::to_chars(p, p + 24, index + 1).ptr;
            *p++ = ' ';
            p = std::to_chars(p, p + 8, type).ptr;
            *p++ = ' ';
            p = put_fixed4(p, x);
            *p++ = ' ';
            p = put_fixed4(p, y);
            *p++ = ' ';
            p = put_fixed4(p, z);
            *p++ = '\n';
          }
          text.set_size(static_cast<size_t>(p - text.data()));
          if (gz) {
            st = gzip_member(text.data(), text.size(), level, packed);
            std::swap(text, packed);
          }
        }
      } catch (const std::exception& e) {
        st = make_error(Errc::internal, "synth: {}", e.what());
      }
      std::unique_lock lock(mu);
      if (!st.ok()) {
        if (worker_error.ok()) worker_error = st;
        abort = true;
        cv.notify_all();
        return;
      }
      Slot& slot = slots[t % window];
      std::swap(slot.data, text);
      slot.ready = true;
      cv.notify_all();
    }
  };

  std::vector<std::thread> pool;
  for (int i = 0; i < threads; ++i) pool.emplace_back(worker);
  Status result;
  Bytes data, header_gz;
  for (uint64_t t = 0; t < tasks && result.ok(); ++t) {
    if (t % per_frame == 0) {
      const std::string h = frame_header(plan, static_cast<int>(t / per_frame), sum.particles);
      if (gz) {
        result = gzip_member(h.data(), h.size(), level, header_gz);
        if (result.ok()) result = out.write(header_gz.data(), header_gz.size());
      } else {
        result = out.write(h.data(), h.size());
      }
      if (!result.ok()) break;
    }
    {
      std::unique_lock lock(mu);
      Slot& slot = slots[t % window];
      cv.wait(lock, [&] { return abort || slot.ready; });
      if (!slot.ready) break;
      std::swap(data, slot.data);
      slot.ready = false;
    }
    result = out.write(data.data(), data.size());
    {
      std::lock_guard lock(mu);
      written = t + 1;
    }
    cv.notify_all();
  }
  {
    std::lock_guard lock(mu);
    if (!result.ok()) abort = true;
  }
  cv.notify_all();
  for (auto& th : pool) th.join();
  if (!worker_error.ok()) return worker_error.error();
  if (!result.ok()) return result.error();
  MDS_TRY(out.commit());
  return plan.summary;
}

}  // namespace mds::synth
