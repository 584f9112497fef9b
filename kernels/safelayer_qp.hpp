// The SafeLayer QP solver (one env): least-distance QP by Lawson-Hanson NNLS
// and the least-violation fallback. Internal to the SafeLayer kernel.
#pragma once
#include <cstdint>
#include <vector>

#include "atacom/safelayer.hpp"

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
  std::vector<double> planar, hk;  // planar_solve: constraints (3 per row and bound), raw right-hand sides
  void setup(int m, int k);
};

struct Result {
  uint32_t status = 0;  // SafeLayerStatus bits
  int iterations = 0;
};

// The exact QP for m <= 2 (kernels/safelayer_qp_planar.cpp) uses at most
// this many kept rows; beyond, the candidate vertices outnumber NNLS's work.
constexpr int kPlanarMaxRows = 16;

// The slack by which a solution may leave the box [-1, 1]^m before it is
// clipped (both paths check the same way; rows: kSafeLayerFeasTol).
constexpr double kBoxSlack = 1e-9;

struct Options {
  bool planar = true;  // false: NNLS for every m (tests compare the two)
};

// min 1/2 |a - a_pi|^2  s.t.  g a <= h (k rows),  -1 <= a <= 1.  a_pi inside the box.
// S must have been set up for (m, k) (the kernel does it once per range).
// mult (k + 2m) optional: KKT multipliers (zero when infeasible).
Result solve(int m, int k, const double* g, const double* h, const double* a_pi, double* a, double* mult, Scratch& S,
             const Options& opt = {});

// m <= 2: the same QP on the kept rows (row kept[c] of g, right-hand side
// hk[c], |g| = gscale[c]) by enumerating candidate active sets. Writes a and,
// when mu != nullptr, the multipliers of [kept rows on unit normals, a <= 1,
// -a <= 1]. Returns false when no action in the box satisfies every row.
int planar_solve(int m, int kk, const int* kept, const double* g, const double* hk, const double* gscale,
                  const double* a_pi, double* a, double* mu, Scratch& S);

// m <= 2 and kk <= kPlanarMaxRows, infeasible, a the least-violation action (the minimiser of
// 1/2 sum max(0, g a - h)^2 over the box, h the raw right-hand sides): moves a
// to the least-violation action closest to a_pi and returns true, or returns
// false (the relaxed QP decides then) when a is not stationary over the box
// (Newton stopped short) or rows violated at a are nearly but not exactly
// parallel.
bool planar_least_violation_tiebreak(int m, int kk, const int* kept, const double* g, const double* h,
                                     const double* gscale, const double* a_pi, double* a);

}  // namespace atacom::safelayer_qp
