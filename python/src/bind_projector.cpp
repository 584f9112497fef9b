// The batched ATACOM projector for users' own systems.
//
// project(): one call over N problems, inputs copied into a ProjectorBatch,
// outputs returned as arrays that own the batch (no output copy).
// Projector: a persistent batch whose input arrays are writable views, for
// loops that refill the same N problems (no copy at all).
// The model comes as the JSON of ProjectorModel (from_json validates it).
#include <algorithm>
#include <memory>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/projector.hpp"
#include "bindings.hpp"

namespace atacom::py_bindings {

namespace {

ProjectorModel model_from(const std::string& model_json) {
  ProjectorModel model;
  from_json(nlohmann::json::parse(model_json), model);
  // The arrays below are laid out for dense G with drift (the filter's form).
  if (model.g_form != GForm::Dense || !model.has_drift)
    throw std::invalid_argument("projector model: only dense G with drift is supported here");
  return model;
}

struct PyProjector {
  ProjectorModel model;
  ProjectorBatch batch;
  PyProjector(const ProjectorModel& mdl, int N) : model(mdl), batch(mdl, N) {}
};

void run(PyProjector& P, bool parallel) {
  py::gil_scoped_release release;
  project_batch(P.model, P.batch, {.store_basis = false, .store_slack = true, .parallel = parallel});
}

}  // namespace

void bind_projector(py::module_& m) {
  m.def(
      "project",
      [](const std::string& model_json, const py::array& f, const py::array& G, const py::array& Jq,
         const py::array& c, const py::array& alpha, const py::object& Jx, const py::object& xdot, bool parallel) {
        const ProjectorModel model = model_from(model_json);
        if (f.ndim() < 1) throw std::invalid_argument("f must have shape (N, n)");
        const py::ssize_t N = f.shape(0), n = model.n, mm = model.m, k = model.k, p = model.p;
        if (N < 1) throw std::invalid_argument("the batch is empty (N = 0)");
        if (N > (py::ssize_t{1} << 31) - 1) throw std::invalid_argument("N is too large");
        auto P = std::make_unique<PyProjector>(model, static_cast<int>(N));
        ProjectorBatch& B = P->batch;
        copy_problems_in(B, N, n, mm, k, p, f, G, Jq, c, alpha, Jx, xdot);
        run(*P, parallel);
        auto qdot = std::make_unique<std::vector<double>>(size_t(N) * n);
        qdot_of(B, n, mm, B.a.data(), qdot->data());
        py::capsule owner(P.release(), [](void* ptr) { delete static_cast<PyProjector*>(ptr); });
        py::capsule qowner(qdot.get(), [](void* ptr) { delete static_cast<std::vector<double>*>(ptr); });
        const double* qd = qdot.release()->data();
        PyProjector* Pp = static_cast<PyProjector*>(owner.get_pointer());
        ProjectorBatch& Bo = Pp->batch;
        py::dict out;
        out["a"] = view_of(owner, {N, mm}, Bo.a.data(), true);
        out["qdot"] = view_of(qowner, {N, n}, qd, true);
        out["s"] = view_of(owner, {N, k}, Bo.s.data(), true);
        out["lambda"] = view_of(owner, {N}, Bo.lambda.data(), true);
        out["status"] = view_of(owner, {N}, Bo.status.data(), true);
        return out;
      },
      py::arg("model_json"), py::arg("f"), py::arg("G"), py::arg("J_q"), py::arg("c"), py::arg("alpha"),
      py::arg("J_x") = py::none(), py::arg("xdot") = py::none(), py::arg("parallel") = true,
      "project N problems; inputs float64 C-contiguous of the model's shapes");

  py::class_<PyProjector>(m, "Projector", "a persistent batch of N projector problems with writable input views")
      .def(py::init([](const std::string& model_json, int N) {
             if (N < 1) throw std::invalid_argument("N must be >= 1");
             return std::make_unique<PyProjector>(model_from(model_json), N);
           }),
           py::arg("model_json"), py::arg("N"))
      .def_property_readonly("N", [](const PyProjector& P) { return P.batch.N; })
      .def_property_readonly("model_json",
                             [](const PyProjector& P) {
                               nlohmann::json j;
                               to_json(j, P.model);
                               return j.dump();
                             })
      .def("project", [](PyProjector& P, bool parallel) { run(P, parallel); }, py::arg("parallel") = true)
      .def("views", [](py::object self) {
        PyProjector& P = self.cast<PyProjector&>();
        ProjectorBatch& B = P.batch;
        const py::ssize_t N = B.N, n = P.model.n, mm = P.model.m, k = P.model.k, p = P.model.p;
        py::dict d;
        d["f"] = view_of(self, {N, n}, B.f.data(), true);
        d["G"] = view_of(self, {N, n, mm}, B.G.data(), true);
        d["J_q"] = view_of(self, {N, k, n}, B.Jq.data(), true);
        d["c"] = view_of(self, {N, k}, B.c.data(), true);
        d["alpha"] = view_of(self, {N, mm}, B.alpha.data(), true);
        d["J_x"] = view_of(self, {N, k, p}, B.Jx.data(), true);
        d["xdot"] = view_of(self, {N, p}, B.xdot.data(), true);
        d["a"] = view_of(self, {N, mm}, B.a.data());
        d["s"] = view_of(self, {N, k}, B.s.data());
        d["slack_u"] = view_of(self, {N, k}, B.slack_u.data());
        d["lambda"] = view_of(self, {N}, B.lambda.data());
        d["status"] = view_of(self, {N}, B.status.data());
        return d;
      });
}

}  // namespace atacom::py_bindings
