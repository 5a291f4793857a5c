// Frame selections (Python slices); see frame_selection.h.
#include "core/frame_selection.h"

#include <algorithm>
#include <charconv>

namespace mds {
namespace {

// A whole signed decimal integer, or nullopt.
std::optional<int64_t> parse_index(std::string_view s) {
  int64_t v = 0;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (!s.empty() && s.front() == '+') ++b;
  auto [p, ec] = std::from_chars(b, e, v);
  if (ec != std::errc() || p != e || b == e) return std::nullopt;
  return v;
}

}  // namespace

Result<FrameSelection> parse_frame_selection(std::string_view text) {
  FrameSelection sel;
  sel.text = std::string(text);
  const auto bad = [&](const char* why) {
    return make_error(Errc::invalid_argument, "'{}': {}; expected all, last, an index K, or a slice A:B or A:B:S "
                      "(B exclusive, negative counts from the end)", sel.text, why);
  };
  if (text == "all") return sel;
  if (text == "last") {
    sel.single = true;
    sel.start = -1;
    return sel;
  }
  const size_t c1 = text.find(':');
  if (c1 == std::string_view::npos) {
    const auto k = parse_index(text);
    if (!k) return bad("not an index");
    sel.single = true;
    sel.start = *k;
    return sel;
  }
  const std::string_view a = text.substr(0, c1);
  std::string_view rest = text.substr(c1 + 1);
  const size_t c2 = rest.find(':');
  const std::string_view b = rest.substr(0, c2);
  const std::string_view s = c2 == std::string_view::npos ? std::string_view{} : rest.substr(c2 + 1);
  if (c2 != std::string_view::npos && s.find(':') != std::string_view::npos) return bad("more than two ':'");
  if (!a.empty()) {
    sel.start = parse_index(a);
    if (!sel.start) return bad("the start is not an index");
  }
  if (!b.empty()) {
    sel.stop = parse_index(b);
    if (!sel.stop) return bad("the stop is not an index");
  }
  if (!s.empty()) {
    const auto st = parse_index(s);
    if (!st || *st < 1) return bad("the step is not an integer >= 1");
    sel.step = *st;
  }
  return sel;
}

Result<std::vector<int64_t>> select_frames(const FrameSelection& sel, int64_t count) {
  std::vector<int64_t> out;
  if (sel.single) {
    const int64_t k = *sel.start < 0 ? *sel.start + count : *sel.start;
    if (k < 0 || k >= count)
      return make_error(Errc::invalid_argument, "'{}': out of range: there {} {} frame{}", sel.text,
                        count == 1 ? "is" : "are", count, count == 1 ? "" : "s");
    out.push_back(k);
    return out;
  }
  // Python's slice.indices for a positive step: negative bounds count from the end, then clamp.
  const auto bound = [&](std::optional<int64_t> v, int64_t dflt) {
    if (!v) return dflt;
    const int64_t x = *v < 0 ? *v + count : *v;
    return std::clamp<int64_t>(x, 0, count);
  };
  const int64_t start = bound(sel.start, 0), stop = bound(sel.stop, count);
  for (int64_t k = start; k < stop; k += sel.step) {  // (no overflow: k + step is formed only below stop)
    out.push_back(k);
    if (sel.step >= stop - k) break;
  }
  if (out.empty())
    return make_error(Errc::invalid_argument, "'{}': selects none of the {} frame{}", sel.text, count,
                      count == 1 ? "" : "s");
  return out;
}

}  // namespace mds
