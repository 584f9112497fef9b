// The README's command table against the binary itself: every subcommand the
// executable registers has a row, each row lists every value its --policy and
// --safety accept (read from the subcommand's --help, the values CLI11
// checks), and the algorithm table names every --algo value (the algorithm
// table of train/algorithms.cpp). A new subcommand, policy, layer or
// algorithm fails here until the README has its row.
#include <catch2/catch.hpp>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "atacom/safety_layer.hpp"
#include "shell_run.hpp"
#include "train/algorithms.hpp"

namespace {

std::string readme() {
  std::ifstream f(ATACOM_README_PATH);
  REQUIRE(f.good());
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string help(const std::string& args) {
  const ShellResult r = run_shell(std::string(ATACOM_ATACOM_EXE) + " " + args + " --help 2>&1");
  REQUIRE(r.rc == 0);
  return r.out;
}

// The subcommands `atacom --help` lists (CLI11: a "SUBCOMMANDS:" block of "  name  description" lines).
std::vector<std::string> subcommands() {
  std::istringstream in(help(""));
  std::vector<std::string> out;
  std::string line;
  bool in_block = false;
  const std::regex entry(R"(^  ([a-z][a-z0-9-]*)\s+\S.*$)");
  while (std::getline(in, line)) {
    if (line.rfind("Subcommands:", 0) == 0 || line.rfind("SUBCOMMANDS:", 0) == 0) {
      in_block = true;
      continue;
    }
    std::smatch m;
    if (in_block && std::regex_match(line, m, entry)) out.push_back(m[1]);
    else if (in_block && !line.empty() && line[0] != ' ') in_block = false;
  }
  return out;
}

// The values an option of a subcommand accepts, as its help prints them (CLI11's IsMember: "{a,b,c}").
std::set<std::string> accepted(const std::string& help_text, const std::string& option) {
  const std::regex opt("(^|\\n)\\s*" + option + "[^\\n{]*\\{([^}]*)\\}");
  std::smatch m;
  std::set<std::string> out;
  if (!std::regex_search(help_text, m, opt)) return out;
  std::stringstream s(m[2].str());
  std::string v;
  while (std::getline(s, v, ',')) {
    while (!v.empty() && v.front() == ' ') v.erase(v.begin());
    if (!v.empty()) out.insert(v);
  }
  return out;
}

// The command table's row of a subcommand: the line starting "| `atacom <name>".
std::string row_of(const std::string& text, const std::string& name) {
  const std::string head = "| `atacom " + name;
  size_t p = text.find(head + " ");
  if (p == std::string::npos) p = text.find(head + "`");
  if (p == std::string::npos) return "";
  return text.substr(p, text.find('\n', p) - p);
}

}  // namespace

TEST_CASE("README: the command table has a row for every subcommand, listing its --policy and --safety values",
          "[readme]") {
  const std::string text = readme();
  const std::vector<std::string> subs = subcommands();
  REQUIRE(subs.size() >= 10);  // the parse found the list (attack ... train)
  size_t with_values = 0;
  for (const std::string& sub : subs) {
    INFO("subcommand " << sub);
    const std::string row = row_of(text, sub);
    CHECK(!row.empty());
    if (row.empty()) continue;
    const std::string h = help(sub);
    for (const char* option : {"--policy", "--safety"}) {
      for (const std::string& v : accepted(h, option)) {
        INFO(option << " " << v);
        // Listed as `--policy random|zero|...` (pipes escaped in the table), in any order.
        CHECK(std::regex_search(row, std::regex(std::string(option) + " [a-z|\\\\-]*\\b" + v + "\\b")));
        ++with_values;
      }
    }
  }
  CHECK(with_values >= 10);  // rollout, render, shelf-real, attack: the values were found in their help
}

TEST_CASE("README: the algorithm table names every --algo value of atacom train", "[readme]") {
  const std::string text = readme();
  const size_t from = text.find("### `atacom train`");
  REQUIRE(from != std::string::npos);
  const std::string section = text.substr(from, text.find("\n## ", from) - from);
  for (const std::string& name : atacom::algorithm_names()) {
    INFO("--algo " << name);
    CHECK(section.find("`" + name + "`") != std::string::npos);
  }
  for (const std::string& layer : atacom::safety_layer_names()) {
    INFO("safety layer " << layer);
    CHECK(section.find("| " + layer) != std::string::npos);  // a column of the source x layer table
  }
}
