// SafeLayer for users' own systems: one call over N problems, as project().
// Inputs copied into a ProjectorBatch (dense G with drift, the filter's
// form); outputs returned as arrays that own their storage.
#include <cmath>
#include <cstring>
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

void copy_in(std::vector<double>& dst, const py::array& src, const std::vector<py::ssize_t>& shape, const char* what) {
  const double* p = checked_f64(src, shape, what);
  size_t count = 1;
  for (py::ssize_t d : shape) count *= static_cast<size_t>(d);
  if (dst.size() != count) throw std::logic_error(std::string("safelayer batch size mismatch for ") + what);
  if (!dst.empty()) std::memcpy(dst.data(), p, dst.size() * sizeof(double));
}

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
        copy_in(B.f, f, {N, n}, "f");
        copy_in(B.G, G, {N, n, mm}, "G");
        copy_in(B.Jq, Jq, {N, k, n}, "J_q");
        copy_in(B.c, c, {N, k}, "c");
        copy_in(B.alpha, alpha, {N, mm}, "alpha");
        if (p > 0) {
          copy_in(B.Jx, Jx.cast<py::array>(), {N, k, p}, "J_x");
          copy_in(B.xdot, xdot.cast<py::array>(), {N, p}, "xdot");
        }
        {
          py::gil_scoped_release release;
          safelayer_batch(P->sm, B, P->out, {.store_active_rows = true, .parallel = parallel});
          P->qdot.resize(size_t(N) * n);
          for (py::ssize_t i = 0; i < N; ++i)
            for (int r = 0; r < n; ++r) {
              double v = B.f[size_t(i * n + r)];
              for (int j = 0; j < mm; ++j) v += B.G[size_t((i * n + r) * mm + j)] * P->out.a[size_t(i * mm + j)];
              P->qdot[size_t(i * n + r)] = v;
            }
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
