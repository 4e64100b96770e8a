// --printer auto: the printer a G-code was made for, from the slicer's embedded settings
// and the built-in library, with the source of every value.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include "machine/printer_internal.hpp"
#include "printtwin/gcode.hpp"
#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"

namespace printtwin {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

/// Keeps what can be part of a decimal number; everything else separates numbers (so
/// "0x300" is 0 and 300, never hexadecimal, and "infill" is no infinity).
std::string decimal_only(std::string_view v) {
  std::string s(v);
  for (auto& c : s)
    if (std::isdigit(static_cast<unsigned char>(c)) == 0 && c != '.' && c != '-' && c != '+' &&
        c != 'e' && c != 'E')
      c = ' ';
  return s;
}

/// The first number of a value ("4000,2500" -> 4000, "0.4,0.4" -> 0.4, "220" -> 220).
std::optional<double> first_number(std::string_view v) {
  while (!v.empty() && (v.front() == '"' || v.front() == '[' ||
                        std::isspace(static_cast<unsigned char>(v.front())) != 0))
    v.remove_prefix(1);
  if (v.empty()) return std::nullopt;
  std::string s = decimal_only(v.substr(0, std::min<std::size_t>(v.size(), 40)));
  char* end = nullptr;
  const double d = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || !std::isfinite(d)) return std::nullopt;
  return d;
}

/// All numbers of a value separated by anything that is not part of a number.
std::vector<double> numbers(std::string_view v) {
  std::vector<double> out;
  const std::string s = decimal_only(v);
  const char* p = s.c_str();
  while (*p != 0) {
    char* end = nullptr;
    const double d = std::strtod(p, &end);
    if (end != p) {
      out.push_back(d);
      p = end;
    } else {
      ++p;
    }
  }
  return out;
}

/// "0x0,300x0,300x300,0x300" -> min x, min y, max x, max y.
std::optional<Eigen::Vector4d> polygon_box(std::string_view v) {
  const auto n = numbers(v);
  if (n.size() < 6 || n.size() % 2 != 0) return std::nullopt;
  Eigen::Vector4d b(n[0], n[1], n[0], n[1]);
  for (std::size_t i = 0; i < n.size(); i += 2) {
    b[0] = std::min(b[0], n[i]);
    b[1] = std::min(b[1], n[i + 1]);
    b[2] = std::max(b[2], n[i]);
    b[3] = std::max(b[3], n[i + 1]);
  }
  if (!(b[2] > b[0] && b[3] > b[1])) return std::nullopt;
  return b;
}

/// The firmware flavour a slicer's flavour setting means (docs/printer-profile.md).
std::optional<std::string> map_flavour(const std::string& slicer, std::string_view text) {
  const std::string f = lower(text);
  if (f.find("klipper") != std::string::npos) return "klipper";
  if (f == "marlin2" || f == "marlin 2") return "marlin2";
  if (f.find("reprapfirmware") != std::string::npos || f == "reprap" || f == "rrf" ||
      f == "reprap (reprap)" || f.find("duet") != std::string::npos)
    return "rrf";
  if (f == "marlin" || f == "marlinlegacy" || f == "marlin (legacy)") {
    // PrusaSlicer and its descendants call Marlin 1 "marlin" (legacy); Cura, Simplify3D and
    // the others do not tell Marlin versions apart: current Marlin (2.x) is assumed.
    const bool slic3r_family = slicer == "PrusaSlicer" || slicer == "SuperSlicer" ||
                               slicer == "Slic3r" || slicer == "OrcaSlicer" ||
                               slicer == "BambuStudio" || slicer == "Creality Print";
    return slic3r_family ? "marlin1" : "marlin2";
  }
  if (f.find("marlin") != std::string::npos) return "marlin2";  // "RepRap (Marlin/Sprinter)", ...
  if (f == "griffin" || f == "ultigcode") return "marlin2";  // Ultimaker's Marlin-derived firmware
  return std::nullopt;
}

/// The firmware family: flavours of one family share a planner model and command set.
std::string family(const std::string& fw) {
  if (fw == "klipper") return "klipper";
  if (fw == "rrf") return "rrf";
  return "marlin";  // marlin2, marlin1, prusa, bambu
}

}  // namespace

namespace {
/// Looks up the slicer's settings for stated_printer().
struct StatedReader {
  const SlicerSettings& s;
  /// The entry of `key` when it is present and not empty.
  [[nodiscard]] const SlicerSettings::Entry* get(std::string_view key) const {
    const auto* e = s.find(key);
    return e != nullptr && !e->value.empty() ? e : nullptr;
  }
  /// The first of `keys` that holds a number (positive when asked) goes into `out`.
  void number(std::initializer_list<std::string_view> keys, bool positive,
              std::optional<StatedPrinter::Value<double>>& out) const {
    for (const auto key : keys) {
      const auto* e = get(key);
      if (e == nullptr) continue;
      const auto d = first_number(e->value);
      if (!d || (positive && !(*d > 0))) continue;
      out = StatedPrinter::Value<double>{*d, std::string(key)};
      return;
    }
  }
};

/// The printer's names (most specific first), its model and the firmware flavour.
void stated_names(const StatedReader& r, StatedPrinter& p) {
  // Names that may identify the printer, most specific first.
  for (const char* key : {"printer_model", "printer_settings_id", "TARGET_MACHINE.NAME",
                          "cura.machine_name", "printer_name", "Machine Name", "Printer Name",
                          "profileName", "inherits", "default_print_profile"}) {
    if (const auto* e = r.get(key)) {
      std::string v = e->value;
      if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
      if (v.empty()) continue;
      p.names.push_back(v);
      if (!p.model && std::string_view(key) != "inherits" &&
          std::string_view(key) != "default_print_profile" &&
          std::string_view(key) != "printer_settings_id")
        p.model = StatedPrinter::Value<std::string>{v, key};
    }
  }

  // Firmware flavour.
  for (const char* key :
       {"gcode_flavor", "FLAVOR", "cura.machine_gcode_flavor", "firmwareTypeOverride"}) {
    if (const auto* e = r.get(key)) {
      p.flavour_text = e->value;
      if (auto fw = map_flavour(r.s.slicer, e->value))
        p.firmware = StatedPrinter::Value<std::string>{*fw, key};
      break;
    }
  }
  // A Klipper extended command (a start macro, SET_PRESSURE_ADVANCE, ...) runs on Klipper
  // only: Marlin and RepRapFirmware reject it. Cura has no Klipper flavour, and older
  // PrusaSlicer profiles for Klipper machines say marlin2 or reprap.
  if (!r.s.klipper_command.empty() && (!p.firmware || p.firmware->value != "klipper")) {
    if (p.flavour_text.empty()) p.flavour_text = "Klipper";
    p.firmware = StatedPrinter::Value<std::string>{
        "klipper", r.s.klipper_command + " command" +
                       (r.s.klipper_command_line > 0
                            ? " (line " + std::to_string(r.s.klipper_command_line) + ")"
                            : std::string())};
  }
}

/// The bed's box in G-code coordinates, from the bed shape or each slicer's size and origin.
void stated_bed(const StatedReader& r, StatedPrinter& p) {
  for (const char* key : {"printable_area", "bed_shape"}) {
    if (const auto* e = r.get(key)) {
      if (auto b = polygon_box(e->value)) {
        p.bed = StatedPrinter::Value<Eigen::Vector4d>{*b, key};
        break;
      }
    }
  }
  auto sized_bed = [&](std::string_view wkey, std::string_view dkey, double cx, double cy) {
    const auto* w = r.get(wkey);
    const auto* d = r.get(dkey);
    if (w == nullptr || d == nullptr) return;
    const auto wv = first_number(w->value), dv = first_number(d->value);
    if (!wv || !dv || !(*wv > 0) || !(*dv > 0)) return;
    p.bed = StatedPrinter::Value<Eigen::Vector4d>{
        Eigen::Vector4d(cx - 0.5 * *wv, cy - 0.5 * *dv, cx + 0.5 * *wv, cy + 0.5 * *dv),
        std::string(wkey)};
  };
  if (!p.bed) {  // Cura: machine_width x machine_depth, origin at a corner or the centre
    const auto* centre = r.get("cura.machine_center_is_zero");
    const bool centred = centre != nullptr && lower(centre->value) == "true";
    const auto* w = r.get("cura.machine_width");
    const auto* d = r.get("cura.machine_depth");
    if (w != nullptr && d != nullptr) {
      const double wv = first_number(w->value).value_or(0), dv = first_number(d->value).value_or(0);
      sized_bed("cura.machine_width", "cura.machine_depth", centred ? 0 : 0.5 * wv,
                centred ? 0 : 0.5 * dv);
    }
  }
  if (!p.bed) {  // KISSlicer: size and the position of the bed centre (G-code origin at the centre)
    const double ox = r.get("bed_offset_x_mm") != nullptr
                          ? first_number(r.get("bed_offset_x_mm")->value).value_or(0)
                          : 0;
    const double oy = r.get("bed_offset_y_mm") != nullptr
                          ? first_number(r.get("bed_offset_y_mm")->value).value_or(0)
                          : 0;
    sized_bed("bed_size_x_mm", "bed_size_y_mm", ox, oy);
  }
  if (!p.bed) {  // Simplify3D: stroke (size) and the origin offset
    const double ox = r.get("originOffsetXoverride") != nullptr
                          ? first_number(r.get("originOffsetXoverride")->value).value_or(0)
                          : 0;
    const double oy = r.get("originOffsetYoverride") != nullptr
                          ? first_number(r.get("originOffsetYoverride")->value).value_or(0)
                          : 0;
    const auto* w = r.get("strokeXoverride");
    const auto* d = r.get("strokeYoverride");
    if (w != nullptr && d != nullptr) {
      const double wv = first_number(w->value).value_or(0), dv = first_number(d->value).value_or(0);
      sized_bed("strokeXoverride", "strokeYoverride", 0.5 * wv - ox, 0.5 * dv - oy);
    }
  }
  if (!p.bed) {  // ideaMaker: ";Dimension: X Y Z nozzle..." and ";Origin Center: 0|1"
    if (const auto* e = r.get("Dimension")) {
      const auto n = numbers(e->value);
      const auto* oc = r.get("Origin Center");
      const bool centred = oc != nullptr && first_number(oc->value).value_or(0) != 0;
      if (n.size() >= 2 && n[0] > 0 && n[1] > 0)
        p.bed = StatedPrinter::Value<Eigen::Vector4d>{
            centred ? Eigen::Vector4d(-0.5 * n[0], -0.5 * n[1], 0.5 * n[0], 0.5 * n[1])
                    : Eigen::Vector4d(0, 0, n[0], n[1]),
            "Dimension"};
      if (n.size() >= 3 && n[2] > 0) p.max_z_mm = StatedPrinter::Value<double>{n[2], "Dimension"};
      if (n.size() >= 4 && n[3] > 0)
        p.nozzle_diameter_mm = StatedPrinter::Value<double>{n[3], "Dimension"};
    }
  }
}

/// Build height, nozzle and filament, and the machine limits the slicer planned with.
void stated_limits(const StatedReader& r, StatedPrinter& p) {
  r.number({"max_print_height", "printable_height", "cura.machine_height", "bed_size_z_mm",
            "strokeZoverride"},
           true, p.max_z_mm);
  r.number({"nozzle_diameter", "cura.machine_nozzle_size", "EXTRUDER_TRAIN.0.NOZZLE.DIAMETER",
            "extruderDiameter"},
           true, p.nozzle_diameter_mm);
  r.number({"filament_diameter", "cura.material_diameter", "fiber_dia_mm", "filamentDiameters",
            "Filament Diameter #1"},
           true, p.filament_diameter_mm);

  static const char* kAxes[4] = {"x", "y", "z", "e"};
  for (int i = 0; i < 4; ++i) {
    const std::string a = kAxes[i];
    r.number(
        {"machine_max_feedrate_" + a, "machine_max_speed_" + a, "cura.machine_max_feedrate_" + a},
        true, p.max_feedrate_mm_s[i]);
    r.number({"machine_max_acceleration_" + a, "cura.machine_max_acceleration_" + a}, true,
             p.max_accel_mm_s2[i]);
    r.number({"machine_max_jerk_" + a, "cura.machine_max_jerk_" + std::string(i < 2 ? "xy" : a)},
             true, p.jerk_mm_s[i]);
  }
  // Strings built above outlive the calls? number() copies the key: the temporaries are fine.
  if (!p.max_accel_mm_s2[0] && r.get("xy_accel_mm_per_s_per_s") != nullptr) {  // KISSlicer
    r.number({"xy_accel_mm_per_s_per_s"}, true, p.max_accel_mm_s2[0]);
    p.max_accel_mm_s2[1] = p.max_accel_mm_s2[0];
  }
  r.number({"machine_max_acceleration_extruding", "cura.machine_acceleration"}, true,
           p.print_accel_mm_s2);
  r.number({"machine_max_acceleration_retracting"}, true, p.retract_accel_mm_s2);
  r.number({"machine_max_acceleration_travel", "cura.machine_acceleration"}, true,
           p.travel_accel_mm_s2);
  r.number({"machine_min_extruding_rate"}, false, p.min_feedrate_mm_s);
  r.number({"machine_min_travel_rate"}, false, p.min_travel_feedrate_mm_s);
}

/// First-layer temperatures (what a start macro without parameters heats to).
void stated_first_layer_temperatures(const StatedReader& r, StatedPrinter& p) {
  r.number({"first_layer_temperature", "nozzle_temperature_initial_layer",
            "cura.material_print_temperature_layer_0", "EXTRUDER_TRAIN.0.INITIAL_TEMPERATURE",
            "first_layer_C"},
           true, p.first_layer_hotend_c);
  std::string plate_key;
  if (const auto* plate = r.get("curr_bed_type")) {
    const std::string t = lower(plate->value);
    if (t.find("cool") != std::string::npos)
      plate_key = "cool_plate_temp_initial_layer";
    else if (t.find("engineering") != std::string::npos)
      plate_key = "eng_plate_temp_initial_layer";
    else if (t.find("textured") != std::string::npos)
      plate_key = "textured_plate_temp_initial_layer";
    else if (t.find("supertack") != std::string::npos)
      plate_key = "supertack_plate_temp_initial_layer";
    else
      plate_key = "hot_plate_temp_initial_layer";
  }
  if (!plate_key.empty()) r.number({plate_key}, true, p.first_layer_bed_c);
  if (!p.first_layer_bed_c)
    r.number({"first_layer_bed_temperature", "bed_temperature_initial_layer_single",
              "hot_plate_temp_initial_layer", "cura.material_bed_temperature_layer_0",
              "BUILD_PLATE.INITIAL_TEMPERATURE", "bed_C"},
             true, p.first_layer_bed_c);
}
}  // namespace

namespace {
/// Items of a list value ("0.4,0.4", "PLA;PETG", "\"a\";\"b\"") split at `sep`.
std::size_t list_items(std::string_view v, char sep) {
  if (v.empty()) return 0;
  return static_cast<std::size_t>(std::count(v.begin(), v.end(), sep)) + 1;
}

/// Tools and the times of a tool change (docs/gcode-coverage.md, "Multi-tool").
void stated_tools(const StatedReader& r, StatedPrinter& p) {
  // PrusaSlicer and the Orca family list one value per extruder (nozzle_diameter) or per
  // filament (filament_type, filament_colour; Bambu's AMS slots); Cura writes a header
  // block per extruder train and one "Filament used" value per extruder.
  std::size_t count = 0;
  std::string key;
  auto consider = [&](std::size_t n, const std::string& k) {
    if (n > count) count = n, key = k;
  };
  for (const char* k : {"nozzle_diameter", "extruder_colour"})
    if (const auto* e = r.get(k)) consider(list_items(e->value, k[0] == 'n' ? ',' : ';'), k);
  for (const char* k : {"filament_type", "filament_colour"})
    if (const auto* e = r.get(k)) consider(list_items(e->value, ';'), k);
  if (const auto* e = r.get("Filament used")) consider(list_items(e->value, ','), "Filament used");
  for (const auto& e : r.s.entries) {
    if (e.key.rfind("EXTRUDER_TRAIN.", 0) != 0) continue;
    const auto n = first_number(std::string_view(e.key).substr(15));
    if (n && *n >= 0 && *n < 64) consider(static_cast<std::size_t>(*n) + 1, "EXTRUDER_TRAIN");
  }
  if (const auto* e = r.get("cura.machine_extruder_count"))
    if (const auto n = first_number(e->value); n && *n >= 1 && *n < 64)
      consider(static_cast<std::size_t>(*n), e->key);
  if (count > 0) p.tool_count = StatedPrinter::Value<int>{static_cast<int>(count), key};

  for (const char* k : {"single_extruder_multi_material", "cura.machine_extruders_share_nozzle"})
    if (const auto* e = r.get(k)) {
      const std::string v = lower(e->value);
      p.shared_nozzle = StatedPrinter::Value<bool>{v == "1" || v == "true", k};
      break;
    }
  // Bambu / Orca: one value for the machine; PrusaSlicer: one per filament.
  static constexpr std::pair<const char*, const char*> kTimes[] = {
      {"machine_load_filament_time", "machine_unload_filament_time"},
      {"filament_load_time", "filament_unload_time"}};
  for (const auto& [load, unload] : kTimes) {
    const auto* l = r.get(load);
    const auto* u = r.get(unload);
    if (l == nullptr && u == nullptr) continue;
    if (l != nullptr) p.filament_load_s = numbers(l->value);
    if (u != nullptr) p.filament_unload_s = numbers(u->value);
    break;
  }
  r.number({"machine_tool_change_time"}, true, p.tool_change_s);
}
}  // namespace

StatedPrinter stated_printer(const SlicerSettings& s) {
  StatedPrinter p;
  const StatedReader r{s};
  stated_names(r, p);
  stated_bed(r, p);
  stated_limits(r, p);
  stated_first_layer_temperatures(r, p);
  stated_tools(r, p);
  return p;
}

namespace {

/// The generic printer for a firmware flavour, every value marked "default".
PrinterProfile generic_printer(const std::string& firmware) {
  PrinterProfile p;
  if (firmware == "klipper") {
    p = ender3_klipper();
    p.name = "generic Klipper printer";
  } else if (firmware == "marlin1") {
    p = ender3_marlin1();
    p.name = "generic Marlin 1 printer";
  } else {
    p = ender3_marlin2();
    p.name = firmware == "rrf" ? "generic RepRapFirmware printer" : "generic Marlin 2 printer";
    p.firmware = firmware == "rrf" ? "rrf" : "marlin2";
  }
  p.origin = {};
  for (const auto& key : printer_profile_keys()) p.origin.set(key, "default", "");
  return p;
}

std::string size_text(double w, double d, double h) {
  return format_number(w) + " x " + format_number(d) + " x " + format_number(h) + " mm";
}

void apply_stated(const StatedPrinter& st, bool from_library, PrinterProfile& p) {
  auto set = [&](const std::string& key, const std::string& setting) {
    p.origin.set(key, "file", setting);
  };
  if (st.bed) {
    const auto& b = st.bed->value;
    p.bed_min_x_mm = b[0];
    p.bed_min_y_mm = b[1];
    p.bed_max_x_mm = b[2];
    p.bed_max_y_mm = b[3];
    for (const char* k : {"bed_min_x_mm", "bed_min_y_mm", "bed_max_x_mm", "bed_max_y_mm"})
      set(k, st.bed->key);
    // The carriage reaches at least the bed; a library printer keeps its wider travel.
    if (!from_library) {
      p.travel_min_x_mm = b[0];
      p.travel_min_y_mm = b[1];
      p.travel_max_x_mm = b[2];
      p.travel_max_y_mm = b[3];
      for (const char* k :
           {"travel_min_x_mm", "travel_min_y_mm", "travel_max_x_mm", "travel_max_y_mm"})
        set(k, st.bed->key);
    } else {
      auto widen = [&](double& v, double to, bool lower_end, const char* key) {
        if (lower_end ? to < v : to > v) {
          v = to;
          set(key, st.bed->key);
        }
      };
      widen(p.travel_min_x_mm, b[0], true, "travel_min_x_mm");
      widen(p.travel_min_y_mm, b[1], true, "travel_min_y_mm");
      widen(p.travel_max_x_mm, b[2], false, "travel_max_x_mm");
      widen(p.travel_max_y_mm, b[3], false, "travel_max_y_mm");
    }
  }
  if (st.max_z_mm) {
    p.max_z_mm = st.max_z_mm->value;
    set("max_z_mm", st.max_z_mm->key);
    if (!from_library || p.travel_max_z_mm < p.max_z_mm) {
      p.travel_max_z_mm = std::max(p.max_z_mm, from_library ? p.travel_max_z_mm : 0.0);
      set("travel_max_z_mm", st.max_z_mm->key);
    }
  }
  if (st.nozzle_diameter_mm) {
    p.nozzle_diameter_mm = st.nozzle_diameter_mm->value;
    set("nozzle_diameter_mm", st.nozzle_diameter_mm->key);
  }
  if (st.filament_diameter_mm) {
    p.filament_diameter_mm = st.filament_diameter_mm->value;
    set("filament_diameter_mm", st.filament_diameter_mm->key);
  }
  // Per-axis values: the source lists the setting of each axis the file states.
  auto vec = [&](const std::optional<StatedPrinter::Value<double>>(&v)[4], Eigen::Vector4d& member,
                 const char* key) {
    std::string keys;
    for (int i = 0; i < 4; ++i) {
      if (!v[i]) continue;
      member[i] = v[i]->value;
      keys += (keys.empty() ? "" : ", ") + v[i]->key;
    }
    if (!keys.empty()) set(key, keys);
  };
  vec(st.max_feedrate_mm_s, p.max_feedrate_mm_s, "max_feedrate_mm_s");
  vec(st.max_accel_mm_s2, p.max_accel_mm_s2, "max_accel_mm_s2");
  vec(st.jerk_mm_s, p.jerk_mm_s, "jerk_mm_s");
  auto scalar = [&](const std::optional<StatedPrinter::Value<double>>& v, double& member,
                    const char* key) {
    if (!v) return;
    member = v->value;
    set(key, v->key);
  };
  scalar(st.print_accel_mm_s2, p.print_accel_mm_s2, "print_accel_mm_s2");
  scalar(st.retract_accel_mm_s2, p.retract_accel_mm_s2, "retract_accel_mm_s2");
  scalar(st.travel_accel_mm_s2, p.travel_accel_mm_s2, "travel_accel_mm_s2");
  scalar(st.min_feedrate_mm_s, p.min_feedrate_mm_s, "min_feedrate_mm_s");
  scalar(st.min_travel_feedrate_mm_s, p.min_travel_feedrate_mm_s, "min_travel_feedrate_mm_s");
}

std::string describe_settings(const SlicerSettings& s) {
  if (s.slicer.empty()) return "no slicer header";
  return s.slicer + (s.slicer_version.empty() ? "" : " " + s.slicer_version);
}

}  // namespace

Result<ResolvedPrinter> resolve_printer(std::string_view spec, SlicerSettings settings) {
  ResolvedPrinter r;
  r.settings = std::move(settings);
  r.stated = stated_printer(r.settings);
  const StatedPrinter& st = r.stated;
  const bool automatic = spec.empty() || spec == "auto";
  PrinterOrigin& o = r.profile.origin;

  if (!automatic) {
    auto p = load_printer_profile(spec);
    if (!p) return p.error();
    r.profile = std::move(*p);
    o.how = "explicit";
    o.summary = r.profile.name + " (--printer " + std::string(spec) + ")";
    // A file made for a bigger machine: its moves will be judged against the smaller one.
    if (st.bed) {
      const auto& b = st.bed->value;
      const double w = b[2] - b[0], d = b[3] - b[1];
      const double pw = r.profile.bed_max_x_mm - r.profile.bed_min_x_mm;
      const double pd = r.profile.bed_max_y_mm - r.profile.bed_min_y_mm;
      const double h = st.max_z_mm ? st.max_z_mm->value : 0;
      if (w > pw + 0.5 || d > pd + 0.5 || h > r.profile.max_z_mm + 0.5) {
        Finding f;
        f.severity = Severity::warning;
        f.code = "printer_mismatch";
        f.message =
            "the file was sliced for a " + size_text(w, d, st.max_z_mm ? h : 0).substr(0) +
            " build volume (" + st.bed->key + (st.max_z_mm ? ", " + st.max_z_mm->key : "") +
            "), larger than " + r.profile.name + " (" + size_text(pw, pd, r.profile.max_z_mm) +
            "): moves beyond this printer's travel are reported out of bounds and clamped, so the "
            "simulated "
            "part differs from the print; use --printer auto to simulate the file's own printer";
        o.findings.push_back(std::move(f));
      }
    }
    if (st.firmware && family(st.firmware->value) != family(r.profile.firmware)) {
      Finding f;
      f.severity = Severity::warning;
      f.code = "printer_mismatch";
      f.message = "the file was written for " + st.flavour_text + " firmware (" + st.firmware->key +
                  ") but " + r.profile.name + " runs " + r.profile.firmware +
                  ": flavour-specific commands and the timing follow the given printer";
      o.findings.push_back(std::move(f));
    }
  } else {
    const LibraryPrinter* lib = nullptr;
    std::string matched_name;
    for (const auto& name : st.names) {
      if ((lib = match_library_printer(name)) != nullptr) {
        matched_name = name;
        break;
      }
    }
    if (lib != nullptr) {
      r.profile = lib->profile;
      o = lib->origin;
      if (st.firmware && family(st.firmware->value) != family(r.profile.firmware)) {
        // The owner runs other firmware on this machine (e.g. Klipper on an Ender-3 V2).
        const PrinterProfile generic = generic_printer(st.firmware->value);
        r.profile.firmware = generic.firmware;
        r.profile.junction = generic.junction;
        r.profile.min_segment_time_s = generic.min_segment_time_s;
        o.set("firmware", "file", st.firmware->key);
      }
    } else {
      r.profile = generic_printer(st.firmware ? st.firmware->value : "marlin2");
      if (st.firmware) r.profile.origin.set("firmware", "file", st.firmware->key);
      if (st.model) r.profile.name = st.model->value + " (not in the library)";
    }
    o.how = "auto";
    apply_stated(st, lib != nullptr, r.profile);
    if (st.model && lib != nullptr) {
      r.profile.model = st.model->value;
      o.set("model", "file", st.model->key);
    }
    std::size_t from_file = 0;
    for (const auto& v : o.values) from_file += v.source == "file" ? 1 : 0;
    const std::string slicer = describe_settings(r.settings);
    if (lib != nullptr) {
      o.summary = r.profile.name + " (library " + lib->id + ", matched \"" + matched_name + "\"; " +
                  std::to_string(from_file) + " values from the " + slicer + " settings)";
    } else if (st.bed) {
      o.summary = r.profile.name + " (" + std::to_string(from_file) + " values from the " + slicer +
                  " settings on a " + r.profile.firmware + " default)";
      Finding f;
      f.severity = Severity::info;
      f.code = "printer_not_in_library";
      f.message = (st.model ? "\"" + st.model->value + "\" is not in the printer library"
                            : std::string("the file names no printer")) +
                  ": the bed (" +
                  size_text(r.profile.bed_max_x_mm - r.profile.bed_min_x_mm,
                            r.profile.bed_max_y_mm - r.profile.bed_min_y_mm, r.profile.max_z_mm) +
                  ") and the limits the file states are used; homing, steps, heating rates and "
                  "unstated limits are "
                  "generic " +
                  r.profile.firmware +
                  " defaults, so times are estimates (pass --printer to be exact)";
      o.findings.push_back(std::move(f));
    } else {
      o.summary = r.profile.name + " (nothing in the file identifies the printer: generic default)";
      Finding f;
      f.severity = Severity::warning;
      f.code = "printer_unknown";
      f.message = "nothing in the file (" + slicer +
                  ") states the printer or its bed: it is judged against the " + r.profile.name +
                  " (" +
                  size_text(r.profile.bed_max_x_mm - r.profile.bed_min_x_mm,
                            r.profile.bed_max_y_mm - r.profile.bed_min_y_mm, r.profile.max_z_mm) +
                  ", " + r.profile.firmware +
                  "): out-of-bounds findings and the print time hold for that machine only; pass "
                  "--printer NAME "
                  "(printtwin printers) or a profile";
      o.findings.push_back(std::move(f));
    }
  }
  o.slicer = describe_settings(r.settings);
  if (r.settings.slicer.empty() && r.settings.empty()) o.slicer.clear();
  if (st.first_layer_hotend_c) o.macro_hotend_c = st.first_layer_hotend_c->value;
  if (st.first_layer_bed_c) o.macro_bed_c = st.first_layer_bed_c->value;
  if (st.tool_count) o.tool_count = st.tool_count->value;
  if (st.shared_nozzle) o.shared_nozzle = st.shared_nozzle->value;
  o.filament_load_s = st.filament_load_s;
  o.filament_unload_s = st.filament_unload_s;
  if (st.tool_change_s) o.tool_change_s = st.tool_change_s->value;
  return r;
}

Result<ResolvedPrinter> resolve_printer(std::string_view spec,
                                        const std::filesystem::path& gcode_path) {
  SlicerSettings settings;
  if (!gcode_path.empty()) {
    // An unreadable file is left to the G-code reader to report (with its own context,
    // after a bad mesh in verify); its printer is then simply not identified.
    if (auto s = read_slicer_settings(gcode_path)) settings = std::move(*s);
  }
  if (gcode_path.empty() && (spec.empty() || spec == "auto")) {
    ResolvedPrinter r;
    auto p = load_printer_profile("auto");
    if (!p) return p.error();
    r.profile = std::move(*p);
    return r;
  }
  return resolve_printer(spec, std::move(settings));
}

void apply_printer_to_options(const ResolvedPrinter& printer, InterpreterOptions& options) {
  if (std::isnan(options.macro_hotend_c))
    options.macro_hotend_c = printer.profile.origin.macro_hotend_c;
  if (std::isnan(options.macro_bed_c)) options.macro_bed_c = printer.profile.origin.macro_bed_c;
  apply_tools_to_options(printer.profile.origin, options);
}

void apply_tools_to_options(const PrinterOrigin& origin, InterpreterOptions& options) {
  if (options.tool_count > 0) return;  // set by the caller
  options.tool_count = origin.tool_count;
  options.shared_nozzle = origin.shared_nozzle;
  options.filament_load_s = origin.filament_load_s;
  options.filament_unload_s = origin.filament_unload_s;
  options.tool_change_s = origin.tool_change_s;
}

}  // namespace printtwin
