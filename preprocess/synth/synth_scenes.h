// Scene plans: geometry and exact part counts of each built-in scene, as a list of chunks
// that the dump writer generates (in parallel) and writes in order.
#pragma once

#include <vector>

#include "synth/synth.h"
#include "synth/synth_parts.h"

namespace mds::synth {

struct Plan {
  SceneSummary summary;
  bool periodic[3] = {false, false, false};  // positions are wrapped into the box along these axes
  std::vector<Chunk> chunks;                  // in particle order; counts sum to summary.particles
};

Result<Plan> plan_scene(const SynthOptions& options);

// Maps a scene class (0 .. natural-1) to a LAMMPS type (1 .. types): classes are merged when
// types < natural, and split into disjoint groups of types (chosen by `key`) when types > natural.
int map_type(int cls, int natural, int types, uint64_t key);

}  // namespace mds::synth
