// The firmware's G-code interpreter: Marlin 2.1's modal state turned into Moves, with the
// commands of each firmware flavour, start/end macros and the slicers' markers.
// References for behaviour (not code): Marlin gcode/motion/G0_G1.cpp, G2_G3.cpp (plan_arc),
// G28.cpp + module/motion.cpp (homing, soft endstops), gcode/config/M200-M205.cpp,
// gcode/temp/M104_M109.cpp, module/planner.cpp (PREVENT_COLD_EXTRUSION / LENGTHY_EXTRUDE);
// Klipper klippy/toolhead.py (SET_VELOCITY_LIMIT, M204), klippy/extras/firmware_retraction.py;
// Prusa-Firmware-Buddy (M862.x); RepRapFirmware's G-code dictionary (M566, M203, G10, M0).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <string>

#include "printtwin/gcode.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kInch_mm = 25.4;
/// Marlin EXTRUDE_MAXLENGTH (PREVENT_LENGTHY_EXTRUDE): longer E moves are dropped.
constexpr double kExtrudeMaxLength_mm = 200.0;
/// Marlin's power-on feedrate (1500 mm/min).
constexpr double kDefaultFeedrate_mm_s = 25.0;
constexpr double kLayerZTolerance_mm = 1e-4;
/// A layer marker's Z is believed when it lies this close to the layer's first extrusion.
constexpr double kMarkerZTolerance_mm = 1.0;

bool starts_with(std::string_view s, std::string_view p) { return s.substr(0, p.size()) == p; }

/// Klipper heater or sensor name -> extruder index: "extruder" 0, "extruder1" 1, ...;
/// -1 for any other name (heater_bed, a fan).
long klipper_extruder_index(std::string_view name) {
  if (!starts_with(name, "extruder")) return -1;
  name.remove_prefix(8);
  long n = 0;
  std::size_t digits = 0;
  while (digits < name.size() && name[digits] >= '0' && name[digits] <= '9' && digits < 3)
    n = n * 10 + (name[digits++] - '0');
  const bool ends = digits == name.size() || name[digits] == ' ' || name[digits] == '\t';
  return ends ? n : -1;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

bool parse_double(std::string_view s, double& v) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && std::isfinite(v);
}

/// The slicer's filament per tool that needs more than a list: Bambu's "filament: 1,3" (which
/// filaments the lengths belong to) and Cura's per-train volumes. True when `c` was one.
bool stated_tool_figures(std::string_view c, std::vector<double>& per_tool, double& total_mm,
                         double filament_area_mm2) {
  constexpr int kMaxTools = 16;  // GcodeInterpreter::kMaxTools
  if (starts_with(c, "filament: ")) {
    if (per_tool.empty()) return true;
    // Bambu Studio: the (1-based) filaments the lengths above belong to, "1,2,3,10".
    std::vector<double> ids;
    for (std::string_view list = c.substr(10); !list.empty();) {
      const auto comma = list.find(',');
      double id = 0;
      if (!parse_double(list.substr(0, comma), id) || id < 1 || id > kMaxTools) return true;
      ids.push_back(id);
      if (comma == std::string_view::npos) break;
      list.remove_prefix(comma + 1);
    }
    if (ids.size() != per_tool.size()) return true;
    std::vector<double> by_tool(
        static_cast<std::size_t>(*std::max_element(ids.begin(), ids.end())));
    for (std::size_t i = 0; i < ids.size(); ++i)
      by_tool[static_cast<std::size_t>(ids[i]) - 1] = per_tool[i];
    per_tool = std::move(by_tool);
    return true;
  }
  if (starts_with(c, "EXTRUDER_TRAIN.") &&
      c.find(".MATERIAL.VOLUME_USED:") != std::string_view::npos) {
    // Cura (Griffin header): mm3 of material per extruder train.
    double tool = 0, mm3 = 0;
    const std::string_view rest = c.substr(15);
    if (parse_double(rest.substr(0, rest.find('.')), tool) && tool >= 0 && tool < kMaxTools &&
        parse_double(c.substr(c.find("VOLUME_USED:") + 12), mm3) && mm3 >= 0 &&
        filament_area_mm2 > 0) {
      auto& list = per_tool;
      if (list.size() <= static_cast<std::size_t>(tool))
        list.resize(static_cast<std::size_t>(tool) + 1, 0.0);
      list[static_cast<std::size_t>(tool)] = mm3 / filament_area_mm2;
      double total = 0;
      for (double x : list) total += x;
      if (total > 0) total_mm = total;
    }
    return true;
  }
  return false;
}

/// "25m 53s", "1h 2m 3s", "1d 2h 3m 4s" -> seconds.
double parse_duration(std::string_view s) {
  double total = 0;
  double number = 0;
  bool have = false;
  for (char c : s) {
    if (c >= '0' && c <= '9') {
      number = number * 10 + (c - '0');
      have = true;
    } else if (have && (c == 'd' || c == 'h' || c == 'm' || c == 's')) {
      total += number * (c == 'd' ? 86400 : c == 'h' ? 3600 : c == 'm' ? 60 : 1);
      number = 0;
      have = false;
    }
  }
  return total;
}

std::string excerpt(std::string_view text) {
  std::string s;
  for (char c : text.substr(0, 80)) s.push_back((c >= 32 && c < 127) ? c : '?');
  if (text.size() > 80) s += "...";
  return s;
}

std::string command_name(const GcodeCommand& c) {
  if (c.letter == 0) return std::string(c.word);
  std::string s(1, c.letter);
  s += std::to_string(c.code);
  if (c.subcode >= 0) s += "." + std::to_string(c.subcode);
  return s;
}
}  // namespace

GcodeInterpreter::GcodeInterpreter(const PrinterProfile& profile, const InterpreterOptions& options)
    : profile_(profile),
      options_(options),
      limits_(motion_limits_from_profile(profile)),
      slicer_estimate_s_(std::numeric_limits<double>::quiet_NaN()),
      slicer_filament_mm_(std::numeric_limits<double>::quiet_NaN()),
      slicer_part_estimate_s_(std::numeric_limits<double>::quiet_NaN()) {
  min_extrude_temp_c_ = profile.min_extrude_temp_c;
  const std::string& fw = profile.firmware;
  flavour_ = fw == "klipper"   ? Flavour::klipper
             : fw == "prusa"   ? Flavour::prusa
             : fw == "rrf"     ? Flavour::rrf
             : fw == "bambu"   ? Flavour::bambu
             : fw == "marlin1" ? Flavour::marlin1
                               : Flavour::marlin2;
  if (profile.firmware_retraction) {
    fw_length_mm_ = profile.fw_retract_length_mm;
    fw_speed_mm_s_ = profile.fw_retract_speed_mm_s;
    fw_recover_speed_mm_s_ = profile.fw_recover_speed_mm_s;
    fw_zraise_mm_ = profile.fw_retract_zraise_mm;
  } else {
    // Klipper's [firmware_retraction] defaults (retract_length 0, speeds 20 / 10 mm/s).
    fw_speed_mm_s_ = 20;
    fw_recover_speed_mm_s_ = 10;
  }
  Vec3 power_on(profile.bed_center_x_mm(), profile.bed_center_y_mm(), 10.0);
  for (int i = 0; i < 3; ++i)
    if (!std::isnan(options.power_on_position_mm[i])) power_on[i] = options.power_on_position_mm[i];
  // Marlin boots believing it is at 0,0,0: the machine position differs by an offset.
  offset_mm_ = power_on;
  logical_mm_ = Vec3::Zero();
  feedrate_mm_s_ = kDefaultFeedrate_mm_s;
  const double hot =
      std::isnan(options.power_on_hotend_c) ? profile.ambient_temp_c : options.power_on_hotend_c;
  const double bed =
      std::isnan(options.power_on_bed_c) ? profile.ambient_temp_c : options.power_on_bed_c;
  for (auto& h : hotends_) h.target_c = h.at_set_c = hot;
  rrf_active_c_.fill(std::numeric_limits<double>::quiet_NaN());
  bed_target_c_ = bed_c_at_set_ = bed;
}

Vec3 GcodeInterpreter::position_mm() const { return logical_mm_ + offset_mm_; }

void GcodeInterpreter::add_finding(Finding f) {
  int& n = finding_counts_[f.code];
  ++n;
  if (n <= options_.max_findings_per_code) {
    findings_.push_back(std::move(f));
    return;
  }
  // Beyond the cap: count it in the last finding of that code.
  for (auto it = findings_.rbegin(); it != findings_.rend(); ++it)
    if (it->code == f.code) {
      ++it->count;
      return;
    }
}

Status GcodeInterpreter::warn(long line, std::string_view text, const std::string& message,
                              std::string code) {
  if (options_.strict)
    return bad_input(message + " in \"" + excerpt(text) + "\" (--strict)", {}, line);
  Finding f;
  f.severity = Severity::warning;
  f.code = std::move(code);
  f.message = message + " in \"" + excerpt(text) + "\"";
  f.line = line;
  f.position_mm = position_mm();
  if (layer_ >= 0) f.layer = layer_;
  add_finding(std::move(f));
  return Ok{};
}

Status GcodeInterpreter::warn_input(const Error& problem) {
  if (options_.strict) {
    Error e = problem;
    e.message += " (--strict)";
    return e;
  }
  Finding f;
  f.severity = Severity::warning;
  f.code = "bad_line";
  f.message = problem.message + "; line skipped";
  f.line = problem.line;
  f.position_mm = position_mm();
  if (layer_ >= 0) f.layer = layer_;
  add_finding(std::move(f));
  return Ok{};
}

namespace {
/// The version of a slicer tag that starts with `name` ("Cura_SteamEngine 5.9.0" -> 509,
/// "PrusaSlicer 2.8.1" -> 208), 0 for another slicer.
int slicer_version(std::string_view slicer, std::string_view name) {
  if (!starts_with(slicer, name)) return 0;
  const auto sp = slicer.find(' ');
  if (sp == std::string_view::npos) return 0;
  int major = 0, minor = 0;
  const char* end = slicer.data() + slicer.size();
  const auto r = std::from_chars(slicer.data() + sp + 1, end, major);
  if (r.ptr != end && *r.ptr == '.') std::from_chars(r.ptr + 1, end, minor);
  return major * 100 + std::min(minor, 99);
}
}  // namespace

Status GcodeInterpreter::finish(bool ended_mid_line, long last_line) {
  if (markers_expected_ && !marker_seen_ && filament_mm_ > 0) {
    // A marking slicer's file without a single layer marker (stripped or post-processed):
    // its extrusions were waiting for the first layer, so no layer is counted. Say so.
    Finding f;
    f.severity = Severity::warning;
    f.code = "no_layer_markers";
    f.message = slicer_ +
                " marks its layers but the file has no layer marker: the twin counts no "
                "layers (per-layer figures are empty; time and filament are complete)";
    f.line = last_line;
    add_finding(std::move(f));
  }
  // A cut file (an upload or a copy that stopped): the printer would stop there, mid-part.
  // Two signs: fewer layers than the slicer's header announces (Orca family, Cura; one layer
  // of slack, as Cura counts one more than it marks on some files), an error; or the closing
  // lines a slicer writes after the end code are missing, a warning.
  const bool slic3r_family = starts_with(slicer_, "PrusaSlicer") ||
                             starts_with(slicer_, "SuperSlicer") || starts_with(slicer_, "Slic3r");
  const char* missing = nullptr;
  if (executable_block_open_ && !executable_block_closed_)
    missing = "\"; EXECUTABLE_BLOCK_END\"";
  else if (!executable_block_open_ && slicer_version(slicer_, "Cura") >= 200 &&
           slicer_version(slicer_, "Cura") < 1500 && !cura_end_seen_)  // Cura 2 to 5, not 15.04
    missing = "\";End of Gcode\"";
  else if (!executable_block_open_ && slic3r_family && !filament_used_seen_)
    missing = "\"; filament used\"";
  else if (!executable_block_open_ && slicer_version(slicer_, "PrusaSlicer") >= 204 &&
           !config_end_seen_)  // its last line since 2.4 (2.8 states its figures at the top)
    missing = "\"; prusaslicer_config = end\"";
  // Markers, not layers, are counted: a post-processed file may repeat a height (several
  // colour passes at one Z), and sequential printing runs the heights once per object.
  const long layers = markers_;
  const bool short_of_layers = slicer_layer_count_ > 0 && layers < slicer_layer_count_ - 1;
  if (short_of_layers || missing != nullptr) {
    Finding f;
    f.severity = short_of_layers ? Severity::error : Severity::warning;
    f.code = "truncated_file";
    f.message = short_of_layers
                    ? "the slicer's header announces " + std::to_string(slicer_layer_count_) +
                          " layers but the file ends after " + std::to_string(layers) +
                          " layer markers" + " (line " + std::to_string(last_line) +
                          (ended_mid_line ? ", without a newline" : "") + ")"
                    : "the file ends at line " + std::to_string(last_line);
    if (missing != nullptr)
      f.message += std::string(short_of_layers ? " and" : "") + " without the " + missing +
                   " line that " + slicer_ + " writes after the end code";
    f.message += ": it was cut, and a printer would stop there";
    f.line = last_line;
    add_finding(std::move(f));
  }
  if (ended_mid_line) {
    // The last line had no newline: a streamed file may have been cut. Marlin would
    // wait for the rest of the line; we execute it but say so.
    Finding f;
    f.severity = Severity::info;
    f.code = "no_final_newline";
    f.message = "the file ends without a newline (last line " + std::to_string(last_line) +
                " may have been cut)";
    f.line = last_line;
    add_finding(std::move(f));
  }
  return Ok{};
}

void GcodeInterpreter::set_limits(const MotionLimits& limits, InterpreterOutput& out) {
  limits_ = limits;
  out.limits(limits_);
}

bool GcodeInterpreter::e_relative() const {
  // Marlin 2 and the firmware built on it (Prusa's Buddy, Bambu's): G90/G91 set E with the
  // axes, M82/M83 after them. Marlin 1 and Klipper: E is relative under G91 or after M83, and
  // G90 leaves M83 alone (Klipper's gcode_move: absolute_coord and absolute_extrude apart).
  // RepRapFirmware's G90/G91 move only the axes, but the files that name its flavour include
  // Slic3r's and Cura's "RepRap" ones, written for Marlin machines whose end code retracts
  // under G91: they are read as Marlin 2 reads them.
  if (flavour_ == Flavour::marlin1 || flavour_ == Flavour::klipper)
    return relative_xyz_ || e_mode_relative_;
  return relative_e_;
}

double GcodeInterpreter::hotend_temp_now(int heater) const {
  const Heater& h = hotends_[static_cast<std::size_t>(heater < 0 ? active_heater() : heater)];
  const double dt = nominal_clock_s_ - h.set_clock_s;
  const double rate = profile_.hotend_heat_rate_c_s;
  if (h.target_c >= h.at_set_c) return std::min(h.target_c, h.at_set_c + rate * dt);
  return std::max(h.target_c, h.at_set_c - rate * dt);
}

void GcodeInterpreter::heat_wait(bool hotend, double target_c, bool wait_cooling, long line,
                                 InterpreterOutput& out, int heater) {
  const double rate = hotend ? profile_.hotend_heat_rate_c_s : profile_.bed_heat_rate_c_s;
  target_c = std::max(target_c, profile_.ambient_temp_c);
  Heater& h = hotends_[static_cast<std::size_t>(heater < 0 ? active_heater() : heater)];
  double& target = hotend ? h.target_c : bed_target_c_;
  double& at_set = hotend ? h.at_set_c : bed_c_at_set_;
  double& set_clock = hotend ? h.set_clock_s : bed_set_clock_s_;
  // Temperature now (linear ramp since the last set).
  const double dt = nominal_clock_s_ - set_clock;
  double now = target >= at_set ? std::min(target, at_set + rate * dt)
                                : std::max(target, at_set - rate * dt);
  target = target_c;
  double wait_s = 0;
  if (target_c > now)
    wait_s = (target_c - now) / rate;
  else if (wait_cooling && target_c < now)
    wait_s = (now - target_c) / rate;
  out.synchronize();
  if (wait_s > 0) out.wait(wait_s, true, line);
  nominal_clock_s_ += wait_s;
  at_set = (wait_s > 0) ? target_c : now;
  set_clock = nominal_clock_s_;
}

void GcodeInterpreter::layer_marker(double z_mm) {
  // A slicer's layer change. Its layer starts at the next extrusion that is not start/end
  // code; a marker at the Z of the current layer (one per object, KISSlicer) adds none.
  // From the first marker on, only markers start layers (layers made by Z before it, in a
  // file whose header named no marking slicer, stay).
  marker_seen_ = true;
  ++markers_;
  if (!std::isnan(z_mm) && layer_ >= 0 && !layer_pending_ &&
      std::fabs(layer_z_[static_cast<std::size_t>(layer_)] - z_mm) <= kLayerZTolerance_mm)
    return;
  layer_pending_ = true;
  pending_layer_z_ = z_mm;
}

void GcodeInterpreter::stated_figures(std::string_view c) {
  if (stated_tool_figures(c, slicer_tool_filament_mm_, slicer_filament_mm_,
                          profile_.filament_area_mm2()))
    return;
  // The slicer's own time and filament, in each slicer's words (docs/gcode-coverage.md).
  auto set_time = [&](double s, int rank) {
    if (s > 0 && rank >= slicer_estimate_rank_) {
      slicer_estimate_s_ = s;
      slicer_estimate_rank_ = rank;
    }
  };
  auto after = [&](std::string_view key) -> std::string_view {
    const auto pos = c.find(key);
    return pos == std::string_view::npos ? std::string_view{} : trim(c.substr(pos + key.size()));
  };
  // "252.22, 0.00" (one value per extruder): the sum; a list of several values is kept as
  // the slicer's filament per tool.
  auto sum_list = [this](std::string_view v, double scale = 1.0) {
    double total = 0;
    bool any = false;
    std::vector<double> items;
    while (!v.empty()) {
      const auto comma = v.find(',');
      double x = 0;
      std::string_view item = trim(v.substr(0, comma));
      std::size_t n = 0;
      while (n < item.size() && ((item[n] >= '0' && item[n] <= '9') || item[n] == '.')) ++n;
      if (parse_double(item.substr(0, n), x)) total += x, any = true, items.push_back(x * scale);
      if (comma == std::string_view::npos) break;
      v.remove_prefix(comma + 1);
    }
    if (items.size() > 1 && total > 0) slicer_tool_filament_mm_ = std::move(items);
    return any ? total : std::numeric_limits<double>::quiet_NaN();
  };
  double v = 0;
  if (starts_with(c, "model printing time:")) {
    // Orca family: "model printing time: 4m 48s; total estimated time: 11m 36s". The model's
    // time leaves out the start sequence (and the fixed time the slicer adds for its bed
    // levelling); the total follows below.
    std::string_view model = c.substr(20);
    model = model.substr(0, model.find(';'));
    if (const double s = parse_duration(model); s > 0) slicer_part_estimate_s_ = s;
  }
  if (starts_with(c, "total layer number:")) {  // Orca family's header
    if (parse_double(c.substr(19), v) && v >= 1 && v < 1e7)
      slicer_layer_count_ = static_cast<long>(v);
  } else if (starts_with(c, "estimated printing time (normal mode) = ")) {
    set_time(parse_duration(c.substr(40)), 3);  // PrusaSlicer, Orca family
  } else if (c.find("total estimated time:") != std::string_view::npos) {
    set_time(parse_duration(after("total estimated time:")), 2);  // Orca, Creality Print
  } else if (starts_with(c, "TIME:") && parse_double(c.substr(5), v)) {
    set_time(v, 2);  // Cura (s)
    estimate_from_time_tag_ = true;
  } else if (starts_with(c, "Print Time:")) {  // ideaMaker (s, or "1h 2m 3s")
    set_time(parse_double(c.substr(11), v) ? v : parse_duration(c.substr(11)), 2);
  } else if (starts_with(c, "Estimated Build Time:")) {
    std::string_view m = trim(c.substr(21));  // KISSlicer (minutes)
    if (parse_double(m.substr(0, m.find(' ')), v)) set_time(v * 60.0, 2);
  } else if (starts_with(c, "Build time:")) {
    // Simplify3D: "1 hours 23 minutes" (the words' first letters as units).
    double total = 0, number = 0;
    bool have = false;
    for (char ch : c.substr(11)) {
      if (ch >= '0' && ch <= '9')
        number = number * 10 + (ch - '0'), have = true;
      else if (have && (ch == 'h' || ch == 'm' || ch == 's' || ch == 'd')) {
        total += number * (ch == 'd' ? 86400 : ch == 'h' ? 3600 : ch == 'm' ? 60 : 1);
        number = 0, have = false;
      }
    }
    set_time(total, 2);
  } else if (starts_with(c, "filament used [mm]")) {  // PrusaSlicer, Orca family
    const std::string_view rest = trim(c.substr(18));
    if (!rest.empty() && (rest.front() == '=' || rest.front() == ':'))
      if (const double f = sum_list(rest.substr(1)); f > 0) slicer_filament_mm_ = f;
  } else if (starts_with(c, "total filament length [mm]")) {  // Bambu Studio
    const std::string_view rest = trim(c.substr(26));
    if (!rest.empty() && (rest.front() == '=' || rest.front() == ':'))
      if (const double f = sum_list(rest.substr(1)); f > 0) slicer_filament_mm_ = f;
  } else if (starts_with(c, "Filament used:")) {  // Cura (metres)
    const double f = sum_list(c.substr(14), 1000.0);
    if (f > 0) {
      slicer_filament_mm_ = f * 1000.0;
    } else if (f == 0) {
      // CuraEngine run without its front end leaves the header's placeholders
      // (";TIME:6666", ";Filament used: 0m"): neither figure is the slicer's.
      if (estimate_from_time_tag_) {
        slicer_estimate_s_ = std::numeric_limits<double>::quiet_NaN();
        slicer_estimate_rank_ = 0;
      }
      note("slicer_header_placeholders",
           "the slicer's header holds placeholders (\"Filament used: 0m\"): its time and filament "
           "figures are not used",
           last_line_);
    }
  } else if (starts_with(c, "Material#1 Used:")) {  // ideaMaker (mm)
    if (const double f = sum_list(c.substr(16)); f > 0) slicer_filament_mm_ = f;
  } else if (starts_with(c, "Filament length:")) {  // Simplify3D (mm)
    if (const double f = sum_list(c.substr(16)); f > 0) slicer_filament_mm_ = f;
  } else if (starts_with(c, "Estimated Build Volume:")) {  // KISSlicer (cm^3)
    if (const double f = sum_list(c.substr(23)); f > 0 && profile_.filament_area_mm2() > 0)
      slicer_filament_mm_ = f * 1000.0 / profile_.filament_area_mm2();
  }
}

/// `;LINE_WIDTH:`, `;LAYER_CHANGE`, `;LAYER:n` and `;LAYER_HEIGHT:` tags.
void GcodeInterpreter::layer_tag(std::string_view c) {
  double v = 0;
  if (starts_with(c, "LINE_WIDTH:")) {
    if (parse_double(c.substr(11), v) && v > 0 && v < 100) width_hint_mm_ = static_cast<float>(v);
  } else if (c == "LAYER_CHANGE") {  // PrusaSlicer, SuperSlicer, Orca, Creality
    layer_marker(std::numeric_limits<double>::quiet_NaN());
  } else if (starts_with(c, "LAYER:")) {  // Cura, ideaMaker: ";LAYER:n"
    // Cura: its start G-code (purge lines) ends at the first ;LAYER: tag.
    if (feature_ == Feature::custom && starts_with(slicer_, "Cura")) feature_ = Feature::unknown;
    std::string_view n = trim(c.substr(6));
    if (!n.empty() && (n.front() == '-' || (n.front() >= '0' && n.front() <= '9')))
      layer_marker(std::numeric_limits<double>::quiet_NaN());
  } else if (starts_with(c, "LAYER_HEIGHT:")) {
    if (parse_double(c.substr(13), v) && v > 0 && v < 100) height_hint_mm_ = static_cast<float>(v);
  } else if (starts_with(c, "LAYER_COUNT:")) {  // Cura's header
    if (parse_double(c.substr(12), v) && v >= 1 && v < 1e7)
      slicer_layer_count_ = static_cast<long>(v);
  }
}

/// The Z that follows a layer marker: ";Z:0.2" (PrusaSlicer), "; Z_HEIGHT: 0.2" (Orca, Bambu).
void GcodeInterpreter::z_tag(std::string_view c) {
  double v = 0;
  if (layer_pending_) {
    std::string_view z = starts_with(c, "Z:")          ? c.substr(2)
                         : starts_with(c, "Z_HEIGHT:") ? c.substr(9)
                                                       : std::string_view{};
    if (!z.empty() && parse_double(z, v) && v > -1000 && v < 10000) {
      pending_layer_z_ = v;
      if (layer_ >= 0 &&
          std::fabs(layer_z_[static_cast<std::size_t>(layer_)] - v) <= kLayerZTolerance_mm)
        layer_pending_ = false;  // a second marker at the same height
    }
  }
}

/// The slicer's name from the header comment that names it.
void GcodeInterpreter::slicer_tag(std::string_view c) {
  // "; generated by PrusaSlicer 2.5.0 on ...", ";Generated with Cura_SteamEngine 4.13.0",
  // "; G-Code generated by Simplify3D(R) Version 4.1.2", ";Sliced by ideaMaker 4.2.1",
  // "; KISSlicer - FREE".
  if (starts_with(c, "KISSlicer")) {
    slicer_ = "KISSlicer";
  } else {
    for (std::string_view key :
         {"generated by ", "Generated with ", "generated with ", "Sliced by "}) {
      const auto at = c.find(key);
      if (at == std::string_view::npos || at > 8) continue;
      std::string_view rest = c.substr(at + key.size());
      const auto on = rest.find(" on ");
      rest = rest.substr(0, std::min(on, rest.find(',')));
      slicer_ = std::string(trim(rest));
      // Cura tags nothing before ;LAYER:0: what comes before is its start G-code.
      if (starts_with(slicer_, "Cura")) feature_ = Feature::custom;
      break;
    }
  }
  // Every current slicer marks its layers; Slic3r 1.x does not.
  if (!slicer_.empty()) markers_expected_ = !starts_with(slicer_, "Slic3r ");
}

void GcodeInterpreter::comment(std::string_view c) {
  // Slicer tags: features, widths, objects, layer markers (docs/gcode-coverage.md).
  if (c.empty()) return;
  if (c == "EXECUTABLE_BLOCK_START") executable_block_open_ = true;
  if (c == "EXECUTABLE_BLOCK_END") executable_block_closed_ = true;
  if (c == "End of Gcode") cura_end_seen_ = true;
  if (starts_with(c, "filament used")) filament_used_seen_ = true;
  if (c == "prusaslicer_config = end") config_end_seen_ = true;
  double v = 0;
  switch (c.front()) {
    case 'T':
      if (starts_with(c, "TYPE:"))
        feature_ = feature_from_label(c.substr(5));
      else if (starts_with(c, "TIME:"))
        stated_figures(c);
      return;
    case 'F':
      if (starts_with(c, "FEATURE:"))
        feature_ = feature_from_label(trim(c.substr(8)));
      else if (starts_with(c, "Filament "))
        stated_figures(c);
      return;
    case 'f':
      if (starts_with(c, "feature "))
        feature_ = feature_from_label(trim(c.substr(8)));  // Simplify3D
      else if (starts_with(c, "filament used") || starts_with(c, "filament: "))
        stated_figures(c);  // "filament: 1,3": Bambu's used filaments
      return;
    case '\'': {
      // KISSlicer: "'Perimeter Path', 0.3 [feed mm/s], 9.5 [head mm/s]"
      const auto close = c.find('\'', 1);
      if (close != std::string_view::npos) feature_ = feature_from_label(c.substr(1, close - 1));
      return;
    }
    case 'W':
      if (starts_with(c, "WIDTH:")) {
        if (parse_double(c.substr(6), v) && v > 0 && v < 100)
          width_hint_mm_ = static_cast<float>(v);
      }
      return;
    case 'L':
      layer_tag(c);
      return;
    case 'C':
      if (c == "CHANGE_LAYER")
        layer_marker(std::numeric_limits<double>::quiet_NaN());  // Orca, Bambu
      return;
    case 'Z':
      z_tag(c);
      return;
    case 'B':
      if (starts_with(c, "BEGIN_LAYER_OBJECT z=")) {  // KISSlicer
        layer_marker(parse_double(c.substr(21), v) ? v : std::numeric_limits<double>::quiet_NaN());
      } else if (starts_with(c, "Build time:")) {
        stated_figures(c);
      } else if (slicer_.empty() && last_line_ <= 200 && starts_with(c, "BambuStudio ")) {
        slicer_ = std::string(trim(c));
        markers_expected_ = true;
      }
      return;
    case 'l':
      if (starts_with(c, "layer ")) {  // Simplify3D: "layer 12, Z = 2.450"
        const auto zpos = c.find("Z = ");
        if (zpos != std::string_view::npos && parse_double(c.substr(zpos + 4), v)) layer_marker(v);
      }
      return;
    case 'H':
      if (starts_with(c, "HEIGHT:")) {
        if (parse_double(c.substr(7), v) && v > 0 && v < 100)
          height_hint_mm_ = static_cast<float>(v);
      }
      return;
    case 'M':
      if (starts_with(c, "MESH:")) {
        const std::string name(trim(c.substr(5)));
        if (name == "NONMESH") {
          object_id_ = -1;
        } else {
          auto [it, inserted] =
              object_names_.try_emplace(name, static_cast<int>(object_names_.size()));
          object_id_ = it->second;
        }
      } else if (starts_with(c, "Material#")) {
        stated_figures(c);
      }
      return;
    case 'P':  // "Print Time:" (ideaMaker)
    case 'E':  // "Estimated Build Time:" (KISSlicer)
    case 't':  // "total estimated time:", "total filament length [mm]" (Orca, Bambu)
      if (starts_with(c, "tool H")) {
        // Simplify3D: "; tool H0.200 W0.480" (layer height and extrusion width).
        const auto wpos = c.find(" W");
        if (parse_double(
                c.substr(6, wpos == std::string_view::npos ? std::string_view::npos : wpos - 6),
                v) &&
            v > 0 && v < 100)
          height_hint_mm_ = static_cast<float>(v);
        if (wpos != std::string_view::npos && parse_double(c.substr(wpos + 2), v) && v > 0 &&
            v < 100)
          width_hint_mm_ = static_cast<float>(v);
        return;
      }
      [[fallthrough]];
    case 'm':  // "model printing time: ...; total estimated time: ..." (Orca)
    case 'e':  // "estimated printing time (normal mode) = " (PrusaSlicer)
      stated_figures(c);
      return;
    case 'p':
      if (starts_with(c, "printing object ")) {
        // PrusaSlicer: "; printing object cube.stl id:0 copy 0"
        const std::string name(trim(c.substr(16)));
        auto [it, inserted] =
            object_names_.try_emplace(name, static_cast<int>(object_names_.size()));
        object_id_ = it->second;
      }
      return;
    case 's':
      if (starts_with(c, "stop printing object")) object_id_ = -1;
      return;
    case 'K':
    case 'S':
    case 'g':
    case 'G':
      if (slicer_.empty() && last_line_ <= 200) slicer_tag(c);
      return;
    default:
      return;
  }
}

void GcodeInterpreter::report_cold_extrusion(long line, const Vec3& at) {
  // In the part's layers the plastic is missing: an error. In start or end code (before
  // the first layer, or tagged custom) only a prime or a push of the vendor's sequence is
  // lost, and the part prints (Bambu's A1 start code pushes filament at 140 C or less).
  // (Before the first layer only where the slicer marks its layers: in a file without
  // markers the part itself may come before any layer is known.)
  const bool outside_part =
      (markers_expected_ && layer_ < 0 && !layer_pending_) || feature_ == Feature::custom;
  Finding f;
  f.severity = outside_part ? Severity::warning : Severity::error;
  f.code = "cold_extrusion";
  f.message = "extrusion with the hotend at " + format_fixed(hotend_temp_now(), 0) +
              " C, below the minimum " + format_fixed(min_extrude_temp_c_, 0) + " C" +
              (options_.prevent_cold_extrusion ? "; the firmware drops the E part" : "") +
              (outside_part ? " (start or end code: a prime or purge is lost, not the part)" : "");
  f.line = line;
  f.position_mm = at;
  f.value = hotend_temp_now();
  if (layer_ >= 0) f.layer = layer_;
  add_finding(std::move(f));
}

void GcodeInterpreter::emit(const Vec3& target_logical_in, double e_delta_mm, double feedrate_mm_s,
                            MoveKind forced, bool is_forced, long line, std::string_view text,
                            InterpreterOutput& out) {
  Vec3 target_logical = target_logical_in;
  const Vec3 start = position_mm();
  Vec3 target = target_logical + offset_mm_;
  const Vec3 lo(profile_.travel_min_x_mm, profile_.travel_min_y_mm, profile_.travel_min_z_mm);
  const Vec3 hi(profile_.travel_max_x_mm, profile_.travel_max_y_mm, profile_.travel_max_z_mm);

  if (!is_forced) {
    // Moves of axes that were never homed: Marlin executes them from where it believes it is.
    // A relative move (G91) needs no position, only a distance: start codes lift the nozzle
    // that way before homing (Bambu's "G91 / G1 Z5"), and Marlin, Prusa's firmware and
    // Bambu's run it. Klipper and RepRapFirmware refuse any move of an unhomed axis.
    const bool relative_ok =
        relative_xyz_ && flavour_ != Flavour::klipper && flavour_ != Flavour::rrf;
    bool unhomed_motion = false;
    for (int i = 0; i < 3; ++i)
      if (!homed_[static_cast<std::size_t>(i)] && std::fabs(target[i] - start[i]) > 1e-9 &&
          !relative_ok)
        unhomed_motion = true;
    if (unhomed_motion && !reported_before_homing_) {
      reported_before_homing_ = true;
      Finding f;
      f.severity = Severity::warning;
      f.code = "move_before_homing";
      f.message =
          "move before the axes were homed (G28): the printer does not know where it is; "
          "first such move \"" +
          excerpt(text) + "\"";
      f.line = line;
      f.position_mm = start;
      add_finding(std::move(f));
    }
    // Software endstops clamp homed axes (Marlin apply_motion_limits); an axis that is not
    // homed stops at the frame.
    bool clamped = false, crashed = false;
    const Vec3 requested = target;
    for (int i = 0; i < 3; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      if (target[i] < lo[i] - 1e-9 || target[i] > hi[i] + 1e-9) {
        // M211 switched the software endstops of a homed axis off: the move runs as written
        // (Bambu's start and end codes park beyond the printable travel that way).
        if (homed_[ui] && !soft_endstops_[ui]) continue;
        const double c = std::clamp(target[i], lo[i], hi[i]);
        if (homed_[ui] && profile_.software_endstops)
          clamped = true;
        else
          crashed = true;
        target[i] = c;
      }
    }
    if (clamped || crashed) {
      Finding f;
      f.severity = crashed ? Severity::error : Severity::warning;
      f.code = crashed ? "hits_frame" : "out_of_bounds";
      f.message =
          std::string(crashed ? "move drives an unhomed axis into the frame"
                              : "move leaves the build volume; software endstops clamp it") +
          ": requested (" + format_fixed(requested.x(), 3) + ", " + format_fixed(requested.y(), 3) +
          ", " + format_fixed(requested.z(), 3) + ") mm, travel is (" + format_fixed(lo.x(), 1) +
          ".." + format_fixed(hi.x(), 1) + ", " + format_fixed(lo.y(), 1) + ".." +
          format_fixed(hi.y(), 1) + ", " + format_fixed(lo.z(), 1) + ".." +
          format_fixed(hi.z(), 1) + ") mm";
      f.line = line;
      f.position_mm = requested;
      if (layer_ >= 0) f.layer = layer_;
      add_finding(std::move(f));
      target_logical = target - offset_mm_;
    }
  }

  // Extruder: flow (M221) and volumetric mode (M200), as Marlin's e_factor.
  double e_mm = e_delta_mm * flow_;
  if (volumetric_area_mm2_ > 0) e_mm /= volumetric_area_mm2_;
  if (e_mm != 0 && !is_forced) {
    if (std::fabs(e_mm) > kExtrudeMaxLength_mm) {
      Finding f;
      f.severity = Severity::error;
      f.code = "lengthy_extrusion";
      f.message = "E changes by " + format_fixed(e_mm, 2) +
                  " mm in one move (more than Marlin's "
                  "EXTRUDE_MAXLENGTH " +
                  format_fixed(kExtrudeMaxLength_mm, 0) + " mm); the firmware drops the E part";
      f.line = line;
      f.position_mm = start;
      f.value = e_mm;
      add_finding(std::move(f));
      e_mm = 0;
    } else if (hotend_temp_now() < min_extrude_temp_c_) {
      report_cold_extrusion(line, start);
      if (options_.prevent_cold_extrusion) e_mm = 0;
    }
  }

  const Vec3 d = target - start;
  const double xyz = d.norm();
  if (xyz < 1e-9 && e_mm == 0) {
    logical_mm_ = target_logical;
    return;
  }
  Move m;
  m.start_mm = start;
  m.end_mm = target;
  m.e_mm = e_mm;
  m.feedrate_mm_s = feedrate_mm_s * limits_.feedrate_scale;
  m.line = line;
  if (is_forced)
    m.kind = forced;
  else if (e_mm > 0)
    m.kind = xyz > 1e-9 ? MoveKind::extrude : MoveKind::unretract;
  else if (e_mm < 0)
    m.kind = MoveKind::retract;
  else
    m.kind = MoveKind::travel;

  // Layers follow the slicer's layer markers when the file has them; otherwise they are
  // made by the Z of extrusions. Start/end code (purge lines, tagged custom) joins the
  // current layer instead of making one; before the first marker of a slicer that marks its
  // layers it belongs to no layer.
  if (m.kind == MoveKind::extrude && feature_ != Feature::custom && layer_pending_) {
    layer_pending_ = false;
    // The marker's Z (the layer's top: right for a spiral vase whose first extrusion starts
    // lower) unless it contradicts the extrusion by more than a layer could be thick.
    const bool trust = !std::isnan(pending_layer_z_) &&
                       std::fabs(pending_layer_z_ - target.z()) <= kMarkerZTolerance_mm;
    layer_z_.push_back(trust ? pending_layer_z_ : target.z());
    layer_ = static_cast<int>(layer_z_.size()) - 1;
  } else if (m.kind == MoveKind::extrude && feature_ != Feature::custom && !marker_seen_ &&
             !markers_expected_) {
    const double z = target.z();
    if (layer_ < 0 ||
        std::fabs(layer_z_[static_cast<std::size_t>(layer_)] - z) > kLayerZTolerance_mm) {
      int found = -1;
      for (std::size_t i = layer_z_.size(); i-- > 0;)
        if (std::fabs(layer_z_[i] - z) <= kLayerZTolerance_mm) {
          found = static_cast<int>(i);
          break;
        }
      if (found < 0) {
        layer_z_.push_back(z);
        found = static_cast<int>(layer_z_.size()) - 1;
      }
      layer_ = found;
    }
  }
  m.layer = layer_;
  m.feature = feature_;
  m.object_id = object_id_;
  m.tool = static_cast<std::uint8_t>(std::max(tool_, 0));
  m.width_hint_mm = width_hint_mm_;
  m.height_hint_mm = height_hint_mm_;
  out.move(m);
  ++moves_;
  filament_mm_ += e_mm;
  logical_mm_ = target_logical;
  const double len = xyz > 1e-9 ? xyz : std::fabs(e_mm);
  if (m.feedrate_mm_s > 0) nominal_clock_s_ += len / m.feedrate_mm_s;
}

Status GcodeInterpreter::motion_words(const GcodeCommand& c, std::string_view text, Vec3& target,
                                      double& de) {
  const double unit = inches_ ? kInch_mm : 1.0;
  if (c.has('F')) {
    const double f = c.get('F') * unit / 60.0;
    if (f > 0) {
      feedrate_mm_s_ = f;
    } else {
      // Marlin ignores F <= 0 and keeps the previous feedrate.
      auto st =
          warn(c.line, text, "feedrate F must be positive; previous feedrate kept", "bad_feedrate");
      if (!st) return st;
    }
  }
  target = logical_mm_;
  static constexpr char kAxes[3] = {'X', 'Y', 'Z'};
  for (int i = 0; i < 3; ++i)
    if (c.has(kAxes[i])) {
      const double v = c.get(kAxes[i]) * unit;
      target[i] = relative_xyz_ ? logical_mm_[i] + v : v;
    }
  de = 0;
  if (c.has('E')) {
    const double v = c.get('E') * unit;
    de = e_relative() ? v : v - e_logical_mm_;
    e_logical_mm_ += de;
  }
  return Ok{};
}

Status GcodeInterpreter::linear_move(const GcodeCommand& c, std::string_view text,
                                     InterpreterOutput& out) {
  Vec3 target;
  double de = 0;
  if (auto st = motion_words(c, text, target, de); !st) return st;
  emit(target, de, feedrate_mm_s_, MoveKind::travel, false, c.line, text, out);
  return Ok{};
}

Status GcodeInterpreter::arc_move(const GcodeCommand& c, std::string_view text,
                                  InterpreterOutput& out) {
  const double unit = inches_ ? kInch_mm : 1.0;
  const bool clockwise = c.code == 2;
  Vec3 target;
  double de = 0;
  const double e_before = e_logical_mm_;
  if (auto st = motion_words(c, text, target, de); !st) return st;
  // A rejected arc leaves the position, E included, where it was (Marlin skips the command).
  auto reject = [&](const std::string& message) {
    e_logical_mm_ = e_before;
    return warn(c.line, text, message, "bad_arc");
  };
  // Centre offset from the start: I/J, or from the radius R (Marlin G2_G3.cpp).
  Vec2 offset(c.get('I') * unit, c.get('J') * unit);
  const Vec2 p1 = logical_mm_.head<2>(), p2 = target.head<2>();
  if (c.has('R')) {
    const double r = c.get('R') * unit;
    if (r == 0 || (p1 - p2).norm() < 1e-9)
      return reject("arc with R needs a non-zero radius and distinct end points; ignored");
    const Vec2 d2 = 0.5 * (p2 - p1);
    const double e = (clockwise ^ (r < 0)) ? -1.0 : 1.0;
    const double len = d2.norm();
    const double h2 = (r - len) * (r + len);
    const double h = h2 >= 0 ? std::sqrt(h2) : 0.0;
    const Vec2 s(-d2.y(), d2.x());
    offset = d2 + s / len * e * h;
  } else if (!c.has('I') && !c.has('J')) {
    return reject("arc without I, J or R; ignored");
  } else if (offset.norm() < 1e-9) {
    // I0 J0: a zero radius. Marlin answers "G2/G3 bad parameters" and skips the move.
    return reject(
        "arc with a zero radius (I and J both 0): the firmware rejects it and skips the move" +
        (de != 0 ? ", and its " + format_fixed(std::fabs(de), 3) + " mm of filament is not laid"
                 : std::string()));
  }
  const double rp = -offset.x(), rq = -offset.y();  // centre -> start
  const double radius = std::hypot(rp, rq);
  const Vec2 center = p1 - Vec2(rp, rq);
  const double rtx = p2.x() - center.x(), rty = p2.y() - center.y();
  double angular = std::atan2(rp * rty - rq * rtx, rp * rtx + rq * rty);
  if (angular < 0) angular += 2 * kPi;
  if (clockwise) angular -= 2 * kPi;
  // P<n>: n full turns on top of the partial arc. An arc that ends where it starts is a full
  // circle without P, and only its P turns with P (OrcaSlicer's / Bambu Studio's spiral lift
  // "G3 Z.. I.. J.. P1" is one turn of a helix).
  const bool closed = (p1 - p2).norm() < 1e-9;
  const double turns = c.has('P') ? std::floor(std::clamp(c.get('P'), 0.0, 1000.0)) : 0.0;
  if (closed) angular = turns > 0 ? 0.0 : (clockwise ? -2 * kPi : 2 * kPi);
  angular += (clockwise ? -2 * kPi : 2 * kPi) * turns;
  const double dz = target.z() - logical_mm_.z();
  const double flat = radius * std::fabs(angular);
  const double travel = std::hypot(flat, dz);
  if (travel < 0.001) return Ok{};
  if (radius > 1e6) return reject("arc radius too large; ignored");
  // Segment length like Marlin: a circle has at least arc_min_segments_per_circle segments,
  // each between arc_min_segment_mm and arc_max_segment_mm.
  const double seg = std::clamp(radius * 2 * kPi / profile_.arc_min_segments_per_circle,
                                profile_.arc_min_segment_mm, profile_.arc_max_segment_mm);
  // Klipper's [gcode_arcs] takes floor(length / resolution) segments; Marlin rounds.
  const double n_seg = travel / seg;
  const long segments =
      std::max(1L, profile_.firmware == "klipper" ? static_cast<long>(std::floor(n_seg))
                                                  : std::lround(n_seg));
  if (segments > 20000) return reject("arc needs more than 20000 segments; ignored");
  const Vec3 start = logical_mm_;
  const double theta_step = angular / static_cast<double>(segments);
  for (long i = 1; i <= segments; ++i) {
    Vec3 p;
    if (i == segments) {
      p = target;  // end exactly on the target
    } else {
      const double a = theta_step * static_cast<double>(i);
      const double ca = std::cos(a), sa = std::sin(a);
      p.x() = center.x() + rp * ca - rq * sa;
      p.y() = center.y() + rp * sa + rq * ca;
      p.z() = start.z() + dz * static_cast<double>(i) / static_cast<double>(segments);
    }
    emit(p, de / static_cast<double>(segments), feedrate_mm_s_, MoveKind::travel, false, c.line,
         text, out);
  }
  return Ok{};
}

Status GcodeInterpreter::home(const GcodeCommand& c, InterpreterOutput& out) {
  // G28 [X] [Y] [Z]: the homing state machine of the seed's printer, made faithful to
  // Marlin: quick diagonal XY approach (QUICK_HOME), then per axis fast approach, bump back,
  // slow re-approach at homing_feedrate / bump_divisor. Z last.
  bool axis[3] = {c.has('X'), c.has('Y'), c.has('Z')};
  if (!axis[0] && !axis[1] && !axis[2]) axis[0] = axis[1] = axis[2] = true;
  // Bambu's firmware homes X and Y together on "G28 X" (its start code: "G28 X ; re-home
  // XY"); "G28 Z P0 T300" homes Z alone.
  if (flavour_ == Flavour::bambu && axis[0]) axis[1] = true;
  out.synchronize();
  const Vec3 lo(profile_.travel_min_x_mm, profile_.travel_min_y_mm, profile_.travel_min_z_mm);
  auto go = [&](const Vec3& machine_target, double feedrate) {
    const Vec3 start = position_mm();
    if ((machine_target - start).norm() < 1e-9) return;
    Move m;
    m.start_mm = start;
    m.end_mm = machine_target;
    m.feedrate_mm_s = feedrate;
    m.line = c.line;
    m.kind = MoveKind::home;
    m.layer = layer_;
    m.feature = Feature::custom;
    m.object_id = -1;
    out.move(m);
    ++moves_;
    nominal_clock_s_ += (machine_target - start).norm() / feedrate;
    logical_mm_ = machine_target - offset_mm_;
    out.synchronize();  // each homing phase ends on an endstop: the printer stops
  };
  const Vec3& fr = profile_.homing_feedrate_mm_s;
  if (axis[0] && axis[1] && profile_.quick_home) {
    // Diagonal until the nearer endstop triggers, then the other axis alone.
    const Vec3 p = position_mm();
    const double dx = p.x() - lo.x(), dy = p.y() - lo.y();
    const double t = std::min(dx / fr.x(), dy / fr.y());
    if (t > 0) go(Vec3(p.x() - fr.x() * t, p.y() - fr.y() * t, p.z()), std::hypot(fr.x(), fr.y()));
    const Vec3 q = position_mm();
    if (q.x() > lo.x() + 1e-9) go(Vec3(lo.x(), q.y(), q.z()), fr.x());
    if (q.y() > lo.y() + 1e-9) go(Vec3(q.x(), lo.y(), q.z()), fr.y());
  }
  for (int i = 0; i < 3; ++i) {
    if (!axis[i]) continue;
    const auto ui = static_cast<std::size_t>(i);
    Vec3 p = position_mm();
    p[i] = lo[i];
    go(p, fr[i]);  // fast approach
    p[i] = lo[i] + profile_.homing_bump_mm[i];
    go(p, fr[i]);  // bump back
    p[i] = lo[i];
    go(p, fr[i] / profile_.homing_bump_divisor[i]);  // slow re-approach
    homed_[ui] = true;
    offset_mm_[i] = 0;  // G28 clears the G92 shift
    logical_mm_[i] = lo[i];
  }
  return Ok{};
}

namespace {
/// Value of KEY=VALUE in the arguments of an extended command ("ACCEL=500
/// SQUARE_CORNER_VELOCITY=9"); keys match case-insensitively. False when absent or not a number.
bool macro_arg(std::string_view args, std::string_view key, double& v) {
  std::size_t pos = 0;
  while (pos < args.size()) {
    while (pos < args.size() && (args[pos] == ' ' || args[pos] == '\t')) ++pos;
    const std::size_t start = pos;
    while (pos < args.size() && args[pos] != ' ' && args[pos] != '\t') ++pos;
    const std::string_view item = args.substr(start, pos - start);
    const auto eq = item.find('=');
    if (eq == std::string_view::npos || eq != key.size()) continue;
    bool same = true;
    for (std::size_t i = 0; i < eq && same; ++i)
      same = std::toupper(static_cast<unsigned char>(item[i])) == key[i];
    if (same) return parse_double(item.substr(eq + 1), v);
  }
  return false;
}

/// The `_`-separated parts of a macro name, upper-cased ("PRINT_START" -> PRINT, START).
bool name_has_part(std::string_view name, std::string_view part) {
  std::size_t pos = 0;
  while (pos <= name.size()) {
    const auto us = name.find('_', pos);
    const std::string_view p =
        name.substr(pos, us == std::string_view::npos ? std::string_view::npos : us - pos);
    if (p.size() == part.size()) {
      bool same = true;
      for (std::size_t i = 0; i < p.size() && same; ++i)
        same = std::toupper(static_cast<unsigned char>(p[i])) == part[i];
      if (same) return true;
    }
    if (us == std::string_view::npos) break;
    pos = us + 1;
  }
  return false;
}

enum class MacroKind { none, start, end };

/// The info note of bed levelling and gantry levelling commands (G29, BED_MESH_CALIBRATE...).
std::string levelling_message(std::string_view command) {
  return "bed levelling (" + std::string(command) +
         " and the like) is not simulated: its probing "
         "moves take time on the printer (often 1-3 min) that the print time does not include";
}

/// Printer-side start/end macros by the shape of their names: START_PRINT, PRINT_START,
/// START_PRINT_K1, PRINT_BEGIN, END_PRINT, PRINT_END, PRINT_FINISH, CANCEL_PRINT...
MacroKind macro_kind(std::string_view name) {
  if (name_has_part(name, "PRINT") || name_has_part(name, "PRINTING")) {
    if (name_has_part(name, "START") || name_has_part(name, "BEGIN")) return MacroKind::start;
    if (name_has_part(name, "END") || name_has_part(name, "FINISH") ||
        name_has_part(name, "CANCEL"))
      return MacroKind::end;
  }
  return MacroKind::none;
}
}  // namespace

void GcodeInterpreter::note(std::string code, std::string message, long line) {
  for (auto& f : findings_)
    if (f.code == code) {
      ++f.count;
      return;
    }
  Finding f;
  f.severity = Severity::info;
  f.code = std::move(code);
  f.message = std::move(message);
  f.line = line;
  findings_.push_back(std::move(f));
}

void GcodeInterpreter::set_hotend_target(double t, int heater) {
  if (heater < 0) heater = active_heater();
  t = std::max(t, profile_.ambient_temp_c);  // a heater off cools to the room, not below
  Heater& h = hotends_[static_cast<std::size_t>(heater)];
  h.at_set_c = hotend_temp_now(heater);
  h.target_c = t;
  h.set_clock_s = nominal_clock_s_;
}

void GcodeInterpreter::set_bed_target(double t) {
  t = std::max(t, profile_.ambient_temp_c);
  const double dt = nominal_clock_s_ - bed_set_clock_s_;
  const double rate = profile_.bed_heat_rate_c_s;
  bed_c_at_set_ = bed_target_c_ >= bed_c_at_set_
                      ? std::min(bed_target_c_, bed_c_at_set_ + rate * dt)
                      : std::max(bed_target_c_, bed_c_at_set_ - rate * dt);
  bed_target_c_ = t;
  bed_set_clock_s_ = nominal_clock_s_;
}

Status GcodeInterpreter::start_macro(const GcodeCommand& c, std::string_view text,
                                     InterpreterOutput& out) {
  // A printer-side start sequence (Klipper START_PRINT / PRINT_START and the like): the
  // printer homes all axes and heats to the temperatures passed, else to those of the
  // slicer's settings, else to an assumed printing temperature. What else the macro does
  // (bed mesh, purge line) is not known to the twin.
  double hotend = std::numeric_limits<double>::quiet_NaN(), bed = hotend;
  for (std::string_view key :
       {"EXTRUDER_TEMP", "EXTRUDER", "HOTEND_TEMP", "HOTEND", "NOZZLE_TEMP", "NOZZLE", "TOOL_TEMP",
        "EXTRUDER_TEMPERATURE", "EXT_TEMP", "HOTEND_TEMPERATURE", "NOZZLE_TEMPERATURE", "TEMP"}) {
    double v = 0;
    if (std::isnan(hotend) && macro_arg(c.args, key, v)) hotend = v;
  }
  for (std::string_view key : {"BED_TEMP", "BED", "BED_TEMPERATURE", "BEDTEMP"}) {
    double v = 0;
    if (std::isnan(bed) && macro_arg(c.args, key, v)) bed = v;
  }
  bool assumed = false;
  if (std::isnan(hotend)) hotend = options_.macro_hotend_c;
  if (std::isnan(bed)) bed = options_.macro_bed_c;
  if (std::isnan(hotend)) {
    hotend = std::max(profile_.min_extrude_temp_c + 30.0, 200.0);
    assumed = true;
  }
  if (std::isnan(bed)) {
    bed = 60.0;
    assumed = true;
  }
  if (hotend < 0 || hotend > 500 || bed < 0 || bed > 200)
    return warn(c.line, text,
                "start macro temperature outside 0..500 C (hotend) or 0..200 C (bed); ignored",
                "bad_temperature");
  if (assumed)
    note("macro_temperature_assumed",
         std::string(c.word) +
             " is given no temperature and the slicer's settings state none: the twin "
             "assumes it heats the hotend to " +
             format_fixed(hotend, 0) + " C and the bed to " + format_fixed(bed, 0) +
             " C (heating time is approximate)",
         c.line);
  GcodeCommand home_all;
  home_all.letter = 'G';
  home_all.code = 28;
  home_all.line = c.line;
  if (auto st = home(home_all, out); !st) return st;
  heat_wait(false, bed, false, c.line, out);
  heat_wait(true, hotend, false, c.line, out);
  e_logical_mm_ = 0;  // start macros end with G92 E0
  return Ok{};
}

Status GcodeInterpreter::firmware_retract(const GcodeCommand& c, bool retract,
                                          std::string_view text, InterpreterOutput& out) {
  // G10/G11: Marlin FWRETRACT (with its Z raise), Klipper [firmware_retraction] (no Z
  // raise; G11 adds unretract_extra_length), RepRapFirmware M207.
  if (retract == fw_retracted_) return Ok{};
  fw_retracted_ = retract;
  const double len = retract ? -fw_length_mm_ : fw_length_mm_ + fw_recover_extra_mm_;
  const double speed = retract ? fw_speed_mm_s_ : fw_recover_speed_mm_s_;
  const double lift = flavour_ == Flavour::klipper ? 0.0 : fw_zraise_mm_;
  Vec3 t = logical_mm_;
  if (lift > 0 && retract) {
    emit(t, len, speed, MoveKind::travel, false, c.line, text, out);
    t.z() += lift;
    emit(t, 0, speed, MoveKind::travel, false, c.line, text, out);
  } else if (lift > 0) {
    t.z() -= lift;
    emit(t, 0, speed, MoveKind::travel, false, c.line, text, out);
    emit(t, len, speed, MoveKind::travel, false, c.line, text, out);
  } else if (len != 0) {
    emit(t, len, speed, MoveKind::travel, false, c.line, text, out);
  }
  return Ok{};
}

Status GcodeInterpreter::klipper_m204(const GcodeCommand& c, std::string_view text,
                                      InterpreterOutput& out) {
  // Klipper's M204: S sets max_accel; otherwise both P and T set it to min(P, T); a lone P
  // or T is ignored (Klipper answers "Invalid M204 command").
  double accel = 0;
  if (c.has('S'))
    accel = c.get('S');
  else if (c.has('P') && c.has('T'))
    accel = std::min(c.get('P'), c.get('T'));
  else {
    note("klipper_m204_ignored",
         "M204 without S, or with only one of P and T, is ignored by Klipper "
         "(\"" +
             excerpt(text) + "\"): the acceleration stays as it was",
         c.line);
    return Ok{};
  }
  if (accel <= 0)
    return warn(c.line, text, "acceleration must be positive; ignored", "bad_parameter");
  limits_.print_accel_mm_s2 = limits_.travel_accel_mm_s2 = limits_.retract_accel_mm_s2 = accel;
  out.limits(limits_);
  return Ok{};
}

Status GcodeInterpreter::extended(const GcodeCommand& c, std::string_view text,
                                  InterpreterOutput& out) {
  const std::string_view w = c.word;
  double v = 0;
  if (w == "EXCLUDE_OBJECT_START") {
    const auto pos = c.args.find("NAME=");
    std::string_view name = pos == std::string_view::npos ? c.args : trim(c.args.substr(pos + 5));
    name = name.substr(0, name.find(' '));
    auto [it, inserted] =
        object_names_.try_emplace(std::string(name), static_cast<int>(object_names_.size()));
    object_id_ = it->second;
    return Ok{};
  }
  if (w == "EXCLUDE_OBJECT_END") {
    object_id_ = -1;
    return Ok{};
  }
  if (w == "SET_VELOCITY_LIMIT") {
    // Klipper: VELOCITY (max_velocity), ACCEL (max_accel), SQUARE_CORNER_VELOCITY,
    // MINIMUM_CRUISE_RATIO, and the older ACCEL_TO_DECEL (minimum_cruise_ratio =
    // 1 - accel_to_decel / max_accel).
    bool any = false;
    if (macro_arg(c.args, "VELOCITY", v) && v > 0) {
      limits_.max_feedrate_mm_s[0] = limits_.max_feedrate_mm_s[1] = v;
      any = true;
    }
    if (macro_arg(c.args, "ACCEL", v) && v > 0) {
      limits_.print_accel_mm_s2 = limits_.travel_accel_mm_s2 = limits_.retract_accel_mm_s2 = v;
      any = true;
    }
    if (macro_arg(c.args, "SQUARE_CORNER_VELOCITY", v) && v >= 0) {
      limits_.square_corner_velocity_mm_s = v;
      any = true;
    }
    if (macro_arg(c.args, "MINIMUM_CRUISE_RATIO", v) && v >= 0 && v < 1) {
      limits_.minimum_cruise_ratio = v;
      any = true;
    } else if (macro_arg(c.args, "ACCEL_TO_DECEL", v) && v > 0) {
      limits_.minimum_cruise_ratio = 1.0 - std::min(1.0, v / limits_.print_accel_mm_s2);
      any = true;
    }
    if (!any && !trim(c.args).empty())
      return warn(c.line, text,
                  "SET_VELOCITY_LIMIT with no valid VELOCITY, ACCEL, SQUARE_CORNER_VELOCITY, "
                  "MINIMUM_CRUISE_RATIO or ACCEL_TO_DECEL; ignored",
                  "bad_parameter");
    if (any) out.limits(limits_);
    return Ok{};
  }
  if (w == "SET_RETRACTION") {
    // Klipper [firmware_retraction]: RETRACT_LENGTH, RETRACT_SPEED, UNRETRACT_EXTRA_LENGTH,
    // UNRETRACT_SPEED.
    if (macro_arg(c.args, "RETRACT_LENGTH", v) && v >= 0) fw_length_mm_ = v;
    if (macro_arg(c.args, "RETRACT_SPEED", v) && v > 0) fw_speed_mm_s_ = v;
    if (macro_arg(c.args, "UNRETRACT_EXTRA_LENGTH", v) && v >= 0) fw_recover_extra_mm_ = v;
    if (macro_arg(c.args, "UNRETRACT_SPEED", v) && v > 0) fw_recover_speed_mm_s_ = v;
    return Ok{};
  }
  if (w == "TEMPERATURE_WAIT") {
    // Klipper: SENSOR=extruder|heater_bed MINIMUM=<C> [MAXIMUM=<C>]: waits until reached.
    const auto h = c.args.find("SENSOR=");
    const std::string_view sensor =
        h == std::string_view::npos ? std::string_view{} : c.args.substr(h + 7);
    if (!macro_arg(c.args, "MINIMUM", v)) return Ok{};
    if (v < 0 || v > 500)
      return warn(c.line, text, "temperature outside 0..500 C; ignored", "bad_temperature");
    // Wait until MINIMUM is reached; the heater keeps heating to its own target.
    const int heater = heater_of_tool(klipper_extruder_index(sensor));
    const bool hotend = heater >= 0;
    if (!hotend && !starts_with(sensor, "heater_bed")) return Ok{};
    const double target =
        hotend ? hotends_[static_cast<std::size_t>(heater)].target_c : bed_target_c_;
    if (v <= (hotend ? hotend_temp_now(heater) : bed_c_at_set_)) return Ok{};
    heat_wait(hotend, v, false, c.line, out, heater);
    if (target > v) hotend ? set_hotend_target(target, heater) : set_bed_target(target);
    return Ok{};
  }
  if (w == "BED_MESH_CALIBRATE" || w == "QUAD_GANTRY_LEVEL" || w == "Z_TILT_ADJUST") {
    note("bed_levelling_not_timed", levelling_message(w), c.line);
    return Ok{};
  }
  if (w == "ACTIVATE_EXTRUDER") {
    // Klipper: EXTRUDER=extruder|extruder1|...: later E moves drive that extruder (the
    // usual body of a multi-extruder printer's T0/T1 macros).
    const auto e = c.args.find("EXTRUDER=");
    const long n = e == std::string_view::npos ? -1 : klipper_extruder_index(c.args.substr(e + 9));
    if (n < 0)
      return warn(c.line, text, "ACTIVATE_EXTRUDER names no extruder; ignored", "bad_tool");
    return select_tool(n, c.line, text, out, true);
  }
  if (w == "SET_HEATER_TEMPERATURE") {
    // Klipper: HEATER=extruder|heater_bed TARGET=<C> (no wait, like M104/M140).
    const auto h = c.args.find("HEATER=");
    const std::string_view heater =
        h == std::string_view::npos ? std::string_view{} : c.args.substr(h + 7);
    const double target = macro_arg(c.args, "TARGET", v) ? v : 0.0;
    if (target < 0 || target > 500)
      return warn(c.line, text, "heater target outside 0..500 C; ignored", "bad_temperature");
    if (const int n = heater_of_tool(klipper_extruder_index(heater)); n >= 0)
      set_hotend_target(target, n);
    else if (starts_with(heater, "heater_bed"))
      set_bed_target(target);
    return Ok{};
  }
  // Klipper commands without effect on motion or material in the twin.
  static constexpr std::string_view kQuiet[] = {"EXCLUDE_OBJECT_DEFINE",
                                                "EXCLUDE_OBJECT",
                                                "SET_PRINT_STATS_INFO",
                                                "SET_PRESSURE_ADVANCE",
                                                "TIMELAPSE_TAKE_FRAME",
                                                "SET_FAN_SPEED",
                                                "SET_IDLE_TIMEOUT",
                                                "SET_INPUT_SHAPER",
                                                "BED_MESH_PROFILE",
                                                "RESPOND",
                                                "SAVE_GCODE_STATE",
                                                "RESTORE_GCODE_STATE",
                                                "SET_LED",
                                                "SET_PIN",
                                                "UPDATE_DELAYED_GCODE",
                                                "SET_SKEW",
                                                "SET_TMC_CURRENT"};
  for (std::string_view q : kQuiet)
    if (w == q) return Ok{};
  switch (macro_kind(w)) {
    case MacroKind::start:
      return start_macro(c, text, out);
    case MacroKind::end:
      // END_PRINT-like: the printer retracts, parks, cools down and stops. No motion the
      // twin can know; the heaters go off.
      out.synchronize();
      set_hotend_target(profile_.ambient_temp_c);
      set_bed_target(profile_.ambient_temp_c);
      return Ok{};
    case MacroKind::none:
      break;
  }
  if (++unknown_[std::string(w)] == 1) unknown_first_line_[std::string(w)] = c.line;
  return Ok{};
}

Status GcodeInterpreter::execute(const GcodeCommand& c, std::string_view text,
                                 InterpreterOutput& out) {
  last_line_ = c.line;
  if (c.letter == 0) {
    if (c.word.empty()) {
      comment(c.comment);
      return Ok{};
    }
    return extended(c, text, out);
  }
  if (c.letter == 'G') return execute_g(c, text, out);
  if (c.letter == 'M') return execute_m(c, text, out);
  if (c.letter == 'T') return select_tool(c.code, c.line, text, out);
  return unknown_command(c);
}

Status GcodeInterpreter::unknown_command(const GcodeCommand& c) {
  const std::string name = command_name(c);
  if (++unknown_[name] == 1) unknown_first_line_[name] = c.line;
  return Ok{};
}

Status GcodeInterpreter::execute_g(const GcodeCommand& c, std::string_view text,
                                   InterpreterOutput& out) {
  switch (c.code) {
    case 0:
    case 1:
      return linear_move(c, text, out);
    case 2:
    case 3:
      return arc_move(c, text, out);
    case 4: {
      double s = c.has('S') ? c.get('S') : c.get('P') / 1000.0;
      if (s < 0) return warn(c.line, text, "negative dwell; ignored", "bad_dwell");
      out.synchronize();
      if (s > 0) out.wait(s, false, c.line);
      nominal_clock_s_ += s;
      return Ok{};
    }
    case 10:
    case 11:
      return g10_g11(c, text, out);
    case 29:
      if (c.subcode >= 1) return Ok{};  // Bambu G29.1 (Z offset), G29.2 (mesh on/off)
      [[fallthrough]];
    case 80:
    case 81:
      // Bed levelling (G29 and its variants P1, P9, A, T...; Prusa G80/G81): the probing
      // takes time on the printer; the twin does not move or count it.
      note("bed_levelling_not_timed", levelling_message(command_name(c)), c.line);
      return Ok{};
    case 380:  // Bambu: probing move towards the bed
    case 150:  // Bambu: nozzle wipe / load
    case 39:   // Bambu: nozzle-to-bed calibration
    case 392:  // Bambu: nozzle clog detection on/off (G392 S0/S1, each layer on the A1)
      return Ok{};
    case 17:
      return Ok{};
    case 18:
    case 19:
      return warn(c.line, text, "only the XY plane (G17) is supported for arcs",
                  "unsupported_plane");
    case 20:
      inches_ = true;
      return Ok{};
    case 21:
      inches_ = false;
      return Ok{};
    case 28:
      return home(c, out);
    case 90:
      relative_xyz_ = relative_e_ = false;
      return Ok{};
    case 91:
      relative_xyz_ = relative_e_ = true;
      return Ok{};
    case 92:
      set_position(c);
      return Ok{};
    default:
      return unknown_command(c);
  }
}

/// G10/G11: firmware retraction, or RepRapFirmware's G10 tool temperatures and offsets.
Status GcodeInterpreter::g10_g11(const GcodeCommand& c, std::string_view text,
                                 InterpreterOutput& out) {
  if (c.code == 10 && flavour_ == Flavour::rrf && c.has('L'))
    return Ok{};  // RRF: tool/work offsets
  if (c.code == 10 && flavour_ == Flavour::rrf && (c.has('P') || c.has('S') || c.has('R'))) {
    // RepRapFirmware: G10 P<tool> S<active C> R<standby C> sets tool temperatures.
    if (c.has('S')) {
      const double t = c.get('S');
      if (t < 0 || t > 500)
        return warn(c.line, text, "tool temperature outside 0..500 C; ignored", "bad_temperature");
      // The tool's active temperature: its heater follows it while the tool is selected.
      const long tool = std::lround(c.get('P', 0));
      if (tool >= 0 && tool < kMaxTools) {
        rrf_active_c_[static_cast<std::size_t>(tool)] = t;
        if (tool == tool_) set_hotend_target(t);
      }
    }
    return Ok{};
  }
  if (!profile_.firmware_retraction && flavour_ != Flavour::klipper && flavour_ != Flavour::rrf) {
    if (++unknown_[command_name(c)] == 1) unknown_first_line_[command_name(c)] = c.line;
    return Ok{};
  }
  if (!profile_.firmware_retraction && fw_length_mm_ == 0)
    note("firmware_retraction_unset",
         "G10/G11 firmware retraction with no retraction length in the printer profile: the "
         "twin retracts 0 mm (Klipper's default); set fw_retract_length_mm or SET_RETRACTION",
         c.line);
  return firmware_retract(c, c.code == 10, text, out);
}

/// G92: sets the logical position of the named axes (all to 0 when none is named).
void GcodeInterpreter::set_position(const GcodeCommand& c) {
  const double unit = inches_ ? kInch_mm : 1.0;
  static constexpr char kAxes[3] = {'X', 'Y', 'Z'};
  bool any = false;
  for (int i = 0; i < 3; ++i)
    if (c.has(kAxes[i])) {
      any = true;
      const Vec3 machine = position_mm();
      logical_mm_[i] = c.get(kAxes[i]) * unit;
      offset_mm_[i] = machine[i] - logical_mm_[i];
    }
  if (c.has('E')) {
    any = true;
    e_logical_mm_ = c.get('E') * unit;
  }
  if (!any) {  // G92 alone: all axes to 0
    const Vec3 machine = position_mm();
    logical_mm_ = Vec3::Zero();
    offset_mm_ = machine;
    e_logical_mm_ = 0;
  }
}

namespace {
/// Known M codes without effect on motion or material in the twin.
bool ignored_m_code(int code) {
  switch (code) {
    case 17:
    case 18:
    case 84:  // steppers on/off
    case 105:
    case 106:
    case 107:  // temperature report, fan
    case 73:
    case 75:
    case 76:
    case 77:  // progress, print job timer
    case 108:
    case 110:
    case 111:
    case 114:
    case 115:
    case 117:
    case 118:
    case 119:
    case 155:
    case 300:
    case 420:
    case 500:
    case 501:
    case 503:
    case 900:
    case 907:
    case 23:
    case 24:
    case 25:
    case 28:
    case 29:
    case 30:
    case 32:
    case 81:
    case 928:
    // Marlin settings that start codes send: hotend and bed PID (M301, M304), power-loss
    // recovery (M413), probe servo and deploy/stow (M280, M401, M402), power on (M80),
    // pins (M42), endstops on/off (M120, M121), controller fan (M710).
    case 301:
    case 304:
    case 413:
    case 280:
    case 401:
    case 402:
    case 80:
    case 42:
    case 120:
    case 121:
    case 710:
    // Prusa firmware: printer/nozzle checks (M862.x), print area (M555), stepper mode
    // (M569), input shaper (M593), pressure advance (M572, also RRF), heatbreak fan (M142),
    // mass estimate (M74), fan and LED settings.
    case 555:
    case 569:
    case 593:
    case 572:
    case 142:
    case 74:
    case 150:
    case 141:
    case 191:
    case 92:
    // Bambu Studio: status (M1002), AMS (M620/M621), conditions (M622/M623), calibrations
    // (M960..M991), filament runout (M412), sounds (M1006), M1003..M1007.
    case 1002:
    case 1003:
    case 1004:
    case 1005:
    case 1006:
    case 1007:
    case 620:
    case 621:
    case 622:
    case 623:
    case 624:
    case 625:
    case 412:
    case 630:   // Bambu A1: motor state reset (M630 S0 P0)
    case 9833:  // Bambu A1: M9833.2 at the top of its start code
      return true;
    default:
      return code >= 960 && code <= 991;  // Bambu: lidar, vibration and flow calibrations
  }
}
}  // namespace

Status GcodeInterpreter::execute_m(const GcodeCommand& c, std::string_view text,
                                   InterpreterOutput& out) {
  const double unit = inches_ ? kInch_mm : 1.0;
  switch (c.code) {
    case 82:
      relative_e_ = e_mode_relative_ = false;
      return Ok{};
    case 83:
      relative_e_ = e_mode_relative_ = true;
      return Ok{};
    case 104:
    case 109:
    case 140:
    case 190:
      return set_temperature(c, text, out);
    case 200: {
      // M200 D<diameter> enables volumetric E (D0 or S0 disables).
      if (c.has('S') && c.get('S') == 0) volumetric_area_mm2_ = 0;
      if (c.has('D')) {
        const double dia = c.get('D') * unit;
        if (dia < 0 || dia > 10)
          return warn(c.line, text, "filament diameter outside 0..10 mm; ignored", "bad_parameter");
        volumetric_area_mm2_ = dia > 0 ? 0.25 * kPi * dia * dia : 0;
      }
      return Ok{};
    }
    case 201:
    case 203:
    case 205:
      return set_axis_limits(c, text, out);
    case 116:
      // RepRapFirmware M116: wait for every heater to reach its target.
      heat_wait(false, bed_target_c_, false, c.line, out);
      for (int i = 0; i < kMaxTools; ++i)
        if (i == heater_of_tool(i))
          heat_wait(true, hotends_[static_cast<std::size_t>(i)].target_c, false, c.line, out, i);
      return Ok{};
    case 566:
      return set_rrf_jerk(c, text, out);
    case 207:
    case 208:
      set_retraction(c);
      return Ok{};
    case 302: {
      // M302 S<C>: minimum extrusion temperature; M302 P1: cold extrusion allowed.
      if (c.has('S') && c.get('S') >= 0 && c.get('S') <= 500) min_extrude_temp_c_ = c.get('S');
      if (c.has('P')) min_extrude_temp_c_ = c.get('P') > 0 ? -1000.0 : profile_.min_extrude_temp_c;
      return Ok{};
    }
    case 862:
      return prusa_printer_check(c, text);
    case 0:
    case 1:
    case 601:
    case 600:
      if (c.code == 0 && flavour_ == Flavour::rrf) {
        // RepRapFirmware M0: stop the print; the heaters go off.
        out.synchronize();
        set_hotend_target(profile_.ambient_temp_c);
        set_bed_target(profile_.ambient_temp_c);
        return Ok{};
      }
      // Marlin M0/M1, Prusa M601, M600 filament change: the printer waits for the user.
      note("user_pause",
           command_name(c) +
               " pauses the print until the user resumes it: the "
               "wait is not counted in the print time",
           c.line);
      out.synchronize();
      return Ok{};
    case 204:
      return set_acceleration(c, text, out);
    case 220: {
      if (c.has_value('S')) {
        const double s = c.get('S');
        if (s <= 0 || s > 1000)
          return warn(c.line, text, "feedrate percentage outside 1..1000; ignored",
                      "bad_parameter");
        limits_.feedrate_scale = s / 100.0;
        out.limits(limits_);
      }
      return Ok{};
    }
    case 211:
      soft_endstops(c, true);
      return Ok{};
    case 221: {
      // Flow only with a number, as Marlin reads it. Bambu's firmware also takes "M221 S"
      // (push the soft endstops' state), "M221 R" (pop it) and "M221 X0 Y0 Z0" (soft
      // endstops off), as its M211: no flow change.
      soft_endstops(c, false);
      if (c.has_value('S')) {
        const double s = c.get('S');
        if (s < 0 || s > 1000)
          return warn(c.line, text, "flow percentage outside 0..1000; ignored", "bad_parameter");
        flow_ = s / 100.0;
        if (s != 100)
          note("flow_override",
               "M221 S" + format_fixed(s, s == std::floor(s) ? 0 : 2) +
                   " scales every extrusion after it (the firmware's flow factor): the twin "
                   "lays that share of the E the file commands, while the slicer's filament "
                   "figure counts the E as written",
               c.line);
      }
      return Ok{};
    }
    case 400:
      out.synchronize();
      // Bambu: M400 S<s> / P<ms> waits that long after the moves end (its start code
      // settles the nozzle with "M400 S7").
      if (flavour_ == Flavour::bambu && (c.has('S') || c.has('P'))) {
        const double s = c.has('S') ? c.get('S') : c.get('P') / 1000.0;
        if (s > 0 && s < 3600) {
          out.wait(s, false, c.line);
          nominal_clock_s_ += s;
        }
      }
      return Ok{};
    case 486: {
      if (c.has('S')) {
        const double s = c.get('S');
        object_id_ = s < 0 ? -1 : static_cast<int>(std::min(s, 1e6));
      }
      return Ok{};
    }
    default:
      return ignored_m_code(c.code) ? Status(Ok{}) : unknown_command(c);
  }
}

/// M211 (and Bambu's M221 forms without a flow): software endstops. S0/S1 switch every axis
/// (Marlin's M211; `s_switches_all`), X0/Y0/Z0 switch axes, a bare S pushes the state and R
/// pops it (Bambu's firmware).
void GcodeInterpreter::soft_endstops(const GcodeCommand& c, bool s_switches_all) {
  if (c.has('S') && !c.has_value('S'))
    soft_endstop_stack_.push_back(soft_endstops_);
  else if (s_switches_all && c.has_value('S'))
    soft_endstops_.fill(c.get('S') != 0);
  if (c.has('R') && !soft_endstop_stack_.empty()) {
    soft_endstops_ = soft_endstop_stack_.back();
    soft_endstop_stack_.pop_back();
  }
  static constexpr char kAxes[3] = {'X', 'Y', 'Z'};
  for (std::size_t i = 0; i < 3; ++i)
    if (c.has_value(kAxes[i])) soft_endstops_[i] = c.get(kAxes[i]) != 0;
}

/// M104/M109 (hotend) and M140/M190 (bed): set the target, and for M109/M190 wait for it.
Status GcodeInterpreter::set_temperature(const GcodeCommand& c, std::string_view text,
                                         InterpreterOutput& out) {
  if (!c.has('S') && !c.has('R')) return Ok{};
  const double t = c.has('S') ? c.get('S') : c.get('R');
  const bool hotend = c.code == 104 || c.code == 109;
  if (hotend && (t < 0 || t > 500))
    return warn(c.line, text, "hotend temperature outside 0..500 C; ignored", "bad_temperature");
  if (!hotend && (t < 0 || t > 200))
    return warn(c.line, text, "bed temperature outside 0..200 C; ignored", "bad_temperature");
  // M104/M109 T<n>: the heater of tool n (Marlin's get_target_extruder_from_command), not
  // necessarily the active one (Prusa XL, Cura's dual-extrusion standby temperatures).
  int heater = active_heater();
  if (hotend && c.has_value('T')) {
    heater = heater_of_tool(std::lround(c.get('T')));
    if (heater < 0)
      return warn(c.line, text, "no hotend T" + format_fixed(c.get('T'), 0) + "; ignored",
                  "bad_tool");
  }
  if (c.code == 104) {
    set_hotend_target(t, heater);
    return Ok{};
  }
  if (c.code == 140) {
    set_bed_target(t);
    return Ok{};
  }
  heat_wait(hotend, t, c.has('R'), c.line, out, hotend ? heater : -1);
  return Ok{};
}

/// M201 (acceleration), M203 (feedrate), M205 (jerk, junction deviation, minimum speeds).
Status GcodeInterpreter::set_axis_limits(const GcodeCommand& c, std::string_view text,
                                         InterpreterOutput& out) {
  const double unit = inches_ ? kInch_mm : 1.0;
  // Klipper has no M201/M203/M205: it answers "Unknown command" and keeps its
  // [printer] limits (SET_VELOCITY_LIMIT changes them).
  if (flavour_ == Flavour::klipper) {
    note("klipper_ignores",
         command_name(c) +
             " is not a Klipper command: Klipper keeps its "
             "configured limits (SET_VELOCITY_LIMIT changes them)",
         c.line);
    return Ok{};
  }
  static constexpr char kAxes[4] = {'X', 'Y', 'Z', 'E'};
  for (int i = 0; i < 4; ++i) {
    if (!c.has(kAxes[i])) continue;
    const double v = c.get(kAxes[i]) * unit;
    if (c.code == 205 ? v < 0 : v <= 0)
      return warn(c.line, text, "limit must be positive; ignored", "bad_parameter");
    if (c.code == 201)
      limits_.max_accel_mm_s2[i] = v;
    else if (c.code == 203)
      limits_.max_feedrate_mm_s[i] = flavour_ == Flavour::rrf ? v / 60.0 : v;  // RRF: mm/min
    else
      limits_.jerk_mm_s[i] = v;
  }
  if (c.code == 205) {
    if (c.has('J') && c.get('J') > 0 && c.get('J') <= 10)
      limits_.junction_deviation_mm = c.get('J');
    if (c.has('S') && c.get('S') >= 0) limits_.min_feedrate_mm_s = c.get('S') * unit;
    if (c.has('T') && c.get('T') >= 0) limits_.min_travel_feedrate_mm_s = c.get('T') * unit;
    if (c.has('B') && c.get('B') >= 0) limits_.min_segment_time_s = c.get('B') * 1e-6;
  }
  out.limits(limits_);
  return Ok{};
}

/// RepRapFirmware M566: maximum instantaneous speed change ("jerk") per axis, in mm/min.
Status GcodeInterpreter::set_rrf_jerk(const GcodeCommand& c, std::string_view text,
                                      InterpreterOutput& out) {
  const double unit = inches_ ? kInch_mm : 1.0;
  static constexpr char kAxes[4] = {'X', 'Y', 'Z', 'E'};
  for (int i = 0; i < 4; ++i) {
    if (!c.has(kAxes[i])) continue;
    const double jerk = c.get(kAxes[i]) * unit / 60.0;
    if (jerk < 0) return warn(c.line, text, "jerk must not be negative; ignored", "bad_parameter");
    limits_.jerk_mm_s[i] = jerk;
  }
  out.limits(limits_);
  return Ok{};
}

/// Firmware retraction settings. M207: S length, F speed (mm/min), Z lift; RRF adds
/// R extra unretract and T unretract speed. M208 (Marlin): S extra, F unretract speed.
void GcodeInterpreter::set_retraction(const GcodeCommand& c) {
  const double unit = inches_ ? kInch_mm : 1.0;
  if (c.code == 207) {
    if (c.has('S') && c.get('S') >= 0) fw_length_mm_ = c.get('S') * unit;
    if (c.has('F') && c.get('F') > 0) fw_speed_mm_s_ = c.get('F') * unit / 60.0;
    if (c.has('Z') && c.get('Z') >= 0) fw_zraise_mm_ = c.get('Z') * unit;
    if (c.has('R') && c.get('R') >= 0) fw_recover_extra_mm_ = c.get('R') * unit;
    if (c.has('T') && c.get('T') > 0) fw_recover_speed_mm_s_ = c.get('T') * unit / 60.0;
  } else {
    if (c.has('S') && c.get('S') >= 0) fw_recover_extra_mm_ = c.get('S') * unit;
    if (c.has('F') && c.get('F') > 0) fw_recover_speed_mm_s_ = c.get('F') * unit / 60.0;
  }
}

/// Prusa firmware's checks: M862.1 P<nozzle diameter>, M862.3 P"<model>". The firmware
/// warns when the G-code was sliced for another nozzle or printer.
Status GcodeInterpreter::prusa_printer_check(const GcodeCommand& c, std::string_view text) {
  if (flavour_ == Flavour::prusa && c.subcode == 1 && c.has('P') &&
      std::fabs(c.get('P') - profile_.nozzle_diameter_mm) > 0.005)
    return warn(c.line, text,
                "the G-code was sliced for a " + format_fixed(c.get('P'), 2) +
                    " mm nozzle, the printer has " + format_fixed(profile_.nozzle_diameter_mm, 2) +
                    " mm: extrusion widths and flow will be off",
                "nozzle_mismatch");
  if (flavour_ == Flavour::prusa && c.subcode == 3 && !c.args.empty() && !profile_.model.empty()) {
    auto lower = [](std::string_view v) {
      std::string folded;
      for (char ch : v)
        if (ch != ' ')
          folded.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(ch))));
      return folded;
    };
    // Lenient: "MK4S" matches a profile model "Original Prusa MK4S".
    const std::string want = lower(c.args), have = lower(profile_.model);
    if (have.find(want) == std::string::npos && want.find(have) == std::string::npos)
      return warn(c.line, text,
                  "the G-code was sliced for a " + std::string(c.args) + ", the printer is a " +
                      profile_.model + ": Prusa firmware warns before printing",
                  "printer_model_mismatch");
  }
  return Ok{};
}

/// M204: S (print and travel), P (print), R (retract), T (travel) accelerations, each capped
/// by the estimator's machine limits; Klipper's own rule for Klipper.
Status GcodeInterpreter::set_acceleration(const GcodeCommand& c, std::string_view text,
                                          InterpreterOutput& out) {
  const double unit = inches_ ? kInch_mm : 1.0;
  if (flavour_ == Flavour::klipper) return klipper_m204(c, text, out);
  auto take = [&](char p, double& dst, double cap) -> Status {
    const double v = c.get(p) * unit;
    if (v <= 0)
      return warn(c.line, text, "acceleration must be positive; ignored", "bad_parameter");
    dst = std::min(v, cap);
    return Ok{};
  };
  const auto& cap = limits_.accel_cap_mm_s2;
  if (c.has('S')) {  // Marlin 2.1: S sets print and travel
    if (auto st = take('S', limits_.print_accel_mm_s2, cap[0]); !st) return st;
    limits_.travel_accel_mm_s2 = std::min(limits_.print_accel_mm_s2, cap[2]);
  }
  if (c.has('P'))
    if (auto st = take('P', limits_.print_accel_mm_s2, cap[0]); !st) return st;
  if (c.has('R'))
    if (auto st = take('R', limits_.retract_accel_mm_s2, cap[1]); !st) return st;
  if (c.has('T'))
    if (auto st = take('T', limits_.travel_accel_mm_s2, cap[2]); !st) return st;
  out.limits(limits_);
  return Ok{};
}

Result<MotionLimits> limits_from_prusaslicer_config(std::string_view text,
                                                    const MotionLimits& base) {
  MotionLimits l = base;
  int found = 0;
  bool orca_keys = false;  // machine_max_speed_*: OrcaSlicer, Bambu Studio, Creality Print
  double extruding = 0, retracting = 0, travel = 0, min_extruding = 0, min_travel = 0;
  std::string_view flavor;
  bool emitted = true;  // PrusaSlicer's machine_limits_usage (absent: Orca's family emits them)
  std::size_t pos = 0;
  // The axis letter after `prefix`, as an index X Y Z E; -1 when `key` is not prefix + axis.
  auto axis_of = [](std::string_view key, std::string_view prefix) {
    if (key.size() != prefix.size() + 1 || key.substr(0, prefix.size()) != prefix) return -1;
    const auto i = std::string_view("xyze").find(key.back());
    return i == std::string_view::npos ? -1 : static_cast<int>(i);
  };
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string_view line = text.substr(pos, eol - pos);
    pos = eol + 1;
    if (starts_with(line, "; gcode_flavor = ")) {
      flavor = line.substr(17);
      continue;
    }
    if (starts_with(line, "; machine_limits_usage = ")) {
      emitted = line.substr(25) == "emit_to_gcode";
      continue;
    }
    if (!starts_with(line, "; machine_")) continue;
    line.remove_prefix(2);
    const auto eq = line.find(" = ");
    if (eq == std::string_view::npos) continue;
    const std::string_view key = line.substr(0, eq);
    std::string_view value = line.substr(eq + 3);
    value = value.substr(0, value.find(','));  // "1500,1250": normal mode first
    double v = 0;
    if (!parse_double(value, v) || v < 0) continue;
    if (const int i = axis_of(key, "machine_max_acceleration_"); i >= 0) {
      if (v > 0) l.max_accel_mm_s2[i] = v, ++found;
    } else if (const int f = axis_of(key, "machine_max_feedrate_"); f >= 0) {
      if (v > 0) l.max_feedrate_mm_s[f] = v, ++found;
    } else if (const int o = axis_of(key, "machine_max_speed_"); o >= 0) {
      if (v > 0) l.max_feedrate_mm_s[o] = v, ++found;
      orca_keys = true;
    } else if (const int j = axis_of(key, "machine_max_jerk_"); j >= 0) {
      l.jerk_mm_s[j] = v, ++found;
    } else if (key == "machine_max_acceleration_extruding") {
      extruding = v, ++found;
    } else if (key == "machine_max_acceleration_retracting") {
      retracting = v, ++found;
    } else if (key == "machine_max_acceleration_travel") {
      travel = v, ++found;
    } else if (key == "machine_min_extruding_rate") {
      min_extruding = v;
    } else if (key == "machine_min_travel_rate") {
      min_travel = v;
    }
  }
  if (found < 12)
    return bad_input(
        "no slicer machine limits (\"; machine_max_acceleration_x = ...\") in the G-code; "
        "--limits-from-gcode needs the config block of PrusaSlicer, SuperSlicer, OrcaSlicer, "
        "Bambu Studio or Creality Print");
  // PrusaSlicer's defaults when a value is 0 (GCodeProcessor: DEFAULT_ACCELERATION 1500,
  // DEFAULT_RETRACT_ACCELERATION 1500, DEFAULT_TRAVEL_ACCELERATION 1250).
  // The estimators keep machine_max_acceleration_travel only for the flavours whose
  // firmware has a travel acceleration of its own (M204 T: Marlin 2, RepRapFirmware,
  // Repetier) and, in PrusaSlicer, only when the limits are emitted to the G-code; otherwise
  // (Klipper, Marlin 1, time_estimate_only...) travel runs at what M204 S or
  // SET_VELOCITY_LIMIT ACCEL last set, unclamped, and at 1250 mm/s^2 until then.
  const bool separate_travel = emitted && (flavor.empty() || flavor == "marlin2" ||
                                           flavor == "reprapfirmware" || flavor == "repetier");
  if (!separate_travel) travel = 0;
  l.print_accel_mm_s2 = extruding > 0 ? extruding : 1500;
  l.retract_accel_mm_s2 = retracting > 0 ? retracting : 1500;
  l.travel_accel_mm_s2 = travel > 0 ? travel : 1250;
  l.accel_cap_mm_s2 =
      Eigen::Vector3d(extruding > 0 ? extruding : std::numeric_limits<double>::infinity(),
                      retracting > 0 ? retracting : std::numeric_limits<double>::infinity(),
                      travel > 0 ? travel : std::numeric_limits<double>::infinity());
  l.min_feedrate_mm_s = min_extruding;
  l.min_travel_feedrate_mm_s = min_travel;
  l.junction = JunctionModel::classic_jerk;
  l.prusaslicer_compat = true;
  // OrcaSlicer's family (Bambu Studio, Creality Print) names the speeds machine_max_speed_*
  // and estimates with Bambu's changes to PrusaSlicer's planner; SET_VELOCITY_LIMIT
  // SQUARE_CORNER_VELOCITY replaces its X/Y jerk.
  l.orca_compat = orca_keys;
  if (orca_keys) l.square_corner_velocity_mm_s = l.jerk_mm_s[0];
  // Bambu Studio's header line "; BambuStudio 01.10.02.76" (OrcaSlicer and Creality Print
  // write "; generated by ...").
  l.bambu_junction = orca_keys && (starts_with(text, "; BambuStudio ") ||
                                   text.find("\n; BambuStudio ") != std::string_view::npos);
  l.klipper = false;
  l.min_segment_time_s = 0;
  return l;
}

}  // namespace printtwin
