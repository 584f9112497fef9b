// Where the project's data files (robot models, geometry) are found.
//
// Order: the environment variable ATACOM_DATA_DIR, else the source tree's
// data/ directory baked in at build time (ATACOM_DEFAULT_DATA_DIR).
#pragma once
#include <string>

namespace atacom {

std::string data_dir();
// Full path of a data file; throws std::runtime_error naming the directory
// searched and how to override it when the file does not exist.
std::string data_file(const std::string& name);

}  // namespace atacom
