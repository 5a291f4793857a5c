// Hostile input for StoreReader: truncated files, flipped bytes in every region, and
// deliberately inconsistent fields in otherwise well-formed files (hashes recomputed so the
// semantic checks, not the checksums, must catch them). Every case must fail with an error
// value naming the place; none may crash (run under ASan/UBSan in the sanitizer build).
#include <gtest/gtest.h>

#include <lz4.h>

#include <bit>

#include "store/hash.h"
#include "store/payload_codec.h"
#include "store/section_codec.h"
#include "store/store_reader.h"
#include "store/store_writer.h"
#include "store_test_helpers.h"

using namespace mds;
using namespace mds::store;

namespace {

// A store file taken apart into its pieces, to be changed and put back together.
struct Image {
  FileHeader h;
  std::vector<std::vector<uint8_t>> payloads;
  std::vector<TypeEntry> types;
  std::vector<NodeEntry> nodes;
  std::vector<VoxelRef> voxels;       // decoded voxel lists
  std::vector<uint8_t> voxel_block;   // stored voxel section (fix_layout re-encodes it from `voxels`)
  std::vector<uint8_t> density;
  std::vector<uint8_t> occupancy;     // kOccupancyBytes per node
  std::vector<uint8_t> trailing;
};

template <class T>
std::vector<T> slice(const std::vector<uint8_t>& b, const Section& s) {
  std::vector<T> v(s.bytes / sizeof(T));
  std::memcpy(v.data(), b.data() + s.offset, v.size() * sizeof(T));
  return v;
}

Image parse(const std::vector<uint8_t>& b) {
  Image im;
  std::memcpy(&im.h, b.data(), sizeof(FileHeader));
  im.types = slice<TypeEntry>(b, im.h.sections[kSectionTypes]);
  im.nodes = slice<NodeEntry>(b, im.h.sections[kSectionDirectory]);
  im.voxel_block = slice<uint8_t>(b, im.h.sections[kSectionVoxels]);
  im.voxels.resize(im.h.sections[kSectionVoxels].raw_bytes / sizeof(VoxelRef));
  EXPECT_TRUE(decode_voxel_section(im.voxel_block, im.voxels).ok());
  im.density = slice<uint8_t>(b, im.h.sections[kSectionDensity]);
  im.occupancy = slice<uint8_t>(b, im.h.sections[kSectionOccupancy]);
  for (const auto& e : im.nodes)
    im.payloads.emplace_back(b.begin() + long(e.payload_offset), b.begin() + long(e.payload_offset + e.payload_bytes));
  return im;
}

// Makes offsets, sizes and hashes consistent with the content.
void fix_layout(Image& im) {
  auto block = encode_voxel_section(im.voxels);
  EXPECT_TRUE(block.ok());
  im.voxel_block = *block;
  im.h.sections[kSectionVoxels].raw_bytes = im.voxels.size() * sizeof(VoxelRef);
  uint64_t off = kHeaderBytes, total = 0;
  for (size_t i = 0; i < im.nodes.size(); ++i) {
    im.nodes[i].payload_offset = off;
    im.nodes[i].payload_bytes = uint32_t(im.payloads[i].size());
    im.nodes[i].payload_hash = hash_bytes(im.payloads[i]);
    off += im.payloads[i].size();
    total += im.payloads[i].size();
  }
  im.h.payload_bytes = total;
  const uint64_t sizes[kSectionCount] = {im.types.size() * sizeof(TypeEntry), im.nodes.size() * sizeof(NodeEntry),
                                         im.voxel_block.size(), im.density.size(), im.occupancy.size()};
  for (int s = 0; s < int(kSectionCount); ++s) {
    im.h.sections[s].offset = off;
    im.h.sections[s].bytes = sizes[s];
    if (s == kSectionTypes || s == kSectionDirectory || s == kSectionOccupancy) im.h.sections[s].raw_bytes = sizes[s];
    off += sizes[s];
  }
}

template <class T>
uint64_t hash_vec(const std::vector<T>& v) {
  return hash_bytes({reinterpret_cast<const uint8_t*>(v.data()), v.size() * sizeof(T)});
}

// Recomputes section hashes and the header hash only (keeps whatever lies the test put in).
void seal(Image& im) {
  im.h.sections[kSectionTypes].hash = hash_vec(im.types);
  im.h.sections[kSectionDirectory].hash = hash_vec(im.nodes);
  im.h.sections[kSectionVoxels].hash = hash_vec(im.voxel_block);
  im.h.sections[kSectionDensity].hash = hash_vec(im.density);
  im.h.sections[kSectionOccupancy].hash = hash_vec(im.occupancy);
  im.h.header_hash = 0;
  im.h.header_hash = hash_bytes({reinterpret_cast<const uint8_t*>(&im.h), sizeof(im.h)});
}

std::vector<uint8_t> serialize(const Image& im) {
  std::vector<uint8_t> b(sizeof(FileHeader));
  std::memcpy(b.data(), &im.h, sizeof(FileHeader));
  auto put = [&](const void* p, size_t n) {
    const auto* c = static_cast<const uint8_t*>(p);
    b.insert(b.end(), c, c + n);
  };
  for (const auto& p : im.payloads) put(p.data(), p.size());
  put(im.types.data(), im.types.size() * sizeof(TypeEntry));
  put(im.nodes.data(), im.nodes.size() * sizeof(NodeEntry));
  put(im.voxel_block.data(), im.voxel_block.size());
  put(im.density.data(), im.density.size());
  put(im.occupancy.data(), im.occupancy.size());
  put(im.trailing.data(), im.trailing.size());
  return b;
}

class Corruption : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = mds::testing::temp_dir("corrupt", /*in_memory=*/true);
    mds::testing::SynthOptions o;
    o.particles = 90;
    o.node_size = 30;
    o.meshlet_size = 8;
    o.per_particle_radius = true;
    o.grid = 2;
    auto s = mds::testing::make_synthetic(o);
    ASSERT_EQ(mds::testing::write_store(s, dir_ / "good.mds"), "");
    good_ = mds::testing::read_bytes(dir_ / "good.mds");
    auto r = StoreReader::open(dir_ / "good.mds");
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ((*r)->nodes().size(), 3u);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // Opens `bytes` and reads every node; returns the first error (or nullopt if all succeeded).
  std::optional<Error> try_all(const std::vector<uint8_t>& bytes) {
    const auto p = dir_ / "bad.mds";
    mds::testing::write_bytes(p, bytes);
    auto r = StoreReader::open(p);
    if (!r.ok()) return r.error();
    NodeData d;
    std::vector<uint8_t> scratch;
    for (uint32_t i = 0; i < (*r)->nodes().size(); ++i) {
      Status st = (*r)->read_node(i, d, scratch);
      if (!st.ok()) return st.error();
    }
    return std::nullopt;
  }

  // Expects failure at open() with `code`, with every `needles` in the message.
  void expect_open_error(const Image& im, Errc code, std::vector<std::string> needles) {
    auto err = try_all(serialize(im));
    ASSERT_TRUE(err.has_value()) << "corruption was not detected";
    EXPECT_EQ(err->code, code) << errc_name(err->code) << ": " << err->message;
    EXPECT_NE(err->message.find("bad.mds"), std::string::npos) << err->message;
    for (const auto& n : needles) EXPECT_NE(err->message.find(n), std::string::npos) << "want '" << n << "' in: " << err->message;
  }

  std::filesystem::path dir_;
  std::vector<uint8_t> good_;
};

TEST_F(Corruption, RebuiltGoodImageIsByteIdentical) {
  Image im = parse(good_);
  fix_layout(im);
  seal(im);
  EXPECT_EQ(serialize(im), good_);
  EXPECT_FALSE(try_all(good_).has_value());
}

TEST_F(Corruption, EveryTruncatedPrefixFails) {
  for (size_t len = 0; len < good_.size(); ++len) {
    std::vector<uint8_t> b(good_.begin(), good_.begin() + long(len));
    auto err = try_all(b);
    ASSERT_TRUE(err.has_value()) << "prefix of " << len << " bytes accepted";
    EXPECT_NE(err->message.find("bad.mds"), std::string::npos) << err->message;
  }
}

TEST_F(Corruption, EveryFlippedByteIsDetected) {
  // Any single-bit change anywhere in the file is caught by a hash (header, section or payload).
  for (size_t i = 0; i < good_.size(); ++i) {
    auto b = good_;
    b[i] ^= uint8_t(1u << (i % 8));
    auto err = try_all(b);
    ASSERT_TRUE(err.has_value()) << "flip at byte " << i << " accepted";
  }
}

TEST_F(Corruption, FlippedPayloadByteNamesNodeAndOffset) {
  Image im = parse(good_);
  for (uint32_t node = 0; node < 3; ++node) {
    auto b = good_;
    const uint64_t off = im.nodes[node].payload_offset;
    b[off + im.nodes[node].payload_bytes / 2] ^= 0x10;
    mds::testing::write_bytes(dir_ / "bad.mds", b);
    auto r = StoreReader::open(dir_ / "bad.mds");
    ASSERT_TRUE(r.ok()) << "payloads are checked on read, not on open: " << r.error().message;
    NodeData d;
    std::vector<uint8_t> scratch;
    for (uint32_t i = 0; i < 3; ++i) {
      Status st = (*r)->read_node(i, d, scratch);
      if (i != node) {
        EXPECT_TRUE(st.ok()) << st.error().message;
        continue;
      }
      ASSERT_FALSE(st.ok());
      EXPECT_EQ(st.error().code, Errc::checksum);
      EXPECT_NE(st.error().message.find("bad.mds: node " + std::to_string(node) + " payload at byte " + std::to_string(off) +
                                        ": checksum mismatch"),
                std::string::npos)
          << st.error().message;
    }
  }
}

TEST_F(Corruption, FlippedSectionByteIsChecksumError) {
  Image im = parse(good_);
  const char* names[kSectionCount] = {"type table", "node directory", "voxel lists", "density volume", "occupancy"};
  for (int s = 0; s < int(kSectionCount); ++s) {
    auto b = good_;
    b[im.h.sections[s].offset + im.h.sections[s].bytes / 2] ^= 0x01;
    auto err = try_all(b);
    ASSERT_TRUE(err.has_value()) << names[s];
    EXPECT_EQ(err->code, Errc::checksum) << err->message;
    EXPECT_NE(err->message.find(names[s]), std::string::npos) << err->message;
    EXPECT_NE(err->message.find(std::to_string(im.h.sections[s].offset)), std::string::npos) << err->message;
  }
}

TEST_F(Corruption, HeaderLies) {
  auto with = [&](auto mutate) {
    Image im = parse(good_);
    mutate(im);
    seal(im);
    return im;
  };
  expect_open_error(with([](Image& im) { im.h.magic[0] = 'X'; }), Errc::format, {"magic", "byte 0"});
  expect_open_error(with([](Image& im) { im.h.version = 3; }), Errc::unsupported, {"version", "byte 8"});
  // Version 1 (no occupancy section) is no longer read: convert the input again.
  expect_open_error(with([](Image& im) { im.h.version = 1; }), Errc::unsupported, {"version", "byte 8", "convert"});
  expect_open_error(with([](Image& im) { im.h.header_bytes = 1024; }), Errc::format, {"header_bytes", "byte 12"});
  {
    Image im = parse(good_);
    im.h.particle_count += 1;  // not resealed
    expect_open_error(im, Errc::checksum, {"header_hash", "byte 504"});
  }
  // The lowest bit no flag uses (the known flags are bits 0 .. k).
  expect_open_error(with([](Image& im) { im.h.flags |= store::kKnownFlags + 1; }), Errc::unsupported, {"flags"});
  expect_open_error(with([](Image& im) { im.h.reserved[10] = 1; }), Errc::format, {"reserved", "byte 490"});
  // The cell section's entry is reserved without kFlagCell.
  expect_open_error(with([](Image& im) { im.h.cell.bytes = 128; }), Errc::format, {"field cell at byte 424", "cell flag"});
  // The property histograms' entry is reserved without kFlagPropertyHistogram.
  expect_open_error(with([](Image& im) { im.h.property_histograms.hash = 5; }), Errc::format,
                    {"field property_histograms at byte 472", "histogram flag"});
  // The property's fields are reserved bytes without kFlagProperty.
  expect_open_error(with([](Image& im) { im.h.property_name[3] = 'a'; }), Errc::format, {"property_name", "byte 363"});
  expect_open_error(with([](Image& im) { im.h.property_max = 1.0f; }), Errc::format, {"property_max", "byte 414"});
  expect_open_error(with([](Image& im) { im.h.node_count = 1u << 31; }), Errc::range, {"particle_count"});
  expect_open_error(with([](Image& im) {
                      im.h.node_count = 1u << 31;
                      im.h.particle_count = uint64_t(1) << 31;
                      im.h.meshlet_count = uint64_t(1) << 31;
                    }),
                    Errc::range, {"payload_bytes", "2147483648 nodes"});
  expect_open_error(with([](Image& im) { im.h.node_count = 4; }), Errc::format, {"sections[1].bytes", "node_count * 112"});
  expect_open_error(with([](Image& im) { im.h.type_count = 300; }), Errc::range, {"type_count", "byte 48"});
  expect_open_error(with([](Image& im) { im.h.type_count = 5; }), Errc::format, {"sections[0].bytes"});
  expect_open_error(with([](Image& im) { im.h.node_size_max = 0; }), Errc::range, {"node_size_max", "byte 20"});
  expect_open_error(with([](Image& im) { im.h.node_size_max = 70000; }), Errc::range, {"node_size_max"});
  expect_open_error(with([](Image& im) { im.h.meshlet_size_max = 256; }), Errc::range, {"meshlet_size_max", "byte 24"});
  expect_open_error(with([](Image& im) { im.h.meshlet_size_max = 4; }), Errc::range, {"node 0", "meshlet_count"});
  expect_open_error(with([](Image& im) { im.h.node_size_max = 20; }), Errc::range, {"particle_count", "byte 32"});
  expect_open_error(with([](Image& im) {
                      im.h.density_dims[0] = 1u << 20;
                      im.h.density_dims[1] = 1u << 20;
                    }),
                    Errc::range, {"density_dims", "byte 52"});
  expect_open_error(with([](Image& im) { im.h.density_dims[2] = 0; }), Errc::range, {"density_dims"});
  expect_open_error(with([](Image& im) { im.h.density_dims[2] = 3; }), Errc::format, {"sections[3].raw_bytes"});
  expect_open_error(with([](Image& im) { im.h.bounds_min[1] = std::nan(""); }), Errc::range, {"bounds"});
  expect_open_error(with([](Image& im) { im.h.bounds_min[2] = im.h.bounds_max[2] + 1; }), Errc::range, {"bounds_min", "byte 80"});
  expect_open_error(with([](Image& im) { im.h.radius_min = -1; }), Errc::range, {"radius_min"});
  expect_open_error(with([](Image& im) { im.h.max_quantization_error = INFINITY; }), Errc::range, {"max_quantization_error"});
  expect_open_error(with([](Image& im) { im.h.particle_count -= 1; }), Errc::range, {"type 2", "store's 89"});
  expect_open_error(with([](Image& im) { im.h.meshlet_count += 1; }), Errc::range, {"meshlet_count"});
  expect_open_error(with([](Image& im) { im.h.payload_raw_bytes += 1; }), Errc::range, {"payload_raw_bytes"});
  expect_open_error(with([](Image& im) { im.h.payload_bytes = uint64_t(1) << 62; }), Errc::range, {"payload_bytes", "byte 184"});
}

TEST_F(Corruption, SectionLies) {
  auto with = [&](auto mutate) {
    Image im = parse(good_);
    mutate(im);
    seal(im);
    return im;
  };
  expect_open_error(with([](Image& im) { im.h.sections[kSectionDensity].offset += 1ull << 40; }), Errc::range,
                    {"sections[3].offset", "byte 296"});
  expect_open_error(with([](Image& im) { im.h.sections[kSectionDensity].bytes = 1ull << 40; }), Errc::range,
                    {"sections[3].bytes", "past the end"});
  expect_open_error(with([](Image& im) { im.h.sections[kSectionTypes].offset -= 8; }), Errc::range,
                    {"sections[0].offset"});
  expect_open_error(with([](Image& im) { im.h.sections[kSectionTypes].offset = 0; }), Errc::range,
                    {"sections[0].offset"});  // overlapping the header
  // Voxel section: decoded size not a multiple of 8, more refs than particles, or a block that
  // does not decode to the declared size.
  expect_open_error(with([](Image& im) { im.h.sections[kSectionVoxels].raw_bytes += 4; }), Errc::format,
                    {"sections[2].raw_bytes", "byte 280"});
  expect_open_error(with([](Image& im) { im.h.sections[kSectionVoxels].raw_bytes = 8 * (im.h.particle_count + 1); }),
                    Errc::format, {"sections[2].raw_bytes"});
  expect_open_error(with([](Image& im) { im.h.sections[kSectionVoxels].raw_bytes += 8; }), Errc::format,
                    {"voxel lists at byte", "LZ4"});
  expect_open_error(with([](Image& im) { im.h.sections[kSectionVoxels].raw_bytes = 0; }), Errc::format, {"sections[2].bytes"});
  expect_open_error(with([](Image& im) { im.trailing = {1, 2, 3}; }), Errc::format, {"after the last section"});
  // Occupancy: 64 bytes per node, and every node occupies some cell.
  expect_open_error(with([](Image& im) {
                      im.occupancy.resize(im.occupancy.size() - 1);
                      im.h.sections[kSectionOccupancy].bytes -= 1;
                      im.h.sections[kSectionOccupancy].raw_bytes -= 1;
                    }),
                    Errc::format, {"sections[4].bytes", "node_count * 64"});
  expect_open_error(with([](Image& im) { std::fill(im.occupancy.begin() + 64, im.occupancy.begin() + 128, 0); }),
                    Errc::format, {"node 1 occupancy", "byte " + std::to_string(parse(good_).h.sections[kSectionOccupancy].offset + 64)});
  expect_open_error(with([](Image& im) {
                      // move the payload/section boundary: payloads claim one byte of the type table
                      im.h.payload_bytes += 1;
                    }),
                    Errc::range, {"sections[0].offset"});
}

TEST_F(Corruption, DirectoryLies) {
  auto with = [&](auto mutate) {
    Image im = parse(good_);
    mutate(im);
    seal(im);
    return im;
  };
  const uint64_t dir = parse(good_).h.sections[kSectionDirectory].offset;
  auto at = [&](int node, size_t field) { return "byte " + std::to_string(dir + 112 * node + field); };
  // Overlapping payloads: node 1 starts inside node 0.
  expect_open_error(with([](Image& im) { im.nodes[1].payload_offset -= 4; }), Errc::range,
                    {"node 1", "payload_offset", at(1, 0)});
  expect_open_error(with([](Image& im) { im.nodes[2].payload_offset = 0; }), Errc::range, {"node 2", "payload_offset"});
  expect_open_error(with([](Image& im) { im.nodes[0].payload_bytes += 1; }), Errc::range, {"node 1", "payload_offset"});
  expect_open_error(with([](Image& im) { im.nodes[2].payload_bytes = 0xFFFFFFF0u; }), Errc::range, {"node 2", "payload_bytes"});
  expect_open_error(with([](Image& im) {
                      const NodeEntry& e = im.nodes[0];
                      im.nodes[0].payload_raw_bytes = uint32_t(node_payload_max_bytes(e.particle_count, e.meshlet_count, true) + 1);
                    }),
                    Errc::format, {"node 0", "payload_raw_bytes"});
  expect_open_error(with([](Image& im) {
                      const NodeEntry& e = im.nodes[0];
                      im.nodes[0].payload_raw_bytes = uint32_t(node_payload_fixed_bytes(e.particle_count, e.meshlet_count, true) - 1);
                    }),
                    Errc::format, {"node 0", "payload_raw_bytes"});
  {  // a raw size inside the bounds but not the block's: caught when the node is read
    auto err = try_all(serialize(with([](Image& im) {
      im.nodes[0].payload_raw_bytes -= 1;
      im.h.payload_raw_bytes -= 1;
    })));
    ASSERT_TRUE(err.has_value());
    EXPECT_EQ(err->code, Errc::format) << err->message;
    EXPECT_NE(err->message.find("node 0 payload at byte 512: LZ4"), std::string::npos) << err->message;
  }
  expect_open_error(with([](Image& im) { im.nodes[1].particle_count = 0; }), Errc::range, {"node 1", "particle_count", at(1, 24)});
  expect_open_error(with([](Image& im) {
                      im.nodes[0].particle_count += 1;  // 31 > node_size_max 30
                      im.nodes[1].particle_count -= 1;
                    }),
                    Errc::range, {"node 0", "particle_count", "node_size_max=30"});
  expect_open_error(with([](Image& im) { im.nodes[1].meshlet_count = 0; }), Errc::range, {"node 1", "meshlet_count"});
  expect_open_error(with([](Image& im) { im.nodes[1].first_particle += 1; }), Errc::range, {"node 1", "first_particle", at(1, 32)});
  expect_open_error(with([](Image& im) { im.nodes[2].first_meshlet = 0; }), Errc::range, {"node 2", "first_meshlet"});
  expect_open_error(with([](Image& im) { im.nodes[0].center_max[0] = std::nan(""); }), Errc::range, {"node 0"});
  expect_open_error(with([](Image& im) { im.nodes[0].center_min[1] = im.nodes[0].center_max[1] + 1; }), Errc::range,
                    {"node 0", "center_min"});
  expect_open_error(with([](Image& im) { im.nodes[2].max_radius = -1; }), Errc::range, {"node 2", "max_radius"});
  expect_open_error(with([](Image& im) { im.nodes[1].voxel_first += 1; }), Errc::range, {"node 1", "voxel_first"});
  expect_open_error(with([](Image& im) { im.nodes[2].voxel_count = 1000; }), Errc::range, {"node 2", "voxel_count"});
  expect_open_error(with([](Image& im) { im.nodes[2].reserved = 9; }), Errc::format, {"node 2", "reserved"});
  expect_open_error(with([](Image& im) { im.types[1].radius = std::nan(""); }), Errc::range, {"type 1", "radius"});
  expect_open_error(with([](Image& im) { std::memset(im.types[0].name, 'A', 48); }), Errc::format, {"type 0", "name"});
  expect_open_error(with([](Image& im) { im.types[0].particle_count += 1; }), Errc::range, {"type"});
}

TEST_F(Corruption, VoxelAndDensityLies) {
  auto with = [&](auto mutate) {
    Image im = parse(good_);
    mutate(im);
    fix_layout(im);  // re-encodes the voxel section from the (lying) refs
    seal(im);
    return im;
  };
  expect_open_error(with([](Image& im) { im.voxels[0].voxel = 8; }), Errc::range, {"node 0", "voxel ref 0", "outside"});
  expect_open_error(with([](Image& im) { im.voxels[0].voxel = 0xFFFFFFFFu; }), Errc::range, {"voxel ref 0"});
  expect_open_error(with([](Image& im) { im.voxels[0].count = 0; }), Errc::range, {"node 0", "voxel ref 0"});
  expect_open_error(with([](Image& im) { im.voxels[0].count += 1; }), Errc::range, {"node 0"});
  ASSERT_GE(parse(good_).nodes[0].voxel_count, 2u);
  expect_open_error(with([](Image& im) { std::swap(im.voxels[0], im.voxels[1]); }), Errc::format,
                    {"node 0", "voxel ref 1", "not strictly ascending"});
  // Voxel block that is not valid LZ4.
  {
    Image im = parse(good_);
    std::fill(im.voxel_block.begin(), im.voxel_block.end(), 0xFF);
    seal(im);
    expect_open_error(im, Errc::format, {"voxel lists at byte", "LZ4"});
  }
  // Density volume that decodes fine but disagrees with the voxel lists.
  expect_open_error(with([](Image& im) {
                      std::vector<uint32_t> counts(8);
                      ASSERT_TRUE(decode_density_section(im.density, counts).ok());
                      counts[7] += 1;
                      im.density = *encode_density_section(counts);
                    }),
                    Errc::range, {"density volume", "voxel 7"});
  // Density block that is not valid LZ4.
  expect_open_error(with([](Image& im) { std::fill(im.density.begin(), im.density.end(), 0xFF); }), Errc::format,
                    {"density volume", "LZ4"});
}

// Payloads whose hashes match but whose content is wrong: decode must reject them.
// An occupancy record that lacks a cell the node's particles reach (but is not empty) opens and
// decodes; verify_occupancy (mdstream info --verify) names the node, the record and the byte.
TEST_F(Corruption, OccupancyRecordMissingACellIsFoundByVerify) {
  Image im = parse(good_);
  const uint64_t base = im.h.sections[kSectionOccupancy].offset;
  // Clear the first set bit of node 1's record, keeping another one set.
  size_t byte = 64;
  while (byte < 128 && im.occupancy[byte] == 0) ++byte;
  ASSERT_LT(byte, 128u);
  const uint8_t bit = uint8_t(im.occupancy[byte] & -im.occupancy[byte]);
  im.occupancy[byte] = uint8_t(im.occupancy[byte] & ~bit);
  size_t set = 0;
  for (size_t b = 64; b < 128; ++b) set += size_t(std::popcount(unsigned(im.occupancy[b])));
  ASSERT_GT(set, 0u) << "node 1's record would be empty";
  seal(im);
  EXPECT_FALSE(try_all(serialize(im)).has_value()) << "open and decode do not check the record's content";
  auto r = StoreReader::open(dir_ / "bad.mds");
  ASSERT_TRUE(r.ok());
  NodeData d;
  std::vector<uint8_t> scratch;
  ASSERT_TRUE((*r)->read_node(0, d, scratch).ok());
  EXPECT_TRUE((*r)->verify_occupancy(0, d).ok());
  ASSERT_TRUE((*r)->read_node(1, d, scratch).ok());
  Status st = (*r)->verify_occupancy(1, d);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, Errc::format);
  for (const std::string& n : {std::string("bad.mds"), std::string("node 1 occupancy"), "byte " + std::to_string(base + 64),
                              "byte " + std::to_string(byte - 64) + " lacks"})
    EXPECT_NE(st.error().message.find(n), std::string::npos) << n << " in: " << st.error().message;
  // The good file passes for every node.
  auto g = StoreReader::open(dir_ / "good.mds");
  ASSERT_TRUE(g.ok());
  for (uint32_t i = 0; i < (*g)->nodes().size(); ++i) {
    ASSERT_TRUE((*g)->read_node(i, d, scratch).ok());
    EXPECT_TRUE((*g)->verify_occupancy(i, d).ok()) << i;
  }
}

TEST_F(Corruption, PayloadContentLies) {
  Image base = parse(good_);
  std::vector<uint32_t> counts;
  auto decode_raw = [&](uint32_t i) {
    std::vector<uint8_t> raw(base.nodes[i].payload_raw_bytes);
    int got = LZ4_decompress_safe(reinterpret_cast<const char*>(base.payloads[i].data()), reinterpret_cast<char*>(raw.data()),
                                  int(base.payloads[i].size()), int(raw.size()));
    EXPECT_EQ(got, int(raw.size()));
    return raw;
  };
  auto compress = [](const std::vector<uint8_t>& raw) {
    std::vector<uint8_t> c(size_t(LZ4_compressBound(int(raw.size()))));
    int n = LZ4_compress_default(reinterpret_cast<const char*>(raw.data()), reinterpret_cast<char*>(c.data()), int(raw.size()),
                                 int(c.size()));
    c.resize(size_t(n));
    return c;
  };
  auto read_error = [&](Image im, uint32_t node) -> std::optional<Error> {
    fix_layout(im);
    seal(im);
    mds::testing::write_bytes(dir_ / "bad.mds", serialize(im));
    auto r = StoreReader::open(dir_ / "bad.mds");
    EXPECT_TRUE(r.ok()) << r.error().message;
    if (!r.ok()) return r.error();
    NodeData d;
    std::vector<uint8_t> scratch;
    Status st = (*r)->read_node(node, d, scratch);
    if (st.ok()) return std::nullopt;
    return st.error();
  };
  const uint32_t n = base.nodes[1].particle_count, m = base.nodes[1].meshlet_count;
  // Node 1's decoded payload replaced by `raw` (sizes and hashes made consistent).
  auto error_with_raw = [&](const std::vector<uint8_t>& raw, uint32_t node = 1) {
    Image im = base;
    im.payloads[node] = compress(raw);
    im.h.payload_raw_bytes += raw.size();
    im.h.payload_raw_bytes -= im.nodes[node].payload_raw_bytes;
    im.nodes[node].payload_raw_bytes = uint32_t(raw.size());
    return read_error(im, node);
  };
  auto expect_payload_error = [&](const std::vector<uint8_t>& raw, Errc code, const std::string& needle, uint32_t node = 1) {
    auto e = error_with_raw(raw, node);
    ASSERT_TRUE(e.has_value()) << needle;
    EXPECT_EQ(e->code, code) << e->message;
    EXPECT_NE(e->message.find("bad.mds: node " + std::to_string(node) + " payload at byte"), std::string::npos)
        << e->message;
    EXPECT_NE(e->message.find(needle), std::string::npos) << e->message;
  };
  // Offsets of the arrays (format.h, "Decoded node payload layout"; the fixture has radii).
  const size_t base_x = m, widths = 7 * m, type_base = 9 * m, type_bits = 10 * m;
  const size_t stream = node_payload_fixed_bytes(n, m, true);
  {
    auto raw = decode_raw(1);
    ASSERT_TRUE(error_with_raw(raw) == std::nullopt) << "the unmodified payload must decode";
  }
  {  // type index beyond the type table, re-encoded validly otherwise
    NodeData d;
    auto raw = decode_raw(1);
    ASSERT_TRUE(decode_payload_raw(raw, {n, m, true, 3, 8}, d).ok());
    d.type_index[2] = 200;
    NodeInput in;
    in.qpos = d.qpos;
    in.type_index = d.type_index;
    in.radius_q = d.radius_q;
    in.meshlet_size = d.meshlet_size;
    encode_payload(in, raw);
    expect_payload_error(raw, Errc::range, "particle 2 has type index 200");
  }
  {  // type base + offset beyond the table (and beyond 255: not truncated to a byte)
    auto raw = decode_raw(1);
    raw[type_base] = 255;
    expect_payload_error(raw, Errc::range, "particle 0 has type index 25");
  }
  {  // meshlet sizes that do not sum to n
    auto raw = decode_raw(1);
    raw[m - 1] += 1;
    expect_payload_error(raw, Errc::range, "meshlet sizes sum to");
  }
  {  // an empty meshlet
    auto raw = decode_raw(1);
    raw[m - 1] = 0;
    expect_payload_error(raw, Errc::range, "meshlet " + std::to_string(m - 1) + " has 0 particles");
  }
  {  // a meshlet larger than meshlet_size_max
    auto raw = decode_raw(1);
    raw[0] = 9;
    expect_payload_error(raw, Errc::range, "meshlet 0 has 9 particles (allowed 1..8)");
  }
  {  // axis width above 16 bits, and the reserved bit 15
    auto raw = decode_raw(1);
    raw[widths] = uint8_t((raw[widths] & ~31) | 17);
    expect_payload_error(raw, Errc::range, "meshlet 0 bit widths");
    raw = decode_raw(1);
    raw[widths + 1] |= 0x80;
    expect_payload_error(raw, Errc::range, "meshlet 0 bit widths");
  }
  {  // type width above 8 bits
    auto raw = decode_raw(1);
    raw[type_bits + 1] = 9;
    expect_payload_error(raw, Errc::range, "meshlet 1 type offsets of 9 bits");
  }
  {  // base + offset beyond 65535 on x
    auto raw = decode_raw(1);
    ASSERT_GT(raw[widths] & 31, 0) << "meshlet 0 of the fixture spans a range on x";
    raw[base_x] = 0xFF;
    raw[base_x + 1] = 0xFF;
    expect_payload_error(raw, Errc::range, "meshlet 0 axis x: base 65535");
  }
  {  // bit stream one byte longer / shorter than the widths give
    auto raw = decode_raw(1);
    raw.push_back(0);
    expect_payload_error(raw, Errc::format, "bit stream has");
    raw = decode_raw(1);
    raw.pop_back();
    expect_payload_error(raw, Errc::format, "bit stream has");
  }
  {  // a decoded payload shorter than its fixed arrays
    auto raw = decode_raw(1);
    raw.resize(stream - 1);
    Image im = base;
    im.payloads[1] = compress(raw);
    im.h.payload_raw_bytes -= im.nodes[1].payload_raw_bytes - raw.size();
    im.nodes[1].payload_raw_bytes = uint32_t(raw.size());
    fix_layout(im);
    seal(im);
    expect_open_error(im, Errc::format, {"node 1", "payload_raw_bytes", "outside"});  // rejected by open()
  }
  {  // non-zero padding bits, in a node whose stream does not end on a byte boundary
    int tested = 0;
    for (uint32_t i = 0; i < 3; ++i) {
      auto raw = decode_raw(i);
      const uint32_t ni = base.nodes[i].particle_count, mi = base.nodes[i].meshlet_count;
      uint64_t bits = 0;
      for (uint32_t j = 0; j < mi; ++j) {
        uint16_t w;
        std::memcpy(&w, raw.data() + 7 * mi + 2 * j, 2);
        bits += uint64_t(raw[j]) * ((w & 31) + ((w >> 5) & 31) + ((w >> 10) & 31) + raw[10 * mi + j]);
      }
      ASSERT_EQ(raw.size(), node_payload_fixed_bytes(ni, mi, true) + (bits + 7) / 8) << "node " << i;
      if (bits % 8 == 0) continue;
      raw.back() |= 0x80;
      expect_payload_error(raw, Errc::format, "padding bits", i);
      ++tested;
    }
    EXPECT_GT(tested, 0) << "every fixture node's bit stream is byte-aligned; change the fixture";
  }
  {  // not an LZ4 block
    Image im = base;
    im.payloads[1].assign(im.payloads[1].size(), 0xF0);
    auto e = read_error(im, 1);
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->code, Errc::format);
    EXPECT_NE(e->message.find("LZ4"), std::string::npos) << e->message;
  }
  {  // LZ4 block that decodes to one byte too few
    Image im = base;
    auto raw = decode_raw(1);
    raw.pop_back();
    im.payloads[1] = compress(raw);
    auto e = read_error(im, 1);
    ASSERT_TRUE(e.has_value());
    EXPECT_NE(e->message.find("node 1"), std::string::npos) << e->message;
  }
  {  // decode_payload with a span of the wrong size and an out-of-range node
    mds::testing::write_bytes(dir_ / "ok.mds", good_);
    auto r = StoreReader::open(dir_ / "ok.mds");
    ASSERT_TRUE(r.ok());
    NodeData d;
    std::vector<uint8_t> buf(3, 0);
    EXPECT_FALSE((*r)->decode_payload(0, buf, d).ok());
    EXPECT_FALSE((*r)->read_payload(3, buf).ok());
    EXPECT_TRUE((*r)->voxels(99).empty());
  }
}

TEST(CorruptionFiles, NotAFileOrEmpty) {
  auto dir = mds::testing::temp_dir("notafile");
  auto r = StoreReader::open(dir);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, Errc::io);
  r = StoreReader::open(dir / "missing.mds");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("missing.mds"), std::string::npos);
  mds::testing::write_bytes(dir / "empty.mds", {});
  r = StoreReader::open(dir / "empty.mds");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("smaller than the 512-byte header"), std::string::npos) << r.error().message;
  std::filesystem::remove_all(dir);
}

}  // namespace
