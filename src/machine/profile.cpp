// Printer profiles: the built-in Ender-3 variants and JSON profile files.
#include <algorithm>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "machine/printer_internal.hpp"
#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/printer.hpp"

namespace printtwin {

using nlohmann::json;

PrinterProfile ender3_marlin2() {
  PrinterProfile p;  // the struct's defaults are the stock Ender-3 with Marlin 2.1
  p.start_gcode =
      "G90 ; absolute XYZ\n"
      "M83 ; relative E\n"
      "M140 S{bed_temp}\n"
      "M104 S{nozzle_temp}\n"
      "M190 S{bed_temp}\n"
      "M109 S{nozzle_temp}\n"
      "G28 ; home all axes\n"
      "G92 E0\n"
      "G1 Z2.0 F3000\n"
      "G1 X0.1 Y20 Z0.3 F5000.0 ; purge line start\n"
      "G1 X0.1 Y200.0 Z0.3 F1500.0 E15\n"
      "G1 X0.4 Y200.0 Z0.3 F5000.0\n"
      "G1 X0.4 Y20 Z0.3 F1500.0 E15\n"
      "G92 E0\n"
      "G1 Z2.0 F3000\n";
  p.end_gcode =
      "G91 ; relative positioning\n"
      "G1 E-2 F2700\n"
      "G1 E-2 Z0.2 F2400\n"
      "G1 X5 Y5 F3000\n"
      "G1 Z10\n"
      "G90\n"
      "G1 X0 Y{bed_max_y}\n"
      "M106 S0\n"
      "M104 S0\n"
      "M140 S0\n"
      "M84 X Y E\n";
  return p;
}

PrinterProfile ender3_marlin1() {
  PrinterProfile p = ender3_marlin2();
  p.name = "Creality Ender-3 (Marlin 1.1.9, classic jerk)";
  p.firmware = "marlin1";
  p.junction = JunctionModel::classic_jerk;
  p.jerk_mm_s = Eigen::Vector4d(10, 10, 0.3, 5);
  return p;
}

PrinterProfile ender3_klipper() {
  PrinterProfile p = ender3_marlin2();
  // Klipper's config/printer-creality-ender3-2018.cfg: [printer] max_velocity 300,
  // max_accel 3000, max_z_velocity 5, max_z_accel 100, and Klipper's defaults
  // square_corner_velocity 5, minimum_cruise_ratio 0.5; [extruder] nozzle 0.4, filament
  // 1.75 and no max_extrude_only_* (derived by the planner as Klipper does). Timed by
  // Klipper's planning model (firmware "klipper"); the Marlin fields are unused there.
  p.name = "Creality Ender-3 (Klipper)";
  p.firmware = "klipper";
  p.max_feedrate_mm_s = Eigen::Vector4d(300, 300, 5, 120);
  p.max_accel_mm_s2 = Eigen::Vector4d(3000, 3000, 100, 3000);
  p.print_accel_mm_s2 = p.retract_accel_mm_s2 = p.travel_accel_mm_s2 = 3000;
  p.square_corner_velocity_mm_s = 5.0;
  p.minimum_cruise_ratio = 0.5;
  p.max_extrude_only_velocity_mm_s = 0;
  p.max_extrude_only_accel_mm_s2 = 0;
  p.min_segment_time_s = 0.0;
  // [gcode_arcs] resolution 1 mm: floor(length / 1 mm) segments per arc.
  p.arc_min_segment_mm = p.arc_max_segment_mm = 1.0;
  return p;
}

namespace {

struct Key {
  std::function<Status(PrinterProfile&, const json&, const std::string&)> set;
  std::function<json(const PrinterProfile&)> get;
};

Error key_error(const std::string& source, const std::string& key, const std::string& what) {
  return bad_input("key \"" + key + "\": " + what, source);
}

Key number(double PrinterProfile::*member, double lo, double hi) {
  return Key{
      [member, lo, hi](PrinterProfile& p, const json& v, const std::string& where) -> Status {
        if (!v.is_number()) return key_error(where, "", "expected a number");
        const double d = v.get<double>();
        if (!(d >= lo && d <= hi))
          return key_error(where, "",
                           "value " + format_number(d) + " outside [" + format_number(lo) + ", " +
                               format_number(hi) + "]");
        p.*member = d;
        return Ok{};
      },
      [member](const PrinterProfile& p) { return json(p.*member); }};
}

Key integer(int PrinterProfile::*member, int lo, int hi) {
  return Key{
      [member, lo, hi](PrinterProfile& p, const json& v, const std::string& where) -> Status {
        if (!v.is_number_integer()) return key_error(where, "", "expected an integer");
        const auto d = v.get<long long>();
        if (d < lo || d > hi)
          return key_error(where, "",
                           "value " + std::to_string(d) + " outside [" + std::to_string(lo) + ", " +
                               std::to_string(hi) + "]");
        p.*member = static_cast<int>(d);
        return Ok{};
      },
      [member](const PrinterProfile& p) { return json(p.*member); }};
}

Key boolean(bool PrinterProfile::*member) {
  return Key{[member](PrinterProfile& p, const json& v, const std::string& where) -> Status {
               if (!v.is_boolean()) return key_error(where, "", "expected true or false");
               p.*member = v.get<bool>();
               return Ok{};
             },
             [member](const PrinterProfile& p) { return json(p.*member); }};
}

Key text(std::string PrinterProfile::*member) {
  return Key{[member](PrinterProfile& p, const json& v, const std::string& where) -> Status {
               if (v.is_array()) {  // multi-line text as an array of lines
                 std::string s;
                 for (const auto& line : v) {
                   if (!line.is_string()) return key_error(where, "", "expected strings");
                   s += line.get<std::string>() + "\n";
                 }
                 p.*member = s;
                 return Ok{};
               }
               if (!v.is_string()) return key_error(where, "", "expected a string");
               p.*member = v.get<std::string>();
               return Ok{};
             },
             [member](const PrinterProfile& p) { return json(p.*member); }};
}

template <class VecT>
Key vector(VecT PrinterProfile::*member, double lo, double hi) {
  return Key{
      [member, lo, hi](PrinterProfile& p, const json& v, const std::string& where) -> Status {
        const int n = static_cast<int>(VecT::RowsAtCompileTime);
        if (!v.is_array() || static_cast<int>(v.size()) != n)
          return key_error(where, "",
                           "expected an array of " + std::to_string(n) + " numbers (" +
                               (n == 4 ? "X, Y, Z, E" : "X, Y, Z") + ")");
        for (int i = 0; i < n; ++i) {
          if (!v[i].is_number()) return key_error(where, "", "expected numbers");
          const double d = v[i].get<double>();
          if (!(d >= lo && d <= hi))
            return key_error(where, "",
                             "value " + format_number(d) + " outside [" + format_number(lo) + ", " +
                                 format_number(hi) + "]");
          (p.*member)[i] = d;
        }
        return Ok{};
      },
      [member](const PrinterProfile& p) {
        json a = json::array();
        for (int i = 0; i < (p.*member).size(); ++i) a.push_back((p.*member)[i]);
        return a;
      }};
}

const std::map<std::string, Key>& keys() {
  using P = PrinterProfile;
  static const std::map<std::string, Key> k = {
      {"name", text(&P::name)},
      {"firmware", text(&P::firmware)},
      {"model", text(&P::model)},
      {"bed_min_x_mm", number(&P::bed_min_x_mm, -1000, 1000)},
      {"bed_min_y_mm", number(&P::bed_min_y_mm, -1000, 1000)},
      {"bed_max_x_mm", number(&P::bed_max_x_mm, 1, 2000)},
      {"bed_max_y_mm", number(&P::bed_max_y_mm, 1, 2000)},
      {"max_z_mm", number(&P::max_z_mm, 1, 2000)},
      {"travel_min_x_mm", number(&P::travel_min_x_mm, -1000, 1000)},
      {"travel_min_y_mm", number(&P::travel_min_y_mm, -1000, 1000)},
      {"travel_min_z_mm", number(&P::travel_min_z_mm, -1000, 1000)},
      {"travel_max_x_mm", number(&P::travel_max_x_mm, 1, 2000)},
      {"travel_max_y_mm", number(&P::travel_max_y_mm, 1, 2000)},
      {"travel_max_z_mm", number(&P::travel_max_z_mm, 1, 2000)},
      {"software_endstops", boolean(&P::software_endstops)},
      {"steps_per_mm", vector(&P::steps_per_mm, 1e-3, 1e5)},
      {"max_feedrate_mm_s", vector(&P::max_feedrate_mm_s, 1e-3, 1e5)},
      {"max_accel_mm_s2", vector(&P::max_accel_mm_s2, 1e-3, 1e7)},
      {"print_accel_mm_s2", number(&P::print_accel_mm_s2, 1e-3, 1e7)},
      {"retract_accel_mm_s2", number(&P::retract_accel_mm_s2, 1e-3, 1e7)},
      {"travel_accel_mm_s2", number(&P::travel_accel_mm_s2, 1e-3, 1e7)},
      {"junction_deviation_mm", number(&P::junction_deviation_mm, 0, 10)},
      {"jerk_mm_s", vector(&P::jerk_mm_s, 0, 1e4)},
      {"min_feedrate_mm_s", number(&P::min_feedrate_mm_s, 0, 1e4)},
      {"min_travel_feedrate_mm_s", number(&P::min_travel_feedrate_mm_s, 0, 1e4)},
      {"min_segment_time_s", number(&P::min_segment_time_s, 0, 10)},
      {"block_buffer_size", integer(&P::block_buffer_size, 2, 4096)},
      {"max_accel_to_decel_ratio", number(&P::max_accel_to_decel_ratio, 0.01, 1)},
      {"square_corner_velocity_mm_s", number(&P::square_corner_velocity_mm_s, 0, 1e4)},
      {"minimum_cruise_ratio", number(&P::minimum_cruise_ratio, 0, 0.99)},
      {"max_extrude_only_velocity_mm_s", number(&P::max_extrude_only_velocity_mm_s, 0, 1e5)},
      {"max_extrude_only_accel_mm_s2", number(&P::max_extrude_only_accel_mm_s2, 0, 1e7)},
      {"homing_feedrate_mm_s", vector(&P::homing_feedrate_mm_s, 1e-3, 1e4)},
      {"homing_bump_mm", vector(&P::homing_bump_mm, 0, 100)},
      {"homing_bump_divisor", vector(&P::homing_bump_divisor, 1, 100)},
      {"quick_home", boolean(&P::quick_home)},
      {"arc_min_segment_mm", number(&P::arc_min_segment_mm, 1e-4, 100)},
      {"arc_max_segment_mm", number(&P::arc_max_segment_mm, 1e-4, 100)},
      {"arc_min_segments_per_circle", integer(&P::arc_min_segments_per_circle, 3, 100000)},
      {"nozzle_diameter_mm", number(&P::nozzle_diameter_mm, 0.05, 5)},
      {"filament_diameter_mm", number(&P::filament_diameter_mm, 0.5, 5)},
      {"min_extrude_temp_c", number(&P::min_extrude_temp_c, 0, 500)},
      {"hotend_heat_rate_c_s", number(&P::hotend_heat_rate_c_s, 1e-3, 1000)},
      {"bed_heat_rate_c_s", number(&P::bed_heat_rate_c_s, 1e-3, 1000)},
      {"ambient_temp_c", number(&P::ambient_temp_c, -50, 100)},
      {"firmware_retraction", boolean(&P::firmware_retraction)},
      {"fw_retract_length_mm", number(&P::fw_retract_length_mm, 0, 100)},
      {"fw_retract_speed_mm_s", number(&P::fw_retract_speed_mm_s, 1e-3, 1000)},
      {"fw_recover_speed_mm_s", number(&P::fw_recover_speed_mm_s, 1e-3, 1000)},
      {"fw_retract_zraise_mm", number(&P::fw_retract_zraise_mm, 0, 100)},
      {"bridge_sag_mm", number(&P::bridge_sag_mm, 0, 100)},
      {"bridge_sag_span_mm", number(&P::bridge_sag_span_mm, 0.1, 10000)},
      {"overhang_fall_mm", number(&P::overhang_fall_mm, 0.01, 100)},
      {"overhang_droop_mm", number(&P::overhang_droop_mm, 0, 100)},
      {"elephant_foot_mm", number(&P::elephant_foot_mm, 0, 5)},
      {"start_gcode", text(&P::start_gcode)},
      {"end_gcode", text(&P::end_gcode)},
  };
  return k;
}

/// Keys of a profile file that describe it rather than set a value.
bool is_metadata_key(const std::string& key) {
  return key == "base" || key == "$schema" || key == "comment" || key == "junction" ||
         key == "id" || key == "aliases" || key == "sources";
}

const std::set<std::string> kFirmwares = {"marlin2", "marlin1", "prusa", "klipper", "rrf", "bambu"};

}  // namespace

Result<PrinterProfile> builtin_printer(std::string_view name) {
  PrinterProfile p;
  if (name == "ender3" || name == "ender3-marlin2")
    p = ender3_marlin2();
  else if (name == "ender3-marlin1")
    p = ender3_marlin1();
  else if (name == "ender3-klipper")
    p = ender3_klipper();
  else if (const auto* lib = find_library_printer(name))
    return lib->profile;
  else
    return usage_error("unknown printer \"" + std::string(name) +
                       "\": expected auto, a library printer (printtwin printers lists them), "
                       "ender3, ender3-marlin1, ender3-klipper, a .json profile or a Klipper .cfg");
  p.origin.library_id = std::string(name == "ender3-marlin2" ? "ender3" : name);
  return p;
}

Result<PrinterProfile> parse_printer_profile_with(std::string_view json_text,
                                                  std::string_view source,
                                                  const ProfileBaseLookup& lookup,
                                                  const std::string& origin_source) {
  const std::string src(source);
  json doc;
  try {
    doc = json::parse(json_text);
  } catch (const json::exception& e) {  // parse_error, also out_of_range for a number overflow
    return bad_input(std::string("not valid JSON: ") + e.what(), src);
  }
  if (!doc.is_object()) return bad_input("expected a JSON object of profile keys", src);

  PrinterProfile profile = ender3_marlin2();
  profile.origin = {};
  if (auto it = doc.find("base"); it != doc.end()) {
    if (!it->is_string()) return key_error(src, "base", "expected a built-in printer name");
    auto base = lookup(it->get<std::string>());
    if (!base) return key_error(src, "base", base.error().message);
    profile = *base;
  }
  for (const auto& [key, value] : doc.items()) {
    if (is_metadata_key(key)) {
      if ((key == "aliases" || key == "sources") &&
          !(value.is_array() &&
            std::all_of(value.begin(), value.end(), [](const json& v) { return v.is_string(); })))
        return key_error(src, key, "expected an array of strings");
      continue;
    }
    const auto it = keys().find(key);
    if (it == keys().end()) return key_error(src, key, "unknown key (see docs/printer-profile.md)");
    auto st = it->second.set(profile, value, src);
    if (!st)
      return key_error(src, key, st.error().message.substr(st.error().message.find(": ") + 2));
    profile.origin.set(key, origin_source, src);
  }
  if (auto it = doc.find("junction"); it != doc.end()) {
    const std::string j = it->is_string() ? it->get<std::string>() : "";
    if (j == "junction_deviation")
      profile.junction = JunctionModel::junction_deviation;
    else if (j == "classic_jerk")
      profile.junction = JunctionModel::classic_jerk;
    else
      return key_error(src, "junction", "expected \"junction_deviation\" or \"classic_jerk\"");
    profile.origin.set("junction", origin_source, src);
  }
  if (kFirmwares.count(profile.firmware) == 0)
    return key_error(src, "firmware", "expected marlin2, marlin1, prusa, klipper, rrf or bambu");
  if (profile.bed_max_x_mm <= profile.bed_min_x_mm || profile.bed_max_y_mm <= profile.bed_min_y_mm)
    return key_error(src, "bed_max_x_mm", "bed max must exceed bed min");
  if (profile.arc_max_segment_mm < profile.arc_min_segment_mm)
    return key_error(src, "arc_max_segment_mm", "must be at least arc_min_segment_mm");
  return profile;
}

Result<PrinterProfile> parse_printer_profile(std::string_view json_text, std::string_view source) {
  return parse_printer_profile_with(json_text, source, builtin_printer, "config");
}

Result<PrinterProfile> load_printer_profile(std::string_view name_or_path) {
  const std::filesystem::path path{std::string(name_or_path)};
  if (path.extension() == ".cfg") return load_klipper_printer_cfg(path);
  if (path.extension() != ".json") {
    if (name_or_path == "auto" || name_or_path.empty()) {
      // Nothing to detect from: the default printer.
      auto p = builtin_printer("ender3");
      p->origin.how = "auto";
      p->origin.library_id.clear();
      p->origin.summary = p->name + " (default: no G-code to read the printer from)";
      return p;
    }
    return builtin_printer(name_or_path);
  }
  auto text = read_file(path);
  if (!text) return text.error();
  return parse_printer_profile(*text, path.string());
}

std::string printer_profile_to_json(const PrinterProfile& profile) {
  json doc = json::object();
  for (const auto& [key, k] : keys()) doc[key] = k.get(profile);
  doc["junction"] =
      profile.junction == JunctionModel::classic_jerk ? "classic_jerk" : "junction_deviation";
  return doc.dump(2);
}

}  // namespace printtwin

namespace printtwin {

void PrinterOrigin::set(const std::string& key, const std::string& source,
                        const std::string& detail) {
  for (auto& v : values)
    if (v.key == key) {
      v.source = source;
      v.detail = detail;
      return;
    }
  values.push_back({key, source, detail});
}

const ValueOrigin* PrinterOrigin::find(std::string_view key) const {
  for (const auto& v : values)
    if (v.key == key) return &v;
  return nullptr;
}

std::vector<std::string> printer_profile_keys() {
  std::vector<std::string> out;
  for (const auto& [key, k] : keys()) out.push_back(key);
  out.emplace_back("junction");
  std::sort(out.begin(), out.end());
  return out;
}

std::string printer_provenance_json(const PrinterProfile& p) {
  json doc = json::object();
  doc["name"] = p.name;
  doc["model"] = p.model;
  doc["firmware"] = p.firmware;
  doc["how"] = p.origin.how.empty() ? "explicit" : p.origin.how;
  doc["summary"] = printer_provenance_summary(p);
  doc["library_id"] = p.origin.library_id.empty() ? json(nullptr) : json(p.origin.library_id);
  doc["slicer_settings"] = p.origin.slicer.empty() ? json(nullptr) : json(p.origin.slicer);
  json values = json::object();
  const json all = json::parse(printer_profile_to_json(p));
  for (const auto& [key, value] : all.items()) {
    if (key == "name" || key == "start_gcode" || key == "end_gcode") continue;
    json v{{"value", value}};
    if (const auto* o = p.origin.find(key)) {
      v["source"] = o->source;
      if (o->source == "file")
        v["key"] = o->detail;
      else if (o->source == "library")
        v["profile"] = o->detail;
      else if (o->source == "config")
        v["file"] = o->detail;
    } else if (!p.origin.library_id.empty()) {
      v["source"] = "library";
      v["profile"] = p.origin.library_id;
    } else {
      v["source"] = "default";
    }
    values[key] = v;
  }
  doc["values"] = values;
  return doc.dump(2);
}

std::string printer_provenance_summary(const PrinterProfile& p) {
  if (!p.origin.summary.empty()) return p.origin.summary;
  if (!p.origin.library_id.empty()) return p.name + " (" + p.origin.library_id + ")";
  return p.name;
}

}  // namespace printtwin
