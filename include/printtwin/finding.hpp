#pragma once
// Finding: a defect or risk of the print (overhang, thin wall, out-of-bed move,
// extrusion into air, deviation over tolerance). Findings are data, not errors.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/geometry.hpp"

namespace printtwin {

enum class Severity { info, warning, error };

[[nodiscard]] constexpr std::string_view to_string(Severity s) {
  switch (s) {
    case Severity::info:
      return "info";
    case Severity::warning:
      return "warning";
    case Severity::error:
      return "error";
  }
  return "error";
}

/// One finding. `code` is stable (snake_case, documented in docs/findings.md) so CI can
/// match on it; `message` is for people.
struct Finding {
  Severity severity = Severity::warning;
  std::string code;                 ///< e.g. "overhang", "thin_wall", "out_of_bounds"
  std::string message;              ///< one sentence with the numbers that matter
  std::optional<Vec3> position_mm;  ///< where (machine or mesh frame, as the stage says)
  std::optional<Box3> extent_mm;    ///< the area it covers, when it is not a point
  std::optional<long> line;         ///< G-code line (1-based), for G-code findings
  std::optional<int> layer;         ///< layer index (0-based), when known
  std::optional<long> face;         ///< mesh triangle index, for mesh findings
  std::optional<double> value;      ///< the measured figure (angle, thickness, mm...)
  long count = 1;                   ///< how many occurrences this finding stands for
};

[[nodiscard]] inline bool has_errors(const std::vector<Finding>& findings) {
  for (const auto& f : findings)
    if (f.severity == Severity::error) return true;
  return false;
}

}  // namespace printtwin
