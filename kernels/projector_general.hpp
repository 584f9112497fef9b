// The projector's general path (equality rows, or more than 16 actions): the
// m x m algebra per env with Eigen, the k_e x k_e Schur complement of the
// equality rows and, for the smooth basis, N_a^{1/2}. Called by project_range
// (kernels/projector_kernel.cpp) for envs [begin, end); the lane kernel covers
// every other model.
#pragma once

#include "atacom/projector.hpp"

namespace atacom {

void project_general_range(const ProjectorModel& mod, ProjectorBatch& B, int begin, int end, bool store_basis,
                           bool store_slack);

}  // namespace atacom
