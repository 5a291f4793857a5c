// H5MD reader tests on files written by MDAnalysis' H5MDWriter and by h5py directly
// (float32/float64, species, boxes, time-dependent and time-independent elements, two
// particle groups) plus malformed files. Expected values come from side files the Python
// writer saves next to each file (numpy tofile, little-endian).
#include <cmath>

#include <gtest/gtest.h>

#include "binreader_test_util.h"
#include "h5md/h5md_reader.h"
#include "readers/reader_factories.h"

namespace mds {
namespace {

using testing::TempDir;

constexpr const char* kWriter = R"PY(
import sys, os, numpy as np, h5py
out = sys.argv[1]
os.chdir(out)
rng = np.random.default_rng(42)

def h5md_root(f):
    g = f.create_group("h5md"); g.attrs["version"] = np.array([1, 1])
    g.create_group("author").attrs["name"] = "test"
    g.create_group("creator").attrs["name"] = "mdstream test"

# 1. MDAnalysis H5MDWriter, 4 frames x 50 atoms, orthorhombic box.
import MDAnalysis as mda
from MDAnalysis.coordinates.memory import MemoryReader
F, N = 4, 50
u = mda.Universe.empty(N, trajectory=True)
pos = (rng.random((F, N, 3)) * 30.0).astype(np.float32)
dims = np.array([[30.0, 31.0, 32.0, 90.0, 90.0, 90.0]] * F, dtype=np.float32)
dims[:, 0] += np.arange(F, dtype=np.float32)
u.load_new(pos, format=MemoryReader, dimensions=dims)
with mda.Writer("mda.h5md", n_atoms=N, convert_units=False) as W:
    for ts in u.trajectory:
        W.write(u)
pos.astype("<f8").tofile("mda.pos.f64")
dims[:, :3].astype("<f8").tofile("mda.box.f64")

# 2. h5py float32, 3 frames, time-dependent species, time-independent box vector, steps.
F, N = 3, 37
p = (rng.random((F, N, 3)) * 10.0 - 5.0).astype(np.float32)
sp = rng.integers(0, 4, size=(F, N)).astype(np.int32)
steps = np.array([0, 100, 250], dtype=np.int64)
with h5py.File("f32.h5md", "w") as f:
    h5md_root(f)
    g = f.create_group("particles/atoms")
    pg = g.create_group("position"); pg["value"] = p; pg["step"] = steps; pg["time"] = steps * 0.5
    sg = g.create_group("species"); sg["value"] = sp; sg["step"] = steps
    b = g.create_group("box"); b.attrs["dimension"] = 3; b["edges"] = np.array([10.0, 11.0, 12.0])
    b.attrs["boundary"] = np.array([b"periodic", b"none", b"periodic"], dtype="S8")  # fixed-length strings
p.astype("<f8").tofile("f32.pos.f64"); sp.astype("<i4").tofile("f32.species.i32"); steps.astype("<i8").tofile("f32.steps.i64")

# 3. h5py float64 time-independent position [N][3], species [N], triclinic box + offset.
N = 29
p = rng.random((N, 3)) * 100.0
sp = rng.integers(1, 9, size=N).astype(np.int64)
M = np.array([[10.0, 0.0, 0.0], [-3.0, 9.0, 0.0], [2.0, 1.5, 8.0]])
off = np.array([-5.0, -4.0, 1.0])
with h5py.File("f64.h5md", "w") as f:
    h5md_root(f)
    g = f.create_group("particles/all")
    g["position"] = p
    g["species"] = sp
    b = g.create_group("box"); b.attrs["dimension"] = 3; b["edges"] = M; b["offset"] = off
    b.attrs["boundary"] = np.array([b"none", b"periodic", b"none"], dtype="S8")
p.astype("<f8").tofile("f64.pos.f64"); sp.astype("<i4").tofile("f64.species.i32")
lo = off + np.minimum(M, 0).sum(axis=0); hi = off + np.maximum(M, 0).sum(axis=0)
np.concatenate([lo, hi]).astype("<f8").tofile("f64.box.f64")

# 4. two particle groups (plus a group without positions), time-dependent box [F][3].
with h5py.File("two.h5md", "w") as f:
    h5md_root(f)
    for name, n in (("solute", 7), ("solvent", 11)):
        v = (rng.random((2, n, 3)) * 5.0).astype(np.float32)
        g = f.create_group("particles/" + name)
        g.create_group("position")["value"] = v
        b = g.create_group("box"); b.attrs["dimension"] = 3
        b.create_group("edges")["value"] = np.array([[5.0, 6.0, 7.0], [5.5, 6.5, 7.5]])
        v.astype("<f8").tofile("two.%s.pos.f64" % name)
    f.create_group("particles/empty").create_group("velocity")["value"] = np.zeros((2, 3, 3))

# 5. malformed files.
def simple(name, value, species=None, td=True, extra=None):
    with h5py.File(name, "w") as f:
        h5md_root(f)
        g = f.create_group("particles/all")
        if td:
            g.create_group("position")["value"] = value
        else:
            g["position"] = value
        if species is not None:
            g.create_group("species")["value"] = species
        if extra:
            extra(g)
simple("shape2.h5md", np.zeros((10, 5, 2), dtype=np.float32))
simple("rank2.h5md", np.zeros((5, 3), dtype=np.float32))
simple("ti_rank3.h5md", np.zeros((2, 5, 3), dtype=np.float32), td=False)
simple("species_len.h5md", np.zeros((2, 5, 3), dtype=np.float32), species=np.zeros((2, 4), dtype=np.int32))
simple("species_float.h5md", np.zeros((2, 5, 3), dtype=np.float32), species=np.zeros((2, 5), dtype=np.float32))
simple("intpos.h5md", np.zeros((2, 5, 3), dtype=np.int32))
nanp = np.zeros((2, 6, 3), dtype=np.float64); nanp[1, 4, 1] = np.nan
simple("nan.h5md", nanp)
infp = np.zeros((2, 6, 3), dtype=np.float32); infp[0, 2, 2] = np.inf
simple("inf.h5md", infp)
simple("badbox.h5md", np.zeros((2, 5, 3), dtype=np.float32),
       extra=lambda g: g.create_group("box").create_dataset("edges", data=np.zeros((4,))))
def box_with_boundary(values):
    def make(g):
        b = g.create_group("box"); b["edges"] = np.array([1.0, 2.0, 3.0]); b.attrs["boundary"] = values
    return make
simple("badboundary.h5md", np.zeros((2, 5, 3), dtype=np.float32),
       extra=box_with_boundary(np.array([b"periodic", b"open", b"none"], dtype="S8")))
simple("boundary2.h5md", np.zeros((2, 5, 3), dtype=np.float32),
       extra=box_with_boundary(np.array([b"periodic", b"none"], dtype="S8")))
# Variable-length strings (as MDAnalysis writes them) are not read: HDF5 1.10.8 crashes on a
# corrupted heap reference in them; the box counts as periodic.
simple("vlen_boundary.h5md", np.zeros((2, 5, 3), dtype=np.float32), extra=box_with_boundary(["none", "none", "none"]))
with h5py.File("plain.h5", "w") as f:
    f["particles/all/position/value"] = np.zeros((1, 2, 3))
# A compact position [1][2][3] whose stored dims (and max dims) say 2^40 frames: the shape needs
# far more than the 48 bytes stored (HDF5 1.10 reads the last frame from a null buffer).
import struct
with h5py.File("compact_short.h5md", "w") as f:
    h5md_root(f)
    g = f.create_group("particles/all/position")
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_layout(h5py.h5d.COMPACT)
    ds = h5py.h5d.create(g.id, b"value", h5py.h5t.IEEE_F64LE, h5py.h5s.create_simple((1, 2, 3)), dcpl=dcpl)
    ds.write(h5py.h5s.ALL, h5py.h5s.ALL, np.ones((1, 2, 3)))
b = bytearray(open("compact_short.h5md", "rb").read())
dims = struct.pack("<3Q", 1, 2, 3)
at = b.find(dims)
while at >= 0:
    b[at:at + 8] = struct.pack("<Q", 1 << 40)
    at = b.find(dims, at + 24)
open("compact_short.h5md", "wb").write(bytes(b))
)PY";

class H5mdReaderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    auto script = *dir_ / "write_h5md.py";
    testing::write_text(script, kWriter);
    ASSERT_EQ(testing::run_python({script.string(), dir_->path().string()}), 0);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::filesystem::path p(const std::string& name) { return *dir_ / name; }
  static Result<std::unique_ptr<ParticleReader>> open(const std::string& name, int64_t frame = 0,
                                                      const std::string& group = "") {
    ReaderOptions o;
    o.frame = frame;
    o.h5md_group = group;
    return H5mdReader::open(p(name), o);
  }
  static std::string error_of(const std::string& name, int64_t frame = 0, const std::string& group = "") {
    auto r = open(name, frame, group);
    if (!r.ok()) return r.error().message;
    auto all = testing::read_all(**r, 4);
    return all.ok() ? std::string("(no error)") : all.error().message;
  }
  static TempDir* dir_;
};
TempDir* H5mdReaderTest::dir_ = nullptr;

void expect_positions(const testing::AllParticles& a, const std::vector<double>& pos, size_t frame, size_t n) {
  ASSERT_EQ(a.x.size(), n);
  ASSERT_GE(pos.size(), (frame + 1) * n * 3);
  for (size_t i = 0; i < n; ++i) {
    const double* e = &pos[(frame * n + i) * 3];
    ASSERT_EQ(a.x[i], e[0]) << i;
    ASSERT_EQ(a.y[i], e[1]) << i;
    ASSERT_EQ(a.z[i], e[2]) << i;
  }
}

TEST_F(H5mdReaderTest, MDAnalysisWriterAllFrames) {
  const auto pos = testing::read_array<double>(p("mda.pos.f64"));
  const auto box = testing::read_array<double>(p("mda.box.f64"));
  const size_t n = 50;
  for (int64_t frame : {0, 1, 2, 3, -1}) {
    SCOPED_TRACE(frame);
    auto r = open("mda.h5md", frame);
    ASSERT_TRUE(r.ok()) << r.error().message;
    auto* h = dynamic_cast<H5mdReader*>(r->get());
    ASSERT_NE(h, nullptr);
    EXPECT_EQ(h->group(), "/particles/trajectory");
    EXPECT_EQ(h->frame_count(), 4u);
    const size_t k = frame < 0 ? 3 : static_cast<size_t>(frame);
    const FrameInfo& info = (*r)->info();
    EXPECT_EQ(info.particle_count, n);
    ASSERT_TRUE(info.has_box);
    for (int d = 0; d < 3; ++d) {
      EXPECT_EQ(info.box_lo[d], 0.0);
      EXPECT_NEAR(info.box_hi[d], box[k * 3 + d], 1e-4);
      // The cell: MDAnalysis writes the boundary as variable-length strings, taken as periodic.
      EXPECT_EQ(info.cell.origin[d], 0.0);
      EXPECT_NEAR(info.cell.vectors[d][d], box[k * 3 + d], 1e-4);
      EXPECT_TRUE(info.cell.periodic[d]);
    }
    EXPECT_TRUE(info.cell.orthogonal());
    auto all = testing::read_all(**r, 7);
    ASSERT_TRUE(all.ok()) << all.error().message;
    expect_positions(*all, pos, k, n);
    EXPECT_TRUE(std::all_of(all->type.begin(), all->type.end(), [](int32_t t) { return t == 1; }));
    EXPECT_TRUE(all->radius.empty());
  }
  EXPECT_NE(error_of("mda.h5md", 4).find("frame 4 out of range"), std::string::npos) << error_of("mda.h5md", 4);
}

TEST_F(H5mdReaderTest, Float32SpeciesStepsAndBoxVector) {
  const auto pos = testing::read_array<double>(p("f32.pos.f64"));
  const auto species = testing::read_array<int32_t>(p("f32.species.i32"));
  const auto steps = testing::read_array<int64_t>(p("f32.steps.i64"));
  const size_t n = 37;
  for (size_t k = 0; k < 3; ++k) {
    auto r = open("f32.h5md", static_cast<int64_t>(k));
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ((*r)->info().timestep, steps[k]);
    EXPECT_TRUE((*r)->info().has_box);
    EXPECT_EQ((*r)->info().box_hi[2], 12.0);
    // Boundary as fixed-length strings.
    const SimulationCell& c = (*r)->info().cell;
    EXPECT_EQ(c.vectors[1][1], 11.0);
    EXPECT_TRUE(c.periodic[0]);
    EXPECT_FALSE(c.periodic[1]);
    EXPECT_TRUE(c.periodic[2]);
    auto all = testing::read_all(**r, 10);
    ASSERT_TRUE(all.ok()) << all.error().message;
    expect_positions(*all, pos, k, n);
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(all->type[i], species[k * n + i]) << i;
    EXPECT_EQ(all->calls, 4u);
  }
}

// list_frames on H5MD: the frames of the position dataset with the steps of position/step
// (through the module), and one frame for a time-independent position.
TEST_F(H5mdReaderTest, ListFramesWithSteps) {
  const auto steps = testing::read_array<int64_t>(p("f32.steps.i64"));
  auto frames = list_frames(p("f32.h5md"), {});
  ASSERT_TRUE(frames.ok()) << frames.error().message;
  ASSERT_EQ(frames->size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ((*frames)[k].index, int64_t(k));
    EXPECT_EQ((*frames)[k].timestep, steps[k]);
    EXPECT_EQ((*frames)[k].particle_count, 37u);
  }
  auto one = list_frames(p("f64.h5md"), {});
  ASSERT_TRUE(one.ok()) << one.error().message;
  ASSERT_EQ(one->size(), 1u);
  EXPECT_EQ((*one)[0].particle_count, 29u);
}

TEST_F(H5mdReaderTest, Float64TimeIndependentTriclinicBoxWithOffset) {
  const auto pos = testing::read_array<double>(p("f64.pos.f64"));
  const auto species = testing::read_array<int32_t>(p("f64.species.i32"));
  const auto box = testing::read_array<double>(p("f64.box.f64"));
  for (int64_t frame : {0, -1}) {
    auto r = open("f64.h5md", frame);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const FrameInfo& info = (*r)->info();
    ASSERT_TRUE(info.has_box);
    for (int d = 0; d < 3; ++d) {
      EXPECT_DOUBLE_EQ(info.box_lo[d], box[d]);
      EXPECT_DOUBLE_EQ(info.box_hi[d], box[3 + d]);
    }
    // The cell itself: rows of the edges matrix, the offset as origin, boundary none/periodic/none.
    const double M[3][3] = {{10.0, 0.0, 0.0}, {-3.0, 9.0, 0.0}, {2.0, 1.5, 8.0}};
    const double off[3] = {-5.0, -4.0, 1.0};
    for (int v = 0; v < 3; ++v) {
      EXPECT_EQ(info.cell.origin[v], off[v]);
      for (int k = 0; k < 3; ++k) EXPECT_EQ(info.cell.vectors[v][k], M[v][k]) << v << "," << k;
    }
    EXPECT_FALSE(info.cell.orthogonal());
    EXPECT_FALSE(info.cell.periodic[0]);
    EXPECT_TRUE(info.cell.periodic[1]);
    EXPECT_FALSE(info.cell.periodic[2]);
    auto all = testing::read_all(**r, 1000);
    ASSERT_TRUE(all.ok()) << all.error().message;
    expect_positions(*all, pos, 0, 29);
    EXPECT_EQ(all->type, species);
  }
  EXPECT_NE(error_of("f64.h5md", 1).find("out of range"), std::string::npos);
}

TEST_F(H5mdReaderTest, SeveralParticleGroups) {
  const std::string e = error_of("two.h5md");
  EXPECT_NE(e.find("/particles/solute"), std::string::npos) << e;
  EXPECT_NE(e.find("/particles/solvent"), std::string::npos) << e;
  EXPECT_EQ(e.find("/particles/empty"), std::string::npos) << e;
  for (auto [name, n] : {std::pair<std::string, size_t>{"solute", 7}, {"solvent", 11}}) {
    const auto pos = testing::read_array<double>(p("two." + name + ".pos.f64"));
    auto r = open("two.h5md", 1, name);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ((*r)->info().box_hi[0], 5.5);
    auto all = testing::read_all(**r, 3);
    ASSERT_TRUE(all.ok()) << all.error().message;
    expect_positions(*all, pos, 1, n);
  }
  auto r = open("two.h5md", 0, "/particles/solvent");
  EXPECT_TRUE(r.ok());
  EXPECT_NE(error_of("two.h5md", 0, "nosuch").find("no particle group /particles/nosuch"), std::string::npos);
}

TEST_F(H5mdReaderTest, BadShapesNameTheDataset) {
  EXPECT_NE(error_of("shape2.h5md").find("dataset /particles/all/position/value has shape [10][5][2], expected [frames][N][3]"),
            std::string::npos)
      << error_of("shape2.h5md");
  EXPECT_NE(error_of("rank2.h5md").find("/particles/all/position/value has shape [5][3], expected [frames][N][3]"),
            std::string::npos)
      << error_of("rank2.h5md");
  EXPECT_NE(error_of("ti_rank3.h5md").find("/particles/all/position has shape [2][5][3], expected [N][3]"),
            std::string::npos)
      << error_of("ti_rank3.h5md");
  const std::string sl = error_of("species_len.h5md");
  EXPECT_NE(sl.find("/particles/all/species/value has shape [2][4]"), std::string::npos) << sl;
  EXPECT_NE(error_of("species_float.h5md").find("/particles/all/species/value is not integer"), std::string::npos);
  EXPECT_NE(error_of("intpos.h5md").find("not floating point"), std::string::npos);
  EXPECT_NE(error_of("badbox.h5md").find("/particles/all/box/edges has shape [4]"), std::string::npos)
      << error_of("badbox.h5md");
  EXPECT_NE(error_of("badboundary.h5md").find("/particles/all/box/boundary: value 1 is 'open'"), std::string::npos)
      << error_of("badboundary.h5md");
  EXPECT_NE(error_of("boundary2.h5md").find("/particles/all/box/boundary has 2 values, expected 3"), std::string::npos)
      << error_of("boundary2.h5md");
  {
    auto r = open("vlen_boundary.h5md", 0);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE((*r)->info().cell.periodic[0] && (*r)->info().cell.periodic[1] && (*r)->info().cell.periodic[2]);
  }
}

// Found by fuzz_h5md (2026-11-27): before the check, --frame last crashed inside H5Dread.
TEST_F(H5mdReaderTest, DataShorterThanItsShapeIsAnError) {
  for (const int64_t frame : {int64_t(0), int64_t(-1)}) {
    const std::string e = error_of("compact_short.h5md", frame);
    EXPECT_NE(e.find("compact_short.h5md: dataset /particles/all/position/value: shape [1099511627776][2][3] of "
                     "8-byte values needs 52776558133248 bytes, the file stores 48"),
              std::string::npos)
        << e;
  }
}

TEST_F(H5mdReaderTest, NonFiniteNamesDatasetAndParticle) {
  EXPECT_EQ(error_of("nan.h5md", 0), "(no error)");
  const std::string e = error_of("nan.h5md", 1);
  EXPECT_NE(e.find("/particles/all/position/value"), std::string::npos) << e;
  EXPECT_NE(e.find("particle 4"), std::string::npos) << e;
  const std::string i = error_of("inf.h5md", 0);
  EXPECT_NE(i.find("particle 2"), std::string::npos) << i;
}

TEST_F(H5mdReaderTest, NotH5md) {
  EXPECT_NE(error_of("plain.h5").find("HDF5 file without /h5md group"), std::string::npos);
  auto has = hdf5_has_h5md_group(p("plain.h5"));
  ASSERT_TRUE(has.ok());
  EXPECT_FALSE(*has);
  EXPECT_TRUE(*hdf5_has_h5md_group(p("mda.h5md")));
  EXPECT_FALSE(hdf5_has_h5md_group(p("mda.pos.f64")).ok());
  EXPECT_NE(error_of("missing.h5md").find("missing.h5md"), std::string::npos);
}

// A file fuzz_h5md made (2026-12-07): its box's variable-length `boundary` attribute holds a
// global-heap reference with a corrupted object index, on which HDF5 1.10.8's H5Aread crashes
// (H5HG_read). The reader does not read variable-length boundaries: the file opens or fails
// with an error, and whatever opens drains.
TEST(H5mdRegression, CorruptedHeapReferenceInTheBoundaryDoesNotCrash) {
  const std::string file = std::string(MDSTREAM_SOURCE_DIR) + "/tests/data/h5md/corrupt_heap_boundary.h5md";
  for (int64_t frame : {0, -1}) {
    ReaderOptions o;
    o.frame = frame;
    auto r = open_h5md_reader(file, o);
    if (!r.ok()) continue;
    auto all = testing::read_all(**r, 3);
    (void)all;
  }
  SUCCEED();
}

}  // namespace
}  // namespace mds
