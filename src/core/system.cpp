#include "atacom/system.hpp"

namespace atacom {

void viability_constraint(int k, int d, const double* c, const double* J, const double* H, const double* qdot,
                          const double* K, double* c_v, double* J_v) {
  for (int i = 0; i < k; ++i) {
    double jq = 0.0;
    for (int t = 0; t < d; ++t) jq += J[i * d + t] * qdot[t];
    c_v[i] = c[i] + K[i] * jq;
    for (int t = 0; t < d; ++t) {
      J_v[i * 2 * d + t] = J[i * d + t] + K[i] * H[i * d + t];
      J_v[i * 2 * d + d + t] = K[i] * J[i * d + t];
    }
  }
}

}  // namespace atacom
