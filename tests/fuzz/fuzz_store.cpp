// libFuzzer entry for the store reader: the input bytes become a file that StoreReader::open
// must either reject with an error value or accept, after which every node is read and
// decoded. Any crash, sanitizer report or hang is a bug in the reader's validation.
// Random bytes rarely get past the header hash, so for inputs of odd length the harness first
// recomputes every hash it can locate (payloads, sections, header): those inputs exercise the
// semantic checks, even-length inputs the checksum paths.
// Seed corpus: tests/data/store/golden_v2.mds, a store with a cell section (kFlagCell) that
// `convert --node-size 2` writes from an extended XYZ with a Lattice, and one with a property and
// its per-node histograms (kFlagPropertyHistogram: `convert --property c_pe --node-size 50` of
// tests/data/lammps/in.void_small's dump). Built only with -DMDSTREAM_FUZZ=ON (clang).
#include <cstring>
#include <vector>

#include "fuzz_harness.h"
#include "store/format.h"
#include "store/hash.h"
#include "store/property_histogram.h"
#include "store/store_reader.h"
#include "store/threshold.h"

namespace {

// Recomputes the payload, section and header hashes of `b` where their ranges lie inside it.
void fix_hashes(std::vector<uint8_t>& b) {
  using namespace mds::store;
  if (b.size() < sizeof(FileHeader)) return;
  FileHeader h;
  std::memcpy(&h, b.data(), sizeof(h));
  auto inside = [&](uint64_t off, uint64_t n) { return off <= b.size() && n <= b.size() - off; };
  const Section& dir = h.sections[kSectionDirectory];
  if (inside(dir.offset, dir.bytes)) {
    for (uint64_t i = 0; i + sizeof(NodeEntry) <= dir.bytes; i += sizeof(NodeEntry)) {
      NodeEntry e;
      std::memcpy(&e, b.data() + dir.offset + i, sizeof(e));
      if (!inside(e.payload_offset, e.payload_bytes)) continue;
      e.payload_hash = hash_bytes({b.data() + e.payload_offset, e.payload_bytes});
      std::memcpy(b.data() + dir.offset + i, &e, sizeof(e));
    }
  }
  for (auto& s : h.sections)
    if (inside(s.offset, s.bytes)) s.hash = hash_bytes({b.data() + s.offset, size_t(s.bytes)});
  if ((h.flags & kFlagCell) && inside(h.cell.offset, h.cell.bytes)) h.cell.hash = hash_bytes({b.data() + h.cell.offset, size_t(h.cell.bytes)});
  const Section& ph = h.property_histograms;
  if ((h.flags & kFlagPropertyHistogram) && inside(ph.offset, ph.bytes))
    h.property_histograms.hash = hash_bytes({b.data() + ph.offset, size_t(ph.bytes)});
  h.header_hash = 0;
  h.header_hash = hash_bytes({reinterpret_cast<const uint8_t*>(&h), sizeof(h)});
  std::memcpy(b.data(), &h, sizeof(h));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto& path = mds::fuzz::input_path("mdstream_fuzz_store", ".mds");
  {
    std::vector<uint8_t> bytes(data, data + size);
    if (size % 2 == 1) fix_hashes(bytes);
    mds::fuzz::write_input(path, bytes.data(), bytes.size());
  }
  auto reader = mds::store::StoreReader::open(path);
  if (reader.ok()) {
    mds::store::NodeData node;
    std::vector<uint8_t> scratch;
    const auto& r = **reader;
    // A threshold over the middle of the property's range, as a streaming render asks of each
    // node's histogram.
    const std::vector<uint32_t> prefix = mds::store::kept_prefix_sums(mds::store::threshold_table(
        {double(r.header().property_min), 0.5 * (double(r.header().property_min) + double(r.header().property_max)), false},
        r.header().property_min, r.header().property_max));
    const auto histograms = r.property_histograms();
    for (uint32_t i = 0; i < r.nodes().size(); ++i) {
      if (r.read_node(i, node, scratch).ok()) (void)r.verify_property_histogram(i, node);
      (void)r.voxels(i);
      if (i < histograms.size()) (void)mds::store::property_cover(histograms[i], prefix);
    }
    (void)r.density_counts();
  }
  return 0;
}
