// Slice settings: PrusaSlicer keys, --set key=value, flat .ini files, validation, widths.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <variant>

#include "core/zip_reader.hpp"
#include "printtwin/io.hpp"
#include "printtwin/slice.hpp"
#include "slice/project_settings.hpp"

namespace printtwin {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

std::optional<double> parse_double(std::string_view s) {
  s = trim(s);
  if (s.empty()) return std::nullopt;
  if (s.front() == '+') s.remove_prefix(1);
  double v = 0;
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// A number, or a percentage ("20%") returned as a ratio with `percent` set.
struct NumberOrPercent {
  double value = 0;
  bool percent = false;
};
std::optional<NumberOrPercent> parse_number_or_percent(std::string_view s) {
  s = trim(s);
  bool percent = false;
  if (!s.empty() && s.back() == '%') {
    percent = true;
    s.remove_suffix(1);
  }
  auto v = parse_double(s);
  if (!v) return std::nullopt;
  return NumberOrPercent{percent ? *v / 100.0 : *v, percent};
}

enum class Kind { number, count, flag, ratio, width, pattern, seam, solid_pattern };

// One settable key. `target` points into a SliceSettings given at use time.
struct Entry {
  const char* key;    // PrusaSlicer key
  const char* alias;  // printtwin alias (CLI flag name with '_'), or nullptr
  Kind kind;
  std::variant<double SliceSettings::*, int SliceSettings::*, bool SliceSettings::*,
               InfillPattern SliceSettings::*, SeamPosition SliceSettings::*, std::monostate>
      member;
};

using S = SliceSettings;
const std::vector<Entry>& entries() {
  static const std::vector<Entry> table = {
      {"layer_height", nullptr, Kind::number, &S::layer_height_mm},
      {"first_layer_height", nullptr, Kind::number, &S::first_layer_height_mm},
      {"nozzle_diameter", "nozzle", Kind::number, &S::nozzle_diameter_mm},
      {"filament_diameter", nullptr, Kind::number, &S::filament_diameter_mm},
      {"filament_density", nullptr, Kind::number, &S::filament_density_g_cm3},
      {"extrusion_multiplier", nullptr, Kind::number, &S::extrusion_multiplier},
      {"extrusion_width", "line_width", Kind::width, &S::extrusion_width_mm},
      {"perimeter_extrusion_width", nullptr, Kind::width, &S::perimeter_width_mm},
      {"external_perimeter_extrusion_width", nullptr, Kind::width, &S::external_perimeter_width_mm},
      {"infill_extrusion_width", nullptr, Kind::width, &S::infill_width_mm},
      {"solid_infill_extrusion_width", nullptr, Kind::width, &S::solid_infill_width_mm},
      {"top_infill_extrusion_width", nullptr, Kind::width, &S::top_infill_width_mm},
      {"first_layer_extrusion_width", nullptr, Kind::width, &S::first_layer_width_mm},
      {"perimeters", nullptr, Kind::count, &S::perimeters},
      {"top_solid_layers", "top_layers", Kind::count, &S::top_solid_layers},
      {"bottom_solid_layers", "bottom_layers", Kind::count, &S::bottom_solid_layers},
      {"fill_density", "infill_density", Kind::ratio, &S::infill_density},
      {"fill_pattern", "infill_pattern", Kind::pattern, &S::infill_pattern},
      {"top_fill_pattern", nullptr, Kind::solid_pattern, std::monostate{}},
      {"bottom_fill_pattern", nullptr, Kind::solid_pattern, std::monostate{}},
      {"solid_fill_pattern", nullptr, Kind::solid_pattern, std::monostate{}},
      {"fill_angle", nullptr, Kind::number, &S::fill_angle_deg},
      {"infill_overlap", nullptr, Kind::ratio, &S::infill_overlap},
      {"solid_infill_below_area", nullptr, Kind::number, &S::solid_infill_below_area_mm2},
      {"thin_walls", nullptr, Kind::flag, &S::thin_walls},
      {"gap_fill_enabled", "gap_fill", Kind::flag, &S::gap_fill},
      {"thin_wall_min_width", nullptr, Kind::width, &S::thin_wall_min_width_mm},
      {"seam_position", "seam", Kind::seam, &S::seam},
      {"external_perimeters_first", nullptr, Kind::flag, &S::external_perimeters_first},
      {"perimeter_speed", nullptr, Kind::number, &S::perimeter_speed_mm_s},
      {"external_perimeter_speed", nullptr, Kind::number, &S::external_perimeter_speed_mm_s},
      {"infill_speed", nullptr, Kind::number, &S::infill_speed_mm_s},
      {"solid_infill_speed", nullptr, Kind::number, &S::solid_infill_speed_mm_s},
      {"top_solid_infill_speed", nullptr, Kind::number, &S::top_solid_infill_speed_mm_s},
      {"gap_fill_speed", nullptr, Kind::number, &S::gap_fill_speed_mm_s},
      {"bridge_speed", nullptr, Kind::number, &S::bridge_speed_mm_s},
      {"first_layer_speed", nullptr, Kind::number, &S::first_layer_speed_mm_s},
      {"travel_speed", nullptr, Kind::number, &S::travel_speed_mm_s},
      {"skirt_speed", nullptr, Kind::number, &S::skirt_speed_mm_s},
      {"retract_length", "retraction", Kind::number, &S::retract_length_mm},
      {"retract_speed", nullptr, Kind::number, &S::retract_speed_mm_s},
      {"deretract_speed", nullptr, Kind::number, &S::deretract_speed_mm_s},
      {"retract_before_travel", nullptr, Kind::number, &S::retract_before_travel_mm},
      {"retract_layer_change", nullptr, Kind::flag, &S::retract_layer_change},
      {"only_retract_when_crossing_perimeters", nullptr, Kind::flag,
       &S::only_retract_when_crossing_perimeters},
      {"retract_lift", "z_hop", Kind::number, &S::retract_lift_mm},
      {"temperature", nullptr, Kind::number, &S::temperature_c},
      {"first_layer_temperature", nullptr, Kind::number, &S::first_layer_temperature_c},
      {"bed_temperature", nullptr, Kind::number, &S::bed_temperature_c},
      {"first_layer_bed_temperature", nullptr, Kind::number, &S::first_layer_bed_temperature_c},
      {"cooling", nullptr, Kind::flag, &S::cooling},
      {"fan_always_on", nullptr, Kind::flag, &S::fan_always_on},
      {"min_fan_speed", nullptr, Kind::number, &S::min_fan_speed},
      {"max_fan_speed", "fan_speed", Kind::number, &S::max_fan_speed},
      {"bridge_fan_speed", nullptr, Kind::number, &S::bridge_fan_speed},
      {"disable_fan_first_layers", nullptr, Kind::count, &S::disable_fan_first_layers},
      {"fan_below_layer_time", nullptr, Kind::number, &S::fan_below_layer_time_s},
      {"slowdown_below_layer_time", nullptr, Kind::number, &S::slowdown_below_layer_time_s},
      {"min_print_speed", nullptr, Kind::number, &S::min_print_speed_mm_s},
      {"skirts", nullptr, Kind::count, &S::skirts},
      {"skirt_distance", nullptr, Kind::number, &S::skirt_distance_mm},
      {"skirt_height", nullptr, Kind::count, &S::skirt_height},
      {"min_skirt_length", nullptr, Kind::number, &S::min_skirt_length_mm},
      {"brim_width", "brim", Kind::number, &S::brim_width_mm},
  };
  return table;
}

const Entry* find_entry(std::string_view key) {
  std::string k(key);
  std::replace(k.begin(), k.end(), '-', '_');
  for (const auto& e : entries())
    if (k == e.key || (e.alias != nullptr && k == e.alias)) return &e;
  return nullptr;
}

std::string quoted(std::string_view s) { return "'" + std::string(s) + "'"; }

// Applies `value` to the entry; returns an error message or empty.
std::string apply(SliceSettings& s, const Entry& e, std::string_view raw) {
  const std::string_view value = trim(raw);
  const std::string what = "setting " + quoted(e.key) + " = " + quoted(value);
  switch (e.kind) {
    case Kind::number: {
      auto v = parse_double(value);
      if (!v) return what + ": expected a number";
      s.*std::get<double S::*>(e.member) = *v;
      return {};
    }
    case Kind::count: {
      auto v = parse_double(value);
      if (!v || *v != std::floor(*v) || *v < 0 || *v > 1e6)
        return what + ": expected a whole number >= 0";
      s.*std::get<int S::*>(e.member) = static_cast<int>(*v);
      return {};
    }
    case Kind::flag: {
      if (value == "1" || value == "true")
        s.*std::get<bool S::*>(e.member) = true;
      else if (value == "0" || value == "false")
        s.*std::get<bool S::*>(e.member) = false;
      else
        return what + ": expected 0/1 or true/false";
      return {};
    }
    case Kind::ratio: {
      auto v = parse_number_or_percent(value);
      if (!v) return what + ": expected a percentage such as 20% or a fraction such as 0.2";
      // PrusaSlicer writes densities as "20%"; a bare number above 1 is read as percent too.
      double r = v->value;
      if (!v->percent && r > 1.0) r /= 100.0;
      s.*std::get<double S::*>(e.member) = r;
      return {};
    }
    case Kind::width: {
      auto v = parse_number_or_percent(value);
      if (!v) return what + ": expected a width in mm or a percentage";
      s.*std::get<double S::*>(e.member) = v->percent ? -v->value : v->value;
      return {};
    }
    case Kind::pattern: {
      InfillPattern p{};
      if (value == "rectilinear" || value == "line" || value == "alignedrectilinear" ||
          value == "monotonic")
        p = InfillPattern::rectilinear;
      else if (value == "grid")
        p = InfillPattern::grid;
      else if (value == "triangles" || value == "stars")
        p = InfillPattern::triangles;
      else if (value == "concentric")
        p = InfillPattern::concentric;
      else
        return what + ": expected rectilinear, grid, triangles or concentric";
      s.*std::get<InfillPattern S::*>(e.member) = p;
      return {};
    }
    case Kind::solid_pattern: {
      if (value == "rectilinear" || value == "monotonic" || value == "alignedrectilinear")
        return {};
      return what + ": solid layers support rectilinear or monotonic lines only";
    }
    case Kind::seam: {
      if (value == "nearest")
        s.seam = SeamPosition::nearest;
      else if (value == "aligned")
        s.seam = SeamPosition::aligned;
      else if (value == "rear")
        s.seam = SeamPosition::rear;
      else
        return what + ": expected nearest, aligned or rear";
      return {};
    }
  }
  return what + ": unsupported";
}

std::string pattern_name(InfillPattern p) {
  switch (p) {
    case InfillPattern::rectilinear:
      return "rectilinear";
    case InfillPattern::grid:
      return "grid";
    case InfillPattern::triangles:
      return "triangles";
    case InfillPattern::concentric:
      return "concentric";
  }
  return "grid";
}

std::string seam_name(SeamPosition p) {
  switch (p) {
    case SeamPosition::nearest:
      return "nearest";
    case SeamPosition::aligned:
      return "aligned";
    case SeamPosition::rear:
      return "rear";
  }
  return "nearest";
}

}  // namespace

Status set_slice_setting(SliceSettings& settings, std::string_view key, std::string_view value) {
  const Entry* e = find_entry(trim(key));
  if (e == nullptr)
    return usage_error("unknown slice setting " + quoted(trim(key)) +
                       " (docs/slicer.md lists the supported keys)");
  std::string msg = apply(settings, *e, value);
  if (!msg.empty()) return usage_error(msg);
  return Ok{};
}

Result<IniLoadReport> apply_prusa_ini(SliceSettings& settings, std::string_view text,
                                      std::string_view source) {
  IniLoadReport report;
  long line_no = 0;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = trim(text.substr(pos, end - pos));
    ++line_no;
    pos = end + 1;
    if (line.empty() || line.front() == '#' || line.front() == ';') {
      if (end == text.size()) break;
      continue;
    }
    if (line.front() == '[') {  // section header of a bundle: not a flat config
      return bad_input("section " + quoted(line) +
                           ": a flat PrusaSlicer config (key = value lines) was expected, "
                           "not a vendor bundle",
                       std::string(source), line_no);
    }
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos)
      return bad_input("expected 'key = value', got " + quoted(line), std::string(source), line_no);
    const std::string_view key = trim(line.substr(0, eq));
    const std::string_view value = trim(line.substr(eq + 1));
    if (key.empty()) return bad_input("empty key in " + quoted(line), std::string(source), line_no);
    const Entry* e = nullptr;
    for (const auto& candidate : entries())
      if (key == candidate.key) e = &candidate;
    if (e == nullptr) {
      report.ignored_keys.emplace_back(key);
    } else {
      std::string msg = apply(settings, *e, value);
      if (!msg.empty()) return bad_input(msg, std::string(source), line_no);
      report.used_keys.emplace_back(key);
      report.sources[std::string(key)] = SettingSource{std::string(source), line_no};
    }
    if (end == text.size()) break;
  }
  return report;
}

Result<std::string> prusa_config_text(std::string bytes, const std::string& source) {
  if (!detail::looks_like_zip(bytes)) return bytes;
  auto entry = detail::zip_entry(bytes, kProjectConfigEntry, source);
  if (!entry) return entry.error();
  if (!*entry)
    return bad_input(std::string("a zip (3MF) archive without PrusaSlicer settings (no ") +
                         std::string(kProjectConfigEntry) +
                         "): save the project from PrusaSlicer, or give its settings as an .ini "
                         "(File > Export > Export Config)",
                     source);
  std::string text = std::move(**entry);
  // The objects' own settings override the project's, as in PrusaSlicer.
  auto model_config = detail::zip_entry(bytes, detail::kProjectModelConfigEntry, source);
  if (!model_config) return model_config.error();
  auto ranges = detail::zip_entry(bytes, detail::kProjectLayerRangesEntry, source);
  if (!ranges) return ranges.error();
  auto overrides = detail::project_object_settings(model_config->value_or(std::string{}),
                                                   ranges->value_or(std::string{}), source);
  if (!overrides) return overrides.error();
  if (!overrides->empty()) {
    if (!text.empty() && text.back() != '\n') text += '\n';
    text += "# The object's own settings (" + std::string(detail::kProjectModelConfigEntry) + ")\n";
    for (const auto& [key, value] : *overrides) {
      std::string one_line = value;  // a multi-line value keeps the .ini's escaped form
      for (std::size_t at = 0; (at = one_line.find_first_of("\r\n", at)) != std::string::npos;)
        one_line.replace(at, 1, one_line[at] == '\n' ? "\\n" : "\\r");
      text.append(key).append(" = ").append(one_line).append("\n");
    }
  }
  return text;
}

Result<std::string> read_prusa_config(const std::filesystem::path& path) {
  auto bytes = read_file(path);
  if (!bytes) return bytes.error();
  return prusa_config_text(std::move(*bytes), path.string());
}

Result<IniLoadReport> load_prusa_ini(SliceSettings& settings, const std::filesystem::path& path) {
  auto text = read_prusa_config(path);
  if (!text) return text.error();
  return apply_prusa_ini(settings, *text, path.string());
}

ResolvedWidths resolve_widths(const SliceSettings& s) {
  const double d = s.nozzle_diameter_mm;
  auto pick = [&](double specific, double automatic, double ref) {
    double v = specific != 0 ? specific : s.extrusion_width_mm;
    if (v < 0) return -v * ref;
    if (v > 0) return v;
    return automatic;
  };
  ResolvedWidths w;
  w.external_perimeter_mm = pick(s.external_perimeter_width_mm, 1.125 * d, d);
  w.perimeter_mm = pick(s.perimeter_width_mm, 1.125 * d, d);
  w.infill_mm = pick(s.infill_width_mm, 1.125 * d, d);
  w.solid_infill_mm = pick(s.solid_infill_width_mm, 1.125 * d, d);
  w.top_infill_mm = pick(s.top_infill_width_mm, d, d);
  if (s.first_layer_width_mm < 0)
    w.first_layer_mm = -s.first_layer_width_mm * s.first_layer_height_mm;
  else if (s.first_layer_width_mm > 0)
    w.first_layer_mm = s.first_layer_width_mm;
  else
    w.first_layer_mm = 2.0 * s.first_layer_height_mm;  // PrusaSlicer's default "200%"
  return w;
}

double bead_area_mm2(double width_mm, double height_mm) {
  if (width_mm <= height_mm) return std::numbers::pi * 0.25 * width_mm * width_mm;
  return (width_mm - height_mm) * height_mm + std::numbers::pi * 0.25 * height_mm * height_mm;
}

double bead_spacing_mm(double width_mm, double height_mm) {
  if (width_mm <= height_mm) return width_mm;
  return width_mm - height_mm * (1.0 - 0.25 * std::numbers::pi);
}

double min_thin_wall_width_mm(const SliceSettings& s) {
  if (s.thin_wall_min_width_mm > 0) return s.thin_wall_min_width_mm;
  if (s.thin_wall_min_width_mm < 0) return -s.thin_wall_min_width_mm * s.nozzle_diameter_mm;
  return s.nozzle_diameter_mm / 3.0;  // PrusaSlicer prints thin walls down to about nozzle/3
}

Status validate_slice_settings(const SliceSettings& s, const SettingSources& sources) {
  auto fail = [&sources](const std::string& key, double v, const std::string& expected) -> Status {
    Error e =
        usage_error("setting '" + key + "' = " + format_number(v) + " is impossible: " + expected);
    if (auto it = sources.find(key); it != sources.end()) {
      e.code = ErrorCode::bad_input;  // a config file's line, not a command-line mistake
      e.file = it->second.file;
      e.line = it->second.line;
    }
    return e;
  };
  if (!(s.nozzle_diameter_mm >= 0.05 && s.nozzle_diameter_mm <= 3.0))
    return fail("nozzle_diameter", s.nozzle_diameter_mm, "expected 0.05 to 3 mm");
  if (!(s.filament_diameter_mm >= 0.5 && s.filament_diameter_mm <= 5.0))
    return fail("filament_diameter", s.filament_diameter_mm, "expected 0.5 to 5 mm");
  // Rounded to the micron so that the message reads 0.32, not 0.32000000000000006.
  const double max_h = std::round(0.8 * s.nozzle_diameter_mm * 1e6) / 1e6;
  if (!(s.layer_height_mm >= 0.01 && s.layer_height_mm <= max_h))
    return fail(
        "layer_height", s.layer_height_mm,
        "expected 0.01 mm to 80 % of the nozzle diameter (" + format_number(max_h) + " mm)");
  if (!(s.first_layer_height_mm >= 0.01 && s.first_layer_height_mm <= max_h))
    return fail(
        "first_layer_height", s.first_layer_height_mm,
        "expected 0.01 mm to 80 % of the nozzle diameter (" + format_number(max_h) + " mm)");
  const ResolvedWidths w = resolve_widths(s);
  const std::pair<const char*, double> widths[] = {
      {"external_perimeter_extrusion_width", w.external_perimeter_mm},
      {"perimeter_extrusion_width", w.perimeter_mm},
      {"infill_extrusion_width", w.infill_mm},
      {"solid_infill_extrusion_width", w.solid_infill_mm},
      {"top_infill_extrusion_width", w.top_infill_mm},
      {"first_layer_extrusion_width", w.first_layer_mm}};
  for (const auto& [key, v] : widths) {
    if (!(v >= 0.5 * s.nozzle_diameter_mm && v <= 3.0 * s.nozzle_diameter_mm))
      return fail(key, v, "expected a line width between 50 % and 300 % of the nozzle diameter");
    if (v < s.layer_height_mm && std::string(key) != "first_layer_extrusion_width")
      return fail(key, v, "a line must be at least as wide as the layer is high");
  }
  if (s.perimeters < 0 || s.perimeters > 100)
    return fail("perimeters", s.perimeters, "expected 0 to 100");
  if (s.top_solid_layers > 1000)
    return fail("top_solid_layers", s.top_solid_layers, "expected <= 1000");
  if (s.bottom_solid_layers > 1000)
    return fail("bottom_solid_layers", s.bottom_solid_layers, "expected <= 1000");
  if (!(s.infill_density >= 0 && s.infill_density <= 1.0))
    return fail("fill_density", s.infill_density * 100, "expected 0 % to 100 %");
  if (!(s.infill_overlap >= 0 && s.infill_overlap <= 1.0))
    return fail("infill_overlap", s.infill_overlap * 100, "expected 0 % to 100 %");
  if (!(s.extrusion_multiplier > 0.1 && s.extrusion_multiplier <= 3))
    return fail("extrusion_multiplier", s.extrusion_multiplier, "expected 0.1 to 3");
  const std::pair<const char*, double> speeds[] = {
      {"perimeter_speed", s.perimeter_speed_mm_s},
      {"external_perimeter_speed", s.external_perimeter_speed_mm_s},
      {"infill_speed", s.infill_speed_mm_s},
      {"solid_infill_speed", s.solid_infill_speed_mm_s},
      {"top_solid_infill_speed", s.top_solid_infill_speed_mm_s},
      {"gap_fill_speed", s.gap_fill_speed_mm_s},
      {"bridge_speed", s.bridge_speed_mm_s},
      {"first_layer_speed", s.first_layer_speed_mm_s},
      {"travel_speed", s.travel_speed_mm_s},
      {"retract_speed", s.retract_speed_mm_s},
      {"min_print_speed", s.min_print_speed_mm_s}};
  for (const auto& [key, v] : speeds)
    if (!(v > 0 && v <= 1000))
      return fail(key, v, "expected a speed above 0 and at most 1000 mm/s");
  if (!(s.skirt_speed_mm_s >= 0 && s.skirt_speed_mm_s <= 1000))
    return fail("skirt_speed", s.skirt_speed_mm_s, "expected 0 (auto) to 1000 mm/s");
  if (!(s.deretract_speed_mm_s >= 0 && s.deretract_speed_mm_s <= 1000))
    return fail("deretract_speed", s.deretract_speed_mm_s, "expected 0 (auto) to 1000 mm/s");
  if (!(s.retract_length_mm >= 0 && s.retract_length_mm <= 50))
    return fail("retract_length", s.retract_length_mm, "expected 0 to 50 mm");
  if (!(s.retract_before_travel_mm >= 0))
    return fail("retract_before_travel", s.retract_before_travel_mm, "expected >= 0 mm");
  if (!(s.retract_lift_mm >= 0 && s.retract_lift_mm <= 10))
    return fail("retract_lift", s.retract_lift_mm, "expected 0 to 10 mm");
  const std::pair<const char*, double> temps[] = {
      {"temperature", s.temperature_c},
      {"first_layer_temperature", s.first_layer_temperature_c},
      {"bed_temperature", s.bed_temperature_c},
      {"first_layer_bed_temperature", s.first_layer_bed_temperature_c}};
  for (const auto& [key, v] : temps)
    if (!(v >= 0 && v <= 450)) return fail(key, v, "expected 0 to 450 C");
  const std::pair<const char*, double> fans[] = {{"min_fan_speed", s.min_fan_speed},
                                                 {"max_fan_speed", s.max_fan_speed},
                                                 {"bridge_fan_speed", s.bridge_fan_speed}};
  for (const auto& [key, v] : fans)
    if (!(v >= 0 && v <= 100)) return fail(key, v, "expected 0 to 100 %");
  if (!(s.skirt_distance_mm >= 0 && s.skirt_distance_mm <= 100))
    return fail("skirt_distance", s.skirt_distance_mm, "expected 0 to 100 mm");
  if (s.skirts > 100) return fail("skirts", s.skirts, "expected 0 to 100 loops");
  if (!(s.brim_width_mm >= 0 && s.brim_width_mm <= 100))
    return fail("brim_width", s.brim_width_mm, "expected 0 to 100 mm");
  if (!(s.filament_density_g_cm3 > 0 && s.filament_density_g_cm3 < 30))
    return fail("filament_density", s.filament_density_g_cm3,
                "expected above 0 and below 30 g/cm3");
  if (!(s.solid_infill_below_area_mm2 >= 0))
    return fail("solid_infill_below_area", s.solid_infill_below_area_mm2, "expected >= 0 mm2");
  if (s.thin_wall_min_width_mm > 0 && s.thin_wall_min_width_mm > 3 * s.nozzle_diameter_mm)
    return fail("thin_wall_min_width", s.thin_wall_min_width_mm, "expected at most 3 x the nozzle");
  return Ok{};
}

std::vector<std::pair<std::string, std::string>> slice_settings_entries(const SliceSettings& s) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& e : entries()) {
    std::string v;
    switch (e.kind) {
      case Kind::number:
        v = format_number(s.*std::get<double S::*>(e.member));
        break;
      case Kind::count:
        v = std::to_string(s.*std::get<int S::*>(e.member));
        break;
      case Kind::flag:
        v = (s.*std::get<bool S::*>(e.member)) ? "1" : "0";
        break;
      case Kind::ratio:
        v = format_number(100.0 * (s.*std::get<double S::*>(e.member))) + "%";
        break;
      case Kind::width: {
        const double w = s.*std::get<double S::*>(e.member);
        v = w < 0 ? format_number(-100.0 * w) + "%" : format_number(w);
        break;
      }
      case Kind::pattern:
        v = pattern_name(s.infill_pattern);
        break;
      case Kind::solid_pattern:
        v = "monotonic";
        break;
      case Kind::seam:
        v = seam_name(s.seam);
        break;
    }
    out.emplace_back(e.key, v);
  }
  return out;
}

}  // namespace printtwin
