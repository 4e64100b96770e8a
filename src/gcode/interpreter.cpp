// The firmware's G-code interpreter: Marlin 2.1's modal state turned into Moves.
// References for behaviour (not code): Marlin gcode/motion/G0_G1.cpp, G2_G3.cpp (plan_arc),
// G28.cpp + module/motion.cpp (homing, soft endstops), gcode/config/M200-M205.cpp,
// gcode/temp/M104_M109.cpp, module/planner.cpp (PREVENT_COLD_EXTRUSION / LENGTHY_EXTRUDE).
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

bool starts_with(std::string_view s, std::string_view p) { return s.substr(0, p.size()) == p; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool parse_double(std::string_view s, double& v) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && std::isfinite(v);
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
      slicer_estimate_s_(std::numeric_limits<double>::quiet_NaN()) {
  Vec3 power_on(profile.bed_center_x_mm(), profile.bed_center_y_mm(), 10.0);
  for (int i = 0; i < 3; ++i)
    if (!std::isnan(options.power_on_position_mm[i])) power_on[i] = options.power_on_position_mm[i];
  // Marlin boots believing it is at 0,0,0: the machine position differs by an offset.
  offset_mm_ = power_on;
  logical_mm_ = Vec3::Zero();
  feedrate_mm_s_ = kDefaultFeedrate_mm_s;
  const double hot = std::isnan(options.power_on_hotend_c) ? profile.ambient_temp_c : options.power_on_hotend_c;
  const double bed = std::isnan(options.power_on_bed_c) ? profile.ambient_temp_c : options.power_on_bed_c;
  hotend_target_c_ = hotend_c_at_set_ = hot;
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

Status GcodeInterpreter::warn(long line, std::string_view text, std::string message, std::string code) {
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

Status GcodeInterpreter::finish(bool ended_mid_line, long last_line) {
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

double GcodeInterpreter::hotend_temp_now() const {
  const double dt = nominal_clock_s_ - hotend_set_clock_s_;
  const double rate = profile_.hotend_heat_rate_c_s;
  if (hotend_target_c_ >= hotend_c_at_set_)
    return std::min(hotend_target_c_, hotend_c_at_set_ + rate * dt);
  return std::max(hotend_target_c_, hotend_c_at_set_ - rate * dt);
}

void GcodeInterpreter::heat_wait(bool hotend, double target_c, bool wait_cooling, long line,
                                 InterpreterOutput& out) {
  const double rate = hotend ? profile_.hotend_heat_rate_c_s : profile_.bed_heat_rate_c_s;
  double& target = hotend ? hotend_target_c_ : bed_target_c_;
  double& at_set = hotend ? hotend_c_at_set_ : bed_c_at_set_;
  double& set_clock = hotend ? hotend_set_clock_s_ : bed_set_clock_s_;
  // Temperature now (linear ramp since the last set).
  const double dt = nominal_clock_s_ - set_clock;
  double now = target >= at_set ? std::min(target, at_set + rate * dt) : std::max(target, at_set - rate * dt);
  target = target_c;
  double wait_s = 0;
  if (target_c > now) wait_s = (target_c - now) / rate;
  else if (wait_cooling && target_c < now) wait_s = (now - target_c) / rate;
  out.synchronize();
  if (wait_s > 0) out.wait(wait_s, true, line);
  nominal_clock_s_ += wait_s;
  at_set = (wait_s > 0) ? target_c : now;
  set_clock = nominal_clock_s_;
}

void GcodeInterpreter::comment(std::string_view c) {
  // Slicer tags. Z never comes from comments (layers are made by the Z of extrusions).
  if (c.empty()) return;
  switch (c.front()) {
    case 'T':
      if (starts_with(c, "TYPE:")) feature_ = feature_from_label(c.substr(5));
      else if (starts_with(c, "TIME:") && slicer_.empty()) {}
      return;
    case 'F':
      if (starts_with(c, "FEATURE:")) feature_ = feature_from_label(trim(c.substr(8)));
      return;
    case 'W':
      if (starts_with(c, "WIDTH:")) {
        double w = 0;
        if (parse_double(c.substr(6), w) && w > 0 && w < 100) width_hint_mm_ = static_cast<float>(w);
      }
      return;
    case 'L':
      if (starts_with(c, "LINE_WIDTH:")) {
        double w = 0;
        if (parse_double(c.substr(11), w) && w > 0 && w < 100) width_hint_mm_ = static_cast<float>(w);
      } else if (starts_with(c, "LAYER:")) {
        // Cura: its start G-code (purge lines) ends at the first ;LAYER: tag.
        if (feature_ == Feature::custom && starts_with(slicer_, "Cura")) feature_ = Feature::unknown;
      } else if (starts_with(c, "LAYER_HEIGHT:")) {
        double h = 0;
        if (parse_double(c.substr(13), h) && h > 0 && h < 100) height_hint_mm_ = static_cast<float>(h);
      }
      return;
    case 'H':
      if (starts_with(c, "HEIGHT:")) {
        double h = 0;
        if (parse_double(c.substr(7), h) && h > 0 && h < 100) height_hint_mm_ = static_cast<float>(h);
      }
      return;
    case 'M':
      if (starts_with(c, "MESH:")) {
        const std::string name(trim(c.substr(5)));
        if (name == "NONMESH") {
          object_id_ = -1;
        } else {
          auto [it, inserted] = object_names_.try_emplace(name, static_cast<int>(object_names_.size()));
          object_id_ = it->second;
        }
      }
      return;
    case 'p':
      if (starts_with(c, "printing object ")) {
        // PrusaSlicer: "; printing object cube.stl id:0 copy 0"
        const std::string name(trim(c.substr(16)));
        auto [it, inserted] = object_names_.try_emplace(name, static_cast<int>(object_names_.size()));
        object_id_ = it->second;
      }
      return;
    case 's':
      if (starts_with(c, "stop printing object")) object_id_ = -1;
      return;
    case 'g':
    case 'G':
      if (slicer_.empty()) {
        // "; generated by PrusaSlicer 2.5.0 on ...", ";Generated with Cura_SteamEngine 4.13.0"
        for (std::string_view prefix : {"generated by ", "Generated with ", "generated with "}) {
          if (starts_with(c, prefix)) {
            std::string_view rest = c.substr(prefix.size());
            const auto on = rest.find(" on ");
            slicer_ = std::string(trim(rest.substr(0, on)));
            // Cura tags nothing before ;LAYER:0: what comes before is its start G-code.
            if (starts_with(slicer_, "Cura")) feature_ = Feature::custom;
            break;
          }
        }
      }
      return;
    case 'e':
      if (starts_with(c, "estimated printing time (normal mode) = "))
        slicer_estimate_s_ = parse_duration(c.substr(40));
      return;
    default:
      return;
  }
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
    bool unhomed_motion = false;
    for (int i = 0; i < 3; ++i)
      if (!homed_[static_cast<std::size_t>(i)] && std::fabs(target[i] - start[i]) > 1e-9) unhomed_motion = true;
    if (unhomed_motion && !reported_before_homing_) {
      reported_before_homing_ = true;
      Finding f;
      f.severity = Severity::warning;
      f.code = "move_before_homing";
      f.message = "move before the axes were homed (G28): the printer does not know where it is; "
                  "first such move \"" + excerpt(text) + "\"";
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
        const double c = std::clamp(target[i], lo[i], hi[i]);
        if (homed_[ui] && profile_.software_endstops) clamped = true;
        else crashed = true;
        target[i] = c;
      }
    }
    if (clamped || crashed) {
      Finding f;
      f.severity = crashed ? Severity::error : Severity::warning;
      f.code = crashed ? "hits_frame" : "out_of_bounds";
      f.message = std::string(crashed ? "move drives an unhomed axis into the frame"
                                      : "move leaves the build volume; software endstops clamp it") +
                  ": requested (" + format_fixed(requested.x(), 3) + ", " + format_fixed(requested.y(), 3) +
                  ", " + format_fixed(requested.z(), 3) + ") mm, travel is (" + format_fixed(lo.x(), 1) + ".." +
                  format_fixed(hi.x(), 1) + ", " + format_fixed(lo.y(), 1) + ".." + format_fixed(hi.y(), 1) +
                  ", " + format_fixed(lo.z(), 1) + ".." + format_fixed(hi.z(), 1) + ") mm";
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
      f.message = "E changes by " + format_fixed(e_mm, 2) + " mm in one move (more than Marlin's "
                  "EXTRUDE_MAXLENGTH " + format_fixed(kExtrudeMaxLength_mm, 0) +
                  " mm); the firmware drops the E part";
      f.line = line;
      f.position_mm = start;
      f.value = e_mm;
      add_finding(std::move(f));
      e_mm = 0;
    } else if (hotend_temp_now() < profile_.min_extrude_temp_c) {
      Finding f;
      f.severity = Severity::error;
      f.code = "cold_extrusion";
      f.message = "extrusion with the hotend at " + format_fixed(hotend_temp_now(), 0) +
                  " C, below the minimum " + format_fixed(profile_.min_extrude_temp_c, 0) + " C" +
                  (options_.prevent_cold_extrusion ? "; the firmware drops the E part" : "");
      f.line = line;
      f.position_mm = start;
      f.value = hotend_temp_now();
      if (layer_ >= 0) f.layer = layer_;
      add_finding(std::move(f));
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
  if (is_forced) m.kind = forced;
  else if (e_mm > 0) m.kind = xyz > 1e-9 ? MoveKind::extrude : MoveKind::unretract;
  else if (e_mm < 0) m.kind = MoveKind::retract;
  else m.kind = MoveKind::travel;

  // Layers are made by the Z of extrusions; start/end code (purge lines, tagged custom)
  // joins the current layer instead of making one.
  if (m.kind == MoveKind::extrude && feature_ != Feature::custom) {
    const double z = target.z();
    if (layer_ < 0 || std::fabs(layer_z_[static_cast<std::size_t>(layer_)] - z) > kLayerZTolerance_mm) {
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
      auto st = warn(c.line, text, "feedrate F must be positive; previous feedrate kept", "bad_feedrate");
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
    de = relative_e_ ? v : v - e_logical_mm_;
    e_logical_mm_ += de;
  }
  return Ok{};
}

Status GcodeInterpreter::linear_move(const GcodeCommand& c, std::string_view text, InterpreterOutput& out) {
  Vec3 target;
  double de = 0;
  if (auto st = motion_words(c, text, target, de); !st) return st;
  emit(target, de, feedrate_mm_s_, MoveKind::travel, false, c.line, text, out);
  return Ok{};
}

Status GcodeInterpreter::arc_move(const GcodeCommand& c, std::string_view text, InterpreterOutput& out) {
  const double unit = inches_ ? kInch_mm : 1.0;
  const bool clockwise = c.code == 2;
  Vec3 target;
  double de = 0;
  if (auto st = motion_words(c, text, target, de); !st) return st;
  // Centre offset from the start: I/J, or from the radius R (Marlin G2_G3.cpp).
  Vec2 offset(c.get('I') * unit, c.get('J') * unit);
  const Vec2 p1 = logical_mm_.head<2>(), p2 = target.head<2>();
  if (c.has('R')) {
    const double r = c.get('R') * unit;
    if (r == 0 || (p1 - p2).norm() < 1e-9)
      return warn(c.line, text, "arc with R needs a non-zero radius and distinct end points; ignored",
                  "bad_arc");
    const Vec2 d2 = 0.5 * (p2 - p1);
    const double e = (clockwise ^ (r < 0)) ? -1.0 : 1.0;
    const double len = d2.norm();
    const double h2 = (r - len) * (r + len);
    const double h = h2 >= 0 ? std::sqrt(h2) : 0.0;
    const Vec2 s(-d2.y(), d2.x());
    offset = d2 + s / len * e * h;
  } else if (!c.has('I') && !c.has('J')) {
    return warn(c.line, text, "arc without I, J or R; ignored", "bad_arc");
  }
  const double rp = -offset.x(), rq = -offset.y();  // centre -> start
  const double radius = std::hypot(rp, rq);
  const Vec2 center = p1 - Vec2(rp, rq);
  const double rtx = p2.x() - center.x(), rty = p2.y() - center.y();
  double angular = std::atan2(rp * rty - rq * rtx, rp * rtx + rq * rty);
  if (angular < 0) angular += 2 * kPi;
  if (clockwise) angular -= 2 * kPi;
  if (angular == 0 && (p1 - p2).norm() < 1e-12) angular = clockwise ? -2 * kPi : 2 * kPi;
  const double dz = target.z() - logical_mm_.z();
  const double flat = radius * std::fabs(angular);
  const double travel = std::hypot(flat, dz);
  if (travel < 0.001) return Ok{};
  if (radius > 1e6) return warn(c.line, text, "arc radius too large; ignored", "bad_arc");
  // Segment length like Marlin: a circle has at least arc_min_segments_per_circle segments,
  // each between arc_min_segment_mm and arc_max_segment_mm.
  const double seg = std::clamp(radius * 2 * kPi / profile_.arc_min_segments_per_circle,
                                profile_.arc_min_segment_mm, profile_.arc_max_segment_mm);
  // Klipper's [gcode_arcs] takes floor(length / resolution) segments; Marlin rounds.
  const double n_seg = travel / seg;
  const long segments = std::max(1L, profile_.firmware == "klipper" ? static_cast<long>(std::floor(n_seg))
                                                                     : std::lround(n_seg));
  if (segments > 20000) return warn(c.line, text, "arc needs more than 20000 segments; ignored", "bad_arc");
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
    emit(p, de / static_cast<double>(segments), feedrate_mm_s_, MoveKind::travel, false, c.line, text, out);
  }
  return Ok{};
}

Status GcodeInterpreter::home(const GcodeCommand& c, InterpreterOutput& out) {
  // G28 [X] [Y] [Z]: the homing state machine of the seed's printer, made faithful to
  // Marlin: quick diagonal XY approach (QUICK_HOME), then per axis fast approach, bump back,
  // slow re-approach at homing_feedrate / bump_divisor. Z last.
  bool axis[3] = {c.has('X'), c.has('Y'), c.has('Z')};
  if (!axis[0] && !axis[1] && !axis[2]) axis[0] = axis[1] = axis[2] = true;
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
    go(p, fr[i]);                                   // fast approach
    p[i] = lo[i] + profile_.homing_bump_mm[i];
    go(p, fr[i]);                                   // bump back
    p[i] = lo[i];
    go(p, fr[i] / profile_.homing_bump_divisor[i]); // slow re-approach
    homed_[ui] = true;
    offset_mm_[i] = 0;                              // G28 clears the G92 shift
    logical_mm_[i] = lo[i];
  }
  return Ok{};
}

Status GcodeInterpreter::execute(const GcodeCommand& c, std::string_view text, InterpreterOutput& out) {
  last_line_ = c.line;
  if (c.letter == 0) {
    if (c.word.empty()) {
      comment(c.comment);
      return Ok{};
    }
    const std::string_view w = c.word;
    if (w == "EXCLUDE_OBJECT_START") {
      const auto pos = c.args.find("NAME=");
      const std::string name(pos == std::string_view::npos ? c.args : trim(c.args.substr(pos + 5)));
      auto [it, inserted] = object_names_.try_emplace(name, static_cast<int>(object_names_.size()));
      object_id_ = it->second;
      return Ok{};
    }
    if (w == "EXCLUDE_OBJECT_END") {
      object_id_ = -1;
      return Ok{};
    }
    if (w == "EXCLUDE_OBJECT_DEFINE" || w == "SET_PRINT_STATS_INFO") return Ok{};
    if (++unknown_[std::string(w)] == 1) unknown_first_line_[std::string(w)] = c.line;
    return Ok{};
  }

  const double unit = inches_ ? kInch_mm : 1.0;
  if (c.letter == 'G') {
    switch (c.code) {
      case 0:
      case 1: return linear_move(c, text, out);
      case 2:
      case 3: return arc_move(c, text, out);
      case 4: {
        double s = c.has('S') ? c.get('S') : c.get('P') / 1000.0;
        if (s < 0) return warn(c.line, text, "negative dwell; ignored", "bad_dwell");
        out.synchronize();
        if (s > 0) out.wait(s, false, c.line);
        nominal_clock_s_ += s;
        return Ok{};
      }
      case 10:
      case 11: {
        if (!profile_.firmware_retraction) {
          if (++unknown_[command_name(c)] == 1) unknown_first_line_[command_name(c)] = c.line;
          return Ok{};
        }
        const bool retract = c.code == 10;
        if (retract == fw_retracted_) return Ok{};
        fw_retracted_ = retract;
        const double len = profile_.fw_retract_length_mm;
        const double speed = retract ? profile_.fw_retract_speed_mm_s : profile_.fw_recover_speed_mm_s;
        Vec3 t = logical_mm_;
        if (profile_.fw_retract_zraise_mm > 0 && retract) {
          emit(t, -len, speed, MoveKind::travel, false, c.line, text, out);
          t.z() += profile_.fw_retract_zraise_mm;
          emit(t, 0, speed, MoveKind::travel, false, c.line, text, out);
        } else if (profile_.fw_retract_zraise_mm > 0) {
          t.z() -= profile_.fw_retract_zraise_mm;
          emit(t, 0, speed, MoveKind::travel, false, c.line, text, out);
          emit(t, len, speed, MoveKind::travel, false, c.line, text, out);
        } else {
          emit(t, retract ? -len : len, speed, MoveKind::travel, false, c.line, text, out);
        }
        return Ok{};
      }
      case 17: return Ok{};
      case 18:
      case 19: return warn(c.line, text, "only the XY plane (G17) is supported for arcs", "unsupported_plane");
      case 20: inches_ = true; return Ok{};
      case 21: inches_ = false; return Ok{};
      case 28: return home(c, out);
      case 90: relative_xyz_ = relative_e_ = false; return Ok{};
      case 91: relative_xyz_ = relative_e_ = true; return Ok{};
      case 92: {
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
        return Ok{};
      }
      default: break;
    }
  } else if (c.letter == 'M') {
    switch (c.code) {
      case 82: relative_e_ = false; return Ok{};
      case 83: relative_e_ = true; return Ok{};
      case 104:
      case 109: {
        if (!c.has('S') && !c.has('R')) return Ok{};
        const double t = c.has('S') ? c.get('S') : c.get('R');
        if (t < 0 || t > 500) return warn(c.line, text, "hotend temperature outside 0..500 C; ignored", "bad_temperature");
        if (c.code == 104) {
          hotend_c_at_set_ = hotend_temp_now();
          hotend_target_c_ = t;
          hotend_set_clock_s_ = nominal_clock_s_;
          return Ok{};
        }
        heat_wait(true, t, c.has('R'), c.line, out);
        return Ok{};
      }
      case 140:
      case 190: {
        if (!c.has('S') && !c.has('R')) return Ok{};
        const double t = c.has('S') ? c.get('S') : c.get('R');
        if (t < 0 || t > 200) return warn(c.line, text, "bed temperature outside 0..200 C; ignored", "bad_temperature");
        if (c.code == 140) {
          const double dt = nominal_clock_s_ - bed_set_clock_s_;
          const double rate = profile_.bed_heat_rate_c_s;
          bed_c_at_set_ = bed_target_c_ >= bed_c_at_set_ ? std::min(bed_target_c_, bed_c_at_set_ + rate * dt)
                                                         : std::max(bed_target_c_, bed_c_at_set_ - rate * dt);
          bed_target_c_ = t;
          bed_set_clock_s_ = nominal_clock_s_;
          return Ok{};
        }
        heat_wait(false, t, c.has('R'), c.line, out);
        return Ok{};
      }
      case 200: {
        // M200 D<diameter> enables volumetric E (D0 or S0 disables).
        if (c.has('S') && c.get('S') == 0) volumetric_area_mm2_ = 0;
        if (c.has('D')) {
          const double dia = c.get('D') * unit;
          if (dia < 0 || dia > 10) return warn(c.line, text, "filament diameter outside 0..10 mm; ignored", "bad_parameter");
          volumetric_area_mm2_ = dia > 0 ? 0.25 * kPi * dia * dia : 0;
        }
        return Ok{};
      }
      case 201:
      case 203:
      case 205: {
        static constexpr char kAxes[4] = {'X', 'Y', 'Z', 'E'};
        for (int i = 0; i < 4; ++i) {
          if (!c.has(kAxes[i])) continue;
          const double v = c.get(kAxes[i]) * unit;
          if (c.code == 205 ? v < 0 : v <= 0)
            return warn(c.line, text, "limit must be positive; ignored", "bad_parameter");
          if (c.code == 201) limits_.max_accel_mm_s2[i] = v;
          else if (c.code == 203) limits_.max_feedrate_mm_s[i] = v;
          else limits_.jerk_mm_s[i] = v;
        }
        if (c.code == 205) {
          if (c.has('J') && c.get('J') > 0 && c.get('J') <= 10) limits_.junction_deviation_mm = c.get('J');
          if (c.has('S') && c.get('S') >= 0) limits_.min_feedrate_mm_s = c.get('S') * unit;
          if (c.has('T') && c.get('T') >= 0) limits_.min_travel_feedrate_mm_s = c.get('T') * unit;
          if (c.has('B') && c.get('B') >= 0) limits_.min_segment_time_s = c.get('B') * 1e-6;
        }
        out.limits(limits_);
        return Ok{};
      }
      case 204: {
        auto take = [&](char p, double& dst, double cap) -> Status {
          const double v = c.get(p) * unit;
          if (v <= 0) return warn(c.line, text, "acceleration must be positive; ignored", "bad_parameter");
          dst = std::min(v, cap);
          return Ok{};
        };
        const auto& cap = limits_.accel_cap_mm_s2;
        if (c.has('S')) {  // Marlin 2.1: S sets print and travel
          if (auto st = take('S', limits_.print_accel_mm_s2, cap[0]); !st) return st;
          limits_.travel_accel_mm_s2 = std::min(limits_.print_accel_mm_s2, cap[2]);
        }
        if (c.has('P')) if (auto st = take('P', limits_.print_accel_mm_s2, cap[0]); !st) return st;
        if (c.has('R')) if (auto st = take('R', limits_.retract_accel_mm_s2, cap[1]); !st) return st;
        if (c.has('T')) if (auto st = take('T', limits_.travel_accel_mm_s2, cap[2]); !st) return st;
        out.limits(limits_);
        return Ok{};
      }
      case 220: {
        if (c.has('S')) {
          const double s = c.get('S');
          if (s <= 0 || s > 1000) return warn(c.line, text, "feedrate percentage outside 1..1000; ignored", "bad_parameter");
          limits_.feedrate_scale = s / 100.0;
          out.limits(limits_);
        }
        return Ok{};
      }
      case 221: {
        if (c.has('S')) {
          const double s = c.get('S');
          if (s < 0 || s > 1000) return warn(c.line, text, "flow percentage outside 0..1000; ignored", "bad_parameter");
          flow_ = s / 100.0;
        }
        return Ok{};
      }
      case 400: out.synchronize(); return Ok{};
      case 486: {
        if (c.has('S')) {
          const double s = c.get('S');
          object_id_ = s < 0 ? -1 : static_cast<int>(std::min(s, 1e6));
        }
        return Ok{};
      }
      // Known commands without effect on motion or material in the twin.
      case 17: case 18: case 84:      // steppers on/off
      case 105: case 106: case 107:   // temperature report, fan
      case 73: case 75: case 76: case 77:  // progress, print job timer
      case 108: case 110: case 111: case 114: case 115: case 117: case 118: case 119:
      case 155: case 300: case 420: case 500: case 501: case 503: case 900: case 907:
      case 23: case 24: case 25: case 28: case 29: case 30: case 32: case 81: case 928:
        return Ok{};
      default: break;
    }
  } else if (c.letter == 'T') {
    if (c.code == 0) return Ok{};
    return warn(c.line, text, "tool T" + std::to_string(c.code) + " selected on a single-extruder printer", "bad_tool");
  }
  const std::string name = command_name(c);
  if (++unknown_[name] == 1) unknown_first_line_[name] = c.line;
  return Ok{};
}

Result<MotionLimits> limits_from_prusaslicer_config(std::string_view text, const MotionLimits& base) {
  MotionLimits l = base;
  int found = 0;
  bool orca_keys = false;  // machine_max_speed_*: OrcaSlicer, Bambu Studio, Creality Print
  double extruding = 0, retracting = 0, travel = 0, min_extruding = 0, min_travel = 0;
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
    return bad_input("no slicer machine limits (\"; machine_max_acceleration_x = ...\") in the G-code; "
                     "--limits-from-gcode needs the config block of PrusaSlicer, SuperSlicer, OrcaSlicer, "
                     "Bambu Studio or Creality Print");
  // PrusaSlicer's defaults when a value is 0 (GCodeProcessor: DEFAULT_ACCELERATION 1500,
  // DEFAULT_RETRACT_ACCELERATION 1500, DEFAULT_TRAVEL_ACCELERATION 1250).
  l.print_accel_mm_s2 = extruding > 0 ? extruding : 1500;
  l.retract_accel_mm_s2 = retracting > 0 ? retracting : 1500;
  l.travel_accel_mm_s2 = travel > 0 ? travel : 1250;
  l.accel_cap_mm_s2 = Eigen::Vector3d(extruding > 0 ? extruding : std::numeric_limits<double>::infinity(),
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
  l.klipper = false;
  l.min_segment_time_s = 0;
  return l;
}

}  // namespace printtwin
