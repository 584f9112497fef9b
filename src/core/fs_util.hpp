// Files a run leaves behind are written atomically: temp file, fsync, rename.
// A crash mid-write never leaves a half-written result or checkpoint.
#pragma once
#include <string>

namespace atacom {

// Writes `data` to `path` atomically. Throws std::runtime_error naming the path.
void write_file_atomic(const std::string& path, const std::string& data);

}  // namespace atacom
