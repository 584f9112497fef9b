// Where the project's data files (robot models, geometry, learned fields) are found.
//
// Order: the environment variable ATACOM_DATA_DIR; else a directory set at
// run time with set_data_dir() (the Python module sets the data/ folder next
// to its own file at import); else the source tree's data/ directory baked
// in at build time; else, when that is gone, <dir of the running
// executable>/../share/atacom/data (where `cmake --install` puts it).
// A program linking an installed atacom can call
// set_data_dir(<prefix>/share/atacom/data) (find_package(atacom) sets
// atacom_DATA_DIR to it). The projector needs no data files; the envs do.
#pragma once
#include <string>

namespace atacom {

std::string data_dir();
// Run-time default, used when ATACOM_DATA_DIR is unset ("" clears it).
// Call before creating envs; not synchronised with concurrent data_dir().
void set_data_dir(const std::string& dir);

}  // namespace atacom
