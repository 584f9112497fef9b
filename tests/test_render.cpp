// `atacom render`: the page is self-contained (no external URL, script,
// style or font), has the SVG views, the slider and both plots, holds one
// frame per step with the geometry of its env, marks the episode's
// terminal event, and the CLI writes it. With chromium on the machine
// ([slow]) the page's script runs and fills in the status line.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>
#include <fstream>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "atacom/trainer.hpp"
#include "src/experiments/render.hpp"
#include "tests/test_files.hpp"

using namespace atacom;
using nlohmann::json;

namespace {

json page_data(const std::string& html) {
  const std::string open = "<script id=\"atacom-data\" type=\"application/json\">";
  const size_t a = html.find(open);
  REQUIRE(a != std::string::npos);
  const size_t b = html.find("</script>", a);
  REQUIRE(b != std::string::npos);
  return json::parse(html.substr(a + open.size(), b - a - open.size()));
}

void check_self_contained(const std::string& html) {
  // The only URL is the SVG namespace the script creates elements in.
  size_t pos = 0;
  int urls = 0;
  while ((pos = html.find("http", pos)) != std::string::npos) {
    CHECK(html.compare(pos, 26, "http://www.w3.org/2000/svg") == 0);
    ++urls;
    pos += 4;
  }
  CHECK(urls <= 1);
  CHECK(html.find("<script src") == std::string::npos);
  CHECK(html.find("<link") == std::string::npos);
  CHECK(html.find("url(") == std::string::npos);
  CHECK(html.find("@import") == std::string::npos);
  CHECK(html.find("//cdn") == std::string::npos);
}

}  // namespace

TEST_CASE("render: table episode without a safety layer ends at its terminal event, one frame per step", "[render]") {
  RenderConfig c;
  c.env = "table";
  c.policy = "random";
  c.safety = SafetyLayer::None;
  c.seed = 1;
  const RenderResult r = render_episode(c);
  check_self_contained(r.html);
  CHECK(r.html.rfind("<!DOCTYPE html>", 0) == 0);
  CHECK(occurrences(r.html, "<input type=\"range\" id=\"slider\"") == 1);
  CHECK(occurrences(r.html, "<div class=\"plot\"><svg") == 2);  // constraints and reward
  CHECK(r.html.find("id=\"views\"") != std::string::npos);
  const json d = page_data(r.html);
  REQUIRE(r.steps > 0);
  CHECK(d["steps"] == r.steps);
  CHECK(d["frames"].size() == static_cast<size_t>(r.steps));
  CHECK(d["reward"].size() == static_cast<size_t>(r.steps));
  CHECK(d["collision"].size() == static_cast<size_t>(r.steps));
  CHECK(d["views"].size() == 2);  // top and side
  // Arm geometry: every frame has all link capsules, all PoIs, goal, axis.
  const size_t caps = d["capsule_radius"].size(), pois = d["sphere_radius"].size();
  CHECK(caps >= 6);
  CHECK(pois == 9);
  for (const json& f : d["frames"]) {
    CHECK(f["cap"].size() == 6 * caps);
    CHECK(f["sph"].size() == 3 * pois);
    CHECK(f["goal"].size() == 3);
    CHECK(f["axis"].size() == 6);
  }
  CHECK(d["statics"]["boxes"].size() >= 2);  // table parts and the torso
  // A random policy without ATACOM ends early, in collision or at a joint limit,
  // and the page marks that step.
  CHECK(r.terminated);
  CHECK(r.steps < 500);
  CHECK(d["collision"].back().get<double>() > 0.0);
  CHECK(r.max_constraint > 0.0);
}

TEST_CASE("render: nav episode through ATACOM, top view with both robots, bad input is rejected", "[render]") {
  RenderConfig c;
  c.env = "nav";
  c.policy = "zero";
  c.seed = 3;
  const RenderResult r = render_episode(c);
  check_self_contained(r.html);
  const json d = page_data(r.html);
  CHECK(d["frames"].size() == static_cast<size_t>(r.steps));
  CHECK(d["views"].size() == 1);
  CHECK(d["disc_cls"] == json({"tiago", "fetch"}));
  CHECK(d["statics"]["boxes"].size() == 4);  // walls
  CHECK(d["frames"][0]["disc"].size() == 6);
  CHECK(r.collisions == 0);
  CHECK(r.max_constraint <= 0.0);
  c.policy = "sideways";
  CHECK_THROWS_AS(render_episode(c), std::invalid_argument);
  c.policy = "zero";
  c.env = "pendulum";
  c.safety = SafetyLayer::None;
  CHECK_THROWS_WITH(render_episode(c), Catch::Contains("no picture"));
}

TEST_CASE("render: the linear attractor and a trained run's policy act through the same contract", "[render]") {
  RenderConfig c;
  c.env = "nav";
  c.policy = "la";
  c.seed = 1;
  const RenderResult nav = render_episode(c);
  CHECK(nav.collisions == 0);
  CHECK(nav.episode_return > 0.0);  // the attractor drives to the goal (zero and random do not)
  c.policy = "zero";
  CHECK(render_episode(c).episode_return < nav.episode_return);
  c.env = "table";
  c.policy = "la";
  const RenderResult table = render_episode(c);
  CHECK(table.collisions == 0);
  CHECK(page_data(table.html)["policy"] == "la");
  // A trained run brings its env, config and layer; settings that do not apply are refused.
  const std::string dir = (std::filesystem::temp_directory_path() / ("atacom_test_render_run." + std::to_string(::getpid()))).string();
  std::filesystem::remove_all(dir);
  const json run = {{"sac", {{"actor", {{"hidden", {16, 16}}}}, {"critic", {{"hidden", {16, 16}}}}, {"batch_size", 16},
                             {"initial_replay", 100}, {"warmup", 100}, {"replay_capacity", 2000}}},
                    {"train", {{"env", "nav"}, {"algo", "atacom-sac"}, {"steps", 300}, {"eval_every", 300},
                               {"eval_episodes", 1}, {"seed", 1}}}};
  TrainOptions o;
  o.out_dir = dir;
  run_training(resolve_run_config(run), o);
  RenderConfig t;
  t.policy = "trained";
  t.run_dir = dir;
  t.seed = 2;
  const RenderResult r = render_episode(t);
  const json d = page_data(r.html);
  CHECK(d["env"] == "nav");
  CHECK(d["safety"] == "atacom");
  CHECK(d["frames"].size() == static_cast<size_t>(r.steps));
  t.which = RunPolicy::Best;
  CHECK(render_episode(t).steps > 0);
  t.env = "table";
  CHECK_THROWS_WITH(render_episode(t), Catch::Contains("differs"));
  t.env.clear();
  t.env_config = {{"velocity_scale", 0.5}};
  CHECK_THROWS_WITH(render_episode(t), Catch::Contains("do not apply"));
  RenderConfig bad;
  bad.env = "nav";
  bad.run_dir = dir;
  CHECK_THROWS_WITH(render_episode(bad), Catch::Contains("--run applies to --policy trained only"));
  bad.run_dir.clear();
  bad.policy = "trained";
  CHECK_THROWS_WITH(render_episode(bad), Catch::Contains("needs --run"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("render: the CLI writes the page and prints its summary", "[render]") {
  const std::string out = (std::filesystem::temp_directory_path() / "atacom_test_render.html").string();
  const std::string cmd = std::string(ATACOM_ATACOM_EXE) + " render --env shelf --policy zero --seed 2 --out " + out;
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p);
  char buf[4096];
  std::string line;
  while (fgets(buf, sizeof buf, p)) line += buf;
  CHECK(pclose(p) == 0);
  const json s = json::parse(line);
  std::ifstream in(out);
  std::stringstream html;
  html << in.rdbuf();
  CHECK(s["bytes"].get<size_t>() == html.str().size());
  CHECK(page_data(html.str())["frames"].size() == s["steps"].get<size_t>());
  std::filesystem::remove(out);
}

TEST_CASE("render: the page's script runs in headless chromium", "[render][slow]") {
  const char* candidates[] = {"/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"};
  std::string browser;
  for (const char* c : candidates)
    if (std::filesystem::exists(c)) browser = c;
  if (browser.empty()) {
    WARN("no chromium on this machine: skipped");
    return;
  }
  RenderConfig c;
  c.env = "table";
  c.policy = "zero";
  c.seed = 4;
  const RenderResult r = render_episode(c);
  const auto dir = std::filesystem::temp_directory_path() / ("atacom_test_render_chromium." + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string page = (dir / "page.html").string();
  std::ofstream(page) << r.html;
  const std::string cmd = browser +
                          " --headless --no-sandbox --disable-gpu --disable-background-networking "
                          "--disable-component-update --disable-sync --no-first-run --user-data-dir=" +
                          (dir / "profile").string() + " --dump-dom 'file://" + page + "?step=7&play=0' 2>/dev/null";
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p);
  char buf[65536];
  std::string dom;
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) dom.append(buf, n);
  pclose(p);
  std::filesystem::remove_all(dir);
  // The script drew the views (one SVG per view plus the two plots) and wrote the status of step 7.
  CHECK(std::regex_search(dom, std::regex("step +7 / " + std::to_string(r.steps))));
  CHECK(occurrences(dom, "<svg") == 4);
  CHECK(occurrences(dom, "class=\"link\"") >= 12);  // the link capsules in both views
}

TEST_CASE("render: the constraint plot's range fits the data, boundary included", "[render]") {
  // nav's distances reach metres below zero (before: clipped at -0.5), an arm's max sits near 0
  for (const std::vector<std::vector<double>>& rows :
       {std::vector<std::vector<double>>{{-2.7, -1.9, -0.4}, {-0.02, -0.001, -0.003}},
        std::vector<std::vector<double>>{{-0.3, -0.2}, {-0.1, NAN}}, std::vector<std::vector<double>>{{0.04, 0.01}}}) {
    const auto [lo, hi] = constraint_plot_range(rows);
    double mn = 0, mx = 0;
    for (const auto& r : rows)
      for (double x : r)
        if (std::isfinite(x)) mn = std::min(mn, x), mx = std::max(mx, x);
    CHECK(lo <= mn);
    CHECK(hi >= mx);
    CHECK(lo < 0.0);
    CHECK(hi > 0.0);
    CHECK(hi - lo <= 2.5 * (mx - mn) + 0.01);  // fits: not a fixed wide range
  }
}

TEST_CASE("render: the page plays on open unless ?play=0", "[render]") {
  RenderConfig c;
  c.env = "nav";
  c.policy = "zero";
  c.seed = 1;
  const RenderResult r = render_episode(c);
  CHECK(r.html.find("query.get('play') !== '0'") != std::string::npos);
  CHECK(r.html.find("toggle();") != std::string::npos);
}
