#pragma once
// Private helpers of the report writers (src/report/ only). What other stages' pages share
// with the report (escapes, gate labels, the stylesheet) is in report/markup.hpp.
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/report.hpp"
#include "report/heatmap.hpp"
#include "report/markup.hpp"

namespace printtwin::detail {

/// Standard base64 (RFC 4648) with padding.
[[nodiscard]] std::string base64(std::string_view bytes);

/// Fixed decimals with an ASCII minus ("-0.000" printed as "0.000").
[[nodiscard]] std::string fixed(double v, int decimals);
/// "1 h 02 min", "12 min 05 s", "8.4 s".
[[nodiscard]] std::string duration_text(double seconds);
/// "missing" / "excess".
[[nodiscard]] std::string_view region_kind_name(RegionKind k);
/// "412-418, 530, +12 more" (at most `max_items` numbers).
[[nodiscard]] std::string line_list(const std::vector<long>& lines, std::size_t max_items);
/// Counts of findings by severity.
struct SeverityCounts {
  int errors = 0, warnings = 0, infos = 0;
};
[[nodiscard]] SeverityCounts count_severities(const std::vector<Finding>& findings);
/// One sentence for the verdict ("3 gates passed; ..."), plain text.
[[nodiscard]] std::string verdict_sentence(const VerifyReport& report);

/// Inline SVG histogram of signed distances, bars coloured by the scale.
[[nodiscard]] std::string histogram_svg(std::span<const double> distances_mm,
                                        const DeviationColorScale& scale, int bins,
                                        std::string_view title);
/// Inline SVG of deviation per layer (max excess, max deficit, RMS; tolerance band).
[[nodiscard]] std::string layer_chart_svg(const DeviationResult& deviation,
                                          const DeviationColorScale& scale);
/// JSON text of the layer viewer's data (compact, base64-packed arrays).
[[nodiscard]] std::string viewer_json(const VerifyReport& report, const DeviationColorScale& scale,
                                      const ReportOptions& options);

/// The page's script (html_assets.cpp).
[[nodiscard]] std::string_view report_js();

}  // namespace printtwin::detail
