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
  std::error_code ec;
  if (std::filesystem::is_directory(ATACOM_DEFAULT_DATA_DIR, ec)) return ATACOM_DEFAULT_DATA_DIR;
  // An installed binary whose source tree is gone: the data `cmake --install` put beside it.
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path installed = exe.parent_path().parent_path() / "share" / "atacom" / "data";
    if (std::filesystem::is_directory(installed, ec)) return installed.string();
  }
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
