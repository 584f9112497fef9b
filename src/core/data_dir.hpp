// Where the project's data files are found (the order: atacom/data_dir.hpp).
#pragma once
#include <string>

#include "atacom/data_dir.hpp"

namespace atacom {

// Full path of a data file; throws std::runtime_error naming the directory
// searched and how to override it when the file does not exist.
std::string data_file(const std::string& name);

}  // namespace atacom
