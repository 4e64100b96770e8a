// junit.xml: the verdict in the JUnit XML dialect CI servers read (GitHub test-reporter
// actions, GitLab `artifacts:reports:junit`, Jenkins junit step): <testsuites> holding
// <testsuite> elements with tests/failures/errors/skipped/time counts, <testcase> elements
// with name/classname/time, and <failure message type> children on failed cases.
//
// Suite "<part>.gates": one case per gate. Suite "<part>.findings": one case per error
// finding (each one fails: an error finding is a defect of the print).
#include <map>

#include "printtwin/io.hpp"
#include "report/report_internal.hpp"

namespace printtwin {

namespace {

using detail::fixed;
using detail::xml_escape;

struct Case {
  std::string name;
  std::string classname;
  bool failed = false;
  std::string message;  // failure message attribute
  std::string type;     // failure type attribute
  std::string detail;   // failure text
};

std::string gate_value(const GateResult& g, double v) {
  return detail::gate_is_count(g.name) ? fixed(v, 0) : fixed(v, 3) + " mm";
}

std::string finding_location(const Finding& f) {
  std::string s;
  auto add = [&s](const std::string& part) { s += (s.empty() ? "" : ", ") + part; };
  if (f.layer) add("layer " + std::to_string(*f.layer));
  if (f.line) add("line " + std::to_string(*f.line));
  if (f.position_mm)
    add("at (" + fixed(f.position_mm->x(), 2) + ", " + fixed(f.position_mm->y(), 2) + ", " +
        fixed(f.position_mm->z(), 2) + ") mm");
  return s;
}

void write_suite(std::string& out, const std::string& name, const std::vector<Case>& cases,
                 double time_s, const std::string& timestamp,
                 const std::vector<std::pair<std::string, std::string>>& properties) {
  int failures = 0;
  for (const auto& c : cases) failures += c.failed ? 1 : 0;
  out += "  <testsuite name=\"" + xml_escape(name) + "\" tests=\"" + std::to_string(cases.size()) +
         "\" failures=\"" + std::to_string(failures) + "\" errors=\"0\" skipped=\"0\" time=\"" +
         fixed(time_s, 3) + "\"";
  if (!timestamp.empty()) {
    // The JUnit schema's timestamp is an ISO 8601 date-time without a zone (UTC here).
    std::string ts = timestamp;
    if (!ts.empty() && ts.back() == 'Z') ts.pop_back();
    out += " timestamp=\"" + xml_escape(ts) + "\"";
  }
  out += ">\n";
  if (!properties.empty()) {
    out += "    <properties>\n";
    for (const auto& [k, v] : properties)
      out += "      <property name=\"" + xml_escape(k) + "\" value=\"" + xml_escape(v) + "\"/>\n";
    out += "    </properties>\n";
  }
  for (const auto& c : cases) {
    out += "    <testcase name=\"" + xml_escape(c.name) + "\" classname=\"" +
           xml_escape(c.classname) + "\" time=\"0\"";
    if (!c.failed) {
      out += "/>\n";
      continue;
    }
    out += ">\n      <failure message=\"" + xml_escape(c.message) + "\" type=\"" +
           xml_escape(c.type) + "\">" + xml_escape(c.detail) + "</failure>\n    </testcase>\n";
  }
  out += "  </testsuite>\n";
}

}  // namespace

std::string report_junit_xml(const VerifyReport& report, const ReportOptions& options) {
  const std::string part = report.part_name.empty() ? "part" : report.part_name;
  const std::string prefix = "printtwin.verify." + part;

  std::vector<Case> gates;
  for (const auto& g : report.gates) {
    Case c;
    c.classname = prefix + ".gates";
    c.name = g.name + " (" + detail::gate_label(g.name) + " <= " + gate_value(g, g.limit) + ")";
    c.failed = !g.pass;
    if (c.failed) {
      c.type = "gate";
      c.message = detail::gate_label(g.name) + " " + gate_value(g, g.value) +
                  " exceeds the limit " + gate_value(g, g.limit);
      c.detail = c.message + ". Tolerance " + fixed(report.settings.gates.tolerance_mm, 3) +
                 " mm; " + detail::verdict_sentence(report);
    }
    gates.push_back(std::move(c));
  }

  std::vector<Case> findings;
  std::map<std::string, int> seen;  // code -> occurrences, to keep case names unique
  for (const auto& f : report.findings) {
    if (f.severity != Severity::error) continue;
    Case c;
    c.classname = prefix + ".findings";
    const std::string where = finding_location(f);
    c.name = f.code + (where.empty() ? "" : " (" + where + ")");
    if (const int n = ++seen[c.name]; n > 1) c.name += " #" + std::to_string(n);
    c.failed = true;
    c.type = f.code;
    c.message = f.message;
    c.detail = f.message + (where.empty() ? "" : "\n" + where) +
               (f.count > 1 ? "\n" + std::to_string(f.count) + " occurrences" : "");
    findings.push_back(std::move(c));
  }

  const double total_s = total_time_s(report);
  int failures = 0;
  for (const auto& c : gates) failures += c.failed ? 1 : 0;
  for (const auto& c : findings) failures += c.failed ? 1 : 0;

  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<testsuites name=\"printtwin verify " + xml_escape(part) + "\" tests=\"" +
         std::to_string(gates.size() + findings.size()) + "\" failures=\"" +
         std::to_string(failures) + "\" errors=\"0\" skipped=\"0\" time=\"" + fixed(total_s, 3) +
         "\">\n";
  const std::vector<std::pair<std::string, std::string>> props = {
      {"printtwin_version", report.tool_version},
      {"tolerance_mm", format_number(report.settings.gates.tolerance_mm)},
      {"pass", report.pass ? "true" : "false"},
      {"regions", std::to_string(report.deviation.regions.size())},
  };
  write_suite(out, prefix + ".gates", gates, total_s, options.generated_utc, props);
  write_suite(out, prefix + ".findings", findings, 0.0, options.generated_utc, {});
  out += "</testsuites>\n";
  return out;
}

}  // namespace printtwin
