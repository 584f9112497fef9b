// Subcommands of the `atacom` executable register themselves here, one file
// each (cmd_<name>.cpp), so adding a command never touches main.cpp.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace atacom::cli {

struct Command {
  std::string name;
  std::string help;
  // Adds options to the subcommand and returns the function that runs it
  // (returns the process exit code).
  std::function<std::function<int()>(CLI::App&)> setup;
};

std::vector<Command>& commands();

struct RegisterCommand {
  explicit RegisterCommand(Command c) { commands().push_back(std::move(c)); }
};

}  // namespace atacom::cli
