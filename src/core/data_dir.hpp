// Where the project's data files (robot models, geometry) are found.
//
// Order: the environment variable ATACOM_DATA_DIR; else a directory set at
// run time with set_data_dir() (the Python module sets the data/ folder next
// to its own file at import, so an installed module needs no build path);
// else the source tree's data/ directory baked in at build time
// (ATACOM_DEFAULT_DATA_DIR).
#pragma once
#include <string>

namespace atacom {

std::string data_dir();
// Full path of a data file; throws std::runtime_error naming the directory
// searched and how to override it when the file does not exist.
std::string data_file(const std::string& name);
// Run-time default, used when ATACOM_DATA_DIR is unset ("" clears it).
// Call before creating envs; not synchronised with concurrent data_dir().
void set_data_dir(const std::string& dir);

}  // namespace atacom
