// External-memory Morton-prefix partitioning (see binning.h).
#include "convert/binning.h"

#include <algorithm>
#include <optional>

namespace mds::convert {

namespace {

Status scatter(TempDir& tmp, const Bin& source, const MortonGrid& grid, const PartitionOptions& opt,
               PartitionStats& stats, const std::function<void(uint64_t)>& on_records, std::vector<Bin>& out) {
  const int remaining_bits = kMortonBits - source.prefix_bits;
  if (remaining_bits <= 0)
    return make_error(Errc::budget,
                      "{} particles share one Morton cell at full resolution; the memory budget cannot hold them",
                      source.count);
  // Levels: enough that an even spread fits, at most max_levels_per_pass.
  int levels = 1;
  while (levels < opt.max_levels_per_pass && 3 * (levels + 1) <= remaining_bits &&
         (source.count >> (3 * levels)) > opt.max_bin_records / 2)
    ++levels;
  const int bits = 3 * levels;
  const uint32_t nbins = 1u << bits;
  const int shift = kMortonBits - source.prefix_bits - bits;

  // Buffers: half for the read chunk, half across the bin writers.
  const size_t chunk_records = std::max<size_t>(1024, opt.buffer_bytes / 2 / sizeof(SpillRecord));
  const size_t bin_buffer = std::max<size_t>(sizeof(SpillRecord) * 16, opt.buffer_bytes / 2 / nbins);

  MDS_ASSIGN_OR_RETURN(SpillReader reader, SpillReader::open(source.path));
  std::vector<std::optional<SpillWriter>> writers(nbins);
  std::vector<SpillRecord> chunk(std::min<uint64_t>(chunk_records, std::max<uint64_t>(1, source.count)));
  // The side column, read in step with the records and scattered alike (W words a record: an
  // eighth (W = 1) or a quarter (W = 2) of the records' buffers).
  const uint32_t W = source.side_path.empty() ? 0 : source.side_words;
  const bool side = W > 0;
  std::optional<SideSpillReader> preader;
  std::vector<std::optional<SideSpillWriter>> pwriters(side ? nbins : 0);
  std::vector<uint32_t> pchunk(side ? W * chunk.size() : 0);
  if (side) {
    MDS_ASSIGN_OR_RETURN(SideSpillReader pr, SideSpillReader::open(source.side_path));
    preader.emplace(std::move(pr));
  }
  const uint64_t mask = nbins - 1;
  ++stats.passes;
  for (;;) {
    MDS_ASSIGN_OR_RETURN(size_t n, reader.read(chunk));
    if (side) {
      MDS_ASSIGN_OR_RETURN(size_t pn, preader->read(std::span(pchunk).first(W * n)));
      if (pn != W * n)
        return make_error(Errc::internal, "{}: {} side words for {} records", source.side_path.string(), pn, n);
    }
    if (n == 0) break;
    for (size_t i = 0; i < n; ++i) {
      const SpillRecord& r = chunk[i];
      const uint32_t b = uint32_t((grid.key(r.x, r.y, r.z) >> shift) & mask);
      auto& w = writers[b];
      if (!w) {
        MDS_ASSIGN_OR_RETURN(auto path, tmp.file(fmt::format("bin-{}-{}-{}.rec", source.prefix_bits + bits,
                                                             (source.prefix << bits) | b, stats.passes)));
        MDS_ASSIGN_OR_RETURN(SpillWriter created, SpillWriter::create(path, bin_buffer));
        w.emplace(std::move(created));
        if (side) {
          MDS_ASSIGN_OR_RETURN(SideSpillWriter pcreated,
                               SideSpillWriter::create(path.string() + ".side", W * bin_buffer / 8));
          pwriters[b].emplace(std::move(pcreated));
        }
      }
      MDS_TRY(w->append(r));
      if (side) MDS_TRY(pwriters[b]->append(std::span<const uint32_t>(pchunk).subspan(W * i, W)));
    }
    stats.records_read += n;
    if (on_records) on_records(n);
  }
  if (reader.count() != source.count)
    return make_error(Errc::internal, "{}: expected {} records, found {}", source.path.string(), source.count,
                      reader.count());
  reader = SpillReader();
  preader.reset();
  std::error_code ec;
  std::filesystem::remove(source.path, ec);
  if (side) std::filesystem::remove(source.side_path, ec);

  // Close every bin first (frees the write buffers), then recurse into oversized ones.
  std::vector<Bin> bins;
  for (uint32_t b = 0; b < nbins; ++b) {
    if (!writers[b]) continue;
    MDS_TRY(writers[b]->close());
    bins.push_back({writers[b]->path(), writers[b]->count(), (source.prefix << bits) | b, source.prefix_bits + bits, {},
                    source.side_words});
    if (side) {
      MDS_TRY(pwriters[b]->close());
      bins.back().side_path = pwriters[b]->path();
      pwriters[b].reset();
    }
    writers[b].reset();
  }
  writers.clear();
  pwriters.clear();
  writers.shrink_to_fit();
  chunk = {};
  for (auto& bin : bins) {
    if (bin.count > opt.max_bin_records) {
      MDS_TRY(scatter(tmp, bin, grid, opt, stats, on_records, out));
    } else {
      out.push_back(std::move(bin));
    }
  }
  return {};
}

}  // namespace

Result<std::vector<Bin>> partition(TempDir& tmp, const Bin& source, const MortonGrid& grid,
                                   const PartitionOptions& options, PartitionStats& stats,
                                   const std::function<void(uint64_t)>& on_records) {
  if (options.max_bin_records == 0) return make_error(Errc::internal, "partition: max_bin_records is 0");
  std::vector<Bin> out;
  MDS_TRY(scatter(tmp, source, grid, options, stats, on_records, out));
  return out;
}

}  // namespace mds::convert
