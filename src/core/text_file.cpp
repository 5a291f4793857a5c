#include "core/text_file.h"

#include <unistd.h>

#include <fstream>
#include <string>

namespace mds {

Status write_text_atomically(const std::filesystem::path& path, std::string_view text) {
  const std::string tmp = path.string() + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) return make_error(Errc::io, "{}: cannot create", tmp);
    f.write(text.data(), std::streamsize(text.size()));
    f.flush();
    if (!f.good()) {
      f.close();
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      return make_error(Errc::io, "{}: cannot write", tmp);
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return make_error(Errc::io, "{}: cannot rename into place: {}", path.string(), ec.message());
  }
  return {};
}

}  // namespace mds
