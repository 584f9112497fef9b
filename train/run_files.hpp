// The text files of a run directory that grow while it runs: progress.csv
// (kept in memory and rewritten whole, atomically, after every row, so a
// kill leaves the old or the new file and a planted symlink is replaced,
// never written through) and progress.svg.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace atacom {

// The columns of the quality target's first meeting (time_to_target_s,
// steps_to_target, updates_to_target, train_cost_to_target): the last four of
// progress.csv, empty cells until the target is met.
const std::vector<std::string>& target_columns();

class ProgressFile {
 public:
  ProgressFile() = default;
  // A NaN in a column of `blank_nan` is written as an empty cell (and an
  // empty cell there reads back as NaN); elsewhere as "nan".
  ProgressFile(std::string path, std::vector<std::string> columns, const std::vector<std::string>& blank_nan = {});

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
  std::vector<uint8_t> blank_nan_;            // (columns) 1: NaN is an empty cell
  std::string header_;
  std::vector<std::string> lines_;            // rows as written
  std::vector<std::vector<double>> values_;   // rows as numbers
};

}  // namespace atacom
