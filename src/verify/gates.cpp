// The verdict of verify: the acceptance gates on the deviation and the findings.
#include <algorithm>

#include "printtwin/verify.hpp"

namespace printtwin {

double total_time_s(const VerifyReport& report) {
  if (report.elapsed_s > 0) return report.elapsed_s;
  double sum = 0;
  for (const auto& t : report.timings) sum += t.seconds;
  return sum;
}

void evaluate_gates(VerifyReport& report) {
  const VerifyGates& g = report.settings.gates;
  const DeviationResult& d = report.deviation;
  report.gates.clear();
  int errors = 0;
  for (const auto& f : report.findings)
    if (f.severity == Severity::error) ++errors;
  report.gates.push_back({"no_error_findings", 0, static_cast<double>(errors), errors == 0});
  const double excess_limit = g.max_excess_mm.value_or(g.tolerance_mm);
  const double deficit_limit = g.max_deficit_mm.value_or(g.tolerance_mm);
  report.gates.push_back(
      {"max_excess", excess_limit, d.max_excess_mm, d.max_excess_mm <= excess_limit});
  report.gates.push_back(
      {"max_deficit", deficit_limit, d.max_deficit_mm, d.max_deficit_mm <= deficit_limit});
  if (g.max_rms_mm) {
    const double rms = std::max(d.deposit_to_mesh.rms_mm, d.mesh_to_deposit.rms_mm);
    report.gates.push_back({"max_rms", *g.max_rms_mm, rms, rms <= *g.max_rms_mm});
  }
  report.pass = true;
  for (const auto& gate : report.gates) report.pass = report.pass && gate.pass;
}

}  // namespace printtwin
