#pragma once
// The report stage's interface to the other writers of HTML, XML and Markdown pages
// (compare.html/compare.md in src/compare/, the batch summary and JUnit file of
// `printtwin check` in src/cli/): escapes, numbers and gate names as the reports print
// them, and report.html's stylesheet so that those pages look alike. Not installed; the
// rest of the report writers' helpers stay private in report/report_internal.hpp.
#include <string>
#include <string_view>

namespace printtwin::detail {

/// Escapes &, <, >, " and ' for HTML text and attribute values.
[[nodiscard]] std::string html_escape(std::string_view s);
/// Escapes for XML 1.0 text/attributes and drops characters XML 1.0 forbids.
[[nodiscard]] std::string xml_escape(std::string_view s);
/// Escapes Markdown table cells (pipes, backslashes, newlines).
[[nodiscard]] std::string md_cell(std::string_view s);
/// Signed with an explicit "+" for positive values.
[[nodiscard]] std::string signed_fixed(double v, int decimals);
/// "12" or "12-18"; "—" when unknown.
[[nodiscard]] std::string layer_range(int lo, int hi);
/// Human label of a gate name ("max_excess" -> "Max excess").
[[nodiscard]] std::string gate_label(std::string_view name);
/// Unit of a gate's limit/value: "mm" or "" (counts).
[[nodiscard]] bool gate_is_count(std::string_view name);
/// report.html's stylesheet (html_assets.cpp).
[[nodiscard]] std::string_view report_css();

}  // namespace printtwin::detail
