// Input format detection by content (magic bytes, first lines) and dispatch to the
// per-format readers of reader_factories.h.
//   gzip / zstd      -> decompress the first bytes and classify the text inside
//   \x89HDF\r\n\x1a\n -> H5MD (an HDF5 file must have a /h5md group)
//   "MMPLD\0"        -> MMPLD
//   "ITEM:"          -> LAMMPS dump;  first line an integer count -> XYZ
//   raw float32 has no signature: InputFormat::raw, or a .raw/.f32 extension as last resort.
#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <fstream>
#include <string_view>

#include <zlib.h>
#include <zstd.h>

#include "readers/h5md_module.h"
#include "readers/reader_factories.h"
#include "readers/replicate_reader.h"
#include "readers/wrap_reader.h"

namespace mds {
namespace {

constexpr size_t kHeadBytes = 4096;

std::string lower_ext(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

// The first line of `text` (without the newline) and whether the line was complete.
std::string_view line_at(std::string_view text, size_t pos, size_t* next) {
  size_t nl = text.find('\n', pos);
  std::string_view l = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
  if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
  *next = nl == std::string_view::npos ? text.size() : nl + 1;
  return l;
}

bool is_text_line(std::string_view l) {
  return std::all_of(l.begin(), l.end(), [](unsigned char c) { return c == '\t' || (c >= 0x20 && c != 0x7f); });
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// LAMMPS dump or XYZ from the first bytes of (decompressed) text.
std::optional<InputFormat> classify_text(std::string_view head) {
  size_t pos = 0;
  // Skip blank leading lines.
  std::string_view first;
  for (;;) {
    if (pos >= head.size()) return std::nullopt;
    size_t next = 0;
    first = line_at(head, pos, &next);
    pos = next;
    if (!trim(first).empty()) break;
  }
  if (!is_text_line(first)) return std::nullopt;
  const std::string_view t = trim(first);
  if (t.rfind("ITEM:", 0) == 0) return InputFormat::lammps;
  std::string_view digits = t;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  if (!digits.empty() && digits.size() <= 19 &&
      std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c) != 0; })) {
    // XYZ: count line, then a comment line that is text too (when it is in the head).
    size_t next = 0;
    std::string_view comment = line_at(head, pos, &next);
    if (pos < head.size() && !is_text_line(comment)) return std::nullopt;
    return InputFormat::xyz;
  }
  return std::nullopt;
}

Result<std::string> gunzip_head(const std::filesystem::path& path) {
  gzFile gz = gzopen(path.c_str(), "rb");
  if (gz == nullptr) return make_error(Errc::io, "{}: cannot open gzip stream", path.string());
  std::string out(kHeadBytes, '\0');
  int n = gzread(gz, out.data(), static_cast<unsigned>(out.size()));
  int errnum = 0;
  const char* msg = gzerror(gz, &errnum);
  std::string err = (n < 0 && msg != nullptr) ? msg : "";
  gzclose(gz);
  if (n < 0) return make_error(Errc::format, "{}: corrupt gzip data: {}", path.string(), err);
  out.resize(static_cast<size_t>(n));
  return out;
}

Result<std::string> unzstd_head(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return make_error(Errc::io, "{}: cannot open", path.string());
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> dctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  std::string out(kHeadBytes, '\0');
  std::vector<char> in(ZSTD_DStreamInSize());
  ZSTD_outBuffer ob{out.data(), out.size(), 0};
  // Bounded: at most 64 input blocks to fill the head.
  for (int round = 0; round < 64 && ob.pos < ob.size; ++round) {
    f.read(in.data(), static_cast<std::streamsize>(in.size()));
    const auto got = static_cast<size_t>(f.gcount());
    if (got == 0) break;
    ZSTD_inBuffer ib{in.data(), got, 0};
    while (ib.pos < ib.size && ob.pos < ob.size) {
      size_t r = ZSTD_decompressStream(dctx.get(), &ob, &ib);
      if (ZSTD_isError(r)) {
        return make_error(Errc::format, "{}: corrupt zstd data: {}", path.string(), ZSTD_getErrorName(r));
      }
      if (r == 0) break;
    }
  }
  out.resize(ob.pos);
  return out;
}

}  // namespace

Result<InputFormat> detect_format(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return make_error(Errc::io, "{}: no such file", name);
  if (!std::filesystem::is_regular_file(path, ec)) return make_error(Errc::io, "{}: not a regular file", name);
  std::ifstream f(path, std::ios::binary);
  if (!f) return make_error(Errc::io, "{}: cannot open", name);
  std::string head(kHeadBytes, '\0');
  f.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(f.gcount()));
  if (head.empty()) return make_error(Errc::format, "{}: empty file", name);
  const auto starts = [&](std::string_view magic) { return std::string_view(head).substr(0, magic.size()) == magic; };

  if (starts("\x1f\x8b") || starts("\x28\xb5\x2f\xfd")) {
    const bool gz = starts("\x1f\x8b");
    MDS_ASSIGN_OR_RETURN(std::string text, gz ? gunzip_head(path) : unzstd_head(path));
    if (auto k = classify_text(text)) return *k;
    return make_error(Errc::format, "{}: {}-compressed content is neither a LAMMPS dump (ITEM:) nor XYZ (count line)",
                      name, gz ? "gzip" : "zstd");
  }

  // HDF5 signature at 0 or at a user-block offset (512, 1024, 2048, ...).
  static constexpr std::string_view kHdf5("\x89HDF\r\n\x1a\n", 8);
  bool hdf5 = starts(kHdf5);
  const uint64_t size = std::filesystem::file_size(path, ec);
  for (uint64_t off = 512; !hdf5 && !ec && off + kHdf5.size() <= size; off *= 2) {
    std::array<char, 8> sig{};
    f.clear();
    f.seekg(static_cast<std::streamoff>(off));
    f.read(sig.data(), sig.size());
    hdf5 = f.gcount() == 8 && std::string_view(sig.data(), 8) == kHdf5;
  }
  if (hdf5) {
    MDS_ASSIGN_OR_RETURN(bool h5md, h5md_detect(path));
    if (!h5md) return make_error(Errc::format, "{}: HDF5 file without /h5md group (not H5MD)", name);
    return InputFormat::h5md;
  }
  if (starts(std::string_view("MMPLD\0", 6))) return InputFormat::mmpld;
  if (auto k = classify_text(head)) return *k;
  const std::string ext = lower_ext(path);
  if (ext == ".raw" || ext == ".f32") return InputFormat::raw;
  return make_error(Errc::format,
                    "{}: unknown input format (not a LAMMPS dump, XYZ, H5MD or MMPLD file, gzip/zstd included; raw "
                    "float32 xyz must be asked for with format raw)",
                    name);
}

namespace {

Result<std::unique_ptr<ParticleReader>> open_format_reader(const std::filesystem::path& path, const ReaderOptions& options) {
  InputFormat f = options.format;
  if (f == InputFormat::automatic) {
    MDS_ASSIGN_OR_RETURN(f, detect_format(path));
  }
  if (options.color && f != InputFormat::xyz && f != InputFormat::mmpld)
    return make_error(Errc::invalid_argument,
                      "{}: {} input has no per-particle colours (--color keeps MMPLD colours and extended XYZ's "
                      "color:R:3)",
                      path.string(), input_format_name(f));
  switch (f) {
    case InputFormat::lammps: return open_lammps_reader(path, options);
    case InputFormat::xyz: return open_xyz_reader(path, options);
    case InputFormat::h5md: return open_h5md_reader(path, options);
    case InputFormat::mmpld: return open_mmpld_reader(path, options);
    case InputFormat::raw:
      if (!options.property.empty())
        return make_error(Errc::invalid_argument, "{}: raw float32 xyz holds positions only; it has no property '{}' (--property)",
                          path.string(), options.property);
      return open_raw_reader(path, options);
    case InputFormat::automatic: break;
  }
  return make_error(Errc::internal, "{}: no reader for format {}", path.string(), input_format_name(f));
}

}  // namespace

Result<std::unique_ptr<ParticleReader>> open_reader(const std::filesystem::path& path, const ReaderOptions& options) {
  MDS_ASSIGN_OR_RETURN(std::unique_ptr<ParticleReader> r, open_format_reader(path, options));
  if (options.wrap) {
    MDS_ASSIGN_OR_RETURN(r, wrap_reader(std::move(r), path.string()));
  }
  if (options.replicate != std::array<uint32_t, 3>{1, 1, 1}) {
    MDS_ASSIGN_OR_RETURN(r, replicate_reader(std::move(r), options.replicate, path.string()));
  }
  return r;
}

Result<std::vector<FrameEntry>> list_frames(const std::filesystem::path& path, const ReaderOptions& options) {
  InputFormat f = options.format;
  if (f == InputFormat::automatic) {
    MDS_ASSIGN_OR_RETURN(f, detect_format(path));
  }
  ReaderOptions o = options;
  o.format = f;
  o.start = FrameMark{};
  o.wrap = false;  // the frames as they are declared
  o.replicate = {1, 1, 1};
  if (f == InputFormat::lammps) return list_lammps_frames(path, o);
  if (f == InputFormat::xyz) return list_xyz_frames(path, o);
  // Binary formats declare their frames: open the first, then each (H5MD's step, MMPLD's lists).
  o.frame = 0;
  MDS_ASSIGN_OR_RETURN(std::unique_ptr<ParticleReader> first, open_reader(path, o));
  const uint64_t count = first->info().frame_count;
  if (count == 0) return make_error(Errc::internal, "{}: the {} reader did not count its frames", path.string(),
                                    input_format_name(f));
  std::vector<FrameEntry> frames;
  frames.reserve(size_t(count));
  for (uint64_t k = 0; k < count; ++k) {
    FrameEntry e;
    e.index = int64_t(k);
    if (k == 0) {
      e.timestep = first->info().timestep;
      e.particle_count = first->info().particle_count;
    } else {
      o.frame = e.index;
      MDS_ASSIGN_OR_RETURN(std::unique_ptr<ParticleReader> r, open_reader(path, o));
      e.timestep = r->info().timestep;
      e.particle_count = r->info().particle_count;
    }
    frames.push_back(e);
  }
  return frames;
}

}  // namespace mds
