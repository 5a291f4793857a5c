// Subcommand registry of the `mdstream` CLI. Each src/cli/cmd_*.cpp registers itself:
//
//   static mds::cli::Registrar reg("convert", "Convert simulation dumps to a store", setup_convert);
//
// where setup_convert(CLI::App& sub, int& exit_code) adds options to `sub` and a callback that
// runs the command and sets exit_code. Only the CLI prints and exits; libraries return errors.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/result.h"

namespace mds::cli {

using Setup = std::function<void(CLI::App& sub, int& exit_code)>;

struct Command {
  std::string name;
  std::string description;
  Setup setup;
};

std::vector<Command>& registry();

struct Registrar {
  Registrar(std::string name, std::string description, Setup setup) {
    registry().push_back({std::move(name), std::move(description), std::move(setup)});
  }
};

// Prints "mdstream <command>: error [<code>]: <message>" to stderr and returns the exit code
// for that error class (1 for bad input, 2 for usage, 3 for I/O, 4 for budget, 70 internal).
int report(const std::string& command, const Error& e);

// True when stderr is a terminal (progress bars are drawn only then).
bool stderr_is_tty();

}  // namespace mds::cli
