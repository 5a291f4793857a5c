// LAMMPS text dump reader. Format: LAMMPS manual, `dump` command (atom/custom styles) and
// "Howto triclinic" for the box; see lammps_reader.h for the box formulas.
//
// Headers are parsed line by line; atom lines are taken from the TextSource in large blocks
// and parsed in parallel (one range of lines per hardware thread): numbers with parse_double
// (decimal.h, Clinger's fast path before std::from_chars), integers with std::from_chars.
// Frames before the requested one are skipped by counting newlines only.
#include "readers/lammps_reader.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "readers/decimal.h"
#include "readers/text_frame_reader.h"

namespace mds {

SimulationCell LammpsBox::cell(const bool periodic[3]) const {
  SimulationCell c;
  for (int d = 0; d < 3; ++d) {
    c.origin[d] = lo[d];
    c.vectors[d][d] = hi[d] - lo[d];
    c.periodic[d] = periodic[d];
  }
  c.vectors[1][0] = xy;
  c.vectors[2][0] = xz;
  c.vectors[2][1] = yz;
  return c;
}

Result<LammpsBox> lammps_box_from_cell(const SimulationCell& c) {
  const auto& v = c.vectors;
  if (!(v[0][0] > 0.0 && v[1][1] > 0.0 && v[2][2] > 0.0 && v[0][1] == 0.0 && v[0][2] == 0.0 && v[1][2] == 0.0))
    return make_error(Errc::unsupported,
                      "the cell's edge vectors a = ({:g}, {:g}, {:g}), b = ({:g}, {:g}, {:g}), c = ({:g}, {:g}, {:g}) are "
                      "not a LAMMPS box (a along +x, b in the xy plane, each with a positive length along its axis)",
                      v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2], v[2][0], v[2][1], v[2][2]);
  LammpsBox b;
  for (int d = 0; d < 3; ++d) {
    b.lo[d] = c.origin[d];
    b.hi[d] = c.origin[d] + v[d][d];
  }
  b.xy = v[1][0];
  b.xz = v[2][0];
  b.yz = v[2][1];
  b.triclinic = b.xy != 0.0 || b.xz != 0.0 || b.yz != 0.0;
  for (int d = 0; d < 3; ++d) {
    b.bound_lo[d] = b.lo[d];
    b.bound_hi[d] = b.hi[d];
  }
  if (b.triclinic) {  // the bounding box, as lammps_box_from_bounds undoes it
    b.bound_lo[0] += std::min({0.0, b.xy, b.xz, b.xy + b.xz});
    b.bound_hi[0] += std::max({0.0, b.xy, b.xz, b.xy + b.xz});
    b.bound_lo[1] += std::min(0.0, b.yz);
    b.bound_hi[1] += std::max(0.0, b.yz);
  }
  return b;
}

void lammps_periodic_from_flags(const std::vector<std::string_view>& flags, bool periodic[3]) {
  int axis = 0;
  for (std::string_view f : flags) {
    if (f == "xy" || f == "xz" || f == "yz") continue;
    if (axis < 3) periodic[axis++] = f == "pp";
  }
  for (; axis < 3; ++axis) periodic[axis] = false;
}

LammpsBox lammps_box_from_bounds(const double bounds[3][3], bool triclinic) {
  LammpsBox b;
  b.triclinic = triclinic;
  for (int i = 0; i < 3; ++i) {
    b.bound_lo[i] = bounds[i][0];
    b.bound_hi[i] = bounds[i][1];
    b.lo[i] = bounds[i][0];
    b.hi[i] = bounds[i][1];
  }
  if (triclinic) {
    b.xy = bounds[0][2];
    b.xz = bounds[1][2];
    b.yz = bounds[2][2];
    b.lo[0] = b.bound_lo[0] - std::min({0.0, b.xy, b.xz, b.xy + b.xz});
    b.hi[0] = b.bound_hi[0] - std::max({0.0, b.xy, b.xz, b.xy + b.xz});
    b.lo[1] = b.bound_lo[1] - std::min(0.0, b.yz);
    b.hi[1] = b.bound_hi[1] - std::max(0.0, b.yz);
  }
  return b;
}

namespace {

constexpr uint64_t kMaxAtoms = kMaxTextAtoms;

enum class Col : uint8_t { skip, id, type, x, y, z, radius, diameter, property };

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (is_blank(s[i]) || s[i] == '\r')) ++i;
    size_t j = i;
    while (j < s.size() && !is_blank(s[j]) && s[j] != '\r') ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

bool starts_with_item(std::string_view line) { return line.substr(0, 5) == "ITEM:"; }

struct FrameHeader {
  uint64_t first_line = 0;   // line of the first ITEM:
  int64_t timestep = 0;
  uint64_t natoms = 0;
  bool has_natoms = false;
  LammpsBox box;
  bool has_box = false;
  bool periodic[3] = {false, false, false};  // BOX BOUNDS flags
  SimulationCell cell;                       // box.cell(periodic)
  uint64_t atoms_line = 0;   // line of ITEM: ATOMS
  std::vector<Col> cols;
  bool scaled = false;
  bool has_id = false, has_type = false, has_radius = false, has_property = false;
  std::string property;      // ReaderOptions::property
};

// Picks the position columns and the roles of all columns of `ITEM: ATOMS ...`.
// `property`: the column kept as the per-particle scalar (ReaderOptions::property), or empty.
Status map_columns(const std::vector<std::string_view>& names, FrameHeader& h, const std::string& file,
                   const std::string& property) {
  h.cols.assign(names.size(), Col::skip);
  static const char* kSets[4][3] = {{"x", "y", "z"}, {"xu", "yu", "zu"}, {"xs", "ys", "zs"}, {"xsu", "ysu", "zsu"}};
  auto find = [&](std::string_view n) -> int {
    for (size_t i = 0; i < names.size(); ++i)
      if (names[i] == n) return static_cast<int>(i);
    return -1;
  };
  int chosen = -1;
  for (int s = 0; s < 4 && chosen < 0; ++s) {
    int ix = find(kSets[s][0]), iy = find(kSets[s][1]), iz = find(kSets[s][2]);
    if (ix >= 0 && iy >= 0 && iz >= 0) {
      chosen = s;
      h.cols[ix] = Col::x;
      h.cols[iy] = Col::y;
      h.cols[iz] = Col::z;
    }
  }
  if (chosen < 0)
    return make_error(Errc::format,
                      "{}:{}: ITEM: ATOMS has no complete set of position columns (x y z, xu yu zu, xs ys zs or "
                      "xsu ysu zsu)",
                      file, h.atoms_line);
  h.scaled = chosen >= 2;
  if (int i = find("id"); i >= 0) { h.cols[i] = Col::id; h.has_id = true; }
  if (int i = find("type"); i >= 0) { h.cols[i] = Col::type; h.has_type = true; }
  if (int i = find("radius"); i >= 0) {
    h.cols[i] = Col::radius;
    h.has_radius = true;
  } else if (int j = find("diameter"); j >= 0) {
    h.cols[j] = Col::diameter;
    h.has_radius = true;
  }
  if (!property.empty()) {
    const int i = find(property);
    if (i < 0) {
      std::string list;
      for (const auto n : names) list += fmt::format("{}{}", list.empty() ? "" : " ", n);
      return make_error(Errc::format, "{}:{}: ITEM: ATOMS has no column '{}' (--property); its columns: {}", file,
                        h.atoms_line, property, list);
    }
    if (h.cols[i] != Col::skip)
      return make_error(Errc::invalid_argument,
                        "{}:{}: column '{}' is read as the particles' {}; --property takes one of the other columns", file,
                        h.atoms_line, property, h.cols[i] == Col::id ? "id" : h.cols[i] == Col::type ? "type" :
                        h.cols[i] == Col::radius || h.cols[i] == Col::diameter ? "radius" : "position");
    h.cols[i] = Col::property;
    h.has_property = true;
  }
  if (h.scaled && !h.has_box)
    return make_error(Errc::format, "{}:{}: scaled coordinates but the frame has no ITEM: BOX BOUNDS", file,
                      h.atoms_line);
  return {};
}

class LammpsReader final : public TextFrameReader {
 public:
  LammpsReader(std::unique_ptr<TextSource> src, FrameHeader h)
      : TextFrameReader(std::move(src),
                        text_frame_info(h.natoms, h.timestep, h.has_box ? &h.cell : nullptr, h.has_radius,
                                        h.has_property),
                        h.first_line, /*reject_unterminated=*/true), h_(std::move(h)) {
    if (h_.has_box) {  // the bounding box as the dump wrote it (cell.bounds() may round differently)
      std::copy(h_.box.bound_lo, h_.box.bound_lo + 3, info_.box_lo);
      std::copy(h_.box.bound_hi, h_.box.bound_hi + 3, info_.box_hi);
    }
  }

 private:
  // After the declared atoms: end of file or the next frame's ITEM:.
  Status check_frame_end() override {
    std::string_view line;
    MDS_ASSIGN_OR_RETURN(bool has, src_->peek_line(line));
    if (!has || starts_with_item(line)) return {};
    if (trim(line).empty()) {
      // Blank lines are allowed only at the very end.
      while (true) {
        MDS_ASSIGN_OR_RETURN(bool more, src_->next_line(line));
        if (!more) return {};
        if (!trim(line).empty()) break;
      }
      return make_error(Errc::format, "{}:{}: unexpected text after a blank line: '{}'", src_->name(), src_->line(),
                        excerpt(line));
    }
    return too_many_atoms_error();
  }

  Status parse_block(const LineBlock& blk, ParticleBatch& out, size_t base, uint64_t done_before) override {
    resize_batch(out, base + blk.lines, h_.has_id, h_.has_radius, h_.has_property);
    return parse_parallel(blk, [&](const char* b, const char* e, size_t first, size_t lines, LineParseError& err) {
      parse_range(b, e, base + first, lines, blk.first_line + first, done_before + first, out, err);
    });
  }

  // done_before: atoms of the frame before this range.
  void parse_range(const char* p, const char* end, size_t out_index, size_t lines, uint64_t first_line,
                   uint64_t done_before, ParticleBatch& out, LineParseError& err) const {
    const Col* cols = h_.cols.data();
    const size_t ncols = h_.cols.size();
    double* xs = out.x.data();
    double* ys = out.y.data();
    double* zs = out.z.data();
    int32_t* types = out.type.data();
    int64_t* ids = h_.has_id ? out.id.data() : nullptr;
    float* radii = h_.has_radius ? out.radius.data() : nullptr;
    float* props = h_.has_property ? out.property.data() : nullptr;
    for (size_t li = 0; li < lines; ++li) {
      const char* line_start = p;
      double pos[3] = {0, 0, 0};
      int32_t type = 1;
      for (size_t c = 0; c < ncols; ++c) {
        while (is_blank(*p)) ++p;
        if (*p == '\n' || *p == '\r') {
          set_error(err, Errc::format, first_line + li,
                    fmt::format("expected {} columns (ITEM: ATOMS at line {}), found {}", ncols, h_.atoms_line, c));
          return;
        }
        const char* tok = p;
        if (c == 0 && *p == 'I' && std::string_view(p, static_cast<size_t>(end - p)).substr(0, 5) == "ITEM:") {
          set_error(err, Errc::format, first_line + li,
                    fmt::format("'ITEM:' after {} of the {} atoms that the frame at line {} declares (wrong atom "
                                "count?)",
                                done_before + li, h_.natoms, h_.first_line));
          return;
        }
        std::from_chars_result r{p, std::errc()};
        const Col role = cols[c];
        if (role == Col::skip) {
          while (!is_token_end(*p)) ++p;
          continue;
        }
        if (*p == '+') ++p;
        switch (role) {
          case Col::x:
          case Col::y:
          case Col::z: {
            double v;
            r = parse_double(p, end, v);
            if (r.ec == std::errc() && !std::isfinite(v)) {
              set_error(err, Errc::range, first_line + li,
                        fmt::format("non-finite coordinate '{}'", token_at(tok)));
              return;
            }
            pos[static_cast<int>(role) - static_cast<int>(Col::x)] = v;
            break;
          }
          case Col::type: {
            r = std::from_chars(p, end, type);
            break;
          }
          case Col::id: {
            int64_t v = 0;
            r = std::from_chars(p, end, v);
            ids[out_index + li] = v;
            break;
          }
          case Col::radius:
          case Col::diameter: {
            double v;
            r = parse_double(p, end, v);
            if (r.ec == std::errc() && (!std::isfinite(v) || v < 0)) {
              set_error(err, Errc::range, first_line + li, fmt::format("invalid radius/diameter '{}'", token_at(tok)));
              return;
            }
            radii[out_index + li] = static_cast<float>(role == Col::diameter ? v * 0.5 : v);
            break;
          }
          case Col::property: {
            double v;
            r = parse_double(p, end, v);
            if (r.ec == std::errc() && !(std::isfinite(v) && std::isfinite(static_cast<float>(v)))) {
              set_error(err, Errc::range, first_line + li,
                        fmt::format("property '{}': non-finite value '{}'", h_.property, token_at(tok)));
              return;
            }
            props[out_index + li] = static_cast<float>(v);
            break;
          }
          case Col::skip:
            break;
        }
        if (r.ec != std::errc() || !is_token_end(*r.ptr)) {
          set_error(err, r.ec == std::errc::result_out_of_range ? Errc::range : Errc::format, first_line + li,
                    fmt::format("bad value '{}' in column {} of {}", token_at(tok), c + 1, ncols));
          return;
        }
        p = r.ptr;
      }
      while (is_blank(*p) || *p == '\r') ++p;
      if (*p != '\n') {
        size_t found = split_ws(std::string_view(line_start, static_cast<size_t>(
                                                                 static_cast<const char*>(std::memchr(p, '\n', end - p)) -
                                                                 line_start)))
                           .size();
        set_error(err, Errc::format, first_line + li,
                  fmt::format("expected {} columns (ITEM: ATOMS at line {}), found {}", ncols, h_.atoms_line, found));
        return;
      }
      ++p;
      const size_t o = out_index + li;
      if (h_.scaled) {
        double c[3];
        h_.box.scaled_to_cartesian(pos, c);
        xs[o] = c[0];
        ys[o] = c[1];
        zs[o] = c[2];
      } else {
        xs[o] = pos[0];
        ys[o] = pos[1];
        zs[o] = pos[2];
      }
      types[o] = type;
    }
  }

  FrameHeader h_;
};

// Reads the header of the next frame up to and including `ITEM: ATOMS`. Returns false at
// the end of the file (no more frames). `after` describes what precedes (for messages).
Result<bool> read_header(TextSource& src, FrameHeader& h, const std::string& after, const std::string& property) {
  h = FrameHeader{};
  h.property = property;
  const std::string& file = src.name();
  std::string_view line;
  // Skip blank lines between frames.
  while (true) {
    MDS_ASSIGN_OR_RETURN(bool has, src.peek_line(line));
    if (!has) return false;
    if (!trim(line).empty()) break;
    MDS_TRY(src.next_line(line));
  }
  MDS_TRY(src.next_line(line));
  h.first_line = src.line();
  if (!starts_with_item(line))
    return make_error(Errc::format, "{}:{}: expected 'ITEM: TIMESTEP'{}, found '{}'", file, src.line(), after,
                      excerpt(line));
  bool seen_ts = false;
  while (true) {
    std::string_view item = trim(line.substr(5));
    const uint64_t item_line = src.line();
    auto value_line = [&](const char* what) -> Result<std::string_view> {
      std::string_view v;
      MDS_ASSIGN_OR_RETURN(bool has, src.next_line(v));
      if (!has)
        return make_error(Errc::format, "{}:{}: file ends after 'ITEM: {}' (truncated?)", file, item_line, what);
      return v;
    };
    if (item == "TIMESTEP") {
      if (seen_ts)
        return make_error(Errc::format, "{}:{}: second ITEM: TIMESTEP before ITEM: ATOMS of the frame at line {}",
                          file, item_line, h.first_line);
      seen_ts = true;
      MDS_ASSIGN_OR_RETURN(std::string_view v, value_line("TIMESTEP"));
      if (!parse_int_exact(v, h.timestep))
        return make_error(Errc::format, "{}:{}: bad timestep '{}'", file, src.line(), excerpt(v));
    } else if (item == "NUMBER OF ATOMS") {
      MDS_ASSIGN_OR_RETURN(std::string_view v, value_line("NUMBER OF ATOMS"));
      bool overflow = false;
      if (!parse_int_exact(v, h.natoms, &overflow)) {
        if (overflow)
          return make_error(Errc::range, "{}:{}: atom count '{}' is out of range", file, src.line(), excerpt(v));
        return make_error(Errc::format, "{}:{}: bad atom count '{}'", file, src.line(), excerpt(v));
      }
      if (h.natoms > kMaxAtoms)
        return make_error(Errc::range, "{}:{}: atom count {} is absurd (more than {})", file, src.line(), h.natoms,
                          kMaxAtoms);
      h.has_natoms = true;
    } else if (item.substr(0, 10) == "BOX BOUNDS") {
      auto flags = split_ws(item.substr(10));
      bool tri = std::find(flags.begin(), flags.end(), "xy") != flags.end();
      if (std::find(flags.begin(), flags.end(), "abc") != flags.end())
        return make_error(Errc::unsupported, "{}:{}: general triclinic boxes ('abc origin') are not supported", file,
                          item_line);
      double b[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
      for (int i = 0; i < 3; ++i) {
        MDS_ASSIGN_OR_RETURN(std::string_view v, value_line("BOX BOUNDS"));
        auto t = split_ws(v);
        const size_t need = tri ? 3 : 2;
        if (t.size() != need)
          return make_error(Errc::format, "{}:{}: expected {} numbers in a {} box bounds line, found {}", file,
                            src.line(), need, tri ? "triclinic" : "orthogonal", t.size());
        for (size_t k = 0; k < need; ++k) {
          if (!parse_double_exact(t[k], b[i][k]))
            return make_error(Errc::format, "{}:{}: bad box bound '{}'", file, src.line(), excerpt(t[k]));
          if (!std::isfinite(b[i][k]))
            return make_error(Errc::range, "{}:{}: non-finite box bound '{}'", file, src.line(), excerpt(t[k]));
        }
      }
      h.box = lammps_box_from_bounds(b, tri);
      lammps_periodic_from_flags(flags, h.periodic);
      h.cell = h.box.cell(h.periodic);
      h.has_box = true;
    } else if (item.substr(0, 5) == "ATOMS") {
      h.atoms_line = item_line;
      if (!h.has_natoms)
        return make_error(Errc::format, "{}:{}: ITEM: ATOMS before ITEM: NUMBER OF ATOMS", file, item_line);
      auto names = split_ws(item.substr(5));
      if (names.empty()) return make_error(Errc::format, "{}:{}: ITEM: ATOMS lists no columns", file, item_line);
      MDS_TRY(map_columns(names, h, file, h.property));
      // Every atom line holds at least one character and one separator per column; counts
      // beyond what the rest of the file could hold at half that are absurd (a slightly
      // malformed file is left to the line checks, which give the better message).
      if (auto rest = src.remaining_bytes()) {
        const uint64_t min_bytes = static_cast<uint64_t>(names.size());
        if (h.natoms > *rest / min_bytes)
          return make_error(Errc::range,
                            "{}:{}: frame declares {} atoms but only {} bytes remain in the file (an atom line "
                            "needs at least {} bytes)",
                            file, item_line, h.natoms, *rest, 2 * min_bytes);
      }
      return true;
    } else if (item.substr(0, 7) == "ENTRIES") {
      return make_error(Errc::unsupported, "{}:{}: this is a 'dump local' file (ITEM: ENTRIES), not an atom dump",
                        file, item_line);
    } else {
      // Other items (UNITS, TIME, ...): skip their value lines.
      while (true) {
        MDS_ASSIGN_OR_RETURN(bool has, src.peek_line(line));
        if (!has || starts_with_item(line)) break;
        MDS_TRY(src.next_line(line));
      }
    }
    MDS_ASSIGN_OR_RETURN(bool has, src.next_line(line));
    if (!has)
      return make_error(Errc::format, "{}:{}: file ends before 'ITEM: ATOMS' of the frame at line {} (truncated?)",
                        file, src.line(), h.first_line);
    if (!starts_with_item(line))
      return make_error(Errc::format, "{}:{}: expected an ITEM: line, found '{}'", file, src.line(), excerpt(line));
  }
}

}  // namespace

Result<std::unique_ptr<ParticleReader>> open_lammps_reader(const std::filesystem::path& path,
                                                           const ReaderOptions& options) {
  FrameHeader h;
  MDS_ASSIGN_OR_RETURN(std::unique_ptr<TextSource> src,
                       open_text_frame(path, options, h, [&](TextSource& s, FrameHeader& fh, const std::string& after) {
                         return read_header(s, fh, after, options.property);
                       }));
  auto r = std::make_unique<LammpsReader>(std::move(src), std::move(h));
  r->set_relay(options.relay);
  return std::unique_ptr<ParticleReader>(std::move(r));
}

Result<std::vector<FrameEntry>> list_lammps_frames(const std::filesystem::path& path, const ReaderOptions& options) {
  FrameHeader h;
  return list_text_frames(path, text_header_fn(h, [&](TextSource& s, FrameHeader& fh, const std::string& after) {
                            return read_header(s, fh, after, options.property);
                          }));
}

}  // namespace mds
