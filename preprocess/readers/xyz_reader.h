// XYZ and extended XYZ reader (plain, .gz or .zst). The factory open_xyz_reader() is declared
// in reader_factories.h; this header exposes the comment-line parser for tests.
//
// Plain XYZ: line 1 the atom count, line 2 a comment, then `species x y z [extra...]`.
// Extended XYZ (the convention of libAtoms/QUIP and ASE, https://github.com/libAtoms/extxyz):
// the comment line holds key=value pairs, values optionally "quoted" or {braced};
// `Lattice="ax ay az bx by bz cx cy cz"` gives the cell vectors and
// `Properties=name:type:count:...` (type S, R, I or L) the per-atom columns, of which we use
// species (or Z / type), pos and radius. Frames follow each other back to back.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "readers/reader_factories.h"

namespace mds {

// One property of the Properties key.
struct XyzProperty {
  std::string name;
  char type = 'R';      // S, R, I or L
  int count = 1;        // number of columns
  int first_column = 0; // 0-based column of its first value in an atom line
};

// Parses `key=value key2="quoted value" flag` into key -> value (flags map to "T").
// Returns false on an unterminated quote/brace.
bool parse_extxyz_comment(std::string_view comment, std::map<std::string, std::string>& out);

// Parses a Properties value; on error returns false and sets `error`.
bool parse_extxyz_properties(std::string_view value, std::vector<XyzProperty>& out, std::string& error);

}  // namespace mds
