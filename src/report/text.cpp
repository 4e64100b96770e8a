// Text helpers shared by the HTML, JUnit and Markdown writers.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>

#include "printtwin/io.hpp"
#include "report/report_internal.hpp"

namespace printtwin {

namespace detail {

namespace {

// The entity for one of the five markup characters, or nullptr for any other character.
// HTML and XML differ only in the apostrophe: HTML 4 has no &apos;, so HTML gets &#39;.
const char* markup_entity(char c, const char* apostrophe) {
  switch (c) {
    case '&':
      return "&amp;";
    case '<':
      return "&lt;";
    case '>':
      return "&gt;";
    case '"':
      return "&quot;";
    case '\'':
      return apostrophe;
    default:
      return nullptr;
  }
}

}  // namespace

std::string html_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size() + 8);
  for (char c : s) {
    if (const char* e = markup_entity(c, "&#39;"))
      out += e;
    else
      out += c;
  }
  return out;
}

std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size() + 8);
  for (char c : s) {
    if (const char* e = markup_entity(c, "&apos;")) {
      out += e;
      continue;
    }
    // Tab, newline and return as character references so that attribute values keep them;
    // every other control character is not allowed in XML 1.0 and is dropped.
    if (c == '\t')
      out += "&#9;";
    else if (c == '\n')
      out += "&#10;";
    else if (c == '\r')
      out += "&#13;";
    else if (static_cast<unsigned char>(c) >= 0x20)
      out += c;
  }
  return out;
}

std::string md_cell(std::string_view s) {
  std::string out;
  for (char c : s) {
    if (c == '|')
      out += "\\|";
    else if (c == '\\')
      out += "\\\\";
    else if (c == '\n' || c == '\r')
      out += ' ';
    else
      out += c;
  }
  return out;
}

std::string base64(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const auto a = static_cast<unsigned char>(bytes[i]),
               b = static_cast<unsigned char>(bytes[i + 1]),
               c = static_cast<unsigned char>(bytes[i + 2]);
    out += kAlphabet[a >> 2];
    out += kAlphabet[((a & 3) << 4) | (b >> 4)];
    out += kAlphabet[((b & 15) << 2) | (c >> 6)];
    out += kAlphabet[c & 63];
  }
  if (i < bytes.size()) {
    const auto a = static_cast<unsigned char>(bytes[i]);
    const unsigned b = i + 1 < bytes.size() ? static_cast<unsigned char>(bytes[i + 1]) : 0u;
    out += kAlphabet[a >> 2];
    out += kAlphabet[((a & 3) << 4) | (b >> 4)];
    out += i + 1 < bytes.size() ? kAlphabet[(b & 15) << 2] : '=';
    out += '=';
  }
  return out;
}

std::string fixed(double v, int decimals) { return format_fixed(v, decimals); }

std::string signed_fixed(double v, int decimals) {
  std::string s = format_fixed(v, decimals);
  if (!s.empty() && s[0] != '-' && std::isfinite(v) && v >= 0.5 * std::pow(10.0, -decimals))
    s.insert(0, "+");
  return s;
}

std::string duration_text(double seconds) {
  if (std::isfinite(seconds) && seconds >= 0 && seconds < 60)
    return format_fixed(seconds, 1) + " s";
  return format_duration(seconds);
}

std::string gate_label(std::string_view name) {
  if (name == "max_excess") return "Max excess";
  if (name == "max_deficit") return "Max deficit";
  if (name == "max_rms") return "RMS";
  if (name == "no_error_findings") return "Error findings";
  std::string out(name);
  for (char& c : out)
    if (c == '_') c = ' ';
  if (!out.empty() && out[0] >= 'a' && out[0] <= 'z') out[0] = static_cast<char>(out[0] - 32);
  return out;
}

bool gate_is_count(std::string_view name) {
  return name == "no_error_findings" || name.find("findings") != std::string_view::npos ||
         name.find("count") != std::string_view::npos;
}

std::string_view region_kind_name(RegionKind k) {
  return k == RegionKind::missing ? "missing" : "excess";
}

std::string line_list(const std::vector<long>& lines, std::size_t max_items) {
  if (lines.empty()) return "—";
  std::string out;
  std::size_t items = 0, i = 0;
  while (i < lines.size() && items < max_items) {
    std::size_t j = i;
    while (j + 1 < lines.size() && lines[j + 1] == lines[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += std::to_string(lines[i]);
    if (j > i) out += "-" + std::to_string(lines[j]);
    ++items;
    i = j + 1;
  }
  if (i < lines.size()) out += ", +" + std::to_string(lines.size() - i) + " more";
  return out;
}

std::string layer_range(int lo, int hi) {
  if (lo < 0 && hi < 0) return "—";
  if (lo == hi || hi < 0) return std::to_string(lo);
  return std::to_string(lo) + "-" + std::to_string(hi);
}

SeverityCounts count_severities(const std::vector<Finding>& findings) {
  SeverityCounts c;
  for (const auto& f : findings) {
    if (f.severity == Severity::error)
      ++c.errors;
    else if (f.severity == Severity::warning)
      ++c.warnings;
    else
      ++c.infos;
  }
  return c;
}

std::string verdict_sentence(const VerifyReport& report) {
  int failed = 0;
  std::string first_failed;
  for (const auto& g : report.gates)
    if (!g.pass) {
      if (failed == 0) first_failed = gate_label(g.name);
      ++failed;
    }
  const auto& regions = report.deviation.regions;
  const std::string tol = "±" + fixed(report.deviation.tolerance_mm, 2) + " mm";
  std::string s;
  if (report.pass) {
    s = "All " + std::to_string(report.gates.size()) + " gates pass at " + tol + ".";
  } else {
    s = std::to_string(failed) + " of " + std::to_string(report.gates.size()) + " gates fail at " +
        tol + (failed > 0 ? " (" + first_failed + (failed > 1 ? ", …" : "") + ")" : "") + ".";
  }
  if (!regions.empty()) {
    std::size_t worst = 0;
    for (std::size_t i = 1; i < regions.size(); ++i)
      if (std::abs(regions[i].worst_mm) > std::abs(regions[worst].worst_mm)) worst = i;
    const auto& r = regions[worst];
    s += " " + std::to_string(regions.size()) + (regions.size() == 1 ? " region" : " regions") +
         " out of tolerance; the worst is " + std::string(region_kind_name(r.kind)) +
         " material, " + signed_fixed(r.worst_mm, 2) + " mm";
    if (r.layer_min >= 0) s += " at layer " + layer_range(r.layer_min, r.layer_max);
    s += ".";
  } else {
    s += " No region out of tolerance.";
  }
  return s;
}

}  // namespace detail

std::string report_timestamp_utc() {
  std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  if (const char* epoch = std::getenv("SOURCE_DATE_EPOCH"); epoch != nullptr && *epoch != '\0') {
    char* end = nullptr;
    const long long v = std::strtoll(epoch, &end, 10);
    if (end != nullptr && *end == '\0' && v >= 0) t = static_cast<std::time_t>(v);
  }
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace printtwin
