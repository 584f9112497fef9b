// The file and text helpers many tests share, defined once: reading a whole
// file, naming a fresh temporary directory, a CSV line's cells, a
// progress.csv without its clock, counting a string's occurrences. One
// definition each also lets the test files compile together in one
// translation unit (CMake's unity build, tests/CMakeLists.txt).
#pragma once
#include <unistd.h>

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

// The whole file, bytes as stored; empty when it cannot be opened.
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// <temp>/atacom_test_<pid>_<name>, removed if it exists (not created): unique
// to this process, so tests running side by side never share a directory.
inline std::string tmp_dir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("atacom_test_" + std::to_string(::getpid()) + "_" + name);
  std::filesystem::remove_all(p);
  return p.string();
}

// A CSV line's cells, empty ones kept (an empty last one too): n commas, n + 1 cells.
inline std::vector<std::string> csv_cells(const std::string& line) {
  std::vector<std::string> out(1);
  for (char c : line)
    if (c == ',') out.emplace_back();
    else out.back() += c;
  return out;
}

// A progress.csv's text without its wall-clock columns (wall_s,
// time_to_target_s), every other cell kept (empty ones too): what two runs of
// the same config must agree on byte for byte.
inline std::string without_wall(const std::string& csv) {
  std::istringstream in(csv);
  std::string line, out;
  std::vector<std::string> head;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = csv_cells(line);
    if (head.empty()) head = cells;
    for (size_t k = 0; k < cells.size(); ++k)
      if (k >= head.size() || (head[k] != "wall_s" && head[k] != "time_to_target_s")) out += cells[k] + ",";
    out += "\n";
  }
  return out;
}

// How often `what` occurs in `text` (overlapping matches counted).
inline size_t occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}
