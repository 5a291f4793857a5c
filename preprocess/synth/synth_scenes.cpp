// The built-in scenes, modelled on the data sets of Ibrahim et al. (Table 2: SARS-CoV-2
// virus, large laser ablation, copper/silver mixture) and Grottel et al. (Table 1: laser
// ablation D1/D4, sparse gas mixture of Fig. 5). Lengths are in units of the nearest-
// neighbour distance (FCC, spacing 1), so radius 0.5 makes touching spheres in dense regions.
//
//  ablation: FCC slab (78%) with a molten top layer, an expanding gas plume above it whose
//            density falls off exponentially with height (15%), and liquid droplets (7%);
//            periodic laterally, the plume rises (self-similar expansion v ~ height) per frame.
//  porous:   FCC block with spherical voids carved out (Swiss cheese, ~40% void fraction),
//            two metals (Cu/Ag-like) in spinodal-like domains.
//  gas:      sparse gas (number density 0.02), density modulated on large scales, 30% of the
//            atoms in small liquid clusters; two species; periodic.
//  shell:    virus-like envelope: a thick spherical lipid shell (70%) with membrane-protein
//            patches, club-shaped spike proteins (15%), RNA lumps lining the inner side (15%),
//            hollow centre.
#include "synth/synth_scenes.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace mds::synth {

namespace {

constexpr double kPi = 3.141592653589793;

// Salts of the random streams (one per purpose) so that parts draw independent values.
enum Salt : uint64_t { kGasSalt = 11, kDropSalt = 12, kVoidSalt = 13, kDomainSalt = 14, kClusterSalt = 15,
                       kSpikeSalt = 16, kRnaSalt = 17, kPatchSalt = 18, kDensitySalt = 19 };

uint64_t fraction_of(uint64_t n, double f) { return static_cast<uint64_t>(std::floor(static_cast<double>(n) * f)); }

// cos() from a 4096-entry table with linear interpolation (error < 3e-7): the fields below
// are evaluated per particle and only need to be smooth and deterministic.
class CosTable {
 public:
  CosTable() {
    for (int i = 0; i <= kSize; ++i) table_[i] = std::cos(2 * kPi * i / kSize);
  }
  double operator()(double theta) const {
    double t = theta * (kSize / (2 * kPi));
    t -= std::floor(t / kSize) * kSize;
    const int i = std::min(static_cast<int>(t), kSize - 1);
    const double f = t - i;
    return table_[i] + f * (table_[i + 1] - table_[i]);
  }

 private:
  static constexpr int kSize = 4096;
  double table_[kSize + 1];
};

const CosTable& cos_table() {
  static const CosTable t;
  return t;
}

// A smooth random field in [-1, 1]: mean of plane waves with random directions/phases.
struct WaveField {
  static constexpr int kWaves = 6;
  double k[kWaves][3];
  double phase[kWaves];
  WaveField(uint64_t key, double wavelength) {
    Stream s(key);
    for (int m = 0; m < kWaves; ++m) {
      double d[3];
      s.unit_vector(d);
      const double w = 2 * kPi / (wavelength * s.uniform(0.7, 1.3));
      for (int a = 0; a < 3; ++a) k[m][a] = d[a] * w;
      phase[m] = s.uniform(0.0, 2 * kPi);
    }
  }
  double operator()(double x, double y, double z) const {
    double f = 0;
    const CosTable& c = cos_table();
    for (int m = 0; m < kWaves; ++m) f += c(k[m][0] * x + k[m][1] * y + k[m][2] * z + phase[m]);
    return f / kWaves;
  }
};

// Points spread evenly over the unit sphere (Fibonacci spiral), randomly rotated.
std::vector<std::array<double, 3>> sphere_points(uint64_t count, uint64_t key) {
  std::vector<std::array<double, 3>> pts;
  Stream s(key);
  const double rot = s.uniform(0.0, 2 * kPi), tilt = s.uniform(-0.5, 0.5);
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (uint64_t i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * (static_cast<double>(i) + 0.5) / static_cast<double>(count);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * static_cast<double>(i) + rot + s.uniform(-0.15, 0.15);
    double p[3] = {r * std::cos(phi), r * std::sin(phi), z};
    // tilt around x so that the spiral's poles are not on the z axis
    const double ct = std::cos(tilt), st = std::sin(tilt);
    pts.push_back({p[0], ct * p[1] - st * p[2], st * p[1] + ct * p[2]});
  }
  return pts;
}

int64_t cells_for(double width) { return std::max<int64_t>(2, static_cast<int64_t>(std::llround(width / (2 * kFccStep)))); }

// ---------------------------------------------------------------- ablation

Result<Plan> plan_ablation(const SynthOptions& o, int threads) {
  Plan plan;
  const uint64_t n = o.particles;
  const uint64_t n_drop = n >= 2000 ? fraction_of(n, 0.07) : 0;
  const uint64_t n_block = std::max<uint64_t>(1, fraction_of(n, 0.78));
  const uint64_t n_gas = n - n_block - n_drop;

  // Slab of width W x W, height about W/2.
  const int64_t cells = cells_for(std::cbrt(static_cast<double>(n_block) / (0.5 * kFccDensity)));
  const int64_t nx = 2 * cells;
  const double width = static_cast<double>(nx) * kFccStep;
  const uint64_t plane_sites = static_cast<uint64_t>(nx * nx / 2);
  const int64_t nz = static_cast<int64_t>((n_block + plane_sites - 1) / plane_sites) + 1;
  const double z0 = 1.0;
  const double expected_top = z0 + static_cast<double>(n_block / plane_sites) * kFccStep;

  LatticeRegion::Params lp;
  lp.origin[0] = lp.origin[1] = 0.5 * kFccStep;
  lp.origin[2] = z0;
  lp.n[0] = lp.n[1] = nx;
  lp.n[2] = nz;
  lp.budget = n_block;
  // crystalline bulk, molten (larger amplitude) top layers
  lp.sigma = [expected_top](double, double, double z) {
    const double t = std::clamp((z - (expected_top - 4.0)) / 4.0, 0.0, 1.0);
    return 0.04 + 0.14 * t * t * (3 - 2 * t);
  };
  MDS_ASSIGN_OR_RETURN(auto block, LatticeRegion::create(std::move(lp), o.seed, threads));
  const double surface = block->top_z() + 1.0;
  const double plume = 1.5 * width + 10.0;
  const double lambda = plume / 3.0;
  const double vmax = 0.4;  // plume-top speed per frame

  auto gas = ScatterPart::create(n_gas, o.seed, kGasSalt, [=](uint64_t, Stream& s, double pos[3], double vel[3]) {
    const double h = -lambda * std::log(1.0 - s.uniform() * (1.0 - std::exp(-plume / lambda)));
    pos[0] = s.uniform(0.0, width);
    pos[1] = s.uniform(0.0, width);
    pos[2] = surface + 0.5 + std::min(h, plume - 1.0);
    vel[0] = 0.02 * s.bounded_normal();
    vel[1] = 0.02 * s.bounded_normal();
    vel[2] = vmax * (pos[2] - surface) / plume;
    return 1;
  });

  std::vector<Blob> drops;
  {
    Stream s(hash64(o.seed, kDropSalt, 0));
    const double max_size = std::clamp(static_cast<double>(n_drop) / 40.0, 60.0, 20000.0);
    uint64_t left = n_drop;
    while (left > 0) {
      uint64_t size = static_cast<uint64_t>(std::exp(s.uniform(std::log(20.0), std::log(max_size))));
      if (size > left || left - size < 10) size = left;
      Blob b;
      b.kind = Blob::Kind::lumpy_sphere;
      b.n = size;
      const double r = std::cbrt(3.0 * static_cast<double>(size) / (4 * kPi * kFccDensity)) * 1.3 + 2.0;
      const double lam = plume / 3.0;
      const double lo = std::min(r + 3.0, plume / 2), hi = std::max(plume - r - 2.0, lo);
      const double h = std::clamp(-lam * std::log(1.0 - s.uniform() * (1.0 - std::exp(-plume / lam))), lo, hi);
      b.center[0] = s.uniform(0.0, width);
      b.center[1] = s.uniform(0.0, width);
      b.center[2] = surface + h;
      b.vel[2] = vmax * h / plume;
      b.lump = 0.15;
      b.sigma = 0.1;
      b.cls = 1;
      b.key = s.next();
      drops.push_back(b);
      left -= size;
    }
  }
  auto drop_part = BlobPart::create(std::move(drops), o.seed);

  uint64_t first = 0;
  block->append_chunks(first, plan.chunks);
  first += block->count();
  gas->append_chunks(first, plan.chunks);
  first += gas->count();
  drop_part->append_chunks(first, plan.chunks);

  SceneSummary& s = plan.summary;
  s.natural_types = 2;
  s.box_lo[0] = s.box_lo[1] = s.box_lo[2] = 0;
  s.box_hi[0] = s.box_hi[1] = width;
  s.box_hi[2] = surface + plume + 2.0;
  s.box_growth_z = vmax;
  s.parts = {{"solid", block->count()}, {"plume_gas", gas->count()}, {"droplets", drop_part->count()}};
  s.geometry = {{"width", width}, {"surface_z", surface}, {"plume_height", plume}, {"droplet_count", static_cast<double>(drop_part->blobs().size())}};
  plan.periodic[0] = plan.periodic[1] = true;
  return plan;
}

// ---------------------------------------------------------------- porous

// Spherical voids, at most one per void cell (centre in the middle half of the cell, radius
// <= 0.7 cell), so a row at (y, z) can only meet the voids of the 2x2 cell columns nearest
// to it; the row's solid spans are the complement of the voids' chords.
struct VoidGrid {
  double cell = 1;
  int64_t n[3] = {0, 0, 0};
  std::vector<std::array<float, 4>> voids;  // cx, cy, cz, r^2 (r^2 < 0: no void)
  void solid_spans(double y, double z, std::vector<XSpan>& spans) const {
    thread_local std::vector<XSpan> chords;
    chords.clear();
    const int64_t cy0 = static_cast<int64_t>(std::floor(y / cell - 0.5)), cz0 = static_cast<int64_t>(std::floor(z / cell - 0.5));
    for (int64_t cz = cz0; cz <= cz0 + 1; ++cz) {
      if (cz < 0 || cz >= n[2]) continue;
      for (int64_t cy = cy0; cy <= cy0 + 1; ++cy) {
        if (cy < 0 || cy >= n[1]) continue;
        for (int64_t cx = 0; cx < n[0]; ++cx) {
          const auto& v = voids[static_cast<size_t>((cz * n[1] + cy) * n[0] + cx)];
          const double dy = y - v[1], dz = z - v[2];
          const double h = static_cast<double>(v[3]) - dy * dy - dz * dz;
          if (h <= 0) continue;
          const double c = std::sqrt(h);
          chords.push_back({v[0] - c, v[0] + c});
        }
      }
    }
    std::sort(chords.begin(), chords.end(), [](const XSpan& a, const XSpan& b) { return a.lo < b.lo || (a.lo == b.lo && a.hi < b.hi); });
    // A site is solid unless strictly inside a chord (the keep test was |p - c|^2 < r^2).
    double from = -1e300;
    for (const XSpan& c : chords) {
      if (c.lo > from) spans.push_back({from, std::nextafter(c.lo, 1e300)});
      from = std::max(from, c.hi);
    }
    spans.push_back({from, 1e300});
  }
};

Result<Plan> plan_porous(const SynthOptions& o, int threads) {
  Plan plan;
  const uint64_t n = o.particles;
  const double solid_fraction = 0.6;
  const int64_t cells = cells_for(std::cbrt(static_cast<double>(n) / (kFccDensity * solid_fraction)));
  const int64_t nx = 2 * cells;
  const double width = static_cast<double>(nx) * kFccStep;
  const bool carve = width >= 12.0;
  const double height_est = static_cast<double>(n) / (kFccDensity * (carve ? solid_fraction : 1.0) * width * width);
  // Enough planes even if the voids take far more than expected.
  const int64_t nz = static_cast<int64_t>(std::ceil((carve ? 5.0 : 1.0) * height_est / kFccStep)) + 4;

  auto grid = std::make_shared<VoidGrid>();
  if (carve) {
    grid->cell = std::max(6.0, width / 8.0);
    grid->n[0] = grid->n[1] = static_cast<int64_t>(std::ceil(width / grid->cell)) + 1;
    grid->n[2] = static_cast<int64_t>(std::ceil(static_cast<double>(nz) * kFccStep / grid->cell)) + 1;
    grid->voids.resize(static_cast<size_t>(grid->n[0] * grid->n[1] * grid->n[2]));
    for (int64_t cz = 0; cz < grid->n[2]; ++cz)
      for (int64_t cy = 0; cy < grid->n[1]; ++cy)
        for (int64_t cx = 0; cx < grid->n[0]; ++cx) {
          const uint64_t idx = static_cast<uint64_t>((cz * grid->n[1] + cy) * grid->n[0] + cx);
          Stream s(hash64(o.seed, kVoidSalt, idx));
          auto& v = grid->voids[idx];
          if (s.uniform() < 0.65) {
            v[0] = static_cast<float>((static_cast<double>(cx) + s.uniform(0.25, 0.75)) * grid->cell);
            v[1] = static_cast<float>((static_cast<double>(cy) + s.uniform(0.25, 0.75)) * grid->cell);
            v[2] = static_cast<float>((static_cast<double>(cz) + s.uniform(0.25, 0.75)) * grid->cell);
            const double r = grid->cell * s.uniform(0.3, 0.7);
            v[3] = static_cast<float>(r * r);
          } else {
            v = {0, 0, 0, -1};
          }
        }
  }
  const WaveField domains(hash64(o.seed, kDomainSalt, 0), std::max(8.0, width / 3.0));

  LatticeRegion::Params lp;
  lp.origin[0] = lp.origin[1] = lp.origin[2] = 0.5;
  lp.n[0] = lp.n[1] = nx;
  lp.n[2] = nz;
  lp.budget = n;
  lp.sigma_const = 0.05;
  if (carve) lp.row_spans = [grid](double y, double z, std::vector<XSpan>& spans) { grid->solid_spans(y, z, spans); };
  // Cu (0) / Ag (1): silver fraction varies smoothly between 5% and 95% (segregated domains)
  lp.classify = [domains](double x, double y, double z, uint64_t key) {
    const double g = 4.0 * domains(x, y, z);
    const double f = 0.5 + 0.45 * g / std::sqrt(1.0 + g * g);  // smooth step, cheaper than tanh
    return to_unit(key) < f ? 1 : 0;
  };
  MDS_ASSIGN_OR_RETURN(auto block, LatticeRegion::create(std::move(lp), o.seed, threads));
  block->append_chunks(0, plan.chunks);

  SceneSummary& s = plan.summary;
  s.natural_types = 2;
  s.box_lo[0] = s.box_lo[1] = s.box_lo[2] = 0;
  s.box_hi[0] = s.box_hi[1] = width + 0.5;
  s.box_hi[2] = block->top_z() + 1.0;
  s.parts = {{"block", block->count()}};
  s.geometry = {{"width", width}, {"height", block->top_z()}, {"void_cell", carve ? grid->cell : 0.0},
                {"voids", carve ? 1.0 : 0.0}};
  return plan;
}

// ---------------------------------------------------------------- gas

Result<Plan> plan_gas(const SynthOptions& o, int /*threads*/) {
  Plan plan;
  const uint64_t n = o.particles;
  const double density = 0.02;
  const double box = std::max(4.0, std::cbrt(static_cast<double>(n) / density));
  const uint64_t n_cluster = n >= 1000 ? fraction_of(n, 0.3) : 0;
  const uint64_t n_free = n - n_cluster;
  const WaveField field(hash64(o.seed, kDensitySalt, 0), std::max(20.0, box / 2.5));

  auto free_part = ScatterPart::create(n_free, o.seed, kGasSalt, [=](uint64_t, Stream& s, double pos[3], double vel[3]) {
    // rejection sampling against a large-scale density modulation (acceptance 0.25 .. 1)
    for (int tries = 0; tries < 16; ++tries) {
      pos[0] = s.uniform(0.0, box);
      pos[1] = s.uniform(0.0, box);
      pos[2] = s.uniform(0.0, box);
      if (s.uniform() < 0.625 + 0.375 * field(pos[0], pos[1], pos[2])) break;
    }
    double d[3];
    s.unit_vector(d);
    const double speed = s.uniform(0.0, 0.3);
    for (int a = 0; a < 3; ++a) vel[a] = speed * d[a];
    return s.uniform() < 0.6 ? 0 : 1;
  });

  std::vector<Blob> clusters;
  {
    Stream s(hash64(o.seed, kClusterSalt, 0));
    uint64_t left = n_cluster;
    while (left > 0) {
      uint64_t size = static_cast<uint64_t>(std::exp(s.uniform(std::log(8.0), std::log(300.0))));
      if (size > left || left - size < 4) size = left;
      Blob b;
      b.n = size;
      for (int a = 0; a < 3; ++a) b.center[a] = s.uniform(0.0, box);
      double d[3];
      s.unit_vector(d);
      for (int a = 0; a < 3; ++a) b.vel[a] = 0.15 * d[a];
      b.lump = 0.2;
      b.sigma = 0.1;
      b.cls = s.uniform() < 0.6 ? 0 : 1;
      b.key = s.next();
      clusters.push_back(b);
      left -= size;
    }
  }
  auto cluster_part = BlobPart::create(std::move(clusters), o.seed);
  free_part->append_chunks(0, plan.chunks);
  cluster_part->append_chunks(free_part->count(), plan.chunks);

  SceneSummary& s = plan.summary;
  s.natural_types = 2;
  s.box_hi[0] = s.box_hi[1] = s.box_hi[2] = box;
  s.parts = {{"free_gas", free_part->count()}, {"clusters", cluster_part->count()}};
  s.geometry = {{"box", box}, {"number_density", density}, {"cluster_count", static_cast<double>(cluster_part->blobs().size())}};
  plan.periodic[0] = plan.periodic[1] = plan.periodic[2] = true;
  return plan;
}

// ---------------------------------------------------------------- shell

Result<Plan> plan_shell(const SynthOptions& o, int threads) {
  Plan plan;
  const uint64_t n = o.particles;
  auto thickness = [](double r) { return std::max(2.5, 0.07 * r); };
  auto membrane_sites = [&](double r) {
    const double ri = std::max(0.0, r - thickness(r));
    return kFccDensity * 4.0 / 3.0 * kPi * (r * r * r - ri * ri * ri);
  };
  // Outer radius such that the membrane holds about 70% of the particles (bisection).
  const double target = 0.70 * static_cast<double>(n);
  double lo = 0.0, hi = 1e6;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (membrane_sites(mid) < target ? lo : hi) = mid;
  }
  const double r_out = hi, r_in = std::max(0.0, r_out - thickness(r_out));

  LatticeRegion::Params lp;
  const int64_t m = static_cast<int64_t>(std::ceil((r_out + 1.0) / kFccStep));
  lp.origin[0] = lp.origin[1] = lp.origin[2] = -static_cast<double>(m) * kFccStep;
  lp.n[0] = lp.n[1] = lp.n[2] = 2 * m + 1;
  lp.budget = n;
  lp.allow_fewer = true;
  lp.sigma_const = 0.05;
  lp.row_spans = [r_out, r_in](double y, double z, std::vector<XSpan>& spans) {
    const double q = y * y + z * z;
    if (q >= r_out * r_out) return;
    const double co = std::sqrt(r_out * r_out - q);
    if (q >= r_in * r_in) {
      spans.push_back({-co, co});
      return;
    }
    const double ci = std::sqrt(r_in * r_in - q);
    spans.push_back({-co, -ci});
    spans.push_back({ci, co});
  };
  const WaveField patches(hash64(o.seed, kPatchSalt, 0), std::max(6.0, r_out / 4.0));
  lp.classify = [patches](double x, double y, double z, uint64_t) { return patches(x, y, z) > 0.45 ? 1 : 0; };
  MDS_ASSIGN_OR_RETURN(auto membrane, LatticeRegion::create(std::move(lp), o.seed, threads));

  // Spikes: club-shaped (thin stalk, wide head), radial, evenly spread.
  const double spike_len = 0.22 * r_out + 3.0, r_stalk = 0.02 * r_out + 0.8, r_head = 0.08 * r_out + 1.5;
  const double spike_volume = kPi * r_stalk * r_stalk * 0.6 * spike_len + kPi * r_head * r_head * 0.3 * spike_len +
                              2.0 / 3.0 * kPi * r_head * r_head * r_head;
  const uint64_t spike_n = std::max<uint64_t>(1, static_cast<uint64_t>(kFccDensity * spike_volume));
  const uint64_t after_membrane = n - membrane->count();
  uint64_t spikes = std::min<uint64_t>(200, static_cast<uint64_t>(std::llround(0.15 * static_cast<double>(n) / static_cast<double>(spike_n))));
  spikes = std::min<uint64_t>(spikes, after_membrane / spike_n);
  std::vector<Blob> spike_blobs;
  {
    const auto dirs = sphere_points(spikes, hash64(o.seed, kSpikeSalt, 0));
    for (uint64_t i = 0; i < spikes; ++i) {
      Blob b;
      b.kind = Blob::Kind::spike;
      b.n = spike_n;
      for (int a = 0; a < 3; ++a) {
        b.axis[a] = dirs[i][a];
        b.center[a] = dirs[i][a] * (r_out + 0.3);
      }
      b.length = spike_len;
      b.r_stalk = r_stalk;
      b.r_head = r_head;
      b.sigma = 0.06;
      b.cls = 2;
      b.key = hash64(o.seed, kSpikeSalt, i + 1);
      spike_blobs.push_back(b);
    }
  }
  auto spike_part = BlobPart::create(std::move(spike_blobs), o.seed);

  // RNA lumps lining the inside of the envelope, leaving the centre hollow.
  const uint64_t n_rna = after_membrane - spike_part->count();
  const uint64_t lumps = n_rna == 0 ? 0 : std::clamp<uint64_t>(std::max<uint64_t>(12, (n_rna + (1u << 18) - 1) >> 18), 1, std::max<uint64_t>(1, n_rna / 20));
  std::vector<Blob> rna_blobs;
  double rna_min_radius = r_in;
  {
    const auto dirs = sphere_points(lumps, hash64(o.seed, kRnaSalt, 0));
    for (uint64_t i = 0; i < lumps; ++i) {
      Blob b;
      b.n = n_rna / lumps + (i < n_rna % lumps ? 1 : 0);
      const double rb = std::cbrt(3.0 * static_cast<double>(b.n) / (4 * kPi * kFccDensity));
      const double rc = std::max(0.0, r_in - 1.4 * rb - 1.5);
      for (int a = 0; a < 3; ++a) b.center[a] = dirs[i][a] * rc;
      b.lump = 0.2;
      b.sigma = 0.1;
      b.cls = 3;
      b.key = hash64(o.seed, kRnaSalt, i + 1);
      rna_blobs.push_back(b);
      rna_min_radius = std::min(rna_min_radius, std::max(0.0, rc - 1.6 * rb - 2.0));
    }
  }
  auto rna_part = BlobPart::create(std::move(rna_blobs), o.seed);

  uint64_t first = 0;
  membrane->append_chunks(first, plan.chunks);
  first += membrane->count();
  spike_part->append_chunks(first, plan.chunks);
  first += spike_part->count();
  rna_part->append_chunks(first, plan.chunks);

  SceneSummary& s = plan.summary;
  s.natural_types = 4;
  const double half = r_out + (spikes > 0 ? spike_len + r_head * 1.5 : 0.0) + 2.0;
  for (int a = 0; a < 3; ++a) {
    s.box_lo[a] = -half;
    s.box_hi[a] = half;
  }
  s.parts = {{"membrane", membrane->count()}, {"spikes", spike_part->count()}, {"rna", rna_part->count()}};
  s.geometry = {{"r_inner", r_in}, {"r_outer", r_out}, {"spike_length", spike_len}, {"spike_head_radius", r_head},
                {"spikes", static_cast<double>(spikes)}, {"rna_lumps", static_cast<double>(lumps)},
                {"rna_min_radius", rna_min_radius}, {"max_radius", half - 2.0}};
  return plan;
}

}  // namespace

int map_type(int cls, int natural, int types, uint64_t key) {
  if (types == natural) return cls + 1;
  if (types < natural) return 1 + cls * types / natural;
  const int lo = cls * types / natural, hi = (cls + 1) * types / natural;
  return 1 + lo + std::min(hi - lo - 1, static_cast<int>(to_unit(key) * (hi - lo)));
}

Result<Plan> plan_scene(const SynthOptions& o) {
  if (o.particles == 0) return make_error(Errc::invalid_argument, "synth: --particles must be at least 1");
  if (o.particles > (uint64_t{1} << 40)) return make_error(Errc::invalid_argument, "synth: --particles {} is absurdly large", o.particles);
  if (o.frames < 1 || o.frames > 100000) return make_error(Errc::invalid_argument, "synth: --frames must be in 1..100000, got {}", o.frames);
  if (o.types < 0 || o.types > 64) return make_error(Errc::invalid_argument, "synth: --types must be in 1..64, got {}", o.types);
  const int threads = resolve_threads(o.threads);
  Result<Plan> r = make_error(Errc::internal, "synth: unknown scene");
  switch (o.scene) {
    case Scene::ablation: r = plan_ablation(o, threads); break;
    case Scene::porous: r = plan_porous(o, threads); break;
    case Scene::gas: r = plan_gas(o, threads); break;
    case Scene::shell: r = plan_shell(o, threads); break;
  }
  if (!r.ok()) return r;
  Plan& p = r.value();
  p.summary.scene = o.scene;
  p.summary.particles = o.particles;
  p.summary.types = o.types == 0 ? p.summary.natural_types : o.types;
  uint64_t total = 0;
  for (const Chunk& c : p.chunks) {
    if (c.first != total) return make_error(Errc::internal, "synth: chunk starts at {}, expected {}", c.first, total);
    total += c.count;
  }
  if (total != o.particles) {
    return make_error(Errc::internal, "synth: scene {} planned {} particles instead of {}", scene_name(o.scene), total, o.particles);
  }
  return r;
}

}  // namespace mds::synth
