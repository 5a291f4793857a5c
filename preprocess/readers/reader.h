// Streaming particle readers: one frame of a simulation dump, read in batches so that
// memory stays bounded whatever the input size.
//
// A reader is opened on one file (or, for raw/H5MD, one dataset) and one frame, then
// read() is called until it returns 0. Every error message names the file and the place
// (line number for text, dataset path for HDF5, byte offset for binary formats).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/cell.h"
#include "core/result.h"

namespace mds {

// std::allocator whose element construction without arguments is default-initialization: for
// the arithmetic types of a batch, resize() leaves the new elements unwritten instead of zeroing
// them (readers overwrite every element they add; the zeroing was ~2 % of a 1M-particle text
// conversion's CPU time in a profile).
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() noexcept = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    if constexpr (sizeof...(Args) == 0) ::new (static_cast<void*>(p)) U;
    else ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <class T>
using BatchVector = std::vector<T, DefaultInitAllocator<T>>;

// A batch of particles in structure-of-arrays form. The caller owns it and reuses it
// across read() calls; readers clear() then append (resize() and write every element, or
// push_back).
struct ParticleBatch {
  BatchVector<double> x, y, z;     // positions in the simulation's length unit (wrapped or unwrapped as the file has them)
  BatchVector<int32_t> type;       // type id as the input names it (LAMMPS type, species index, MMPLD list index)
  BatchVector<float> radius;       // per-particle radius; empty when the input has none
  BatchVector<int64_t> id;         // particle id when the input has one (LAMMPS `id`), else empty
  BatchVector<float> property;     // the scalar ReaderOptions::property names (finite); empty without one
  BatchVector<uint32_t> color;     // with ReaderOptions::color: RGBA8 (pack_rgba8), else empty

  size_t size() const { return x.size(); }
  void clear() {
    x.clear(); y.clear(); z.clear(); type.clear(); radius.clear(); id.clear(); property.clear(); color.clear();
  }
  void reserve(size_t n) { x.reserve(n); y.reserve(n); z.reserve(n); type.reserve(n); }
};

// A per-particle colour as the store keeps it (store kFlagColor): R in bits 0-7, then G, B, A.
inline uint32_t pack_rgba8(uint32_t r, uint32_t g, uint32_t b, uint32_t a = 255) {
  return (r & 0xffu) | (g & 0xffu) << 8 | (b & 0xffu) << 16 | (a & 0xffu) << 24;
}
// A colour channel in [0, 1] (clamped; finite) to 8 bits, rounded to nearest.
inline uint32_t unit_to_u8(double v) {
  return uint32_t(std::lround((v < 0 ? 0 : v > 1 ? 1 : v) * 255.0));
}

enum class InputFormat { automatic, lammps, xyz, h5md, mmpld, raw };

const char* input_format_name(InputFormat f);
std::optional<InputFormat> parse_input_format(const std::string& name);

// Where a frame of a text input (LAMMPS, XYZ) starts, as list_frames() found it. With it in
// ReaderOptions::start, open_reader() goes to the frame directly instead of skipping the frames
// before it: a plain file seeks, a compressed one is decompressed again up to the offset.
struct FrameMark {
  int64_t index = -1;   // the frame's index (0 = first); -1: no mark
  uint64_t offset = 0;  // uncompressed byte offset of the frame's first header line
  uint64_t line = 0;    // lines of the file before that one
};

class TextSource;  // readers/text_source.h

// Hands a text input's open source from one frame's reader to the next (convert_series): a text
// reader opened with a relay that holds a source of the same file takes it (and seeks forward in
// it), and gives it back when destroyed after reading without an error. So a compressed
// trajectory is decompressed once for all its frames, not again from the start for each.
// Not thread-safe: one reader at a time.
struct TextSourceRelay {
  TextSourceRelay();
  ~TextSourceRelay();
  std::unique_ptr<TextSource> source;
};

struct ReaderOptions {
  InputFormat format = InputFormat::automatic;
  // Frame to read: >= 0 is the index (0 = first), -1 = the last frame.
  int64_t frame = 0;
  // Text formats: when start.index == frame, the frame starts at start (list_frames); other
  // formats and other frames ignore it. A mark that does not point at a frame header is an error.
  FrameMark start;
  // Text formats: where to take the open source from and give it back to (nullptr: none).
  std::shared_ptr<TextSourceRelay> relay;
  std::string h5md_group;          // H5MD: /particles/<group>; empty = the only one (error if several)
  // A per-particle scalar to keep (colour coding): a LAMMPS column (`c_pe`, `vx`, `q`), an
  // extended-XYZ R:1 property, the H5MD dataset /particles/<group>/<name>/value, or MMPLD's
  // `intensity` (FLOAT_I colours). Empty = none. A reader that cannot find it fails at open,
  // naming the file and what it has.
  std::string property;
  // Keep per-particle colours (`convert --color`): MMPLD's colours (per particle, or a list's
  // global colour; not the FLOAT_I / DOUBLE_I intensities) and extended XYZ's `color:R:3`
  // (OVITO's "Color", channels in [0, 1]). A reader whose input has none fails at open.
  bool color = false;
  // Wrap the positions into the frame's periodic cell (`convert --wrap`; readers/wrap_reader.h).
  // An input without a cell, or with one that is flat or periodic along no vector, fails at open.
  bool wrap = false;
  // Periodic images along the cell vectors a, b, c (`convert --replicate`; readers/replicate_reader.h),
  // after wrap; {1, 1, 1}: none. An input without a cell fails at open.
  std::array<uint32_t, 3> replicate = {1, 1, 1};
};

// What is known about the frame after open (before reading particles).
struct FrameInfo {
  uint64_t particle_count = 0;     // exact count the frame declares
  uint64_t frame_count = 0;        // frames of the input where the format declares them (H5MD, MMPLD;
                                   // raw: 1); 0 for text formats, whose frames list_frames() counts
  int64_t timestep = 0;            // simulation step when the file has one
  bool has_box = false;            // simulation box (orthogonal bounds or triclinic bounding box)
  double box_lo[3] = {0, 0, 0};    //   = cell.bounds() where has_box
  double box_hi[3] = {0, 0, 0};
  SimulationCell cell;             // with has_box: the cell itself (origin, edge vectors, periodicity)
  bool has_radius = false;         // read() fills ParticleBatch::radius
  bool has_property = false;       // read() fills ParticleBatch::property (ReaderOptions::property)
  bool has_color = false;          // read() fills ParticleBatch::color (ReaderOptions::color)
  // Names of type ids, when the input has names (XYZ/H5MD species strings). Readers may
  // add names while streaming (XYZ); the final map is type_names() after the last read().
  std::map<int32_t, std::string> type_names;
  // Per-type radius the input defines (MMPLD list radius), keyed by type id.
  std::map<int32_t, float> type_radius;
};

class ParticleReader {
 public:
  virtual ~ParticleReader() = default;
  ParticleReader() = default;
  ParticleReader(const ParticleReader&) = delete;
  ParticleReader& operator=(const ParticleReader&) = delete;

  virtual const FrameInfo& info() const = 0;
  // Clears `out` and appends up to `max_particles` particles of the frame.
  // Returns the number appended; 0 once the frame is exhausted. Validates as it goes:
  // NaN/Inf coordinates, short frames and trailing garbage are errors.
  virtual Result<size_t> read(ParticleBatch& out, size_t max_particles) = 0;
  // Names known so far (complete after the last read()).
  virtual std::map<int32_t, std::string> type_names() const { return info().type_names; }
};

// Detects the format from the file's content (magic bytes, first lines), falling back
// to the extension only where content is ambiguous. Raw float32 has no signature and
// must be asked for explicitly with InputFormat::raw.
Result<InputFormat> detect_format(const std::filesystem::path& path);

// Opens `path` positioned at the requested frame.
Result<std::unique_ptr<ParticleReader>> open_reader(const std::filesystem::path& path,
                                                    const ReaderOptions& options);

// One frame of an input, as list_frames() finds it.
struct FrameEntry {
  int64_t index = 0;
  int64_t timestep = 0;         // the simulation step (the frame index where the format has none)
  uint64_t particle_count = 0;  // as the frame declares it (before ReaderOptions::replicate)
  FrameMark mark;               // text formats: where the frame starts (ReaderOptions::start)
};

// Every frame of `path`, in file order (options.frame and options.start are ignored). Text
// formats read each frame's header once and count the atom lines without parsing them (a
// malformed header or a short frame is an error naming its line); H5MD and MMPLD read their
// frame tables (one open per frame for H5MD's steps); raw has one frame.
Result<std::vector<FrameEntry>> list_frames(const std::filesystem::path& path, const ReaderOptions& options);

}  // namespace mds
