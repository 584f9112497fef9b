// A report CSV as rows of column name -> cell text: every cell, empty ones
// included (an empty last cell too), and every row as wide as the header.
#pragma once
#include <catch2/catch.hpp>

#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/test_files.hpp"

namespace csv_rows {

inline std::vector<std::map<std::string, std::string>> read(const std::filesystem::path& p) {
  std::istringstream in(slurp(p.string()));
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> head = csv_cells(line);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    const std::vector<std::string> f = csv_cells(line);
    REQUIRE(f.size() == head.size());
    std::map<std::string, std::string> r;
    for (size_t i = 0; i < f.size(); ++i) r[head[i]] = f[i];
    rows.push_back(r);
  }
  return rows;
}

}  // namespace csv_rows
