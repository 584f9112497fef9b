// Shared pieces of the pybind11 bindings (module atacom._core).
//
// The pure-Python layer (python/atacom/*.py) checks user input and gives the
// friendly messages; the bindings check again (shape, dtype, contiguity) so
// that nothing reaching C++ from Python can read or write out of bounds.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

namespace atacom {
struct ProjectorBatch;
}

namespace atacom::py_bindings {

namespace py = pybind11;

void bind_env(py::module_& m);
void bind_projector(py::module_& m);
void bind_safelayer(py::module_& m);
void bind_misc(py::module_& m);
void bind_policy(py::module_& m);

// A NumPy array over memory owned by `owner` (kept alive as the array's base).
// Read-only unless `writeable`: envs own their buffers and rewrite them each step.
// Empty shapes get a fresh empty array (std::vector::data() may be null).
inline py::array view(const py::handle& owner, const py::dtype& dtype, std::vector<py::ssize_t> shape,
                      const void* data, bool writeable = false) {
  py::ssize_t count = 1;
  for (py::ssize_t s : shape) count *= s;
  if (count == 0 || data == nullptr) return py::array(dtype, shape);
  py::array a(dtype, shape, {}, data, owner);
  if (!writeable) a.attr("flags").attr("writeable") = false;
  return a;
}

template <class T>
py::array view_of(const py::handle& owner, std::vector<py::ssize_t> shape, const T* data, bool writeable = false) {
  return view(owner, py::dtype::of<T>(), std::move(shape), data, writeable);
}

// Throws std::invalid_argument unless `a` is a C-contiguous float64 array of
// exactly `shape`; returns its data.
const double* checked_f64(const py::array& a, const std::vector<py::ssize_t>& shape, const char* what);
double* checked_f64_mutable(py::array& a, const std::vector<py::ssize_t>& shape, const char* what);
std::string shape_str(const std::vector<py::ssize_t>& shape);

// The arrays of N control-affine problems in the filter's form (dense G with
// drift; J_x and xdot only when p > 0) copied into B, sized for them, after
// checking every shape. Shared by project() and safelayer().
void copy_problems_in(ProjectorBatch& B, py::ssize_t N, py::ssize_t n, py::ssize_t m, py::ssize_t k, py::ssize_t p,
                      const py::array& f, const py::array& G, const py::array& Jq, const py::array& c,
                      const py::array& alpha, const py::object& Jx, const py::object& xdot);
// qdot = f + G a of B's N problems (a: N x m), as the filter reports it.
void qdot_of(const ProjectorBatch& B, py::ssize_t n, py::ssize_t m, const double* a, double* qdot);

}  // namespace atacom::py_bindings
