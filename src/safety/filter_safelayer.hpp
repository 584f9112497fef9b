// `atacom filter` with "method": "safelayer" (issue 9, section 2) or "cbf"
// (issue 32: the same QP with the rows J_q (f + G a) + J_x xdot <= -gamma c,
// key gamma > 0, default 10; src/safety/cbf_env.hpp).
//
// Extra keys: dt (> 0, default 1/30) and threshold (C: a number or one per
// row, default 0). a_pi = clip(alpha, -1, 1); the output a is the exact
// solution of min 1/2 |a - a_pi|^2 s.t. c_i + dt (F_i + (J_q G)_i a) <= C_i
// for every row and -1 <= a_j <= 1, F = J_q f + J_x xdot. Output keys: a,
// qdot = f + G a, active (row indices active at the solution), correction
// (|a - a_pi|), iterations, status (SafeLayerStatus bits) and status_flags
// ("infeasible": no action in the box satisfies every row, a is then the
// action in the box with the least squared row violation; "alpha_nonfinite";
// "model_nonfinite"; "iteration_limit").
#pragma once
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/projector.hpp"

namespace atacom {

// "atacom" (default), "safelayer" or "cbf"; throws std::invalid_argument for
// any other value and for keys that belong to another method.
std::string filter_method(const nlohmann::json& j);

// The SafeLayer or CBF answer for the parsed inputs (B holds one env; model its shapes).
nlohmann::json safelayer_filter(const nlohmann::json& j, const ProjectorModel& model, const ProjectorBatch& B);

}  // namespace atacom
