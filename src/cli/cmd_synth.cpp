// `mdstream synth --scene NAME --particles N -o FILE [--seed S] [--types T] [--frames F]`:
// writes a deterministic built-in scene (ablation, porous, gas, shell) as a LAMMPS text dump
// (gzip-compressed when FILE ends in .gz). See preprocess/synth/synth.h.
#include <chrono>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "synth/synth.h"

namespace mds::cli {
namespace {

struct SynthCli {
  std::string scene = "porous";
  std::string particles = "1000000";
  std::string output;
  uint64_t seed = 1;
  int types = 0;
  int frames = 1;
  int threads = 0;
  int gzip_level = 1;
  bool quiet = false;
  bool json = false;
};

// Accepts 1000000, 1e6, 2.5e7, 10M, 500k, 1G (k/M/G are powers of ten).
Result<uint64_t> parse_count(const std::string& text) {
  std::string s = text;
  double mult = 1;
  if (!s.empty()) {
    const char last = s.back();
    if (last == 'k' || last == 'K') mult = 1e3;
    if (last == 'm' || last == 'M') mult = 1e6;
    if (last == 'g' || last == 'G') mult = 1e9;
    if (mult != 1) s.pop_back();
  }
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) {
    return make_error(Errc::invalid_argument, "--particles '{}': not a number (examples: 1000000, 1e6, 10M)", text);
  }
  v *= mult;
  if (v < 1 || v > 1.1e12 || v != std::floor(v)) {
    return make_error(Errc::invalid_argument, "--particles '{}': must be a whole number in 1..1e12", text);
  }
  return static_cast<uint64_t>(v);
}

void setup_synth(CLI::App& sub, int& exit_code) {
  auto opt = std::make_shared<SynthCli>();
  std::string names;
  for (const auto& n : synth::scene_names()) names += (names.empty() ? "" : ", ") + n;
  sub.add_option("--scene", opt->scene, "Scene: " + names)->capture_default_str();
  sub.add_option("-n,--particles", opt->particles, "Exact number of particles per frame (1000000, 1e6, 10M)")
      ->capture_default_str();
  sub.add_option("-o,--output", opt->output, "Output LAMMPS dump (.gz: gzip-compressed)")->required();
  sub.add_option("--seed", opt->seed, "Random seed (same seed, same bytes)")->capture_default_str();
  sub.add_option("--types", opt->types, "Number of particle types (0 = the scene's own: ablation 2, porous 2, gas 2, shell 4)")
      ->capture_default_str();
  sub.add_option("--frames", opt->frames, "Frames to write (later frames: thermal motion, expanding plume)")
      ->capture_default_str();
  sub.add_option("--threads", opt->threads, "Worker threads (0 = all cores; output does not depend on it)")
      ->capture_default_str();
  sub.add_option("--gzip-level", opt->gzip_level, "zlib level for .gz output (1..9)")->capture_default_str();
  sub.add_flag("--json", opt->json, "Print the scene summary (parts, box, geometry) as JSON on stdout");
  sub.add_flag("-q,--quiet", opt->quiet, "No summary on stderr");
  sub.callback([opt, &exit_code] {
    auto scene = synth::parse_scene(opt->scene);
    if (!scene) {
      exit_code = report("synth", make_error(Errc::invalid_argument, "unknown scene '{}'", opt->scene));
      return;
    }
    auto count = parse_count(opt->particles);
    if (!count.ok()) {
      exit_code = report("synth", count.error());
      return;
    }
    synth::SynthOptions so;
    so.scene = *scene;
    so.particles = *count;
    so.seed = opt->seed;
    so.types = opt->types;
    so.frames = opt->frames;
    so.threads = opt->threads;
    so.gzip_level = opt->gzip_level;
    const auto t0 = std::chrono::steady_clock::now();
    auto sum = synth::write_scene(so, opt->output);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!sum.ok()) {
      exit_code = report("synth", sum.error());
      return;
    }
    {
      if (opt->json) {
        nlohmann::json j;
        j["scene"] = synth::scene_name(sum->scene);
        j["particles"] = sum->particles;
        j["frames"] = so.frames;
        j["seed"] = so.seed;
        j["types"] = sum->types;
        j["natural_types"] = sum->natural_types;
        j["box_lo"] = {sum->box_lo[0], sum->box_lo[1], sum->box_lo[2]};
        j["box_hi"] = {sum->box_hi[0], sum->box_hi[1], sum->box_hi[2]};
        j["box_growth_z"] = sum->box_growth_z;
        for (const auto& [name, n] : sum->parts) j["parts"][name] = n;
        for (const auto& [name, v] : sum->geometry) j["geometry"][name] = v;
        j["seconds"] = secs;
        j["output"] = opt->output;
        std::fputs((j.dump(2) + "\n").c_str(), stdout);
      }
      if (!opt->quiet) {
        const double lines = static_cast<double>(so.particles) * so.frames;
        std::string parts;
        for (const auto& [name, n] : sum->parts) parts += fmt::format(" {}={}", name, n);
        std::fprintf(stderr, "synth: %s, %llu particles x %d frame(s), %d types ->%s\n", synth::scene_name(so.scene),
                     static_cast<unsigned long long>(so.particles), so.frames, sum->types, parts.c_str());
        std::fprintf(stderr, "synth: wrote %s in %.2f s (%.2f M lines/s)\n", opt->output.c_str(), secs,
                     lines / secs / 1e6);
      }
    }
    exit_code = 0;
  });
}

Registrar reg("synth", "Write a deterministic built-in scene (ablation, porous, gas, shell) as a LAMMPS dump", setup_synth);

}  // namespace
}  // namespace mds::cli
