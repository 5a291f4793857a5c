// Streaming particle readers: one frame of a simulation dump, read in batches so that
// memory stays bounded whatever the input size.
//
// A reader is opened on one file (or, for raw/H5MD, one dataset) and one frame, then
// read() is called until it returns 0. Every error message names the file and the place
// (line number for text, dataset path for HDF5, byte offset for binary formats).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

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

  size_t size() const { return x.size(); }
  void clear() { x.clear(); y.clear(); z.clear(); type.clear(); radius.clear(); id.clear(); property.clear(); }
  void reserve(size_t n) { x.reserve(n); y.reserve(n); z.reserve(n); type.reserve(n); }
};

enum class InputFormat { automatic, lammps, xyz, h5md, mmpld, raw };

const char* input_format_name(InputFormat f);
std::optional<InputFormat> parse_input_format(const std::string& name);

struct ReaderOptions {
  InputFormat format = InputFormat::automatic;
  // Frame to read: >= 0 is the index (0 = first), -1 = the last frame.
  int64_t frame = 0;
  std::string h5md_group;          // H5MD: /particles/<group>; empty = the only one (error if several)
  // A per-particle scalar to keep (colour coding): a LAMMPS column (`c_pe`, `vx`, `q`), an
  // extended-XYZ R:1 property, the H5MD dataset /particles/<group>/<name>/value, or MMPLD's
  // `intensity` (FLOAT_I colours). Empty = none. A reader that cannot find it fails at open,
  // naming the file and what it has.
  std::string property;
};

// What is known about the frame after open (before reading particles).
struct FrameInfo {
  uint64_t particle_count = 0;     // exact count the frame declares
  int64_t timestep = 0;            // simulation step when the file has one
  bool has_box = false;            // simulation box (orthogonal bounds or triclinic bounding box)
  double box_lo[3] = {0, 0, 0};
  double box_hi[3] = {0, 0, 0};
  bool has_radius = false;         // read() fills ParticleBatch::radius
  bool has_property = false;       // read() fills ParticleBatch::property (ReaderOptions::property)
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

}  // namespace mds
