// load_manifest / find_manifests: the parts manifest (manifest.hpp).
#include "cli/manifest.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "printtwin/io.hpp"
#include "printtwin/verify.hpp"
#include "report/report_internal.hpp"

namespace printtwin::cli {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr const char* kPartKeys[] = {"file",
                                     "printer",
                                     "units",
                                     "scale",
                                     "orient",
                                     "overhang_angle_deg",
                                     "min_thickness_mm",
                                     "line_width_mm",
                                     "self_intersections",
                                     "weld_tolerance_mm",
                                     "gcode",
                                     "tolerance_mm",
                                     "max_excess_mm",
                                     "max_deficit_mm",
                                     "max_rms_mm",
                                     "object"};

std::string key_list(bool with_file) {
  std::string s;
  for (const char* k : kPartKeys)
    if (with_file || std::string(k) != "file") s += (s.empty() ? "" : ", ") + std::string(k);
  return s;
}

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)), dir_(fs::path(path_).parent_path()) {}

  Error fail(const std::string& where, const std::string& what) const {
    return bad_input(where + ": " + what, path_);
  }

  std::string resolve(const std::string& p) const {
    const fs::path q(p);
    return (q.is_absolute() || dir_.empty() ? q : dir_ / q).lexically_normal().string();
  }

  static std::string unknown_key_message(const std::string& key, bool is_part) {
    std::string m = "unknown key '" + key + "' (expected ";
    m += key_list(is_part);
    m += ')';
    return m;
  }
  /// Reads the settings keys of `obj` (a part entry or "defaults") into `s`.
  Status settings(const json& obj, const std::string& where, bool is_part, PartSettings& s) const {
    if (!obj.is_object()) return fail(where, "expected an object");
    for (const auto& item : obj.items()) {
      const std::string& key = item.key();
      const json& value = item.value();
      if (std::find_if(std::begin(kPartKeys), std::end(kPartKeys),
                       [&key](const char* k) { return key == k; }) == std::end(kPartKeys) ||
          (!is_part && key == "file"))
        return fail(where, unknown_key_message(key, is_part));
      std::string at = where;
      at += '.';
      at += key;
      if (key == "file") continue;
      if (key == "printer" || key == "units" || key == "gcode" || key == "object") {
        if (!value.is_string() || value.get<std::string>().empty())
          return fail(at, "expected a non-empty string");
        std::string v = value.get<std::string>();
        if (key == "units" && v != "auto") {
          VerifySettings probe;
          if (!parse_units_option(v, probe))
            return fail(
                at, "unknown unit '" + v + "' (expected auto, mm, cm, m, in, um or mm per unit)");
        }
        if (key == "gcode") v = resolve(v);
        if (key == "printer" && (v.find('/') != std::string::npos || fs::path(v).has_extension()))
          v = resolve(v);
        (key == "printer" ? s.printer
         : key == "units" ? s.units
         : key == "gcode" ? s.gcode
                          : s.object) = v;
      } else if (key == "orient" || key == "self_intersections") {
        if (!value.is_boolean()) return fail(at, "expected true or false");
        (key == "orient" ? s.orient : s.self_intersections) = value.get<bool>();
      } else {
        if (!value.is_number() || !std::isfinite(value.get<double>()))
          return fail(at, "expected a number");
        const double v = value.get<double>();
        if (key == "overhang_angle_deg") {
          if (v < 0 || v > 90) return fail(at, "expected degrees from 0 to 90");
          s.overhang_angle_deg = v;
          continue;
        }
        if (key == "weld_tolerance_mm") {
          if (v < 0) return fail(at, "expected a number >= 0 (0: no weld)");
          s.weld_tolerance_mm = v;
          continue;
        }
        if (!(v > 0)) return fail(at, "expected a number > 0");
        std::optional<double>* slots[] = {&s.scale,        &s.min_thickness_mm, &s.line_width_mm,
                                          &s.tolerance_mm, &s.max_excess_mm,    &s.max_deficit_mm,
                                          &s.max_rms_mm};
        const char* names[] = {"scale",         "min_thickness_mm", "line_width_mm", "tolerance_mm",
                               "max_excess_mm", "max_deficit_mm",   "max_rms_mm"};
        for (std::size_t i = 0; i < std::size(names); ++i)
          if (key == names[i]) *slots[i] = v;
      }
    }
    return Ok{};
  }

 private:
  std::string path_;
  fs::path dir_;
};

/// `over`'s set keys on top of `base`.
PartSettings merged(PartSettings base, const PartSettings& over) {
  auto take = [](auto& dst, const auto& src) {
    if (src) dst = src;
  };
  take(base.printer, over.printer);
  take(base.units, over.units);
  take(base.scale, over.scale);
  take(base.orient, over.orient);
  take(base.overhang_angle_deg, over.overhang_angle_deg);
  take(base.min_thickness_mm, over.min_thickness_mm);
  take(base.line_width_mm, over.line_width_mm);
  take(base.self_intersections, over.self_intersections);
  take(base.weld_tolerance_mm, over.weld_tolerance_mm);
  take(base.gcode, over.gcode);
  take(base.tolerance_mm, over.tolerance_mm);
  take(base.max_excess_mm, over.max_excess_mm);
  take(base.max_deficit_mm, over.max_deficit_mm);
  take(base.max_rms_mm, over.max_rms_mm);
  take(base.object, over.object);
  return base;
}

}  // namespace

bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec1, ec2;
  const fs::path ca = fs::weakly_canonical(a, ec1), cb = fs::weakly_canonical(b, ec2);
  if (ec1 || ec2) return fs::path(a).lexically_normal() == fs::path(b).lexically_normal();
  return ca == cb;
}

Result<Manifest> load_manifest(const fs::path& path) {
  auto text = read_file(path);
  if (!text) return text.error();
  Manifest m;
  m.path = path.string();
  const Reader reader(m.path);
  json doc;
  try {
    doc = json::parse(*text);
  } catch (const json::parse_error& e) {
    return bad_input(std::string("not valid JSON: ") + e.what(), m.path);
  }
  if (!doc.is_object()) return bad_input("expected a JSON object with \"parts\"", m.path);
  for (const auto& [key, value] : doc.items()) {
    if (key == "version") {
      if (!value.is_number_integer() || value.get<long>() != 1)
        return reader.fail("version", "expected 1 (the only manifest version)");
    } else if (key == "defaults") {
      if (auto st = reader.settings(value, "defaults", false, m.defaults); !st) return st.error();
    } else if (key != "parts") {
      return reader.fail(key, "unknown key '" + key + "' (expected version, defaults, parts)");
    }
  }
  if (!doc.contains("parts") || !doc["parts"].is_array())
    return bad_input("expected \"parts\": a list of {\"file\": ...} entries", m.path);
  const json& parts = doc["parts"];
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::string where = "parts[" + std::to_string(i) + "]";
    PartSettings own;
    if (auto st = reader.settings(parts[i], where, true, own); !st) return st.error();
    if (!parts[i].contains("file") || !parts[i]["file"].is_string() ||
        parts[i]["file"].get<std::string>().empty())
      return reader.fail(where, "expected \"file\": the part's path, relative to the manifest");
    ManifestPart part;
    part.file = reader.resolve(parts[i]["file"].get<std::string>());
    for (const auto& earlier : m.parts)
      if (same_file(earlier.file, part.file))
        return reader.fail(where, "'" + part.file + "' is listed twice");
    part.settings = merged(m.defaults, own);
    m.parts.push_back(std::move(part));
  }
  return m;
}

Result<std::vector<Manifest>> find_manifests(const std::vector<std::string>& inputs,
                                             const std::string& explicit_manifest) {
  std::vector<Manifest> out;
  if (!explicit_manifest.empty()) {
    auto m = load_manifest(explicit_manifest);
    if (!m) return m.error();
    out.push_back(std::move(*m));
    return out;
  }
  std::vector<fs::path> candidates;
  for (const std::string& in : inputs) {
    std::error_code ec;
    const fs::path p(in);
    const fs::path dir = fs::is_directory(p, ec) ? p : p.parent_path();
    const fs::path cand = (dir.empty() ? fs::path(".") : dir) / kManifestName;
    if (fs::is_regular_file(cand, ec) &&
        std::none_of(candidates.begin(), candidates.end(),
                     [&](const fs::path& c) { return same_file(c.string(), cand.string()); }))
      candidates.push_back(cand);
  }
  for (const auto& c : candidates) {
    auto m = load_manifest(c);
    if (!m) return m.error();
    for (const auto& part : m->parts)
      for (const auto& other : out)
        for (const auto& q : other.parts)
          if (same_file(part.file, q.file))
            return bad_input("'" + part.file + "' is also listed in " + other.path, m->path);
    out.push_back(std::move(*m));
  }
  return out;
}

const ManifestPart* find_manifest_part(const std::vector<Manifest>& manifests,
                                       const std::string& file) {
  for (const auto& m : manifests)
    for (const auto& p : m.parts)
      if (same_file(p.file, file)) return &p;
  return nullptr;
}

std::string junit_xml(const std::string& suite, const std::string& classname,
                      const std::vector<CaseOutcome>& cases) {
  using detail::xml_escape;
  std::size_t failures = 0;
  double total = 0;
  for (const auto& c : cases) {
    failures += c.pass ? 0 : 1;
    total += c.seconds;
  }
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites>\n";
  x += "  <testsuite name=\"" + xml_escape(suite) + "\" tests=\"" + std::to_string(cases.size()) +
       "\" failures=\"" + std::to_string(failures) + "\" errors=\"0\" time=\"" +
       format_fixed(total, 3) + "\">\n";
  for (const auto& c : cases) {
    x += "    <testcase classname=\"" + xml_escape(classname) + "\" name=\"" + xml_escape(c.name) +
         "\" time=\"" + format_fixed(c.seconds, 3) + "\"";
    if (c.pass) {
      x += "/>\n";
      continue;
    }
    x += ">\n      <failure type=\"" + xml_escape(c.failure_type) + "\" message=\"" +
         xml_escape(c.message) + "\">" + xml_escape(c.details) + "</failure>\n    </testcase>\n";
  }
  x += "  </testsuite>\n</testsuites>\n";
  return x;
}

}  // namespace printtwin::cli
