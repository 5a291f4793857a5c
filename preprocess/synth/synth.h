// Built-in synthetic scenes modelled on the data sets of the source papers
// (Ibrahim et al., probabilistic occlusion culling, Table 2 / Fig. 1, 2, 6; Grottel et al.,
// Table 1): a laser-ablation slab with an expanding plume, a porous copper/silver block,
// a sparse gas, and a virus-like spherical shell (SARS-CoV-2 envelope with spikes).
//
// Scenes are written as LAMMPS text dumps (`ITEM: ATOMS id type x y z`) so that they go
// through the same reader as real LAMMPS output. Generation is procedural and streaming:
// lattice sites are enumerated row by row, random values come from a counter-based hash of
// (seed, particle id, frame), so memory stays bounded (O(N^(2/3)) bookkeeping) whatever N,
// and the output is identical for a given (scene, N, seed, types, frames) on every platform.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/result.h"

namespace mds::synth {

enum class Scene { ablation, porous, gas, shell };

const char* scene_name(Scene s);
std::optional<Scene> parse_scene(const std::string& name);
std::vector<std::string> scene_names();

struct SynthOptions {
  Scene scene = Scene::porous;
  uint64_t particles = 1'000'000;  // exact number of particles per frame (>= 1)
  uint64_t seed = 1;
  int types = 0;                   // number of particle types; 0 = the scene's natural count
  int frames = 1;                  // frames written; later frames carry small displacements
  int threads = 0;                 // worker threads; 0 = hardware concurrency (output does not depend on it)
  int gzip_level = 1;              // zlib level for .gz output
};

// What a scene consists of, known before any particle is written.
struct SceneSummary {
  Scene scene = Scene::porous;
  uint64_t particles = 0;
  int natural_types = 0;            // types the scene distinguishes (lattice/gas, Cu/Ag, lipid/protein/spike/RNA)
  int types = 0;                    // types written (options.types or natural_types)
  double box_lo[3] = {0, 0, 0};     // frame 0 box
  double box_hi[3] = {0, 0, 0};
  double box_growth_z = 0;          // box_hi[2] grows by this per frame (expanding plume)
  std::vector<std::pair<std::string, uint64_t>> parts;  // part name -> exact particle count
  std::map<std::string, double> geometry;               // scene-specific lengths (radii, heights)
};

// Plans a scene (geometry, exact part counts) without writing anything.
Result<SceneSummary> describe_scene(const SynthOptions& options);

// Writes the scene as a LAMMPS text dump to `path` (gzip-compressed when the name ends in
// ".gz"). The file is written to a temporary name next to `path` and renamed when complete.
// Returns the scene's summary (as describe_scene).
Result<SceneSummary> write_scene(const SynthOptions& options, const std::filesystem::path& path);

}  // namespace mds::synth
