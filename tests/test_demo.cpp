#include <catch2/catch.hpp>

#include "src/experiments/demo.hpp"
#include "atacom/parallel.hpp"

TEST_CASE("demo: no collisions through ATACOM, many without, same result for 1 and 2 threads", "[demo]") {
  atacom::DemoConfig cfg = atacom::default_demo_config();
  cfg.envs = 256;
  cfg.steps = 600;
  atacom::set_num_threads(1);
  const auto r1 = atacom::run_demo(cfg);
  atacom::set_num_threads(2);
  const auto r2 = atacom::run_demo(cfg);
  atacom::set_num_threads(0);
  CHECK(r1.summary["atacom"]["collisions"] == 0);
  CHECK(r1.summary["no_atacom"]["collisions"].get<long>() > 100);
  CHECK(r1.summary["atacom"]["max_constraint"] == r2.summary["atacom"]["max_constraint"]);
  CHECK(r1.summary["no_atacom"]["collisions"] == r2.summary["no_atacom"]["collisions"]);
  CHECK(r1.svg.find("<svg") == 0);
  cfg.envs = 0;
  CHECK_THROWS_WITH(atacom::run_demo(cfg), Catch::Contains("--envs"));
}
