// The subcommand registry and the CLI's shared helpers (see command.h). Compiled into the
// mdstream executable and into libmdstream_vulkan.so, which each keep their own registry: the
// module hands its commands to the executable (vulkan_module.h).
#include "cli/command.h"

#include <unistd.h>

#include <cstdio>

namespace mds::cli {

std::vector<Command>& registry() {
  static std::vector<Command> commands;
  return commands;
}

int report(const std::string& command, const Error& e) {
  std::fprintf(stderr, "mdstream %s: error [%s]: %s\n", command.c_str(), errc_name(e.code), e.message.c_str());
  switch (e.code) {
    case Errc::invalid_argument: return 2;
    case Errc::io: return 3;
    case Errc::budget: return 4;
    case Errc::internal: return 70;
    default: return 1;
  }
}

bool stderr_is_tty() { return isatty(STDERR_FILENO) == 1; }

}  // namespace mds::cli
