// Counter-based random numbers for the synthetic scenes: every value is a pure function of
// (seed, stream key, counter), so chunks can be generated in any order and in parallel and
// the output does not depend on the standard library (std:: distributions are not portable).
// Mixing function: SplitMix64 (Steele, Lea, Flood, "Fast splittable pseudorandom number
// generators", OOPSLA 2014). Distributions are implemented here explicitly.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace mds::synth {

inline uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Hash of up to three 64-bit words.
inline uint64_t hash64(uint64_t a, uint64_t b, uint64_t c = 0) {
  uint64_t h = splitmix64(a ^ 0x6A09E667F3BCC909ull);
  h = splitmix64(h ^ b);
  return splitmix64(h ^ (c * 0xD1B54A32D192ED03ull));
}

// Uniform in [0, 1) from the top 53 bits.
inline double to_unit(uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

// A small sequential stream keyed by a hash; used where one item needs several values.
class Stream {
 public:
  explicit Stream(uint64_t key) : state_(key) {}
  uint64_t next() { state_ += 0x9E3779B97F4A7C15ull; return splitmix64(state_); }
  double uniform() { return to_unit(next()); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Integer in [0, n).
  uint64_t below(uint64_t n) { return static_cast<uint64_t>(uniform() * static_cast<double>(n)) % (n ? n : 1); }
  // Bounded, zero-mean, unit-variance noise: Irwin-Hall sum of three uniforms (|v| <= 3).
  double bounded_normal() { return 2.0 * (uniform() + uniform() + uniform() - 1.5); }
  // Unit vector, uniform on the sphere (Archimedes: z uniform in [-1, 1]).
  void unit_vector(double v[3]) {
    double z = uniform(-1.0, 1.0), phi = uniform(0.0, 6.283185307179586);
    double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    v[0] = r * std::cos(phi); v[1] = r * std::sin(phi); v[2] = z;
  }

 private:
  uint64_t state_;
};

// Three bounded unit-variance values from one 64-bit hash (21 bits per uniform, 3 uniforms each).
inline void bounded_normal3(uint64_t h0, uint64_t h1, uint64_t h2, double out[3]) {
  constexpr double s = 0x1.0p-21;
  const uint64_t hs[3] = {h0, h1, h2};
  for (int k = 0; k < 3; ++k) {
    uint64_t h = hs[k];
    double u0 = static_cast<double>(h & 0x1FFFFF) * s;
    double u1 = static_cast<double>((h >> 21) & 0x1FFFFF) * s;
    double u2 = static_cast<double>((h >> 42) & 0x1FFFFF) * s;
    out[k] = 2.0 * (u0 + u1 + u2 - 1.5);
  }
}

}  // namespace mds::synth
