// XYZ / extended XYZ reader; formats described in xyz_reader.h.
//
// Like the LAMMPS reader: headers line by line, atom lines in large blocks parsed in
// parallel with parse_double (decimal.h); species strings are mapped to type ids afterwards on one
// thread (first seen -> 1, 2, ...; an integer species is used as the type id itself).
#include "readers/xyz_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>
#include <unordered_map>

#include "readers/decimal.h"
#include "readers/text_frame_reader.h"

namespace mds {

bool parse_extxyz_comment(std::string_view s, std::map<std::string, std::string>& out) {
  size_t i = 0;
  auto read_value = [&](std::string& v) -> bool {
    if (i < s.size() && (s[i] == '"' || s[i] == '\'' || s[i] == '{')) {
      const char close = s[i] == '{' ? '}' : s[i];
      ++i;
      while (i < s.size() && s[i] != close) {
        if (s[i] == '\\' && i + 1 < s.size()) ++i;
        v.push_back(s[i++]);
      }
      if (i >= s.size()) return false;
      ++i;
      return true;
    }
    while (i < s.size() && !is_blank(s[i]) && s[i] != '\r') v.push_back(s[i++]);
    return true;
  };
  while (i < s.size()) {
    while (i < s.size() && (is_blank(s[i]) || s[i] == '\r')) ++i;
    if (i >= s.size()) break;
    std::string key;
    if (s[i] == '"' || s[i] == '\'' || s[i] == '{') {
      if (!read_value(key)) return false;
    } else {
      while (i < s.size() && !is_blank(s[i]) && s[i] != '=' && s[i] != '\r') key.push_back(s[i++]);
    }
    // Allow spaces around '='.
    size_t j = i;
    while (j < s.size() && is_blank(s[j])) ++j;
    if (j < s.size() && s[j] == '=') {
      i = j + 1;
      while (i < s.size() && is_blank(s[i])) ++i;
      std::string v;
      if (!read_value(v)) return false;
      out[key] = v;
    } else {
      out[key] = "T";
    }
  }
  return true;
}

bool parse_extxyz_properties(std::string_view value, std::vector<XyzProperty>& out, std::string& error) {
  out.clear();
  std::vector<std::string_view> parts;
  size_t start = 0;
  for (size_t i = 0; i <= value.size(); ++i) {
    if (i == value.size() || value[i] == ':') {
      parts.push_back(trim(value.substr(start, i - start)));
      start = i + 1;
    }
  }
  if (parts.size() % 3 != 0) {
    error = fmt::format("Properties '{}' is not a list of name:type:count triples", excerpt(value));
    return false;
  }
  int col = 0;
  for (size_t k = 0; k < parts.size(); k += 3) {
    XyzProperty p;
    p.name = std::string(parts[k]);
    if (parts[k + 1].size() != 1 || std::string_view("SRIL").find(parts[k + 1][0]) == std::string_view::npos) {
      error = fmt::format("Properties: type of '{}' must be S, R, I or L, found '{}'", p.name, parts[k + 1]);
      return false;
    }
    p.type = parts[k + 1][0];
    if (!parse_int_exact(parts[k + 2], p.count) || p.count < 1 || p.count > 1000) {
      error = fmt::format("Properties: bad column count '{}' for '{}'", parts[k + 2], p.name);
      return false;
    }
    p.first_column = col;
    col += p.count;
    out.push_back(std::move(p));
  }
  if (out.empty()) {
    error = "Properties is empty";
    return false;
  }
  return true;
}

namespace {

constexpr uint64_t kMaxAtoms = kMaxTextAtoms;
constexpr const char* kChannelNames[3] = {"red", "green", "blue"};  // of color:R:3, for messages
// A well-formed atom line has at least 8 bytes ("H 0 0 0\n"); counts beyond what the rest of
// the file could hold at half that are rejected as absurd before anything is read (a slightly
// malformed short file is left to the line checks, which give the better message).
constexpr uint64_t kMinAtomLineBytes = 4;

// The values of an extended-XYZ key (Lattice, Origin, pbc): separated by blanks or commas.
std::vector<std::string_view> value_tokens(std::string_view s) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (is_blank(s[i]) || s[i] == ',')) ++i;
    size_t j = i;
    while (j < s.size() && !is_blank(s[j]) && s[j] != ',') ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string lower(std::string_view s) {
  std::string r(s);
  for (auto& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

struct XyzHeader {
  uint64_t first_line = 0;   // line of the atom count
  uint64_t natoms = 0;
  int64_t timestep = 0;
  bool has_box = false;
  SimulationCell cell;       // Lattice=, Origin=, pbc=
  bool extended = false;     // exact column count
  int ncols = 4;             // exact (extended) or minimum (plain)
  int species_col = 0;       // -1: none (type 1)
  int pos_col = 1;
  int radius_col = -1;
  int property_col = -1;     // ReaderOptions::property's column, or -1
  std::string property;      // ReaderOptions::property
  int color_col = -1;        // with ReaderOptions::color: the first of the color:R:3 columns, or -1
};

// Reads the count and comment lines of the next frame; false at the end of the file.
Result<bool> read_header(TextSource& src, XyzHeader& h, const std::string& after, const std::string& property,
                         bool color) {
  h = XyzHeader{};
  h.property = property;
  const std::string& file = src.name();
  std::string_view line;
  while (true) {
    MDS_ASSIGN_OR_RETURN(bool has, src.next_line(line));
    if (!has) return false;
    if (!trim(line).empty()) break;
  }
  h.first_line = src.line();
  bool overflow = false;
  if (!parse_int_exact(line, h.natoms, &overflow)) {
    if (overflow) return make_error(Errc::range, "{}:{}: atom count '{}' is out of range", file, src.line(), excerpt(line));
    return make_error(Errc::format, "{}:{}: expected the atom count of a frame{}, found '{}'", file, src.line(), after,
                      excerpt(line));
  }
  if (h.natoms > kMaxAtoms)
    return make_error(Errc::range, "{}:{}: atom count {} is absurd (more than {})", file, src.line(), h.natoms, kMaxAtoms);
  std::string_view comment;
  MDS_ASSIGN_OR_RETURN(bool has_comment, src.next_line(comment));
  if (!has_comment)
    return make_error(Errc::format, "{}:{}: file ends after the atom count (no comment line; truncated?)", file,
                      h.first_line);
  const uint64_t cline = src.line();
  if (auto rest = src.remaining_bytes(); rest && h.natoms > *rest / kMinAtomLineBytes)
    return make_error(Errc::range, "{}:{}: frame declares {} atoms but only {} bytes remain in the file", file,
                      h.first_line, h.natoms, *rest);

  std::map<std::string, std::string> kv;
  const bool looks_extended = comment.find('=') != std::string_view::npos;
  if (looks_extended && !parse_extxyz_comment(comment, kv))
    return make_error(Errc::format, "{}:{}: unterminated quote in the extended XYZ comment line", file, cline);
  std::map<std::string, std::string> lkv;  // lower-cased keys
  for (auto& [k, v] : kv) lkv[lower(k)] = v;

  if (auto it = lkv.find("lattice"); it != lkv.end()) {
    std::vector<double> v;
    for (std::string_view t : value_tokens(it->second)) {
      double d;
      if (!parse_double_exact(t, d) || !std::isfinite(d))
        return make_error(Errc::format, "{}:{}: bad Lattice value '{}'", file, cline, excerpt(t));
      v.push_back(d);
    }
    if (v.size() != 9)
      return make_error(Errc::format, "{}:{}: Lattice needs 9 numbers, found {}", file, cline, v.size());
    double origin[3] = {0, 0, 0};
    if (auto o = lkv.find("origin"); o != lkv.end()) {
      const std::vector<std::string_view> t = value_tokens(o->second);
      for (int d = 0; d < 3; ++d)
        if (size_t(d) >= t.size() || !parse_double_exact(t[size_t(d)], origin[d]) || !std::isfinite(origin[d]))
          return make_error(Errc::format, "{}:{}: bad Origin value '{}'", file, cline, excerpt(o->second));
    }
    for (int d = 0; d < 3; ++d) {
      h.cell.origin[d] = origin[d];
      for (int e = 0; e < 3; ++e) h.cell.vectors[e][d] = v[static_cast<size_t>(3 * e + d)];
    }
    // pbc="T T F" (ASE, OVITO); without it a cell given by Lattice is periodic along all three.
    bool pbc[3] = {true, true, true};
    if (auto p = lkv.find("pbc"); p != lkv.end()) {
      const std::vector<std::string_view> t = value_tokens(p->second);
      bool ok = t.size() == 3;
      for (size_t d = 0; ok && d < 3; ++d) {
        const std::string b = lower(t[d]);
        pbc[d] = b == "t" || b == "true" || b == "1";
        ok = pbc[d] || b == "f" || b == "false" || b == "0";
      }
      if (!ok)
        return make_error(Errc::format, "{}:{}: bad pbc value '{}' (three of T/F)", file, cline, excerpt(p->second));
    }
    for (int d = 0; d < 3; ++d) h.cell.periodic[d] = pbc[d];
    h.has_box = true;
  }
  bool has_ts = false;
  for (const char* k : {"timestep", "step", "time_step"}) {
    if (auto it = lkv.find(k); it != lkv.end() && parse_int_exact(it->second, h.timestep)) {
      has_ts = true;
      break;
    }
  }
  // LAMMPS' dump xyz writes "Atoms. Timestep: N".
  if (size_t at = comment.find("Timestep:"); !has_ts && at != std::string_view::npos) {
    std::string_view rest = trim(comment.substr(at + 9));
    size_t k = 0;
    while (k < rest.size() && !is_blank(rest[k])) ++k;
    if (!parse_int_exact(rest.substr(0, k), h.timestep)) h.timestep = 0;
  }

  const bool has_props = lkv.count("properties") > 0;
  if (has_props || h.has_box) {
    std::vector<XyzProperty> props;
    std::string err;
    if (!parse_extxyz_properties(has_props ? std::string_view(lkv["properties"]) : "species:S:1:pos:R:3", props, err))
      return make_error(Errc::format, "{}:{}: {}", file, cline, err);
    h.extended = true;
    h.ncols = props.back().first_column + props.back().count;
    h.species_col = h.pos_col = -1;
    for (const char* want : {"species", "element", "z", "type"}) {
      for (auto& p : props)
        if (lower(p.name) == want && p.count == 1 && h.species_col < 0) h.species_col = p.first_column;
    }
    for (auto& p : props) {
      std::string n = lower(p.name);
      if ((n == "pos" || n == "positions" || n == "position") && h.pos_col < 0) {
        if (p.type != 'R' || p.count != 3)
          return make_error(Errc::format, "{}:{}: Properties: '{}' must be R:3", file, cline, p.name);
        h.pos_col = p.first_column;
      }
      if ((n == "radius" || n == "radii") && h.radius_col < 0) {
        if (p.type != 'R' || p.count != 1)
          return make_error(Errc::format, "{}:{}: Properties: '{}' must be R:1", file, cline, p.name);
        h.radius_col = p.first_column;
      }
    }
    if (h.pos_col < 0)
      return make_error(Errc::format, "{}:{}: Properties has no pos:R:3 column", file, cline);
    if (!property.empty()) {
      std::string list;
      for (auto& p : props) {
        list += fmt::format("{}{}:{}:{}", list.empty() ? "" : " ", p.name, p.type, p.count);
        if (p.name != property) continue;
        if (p.first_column == h.pos_col || p.first_column == h.species_col || p.first_column == h.radius_col)
          return make_error(Errc::invalid_argument,
                            "{}:{}: Properties: '{}' is read as the particles' species, position or radius; --property "
                            "takes one of the other properties",
                            file, cline, p.name);
        if (p.type != 'R' && p.type != 'I')
          return make_error(Errc::format, "{}:{}: Properties: '{}' is {}:{}; --property needs a number (R:1 or I:1)", file,
                            cline, p.name, p.type, p.count);
        if (p.count != 1)
          return make_error(Errc::format, "{}:{}: Properties: '{}' has {} columns; --property needs one (R:1 or I:1)", file,
                            cline, p.name, p.count);
        h.property_col = p.first_column;
      }
      if (h.property_col < 0)
        return make_error(Errc::format, "{}:{}: Properties has no '{}' (--property); it has: {}", file, cline, property,
                          list);
    }
    if (color) {
      // OVITO writes per-particle colours as Color:R:3, channels in [0, 1].
      for (auto& p : props) {
        const std::string n = lower(p.name);
        if ((n != "color" && n != "colour" && n != "colors") || h.color_col >= 0) continue;
        if (p.type != 'R' || p.count != 3)
          return make_error(Errc::format, "{}:{}: Properties: '{}' is {}:{}; --color needs R:3 (red, green, blue in [0, 1])",
                            file, cline, p.name, p.type, p.count);
        h.color_col = p.first_column;
      }
      if (h.color_col < 0)
        return make_error(Errc::format, "{}:{}: Properties has no color:R:3 (--color)", file, cline);
    }
  }
  if (color && !h.extended)
    return make_error(Errc::format,
                      "{}:{}: a plain XYZ frame has no named columns; --color needs extended XYZ with color:R:3", file,
                      h.first_line + 1);
  if (!property.empty() && !h.extended)
    return make_error(Errc::format,
                      "{}:{}: a plain XYZ frame has no named columns; --property '{}' needs extended XYZ (Properties=...)",
                      file, h.first_line + 1, property);
  return true;
}

class XyzReader final : public TextFrameReader {
 public:
  XyzReader(std::unique_ptr<TextSource> src, const XyzHeader& h)
      : TextFrameReader(std::move(src),
                        text_frame_info(h.natoms, h.timestep, h.has_box ? &h.cell : nullptr, h.radius_col >= 0,
                                        h.property_col >= 0, h.color_col >= 0),
                        h.first_line, /*reject_unterminated=*/false), h_(h) {}

 private:
  // After the declared atoms: end of file (blank lines allowed) or the next frame's count.
  Status check_frame_end() override {
    std::string_view line;
    while (true) {
      MDS_ASSIGN_OR_RETURN(bool has, src_->peek_line(line));
      if (!has) return {};
      if (!trim(line).empty()) break;
      MDS_TRY(src_->next_line(line));
    }
    uint64_t n;
    if (parse_int_exact(line, n)) return {};
    return too_many_atoms_error();
  }

  Status parse_block(const LineBlock& blk, ParticleBatch& out, size_t base, uint64_t done_before) override {
    resize_batch(out, base + blk.lines, /*with_id=*/false, h_.radius_col >= 0, h_.property_col >= 0, h_.color_col >= 0);
    species_.resize(blk.lines);
    MDS_TRY(parse_parallel(blk, [&](const char* b, const char* e, size_t first, size_t lines, LineParseError& err) {
      parse_range(b, e, first, base, lines, blk.first_line, done_before, out, err);
    }));
    // Species -> type ids, in file order (first seen -> next id).
    std::string_view last;
    int32_t last_id = 0;
    for (size_t i = 0; i < blk.lines; ++i) {
      std::string_view sp = species_[i];
      if (h_.species_col < 0) {
        out.type[base + i] = 1;
        continue;
      }
      if (i > 0 && sp == last) {
        out.type[base + i] = last_id;
        continue;
      }
      auto id = species_id(sp, blk.first_line + i);
      if (!id.ok()) return id.error();
      last = sp;
      last_id = *id;
      out.type[base + i] = last_id;
    }
    return {};
  }

  Result<int32_t> species_id(std::string_view sp, uint64_t line) {
    int32_t v;
    if (parse_int_exact(sp, v)) {
      if (auto it = info_.type_names.find(v); it != info_.type_names.end())
        return make_error(Errc::format, "{}:{}: integer species {} collides with the id given to species '{}'",
                          src_->name(), line, v, it->second);
      int_ids_.insert(v);
      return v;
    }
    std::string key(sp);
    if (auto it = name_ids_.find(key); it != name_ids_.end()) return it->second;
    while (int_ids_.count(next_id_) || info_.type_names.count(next_id_)) ++next_id_;
    const int32_t id = next_id_++;
    name_ids_.emplace(key, id);
    info_.type_names[id] = key;
    return id;
  }

  void parse_range(const char* p, const char* end, size_t first, size_t base, size_t lines, uint64_t first_line,
                   uint64_t done_before, ParticleBatch& out, LineParseError& err) {
    const int ncols = h_.ncols;
    const int scol = h_.species_col, pcol = h_.pos_col, rcol = h_.radius_col, vcol = h_.property_col;
    const int ccol = h_.color_col;
    const int need = h_.extended ? ncols : 4;
    for (size_t li = 0; li < lines; ++li) {
      const size_t bi = first + li;  // index within the block
      const uint64_t line_no = first_line + bi;
      double pos[3] = {0, 0, 0};
      double rgb[3] = {0, 0, 0};
      int c = 0;
      for (;; ++c) {
        while (is_blank(*p)) ++p;
        if (*p == '\n' || *p == '\r') break;
        if (c >= need) {
          if (h_.extended) {
            int found = c;
            while (*p != '\n') {
              while (is_blank(*p) || *p == '\r') ++p;
              if (*p == '\n') break;
              ++found;
              while (!is_token_end(*p)) ++p;
            }
            set_error(err, Errc::format, line_no,
                      fmt::format("expected {} columns (from Properties), found {}", ncols, found));
            return;
          }
          while (*p != '\n') ++p;  // plain XYZ: extra columns ignored
          break;
        }
        const char* tok = p;
        if (c == scol) {
          while (!is_token_end(*p)) ++p;
          species_[bi] = std::string_view(tok, static_cast<size_t>(p - tok));
        } else if (c >= pcol && c < pcol + 3) {
          if (*p == '+') ++p;
          double v;
          auto r = parse_double(p, end, v);
          if (r.ec != std::errc() || !is_token_end(*r.ptr)) {
            set_error(err, r.ec == std::errc::result_out_of_range ? Errc::range : Errc::format, line_no,
                      fmt::format("bad coordinate '{}'", token_at(tok)));
            return;
          }
          if (!std::isfinite(v)) {
            set_error(err, Errc::range, line_no, fmt::format("non-finite coordinate '{}'", token_at(tok)));
            return;
          }
          pos[c - pcol] = v;
          p = r.ptr;
        } else if (c == rcol) {
          if (*p == '+') ++p;
          double v;
          auto r = parse_double(p, end, v);
          if (r.ec != std::errc() || !is_token_end(*r.ptr) || !std::isfinite(v) || v < 0) {
            set_error(err, r.ec == std::errc::result_out_of_range ? Errc::range : Errc::format, line_no,
                      fmt::format("bad radius '{}'", token_at(tok)));
            return;
          }
          out.radius[base + bi] = static_cast<float>(v);
          p = r.ptr;
        } else if (c == vcol) {
          if (*p == '+') ++p;
          double v;
          auto r = parse_double(p, end, v);
          if (r.ec != std::errc() || !is_token_end(*r.ptr) || !std::isfinite(v) || !std::isfinite(static_cast<float>(v))) {
            set_error(err, r.ec == std::errc::result_out_of_range ? Errc::range : Errc::format, line_no,
                      fmt::format("property '{}': bad value '{}'", h_.property, token_at(tok)));
            return;
          }
          out.property[base + bi] = static_cast<float>(v);
          p = r.ptr;
        } else if (ccol >= 0 && c >= ccol && c < ccol + 3) {
          if (*p == '+') ++p;
          double v;
          auto r = parse_double(p, end, v);
          if (r.ec != std::errc() || !is_token_end(*r.ptr) || !std::isfinite(v)) {
            set_error(err, r.ec == std::errc::result_out_of_range ? Errc::range : Errc::format, line_no,
                      fmt::format("bad colour channel ({}) '{}'", kChannelNames[c - ccol], token_at(tok)));
            return;
          }
          rgb[c - ccol] = v;
          p = r.ptr;
        } else {
          while (!is_token_end(*p)) ++p;
        }
      }
      if (c < need) {
        std::string hint;
        if (c == 1) {
          hint = fmt::format(" (atom {} of the {} that the frame at line {} declares; is the count wrong?)",
                             done_before + bi + 1, h_.natoms, h_.first_line);
        }
        set_error(err, Errc::format, line_no,
                  fmt::format("expected {} {} columns, found {}{}", h_.extended ? "exactly" : "at least", need, c, hint));
        return;
      }
      while (*p != '\n') ++p;
      ++p;
      out.x[base + bi] = pos[0];
      out.y[base + bi] = pos[1];
      out.z[base + bi] = pos[2];
      if (ccol >= 0) out.color[base + bi] = pack_rgba8(unit_to_u8(rgb[0]), unit_to_u8(rgb[1]), unit_to_u8(rgb[2]));
    }
  }

  XyzHeader h_;
  std::vector<std::string_view> species_;  // per line of the current block
  std::unordered_map<std::string, int32_t> name_ids_;
  std::set<int32_t> int_ids_;
  int32_t next_id_ = 1;
};

}  // namespace

Result<std::unique_ptr<ParticleReader>> open_xyz_reader(const std::filesystem::path& path,
                                                        const ReaderOptions& options) {
  XyzHeader h;
  MDS_ASSIGN_OR_RETURN(std::unique_ptr<TextSource> src,
                       open_text_frame(path, options, h, [&](TextSource& s, XyzHeader& xh, const std::string& after) {
                         return read_header(s, xh, after, options.property, options.color);
                       }));
  auto r = std::make_unique<XyzReader>(std::move(src), h);
  r->set_relay(options.relay);
  return std::unique_ptr<ParticleReader>(std::move(r));
}

Result<std::vector<FrameEntry>> list_xyz_frames(const std::filesystem::path& path, const ReaderOptions& options) {
  XyzHeader h;
  return list_text_frames(path, text_header_fn(h, [&](TextSource& s, XyzHeader& xh, const std::string& after) {
                            return read_header(s, xh, after, options.property, options.color);
                          }));
}

}  // namespace mds
