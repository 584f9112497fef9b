// The one convention of every subcommand: --config FILE names a JSON file,
// read strictly (duplicate keys, a directory, an oversized file are errors):
// the project's one reader, src/core/config_json.
#pragma once
#include "src/core/config_json.hpp"

namespace atacom::cli {
using atacom::read_json_file;
}  // namespace atacom::cli
