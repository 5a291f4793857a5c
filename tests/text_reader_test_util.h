// Shared helpers for the text-reader tests (LAMMPS dump, XYZ): a temporary directory,
// running Debian's `lmp` on the project's decks in tests/data/lammps, draining a reader, and
// a deliberately simple, independent parser of LAMMPS dump text (iostreams + strtod) that
// the readers' results are compared against.
#pragma once

#include <stdlib.h>

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "readers/reader_factories.h"

namespace mds::textest {

namespace fs = std::filesystem;

class TempDir {
 public:
  explicit TempDir(const char* tag) {
    std::string tmpl = (fs::temp_directory_path() / (std::string("mds_") + tag + "_XXXXXX")).string();
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

inline std::string read_text(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

inline void write_text(const fs::path& p, const std::string& text) {
  std::ofstream f(p, std::ios::binary);
  f << text;
}

inline std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream is(text);
  for (std::string l; std::getline(is, l);) lines.push_back(l);
  return lines;
}

inline std::string join_lines(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

inline std::string quote(const std::string& s) { return "'" + s + "'"; }

// Runs `lmp -in <deck>` in `dir`; returns the exit status.
inline int run_lammps(const fs::path& dir, const std::string& deck, bool with_log = false) {
  const std::string deck_path = std::string(MDSTREAM_SOURCE_DIR) + "/tests/data/lammps/" + deck;
  std::string cmd = "cd " + quote(dir.string()) + " && lmp -in " + quote(deck_path) +
                    (with_log ? " -log log.lammps" : " -log none") + " -screen none";
  return std::system(cmd.c_str());
}

// The outputs of `lmp -in <deck>`, run once and shared by all test processes (CTest runs
// every test case in its own process): kept in <tmp>/mds_lmp_<hash of the deck>, created
// atomically (run in a private directory, then renamed). Returns an empty path when lmp fails.
inline fs::path cached_lammps_run(const std::string& deck, bool with_log = false) {
  const std::string deck_path = std::string(MDSTREAM_SOURCE_DIR) + "/tests/data/lammps/" + deck;
  const std::string key = read_text(deck_path) + (with_log ? "+log" : "");
  char name[64];
  std::snprintf(name, sizeof name, "mds_lmp_%016zx", std::hash<std::string>{}(key));
  const fs::path final_dir = fs::temp_directory_path() / name;
  if (fs::exists(final_dir / ".complete")) return final_dir;
  std::string tmpl = (fs::temp_directory_path() / "mds_lmp_run_XXXXXX").string();
  if (::mkdtemp(tmpl.data()) == nullptr) return {};
  const fs::path tmp = tmpl;
  std::error_code ec;
  if (run_lammps(tmp, deck, with_log) != 0) {
    fs::remove_all(tmp, ec);
    return {};
  }
  write_text(tmp / ".complete", deck + "\n");
  fs::rename(tmp, final_dir, ec);
  if (ec) fs::remove_all(tmp, ec);  // another process finished first; use its copy
  return fs::exists(final_dir / ".complete") ? final_dir : fs::path{};
}

// All particles of one frame, read in batches of `batch`.
struct ReadAll {
  FrameInfo info;
  ParticleBatch all;
  std::map<int32_t, std::string> type_names;
  std::optional<Error> error;
};

inline ReadAll read_all(Result<std::unique_ptr<ParticleReader>> opened, size_t batch = 100000) {
  ReadAll r;
  if (!opened.ok()) {
    r.error = opened.error();
    return r;
  }
  auto& reader = *opened.value();
  r.info = reader.info();
  ParticleBatch b;
  while (true) {
    auto n = reader.read(b, batch);
    if (!n.ok()) {
      r.error = n.error();
      return r;
    }
    if (*n == 0) break;
    if (*n != b.size()) {
      r.error = Error{Errc::internal, "read() count differs from the batch size"};
      return r;
    }
    r.all.x.insert(r.all.x.end(), b.x.begin(), b.x.end());
    r.all.y.insert(r.all.y.end(), b.y.begin(), b.y.end());
    r.all.z.insert(r.all.z.end(), b.z.begin(), b.z.end());
    r.all.type.insert(r.all.type.end(), b.type.begin(), b.type.end());
    r.all.radius.insert(r.all.radius.end(), b.radius.begin(), b.radius.end());
    r.all.id.insert(r.all.id.end(), b.id.begin(), b.id.end());
    r.all.property.insert(r.all.property.end(), b.property.begin(), b.property.end());
  }
  r.type_names = reader.type_names();
  return r;
}

// Options that read frame `frame` (-1: the last) of a file in `format`.
inline ReaderOptions frame_options(InputFormat format, int64_t frame) {
  ReaderOptions o;
  o.format = format;
  o.frame = frame;
  return o;
}

// Expects an error of `code` whose message names the file and `file:line:`.
inline void expect_error(const ReadAll& r, Errc code, const fs::path& p, uint64_t line) {
  ASSERT_TRUE(r.error.has_value()) << "expected an error for " << p;
  EXPECT_EQ(r.error->code, code) << r.error->message;
  EXPECT_THAT(r.error->message, ::testing::HasSubstr(p.string() + ":" + std::to_string(line) + ":"));
}

// One frame of a LAMMPS dump as plain strings and numbers, parsed independently.
struct RefFrame {
  long long timestep = 0;
  size_t natoms = 0;
  std::string box_flags;
  double bounds[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;  // every column as a number
  size_t first_line = 0;                  // 1-based line of ITEM: TIMESTEP
  double col(size_t row, const std::string& name) const {
    for (size_t c = 0; c < columns.size(); ++c)
      if (columns[c] == name) return rows[row][c];
    throw std::runtime_error("no column " + name);
  }
};

inline std::vector<RefFrame> parse_reference_dump(const std::string& text) {
  std::vector<RefFrame> frames;
  auto lines = split_lines(text);
  size_t i = 0;
  while (i < lines.size()) {
    RefFrame f;
    f.first_line = i + 1;
    if (lines[i] != "ITEM: TIMESTEP") throw std::runtime_error("reference parser: expected ITEM: TIMESTEP");
    f.timestep = std::stoll(lines[i + 1]);
    if (lines[i + 2] != "ITEM: NUMBER OF ATOMS") throw std::runtime_error("reference parser: expected NUMBER");
    f.natoms = std::stoull(lines[i + 3]);
    f.box_flags = lines[i + 4].substr(std::string("ITEM: BOX BOUNDS").size());
    for (int k = 0; k < 3; ++k) {
      std::istringstream is(lines[i + 5 + static_cast<size_t>(k)]);
      is >> f.bounds[k][0] >> f.bounds[k][1];
      if (!(is >> f.bounds[k][2])) f.bounds[k][2] = 0;
    }
    std::istringstream hs(lines[i + 8].substr(std::string("ITEM: ATOMS").size()));
    for (std::string c; hs >> c;) f.columns.push_back(c);
    i += 9;
    for (size_t a = 0; a < f.natoms; ++a, ++i) {
      std::istringstream is(lines.at(i));
      std::vector<double> row;
      for (std::string tok; is >> tok;) row.push_back(std::strtod(tok.c_str(), nullptr));
      f.rows.push_back(row);
    }
    frames.push_back(std::move(f));
  }
  return frames;
}

}  // namespace mds::textest
