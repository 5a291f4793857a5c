// The simulation cell (core/cell.h) in the commands' reports: one JSON object (`info --json`,
// `convert --json-report`) and one line of text.
#pragma once

#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/cell.h"

namespace mds::cli {

// {"origin": [x, y, z], "vectors": [a, b, c], "periodic": [bool, bool, bool], "orthogonal": bool}
inline nlohmann::json cell_json(const SimulationCell& c) {
  auto v = [](const double* x) { return nlohmann::json::array({x[0], x[1], x[2]}); };
  return {{"origin", v(c.origin)},
          {"vectors", nlohmann::json::array({v(c.vectors[0]), v(c.vectors[1]), v(c.vectors[2])})},
          {"periodic", nlohmann::json::array({c.periodic[0], c.periodic[1], c.periodic[2]})},
          {"orthogonal", c.orthogonal()}};
}

// "orthogonal 10 x 10 x 12 at (0, 0, 0), periodic x y" or
// "triclinic a (10, 0, 0) b (2, 9, 0) c (0, 0, 12) at (0, 0, 0), not periodic"
inline std::string cell_line(const SimulationCell& c) {
  auto v = [](const double* x) { return fmt::format("({:.6g}, {:.6g}, {:.6g})", x[0], x[1], x[2]); };
  std::string pbc;
  for (int d = 0; d < 3; ++d)
    if (c.periodic[d]) pbc += pbc.empty() ? std::string(1, "abc"[d]) : std::string(" ") + "abc"[d];
  pbc = pbc.empty() ? "not periodic" : "periodic along " + pbc;
  if (c.orthogonal())
    return fmt::format("orthogonal {:.6g} x {:.6g} x {:.6g} at {}, {}", c.vectors[0][0], c.vectors[1][1], c.vectors[2][2],
                       v(c.origin), pbc);
  return fmt::format("triclinic a {} b {} c {} at {}, {}", v(c.vectors[0]), v(c.vectors[1]), v(c.vectors[2]),
                     v(c.origin), pbc);
}

}  // namespace mds::cli
