// Voxel-list and density-volume sections (format.h; docs/store-format.md, "Density volume and
// voxel lists"): uint32 arrays stored as LZ4 blocks of their byte planes, voxel indices delta
// coded first; the cell section (one CellRecord). Shared by the writer, the reader and the tests.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/cell.h"
#include "core/result.h"
#include "store/format.h"

namespace mds::store {

// Stored bytes of the voxel-list section (empty for no refs). refs.size() <= kMaxVoxelRefs.
Result<std::vector<uint8_t>> encode_voxel_section(std::span<const VoxelRef> refs);
// Decodes a block into `refs`, whose size (raw_bytes / 8) the caller has bounded. Errc::format
// "LZ4 block is corrupt (...)" when it does not decode to exactly 8 * refs.size() bytes.
Status decode_voxel_section(std::span<const uint8_t> block, std::span<VoxelRef> refs);

// Stored bytes of the density volume (empty for no grid). counts.size() <= 2^28.
Result<std::vector<uint8_t>> encode_density_section(std::span<const uint32_t> counts);
Status decode_density_section(std::span<const uint8_t> block, std::span<uint32_t> counts);

// The cell section's record of a cell (precondition: cell.finite()).
CellRecord encode_cell(const SimulationCell& cell);
// Its cell; Errc::format naming the field and its byte offset within the record when a value is
// not finite or a periodic/reserved bit is set.
Result<SimulationCell> decode_cell(const CellRecord& record);

}  // namespace mds::store
