// mdstream: one CLI, subcommands registered by src/cli/cmd_*.cpp; the Vulkan commands
// (src/cli/vulkan/) come from libmdstream_vulkan.so, opened only when needed (vulkan_module.h).
#include <algorithm>
#include <cstdio>
#include <string>

#include "cli/command.h"
#include "cli/vulkan_module.h"
#include "core/module_loader.h"

namespace {

bool accept_vulkan(const void* table) {
  const auto* api = static_cast<const mds::cli::VulkanModuleApi*>(table);
  if (api->abi != mds::cli::kVulkanModuleAbi || !api->commands) return false;
  if (api->commands->size() != mds::cli::kVulkanCommands.size()) return false;
  for (const auto& c : *api->commands)
    if (std::find(mds::cli::kVulkanCommands.begin(), mds::cli::kVulkanCommands.end(), c.name) ==
        mds::cli::kVulkanCommands.end())
      return false;
  return true;
}

// The module is needed for a Vulkan command and for the help that lists every command.
bool needs_vulkan(int argc, char** argv, bool& required) {
  required = false;
  if (argc < 2) return true;
  const std::string a = argv[1];
  if (a == "-h" || a == "--help") return true;
  required = std::find(mds::cli::kVulkanCommands.begin(), mds::cli::kVulkanCommands.end(), a) !=
             mds::cli::kVulkanCommands.end();
  return required;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mdstream: out-of-core renderer for large particle data (molecular dynamics)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "mdstream 0.1.0");
  int exit_code = 0;
  auto& commands = mds::cli::registry();
  bool required = false;
  if (needs_vulkan(argc, argv, required)) {
    auto m = mds::load_module(mds::cli::kVulkanModuleFile, mds::cli::kVulkanModuleSymbol, accept_vulkan,
                              "each Vulkan command (bench, render, stress, view)");
    if (m.ok()) {
      const auto* api = static_cast<const mds::cli::VulkanModuleApi*>(*m);
      commands.insert(commands.end(), api->commands->begin(), api->commands->end());
    } else if (required) {
      return mds::cli::report(argv[1], m.error());
    }
  }
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
