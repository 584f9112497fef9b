// `atacom filter`: ATACOM for any language, one JSON object per line.
//
// Input keys (n states, m controls, k constraints, p uncontrollable states):
//   f (n), G (n x m, list of rows), J_q (k x n), c (k), alpha (m)   required
//   J_x (k x p), xdot (p)                                            optional, together
//   slack  "softcorner" | "exponential" | "quadratic", or one per row   default "softcorner"
//   beta   number or one per row (> 0)                                default 3
//   tol    number or one per row, in (0, 1)                           default 1e-6
//   K_c    number >= 0                                                default 30 (1/dt at 30 Hz)
//   basis  "projected" | "smooth"                                     default "projected"
//   equality  k booleans                                              default all false
//   method "atacom" (default) | "safelayer" (keys and outputs: filter_safelayer.hpp)
//   id     anything; echoed back
// Output keys: a (m), qdot (n) = f + G a, s (k), lambda, status (bits of
// ProjectorStatus) and status_flags (their names). A line that cannot be
// processed produces {"error": "line L: ...", "line": L} instead: bad or
// invalid-UTF-8 JSON, duplicate keys, a blank line, a line longer than the
// limit, n/m/k/p above limits::kFilterMaxDim. Every input line gets exactly
// one answer line.
#pragma once
#include <cstddef>
#include <iosfwd>
#include <string>

#include "src/core/limits.hpp"

namespace atacom {

// Process one input line. Returns true and sets `out` to the result object,
// or returns false and sets `out` to the error object. Never throws.
bool filter_line(const std::string& line, long line_number, std::string& out);

// Stream stdin-like input to output line by line (flushing each answer, so a
// controller can use it request/response). Exactly one answer per input line
// (a blank line gets an error answer); a line longer than `max_line_bytes`
// is answered with an error without being kept in memory. Returns the number
// of lines that failed; throws std::runtime_error when `out` fails (a lost
// answer is never silent).
long run_filter(std::istream& in, std::ostream& out,
                size_t max_line_bytes = size_t(limits::kFilterDefaultLineBytes));

}  // namespace atacom
