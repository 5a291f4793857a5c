// mdstream: one CLI, subcommands registered by src/cli/cmd_*.cpp.
#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "cli/command.h"

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

int main(int argc, char** argv) {
  CLI::App app{"mdstream: out-of-core renderer for large particle data (molecular dynamics)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "mdstream 0.1.0");
  int exit_code = 0;
  auto& commands = mds::cli::registry();
  std::sort(commands.begin(), commands.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  for (auto& c : commands) {
    CLI::App* sub = app.add_subcommand(c.name, c.description);
    c.setup(*sub, exit_code);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);  // prints the usage message
    return 2;     // usage errors exit 2, like every option the commands validate themselves
  }
  return exit_code;
}
