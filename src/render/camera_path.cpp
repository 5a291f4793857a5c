// Camera paths: the keyframe text format (docs/camera-path.md), linear interpolation between
// keyframes, and the built-in paths of the cache stress tests (issue 4, `mdstream stress`).
#include "core/text_file.h"
#include "render/camera_path.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <system_error>

#include <fmt/format.h>
#include <glm/gtc/constants.hpp>

namespace mds::render {

namespace {

constexpr const char* kFieldNames[12] = {"frame", "ex", "ey", "ez", "tx", "ty", "tz",
                                         "ux",    "uy", "uz", "fov_y_deg", "ortho"};

std::string_view trim(std::string_view s) {
  const char* ws = " \t\r\n\v\f";
  size_t b = s.find_first_not_of(ws);
  if (b == std::string_view::npos) return {};
  size_t e = s.find_last_not_of(ws);
  return s.substr(b, e - b + 1);
}

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    size_t b = i;
    while (i < s.size() && !(s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    if (i > b) out.push_back(s.substr(b, i - b));
  }
  return out;
}

// A token as a double: the whole token must parse. NaN/Inf parse but are rejected by the caller.
bool parse_double(std::string_view tok, double* out) {
  const char* b = tok.data();
  const char* e = tok.data() + tok.size();
  if (b != e && *b == '+') ++b;  // from_chars does not accept a leading '+'
  auto [p, ec] = std::from_chars(b, e, *out);
  return ec == std::errc() && p == e;
}

// |a x b| relative to |a||b|: up must not be (nearly) parallel to the view direction.
bool nearly_parallel(const glm::dvec3& a, const glm::dvec3& b) {
  double la = glm::length(a), lb = glm::length(b);
  return la == 0.0 || lb == 0.0 || glm::length(glm::cross(a, b)) < 1e-9 * la * lb;
}

// A unit vector orthogonal-ish to `dir` to use as up when the preferred one is parallel.
glm::dvec3 up_for(const glm::dvec3& dir, const glm::dvec3& preferred) {
  if (!nearly_parallel(dir, preferred)) return preferred;
  return std::abs(dir.z) < 0.9 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0);
}

// Distance from the centre at which the bounding sphere of the bounds fits in the frustum.
double sphere_fit_distance(const Bounds& b, double fov_y_deg, double aspect) {
  const double R = std::max(b.bounding_radius(), 1e-6);
  const double half_v = glm::radians(fov_y_deg) * 0.5;
  const double half_h = std::atan(std::tan(half_v) * aspect);
  return R / std::sin(std::min(half_v, half_h)) * 1.02;
}

Camera look_from(const glm::dvec3& center, const glm::dvec3& dir, double distance, double fov_y_deg) {
  Camera c;
  c.fov_y_deg = fov_y_deg;
  c.target = center;
  c.eye = center + glm::normalize(dir) * distance;
  c.up = up_for(c.target - c.eye, glm::dvec3(0, 1, 0));
  return c;
}

}  // namespace

CameraPath::CameraPath(std::vector<CameraKey> keys) : keys_(std::move(keys)) {}

uint32_t CameraPath::frame_count() const { return keys_.empty() ? 0u : keys_.back().frame + 1u; }

Camera CameraPath::at(uint32_t frame) const {
  // First key with key.frame > frame.
  auto it = std::upper_bound(keys_.begin(), keys_.end(), frame,
                             [](uint32_t f, const CameraKey& k) { return f < k.frame; });
  auto held = [](Camera c) {
    c.up = glm::normalize(c.up);
    return c;
  };
  if (it == keys_.begin()) return held(keys_.front().camera);
  if (it == keys_.end()) return held(keys_.back().camera);
  const CameraKey& a = *(it - 1);
  const CameraKey& b = *it;
  if (a.frame == frame) return held(a.camera);
  const double t = double(frame - a.frame) / double(b.frame - a.frame);
  Camera c = a.camera;  // ortho, near/far: from the earlier key
  // a + (b - a) t, not mix(): equal keys give exactly the key's camera (a held view).
  c.eye = a.camera.eye + (b.camera.eye - a.camera.eye) * t;
  c.target = a.camera.target + (b.camera.target - a.camera.target) * t;
  c.fov_y_deg = a.camera.fov_y_deg + (b.camera.fov_y_deg - a.camera.fov_y_deg) * t;
  glm::dvec3 up = a.camera.up + (b.camera.up - a.camera.up) * t;
  const glm::dvec3 dir = c.target - c.eye;
  if (glm::length(dir) == 0.0) c.target = c.eye + glm::normalize(a.camera.target - a.camera.eye);
  if (nearly_parallel(c.target - c.eye, up)) up = nearly_parallel(c.target - c.eye, a.camera.up) ? b.camera.up : a.camera.up;
  c.up = glm::normalize(up_for(c.target - c.eye, up));
  return c;
}

Result<CameraPath> CameraPath::parse(std::string_view text, std::string_view name) {
  std::vector<CameraKey> keys;
  size_t line_no = 0;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t nl = text.find('\n', pos);
    std::string_view line = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    ++line_no;
    if (size_t h = line.find('#'); h != std::string_view::npos) line = line.substr(0, h);
    line = trim(line);
    if (line.empty()) continue;
    const auto tok = split_ws(line);
    if (tok.size() != 12)
      return make_error(Errc::format,
                        "{}:{}: expected 12 fields (frame ex ey ez tx ty tz ux uy uz fov_y_deg ortho), found {}", name,
                        line_no, tok.size());
    std::array<double, 12> v{};
    for (size_t i = 0; i < 12; ++i) {
      if (!parse_double(tok[i], &v[i]))
        return make_error(Errc::format, "{}:{}: field {} ({}) '{}' is not a number", name, line_no, i + 1,
                          kFieldNames[i], tok[i]);
      if (!std::isfinite(v[i]))
        return make_error(Errc::range, "{}:{}: field {} ({}) '{}' is not finite", name, line_no, i + 1, kFieldNames[i],
                          tok[i]);
    }
    if (v[0] < 0.0 || v[0] != std::floor(v[0]) || v[0] > 4294967294.0)
      return make_error(Errc::format, "{}:{}: frame '{}' is not a non-negative integer", name, line_no, tok[0]);
    const uint32_t frame = uint32_t(v[0]);
    if (!keys.empty() && frame <= keys.back().frame)
      return make_error(Errc::format, "{}:{}: frame {} is not greater than the previous keyframe's frame {}", name,
                        line_no, frame, keys.back().frame);
    if (!(v[10] > 0.0 && v[10] < 180.0))
      return make_error(Errc::range, "{}:{}: fov_y_deg {} is not in (0, 180)", name, line_no, tok[10]);
    if (v[11] != 0.0 && v[11] != 1.0)
      return make_error(Errc::format, "{}:{}: ortho '{}' must be 0 or 1", name, line_no, tok[11]);
    CameraKey k;
    k.frame = frame;
    k.camera.eye = {v[1], v[2], v[3]};
    k.camera.target = {v[4], v[5], v[6]};
    k.camera.up = {v[7], v[8], v[9]};
    k.camera.fov_y_deg = v[10];
    k.camera.ortho = v[11] == 1.0;
    if (k.camera.eye == k.camera.target)
      return make_error(Errc::range, "{}:{}: eye and target coincide", name, line_no);
    if (nearly_parallel(k.camera.target - k.camera.eye, k.camera.up))
      return make_error(Errc::range, "{}:{}: up vector is zero or parallel to the view direction", name, line_no);
    keys.push_back(k);  // up as written (at() returns it normalised): save/load is exact
  }
  if (keys.empty()) return make_error(Errc::format, "{}: no keyframes (expected lines 'frame ex ey ez tx ty tz ux uy uz fov_y_deg ortho')", name);
  return CameraPath(std::move(keys));
}

Result<CameraPath> CameraPath::load(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return make_error(Errc::io, "{}: cannot open camera path", path.string());
  std::stringstream ss;
  ss << f.rdbuf();
  if (f.bad()) return make_error(Errc::io, "{}: read error", path.string());
  return parse(ss.str(), path.string());
}

std::string CameraPath::to_text() const {
  std::string s = "# mdstream camera path v1\n# frame ex ey ez tx ty tz ux uy uz fov_y_deg ortho\n";
  for (const CameraKey& k : keys_) {
    const Camera& c = k.camera;
    // "{}" prints the shortest representation that reads back to the same double.
    s += fmt::format("{} {} {} {} {} {} {} {} {} {} {} {}\n", k.frame, c.eye.x, c.eye.y, c.eye.z, c.target.x,
                     c.target.y, c.target.z, c.up.x, c.up.y, c.up.z, c.fov_y_deg, c.ortho ? 1 : 0);
  }
  return s;
}

Status CameraPath::save(const std::filesystem::path& path) const { return write_text_atomically(path, to_text()); }


Result<BuiltinPath> parse_builtin_path(std::string_view name) {
  if (name == "orbit") return BuiltinPath::orbit;
  if (name == "flythrough") return BuiltinPath::flythrough;
  if (name == "jumps") return BuiltinPath::jumps;
  return make_error(Errc::invalid_argument, "unknown built-in camera path '{}' (expected orbit, flythrough or jumps)",
                    name);
}

const char* builtin_path_name(BuiltinPath kind) {
  switch (kind) {
    case BuiltinPath::orbit: return "orbit";
    case BuiltinPath::flythrough: return "flythrough";
    case BuiltinPath::jumps: return "jumps";
  }
  return "?";
}

std::vector<Camera> jump_views(const Bounds& bounds, double fov_y_deg, double aspect) {
  std::vector<Camera> views;
  for (int i = 0; i < 3; ++i) {
    Result<Camera> c = default_view(i, bounds, fov_y_deg, aspect);
    views.push_back(c.ok() ? *c : look_from(bounds.center(), glm::dvec3(0, 0, 1), 1.0, fov_y_deg));
  }
  // View 0 looks along -z from +z; the other five axis directions complete the set of 8.
  const double d = sphere_fit_distance(bounds, fov_y_deg, aspect);
  const glm::dvec3 dirs[5] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, -1}};
  for (const auto& dir : dirs) views.push_back(look_from(bounds.center(), dir, d, fov_y_deg));
  return views;
}

CameraPath builtin_path(BuiltinPath kind, const Bounds& bounds, uint32_t frames, double fov_y_deg, double aspect) {
  frames = std::max(frames, 1u);
  const glm::dvec3 center = bounds.center();
  const double R = std::max(bounds.bounding_radius(), 1e-6);
  std::vector<CameraKey> keys;
  keys.reserve(frames);
  switch (kind) {
    case BuiltinPath::orbit: {
      Result<Camera> v0 = default_view(0, bounds, fov_y_deg, aspect);
      const double d = v0.ok() ? glm::length(v0->eye - center) : sphere_fit_distance(bounds, fov_y_deg, aspect);
      const double elev = glm::radians(15.0);
      for (uint32_t f = 0; f < frames; ++f) {
        const double th = 2.0 * std::numbers::pi * double(f) / double(frames);
        glm::dvec3 dir(std::sin(th) * std::cos(elev), std::sin(elev), std::cos(th) * std::cos(elev));
        keys.push_back({f, look_from(center, dir, d, fov_y_deg)});
      }
      break;
    }
    case BuiltinPath::flythrough: {
      // Enter through the +z face, slightly off-axis so the flight does not run along node
      // boundaries, leave through the opposite face; the target stays a quarter radius ahead.
      const glm::dvec3 dir = glm::normalize(glm::dvec3(0.12, 0.08, -1.0));
      const glm::dvec3 start = center - dir * (1.05 * R), end = center + dir * (1.05 * R);
      for (uint32_t f = 0; f < frames; ++f) {
        const double t = frames > 1 ? double(f) / double(frames - 1) : 0.0;
        Camera c;
        c.fov_y_deg = fov_y_deg;
        c.eye = glm::mix(start, end, t);
        c.target = c.eye + dir * (0.25 * R);
        c.up = up_for(dir, glm::dvec3(0, 1, 0));
        keys.push_back({f, c});
      }
      break;
    }
    case BuiltinPath::jumps: {
      const std::vector<Camera> views = jump_views(bounds, fov_y_deg, aspect);
      const uint32_t n = uint32_t(views.size());
      const uint32_t seg = std::max(1u, frames / n);
      for (uint32_t f = 0; f < frames; ++f) keys.push_back({f, views[std::min(n - 1, f / seg)]});
      break;
    }
  }
  for (auto& k : keys) {
    k.camera.up = glm::normalize(k.camera.up);
    k.camera.ortho_half_height = 0.0;  // not part of the file format: derived from the distance
  }
  return CameraPath(std::move(keys));
}

}  // namespace mds::render
