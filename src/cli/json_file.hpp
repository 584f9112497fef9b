// The one convention of every subcommand: --config FILE names a JSON file.
#pragma once
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace atacom::cli {

inline nlohmann::json read_json_file(const std::string& path) {
  if (std::filesystem::is_directory(path))
    throw std::invalid_argument("config file '" + path + "' is a directory (--config takes a JSON file)");
  std::ifstream f(path);
  if (!f) throw std::invalid_argument("cannot read config file '" + path + "'");
  try {
    return nlohmann::json::parse(f);
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument("config file '" + path + "' is not valid JSON: " + e.what());
  }
}

}  // namespace atacom::cli
