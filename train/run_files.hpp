// The text files of a run directory that grow while it runs: progress.csv
// (kept in memory and rewritten whole, atomically, after every row, so a
// kill leaves the old or the new file and a planted symlink is replaced,
// never written through) and progress.svg.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace atacom {

class ProgressFile {
 public:
  ProgressFile() = default;
  ProgressFile(std::string path, std::vector<std::string> columns);

  // A new run: the header alone.
  void start();
  // A resumed run: reads the file, checks its header against the columns
  // and keeps its first `rows` rows (rows written after the checkpoint are
  // produced again). Throws std::runtime_error naming what does not fit.
  // Reads the first `rows` rows back (a resume). A file written by an earlier
  // build whose header lacks columns added since (every one of its columns
  // still among this run's) is taken over with NaN in the new columns.
  void restore(int64_t rows);
  void append(const std::vector<double>& row);  // one value per column

  int64_t rows() const { return int64_t(values_.size()); }
  const std::vector<std::string>& columns() const { return columns_; }
  int column(const std::string& name) const;  // -1 if absent
  // Column `col` of every row (the curves).
  std::vector<double> series(int col) const;

  static std::string format(double v);  // "%.9g"; nan, inf, -inf

 private:
  void write() const;
  std::string path_;
  std::vector<std::string> columns_;
  std::string header_;
  std::vector<std::string> lines_;            // rows as written
  std::vector<std::vector<double>> values_;   // rows as numbers
};

}  // namespace atacom
