// Copying users' control-affine problems into a ProjectorBatch, and qdot.
#include <cstring>
#include <stdexcept>

#include "atacom/projector.hpp"
#include "bindings.hpp"

namespace atacom::py_bindings {

namespace {

void copy_in(std::vector<double>& dst, const py::array& src, const std::vector<py::ssize_t>& shape, const char* what) {
  const double* p = checked_f64(src, shape, what);
  size_t count = 1;
  for (py::ssize_t d : shape) count *= static_cast<size_t>(d);
  if (dst.size() != count) throw std::logic_error(std::string("problem batch size mismatch for ") + what);
  if (!dst.empty()) std::memcpy(dst.data(), p, dst.size() * sizeof(double));
}

}  // namespace

void copy_problems_in(ProjectorBatch& B, py::ssize_t N, py::ssize_t n, py::ssize_t m, py::ssize_t k, py::ssize_t p,
                      const py::array& f, const py::array& G, const py::array& Jq, const py::array& c,
                      const py::array& alpha, const py::object& Jx, const py::object& xdot) {
  copy_in(B.f, f, {N, n}, "f");
  copy_in(B.G, G, {N, n, m}, "G");
  copy_in(B.Jq, Jq, {N, k, n}, "J_q");
  copy_in(B.c, c, {N, k}, "c");
  copy_in(B.alpha, alpha, {N, m}, "alpha");
  if (p > 0) {
    copy_in(B.Jx, Jx.cast<py::array>(), {N, k, p}, "J_x");
    copy_in(B.xdot, xdot.cast<py::array>(), {N, p}, "xdot");
  }
}

void qdot_of(const ProjectorBatch& B, py::ssize_t n, py::ssize_t m, const double* a, double* qdot) {
  for (py::ssize_t i = 0; i < B.N; ++i)
    for (py::ssize_t r = 0; r < n; ++r) {
      double v = B.f[size_t(i * n + r)];
      for (py::ssize_t j = 0; j < m; ++j) v += B.G[size_t((i * n + r) * m + j)] * a[size_t(i * m + j)];
      qdot[size_t(i * n + r)] = v;
    }
}

}  // namespace atacom::py_bindings
