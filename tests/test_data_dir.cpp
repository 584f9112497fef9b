// Where data files are found: ATACOM_DATA_DIR, then the run-time default the
// Python module sets at import, then the build's source data/ directory.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <string>

#include "src/core/data_dir.hpp"

using namespace atacom;

TEST_CASE("data_dir: environment, then set_data_dir, then the build default", "[data_dir]") {
  const char* old = std::getenv("ATACOM_DATA_DIR");
  const std::string saved = old ? old : "";
  ::unsetenv("ATACOM_DATA_DIR");
  const std::string built_in = data_dir();
  CHECK_NOTHROW(data_file("tiago_arm.json"));  // the build default holds the data

  set_data_dir("/nonexistent/atacom-data");
  CHECK(data_dir() == "/nonexistent/atacom-data");
  CHECK_THROWS_WITH(data_file("tiago_arm.json"), Catch::Contains("/nonexistent/atacom-data"));
  ::setenv("ATACOM_DATA_DIR", "/from/env", 1);
  CHECK(data_dir() == "/from/env");  // the environment wins over the setter
  ::unsetenv("ATACOM_DATA_DIR");
  set_data_dir("");
  CHECK(data_dir() == built_in);

  if (old) ::setenv("ATACOM_DATA_DIR", saved.c_str(), 1);
}
