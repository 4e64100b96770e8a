// verify_to_folder: verify() and the report folder in one call. The heatmaps' views need only
// the placed mesh, so they are traced as soon as the registration is known, while the
// deposit is still being laid; the report then only colours them.
#include <optional>

#include "printtwin/report.hpp"
#include "report/heatmap.hpp"
#include "verify/pipeline.hpp"

namespace printtwin {

Result<VerifyReport> verify_to_folder(const VerifyOptions& options,
                                      const std::filesystem::path& out_dir,
                                      const ReportOptions& report_options,
                                      const DerivedOutputs& derived_outputs) {
  std::optional<Result<HeatmapCache>> heatmaps;
  auto report = verify_detail::verify_with(options, [&](const Mesh& placed_mesh) {
    heatmaps.emplace(build_heatmap_cache(placed_mesh, report_options.views));
  });
  if (!report) return report.error();
  const HeatmapCache* traced = heatmaps && *heatmaps ? &**heatmaps : nullptr;
  ReportOptions with_outputs = report_options;
  if (derived_outputs)
    if (auto st = derived_outputs(*report, with_outputs); !st) return st.error();
  const VerifyReport& finished = *report;
  with_outputs.extra_outputs = [&](const std::filesystem::path& staging) -> Status {
    if (auto st = write_verify_outputs(finished, staging); !st) return st;
    return report_options.extra_outputs ? report_options.extra_outputs(staging) : Status(Ok{});
  };
  if (auto st = detail::write_report_folder(finished, out_dir, with_outputs, traced); !st)
    return st.error();
  return report;
}

}  // namespace printtwin
