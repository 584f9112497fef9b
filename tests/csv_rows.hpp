// A CSV (a report's, a run's progress.csv) read two ways: rows of column name
// -> cell text, or a header and rows of cells looked up by column name. Every
// cell is kept, empty ones included (an empty last cell too), and every row
// must be as wide as the header.
#pragma once
#include <catch2/catch.hpp>

#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/test_files.hpp"

namespace csv_rows {

// The header and the rows of cells.
struct Table {
  std::vector<std::string> head;
  std::vector<std::vector<std::string>> rows;
  size_t col(const std::string& name) const {
    for (size_t c = 0; c < head.size(); ++c)
      if (head[c] == name) return c;
    FAIL("no column " << name);
    return 0;
  }
  const std::string& at(size_t row, const std::string& name) const { return rows.at(row).at(col(name)); }
  double num(size_t row, const std::string& name) const { return std::stod(at(row, name)); }
};

inline Table read_table(const std::filesystem::path& p) {
  Table t;
  std::istringstream in(slurp(p.string()));
  std::string line;
  std::getline(in, line);
  t.head = csv_cells(line);
  while (std::getline(in, line)) {
    t.rows.push_back(csv_cells(line));
    REQUIRE(t.rows.back().size() == t.head.size());
  }
  return t;
}

inline std::vector<std::map<std::string, std::string>> read(const std::filesystem::path& p) {
  const Table t = read_table(p);
  std::vector<std::map<std::string, std::string>> rows;
  for (const auto& f : t.rows) {
    std::map<std::string, std::string> r;
    for (size_t i = 0; i < f.size(); ++i) r[t.head[i]] = f[i];
    rows.push_back(r);
  }
  return rows;
}

}  // namespace csv_rows
