#include "store/type_style.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

namespace mds::store {
namespace {

std::string_view type_name(const TypeEntry& t) { return {t.name, strnlen(t.name, sizeof(t.name))}; }

// "1, 2 (Cu), ..." for error messages.
std::string type_list(std::span<const TypeEntry> types) {
  std::string s;
  for (const TypeEntry& t : types) {
    if (!s.empty()) s += ", ";
    s += std::to_string(t.input_id);
    if (!type_name(t).empty()) s += fmt::format(" ({})", type_name(t));
  }
  return s.empty() ? "none" : s;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

Srgb default_type_color(uint32_t type_index) {
  static constexpr uint32_t kTableau10[10] = {0x4E79A7, 0xF28E2B, 0xE15759, 0x76B7B2, 0x59A14F,
                                              0xEDC948, 0xB07AA1, 0xFF9DA7, 0x9C755F, 0xBAB0AC};
  const uint32_t c = kTableau10[type_index % 10];
  return {float((c >> 16) & 0xff) / 255.0f, float((c >> 8) & 0xff) / 255.0f, float(c & 0xff) / 255.0f};
}

Result<Srgb> parse_srgb(std::string_view given) {
  const std::string_view text = trim(given);  // spaces around the colour and its numbers are allowed
  if (!text.empty() && text.front() == '#') {
    if (text.size() != 7)
      return make_error(Errc::invalid_argument, "colour '{}': expected #rrggbb (6 hex digits)", text);
    float v[3];
    for (int i = 0; i < 3; ++i) {
      const int hi = hex_digit(text[1 + 2 * i]), lo = hex_digit(text[2 + 2 * i]);
      if (hi < 0 || lo < 0) return make_error(Errc::invalid_argument, "colour '{}': '{}' is not a hex digit", text,
                                              hi < 0 ? text[1 + 2 * i] : text[2 + 2 * i]);
      v[i] = float(hi * 16 + lo) / 255.0f;
    }
    return Srgb{v[0], v[1], v[2]};
  }
  float v[3];
  std::string_view rest = text;
  for (int i = 0; i < 3; ++i) {
    const size_t comma = rest.find(',');
    const std::string_view item = trim(rest.substr(0, comma));
    if ((i < 2) != (comma != std::string_view::npos))
      return make_error(Errc::invalid_argument, "colour '{}': expected #rrggbb or r,g,b (sRGB, 0..1)", text);
    double x = 0.0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), x);
    if (item.empty() || ec != std::errc() || end != item.data() + item.size() || !(x >= 0.0 && x <= 1.0))
      return make_error(Errc::invalid_argument, "colour '{}': '{}' is not a number in [0, 1]", text, item);
    v[i] = float(x);
    if (comma != std::string_view::npos) rest = rest.substr(comma + 1);
  }
  return Srgb{v[0], v[1], v[2]};
}

std::string srgb_hex(const Srgb& c) {
  auto byte = [](float x) { return unsigned(std::lround(std::fmin(std::fmax(x, 0.0f), 1.0f) * 255.0f)); };
  return fmt::format("#{:02x}{:02x}{:02x}", byte(c.r), byte(c.g), byte(c.b));
}

Result<TypeColorSpec> parse_type_color(std::string_view text) {
  const size_t eq = text.find('=');
  if (eq == std::string_view::npos || eq == 0)
    return make_error(Errc::invalid_argument, "'{}': expected TYPE=COLOR, e.g. 1=#e15759 or Cu=0.72,0.45,0.2", text);
  auto color = parse_srgb(text.substr(eq + 1));
  if (!color) return make_error(Errc::invalid_argument, "'{}': {}", text, color.error().message);
  return TypeColorSpec{std::string(text.substr(0, eq)), *color};
}

Result<uint32_t> find_type(std::span<const TypeEntry> types, std::string_view key) {
  for (size_t i = 0; i < types.size(); ++i)
    if (!key.empty() && type_name(types[i]) == key) return uint32_t(i);
  int32_t id = 0;
  const auto [end, ec] = std::from_chars(key.data(), key.data() + key.size(), id);
  if (!key.empty() && ec == std::errc() && end == key.data() + key.size())
    for (size_t i = 0; i < types.size(); ++i)
      if (types[i].input_id == id) return uint32_t(i);
  return make_error(Errc::invalid_argument, "no type '{}' in the store (its types: {})", key, type_list(types));
}

Result<std::vector<Srgb>> type_colors(std::span<const TypeEntry> types, std::span<const TypeColorSpec> specs) {
  std::vector<Srgb> colors(types.size());
  for (size_t i = 0; i < types.size(); ++i) colors[i] = default_type_color(uint32_t(i));
  std::vector<const TypeColorSpec*> given(types.size(), nullptr);
  for (const TypeColorSpec& s : specs) {
    MDS_ASSIGN_OR_RETURN(const uint32_t t, find_type(types, s.key));
    if (given[t])
      return make_error(Errc::invalid_argument, "type {} is given two colours ('{}' and '{}')",
                        types[t].input_id, given[t]->key, s.key);
    given[t] = &s;
    colors[t] = s.color;
  }
  return colors;
}

Result<TypeRadiusSpec> parse_type_radius(std::string_view text) {
  const size_t eq = text.find('=');
  if (eq == std::string_view::npos || eq == 0)
    return make_error(Errc::invalid_argument, "'{}': expected TYPE=RADIUS, e.g. 1=0.7 or Cu=1.28", text);
  const std::string_view value = trim(text.substr(eq + 1));
  double r = 0.0;
  const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), r);
  if (value.empty() || ec != std::errc() || end != value.data() + value.size() || !std::isfinite(r) || r <= 0.0 ||
      r > 3.0e38)
    return make_error(Errc::invalid_argument, "'{}': the radius must be a finite number > 0", text);
  return TypeRadiusSpec{std::string(text.substr(0, eq)), float(r)};
}

Result<std::vector<float>> type_radii(std::span<const TypeEntry> types, std::span<const TypeRadiusSpec> specs) {
  std::vector<float> radii(types.size());
  for (size_t i = 0; i < types.size(); ++i) radii[i] = types[i].radius;
  std::vector<const TypeRadiusSpec*> given(types.size(), nullptr);
  for (const TypeRadiusSpec& s : specs) {
    MDS_ASSIGN_OR_RETURN(const uint32_t t, find_type(types, s.key));
    if (given[t])
      return make_error(Errc::invalid_argument, "type {} is given two radii ('{}' and '{}')", types[t].input_id,
                        given[t]->key, s.key);
    given[t] = &s;
    radii[t] = s.radius;
  }
  return radii;
}

Result<std::vector<uint8_t>> shown_types(std::span<const TypeEntry> types, std::span<const std::string> hidden_keys) {
  if (hidden_keys.empty()) return std::vector<uint8_t>{};
  std::vector<uint8_t> shown(types.size(), 1);
  for (const std::string& key : hidden_keys) {
    MDS_ASSIGN_OR_RETURN(const uint32_t t, find_type(types, key));
    shown[t] = 0;
  }
  if (std::none_of(shown.begin(), shown.end(), [](uint8_t v) { return v != 0; }))
    return make_error(Errc::invalid_argument, "every type of the store is hidden: nothing to draw");
  return shown;
}

}  // namespace mds::store
