// Pass A of the converter: parse every input once, validate, collect bounds, counts and types,
// and keep the 32-byte records in memory (when the declared count fits the budget) or spill
// them to a temporary file (spill.h). Reading overlaps with the processing of the previous
// batch: a reader thread fills a small ring of ParticleBatches (kReadAheadBatches) while the
// calling thread validates and stores the batch before. In memory, the pages of the record
// array are mapped ahead of the consumer on a third thread (BackgroundPrefault).
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "convert/big_buffer.h"
#include "convert/progress.h"
#include "convert/record_view.h"
#include "convert/spill.h"
#include "core/result.h"
#include "readers/raw_reader.h"
#include "readers/reader.h"

namespace mds::convert {

inline constexpr size_t kReadAheadBatches = 3;  // batches alive at once (one processed, two read ahead)

struct TypeStat {
  float radius = 0;
  uint64_t count = 0;
  std::string name;
};

struct ScanOptions {
  std::vector<std::filesystem::path> inputs;   // names for messages, one per reader
  float radius = 0.5f;                         // default radius of every type
  std::map<int32_t, float> radius_by_type;
  SideLayout side;                             // the readers fill ParticleBatch::property / color
  size_t batch_particles = 65536;
  size_t spill_buffer_bytes = 4 << 20;
  uint64_t max_memory_records = 0;             // more than this: spill
};

// Everything pass A learns about the input.
struct InputScan {
  uint64_t count = 0;
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                  -std::numeric_limits<double>::infinity()};
  bool per_particle_radius = false;
  float prad_min = std::numeric_limits<float>::infinity();
  float prad_max = 0;
  float property_min = std::numeric_limits<float>::infinity();   // over all particles, with side.property
  float property_max = -std::numeric_limits<float>::infinity();
  std::map<int32_t, TypeStat> types;
  bool in_memory = true;
  BigVector<SpillRecord> memory;          // in-memory path
  BigVector<uint32_t> memory_side;        // in-memory path with a side column: side.words() per record of memory
  std::unique_ptr<BackgroundPrefault> prefault;  // maps `memory`'s pages ahead of the reading
  std::optional<SpillWriter> spill;       // spill path (closed at the end of pass A)
  std::filesystem::path spill_path;
  std::optional<SideSpillWriter> spill_side;  // with a side column: parallel to spill
  std::filesystem::path spill_side_path;
};

// Reads every reader to its end (readers are released as they finish).
Status scan_inputs(const ScanOptions& o, std::vector<std::unique_ptr<ParticleReader>>& readers, TempDir& tmp,
                   InputScan& s, Progress& progress);

// Pass A for one raw float32 input that fits in memory: the file is mapped and validated in
// place (finite coordinates, bounds) on `threads` threads; no records are copied. `view`
// reads the mapping, which lives as long as `reader`. Same checks and messages as
// scan_inputs over the reader.
Status scan_raw_mapped(const ScanOptions& o, RawReader& reader, unsigned threads, InputScan& s, RawXyzRecords& view,
                       Progress& progress);

}  // namespace mds::convert
