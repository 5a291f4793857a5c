// Frame selection and block streaming shared by the text readers; see text_frame_reader.h.
#include "readers/text_frame_reader.h"

#include <algorithm>

namespace mds {

Error truncated_frame_error(const TextSource& src, uint64_t frame_line, uint64_t natoms, uint64_t found) {
  return make_error(Errc::format,
                    "{}:{}: file ends inside the frame that starts at line {}: it declares {} atoms, found {} "
                    "(truncated file or wrong atom count)",
                    src.name(), src.unterminated_line() ? src.unterminated_line() : src.line() + 1, frame_line, natoms,
                    found);
}

FrameInfo text_frame_info(uint64_t natoms, int64_t timestep, const SimulationCell* cell, bool has_radius,
                          bool has_property, bool has_color) {
  FrameInfo info;
  info.particle_count = natoms;
  info.timestep = timestep;
  info.has_box = cell != nullptr;
  if (cell) {
    info.cell = *cell;
    cell->bounds(info.box_lo, info.box_hi);
  }
  info.has_radius = has_radius;
  info.has_property = has_property;
  info.has_color = has_color;
  return info;
}

namespace {

// Skips the atom lines of a frame whose header was just read.
Status skip_atoms(TextSource& src, const TextFrameExtent& f) {
  MDS_ASSIGN_OR_RETURN(uint64_t skipped, src.skip_lines(f.natoms));
  if (skipped < f.natoms) return truncated_frame_error(src, f.first_line, f.natoms, skipped);
  return {};
}

std::string after_frame(const TextFrameExtent& f) {
  return fmt::format(" after the {} atoms of the frame at line {} (wrong atom count?)", f.natoms, f.first_line);
}

}  // namespace

Result<std::unique_ptr<TextSource>> open_text_frame(const std::filesystem::path& path, const ReaderOptions& options,
                                                    const TextHeaderFn& read_header) {
  if (options.frame < -1)
    return make_error(Errc::invalid_argument, "{}: frame {} is not valid (use >= 0, or -1 for the last)",
                      path.string(), options.frame);
  std::unique_ptr<TextSource> src;
  const bool marked = options.start.index >= 0 && options.start.index == options.frame;
  if (marked && options.relay && options.relay->source && options.relay->source->name() == path.string()) {
    src = std::move(options.relay->source);  // seek() below goes forward in it, even compressed
  } else {
    MDS_ASSIGN_OR_RETURN(src, TextSource::open(path));
  }
  std::string after;
  if (marked) {
    // A mark from list_frames(): go there and read the header found there.
    MDS_TRY(src->seek(options.start.offset, options.start.line));
    MDS_ASSIGN_OR_RETURN(std::optional<TextFrameExtent> h, read_header(*src, ""));
    if (!h)
      return make_error(Errc::invalid_argument, "{}: byte offset {}: no frame {} there (the file changed since its "
                        "frames were listed?)", src->name(), options.start.offset, options.frame);
  } else if (options.frame >= 0) {
    for (int64_t f = 0;; ++f) {
      MDS_ASSIGN_OR_RETURN(std::optional<TextFrameExtent> h, read_header(*src, after));
      if (!h) {
        if (f == 0) return make_error(Errc::format, "{}: no frames (empty file?)", src->name());
        return make_error(Errc::invalid_argument, "{}: frame {} requested but the file has {} frame{}", src->name(),
                          options.frame, f, f == 1 ? "" : "s");
      }
      if (f == options.frame) break;
      MDS_TRY(skip_atoms(*src, *h));
      after = after_frame(*h);
    }
  } else {
    // Last frame: scan all frames, remember where the last one starts, go back there.
    uint64_t last_offset = 0, last_line = 0;
    int64_t frames = 0;
    while (true) {
      const uint64_t off = src->tell(), line = src->line();
      MDS_ASSIGN_OR_RETURN(std::optional<TextFrameExtent> h, read_header(*src, after));
      if (!h) break;
      last_offset = off;
      last_line = line;
      ++frames;
      MDS_TRY(skip_atoms(*src, *h));
      after = after_frame(*h);
    }
    if (frames == 0) return make_error(Errc::format, "{}: no frames (empty file?)", src->name());
    MDS_TRY(src->seek(last_offset, last_line));
    MDS_ASSIGN_OR_RETURN(std::optional<TextFrameExtent> h, read_header(*src, ""));
    if (!h) return make_error(Errc::internal, "{}: last frame vanished on re-read", src->name());
  }
  return src;
}

Result<std::vector<FrameEntry>> list_text_frames(const std::filesystem::path& path, const TextHeaderFn& read_header) {
  MDS_ASSIGN_OR_RETURN(std::unique_ptr<TextSource> src, TextSource::open(path));
  std::vector<FrameEntry> frames;
  std::string after;
  while (true) {
    const uint64_t off = src->tell(), line = src->line();
    MDS_ASSIGN_OR_RETURN(std::optional<TextFrameExtent> h, read_header(*src, after));
    if (!h) break;
    FrameEntry e;
    e.index = int64_t(frames.size());
    e.timestep = h->timestep;
    e.particle_count = h->natoms;
    e.mark = FrameMark{e.index, off, line};
    frames.push_back(e);
    MDS_TRY(skip_atoms(*src, *h));
    after = after_frame(*h);
  }
  if (frames.empty()) return make_error(Errc::format, "{}: no frames (empty file?)", src->name());
  return frames;
}

TextSourceRelay::TextSourceRelay() = default;
TextSourceRelay::~TextSourceRelay() = default;

TextFrameReader::~TextFrameReader() {
  if (relay_ && src_ && !failed_) relay_->source = std::move(src_);
}

TextFrameReader::TextFrameReader(std::unique_ptr<TextSource> src, FrameInfo info, uint64_t frame_line,
                                 bool reject_unterminated)
    : src_(std::move(src)),
      info_(std::move(info)),
      frame_line_(frame_line),
      reject_unterminated_(reject_unterminated),
      remaining_(info_.particle_count) {}

Error TextFrameReader::fail(Error e) {
  failed_ = e;
  return e;
}

Result<size_t> TextFrameReader::read(ParticleBatch& out, size_t max_particles) {
  out.clear();
  if (failed_) return *failed_;
  if (remaining_ == 0 || max_particles == 0) return size_t{0};
  const size_t want = static_cast<size_t>(std::min<uint64_t>(remaining_, max_particles));
  const uint64_t done_before = natoms() - remaining_;
  size_t got = 0;
  while (got < want) {
    auto blk = src_->take_lines(want - got);
    if (!blk.ok()) return fail(blk.error());
    if (blk->lines == 0) return fail(truncated_frame_error(*src_, frame_line_, natoms(), done_before + got));
    if (reject_unterminated_ && src_->unterminated_line() != 0 &&
        blk->first_line + blk->lines - 1 == src_->unterminated_line())
      return fail(make_error(Errc::format, "{}:{}: last line has no end-of-line (file truncated?)", src_->name(),
                             src_->unterminated_line()));
    Status st = parse_block(*blk, out, got, done_before + got);
    if (!st.ok()) return fail(st.error());
    got += blk->lines;
  }
  remaining_ -= got;
  if (remaining_ == 0) {
    Status st = check_frame_end();
    if (!st.ok()) return fail(st.error());
  }
  return got;
}

void TextFrameReader::resize_batch(ParticleBatch& out, size_t n, bool with_id, bool with_radius, bool with_property,
                                   bool with_color) {
  out.x.resize(n);
  out.y.resize(n);
  out.z.resize(n);
  out.type.resize(n);
  if (with_id) out.id.resize(n);
  if (with_radius) out.radius.resize(n);
  if (with_property) out.property.resize(n);
  if (with_color) out.color.resize(n);
}

void TextFrameReader::set_error(LineParseError& err, Errc code, uint64_t line, const std::string& what) const {
  err.set = true;
  err.error = Error{code, fmt::format("{}:{}: {}", src_->name(), line, what)};
}

std::string TextFrameReader::token_at(const char* t) {
  const char* e = t;
  while (!is_token_end(*e) && e - t < 40) ++e;
  return std::string(t, e);
}

Error TextFrameReader::too_many_atoms_error() const {
  return make_error(Errc::format,
                    "{}:{}: more atom lines than the {} that the frame at line {} declares (wrong atom count?)",
                    src_->name(), src_->line() + 1, natoms(), frame_line_);
}

}  // namespace mds
