// atacom._core.TrainedPolicy: a training run's policy file (policy_final.bin
// or policy_best.bin) acting on NumPy observations, exactly as in the run's
// evaluations and in `atacom rollout --policy trained` (the same C++ object:
// TrainedPolicy::load).
#include <mutex>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/rng.hpp"
#include "atacom/safety_layer.hpp"
#include "atacom/trainer.hpp"
#include "bindings.hpp"

namespace atacom::py_bindings {

namespace {

class PyPolicy {
 public:
  PyPolicy(const std::string& run_dir, const std::string& which) {
    if (which != "final" && which != "best")
      throw std::invalid_argument("which must be 'final' or 'best', got '" + which + "'");
    policy_ = TrainedPolicy::load(run_dir, which == "best" ? RunPolicy::Best : RunPolicy::Final);
  }

  const TrainedPolicy& policy() const { return *policy_; }

  // Row i of a sampled call draws from Rng(seed, i): the same actions whatever
  // the batch's other rows are, reproducible after seed(s).
  void seed(uint64_t s) {
    seed_ = s;
    rngs_.clear();
  }

  py::array_t<double> act(const py::array& obs, bool deterministic) {
    if (!obs.dtype().is(py::dtype::of<float>()))
      throw std::invalid_argument("obs must be float32, got " + std::string(py::str(obs.dtype())));
    if (obs.ndim() != 2 || obs.shape(1) != policy_->obs_dim())
      throw std::invalid_argument("obs must have shape (N, " + std::to_string(policy_->obs_dim()) + ")");
    if (!(obs.flags() & py::array::c_style)) throw std::invalid_argument("obs must be C-contiguous");
    const int N = static_cast<int>(obs.shape(0));
    py::array_t<double> out({static_cast<py::ssize_t>(N), static_cast<py::ssize_t>(policy_->act_dim())});
    if (N == 0) return out;
    const float* o = static_cast<const float*>(obs.data());
    double* a = out.mutable_data();
    std::unique_lock<std::mutex> l(busy_, std::try_to_lock);
    if (!l.owns_lock()) throw std::runtime_error("this policy is in use by another thread");
    if (!deterministic)
      while (static_cast<int>(rngs_.size()) < N) rngs_.emplace_back(seed_, static_cast<uint64_t>(rngs_.size()));
    {
      py::gil_scoped_release release;
      policy_->act(o, N, deterministic, deterministic ? nullptr : rngs_.data(), a);
    }
    return out;
  }

 private:
  std::unique_ptr<TrainedPolicy> policy_;
  std::vector<Rng> rngs_;
  uint64_t seed_ = 0;
  std::mutex busy_;
};

}  // namespace

void bind_policy(py::module_& m) {
  py::class_<PyPolicy>(m, "TrainedPolicy", "a training run's policy file (C++ TrainedPolicy)")
      .def(py::init<const std::string&, const std::string&>(), py::arg("run_dir"), py::arg("which"))
      .def("act", &PyPolicy::act, py::arg("obs"), py::arg("deterministic"))
      .def("seed", &PyPolicy::seed, py::arg("seed"))
      .def_property_readonly("obs_dim", [](const PyPolicy& p) { return p.policy().obs_dim(); })
      .def_property_readonly("act_dim", [](const PyPolicy& p) { return p.policy().act_dim(); })
      .def_property_readonly("kind", [](const PyPolicy& p) { return p.policy().kind(); })
      .def_property_readonly("env", [](const PyPolicy& p) { return p.policy().config().train.env; })
      .def_property_readonly("algo", [](const PyPolicy& p) { return p.policy().config().train.algo; })
      .def_property_readonly("safety", [](const PyPolicy& p) { return std::string(safety_layer_name(p.policy().safety())); })
      .def_property_readonly("env_config_json", [](const PyPolicy& p) { return p.policy().config().env.dump(); })
      .def_property_readonly("manifest_json", [](const PyPolicy& p) { return p.policy().manifest().dump(); });
}

}  // namespace atacom::py_bindings
