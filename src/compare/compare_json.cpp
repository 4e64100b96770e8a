// compare.json and the sweep manifest: writing and reading back (docs/compare.md).
// Keys are written in a fixed order (ordered_json) and numbers rounded to 1e-6, so the same
// rows give the same bytes, and a merged comparison reads back exactly what a share wrote.
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>

#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "printtwin/version.hpp"

namespace printtwin {

namespace {

using Json = nlohmann::ordered_json;

double rounded(double v) {
  const double r = std::round(v * 1e6) / 1e6;
  return r == 0 ? 0.0 : r;  // no "-0.0"
}

Json num(double v) {
  if (!std::isfinite(v)) return nullptr;
  return rounded(v);
}

Json vec(const Vec3& p) { return Json::array({num(p.x()), num(p.y()), num(p.z())}); }

Json box(const Box3& b) {
  if (b.empty()) return nullptr;
  return Json{{"min", vec(b.min)}, {"max", vec(b.max)}};
}

Json settings_json(const std::vector<SettingKV>& settings) {
  Json a = Json::array();
  for (const auto& [k, v] : settings) a.push_back(Json::array({k, v}));
  return a;
}

Json variant_spec_json(const VariantSpec& v) {
  Json j;
  j["index"] = v.index;
  j["label"] = v.label;
  j["kind"] = std::string(to_string(v.kind));
  j["slicer_backend"] = v.slicer;
  j["config"] = v.config_path;
  j["settings"] = settings_json(v.settings);
  j["gcode"] = v.gcode_path;
  return j;
}

Json verify_settings_json(const VerifySettings& s) {
  Json j;
  j["tolerance_mm"] = num(s.gates.tolerance_mm);
  j["max_excess_mm"] = s.gates.max_excess_mm ? num(*s.gates.max_excess_mm) : Json(nullptr);
  j["max_deficit_mm"] = s.gates.max_deficit_mm ? num(*s.gates.max_deficit_mm) : Json(nullptr);
  j["max_rms_mm"] = s.gates.max_rms_mm ? num(*s.gates.max_rms_mm) : Json(nullptr);
  j["voxel_mm"] = num(s.voxel_mm);
  j["mesh_sample_spacing_mm"] = num(s.mesh_sample_spacing_mm);
  j["place_mm"] = s.place_mm ? vec(*s.place_mm) : Json(nullptr);
  j["printer"] = s.printer;
  j["seed"] = s.seed;
  j["max_regions"] = s.max_regions;
  return j;
}

Json direction_json(const DirectionFigures& d) {
  return Json{{"samples", d.samples},
              {"rms_mm", num(d.rms_mm)},
              {"p95_mm", num(d.p95_mm)},
              {"max_excess_mm", num(d.max_excess_mm)},
              {"max_deficit_mm", num(d.max_deficit_mm)},
              {"within_tolerance_pct", num(d.within_tolerance_pct)},
              {"slope_rms_mm", num(d.slope_rms_mm)},
              {"slope_samples", d.slope_samples}};
}

Json variant_result_json(const VariantResult& r) {
  Json j = variant_spec_json(r.variant);
  j["status"] = r.ran ? "ok" : "error";
  j["error"] = r.error;
  j["slicer"] = r.slicer;
  j["command"] = r.command;
  j["layers"] = r.layers;
  j["layer_height_mm"] = num(r.layer_height_mm);
  j["print_time_s"] = num(r.print_time_s);
  j["filament_m"] = num(r.filament_m);
  j["filament_g"] = num(r.filament_g);
  j["filament_density_g_cm3"] = num(r.filament_density_g_cm3);
  j["deviation"] = Json{{"rms_mm", num(r.rms_mm)},
                        {"slope_rms_mm", num(r.slope_rms_mm)},
                        {"deposit_to_mesh", direction_json(r.deposit_to_mesh)},
                        {"mesh_to_deposit", direction_json(r.mesh_to_deposit)}};
  j["regions"] = Json{{"missing", r.missing_regions}, {"excess", r.excess_regions}};
  j["findings"] =
      Json{{"error", r.error_findings}, {"warning", r.warning_findings}, {"info", r.info_findings}};
  Json gates = Json::array();
  for (const auto& g : r.gates)
    gates.push_back(
        Json{{"name", g.name}, {"limit", num(g.limit)}, {"value", num(g.value)}, {"pass", g.pass}});
  j["gates"] = gates;
  j["pass"] = r.pass;
  j["pareto"] = r.pareto;
  Json regions = Json::array();
  for (const auto& b : r.top_regions)
    regions.push_back(Json{{"kind", b.kind},
                           {"worst_mm", num(b.worst_mm)},
                           {"area_mm2", num(b.area_mm2)},
                           {"layers", Json::array({b.layer_min, b.layer_max})},
                           {"worst_position_mm", vec(b.worst_position_mm)}});
  j["top_regions"] = regions;
  j["report_dir"] = r.report_dir;
  j["run_time_s"] = num(r.run_time_s);
  return j;
}

// ---------------------------------------------------------------- reading

/// Reads typed values out of a parsed document; the first failure is kept with the path of
/// the key, and every later read returns a default.
class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[nodiscard]] const Json* at(const Json& obj, const char* key, const std::string& where) {
    if (!obj.is_object()) {
      fail(where, "expected an object");
      return nullptr;
    }
    auto it = obj.find(key);
    if (it == obj.end()) {
      fail(where + "." + key, "missing");
      return nullptr;
    }
    return &*it;
  }
  double number(const Json& obj, const char* key, const std::string& where, double fallback = 0) {
    const Json* v = at(obj, key, where);
    if (v == nullptr) return fallback;
    if (v->is_null()) return std::numeric_limits<double>::quiet_NaN();
    if (!v->is_number()) return fail(where + "." + key, "expected a number"), fallback;
    return v->get<double>();
  }
  std::optional<double> opt_number(const Json& obj, const char* key, const std::string& where) {
    const Json* v = at(obj, key, where);
    if (v == nullptr || v->is_null()) return std::nullopt;
    if (!v->is_number()) return fail(where + "." + key, "expected a number or null"), std::nullopt;
    return v->get<double>();
  }
  long long integer(const Json& obj, const char* key, const std::string& where) {
    const Json* v = at(obj, key, where);
    if (v == nullptr) return 0;
    if (!v->is_number_integer()) return fail(where + "." + key, "expected a whole number"), 0;
    return v->get<long long>();
  }
  std::string text(const Json& obj, const char* key, const std::string& where) {
    const Json* v = at(obj, key, where);
    if (v == nullptr) return {};
    if (!v->is_string()) return fail(where + "." + key, "expected a string"), std::string();
    return v->get<std::string>();
  }
  bool flag(const Json& obj, const char* key, const std::string& where) {
    const Json* v = at(obj, key, where);
    if (v == nullptr) return false;
    if (!v->is_boolean()) return fail(where + "." + key, "expected true or false"), false;
    return v->get<bool>();
  }
  const Json& array(const Json& obj, const char* key, const std::string& where) {
    static const Json kEmpty = Json::array();
    const Json* v = at(obj, key, where);
    if (v == nullptr) return kEmpty;
    if (!v->is_array()) return fail(where + "." + key, "expected an array"), kEmpty;
    return *v;
  }
  Vec3 vec3(const Json& obj, const char* key, const std::string& where) {
    const Json* v = at(obj, key, where);
    if (v == nullptr || v->is_null()) return Vec3::Zero();
    if (!v->is_array() || v->size() != 3 || !(*v)[0].is_number() || !(*v)[1].is_number() ||
        !(*v)[2].is_number())
      return fail(where + "." + key, "expected [x, y, z]"), Vec3::Zero();
    return Vec3((*v)[0].get<double>(), (*v)[1].get<double>(), (*v)[2].get<double>());
  }
  Box3 box3(const Json& obj, const char* key, const std::string& where) {
    const Json* v = at(obj, key, where);
    if (v == nullptr || v->is_null()) return Box3{};
    Box3 b;
    b.min = vec3(*v, "min", where + "." + key);
    b.max = vec3(*v, "max", where + "." + key);
    return b;
  }
  void fail(const std::string& where, const std::string& what) {
    if (!error_) error_ = bad_input("key '" + where + "': " + what, source_);
  }
  [[nodiscard]] const std::optional<Error>& error() const { return error_; }

 private:
  std::string source_;
  std::optional<Error> error_;
};

std::vector<SettingKV> read_settings(Reader& rd, const Json& obj, const std::string& where,
                                     const char* key = "settings") {
  std::vector<SettingKV> out;
  const Json& a = rd.array(obj, key, where);
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Json& kv = a[i];
    if (!kv.is_array() || kv.size() != 2 || !kv[0].is_string() || !kv[1].is_string()) {
      rd.fail(where + "." + key + "[" + std::to_string(i) + "]", "expected [\"key\", \"value\"]");
      break;
    }
    out.emplace_back(kv[0].get<std::string>(), kv[1].get<std::string>());
  }
  return out;
}

VariantSpec read_variant_spec(Reader& rd, const Json& j, const std::string& where) {
  VariantSpec v;
  v.index = static_cast<int>(rd.integer(j, "index", where));
  v.label = rd.text(j, "label", where);
  const std::string kind = rd.text(j, "kind", where);
  if (kind == "gcode")
    v.kind = VariantKind::gcode;
  else if (kind == "slicer")
    v.kind = VariantKind::slicer;
  else
    rd.fail(where + ".kind", "expected \"slicer\" or \"gcode\", got \"" + kind + "\"");
  // Written since the external slicer back-ends; older files are printtwin's slicer.
  if (j.contains("slicer_backend")) v.slicer = rd.text(j, "slicer_backend", where);
  if (v.kind == VariantKind::slicer && !is_known_slicer(v.slicer))
    rd.fail(where + ".slicer_backend",
            "expected printtwin, prusa-slicer, cura or slic3r, got \"" + v.slicer + "\"");
  v.config_path = rd.text(j, "config", where);
  v.settings = read_settings(rd, j, where);
  v.gcode_path = rd.text(j, "gcode", where);
  return v;
}

VerifySettings read_verify_settings(Reader& rd, const Json& j, const std::string& where) {
  VerifySettings s;
  s.gates.tolerance_mm = rd.number(j, "tolerance_mm", where, s.gates.tolerance_mm);
  s.gates.max_excess_mm = rd.opt_number(j, "max_excess_mm", where);
  s.gates.max_deficit_mm = rd.opt_number(j, "max_deficit_mm", where);
  s.gates.max_rms_mm = rd.opt_number(j, "max_rms_mm", where);
  s.voxel_mm = rd.number(j, "voxel_mm", where, s.voxel_mm);
  s.mesh_sample_spacing_mm = rd.number(j, "mesh_sample_spacing_mm", where);
  const Json* place = rd.at(j, "place_mm", where);
  if (place != nullptr && !place->is_null()) s.place_mm = rd.vec3(j, "place_mm", where);
  s.printer = rd.text(j, "printer", where);
  s.seed = static_cast<std::uint64_t>(rd.integer(j, "seed", where));
  s.max_regions = static_cast<int>(rd.integer(j, "max_regions", where));
  return s;
}

DirectionFigures read_direction(Reader& rd, const Json& j, const std::string& where) {
  DirectionFigures d;
  d.samples = static_cast<std::size_t>(rd.integer(j, "samples", where));
  d.rms_mm = rd.number(j, "rms_mm", where);
  d.p95_mm = rd.number(j, "p95_mm", where);
  d.max_excess_mm = rd.number(j, "max_excess_mm", where);
  d.max_deficit_mm = rd.number(j, "max_deficit_mm", where);
  d.within_tolerance_pct = rd.number(j, "within_tolerance_pct", where);
  d.slope_rms_mm = rd.number(j, "slope_rms_mm", where);
  d.slope_samples = static_cast<std::size_t>(rd.integer(j, "slope_samples", where));
  return d;
}

VariantResult read_variant_result(Reader& rd, const Json& j, const std::string& where) {
  VariantResult r;
  r.variant = read_variant_spec(rd, j, where);
  const std::string status = rd.text(j, "status", where);
  if (status != "ok" && status != "error")
    rd.fail(where + ".status", "expected \"ok\" or \"error\"");
  r.ran = status == "ok";
  r.error = rd.text(j, "error", where);
  r.slicer = rd.text(j, "slicer", where);
  if (j.contains("command")) r.command = rd.text(j, "command", where);
  r.layers = static_cast<int>(rd.integer(j, "layers", where));
  r.layer_height_mm = rd.number(j, "layer_height_mm", where);
  r.print_time_s = rd.number(j, "print_time_s", where);
  r.filament_m = rd.number(j, "filament_m", where);
  r.filament_g = rd.number(j, "filament_g", where);
  r.filament_density_g_cm3 = rd.number(j, "filament_density_g_cm3", where);
  if (const Json* dev = rd.at(j, "deviation", where)) {
    const std::string w = where + ".deviation";
    r.rms_mm = rd.number(*dev, "rms_mm", w);
    r.slope_rms_mm = rd.number(*dev, "slope_rms_mm", w);
    if (const Json* d = rd.at(*dev, "deposit_to_mesh", w))
      r.deposit_to_mesh = read_direction(rd, *d, w + ".deposit_to_mesh");
    if (const Json* d = rd.at(*dev, "mesh_to_deposit", w))
      r.mesh_to_deposit = read_direction(rd, *d, w + ".mesh_to_deposit");
  }
  if (const Json* reg = rd.at(j, "regions", where)) {
    r.missing_regions = static_cast<int>(rd.integer(*reg, "missing", where + ".regions"));
    r.excess_regions = static_cast<int>(rd.integer(*reg, "excess", where + ".regions"));
  }
  if (const Json* f = rd.at(j, "findings", where)) {
    r.error_findings = static_cast<int>(rd.integer(*f, "error", where + ".findings"));
    r.warning_findings = static_cast<int>(rd.integer(*f, "warning", where + ".findings"));
    r.info_findings = static_cast<int>(rd.integer(*f, "info", where + ".findings"));
  }
  const Json& gates = rd.array(j, "gates", where);
  for (std::size_t i = 0; i < gates.size(); ++i) {
    const std::string w = where + ".gates[" + std::to_string(i) + "]";
    GateResult g;
    g.name = rd.text(gates[i], "name", w);
    g.limit = rd.number(gates[i], "limit", w);
    g.value = rd.number(gates[i], "value", w);
    g.pass = rd.flag(gates[i], "pass", w);
    r.gates.push_back(g);
  }
  r.pass = rd.flag(j, "pass", where);
  r.pareto = rd.flag(j, "pareto", where);
  const Json& regions = rd.array(j, "top_regions", where);
  for (std::size_t i = 0; i < regions.size(); ++i) {
    const std::string w = where + ".top_regions[" + std::to_string(i) + "]";
    RegionBrief b;
    b.kind = rd.text(regions[i], "kind", w);
    b.worst_mm = rd.number(regions[i], "worst_mm", w);
    b.area_mm2 = rd.number(regions[i], "area_mm2", w);
    const Json& layers = rd.array(regions[i], "layers", w);
    if (layers.size() == 2 && layers[0].is_number_integer() && layers[1].is_number_integer()) {
      b.layer_min = layers[0].get<int>();
      b.layer_max = layers[1].get<int>();
    } else {
      rd.fail(w + ".layers", "expected [first, last]");
    }
    b.worst_position_mm = rd.vec3(regions[i], "worst_position_mm", w);
    r.top_regions.push_back(b);
  }
  r.report_dir = rd.text(j, "report_dir", where);
  r.run_time_s = rd.number(j, "run_time_s", where);
  return r;
}

Result<Json> parse_text(std::string_view text, std::string_view source) {
  try {
    return Json::parse(text);
  } catch (
      const nlohmann::json::exception& e) {  // parse_error, also out_of_range for a number overflow
    return bad_input(std::string("not valid JSON: ") + e.what(), std::string(source));
  }
}

std::optional<Error> check_schema(const Json& doc, const char* schema, std::string_view source) {
  if (!doc.is_object() || !doc.contains("schema") || doc["schema"] != schema)
    return bad_input(
        std::string("not a ") + schema + " file (its \"schema\" key is not \"" + schema + "\")",
        std::string(source));
  if (!doc.contains("schema_version") || !doc["schema_version"].is_number_integer() ||
      doc["schema_version"].get<int>() > kCompareSchemaVersion)
    return bad_input("unsupported schema_version (this printtwin reads up to " +
                         std::to_string(kCompareSchemaVersion) + ")",
                     std::string(source));
  return std::nullopt;
}

}  // namespace

// ---------------------------------------------------------------- plan

namespace {
Json plan_body(const ComparePlan& plan, bool with_path) {
  Json j;
  j["schema"] = "printtwin.compare-plan";
  j["schema_version"] = kCompareSchemaVersion;
  if (with_path) j["mesh"] = plan.mesh_path;
  j["mesh_sha256"] = plan.mesh_sha256;
  j["printer"] = plan.printer;
  j["verify"] = verify_settings_json(plan.verify);
  j["filament_density_g_cm3"] = num(plan.filament_density_g_cm3);
  j["slicer_timeout_s"] = num(plan.slicer_timeout_s);
  j["cura_definition"] = plan.cura_definition;
  if (with_path) j["slicer_paths"] = settings_json(plan.slicer_paths);
  Json vs = Json::array();
  for (const auto& v : plan.variants) vs.push_back(variant_spec_json(v));
  j["variants"] = vs;
  return j;
}
}  // namespace

std::string compare_plan_id(const ComparePlan& plan) {
  return sha256_hex(plan_body(plan, false).dump());
}

std::string compare_plan_json(const ComparePlan& plan) {
  Json j = plan_body(plan, true);
  j["plan_id"] = compare_plan_id(plan);
  return j.dump(2) + "\n";
}

Result<ComparePlan> parse_compare_plan(std::string_view json_text, std::string_view source) {
  auto doc = parse_text(json_text, source);
  if (!doc) return doc.error();
  if (auto e = check_schema(*doc, "printtwin.compare-plan", source)) return *e;
  Reader rd{std::string(source)};
  ComparePlan plan;
  plan.mesh_path = rd.text(*doc, "mesh", "");
  plan.mesh_sha256 = rd.text(*doc, "mesh_sha256", "");
  plan.printer = rd.text(*doc, "printer", "");
  if (const Json* v = rd.at(*doc, "verify", ""))
    plan.verify = read_verify_settings(rd, *v, "verify");
  plan.filament_density_g_cm3 = rd.number(*doc, "filament_density_g_cm3", "");
  if (doc->contains("slicer_timeout_s"))
    plan.slicer_timeout_s = rd.number(*doc, "slicer_timeout_s", "");
  if (doc->contains("cura_definition")) plan.cura_definition = rd.text(*doc, "cura_definition", "");
  if (doc->contains("slicer_paths"))
    plan.slicer_paths = read_settings(rd, *doc, "", "slicer_paths");
  const Json& vs = rd.array(*doc, "variants", "");
  for (std::size_t i = 0; i < vs.size(); ++i) {
    plan.variants.push_back(read_variant_spec(rd, vs[i], "variants[" + std::to_string(i) + "]"));
    if (plan.variants.back().index != static_cast<int>(i))
      rd.fail("variants[" + std::to_string(i) + "].index", "expected " + std::to_string(i));
  }
  if (rd.error()) return *rd.error();
  if (doc->contains("plan_id") && (*doc)["plan_id"].is_string() &&
      (*doc)["plan_id"].get<std::string>() != compare_plan_id(plan))
    return bad_input(
        "the manifest was edited after it was written (its plan_id does not match "
        "its content); write it again with --write-manifest",
        std::string(source));
  return plan;
}

// ---------------------------------------------------------------- compare.json

std::string compare_json(const CompareResult& r) {
  Json j;
  j["schema"] = "printtwin.compare";
  j["schema_version"] = r.schema_version;
  j["tool_version"] = r.tool_version;
  j["part"] = Json{{"name", r.part.name},
                   {"path", r.part.path},
                   {"sha256", r.part.sha256},
                   {"triangles", r.part.triangles},
                   {"volume_mm3", num(r.part.volume_mm3)},
                   {"area_mm2", num(r.part.area_mm2)},
                   {"sloped_area_mm2", num(r.part.sloped_area_mm2)},
                   {"bbox_mm", box(r.part.bbox_mm)}};
  j["printer"] = r.printer;
  j["verify"] = verify_settings_json(r.verify);
  j["plan_id"] = r.plan_id;
  j["variant_count"] = r.variant_count;
  j["shard"] = r.shard ? Json{{"index", r.shard->first}, {"of", r.shard->second}} : Json(nullptr);
  j["pareto_objectives"] = Json::array({"print_time_s", "deviation.rms_mm"});
  Json vs = Json::array();
  for (const auto& v : r.variants) vs.push_back(variant_result_json(v));
  j["variants"] = vs;
  j["timing"] = Json{{"shared_s", num(r.shared_time_s)}, {"total_s", num(r.total_time_s)}};
  return j.dump(2) + "\n";
}

Result<CompareResult> parse_compare_json(std::string_view json_text, std::string_view source) {
  auto doc = parse_text(json_text, source);
  if (!doc) return doc.error();
  if (auto e = check_schema(*doc, "printtwin.compare", source)) return *e;
  Reader rd{std::string(source)};
  CompareResult r;
  r.schema_version = static_cast<int>(rd.integer(*doc, "schema_version", ""));
  r.tool_version = rd.text(*doc, "tool_version", "");
  if (const Json* p = rd.at(*doc, "part", "")) {
    r.part.name = rd.text(*p, "name", "part");
    r.part.path = rd.text(*p, "path", "part");
    r.part.sha256 = rd.text(*p, "sha256", "part");
    r.part.triangles = static_cast<std::size_t>(rd.integer(*p, "triangles", "part"));
    r.part.volume_mm3 = rd.number(*p, "volume_mm3", "part");
    r.part.area_mm2 = rd.number(*p, "area_mm2", "part");
    r.part.sloped_area_mm2 = rd.number(*p, "sloped_area_mm2", "part");
    r.part.bbox_mm = rd.box3(*p, "bbox_mm", "part");
  }
  r.printer = rd.text(*doc, "printer", "");
  if (const Json* v = rd.at(*doc, "verify", "")) r.verify = read_verify_settings(rd, *v, "verify");
  r.plan_id = rd.text(*doc, "plan_id", "");
  r.variant_count = static_cast<int>(rd.integer(*doc, "variant_count", ""));
  if (const Json* s = rd.at(*doc, "shard", ""); s != nullptr && !s->is_null())
    r.shard = std::make_pair(static_cast<int>(rd.integer(*s, "index", "shard")),
                             static_cast<int>(rd.integer(*s, "of", "shard")));
  const Json& vs = rd.array(*doc, "variants", "");
  for (std::size_t i = 0; i < vs.size(); ++i)
    r.variants.push_back(read_variant_result(rd, vs[i], "variants[" + std::to_string(i) + "]"));
  if (const Json* t = rd.at(*doc, "timing", "")) {
    r.shared_time_s = rd.number(*t, "shared_s", "timing");
    r.total_time_s = rd.number(*t, "total_s", "timing");
  }
  if (rd.error()) return *rd.error();
  return r;
}

}  // namespace printtwin
