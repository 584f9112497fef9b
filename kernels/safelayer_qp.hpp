// The SafeLayer QP solver (one env): least-distance QP by Lawson-Hanson NNLS
// and the least-violation fallback. Internal to the SafeLayer kernel.
#pragma once
#include <cstdint>
#include <vector>

namespace atacom::safelayer_qp {

// Scratch sized once per thread and shape (grow only): no allocation per solve.
struct Scratch {
  // NNLS matrix, column-major (nr x nc), and its vectors
  std::vector<double> E, d, u, z, w, resid, colnorm, qr, rhs;
  std::vector<int> P;
  std::vector<uint8_t> inP, blocked;
  // the reduced problem: kept rows, normalised
  std::vector<double> gn, hn, gscale, h2, x, grad, H, dir, trial, mu, a2;
  std::vector<int> kept;
  void setup(int m, int k);
};

struct Result {
  uint32_t status = 0;  // SafeLayerStatus bits
  int iterations = 0;
};

// min 1/2 |a - a_pi|^2  s.t.  g a <= h (k rows),  -1 <= a <= 1.  a_pi inside the box.
// mult (k + 2m) optional: KKT multipliers (zero when infeasible).
Result solve(int m, int k, const double* g, const double* h, const double* a_pi, double* a, double* mult, Scratch& S);

}  // namespace atacom::safelayer_qp
