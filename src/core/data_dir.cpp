#include "src/core/data_dir.hpp"

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#ifndef ATACOM_DEFAULT_DATA_DIR
#define ATACOM_DEFAULT_DATA_DIR "data"
#endif

namespace atacom {

namespace {
std::string& runtime_data_dir() {
  static std::string dir;
  return dir;
}
}  // namespace

void set_data_dir(const std::string& dir) { runtime_data_dir() = dir; }

std::string data_dir() {
  const char* env = std::getenv("ATACOM_DATA_DIR");
  if (env != nullptr && env[0] != '\0') return env;
  if (!runtime_data_dir().empty()) return runtime_data_dir();
  return ATACOM_DEFAULT_DATA_DIR;
}

std::string data_file(const std::string& name) {
  const std::filesystem::path path = std::filesystem::path(data_dir()) / name;
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error("data file '" + name + "' not found in '" + data_dir() +
                             "' (set ATACOM_DATA_DIR to the directory holding the project's data/ files)");
  return path.string();
}

}  // namespace atacom
