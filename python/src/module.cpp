// atacom._core: the compiled half of the Python module `atacom`.
#include "bindings.hpp"

namespace atacom::py_bindings {

std::string shape_str(const std::vector<py::ssize_t>& shape) {
  std::string s = "(";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

namespace {
std::vector<py::ssize_t> shape_of(const py::array& a) {
  return std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim());
}

void check_f64(const py::array& a, const std::vector<py::ssize_t>& shape, const char* what) {
  if (!a.dtype().is(py::dtype::of<double>()))
    throw std::invalid_argument(std::string(what) + " must be float64, got " + std::string(py::str(a.dtype())));
  if (shape_of(a) != shape)
    throw std::invalid_argument(std::string(what) + " must have shape " + shape_str(shape) + ", got " +
                                shape_str(shape_of(a)));
  if (!(a.flags() & py::array::c_style)) throw std::invalid_argument(std::string(what) + " must be C-contiguous");
}
}  // namespace

const double* checked_f64(const py::array& a, const std::vector<py::ssize_t>& shape, const char* what) {
  check_f64(a, shape, what);
  return static_cast<const double*>(a.data());
}

double* checked_f64_mutable(py::array& a, const std::vector<py::ssize_t>& shape, const char* what) {
  check_f64(a, shape, what);
  if (!a.writeable()) throw std::invalid_argument(std::string(what) + " must be writeable");
  return static_cast<double*>(a.mutable_data());
}

}  // namespace atacom::py_bindings

PYBIND11_MODULE(_core, m) {
  m.doc() = "atacom native core: batched envs, the ATACOM projector, per-env random streams";
  atacom::py_bindings::bind_misc(m);
  atacom::py_bindings::bind_env(m);
  atacom::py_bindings::bind_projector(m);
  atacom::py_bindings::bind_safelayer(m);
  atacom::py_bindings::bind_policy(m);
}
