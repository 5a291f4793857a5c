// Periodic images of the particles (`convert --replicate NA,NB,NC`), as LAMMPS' `replicate`
// command and OVITO's Replicate modifier: every particle is written NA x NB x NC times, at
// x + i a + j b + k c for 0 <= i < NA, 0 <= j < NB, 0 <= k < NC (a, b, c the cell vectors), and
// the cell becomes the one with vectors NA a, NB b, NC c at the same origin and periodicity. So
// a small simulation box makes a store as large as the data sets the renderer is for (10^8-10^9
// particles) from real simulation output.
//
// Streamed, with memory bounded by two batches (the input's and the one handed out): each batch
// of the input is handed out once per image (in parts when a call asks for fewer particles), the images in LAMMPS' order (i fastest, then j, then k: image index i + NA (j + NB k),
// the order LAMMPS numbers its replicated atom ids by). Image 0 is the batch as read, bit for
// bit; the others add the image's shift, i a + j b + k c summed in double, to each position.
// LAMMPS shifts the unwrapped position (its image flags added back) and wraps it into the new
// box; the positions here are shifted as read. Modulo the new cell both give the same copies of
// every atom, in another order where an atom has image flags (tests/test_replicate.cpp).
// Every other column (type, radius, id, property, colour) is copied unchanged (the store keeps
// no ids). Applied after --wrap (open_reader), so wrapped positions give images inside the
// new cell.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "core/cell.h"
#include "core/result.h"
#include "readers/reader.h"

namespace mds {

// Most particles a replicated frame may have: the text readers' limit on a declared count
// (kMaxTextAtoms, 2^40 ~ 1.1e12).
inline constexpr uint64_t kMaxReplicatedParticles = uint64_t{1} << 40;

// The images along a, b, c (each >= 1; {1, 1, 1}: no replication).
using ReplicateCounts = std::array<uint32_t, 3>;

// "2,2,2" or "2x2x2"; each count in 1..65536. Errc::invalid_argument otherwise.
Result<ReplicateCounts> parse_replicate_counts(const std::string& text);

// `cell` with its vectors multiplied by the counts (origin and periodicity as they are).
SimulationCell replicated_cell(const SimulationCell& cell, const ReplicateCounts& counts);

// `inner` with every particle written once per image (see above). Errc::invalid_argument naming
// `file` when the frame has no cell or one that is not finite (SimulationCell::finite), when the
// vectors along which there is more than one image have zero length or are parallel or coplanar
// (the images would lie on top of each other), or the grown cell is not finite; Errc::range when the replicated frame would have more than
// kMaxReplicatedParticles particles. read() is Errc::range naming the file and the particle
// whose shifted position is not finite.
Result<std::unique_ptr<ParticleReader>> replicate_reader(std::unique_ptr<ParticleReader> inner,
                                                         const ReplicateCounts& counts, const std::string& file);

}  // namespace mds
