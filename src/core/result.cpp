#include "core/result.h"

namespace mds {

const char* errc_name(Errc c) {
  switch (c) {
    case Errc::io: return "io";
    case Errc::format: return "format";
    case Errc::range: return "range";
    case Errc::checksum: return "checksum";
    case Errc::unsupported: return "unsupported";
    case Errc::invalid_argument: return "invalid_argument";
    case Errc::budget: return "budget";
    case Errc::internal: return "internal";
  }
  return "unknown";
}

}  // namespace mds
