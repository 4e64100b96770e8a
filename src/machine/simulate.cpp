// simulate_gcode(): reader -> parser -> interpreter -> planner, with the accounting that
// becomes SimulationResult, and its JSON / text forms.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "printtwin/bgcode.hpp"
#include "printtwin/gcode_3mf.hpp"
#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/simulate.hpp"

namespace printtwin {

namespace {

/// Glue between the interpreter, the planner and the caller's sink; accumulates the result.
class Pipeline final : public InterpreterOutput, public MoveSink {
 public:
  Pipeline(const MotionLimits& limits, int window, MoveSink* user, bool plan)
      : planner_(limits, window), user_(user), plan_(plan) {}

  // InterpreterOutput
  void move(const Move& m) override {
    if (user_ != nullptr) user_->on_move(m);
    ++r.moves;
    const double len = m.length_mm();
    if (m.kind == MoveKind::extrude) {
      r.extrude_distance_mm += len;
      r.extrusion_bounds_mm.extend(m.start_mm);
      r.extrusion_bounds_mm.extend(m.end_mm);
    } else if (m.kind == MoveKind::travel || m.kind == MoveKind::retract) {
      r.travel_distance_mm += len;
    }
    r.motion_bounds_mm.extend(m.end_mm);
    r.filament_mm += m.e_mm;
    if (m.kind == MoveKind::extrude) r.filament_extruding_mm += m.e_mm;
    const auto tool = static_cast<std::size_t>(m.tool);
    if (tool >= r.tool_filament_mm.size()) r.tool_filament_mm.resize(tool + 1, 0.0);
    r.tool_filament_mm[tool] += m.e_mm;
    if (m.layer >= 0 && m.feature != Feature::custom) {
      part_net_mm_ += m.e_mm;
      if (m.kind == MoveKind::extrude) r.filament_part_mm = part_net_mm_;
    }
    if (m.e_mm < 0) r.retracted_mm -= m.e_mm;
    if (m.layer >= 0) {
      grow_layers(m.layer);
      layer_filament_[static_cast<std::size_t>(m.layer)] += m.e_mm;
      if (m.kind == MoveKind::extrude && layer_first_line_[static_cast<std::size_t>(m.layer)] == 0)
        layer_first_line_[static_cast<std::size_t>(m.layer)] = m.line;
    }
    current_layer_ = m.layer;
    if (plan_) planner_.add(m, *this);
  }
  void limits(const MotionLimits& l) override { planner_.set_limits(l); }
  void synchronize() override {
    if (plan_) planner_.flush(*this);
  }
  void wait(double duration_s, bool heating, long line) override {
    if (plan_) planner_.wait(duration_s, heating, line, *this);
  }

  // MoveSink (from the planner)
  void on_segment(const MotionSegment& s) override {
    ++r.segments;
    const double t = s.duration_s();
    r.max_speed_mm_s = std::max(r.max_speed_mm_s, s.cruise_speed_mm_s);
    std::size_t key;
    switch (s.kind) {
      case MoveKind::home:
        r.homing_time_s += t;
        key = kHoming;
        break;
      case MoveKind::travel:
        r.motion_time_s += t;
        key = kTravel;
        break;
      case MoveKind::retract:
      case MoveKind::unretract:
        r.motion_time_s += t;
        key = kRetract;
        break;
      case MoveKind::extrude:
      default:
        r.motion_time_s += t;
        key = static_cast<std::size_t>(s.feature);
        break;
    }
    feature_time_[key] += t;
    if (s.layer >= 0) {
      grow_layers(s.layer);
      layer_time_[static_cast<std::size_t>(s.layer)] += t;
    }
    if (user_ != nullptr) user_->on_segment(s);
  }
  void on_wait(double start_s, double duration_s, bool heating, long line) override {
    (heating ? r.heating_time_s : r.dwell_time_s) += duration_s;
    if (current_layer_ >= 0) {
      grow_layers(current_layer_);
      layer_time_[static_cast<std::size_t>(current_layer_)] += duration_s;
    }
    if (user_ != nullptr) user_->on_wait(start_s, duration_s, heating, line);
  }

  void finish(const GcodeInterpreter& interp) {
    if (plan_) planner_.flush(*this);
    r.print_time_s = r.motion_time_s + r.homing_time_s + r.dwell_time_s + r.heating_time_s;
    r.filament_mm3 = 0;  // set by the caller (needs the profile)
    for (std::size_t i = 0; i < kKeys; ++i) {
      if (feature_time_[i] <= 0) continue;
      std::string name = i == kTravel    ? "travel"
                         : i == kRetract ? "retract"
                         : i == kHoming  ? "homing"
                                         : std::string(to_string(static_cast<Feature>(i)));
      r.time_by_feature_s[name] += feature_time_[i];
    }
    const auto& zs = interp.layer_z_mm();
    grow_layers(static_cast<int>(zs.size()) - 1);
    for (std::size_t i = 0; i < zs.size(); ++i) {
      LayerStats l;
      l.index = static_cast<int>(i);
      l.z_mm = zs[i];
      double below = 0;
      for (double z : zs)
        if (z < zs[i] - 1e-9) below = std::max(below, z);
      l.height_mm = zs[i] - below;
      l.time_s = layer_time_[i];
      l.filament_mm = layer_filament_[i];
      l.first_line = layer_first_line_[i];
      r.layers.push_back(l);
    }
  }

  SimulationResult r;

 private:
  static constexpr std::size_t kTravel = static_cast<std::size_t>(Feature::count_);
  static constexpr std::size_t kRetract = kTravel + 1;
  static constexpr std::size_t kHoming = kTravel + 2;
  static constexpr std::size_t kKeys = kTravel + 3;

  void grow_layers(int layer) {
    if (layer < 0) return;
    const auto n = static_cast<std::size_t>(layer) + 1;
    if (layer_time_.size() < n) {
      layer_time_.resize(n, 0.0);
      layer_filament_.resize(n, 0.0);
      layer_first_line_.resize(n, 0);
    }
  }

  Planner planner_;
  MoveSink* user_;
  bool plan_;
  int current_layer_ = -1;
  double part_net_mm_ = 0;
  std::array<double, kKeys> feature_time_{};
  std::vector<double> layer_time_, layer_filament_;
  std::vector<long> layer_first_line_;
};

Error with_file(Error e, const std::string& file) {
  if (e.file.empty()) e.file = file;
  return e;
}

Result<SimulationResult> run(std::istream& in, const PrinterProfile& profile,
                             const SimulateOptions& options, MoveSink* sink, bool plan) {
  const std::string& file = options.source_name;
  MotionLimits limits = motion_limits_from_profile(profile);
  int window = profile.block_buffer_size;
  if (options.limits_from_gcode) {
    // Slicers write their config block at the end (PrusaSlicer) or the start (Bambu
    // Studio): read the head and the tail, then rewind.
    in.clear();
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    if (size < 0 || !in)
      return bad_input(
          "--limits-from-gcode needs a seekable file (slicers write their limits at the end)",
          file);
    const std::streamoff part = std::min<std::streamoff>(size, 256 * 1024);
    std::string text(static_cast<std::size_t>(2 * part + 1), '\n');
    in.seekg(0);
    in.read(text.data(), part);
    in.clear();
    in.seekg(size - part);
    in.read(text.data() + part + 1, part);
    in.clear();
    in.seekg(0);
    auto l = limits_from_prusaslicer_config(text, limits);
    if (!l) return with_file(l.error(), file);
    limits = *l;
    // PrusaSlicer's estimator plans over a much longer queue than Marlin's 16 blocks.
    window = std::max(window, 64);
  }

  // A start macro without parameters heats to the file's first-layer temperatures
  // (resolve_printer read them from the slicer's settings into the profile's origin).
  InterpreterOptions interp_options = options.interpreter;
  if (std::isnan(interp_options.macro_hotend_c))
    interp_options.macro_hotend_c = profile.origin.macro_hotend_c;
  if (std::isnan(interp_options.macro_bed_c))
    interp_options.macro_bed_c = profile.origin.macro_bed_c;
  apply_tools_to_options(profile.origin, interp_options);
  GcodeInterpreter interp(profile, interp_options);
  Pipeline pipe(limits, window, sink, plan);
  if (options.limits_from_gcode) interp.set_limits(limits, pipe);

  GcodeLineReader reader(in);
  std::string_view text;
  GcodeCommand cmd;
  long lines = 0;
  while (reader.next(text)) {
    lines = reader.line_number();
    if (reader.truncated()) {
      auto st = interp.warn_input(bad_input(
          "line longer than " + std::to_string(kMaxGcodeLineLength) + " bytes", file, lines));
      if (!st) return with_file(st.error(), file);
      continue;
    }
    auto parsed = parse_gcode_line(text, lines, cmd);
    if (!parsed) {
      auto st = interp.warn_input(parsed.error());
      if (!st) return with_file(st.error(), file);
      continue;
    }
    auto st = interp.execute(cmd, text, pipe);
    if (!st) return with_file(st.error(), file);
  }
  if (in.bad()) return bad_input("read error after line " + std::to_string(lines), file);
  if (auto st = interp.finish(reader.ended_mid_line(), lines); !st)
    return with_file(st.error(), file);

  pipe.finish(interp);
  SimulationResult r = std::move(pipe.r);
  r.lines = lines;
  r.filament_mm3 = r.filament_mm * profile.filament_area_mm2();
  r.findings = profile.origin.findings;  // how the printer was identified (printer.hpp)
  for (auto& f : interp.findings()) r.findings.push_back(f);
  r.unknown_commands = interp.unknown_commands();
  for (const auto& [name, count] : r.unknown_commands) {
    Finding f;
    f.severity = Severity::info;
    f.code = "unknown_command";
    f.message = name + " is not simulated (ignored " + std::to_string(count) +
                (count == 1 ? " time)" : " times)");
    f.line = interp.unknown_first_lines().at(name);
    f.count = count;
    r.findings.push_back(std::move(f));
  }
  r.slicer = interp.slicer();
  for (const auto& [name, id] : interp.object_names()) r.object_names[id] = name;
  if (!std::isnan(interp.slicer_estimate_s())) r.slicer_estimate_s = interp.slicer_estimate_s();
  if (!std::isnan(interp.slicer_filament_mm())) r.slicer_filament_mm = interp.slicer_filament_mm();
  if (!std::isnan(interp.slicer_part_estimate_s()))
    r.slicer_part_estimate_s = interp.slicer_part_estimate_s();
  r.tool_changes = interp.tool_changes();
  r.tool_change_time_s = interp.tool_change_time_s();
  r.slicer_tool_filament_mm = interp.slicer_tool_filament_mm();
  if (r.tool_changes == 0 && r.tool_filament_mm.size() <= 1) r.tool_filament_mm.clear();
  r.layers_from = interp.layers_from_markers() ? "markers" : "z";
  r.limits_used = limits;
  r.limits_from_gcode = options.limits_from_gcode;
  r.printer = profile;
  return r;
}

double round_to(double v, double q) { return std::round(v / q) * q; }

/// Runs `run` on the G-code text of a binary G-code file (bgcode.hpp); a decode error in
/// the middle of the file wins over the result of the text read up to it.
template <class Run>
auto run_on_bgcode(const std::filesystem::path& path, Run run)
    -> decltype(run(std::declval<std::istream&>())) {
  auto stream = BgcodeGcodeStream::open(path);
  if (!stream) return stream.error();
  auto r = run(**stream);
  if ((*stream)->error()) return *(*stream)->error();
  return r;
}

/// Runs `run` on the G-code of a sliced 3MF (gcode_3mf.hpp).
template <class Run>
auto run_on_3mf(const std::filesystem::path& path, Run run)
    -> decltype(run(std::declval<std::istream&>())) {
  auto text = read_gcode_3mf(path);
  if (!text) return text.error();
  std::istringstream in(std::move(*text));
  return run(in);
}

}  // namespace

Result<SimulationResult> simulate_gcode(std::istream& in, const PrinterProfile& profile,
                                        const SimulateOptions& options, MoveSink* sink) {
  return run(in, profile, options, sink, true);
}

Result<SimulationResult> simulate_gcode_file(const std::filesystem::path& path,
                                             const PrinterProfile& profile,
                                             const SimulateOptions& options, MoveSink* sink) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return bad_input("is a directory, expected a G-code file", path.string());
  SimulateOptions o = options;
  if (o.source_name.empty()) o.source_name = path.string();
  if (is_bgcode_file(path))
    return run_on_bgcode(path,
                         [&](std::istream& in) { return simulate_gcode(in, profile, o, sink); });
  if (is_gcode_3mf_file(path))
    return run_on_3mf(path, [&](std::istream& in) { return simulate_gcode(in, profile, o, sink); });
  std::ifstream in(path, std::ios::binary);
  if (!in) return bad_input("cannot open G-code file", path.string());
  return simulate_gcode(in, profile, o, sink);
}

Result<std::vector<Move>> interpret_gcode(std::istream& in, const PrinterProfile& profile,
                                          const SimulateOptions& options) {
  struct Collect final : MoveSink {
    std::vector<Move> moves;
    void on_move(const Move& m) override { moves.push_back(m); }
  } collect;
  auto r = run(in, profile, options, &collect, false);
  if (!r) return r.error();
  return std::move(collect.moves);
}

Result<std::vector<Move>> interpret_gcode_file(const std::filesystem::path& path,
                                               const PrinterProfile& profile,
                                               const SimulateOptions& options) {
  SimulateOptions o = options;
  if (o.source_name.empty()) o.source_name = path.string();
  if (is_bgcode_file(path))
    return run_on_bgcode(path, [&](std::istream& in) { return interpret_gcode(in, profile, o); });
  if (is_gcode_3mf_file(path))
    return run_on_3mf(path, [&](std::istream& in) { return interpret_gcode(in, profile, o); });
  std::ifstream in(path, std::ios::binary);
  if (!in) return bad_input("cannot open G-code file", path.string());
  return interpret_gcode(in, profile, o);
}

std::string simulation_to_json(const SimulationResult& r, const std::string& input_name) {
  using nlohmann::json;
  auto q = [](double v) { return round_to(v, 1e-6); };
  json doc;
  doc["schema"] = "printtwin.simulate/1";
  doc["input"] = input_name;
  doc["slicer"] = r.slicer;
  doc["slicer_estimate_s"] = r.slicer_estimate_s ? json(*r.slicer_estimate_s) : json(nullptr);
  doc["slicer_part_estimate_s"] =
      r.slicer_part_estimate_s ? json(*r.slicer_part_estimate_s) : json(nullptr);
  doc["print_time_s"] = q(r.print_time_s);
  doc["motion_time_s"] = q(r.motion_time_s);
  doc["homing_time_s"] = q(r.homing_time_s);
  doc["dwell_time_s"] = q(r.dwell_time_s);
  doc["heating_time_s"] = q(r.heating_time_s);
  doc["slicer_filament_mm"] = r.slicer_filament_mm ? json(q(*r.slicer_filament_mm)) : json(nullptr);
  doc["filament_mm"] = q(r.filament_mm);
  doc["filament_part_mm"] = q(r.filament_part_mm);
  doc["filament_extruding_mm"] = q(r.filament_extruding_mm);
  doc["filament_mm3"] = q(r.filament_mm3);
  if (!r.tool_filament_mm.empty()) {
    json per_tool = json::array(), stated = json::array();
    for (double v : r.tool_filament_mm) per_tool.push_back(q(v));
    for (double v : r.slicer_tool_filament_mm) stated.push_back(q(v));
    doc["tools"] = {{"changes", r.tool_changes},
                    {"change_time_s", q(r.tool_change_time_s)},
                    {"filament_mm", per_tool},
                    {"slicer_filament_mm", stated}};
  }
  doc["retracted_mm"] = q(r.retracted_mm);
  doc["extrude_distance_mm"] = q(r.extrude_distance_mm);
  doc["travel_distance_mm"] = q(r.travel_distance_mm);
  doc["max_speed_mm_s"] = q(r.max_speed_mm_s);
  doc["lines"] = r.lines;
  doc["moves"] = r.moves;
  doc["segments"] = r.segments;
  json layers = json::array();
  for (const auto& l : r.layers)
    layers.push_back({{"index", l.index},
                      {"z_mm", q(l.z_mm)},
                      {"height_mm", q(l.height_mm)},
                      {"time_s", q(l.time_s)},
                      {"filament_mm", q(l.filament_mm)},
                      {"first_line", l.first_line}});
  doc["layers"] = {{"count", r.layers.size()}, {"from", r.layers_from}, {"items", layers}};
  json tf = json::object();
  for (const auto& [k, v] : r.time_by_feature_s) tf[k] = q(v);
  doc["time_by_feature_s"] = tf;
  json unknown = json::object();
  for (const auto& [k, v] : r.unknown_commands) unknown[k] = v;
  doc["unknown_commands"] = unknown;
  auto box = [&](const Box3& b) {
    if (b.empty()) return json(nullptr);
    return json{{"min_mm", {q(b.min.x()), q(b.min.y()), q(b.min.z())}},
                {"max_mm", {q(b.max.x()), q(b.max.y()), q(b.max.z())}}};
  };
  doc["extrusion_bounds"] = box(r.extrusion_bounds_mm);
  doc["motion_bounds"] = box(r.motion_bounds_mm);
  json findings = json::array();
  for (const auto& f : r.findings) {
    json j{
        {"severity", std::string(to_string(f.severity))}, {"code", f.code}, {"message", f.message}};
    j["line"] = f.line ? json(*f.line) : json(nullptr);
    j["layer"] = f.layer ? json(*f.layer) : json(nullptr);
    j["position_mm"] =
        f.position_mm ? json{q(f.position_mm->x()), q(f.position_mm->y()), q(f.position_mm->z())}
                      : json(nullptr);
    j["count"] = f.count;
    findings.push_back(j);
  }
  doc["findings"] = findings;
  const auto& L = r.limits_used;
  doc["limits"] = {
      {"source", r.limits_from_gcode ? "gcode" : "profile"},
      {"junction",
       L.junction == JunctionModel::classic_jerk ? "classic_jerk" : "junction_deviation"},
      {"junction_deviation_mm", L.junction_deviation_mm},
      {"jerk_mm_s", {L.jerk_mm_s[0], L.jerk_mm_s[1], L.jerk_mm_s[2], L.jerk_mm_s[3]}},
      {"max_feedrate_mm_s",
       {L.max_feedrate_mm_s[0], L.max_feedrate_mm_s[1], L.max_feedrate_mm_s[2],
        L.max_feedrate_mm_s[3]}},
      {"max_accel_mm_s2",
       {L.max_accel_mm_s2[0], L.max_accel_mm_s2[1], L.max_accel_mm_s2[2], L.max_accel_mm_s2[3]}},
      {"print_accel_mm_s2", L.print_accel_mm_s2},
      {"retract_accel_mm_s2", L.retract_accel_mm_s2},
      {"travel_accel_mm_s2", L.travel_accel_mm_s2},
      {"min_segment_time_s", L.min_segment_time_s},
      {"prusaslicer_compat", L.prusaslicer_compat},
      {"planner", L.klipper              ? "klipper"
                  : L.bambu_junction     ? "bambustudio_estimator"
                  : L.orca_compat        ? "orcaslicer_estimator"
                  : L.prusaslicer_compat ? "prusaslicer_estimator"
                                         : "marlin"}};
  doc["printer"] = json::parse(printer_provenance_json(r.printer));
  return doc.dump(2) + "\n";
}

namespace {
/// "tools ..." lines of a multi-tool file: filament per tool, beside the slicer's.
std::string tools_summary(const SimulationResult& r) {
  if (r.tool_filament_mm.empty()) return {};
  const auto used = std::count_if(r.tool_filament_mm.begin(), r.tool_filament_mm.end(),
                                  [](double mm) { return mm > 1e-6; });
  std::string s = "tools         " + std::to_string(used) + " used (" +
                  std::to_string(r.tool_changes) + " changes";
  if (r.tool_change_time_s > 0)
    s += ", " + format_fixed(r.tool_change_time_s, 1) + " s of them changing filament or tools";
  s += ")\n";
  for (std::size_t i = 0; i < r.tool_filament_mm.size(); ++i) {
    const bool stated = i < r.slicer_tool_filament_mm.size();
    if (std::fabs(r.tool_filament_mm[i]) < 1e-6 && (!stated || r.slicer_tool_filament_mm[i] == 0))
      continue;
    s += "  T" + std::to_string(i) + "          " + format_fixed(r.tool_filament_mm[i], 2) + " mm";
    if (stated) s += " (slicer says " + format_fixed(r.slicer_tool_filament_mm[i], 2) + " mm)";
    s += "\n";
  }
  return s;
}
}  // namespace

std::string simulation_summary(const SimulationResult& r) {
  std::string s;
  if (!r.slicer.empty()) s += "slicer        " + r.slicer + "\n";
  s += "printer       " + printer_provenance_summary(r.printer) + "\n";
  s += "lines         " + std::to_string(r.lines) + " (" + std::to_string(r.moves) + " moves, " +
       std::to_string(r.segments) + " planned segments)\n";
  s += "print time    " + format_duration_compact(r.print_time_s) + " (" +
       format_fixed(r.print_time_s, 1) + " s)\n";
  s += "  motion      " + format_fixed(r.motion_time_s, 1) + " s\n";
  s += "  homing      " + format_fixed(r.homing_time_s, 1) + " s\n";
  s += "  dwell       " + format_fixed(r.dwell_time_s, 1) + " s\n";
  s += "  heating     " + format_fixed(r.heating_time_s, 1) + " s\n";
  const auto percent = [](double ours, double ref) {
    return format_fixed(100.0 * (ours - ref) / std::max(1e-9, ref), 2) + " %";
  };
  const std::string hint = r.limits_from_gcode ? "" : " (try --limits-from-gcode)";
  if (r.slicer_part_estimate_s) {
    // The Orca family states the model's time apart from its start sequence (whose bed
    // levelling it counts at a fixed time): compare the time of the layers.
    double layers_s = 0;
    for (const auto& l : r.layers) layers_s += l.time_s;
    s += "slicer says   " + format_duration_compact(*r.slicer_part_estimate_s) + " for the model";
    if (r.slicer_estimate_s)
      s += " (" + format_duration_compact(*r.slicer_estimate_s) + " with its start sequence)";
    s += "; the layers' time (" + format_duration_compact(layers_s) + ") differs by " +
         percent(layers_s, *r.slicer_part_estimate_s) + hint + "\n";
  } else if (r.slicer_estimate_s) {
    // PrusaSlicer 2.5's estimate counts planned motion (its G28 is instantaneous and the
    // start G-code's G4 S is not added): compare motion time, plus the filament load and
    // unload times of tool changes that the slicers' estimators add.
    s += "slicer says   " + format_duration_compact(*r.slicer_estimate_s) +
         (r.tool_change_time_s > 0 ? "; motion and tool change time differs by "
                                   : "; motion time differs by ") +
         percent(r.motion_time_s + r.tool_change_time_s, *r.slicer_estimate_s) + hint + "\n";
  }
  s += "filament      " + format_fixed(r.filament_mm, 2) + " mm (" +
       format_fixed(r.filament_mm3, 1) + " mm3); part " + format_fixed(r.filament_part_mm, 2) +
       " mm without start/end code; " + format_fixed(r.filament_extruding_mm, 2) +
       " mm on extruding moves\n";
  if (r.slicer_filament_mm) {
    // Slicers count differently: Cura the part, the Slic3r and Orca families and KISSlicer
    // every extruding move (start-code purge lines in, E-only priming out).
    const double ref = *r.slicer_filament_mm;
    s += "slicer says   " + format_fixed(ref, 2) + " mm of filament; part differs by " +
         percent(r.filament_part_mm, ref) + ", extruding moves by " +
         percent(r.filament_extruding_mm, ref) + ", total by " + percent(r.filament_mm, ref) + "\n";
  }
  s += tools_summary(r);
  if (!r.layers.empty()) {
    double zmin = r.layers.front().z_mm, zmax = zmin;
    for (const auto& l : r.layers) zmin = std::min(zmin, l.z_mm), zmax = std::max(zmax, l.z_mm);
    s += "layers        " + std::to_string(r.layers.size()) + " (z " + format_fixed(zmin, 2) +
         " .. " + format_fixed(zmax, 2) + " mm, " +
         (r.layers_from == "markers" ? "the slicer's layer markers" : "by Z of extrusions") + ")\n";
  } else {
    s += "layers        0\n";
  }
  long errors = 0, warnings = 0;
  for (const auto& f : r.findings) {
    if (f.severity == Severity::error) ++errors;
    if (f.severity == Severity::warning) ++warnings;
  }
  s += "findings      " + std::to_string(errors) + " errors, " + std::to_string(warnings) +
       " warnings\n";
  for (const auto& f : r.findings) {
    s += "  " + std::string(to_string(f.severity)) + " " + f.code;
    if (f.line) s += " (line " + std::to_string(*f.line) + ")";
    s += ": " + f.message;
    if (f.count > 1) s += " [x" + std::to_string(f.count) + "]";
    s += "\n";
  }
  return s;
}

}  // namespace printtwin
