// GEMM tiles for the tape that give Eigen's bits without Eigen's packing.
//
// C (m x n, row-major, leading dimension ldc) += A (m x k) * B (k x n), float,
// with A(i, p) = a[i * a_rs + p * a_cs] and B(p, j) = b[p * b_rs + j * b_cs],
// where B is row-major (b_cs == 1) or transposed row-major (b_rs == 1). With
// c_init, every row of C starts as c_init[0..n) (a bias) instead of its own
// contents; with relu, C = max(C + A B, 0) afterwards.
//
// Eigen's product of row-major maps runs its kernel on C^T = B^T A^T: 48-row
// panels of C^T (48 columns of C) sum each element over k in one sequential
// FMA chain from zero, and so do 32-row panels; narrower panels split the sum
// into even and odd k. Its depth blocking (kc) adds each block's partial sum
// to C in turn. This kernel does exactly that, reading A and B in place
// (only a transposed B is copied, a 48-column strip at a time), so the result
// is bitwise what `C.noalias() += A * B` gives on the same machine, only
// faster. It computes Eigen's own blocking for the shape and returns false,
// touching nothing, wherever Eigen would leave the sequential panels (or
// take a GEMV or coefficient path, or the build has no AVX-512); the caller
// then runs the Eigen expression itself.
#pragma once
#include <cstdint>

namespace atacom {

bool eigen_exact_gemm(int m, int n, int k, const float* a, int64_t a_rs, int64_t a_cs, const float* b, int64_t b_rs,
                      int64_t b_cs, float* c, int64_t ldc, const float* c_init, bool relu);

}  // namespace atacom
