// H5MD reader (see h5md_reader.h). HDF5 C API only; HDF5's automatic error printing is
// switched off and every failure becomes an mds::Error naming the file and dataset.
#include "h5md/h5md_reader.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <hdf5.h>


namespace mds {
namespace {

constexpr uint64_t kChunkParticles = uint64_t{1} << 20;  // bounded buffer: 24 MiB of doubles

// RAII for an HDF5 identifier.
class Hid {
 public:
  Hid() = default;
  Hid(hid_t id, herr_t (*closer)(hid_t)) : id_(id), closer_(closer) {}
  Hid(Hid&& o) noexcept : id_(o.id_), closer_(o.closer_) { o.id_ = -1; }
  Hid& operator=(Hid&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_;
      closer_ = o.closer_;
      o.id_ = -1;
    }
    return *this;
  }
  Hid(const Hid&) = delete;
  Hid& operator=(const Hid&) = delete;
  ~Hid() { reset(); }
  void reset() {
    if (id_ >= 0 && closer_ != nullptr) closer_(id_);
    id_ = -1;
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = -1;
  herr_t (*closer_)(hid_t) = nullptr;
};

void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

Result<Hid> open_hdf5(const std::filesystem::path& path) {
  silence_hdf5();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return make_error(Errc::io, "{}: cannot open: no such file", path.string());
  }
  if (H5Fis_hdf5(path.c_str()) <= 0) return make_error(Errc::format, "{}: not an HDF5 file", path.string());
  Hid f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid()) return make_error(Errc::io, "{}: HDF5 cannot open the file", path.string());
  return f;
}

// True when every link along `path` (absolute, '/'-separated) exists.
bool link_exists(hid_t loc, const std::string& path) {
  size_t pos = 1;
  while (pos <= path.size()) {
    size_t slash = path.find('/', pos);
    std::string prefix = path.substr(0, slash);
    if (H5Lexists(loc, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (slash == std::string::npos) break;
    pos = slash + 1;
  }
  return true;
}

enum class Kind { missing, group, dataset, other };

Kind kind_of(hid_t loc, const std::string& path) {
  if (!link_exists(loc, path)) return Kind::missing;
  Hid o(H5Oopen(loc, path.c_str(), H5P_DEFAULT), H5Oclose);
  if (!o.valid()) return Kind::missing;
  switch (H5Iget_type(o.get())) {
    case H5I_GROUP: return Kind::group;
    case H5I_DATASET: return Kind::dataset;
    default: return Kind::other;
  }
}

std::string shape_str(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return "[] (scalar)";
  std::string s;
  for (hsize_t d : dims) s += fmt::format("[{}]", static_cast<unsigned long long>(d));
  return s;
}

struct Dataset {
  Hid dset;
  Hid space;
  std::vector<hsize_t> dims;
  H5T_class_t type_class = H5T_NO_CLASS;
  size_t type_size = 0;
};

Result<Dataset> open_dataset(hid_t file, const std::string& file_name, const std::string& path) {
  Dataset d;
  // A 64 MiB chunk cache (default 1 MiB) so that a batch of compressed chunks is
  // decompressed once, whatever the chunk shape.
  Hid dapl(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
  if (dapl.valid()) H5Pset_chunk_cache(dapl.get(), 12421, size_t{64} << 20, 1.0);
  d.dset = Hid(H5Dopen2(file, path.c_str(), dapl.valid() ? dapl.get() : H5P_DEFAULT), H5Dclose);
  if (!d.dset.valid()) return make_error(Errc::format, "{}: cannot open dataset {}", file_name, path);
  d.space = Hid(H5Dget_space(d.dset.get()), H5Sclose);
  if (!d.space.valid()) return make_error(Errc::format, "{}: dataset {}: cannot read its dataspace", file_name, path);
  const int rank = H5Sget_simple_extent_ndims(d.space.get());
  if (rank < 0) return make_error(Errc::format, "{}: dataset {}: not a simple dataspace", file_name, path);
  d.dims.resize(static_cast<size_t>(rank));
  if (rank > 0) H5Sget_simple_extent_dims(d.space.get(), d.dims.data(), nullptr);
  Hid type(H5Dget_type(d.dset.get()), H5Tclose);
  d.type_class = type.valid() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
  d.type_size = type.valid() ? H5Tget_size(type.get()) : 0;
  // Compact and contiguous data must be stored whole: HDF5 1.10 reads a compact dataset whose
  // shape claims more than its stored bytes from a null buffer (a crash, found by fuzz_h5md on
  // 2026-11-27: a frame count changed to 4.5e11 over a 0-byte compact layout). Chunked data may
  // leave chunks unallocated (they read as the fill value), so it is not checked.
  Hid dcpl(H5Dget_create_plist(d.dset.get()), H5Pclose);
  const H5D_layout_t layout = dcpl.valid() ? H5Pget_layout(dcpl.get()) : H5D_LAYOUT_ERROR;
  if (layout == H5D_COMPACT || layout == H5D_CONTIGUOUS) {
    hsize_t need = d.type_size;
    bool overflow = false;
    for (const hsize_t n : d.dims) overflow = overflow || __builtin_mul_overflow(need, n, &need);
    const hsize_t stored = H5Dget_storage_size(d.dset.get());
    if (overflow || stored < need)
      return make_error(Errc::format, "{}: dataset {}: shape {} of {}-byte values needs {} bytes, the file stores {}",
                        file_name, path, shape_str(d.dims), d.type_size,
                        overflow ? std::string("more than 2^64") : std::to_string(need), stored);
  }
  return d;
}

// Reads `count` elements starting at `start` (one entry per dimension) as `mem_type`.
Status read_slab(const Dataset& d, const std::vector<hsize_t>& start, const std::vector<hsize_t>& count,
                 hid_t mem_type, void* dst, const std::string& file_name, const std::string& path) {
  hsize_t total = 1;
  for (hsize_t c : count) total *= c;
  if (total == 0) return Status::success();
  if (!d.dims.empty() &&
      H5Sselect_hyperslab(d.space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0) {
    return make_error(Errc::format, "{}: dataset {}: cannot select {} elements", file_name, path, total);
  }
  if (d.dims.empty()) H5Sselect_all(d.space.get());
  // Memory space shaped like the selection: HDF5 takes its fast path only when shapes match.
  Hid mem = d.dims.empty() ? Hid(H5Screate_simple(1, &total, nullptr), H5Sclose)
                           : Hid(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr), H5Sclose);
  if (H5Dread(d.dset.get(), mem_type, mem.get(), d.space.get(), H5P_DEFAULT, dst) < 0) {
    return make_error(Errc::io, "{}: dataset {}: HDF5 read failed (start {}, count {})", file_name, path,
                      shape_str(start), shape_str(count));
  }
  return Status::success();
}

// Box edges/offset: element at `base` (group with `value` = time-dependent, or dataset).
// Returns the values (3 for a vector, 9 for a matrix) of frame `frame`, or empty if absent.
Result<std::vector<double>> read_box_element(hid_t file, const std::string& file_name, const std::string& base,
                                             uint64_t frame, bool allow_matrix) {
  const Kind k = kind_of(file, base);
  if (k == Kind::missing) return std::vector<double>{};
  const bool td = (k == Kind::group);
  const std::string path = td ? base + "/value" : base;
  if (td && kind_of(file, path) != Kind::dataset) {
    return make_error(Errc::format, "{}: {} is a time-dependent group without a value dataset", file_name, base);
  }
  MDS_ASSIGN_OR_RETURN(Dataset d, open_dataset(file, file_name, path));
  std::vector<hsize_t> dims = d.dims;
  const std::string expected = allow_matrix ? (td ? "[frames][3] or [frames][3][3]" : "[3] or [3][3]")
                                            : (td ? "[frames][3]" : "[3]");
  const size_t lead = td ? 1 : 0;
  const bool vec = dims.size() == lead + 1 && dims[lead] == 3;
  const bool mat = allow_matrix && dims.size() == lead + 2 && dims[lead] == 3 && dims[lead + 1] == 3;
  if ((!vec && !mat) || d.type_class == H5T_STRING || (d.type_class != H5T_FLOAT && d.type_class != H5T_INTEGER)) {
    return make_error(Errc::format, "{}: dataset {} has shape {}, expected {} numbers", file_name, path,
                      shape_str(dims), expected);
  }
  if (td && frame >= dims[0]) {
    return make_error(Errc::format, "{}: dataset {} has {} frames; frame {} requested", file_name, path,
                      static_cast<unsigned long long>(dims[0]), frame);
  }
  std::vector<double> v(vec ? 3 : 9);
  std::vector<hsize_t> start(dims.size(), 0), count(dims.begin(), dims.end());
  if (td) {
    start[0] = frame;
    count[0] = 1;
  }
  MDS_TRY(read_slab(d, start, count, H5T_NATIVE_DOUBLE, v.data(), file_name, path));
  for (double x : v) {
    if (!std::isfinite(x)) return make_error(Errc::range, "{}: dataset {}: non-finite box value", file_name, path);
  }
  return v;
}

// The box group's `boundary` attribute (H5MD 1.1: "periodic" or "none" per dimension). Absent:
// not periodic. Fixed-length strings are read. Variable-length ones (MDAnalysis writes those) are
// not: HDF5 1.10.8 follows their global-heap references without checking the object index and
// crashes on a corrupted one (found by fuzz_h5md on 2026-12-07), so such a box counts as periodic
// along all three, as the boxes MD codes write are.
Status read_boundary(hid_t file, const std::string& file_name, const std::string& box, bool periodic[3]) {
  for (int d = 0; d < 3; ++d) periodic[d] = false;
  if (H5Aexists_by_name(file, box.c_str(), "boundary", H5P_DEFAULT) <= 0) return Status::success();
  const std::string where = box + "/boundary";
  Hid a(H5Aopen_by_name(file, box.c_str(), "boundary", H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.valid()) return make_error(Errc::io, "{}: HDF5 cannot open attribute {}", file_name, where);
  Hid space(H5Aget_space(a.get()), H5Sclose);
  Hid type(H5Aget_type(a.get()), H5Tclose);
  if (!space.valid() || !type.valid() || H5Tget_class(type.get()) != H5T_STRING)
    return make_error(Errc::format, "{}: attribute {} is not an array of strings", file_name, where);
  if (H5Sget_simple_extent_npoints(space.get()) != 3)
    return make_error(Errc::format, "{}: attribute {} has {} values, expected 3", file_name, where,
                      static_cast<long long>(H5Sget_simple_extent_npoints(space.get())));
  std::string vals[3];
  Hid mem(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
  if (H5Tis_variable_str(type.get()) != 0) {  // not read (above); also when HDF5 cannot tell
    for (int d = 0; d < 3; ++d) periodic[d] = true;
    return Status::success();
  } else {
    const size_t size = H5Tget_size(type.get());
    if (size == 0 || size > 256)
      return make_error(Errc::format, "{}: attribute {} has strings of {} bytes", file_name, where, size);
    H5Tset_size(mem.get(), size);
    H5Tset_strpad(mem.get(), H5T_STR_NULLPAD);  // all `size` bytes, a full-length string without a NUL
    std::vector<char> buf(3 * size);
    if (H5Aread(a.get(), mem.get(), buf.data()) < 0)
      return make_error(Errc::io, "{}: HDF5 cannot read attribute {}", file_name, where);
    for (int d = 0; d < 3; ++d) {
      const char* p = buf.data() + size_t(d) * size;
      vals[d] = std::string(p, std::find(p, p + size, '\0'));
    }
  }
  for (int d = 0; d < 3; ++d) {
    std::string v = vals[d];
    while (!v.empty() && v.back() == ' ') v.pop_back();
    if (v == "periodic") periodic[d] = true;
    else if (v != "none")
      return make_error(Errc::format, "{}: attribute {}: value {} is '{}', expected periodic or none", file_name, where,
                        d, v.substr(0, 40));
  }
  return Status::success();
}

}  // namespace

struct H5mdReader::Handles {
  Hid file;
  Dataset position;
  Dataset species;
  Dataset property;
};

H5mdReader::~H5mdReader() = default;

Result<bool> hdf5_has_h5md_group(const std::filesystem::path& path) {
  MDS_ASSIGN_OR_RETURN(Hid f, open_hdf5(path));
  return kind_of(f.get(), "/h5md") == Kind::group;
}

Result<std::unique_ptr<ParticleReader>> H5mdReader::open(const std::filesystem::path& path,
                                                         const ReaderOptions& options) {
  std::unique_ptr<H5mdReader> r(new H5mdReader());
  r->h_ = std::make_unique<Handles>();
  r->file_name_ = path.string();
  const std::string& fn = r->file_name_;
  MDS_ASSIGN_OR_RETURN(r->h_->file, open_hdf5(path));
  const hid_t file = r->h_->file.get();
  if (kind_of(file, "/h5md") != Kind::group) return make_error(Errc::format, "{}: HDF5 file without /h5md group", fn);
  if (kind_of(file, "/particles") != Kind::group) {
    return make_error(Errc::format, "{}: H5MD file without /particles group", fn);
  }

  // Particle groups that carry positions.
  std::vector<std::string> candidates;
  {
    Hid particles(H5Gopen2(file, "/particles", H5P_DEFAULT), H5Gclose);
    H5G_info_t gi{};
    if (!particles.valid() || H5Gget_info(particles.get(), &gi) < 0) {
      return make_error(Errc::format, "{}: cannot list /particles", fn);
    }
    for (hsize_t i = 0; i < gi.nlinks; ++i) {
      ssize_t len = H5Lget_name_by_idx(particles.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
      if (len <= 0) continue;
      std::string name(static_cast<size_t>(len) + 1, '\0');
      H5Lget_name_by_idx(particles.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(), name.size(), H5P_DEFAULT);
      name.resize(static_cast<size_t>(len));
      const std::string g = "/particles/" + name;
      if (kind_of(file, g) == Kind::group && kind_of(file, g + "/position") != Kind::missing) candidates.push_back(name);
    }
  }
  auto list = [&] {
    std::string s;
    for (const auto& c : candidates) s += (s.empty() ? "" : ", ") + ("/particles/" + c);
    return s;
  };
  std::string chosen;
  if (!options.h5md_group.empty()) {
    std::string want = options.h5md_group;
    if (want.rfind("/particles/", 0) == 0) want = want.substr(11);
    if (std::find(candidates.begin(), candidates.end(), want) == candidates.end()) {
      return make_error(Errc::invalid_argument, "{}: no particle group /particles/{} with positions (groups: {})", fn,
                        want, candidates.empty() ? std::string("none") : list());
    }
    chosen = want;
  } else if (candidates.empty()) {
    return make_error(Errc::format, "{}: no group under /particles has a position element", fn);
  } else if (candidates.size() > 1) {
    return make_error(Errc::invalid_argument, "{}: several particle groups have positions ({}); choose one with the H5MD group option",
                      fn, list());
  } else {
    chosen = candidates[0];
  }
  r->group_ = "/particles/" + chosen;
  const std::string& g = r->group_;

  // Positions.
  const Kind pk = kind_of(file, g + "/position");
  r->position_time_dependent_ = (pk == Kind::group);
  r->position_name_ = r->position_time_dependent_ ? g + "/position/value" : g + "/position";
  if (r->position_time_dependent_ && kind_of(file, r->position_name_) != Kind::dataset) {
    return make_error(Errc::format, "{}: {}/position is a group without a value dataset", fn, g);
  }
  MDS_ASSIGN_OR_RETURN(r->h_->position, open_dataset(file, fn, r->position_name_));
  const Dataset& pos = r->h_->position;
  const size_t want_rank = r->position_time_dependent_ ? 3 : 2;
  if (pos.dims.size() != want_rank || pos.dims.back() != 3) {
    return make_error(Errc::format, "{}: dataset {} has shape {}, expected {}", fn, r->position_name_,
                      shape_str(pos.dims), r->position_time_dependent_ ? "[frames][N][3]" : "[N][3]");
  }
  if (pos.type_class != H5T_FLOAT) {
    return make_error(Errc::format, "{}: dataset {} is not floating point (expected float32 or float64)", fn,
                      r->position_name_);
  }
  r->frames_ = r->position_time_dependent_ ? pos.dims[0] : 1;
  const uint64_t n = r->position_time_dependent_ ? pos.dims[1] : pos.dims[0];
  int64_t frame = options.frame;
  if (frame == -1) frame = static_cast<int64_t>(r->frames_) - 1;
  if (frame < 0 || static_cast<uint64_t>(frame) >= r->frames_) {
    return make_error(Errc::invalid_argument, "{}: frame {} out of range: dataset {} has {} frames", fn, options.frame,
                      r->position_name_, r->frames_);
  }
  r->frame_ = static_cast<uint64_t>(frame);
  r->info_.particle_count = n;
  r->info_.frame_count = r->frames_;
  r->info_.timestep = frame;

  // Simulation step of the frame.
  if (r->position_time_dependent_ && kind_of(file, g + "/position/step") == Kind::dataset) {
    const std::string sp = g + "/position/step";
    MDS_ASSIGN_OR_RETURN(Dataset step, open_dataset(file, fn, sp));
    int64_t s = 0;
    if (step.type_class != H5T_INTEGER) return make_error(Errc::format, "{}: dataset {} is not integer", fn, sp);
    if (step.dims.size() == 1 && step.dims[0] > r->frame_) {
      MDS_TRY(read_slab(step, {r->frame_}, {1}, H5T_NATIVE_INT64, &s, fn, sp));
      r->info_.timestep = s;
    } else if (step.dims.empty()) {
      MDS_TRY(read_slab(step, {}, {}, H5T_NATIVE_INT64, &s, fn, sp));  // fixed step interval
      r->info_.timestep = s * frame;
    } else {
      return make_error(Errc::format, "{}: dataset {} has shape {}, expected [frames] with {} frames", fn, sp,
                        shape_str(step.dims), r->frames_);
    }
  }

  // Species -> type ids.
  const Kind sk = kind_of(file, g + "/species");
  if (sk != Kind::missing) {
    const bool sgroup = (sk == Kind::group);
    r->species_name_ = sgroup ? g + "/species/value" : g + "/species";
    if (sgroup && kind_of(file, r->species_name_) != Kind::dataset) {
      return make_error(Errc::format, "{}: {}/species is a group without a value dataset", fn, g);
    }
    MDS_ASSIGN_OR_RETURN(r->h_->species, open_dataset(file, fn, r->species_name_));
    const Dataset& sp = r->h_->species;
    if (sp.type_class != H5T_INTEGER) {
      return make_error(Errc::format, "{}: dataset {} is not integer (species must be integer type ids)", fn,
                        r->species_name_);
    }
    const bool per_frame = sgroup && sp.dims.size() == 2;
    const bool fixed = sp.dims.size() == 1;
    if ((!per_frame && !fixed) || sp.dims.back() != n || (per_frame && sp.dims[0] <= r->frame_)) {
      return make_error(Errc::format, "{}: dataset {} has shape {}, expected {} to match {} {}", fn, r->species_name_,
                        shape_str(sp.dims), per_frame ? fmt::format("[frames][{}]", n) : fmt::format("[{}]", n),
                        r->position_name_, shape_str(pos.dims));
    }
    r->has_species_ = true;
    r->species_time_dependent_ = per_frame;
  }

  // The per-particle scalar asked for: /particles/<g>/<name>/value [frames][N] (or [frames][N][1]),
  // or the time-independent /particles/<g>/<name> [N] (or [N][1]); integer or floating point.
  if (!options.property.empty()) {
    const std::string e = g + "/" + options.property;
    const Kind k = kind_of(file, e);
    if (k == Kind::missing)
      return make_error(Errc::format, "{}: no element {} for the property '{}' (--property)", fn, e, options.property);
    const bool pgroup = k == Kind::group;
    r->property_name_ = pgroup ? e + "/value" : e;
    if (pgroup && kind_of(file, r->property_name_) != Kind::dataset)
      return make_error(Errc::format, "{}: {} is a group without a value dataset", fn, e);
    MDS_ASSIGN_OR_RETURN(r->h_->property, open_dataset(file, fn, r->property_name_));
    const Dataset& pd = r->h_->property;
    if (pd.type_class != H5T_FLOAT && pd.type_class != H5T_INTEGER)
      return make_error(Errc::format, "{}: dataset {} is not numeric (the property must be integer or floating point)", fn,
                        r->property_name_);
    std::vector<hsize_t> d = pd.dims;
    if (!d.empty() && d.size() == (pgroup ? 3u : 2u) && d.back() == 1) d.pop_back();  // [..][N][1]: one component
    const bool ok = pgroup ? (d.size() == 2 && d[1] == n && d[0] > r->frame_) : (d.size() == 1 && d[0] == n);
    if (!ok)
      return make_error(Errc::format, "{}: dataset {} has shape {}, expected {} for one value per particle of {} {}", fn,
                        r->property_name_, shape_str(pd.dims),
                        pgroup ? fmt::format("[frames > {}][{}]", r->frame_, n) : fmt::format("[{}]", n),
                        r->position_name_, shape_str(pos.dims));
    r->has_property_ = true;
    r->property_time_dependent_ = pgroup;
    r->info_.has_property = true;
  }

  // Box: edges (vector or matrix, rows = box vectors), optional offset = lower corner.
  if (kind_of(file, g + "/box") == Kind::group) {
    const uint64_t bframe = r->position_time_dependent_ ? r->frame_ : 0;
    MDS_ASSIGN_OR_RETURN(std::vector<double> edges, read_box_element(file, fn, g + "/box/edges", bframe, true));
    MDS_ASSIGN_OR_RETURN(std::vector<double> offset, read_box_element(file, fn, g + "/box/offset", bframe, false));
    if (!edges.empty()) {
      SimulationCell& cell = r->info_.cell;
      for (int k = 0; k < 3; ++k) {
        cell.origin[k] = offset.empty() ? 0.0 : offset[k];
        for (int v = 0; v < 3; ++v) cell.vectors[v][k] = edges.size() == 3 ? (v == k ? edges[k] : 0.0) : edges[v * 3 + k];
      }
      MDS_TRY(read_boundary(file, fn, g + "/box", cell.periodic));
      double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
      for (int v = 0; v < 3; ++v)
        for (int k = 0; k < 3; ++k) {
          lo[k] += std::min(0.0, cell.vectors[v][k]);
          hi[k] += std::max(0.0, cell.vectors[v][k]);
        }
      for (int k = 0; k < 3; ++k) {
        r->info_.box_lo[k] = lo[k] + cell.origin[k];
        r->info_.box_hi[k] = hi[k] + cell.origin[k];
      }
      r->info_.has_box = true;
    }
  }
  return std::unique_ptr<ParticleReader>(std::move(r));
}

Result<size_t> H5mdReader::read(ParticleBatch& out, size_t max_particles) {
  out.clear();
  const uint64_t n = std::min<uint64_t>({info_.particle_count - next_, max_particles, kChunkParticles});
  if (n == 0) return size_t{0};
  // Read in the stored precision (float32 stays float32: HDF5's own conversion works in
  // small strips and is much slower), then widen and validate here.
  const bool f32 = h_->position.type_size == 4;
  const hid_t mem_type = f32 ? H5T_NATIVE_FLOAT : H5T_NATIVE_DOUBLE;
  void* dst = nullptr;
  if (f32) {
    buffer_f32_.resize(n * 3);
    dst = buffer_f32_.data();
  } else {
    buffer_.resize(n * 3);
    dst = buffer_.data();
  }
  if (position_time_dependent_) {
    MDS_TRY(read_slab(h_->position, {frame_, next_, 0}, {1, n, 3}, mem_type, dst, file_name_, position_name_));
  } else {
    MDS_TRY(read_slab(h_->position, {next_, 0}, {n, 3}, mem_type, dst, file_name_, position_name_));
  }
  out.x.resize(n);
  out.y.resize(n);
  out.z.resize(n);
  auto store = [&](const auto* v) -> Status {
    for (uint64_t i = 0; i < n; ++i) {
      const double px = v[3 * i], py = v[3 * i + 1], pz = v[3 * i + 2];
      if (!std::isfinite(px) || !std::isfinite(py) || !std::isfinite(pz)) {
        return make_error(Errc::range, "{}: dataset {}: frame {} particle {} has a non-finite coordinate", file_name_,
                          position_name_, frame_, next_ + i);
      }
      out.x[i] = px;
      out.y[i] = py;
      out.z[i] = pz;
    }
    return Status::success();
  };
  MDS_TRY(f32 ? store(buffer_f32_.data()) : store(buffer_.data()));
  if (has_species_) {
    species_buffer_.resize(n);
    if (species_time_dependent_) {
      MDS_TRY(read_slab(h_->species, {frame_, next_}, {1, n}, H5T_NATIVE_INT64, species_buffer_.data(), file_name_,
                        species_name_));
    } else {
      MDS_TRY(read_slab(h_->species, {next_}, {n}, H5T_NATIVE_INT64, species_buffer_.data(), file_name_,
                        species_name_));
    }
    out.type.resize(n);
    for (uint64_t i = 0; i < n; ++i) {
      const int64_t s = species_buffer_[i];
      if (s < std::numeric_limits<int32_t>::min() || s > std::numeric_limits<int32_t>::max()) {
        return make_error(Errc::range, "{}: dataset {}: particle {} species {} does not fit a 32-bit type id",
                          file_name_, species_name_, next_ + i, s);
      }
      out.type[i] = static_cast<int32_t>(s);
    }
  } else {
    out.type.assign(n, 1);
  }
  if (has_property_) {
    property_buffer_.resize(n);
    const Dataset& pd = h_->property;
    const bool one = pd.dims.back() == 1 && pd.dims.size() == (property_time_dependent_ ? 3u : 2u);
    if (property_time_dependent_) {
      if (one) MDS_TRY(read_slab(pd, {frame_, next_, 0}, {1, n, 1}, H5T_NATIVE_DOUBLE, property_buffer_.data(), file_name_, property_name_));
      else MDS_TRY(read_slab(pd, {frame_, next_}, {1, n}, H5T_NATIVE_DOUBLE, property_buffer_.data(), file_name_, property_name_));
    } else {
      if (one) MDS_TRY(read_slab(pd, {next_, 0}, {n, 1}, H5T_NATIVE_DOUBLE, property_buffer_.data(), file_name_, property_name_));
      else MDS_TRY(read_slab(pd, {next_}, {n}, H5T_NATIVE_DOUBLE, property_buffer_.data(), file_name_, property_name_));
    }
    out.property.resize(n);
    for (uint64_t i = 0; i < n; ++i) {
      const double v = property_buffer_[i];
      if (!std::isfinite(v) || !std::isfinite(static_cast<float>(v)))
        return make_error(Errc::range, "{}: dataset {}: frame {} particle {} has the non-finite value {}", file_name_,
                          property_name_, frame_, next_ + i, v);
      out.property[i] = static_cast<float>(v);
    }
  }
  next_ += n;
  return static_cast<size_t>(n);
}

}  // namespace mds
