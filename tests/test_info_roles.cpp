// Info columns carry their role (EnvSpec::info_role): the consumers that
// total or pick columns look the role up, and the totals keep the names they
// had when they were found by name.
#include <catch2/catch.hpp>

#include <string>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/evaluate.hpp"
#include "atacom/make_env.hpp"

using namespace atacom;

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

TEST_CASE("info roles: event totals are named as before", "[info_roles]") {
  CHECK(event_total_name("collision", InfoRole::AnyContact) == "collisions");
  CHECK(event_total_name("wall_collision", InfoRole::Contact) == "wall_collisions");
  CHECK(event_total_name("human_collision", InfoRole::Contact) == "human_collisions");
  CHECK(event_total_name("spill", InfoRole::EpisodeEvent) == "spills");
  CHECK(event_total_name("spill_15", InfoRole::EpisodeEvent) == "spills_15");
  CHECK(event_total_name("final_distance", InfoRole::GoalDistance).empty());
  CHECK(event_total_name("nan_action", InfoRole::Diagnostic).empty());
}

// Every registered env declares one role per column, and the roles pick the
// columns the names picked before (so every output name and number stays):
// contacts end in "collision", episode events start with "spill", the goal
// distance is final_distance, the every-contact column is "collision".
TEST_CASE("info roles: every env's roles pick the columns the names picked", "[info_roles]") {
  for (const std::string& name : env_names()) {
    INFO("env " << name);
    const EnvSpec s = make_env(EnvRequest{name, 1, SafetyLayer::None, nlohmann::json::object()})->spec();
    REQUIRE((s.info_role.empty() || s.info_role.size() == s.info_names.size()));
    for (size_t c = 0; c < s.info_names.size(); ++c) {
      const std::string& col = s.info_names[c];
      INFO("column " << col);
      CHECK(is_contact(s.role(c)) == ends_with(col, "collision"));
      CHECK((s.role(c) == InfoRole::AnyContact) == (col == "collision"));
      CHECK((s.role(c) == InfoRole::EpisodeEvent) == (col == "spill" || col.rfind("spill_", 0) == 0));
      CHECK((s.role(c) == InfoRole::GoalDistance) == (col == "final_distance"));
    }
  }
}

TEST_CASE("info roles: the evaluation's JSON totals follow the role, not the name", "[info_roles]") {
  EvalResult r;
  r.episodes = 10;
  r.info_names = {"bump", "side_bump", "tip", "tip_5", "gap"};
  r.info_roles = {InfoRole::AnyContact, InfoRole::Contact, InfoRole::EpisodeEvent, InfoRole::EpisodeEvent,
                  InfoRole::GoalDistance};
  r.info = {1.5, 0.5, 0.3, 0.2, 0.25};
  const nlohmann::json j = eval_json(r);
  CHECK(j["bumps"] == 1.5);       // contacts per episode
  CHECK(j["side_bumps"] == 0.5);
  CHECK(j["tips"] == 3.0);        // episodes with the event
  CHECK(j["tip_5"] == 0.2);
  CHECK(j["tips_5"] == 2.0);
  CHECK(!j.contains("gaps"));
  r.info_roles.clear();  // no roles: plain columns, no totals
  CHECK(!eval_json(r).contains("bumps"));
}
