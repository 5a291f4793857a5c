// Store series index (ParaView's file-series JSON); see series.h.
#include "store/series.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/text_file.h"

namespace mds::store {

bool is_series_path(const std::filesystem::path& path) { return path.extension() == ".series"; }

Result<Series> read_series(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return make_error(Errc::io, "{}: cannot open the series index", file.string());
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return make_error(Errc::io, "{}: read error", file.string());
  const std::string text = ss.str();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte counts from 1 (the byte it stopped at); byte offsets in mdstream's messages count from 0.
    return make_error(Errc::format, "{}: byte offset {}: not JSON ({})", file.string(), e.byte > 0 ? e.byte - 1 : 0,
                      e.what());
  } catch (const nlohmann::json::exception& e) {
    // A number the parser cannot hold (out_of_range 406, "number overflow parsing '1e999'"): the
    // message quotes it, and no offset comes with it. Found by fuzz_series.
    return make_error(Errc::format, "{}: not JSON ({})", file.string(), e.what());
  }
  const auto bad = [&](const std::string& where, const std::string& what) {
    return make_error(Errc::format, "{}: {}: {} (a ParaView file-series index: {{\"file-series-version\": \"1.0\", "
                      "\"files\": [{{\"name\": ..., \"time\": ...}}]}})", file.string(), where, what);
  };
  if (!j.is_object()) return bad("/", "expected an object");
  const auto v = j.find("file-series-version");
  if (v == j.end()) return bad("/file-series-version", "missing");
  if (!v->is_string() || v->get<std::string>() != kSeriesVersion)
    return bad("/file-series-version", fmt::format("version {} is not supported (expected \"{}\")", v->dump(),
                                                   kSeriesVersion));
  const auto files = j.find("files");
  if (files == j.end()) return bad("/files", "missing");
  if (!files->is_array()) return bad("/files", "expected an array");
  if (files->empty()) return bad("/files", "no files: a series needs at least one");
  Series s;
  s.file = file;
  const std::filesystem::path dir = file.parent_path();
  for (size_t i = 0; i < files->size(); ++i) {
    const nlohmann::json& f = (*files)[i];
    const std::string at = fmt::format("/files/{}", i);
    if (!f.is_object()) return bad(at, "expected an object with name and time");
    const auto n = f.find("name");
    if (n == f.end() || !n->is_string() || n->get<std::string>().empty())
      return bad(at + "/name", "expected a non-empty string");
    const auto t = f.find("time");
    if (t == f.end() || !t->is_number()) return bad(at + "/time", "expected a number");
    SeriesFrame fr;
    fr.name = n->get<std::string>();
    fr.time = t->get<double>();
    if (!std::isfinite(fr.time)) return bad(at + "/time", "not finite");
    const std::filesystem::path p(fr.name);
    fr.path = p.is_absolute() || dir.empty() ? p : dir / p;
    s.frames.push_back(std::move(fr));
  }
  return s;
}

std::string series_json(const std::vector<SeriesFrame>& frames) {
  // ParaView's layout: one line per file.
  std::string out = fmt::format("{{\n  \"file-series-version\" : \"{}\",\n  \"files\" : [\n", kSeriesVersion);
  for (size_t i = 0; i < frames.size(); ++i) {
    const nlohmann::json name = frames[i].name;  // escaped as JSON
    const double t = frames[i].time;  // a step as an integer, anything else as its shortest round-trip number
    const nlohmann::json time = std::trunc(t) == t && std::fabs(t) < 0x1p53 ? nlohmann::json(int64_t(t)) : nlohmann::json(t);
    out += fmt::format("    {{ \"name\" : {}, \"time\" : {} }}{}\n", name.dump(), time.dump(),
                       i + 1 < frames.size() ? "," : "");
  }
  out += "  ]\n}\n";
  return out;
}

Status write_series(const std::filesystem::path& file, const std::vector<SeriesFrame>& frames) {
  return write_text_atomically(file, series_json(frames));
}

}  // namespace mds::store
