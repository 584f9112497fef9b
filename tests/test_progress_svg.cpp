// progress.svg: panels for what progress.csv holds (train/progress_svg.hpp).
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <unistd.h>

#include "train/progress_svg.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;

namespace {

atacom::ProgressFile progress(const std::vector<std::string>& cols, const std::vector<std::vector<double>>& rows) {
  const std::string path = (fs::temp_directory_path() / ("atacom_progress_svg_" + std::to_string(::getpid()) + ".csv")).string();
  atacom::ProgressFile p(path, cols);
  p.start();
  for (const auto& r : rows) p.append(r);
  fs::remove(path);
  return p;
}

}  // namespace

TEST_CASE("progress.svg: return, final distance, training and evaluation safety panels", "[progress_svg]") {
  const std::vector<std::string> cols = {"env_steps",        "eval_return_mean", "eval_return_std", "final_distance",
                                         "collision",        "violations",       "train_collision", "train_wall_collision",
                                         "train_violations"};
  const auto p = progress(cols, {{1000, -300, 20, 0.9, 0.2, 3, 4, 1, 10},
                                 {2000, -200, 15, 0.5, 0.0, 1, 6, 1, 12},
                                 {3000, -150, 10, NAN, 0.0, 0, 6, 2, 12}});
  const std::string svg = atacom::progress_svg("table / sac / seed <0>", p, true);
  REQUIRE(svg.rfind("<svg", 0) == 0);
  CHECK(svg.find("table / sac / seed &lt;0&gt;") != std::string::npos);
  for (const char* title : {"evaluation return", "final distance to the goal", "training: collisions and violations",
                            "evaluation: collisions and violations per episode"})
    CHECK(svg.find(title) != std::string::npos);
  CHECK(occurrences(svg, "<svg") == 5);  // the outer image and four panels
  // legends name every series of the safety panels
  for (const char* series : {"collisions", "wall_collisions", "violations (steps)"}) CHECK(svg.find(series) != std::string::npos);
  // a NaN point is skipped: the final-distance curve has two dots, not three
  const size_t fd = svg.find("final distance to the goal");
  const std::string panel = svg.substr(fd, svg.find("</svg>", fd) - fd);
  CHECK(occurrences(panel, "<circle") == 2);
  CHECK(svg.find("nan") == std::string::npos);
}

TEST_CASE("progress.svg: an env without constraints or a goal gets the return panel only", "[progress_svg]") {
  const auto p = progress({"env_steps", "eval_return_mean", "eval_return_std", "violations", "train_violations"},
                          {{300, -1200, 100, 0, 0}, {600, -900, 80, 0, 0}});
  const std::string svg = atacom::progress_svg("pendulum", p, false);
  CHECK(occurrences(svg, "<svg") == 2);
  CHECK(svg.find("evaluation return") != std::string::npos);
  CHECK(svg.find("violations") == std::string::npos);
}

TEST_CASE("progress.svg: the values as progress.csv holds them, so a resumed run draws the same bytes", "[progress_svg]") {
  // A run that kept its rows in memory and one that read the first of them back from the CSV (9 digits).
  const double d = 1.2562641234567891, d9 = 1.25626412;
  const std::vector<std::string> cols = {"env_steps", "eval_return_mean", "eval_return_std", "final_distance"};
  const auto kept = progress(cols, {{1000, -500.00000012345, 3, d}, {2000, -400, 3, d}, {3000, -300, 3, d}});
  const auto resumed = progress(cols, {{1000, -500.000000, 3, d9}, {2000, -400, 3, d9}, {3000, -300, 3, d}});
  CHECK(atacom::progress_svg("t", kept, false) == atacom::progress_svg("t", resumed, false));
}
