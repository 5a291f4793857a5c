#include "readers/reader.h"

namespace mds {

const char* input_format_name(InputFormat f) {
  switch (f) {
    case InputFormat::automatic: return "auto";
    case InputFormat::lammps: return "lammps";
    case InputFormat::xyz: return "xyz";
    case InputFormat::h5md: return "h5md";
    case InputFormat::mmpld: return "mmpld";
    case InputFormat::raw: return "raw";
  }
  return "unknown";
}

std::optional<InputFormat> parse_input_format(const std::string& name) {
  for (auto f : {InputFormat::automatic, InputFormat::lammps, InputFormat::xyz, InputFormat::h5md,
                 InputFormat::mmpld, InputFormat::raw}) {
    if (name == input_format_name(f)) return f;
  }
  if (name == "lammpstrj" || name == "dump") return InputFormat::lammps;
  return std::nullopt;
}

}  // namespace mds
