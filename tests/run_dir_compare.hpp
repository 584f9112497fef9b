// Comparing run directories file by file, the wall-clock fields taken out
// (the only thing an interrupted run may change): wall_s in summary.json and
// checkpoint.json, summary.json's time_to_target_s, eval_wall_s and
// eval_share, and progress.csv's wall_s and time_to_target_s columns. checkpoint.bin is left
// out (its counters hold the wall time; checkpoint.json holds its agent hash).
#pragma once
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/test_files.hpp"

namespace run_dir_compare {

inline std::string comparable(const std::filesystem::path& p) {
  const std::string name = p.filename().string();
  const std::string text = slurp(p.string());
  if (name == "summary.json" || name == "checkpoint.json") {
    nlohmann::json j = nlohmann::json::parse(text);
    for (const char* k : {"wall_s", "time_to_target_s", "eval_wall_s", "eval_share"}) j.erase(k);
    return j.dump();
  }
  if (name == "progress.csv") {
    std::istringstream in(text);
    std::string out, line;
    std::vector<size_t> wall_cols;  // wall_s and time_to_target_s, from the header
    while (std::getline(in, line)) {
      std::vector<std::string> cols;
      for (size_t at = 0;;) {  // every cell, an empty last one included
        const size_t comma = line.find(',', at);
        cols.push_back(line.substr(at, comma == std::string::npos ? std::string::npos : comma - at));
        if (comma == std::string::npos) break;
        at = comma + 1;
      }
      REQUIRE(cols.size() > 2);
      if (out.empty()) {
        REQUIRE(cols[2] == "wall_s");
        for (size_t k = 0; k < cols.size(); ++k)
          if (cols[k] == "wall_s" || cols[k] == "time_to_target_s") wall_cols.push_back(k);
      }
      for (size_t k = 0; k < cols.size(); ++k)
        if (std::find(wall_cols.begin(), wall_cols.end(), k) == wall_cols.end()) out += cols[k] + ",";
      out += "\n";
    }
    return out;
  }
  return text;
}

// Every regular file under `dir` (recursively) but checkpoint.bin, by its path relative to `root`.
inline std::map<std::string, std::string> files(const std::string& dir, const std::string& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().filename() == "checkpoint.bin") continue;
    out[std::filesystem::relative(e.path(), root).string()] = comparable(e.path());
  }
  return out;
}

// REQUIREs the same file names and contents.
inline void require_same(const std::map<std::string, std::string>& want, const std::map<std::string, std::string>& got) {
  for (const auto& [name, text] : got) {
    INFO("file only in the interrupted run: " << name);
    CHECK(want.count(name) == 1);
  }
  REQUIRE(got.size() == want.size());
  for (const auto& [name, text] : want) {
    INFO(name);
    REQUIRE(got.count(name) == 1);
    REQUIRE(got.at(name) == text);
  }
}

}  // namespace run_dir_compare
