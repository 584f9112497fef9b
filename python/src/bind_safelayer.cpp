// SafeLayer for users' own systems: one call over N problems, as project().
// Inputs copied into a ProjectorBatch (dense G with drift, the filter's
// form); outputs returned as arrays that own their storage.
#include <cmath>
#include <memory>
#include <stdexcept>

#include "atacom/safelayer.hpp"
#include "bindings.hpp"

namespace atacom::py_bindings {

namespace {

struct PySafeLayer {
  ProjectorModel pm;
  SafeLayerModel sm;
  ProjectorBatch in;
  SafeLayerBatch out;
  std::vector<double> qdot;
};

}  // namespace

void bind_safelayer(py::module_& m) {
  m.def(
      "safelayer",
      [](int n, int mm, int k, int p, double dt, const std::vector<double>& threshold, const py::array& f,
         const py::array& G, const py::array& Jq, const py::array& c, const py::array& alpha, const py::object& Jx,
         const py::object& xdot, bool parallel) {
        if (f.ndim() < 1) throw std::invalid_argument("f must have shape (N, n)");
        const py::ssize_t N = f.shape(0);
        if (N < 1) throw std::invalid_argument("the batch is empty (N = 0)");
        if (N > (py::ssize_t{1} << 31) - 1) throw std::invalid_argument("N is too large");
        auto P = std::make_unique<PySafeLayer>();
        P->pm = default_projector_model(n, mm, k, p);  // shapes only: dense G, drift
        P->sm = safelayer_model(P->pm, dt, threshold);
        P->in.resize(P->pm, static_cast<int>(N));
        P->out.resize(P->sm, static_cast<int>(N));
        ProjectorBatch& B = P->in;
        copy_problems_in(B, N, n, mm, k, p, f, G, Jq, c, alpha, Jx, xdot);
        {
          py::gil_scoped_release release;
          safelayer_batch(P->sm, B, P->out, {.store_active_rows = true, .parallel = parallel});
          P->qdot.resize(size_t(N) * n);
          qdot_of(B, n, mm, P->out.a.data(), P->qdot.data());
        }
        py::capsule owner(P.release(), [](void* ptr) { delete static_cast<PySafeLayer*>(ptr); });
        const PySafeLayer& R = *static_cast<PySafeLayer*>(owner.get_pointer());
        py::dict d;
        d["a"] = view_of(owner, {N, mm}, R.out.a.data(), true);
        d["qdot"] = view_of(owner, {N, n}, R.qdot.data(), true);
        d["active"] = view(owner, py::dtype::of<bool>(), {N, k}, R.out.active_rows.data(), true);
        d["correction"] = view_of(owner, {N}, R.out.correction.data(), true);
        d["iterations"] = view_of(owner, {N}, R.out.iterations.data(), true);
        d["status"] = view_of(owner, {N}, R.out.status.data(), true);
        return d;
      },
      py::arg("n"), py::arg("m"), py::arg("k"), py::arg("p"), py::arg("dt"), py::arg("threshold"), py::arg("f"),
      py::arg("G"), py::arg("J_q"), py::arg("c"), py::arg("alpha"), py::arg("J_x") = py::none(),
      py::arg("xdot") = py::none(), py::arg("parallel") = true,
      "SafeLayer's correction of N actions; inputs float64 C-contiguous of the shapes given");
}

}  // namespace atacom::py_bindings
