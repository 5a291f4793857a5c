// LAMMPS text dump reader (dump atom/custom: ITEM: TIMESTEP / NUMBER OF ATOMS / BOX BOUNDS /
// ATOMS <columns>), plain, .gz or .zst. The factory open_lammps_reader() is declared in
// reader_factories.h; this header exposes the box conversion for tests and other readers.
//
// Box conventions follow the LAMMPS manual, "Howto triclinic" (dump file box section):
// a triclinic dump writes the bounding box plus the tilt factors,
//   xlo_bound xhi_bound xy / ylo_bound yhi_bound xz / zlo_bound zhi_bound yz
// and the box itself is recovered as
//   xlo = xlo_bound - min(0, xy, xz, xy+xz), xhi = xhi_bound - max(0, xy, xz, xy+xz),
//   ylo = ylo_bound - min(0, yz),            yhi = yhi_bound - max(0, yz),
//   zlo = zlo_bound,                         zhi = zhi_bound.
// Scaled coordinates map to Cartesian ones with the edge vectors
//   a = (lx, 0, 0), b = (xy, ly, 0), c = (xz, yz, lz):
//   x = xlo + xs*lx + ys*xy + zs*xz,  y = ylo + ys*ly + zs*yz,  z = zlo + zs*lz.
#pragma once

#include <string_view>
#include <vector>

#include "readers/reader_factories.h"

namespace mds {

struct LammpsBox {
  bool triclinic = false;
  double lo[3] = {0, 0, 0};        // xlo, ylo, zlo of the (restricted triclinic) box
  double hi[3] = {0, 0, 0};
  double xy = 0, xz = 0, yz = 0;   // tilt factors
  double bound_lo[3] = {0, 0, 0};  // bounding box as the dump writes it
  double bound_hi[3] = {0, 0, 0};

  // Cartesian position of the scaled (fractional) coordinates s.
  void scaled_to_cartesian(const double s[3], double out[3]) const {
    const double lx = hi[0] - lo[0], ly = hi[1] - lo[1], lz = hi[2] - lo[2];
    out[0] = lo[0] + s[0] * lx + s[1] * xy + s[2] * xz;
    out[1] = lo[1] + s[1] * ly + s[2] * yz;
    out[2] = lo[2] + s[2] * lz;
  }
  // The cell: origin lo, edge vectors a, b, c above; `periodic` from the boundary flags.
  SimulationCell cell(const bool periodic[3]) const;
};

// Periodicity from the flags after `ITEM: BOX BOUNDS` (`pp ff fs`, after `xy xz yz` when
// triclinic): "pp" is periodic, anything else (f, s, m) is not; missing flags: not periodic.
void lammps_periodic_from_flags(const std::vector<std::string_view>& flags, bool periodic[3]);

// Box from the three BOX BOUNDS lines: bounds[i] = {lo_bound, hi_bound, tilt} (tilt only
// read when triclinic; the tilts are xy, xz, yz in line order).
LammpsBox lammps_box_from_bounds(const double bounds[3][3], bool triclinic);

// The inverse of LammpsBox::cell, for writing a dump: the box of a cell LAMMPS can hold, a
// restricted triclinic one (a = (lx, 0, 0), b = (xy, ly, 0), c = (xz, yz, lz), lx, ly, lz > 0),
// triclinic when a tilt is not zero, with the bounding box the dump writes. Errc::unsupported
// naming the edge vectors for any other cell (rotated, left-handed or flat).
Result<LammpsBox> lammps_box_from_cell(const SimulationCell& cell);

}  // namespace mds
