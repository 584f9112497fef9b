// Threads, the data directory, the env registry, and per-env random streams.
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/parallel.hpp"
#include "atacom/rng.hpp"
#include "atacom/safety_layer.hpp"
#include "bindings.hpp"
#include "src/core/data_dir.hpp"
#include "src/core/limits.hpp"

namespace atacom::py_bindings {

namespace {

// The C++ Rng streams (xoshiro256++ keyed by (seed, stream)), S at once:
// row i of every draw comes from stream i, exactly as C++ code drawing from
// Rng(seed, streams[i]) would get it.
class RandomStreams {
 public:
  RandomStreams(uint64_t seed, const std::vector<uint64_t>& streams) {
    if (streams.empty()) throw std::invalid_argument("RandomStreams: no streams");
    rng_.reserve(streams.size());
    for (uint64_t s : streams) rng_.emplace_back(seed, s);
  }
  int size() const { return static_cast<int>(rng_.size()); }

  template <class Draw>
  py::array_t<double> draw(int per_stream, Draw&& fn) {
    if (per_stream < 0) throw std::invalid_argument("RandomStreams: per_stream must be >= 0");
    py::array_t<double> out({static_cast<py::ssize_t>(rng_.size()), static_cast<py::ssize_t>(per_stream)});
    double* o = out.mutable_data();
    for (size_t i = 0; i < rng_.size(); ++i)
      for (int j = 0; j < per_stream; ++j) o[i * per_stream + j] = fn(rng_[i]);
    return out;
  }

 private:
  std::vector<Rng> rng_;
};

}  // namespace

void bind_misc(py::module_& m) {
  m.def(
      "set_num_threads",
      [](int threads) {
        if (threads < 0 || threads > limits::kMaxThreads)
          throw std::invalid_argument("threads must be an integer in [0, 1024], got " + std::to_string(threads));
        set_num_threads(threads);
      },
      py::arg("threads"),
      "limit the worker threads of the C++ side (0 = all cores, at most 1024); results do not depend on it "
      "(atacom.set_num_threads also clamps to the cores)");
  m.def("num_threads", &num_threads);
  m.def("set_data_dir", &set_data_dir, py::arg("dir"),
        "directory of the project's data files, used when ATACOM_DATA_DIR is unset");
  m.def("data_dir", &data_dir);
  m.def("env_names", &env_names);
  m.def("env_help", [] {
    py::dict d;
    for (const EnvEntry& e : env_entries()) d[py::str(e.name)] = py::make_tuple(e.help, e.has_constraints);
    return d;
  });
  m.def(
      "default_env_config", [](const std::string& name) { return env_entry(name).default_config().dump(); },
      py::arg("name"), "the env's default config as JSON");
  m.def(
      "resolve_env_config",
      [](const std::string& name, const std::string& overrides) {
        return resolve_env_config(name, nlohmann::json::parse(overrides)).dump();
      },
      py::arg("name"), py::arg("overrides_json"));
  m.def("safety_layer_names", &safety_layer_names);

  py::class_<RandomStreams>(m, "RandomStreams",
                            "C++ per-env random streams Rng(seed, stream) (xoshiro256++), one per row")
      .def(py::init<uint64_t, const std::vector<uint64_t>&>(), py::arg("seed"), py::arg("streams"))
      .def_property_readonly("num_streams", &RandomStreams::size)
      .def(
          "uniform",
          [](RandomStreams& r, double low, double high, int per_stream) {
            return r.draw(per_stream, [&](Rng& g) { return g.uniform(low, high); });
          },
          py::arg("low"), py::arg("high"), py::arg("per_stream"),
          "(streams, per_stream) draws low + (high - low) U[0, 1)")
      .def(
          "normal", [](RandomStreams& r, int per_stream) { return r.draw(per_stream, [](Rng& g) { return g.normal(); }); },
          py::arg("per_stream"), "(streams, per_stream) standard normal draws (Box-Muller)");
}

}  // namespace atacom::py_bindings
