// atacom._core.BatchEnv: one C++ BatchEnv (N envs, optionally behind a safety
// layer) with zero-copy views of its buffers.
//
// Views share the env's std::vector storage and hold a reference to the
// BatchEnv object, so the env outlives every view. The storage never moves:
// buffers are sized once at construction, and load_state() checks that the
// snapshot did not resize them. step() releases the GIL; a per-env lock turns
// overlapping calls from two Python threads into an exception instead of a race.
#include <cstring>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/safe_env.hpp"
#include "atacom/safety_layer.hpp"
#include "bindings.hpp"
#include "src/core/limits.hpp"

namespace atacom::py_bindings {

namespace {

const char* reduce_name(InfoReduce r) {
  switch (r) {
    case InfoReduce::Last: return "last";
    case InfoReduce::Sum: return "sum";
    case InfoReduce::Max: return "max";
    case InfoReduce::Mean: return "mean";
  }
  return "last";
}

// What an info column is for (include/atacom/env.hpp, InfoRole).
const char* role_name(InfoRole r) {
  switch (r) {
    case InfoRole::Diagnostic: return "diagnostic";
    case InfoRole::Contact: return "contact";
    case InfoRole::AnyContact: return "any_contact";
    case InfoRole::EpisodeEvent: return "episode_event";
    case InfoRole::GoalDistance: return "goal_distance";
  }
  return "diagnostic";
}

class PyEnv {
 public:
  PyEnv(const std::string& name, int num_envs, const std::string& safety, const std::string& config_json) {
    if (num_envs < 1 || num_envs > limits::kMaxEnvs)
      throw std::invalid_argument("num_envs must be an integer in [1, 2^20], got " + std::to_string(num_envs));
    nlohmann::json config = nlohmann::json::parse(config_json);
    safety_ = parse_safety_layer(safety);
    env_ = make_env(EnvRequest{name, num_envs, safety_, config});
    safe_ = dynamic_cast<const SafeEnv*>(env_.get());
  }

  BatchEnv& env() { return *env_; }
  const EnvSpec& spec() const { return env_->spec(); }
  int N() const { return env_->num_envs(); }
  const SafeEnv* safe() const { return safe_; }
  SafetyLayer safety() const { return safety_; }

  // Held for the duration of every call that touches the env's state.
  std::unique_lock<std::mutex> lock() {
    std::unique_lock<std::mutex> l(busy_, std::try_to_lock);
    if (!l.owns_lock())
      throw std::runtime_error("this env is in use by another thread: step, reset, save_state and load_state "
                               "of one env must not overlap");
    return l;
  }

  // Step outputs of freshly reset envs: no step happened, so no reward, cost,
  // termination or info (envs differ in what reset() leaves there).
  void clear_step_outputs(const uint8_t* mask) {
    EnvBuffers& b = env_->buffers();
    const size_t ni = spec().info_names.size();
    for (int i = 0; i < N(); ++i) {
      if (mask && !mask[i]) continue;
      b.reward[i] = 0.0f;
      b.cost[i] = b.cost_continuous[i] = 0.0f;
      b.terminated[i] = b.truncated[i] = 0;
      std::fill_n(b.info.data() + size_t(i) * ni, ni, 0.0f);
    }
  }

  std::vector<const void*> storage() const {
    const EnvBuffers& b = env_->buffers();
    std::vector<const void*> s = {b.obs.data(),         b.final_obs.data(),      b.reward.data(),
                                  b.cost.data(),        b.terminated.data(),     b.truncated.data(),
                                  b.constraints.data(), b.info.data(),           b.episode_return.data(),
                                  b.episode_length.data(), b.cost_continuous.data()};
    if (safe_) s.push_back(safe_->projection().status.data());
    return s;
  }

 private:
  std::unique_ptr<BatchEnv> env_;
  const SafeEnv* safe_ = nullptr;
  SafetyLayer safety_ = SafetyLayer::None;
  std::mutex busy_;
};

const uint8_t* checked_mask(const py::object& mask, int N, py::array_t<uint8_t>& holder) {
  if (mask.is_none()) return nullptr;
  py::array a = py::array::ensure(mask);
  if (!a) throw std::invalid_argument("reset mask must be an array of N booleans");
  if (!(a.dtype().is(py::dtype::of<bool>()) || a.dtype().is(py::dtype::of<uint8_t>())))
    throw std::invalid_argument("reset mask must be bool or uint8, got " + std::string(py::str(a.dtype())));
  if (a.ndim() != 1 || a.shape(0) != N)
    throw std::invalid_argument("reset mask must have shape (" + std::to_string(N) + ",)");
  holder = py::array_t<uint8_t, py::array::c_style | py::array::forcecast>::ensure(a);
  return holder.data();
}

}  // namespace

void bind_env(py::module_& m) {
  py::class_<PyEnv>(m, "BatchEnv", "N envs of one registered kind behind a safety layer (C++ BatchEnv)")
      .def(py::init<const std::string&, int, const std::string&, const std::string&>(), py::arg("name"),
           py::arg("num_envs"), py::arg("safety"), py::arg("config_json") = "{}")
      .def_property_readonly("num_envs", &PyEnv::N)
      .def_property_readonly("safety", [](const PyEnv& e) { return std::string(safety_layer_name(e.safety())); })
      .def("spec",
           [](const PyEnv& e) {
             const EnvSpec& s = e.spec();
             py::dict d;
             d["name"] = s.name;
             d["obs_dim"] = s.obs_dim;
             d["act_dim"] = s.act_dim;
             d["obs_low"] = s.obs_low;
             d["obs_high"] = s.obs_high;
             d["dt"] = s.dt;
             d["horizon"] = s.horizon;
             d["num_constraints"] = s.num_constraints;
             d["constraint_tolerance"] = s.constraint_tolerance;
             d["constraint_names"] = s.constraint_names;
             d["info_names"] = s.info_names;
             d["cost_events"] = s.cost_events;
             std::vector<std::string> reduce;
             for (InfoReduce r : s.info_reduce) reduce.push_back(reduce_name(r));
             d["info_reduce"] = reduce;
             std::vector<std::string> role;
             for (size_t i = 0; i < s.info_names.size(); ++i) role.push_back(role_name(s.role(i)));
             d["info_role"] = role;
             return d;
           })
      .def(
          "seed",
          [](PyEnv& e, uint64_t seed) {
            auto l = e.lock();
            py::gil_scoped_release release;
            e.env().seed(seed);
            e.clear_step_outputs(nullptr);
          },
          py::arg("seed"), "re-key env i's stream with (seed, i) and reset all envs")
      .def(
          "reset",
          [](PyEnv& e, const py::object& mask) {
            py::array_t<uint8_t> holder;
            const uint8_t* mk = checked_mask(mask, e.N(), holder);
            auto l = e.lock();
            py::gil_scoped_release release;
            e.env().reset(mk);
            e.clear_step_outputs(mk);
          },
          py::arg("mask") = py::none(), "reset the envs with mask[i] (all when None); their step outputs are cleared")
      .def(
          "step",
          [](PyEnv& e, const py::array& actions) {
            const double* a = checked_f64(actions, {e.N(), e.spec().act_dim}, "actions");
            auto l = e.lock();
            py::gil_scoped_release release;
            e.env().step(a);
          },
          py::arg("actions"), "one step of every env; actions: float64 (N, act_dim), C-contiguous")
      .def("save_state",
           [](PyEnv& e) {
             std::ostringstream out;
             {
               auto l = e.lock();
               py::gil_scoped_release release;
               e.env().save_state(out);
             }
             return py::bytes(out.str());
           })
      .def(
          "load_state",
          [](PyEnv& e, const py::bytes& data) {
            std::string in_bytes = data;
            auto l = e.lock();
            const std::vector<const void*> before = e.storage();
            std::string backup;
            {
              py::gil_scoped_release release;
              std::ostringstream out;
              e.env().save_state(out);
              backup = out.str();
            }
            try {
              py::gil_scoped_release release;
              std::istringstream in(in_bytes);
              e.env().load_state(in);
              // The snapshot is the whole of the bytes: anything after it is not one of save_state()'s.
              if (in.peek() != std::char_traits<char>::eof()) {
                const auto at = static_cast<size_t>(in.tellg());
                throw std::invalid_argument("load_state: " + std::to_string(in_bytes.size() - at) +
                                            " bytes after the snapshot's end (at byte " + std::to_string(at) +
                                            " of " + std::to_string(in_bytes.size()) +
                                            "); pass exactly the bytes save_state() returned");
              }
            } catch (...) {
              // A snapshot that fails half-way leaves a half-loaded env: put the old state back.
              std::istringstream in(backup);
              e.env().load_state(in);
              throw;
            }
            if (e.storage() != before)
              throw std::logic_error("load_state moved the env's buffers (views would dangle): a bug in the env");
          },
          py::arg("data"), "restore a save_state() snapshot; on failure the env keeps its previous state")
      // Zero-copy, read-only views; each holds a reference to this object.
      .def("view_obs",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N(), e.spec().obs_dim}, e.env().buffers().obs.data());
           })
      .def("view_final_obs",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N(), e.spec().obs_dim}, e.env().buffers().final_obs.data());
           })
      .def("view_reward",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N()}, e.env().buffers().reward.data());
           })
      .def("view_cost",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N()}, e.env().buffers().cost.data());
           })
      .def("view_cost_continuous",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N()}, e.env().buffers().cost_continuous.data());
           })
      // 0/1 bytes viewed as NumPy bool (same size, and the envs only write 0 or 1).
      .def("view_terminated",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view(self, py::dtype::of<bool>(), {e.N()}, e.env().buffers().terminated.data());
           })
      .def("view_truncated",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view(self, py::dtype::of<bool>(), {e.N()}, e.env().buffers().truncated.data());
           })
      .def("view_constraints",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N(), e.spec().num_constraints}, e.env().buffers().constraints.data());
           })
      .def("view_info",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             const py::ssize_t ni = static_cast<py::ssize_t>(e.spec().info_names.size());
             return view_of(self, {e.N(), ni}, e.env().buffers().info.data());
           })
      .def("view_episode_return",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N()}, e.env().buffers().episode_return.data());
           })
      .def("view_episode_length",
           [](py::object self) {
             PyEnv& e = self.cast<PyEnv&>();
             return view_of(self, {e.N()}, e.env().buffers().episode_length.data());
           })
      .def(
          "view_atacom_status",
          [](py::object self) -> py::object {
            PyEnv& e = self.cast<PyEnv&>();
            if (!e.safe()) return py::none();
            return view_of(self, {e.N()}, e.safe()->projection().status.data());
          },
          "ProjectorStatus bits of the last step (ATACOM only, else None)");
}

}  // namespace atacom::py_bindings
