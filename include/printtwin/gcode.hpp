#pragma once
// G-code text -> commands -> Moves: the streaming parser and the firmware's interpreter.
//
// GcodeLineReader cuts a stream into lines (bounded memory, 1-based line numbers, no
// allocation per line); parse_gcode_line() splits one line into a GcodeCommand without
// allocating; GcodeInterpreter executes commands with Marlin 2.1's modal state (G90/G91,
// M82/M83, G92, G20/G21, M200/M220/M221, temperatures, homing state), the commands of the
// profile's firmware flavour (Prusa, Klipper, RepRapFirmware, Bambu), printer-side start
// and end macros, and the slicers' layer and feature markers, and emits Moves plus the
// events the planner needs (limit changes, dwells, heating waits) to an InterpreterOutput.
// simulate.hpp chains these with the planner; most callers want simulate_gcode() or
// interpret_gcode_file() from there.
//
// Supported commands and slicer markers: docs/gcode-coverage.md.
#include <algorithm>
#include <array>
#include <cstdint>
#include <istream>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/result.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin {

/// Longest line the reader accepts (bytes). Longer lines (e.g. 1 MB of garbage) are
/// skipped whole and reported as `line_too_long`, never buffered.
inline constexpr std::size_t kMaxGcodeLineLength = 64 * 1024;

/// Cuts a byte stream into lines. Accepts "\n", "\r\n", a last line without a newline and a
/// UTF-8 byte order mark before the first line (dropped).
/// Memory: one buffer of a few hundred KB, whatever the file size.
class GcodeLineReader {
 public:
  explicit GcodeLineReader(std::istream& in);
  /// Next line without its line ending; false at the end of the stream. The view stays
  /// valid until the next call.
  bool next(std::string_view& line);
  /// 1-based number of the line returned last.
  [[nodiscard]] long line_number() const { return line_; }
  /// True if the line returned last was longer than kMaxGcodeLineLength (its view then
  /// holds only the first kMaxGcodeLineLength bytes).
  [[nodiscard]] bool truncated() const { return truncated_; }
  /// True if the stream ended without a final newline (the last line was cut).
  [[nodiscard]] bool ended_mid_line() const { return ended_mid_line_; }

 private:
  bool next_line(std::string_view& line);
  bool fill();
  std::istream& in_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0;
  long line_ = 0;
  bool eof_ = false, truncated_ = false, ended_mid_line_ = false;
};

/// One G-code line split into command and parameters. Views point into the caller's line.
struct GcodeCommand {
  char letter = 0;   ///< 'G', 'M', 'T', or 0 (no command, or an extended command in `word`)
  int code = -1;     ///< G1 -> 1
  int subcode = -1;  ///< G29.1 -> 1; -1 when none
  std::uint32_t present = 0;  ///< bit (c - 'A') set when parameter c is present
  std::uint32_t valued = 0;   ///< bit (c - 'A') set when parameter c came with a number
  std::array<double, 26>
      value{};               ///< value of parameter c at [c - 'A'] (0 when given without a number)
  std::string_view word;     ///< extended command (Klipper style), e.g. "EXCLUDE_OBJECT_START"
  std::string_view args;     ///< text after the command (M117 message, NAME=... arguments)
  std::string_view comment;  ///< text after ';' (leading spaces removed), empty when none
  long line = 0;             ///< 1-based line number

  [[nodiscard]] bool has(char c) const { return (present >> (c - 'A')) & 1U; }
  /// Present with a number (Marlin's seenval): "M221 S" alone is not a flow of 0.
  [[nodiscard]] bool has_value(char c) const { return (valued >> (c - 'A')) & 1U; }
  [[nodiscard]] double get(char c, double fallback = 0) const {
    return has(c) ? value[static_cast<std::size_t>(c - 'A')] : fallback;
  }
  [[nodiscard]] bool is(char l, int c) const { return letter == l && code == c; }
};

/// Parses one line (without line ending) into `out`. Accepts comments (`;` and `( )`),
/// line numbers and checksums (`N123 G1 X1*45`, checksum verified), lower-case letters and
/// spaces between a letter and its number. Errors (with the line number and the offending
/// text): unparsable numbers, NaN/inf/out-of-range values (|v| > 1e9), unexpanded slicer
/// placeholders (`G1 Z[next_layer_z]`, `{...}`), bytes that are not G-code, bad checksums.
/// Never allocates on success.
[[nodiscard]] Status parse_gcode_line(std::string_view text, long line, GcodeCommand& out);

/// Options of the interpreter (and of simulate_gcode).
struct InterpreterOptions {
  /// Warnings about the input (unknown commands aside) become errors: the run stops.
  bool strict = false;
  /// Marlin's PREVENT_COLD_EXTRUSION: E motion below the profile's min_extrude_temp_c is
  /// dropped (and reported as `cold_extrusion`). When false it is only reported.
  bool prevent_cold_extrusion = true;
  /// Where the carriage stands at power-on (machine frame, mm); NaN components mean the
  /// default: bed centre in X and Y, 10 mm in Z. Only moves before G28 depend on it.
  Vec3 power_on_position_mm = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  /// Temperatures at power-on (°C); NaN means the profile's ambient.
  double power_on_hotend_c = std::numeric_limits<double>::quiet_NaN();
  double power_on_bed_c = std::numeric_limits<double>::quiet_NaN();
  /// At most this many findings are listed per code; the rest are counted in the last one.
  int max_findings_per_code = 20;
  /// Temperatures a printer-side start macro (Klipper START_PRINT, PRINT_START, ...) heats to
  /// when it is called without temperature parameters: the first-layer temperatures the
  /// slicer's embedded settings state (°C). NaN = unknown (then the macro heats to at least
  /// the profile's min_extrude_temp_c, reported as an info finding).
  double macro_hotend_c = std::numeric_limits<double>::quiet_NaN();
  double macro_bed_c = std::numeric_limits<double>::quiet_NaN();
  /// Tools (extruders or filaments) the file's settings declare; 0 = not stated. T<n> with
  /// n below it is a tool change; above it (or on a file that declares none, on a
  /// single-extruder printer) it is reported as `bad_tool`.
  int tool_count = 0;
  /// The tools share one nozzle and heater (Bambu AMS, Prusa MMU, single_extruder_multi_
  /// material): T<n> swaps the filament in that nozzle. Otherwise each tool has its own
  /// nozzle and heater (tool changers, IDEX, dual extruders).
  bool shared_nozzle = false;
  /// Time the printer takes to unload the old filament and load the new one at a
  /// filament change on a shared nozzle (s), per tool, as the slicer's settings state it
  /// (Bambu/Orca machine_(un)load_filament_time, PrusaSlicer filament_(un)load_time).
  /// Empty: not stated (the change then takes only its G-code's moves).
  std::vector<double> filament_load_s, filament_unload_s;
  /// Time a multi-nozzle printer takes to switch tools (s; Orca machine_tool_change_time).
  double tool_change_s = 0;
};

/// Where the interpreter's output goes, in order. Implemented by the simulation pipeline.
class InterpreterOutput {
 public:
  virtual ~InterpreterOutput() = default;
  virtual void move(const Move& move) = 0;
  /// Motion settings changed (M201/M203/M204/M205/M220); applies to later moves.
  virtual void limits(const MotionLimits& limits) = 0;
  /// The printer finishes all queued moves (M400, before G4/M109/M190/G28).
  virtual void synchronize() = 0;
  /// The printer stands still for `duration_s` after finishing queued moves.
  virtual void wait(double duration_s, bool heating, long line) = 0;
};

/// The firmware's state machine for one file. Feed it every parsed line in order.
class GcodeInterpreter {
 public:
  GcodeInterpreter(const PrinterProfile& profile, const InterpreterOptions& options);

  /// Executes one command. Errors are bad input that stops the run (or any warning in
  /// strict mode); they carry the line number and the line's text.
  [[nodiscard]] Status execute(const GcodeCommand& command, std::string_view line_text,
                               InterpreterOutput& out);
  /// Reports a problem found before interpretation (parse error, over-long line) as a
  /// warning; in strict mode returns it as an error.
  [[nodiscard]] Status warn_input(const Error& problem);
  /// Call at the end of the stream (end-of-file checks, e.g. a cut last line).
  [[nodiscard]] Status finish(bool ended_mid_line, long last_line);

  /// Findings so far (out_of_bounds, move_before_homing, cold_extrusion, ...).
  [[nodiscard]] const std::vector<Finding>& findings() const { return findings_; }
  /// Commands the interpreter does not know, with how often each occurred.
  [[nodiscard]] const std::map<std::string, long>& unknown_commands() const { return unknown_; }
  /// Labelled objects seen so far (EXCLUDE_OBJECT / "printing object" / ;MESH: name ->
  /// Move::object_id).
  [[nodiscard]] const std::map<std::string, int>& object_names() const { return object_names_; }
  /// Line of the first occurrence of each unknown command.
  [[nodiscard]] const std::map<std::string, long>& unknown_first_lines() const {
    return unknown_first_line_;
  }
  /// Motion limits currently in force.
  [[nodiscard]] const MotionLimits& limits() const { return limits_; }
  /// Replaces the limits in force (e.g. with those of a slicer's config block).
  void set_limits(const MotionLimits& limits, InterpreterOutput& out);
  /// Filament pushed so far (mm, after flow and volumetric conversion; net of retractions).
  [[nodiscard]] double filament_mm() const { return filament_mm_; }
  /// Current nozzle position (machine frame).
  [[nodiscard]] Vec3 position_mm() const;
  /// Z of each layer so far (index = Move::layer).
  [[nodiscard]] const std::vector<double>& layer_z_mm() const { return layer_z_; }
  /// The slicer that wrote the file, from its header comment ("PrusaSlicer 2.5.0"), or "".
  [[nodiscard]] const std::string& slicer() const { return slicer_; }
  /// Estimates the slicer wrote into the file (s), NaN when absent.
  [[nodiscard]] double slicer_estimate_s() const { return slicer_estimate_s_; }
  /// Filament the slicer says the file uses (mm of filament), NaN when it states none.
  [[nodiscard]] double slicer_filament_mm() const { return slicer_filament_mm_; }
  /// The slicer's estimate for the model alone (Orca family's "model printing time", without
  /// its start sequence), NaN when absent.
  [[nodiscard]] double slicer_part_estimate_s() const { return slicer_part_estimate_s_; }
  /// Layers the slicer's header announces (Orca family's "total layer number", Cura's
  /// ";LAYER_COUNT:"), 0 when it states none.
  [[nodiscard]] long slicer_layer_count() const { return slicer_layer_count_; }
  /// Filament per tool the slicer states (mm), when it lists more than one; else empty.
  [[nodiscard]] const std::vector<double>& slicer_tool_filament_mm() const {
    return slicer_tool_filament_mm_;
  }
  /// Tool changes executed (T<n> to a tool other than the active one).
  [[nodiscard]] long tool_changes() const { return tool_changes_; }
  /// Time spent unloading and loading filament at those changes (s), as stated by the
  /// file's settings (InterpreterOptions::filament_load_s); part of the dwell time.
  [[nodiscard]] double tool_change_time_s() const { return tool_change_time_s_; }
  /// True once a slicer layer marker (`;LAYER_CHANGE`, `; CHANGE_LAYER`, `;LAYER:n`,
  /// `; BEGIN_LAYER_OBJECT z=`, `; layer N, Z = `) was seen: layers then follow the markers.
  [[nodiscard]] bool layers_from_markers() const { return marker_seen_; }
  [[nodiscard]] long moves_emitted() const { return moves_; }

 private:
  void add_finding(Finding f);
  Status warn(long line, std::string_view text, const std::string& message, std::string code);
  Status linear_move(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status arc_move(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  /// The F, X/Y/Z and E words of G0-G3 applied to the modal state: new feedrate, the target
  /// in logical coordinates and the filament delta (E position updated).
  Status motion_words(const GcodeCommand& c, std::string_view text, Vec3& target, double& de);
  Status home(const GcodeCommand& c, InterpreterOutput& out);
  void comment(std::string_view comment);
  void layer_tag(std::string_view c);
  void z_tag(std::string_view c);
  void slicer_tag(std::string_view c);
  void emit(const Vec3& target_logical, double e_delta_mm, double feedrate_mm_s, MoveKind forced,
            bool is_forced, long line, std::string_view text, InterpreterOutput& out);
  /// The cold_extrusion finding of an E move at `at` (an error in the part's layers).
  void report_cold_extrusion(long line, const Vec3& at);
  void heat_wait(bool hotend, double target_c, bool wait_cooling, long line, InterpreterOutput& out,
                 int heater = -1);
  void set_hotend_target(double target_c, int heater = -1);
  /// T<n> (and Klipper's ACTIVATE_EXTRUDER): selects tool n (tool_change.cpp).
  /// `named`: the firmware command names the extruder (ACTIVATE_EXTRUDER), so it exists.
  Status select_tool(long tool, long line, std::string_view text, InterpreterOutput& out,
                     bool named = false);
  /// The hotend heater a T parameter (or Klipper heater name) addresses; -1 = none valid.
  [[nodiscard]] int heater_of_tool(long tool) const;
  /// The heater of the active tool (0 when none is selected).
  [[nodiscard]] int active_heater() const { return std::max(0, heater_of_tool(tool_)); }
  void set_bed_target(double target_c);
  /// An info finding listed once per code; later occurrences are counted in it.
  void note(std::string code, std::string message, long line);
  Status extended(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status execute_g(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status execute_m(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status unknown_command(const GcodeCommand& c);
  Status g10_g11(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  void set_position(const GcodeCommand& c);
  void soft_endstops(const GcodeCommand& c, bool s_switches_all);
  Status set_temperature(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status set_axis_limits(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status set_rrf_jerk(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  void set_retraction(const GcodeCommand& c);
  Status prusa_printer_check(const GcodeCommand& c, std::string_view text);
  Status set_acceleration(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status start_macro(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  Status firmware_retract(const GcodeCommand& c, bool retract, std::string_view text,
                          InterpreterOutput& out);
  Status klipper_m204(const GcodeCommand& c, std::string_view text, InterpreterOutput& out);
  void layer_marker(double z_mm);
  void stated_figures(std::string_view comment);
  double hotend_temp_now(int heater = -1) const;
  /// Whether E words are relative now, as the firmware flavour reads G90/G91 and M82/M83.
  [[nodiscard]] bool e_relative() const;

  PrinterProfile profile_;
  InterpreterOptions options_;
  MotionLimits limits_;
  std::vector<Finding> findings_;
  std::map<std::string, int> finding_counts_;
  std::map<std::string, long> unknown_;
  std::map<std::string, long> unknown_first_line_;
  std::map<std::string, int> object_names_;
  std::vector<double> layer_z_;
  std::string slicer_;
  double slicer_estimate_s_;
  double slicer_filament_mm_;
  double slicer_part_estimate_s_;
  long slicer_layer_count_ = 0;
  long markers_ = 0;  ///< layer markers read (a repeated height counts again)
  std::vector<double> slicer_tool_filament_mm_;
  int slicer_estimate_rank_ = 0;         ///< which stated time won (normal mode beats totals)
  bool estimate_from_time_tag_ = false;  ///< Cura's ";TIME:" (a placeholder when unfilled)

  /// Firmware flavour (PrinterProfile::firmware).
  enum class Flavour : std::uint8_t { marlin2, marlin1, prusa, klipper, rrf, bambu };
  Flavour flavour_ = Flavour::marlin2;
  // Firmware retraction in force (G10/G11; M207 / SET_RETRACTION change it).
  double min_extrude_temp_c_ = 170;  ///< M302 S (P1: cold extrusion allowed)
  double fw_length_mm_ = 0, fw_speed_mm_s_ = 0, fw_recover_speed_mm_s_ = 0;
  double fw_recover_extra_mm_ = 0, fw_zraise_mm_ = 0;
  // Layer markers.
  bool markers_expected_ = false;  ///< the header names a slicer that writes layer markers
  /// What the slicer writes after the end code, to tell a file that was cut: Bambu, Orca and
  /// Creality Print close "; EXECUTABLE_BLOCK_START" with "_END", Cura writes ";End of
  /// Gcode", PrusaSlicer and its family "; filament used".
  bool executable_block_open_ = false, executable_block_closed_ = false;
  bool cura_end_seen_ = false, filament_used_seen_ = false, config_end_seen_ = false;
  bool marker_seen_ = false;
  bool layer_pending_ = false;  ///< a marker was seen; its layer starts at the next extrusion
  double pending_layer_z_ = 0;  ///< NaN: Z of the first extrusion

  // Modal state (Marlin's names in comments).
  Vec3 logical_mm_ = Vec3::Zero();  ///< current_position (XYZ, logical)
  Vec3 offset_mm_ = Vec3::Zero();   ///< machine = logical + offset (G92 shift, not homed)
  double e_logical_mm_ = 0;         ///< current_position.e
  bool relative_xyz_ = false, relative_e_ = false;
  bool e_mode_relative_ = false;  ///< M83 (M82 clears it); G90/G91 leave it (e_relative())
  bool inches_ = false;
  std::array<bool, 3> homed_{false, false, false};
  /// M211: software endstops per axis (Marlin switches all; Bambu's firmware switches them
  /// per axis and keeps a stack: "M211 S" pushes the state, "M211 R" pops it).
  std::array<bool, 3> soft_endstops_{true, true, true};
  std::vector<std::array<bool, 3>> soft_endstop_stack_;
  double feedrate_mm_s_ = 0;        ///< modal F (mm/s)
  double flow_ = 1.0;               ///< M221
  double volumetric_area_mm2_ = 0;  ///< M200: 0 = off
  double filament_mm_ = 0;
  /// A heater's linear thermal ramp: target, temperature when it was set, and when.
  struct Heater {
    double target_c = 0, at_set_c = 0, set_clock_s = 0;
  };
  static constexpr int kMaxTools = 16;
  std::array<Heater, kMaxTools> hotends_{};  ///< one per nozzle (only [0] on a shared nozzle)
  int tool_ = 0;                             ///< active_extruder (-1: none, Bambu T255)
  /// RepRapFirmware G10 P<tool> S<C>: each tool's active temperature (NaN: not set).
  std::array<double, kMaxTools> rrf_active_c_;
  long tool_changes_ = 0;
  double tool_change_time_s_ = 0;  ///< filament unload + load waits (shared nozzle)
  double bed_target_c_;
  double bed_c_at_set_;  ///< temperature when the target was set
  double bed_set_clock_s_ = 0;
  double nominal_clock_s_ = 0;  ///< time estimate of the interpreter (for the thermal model)
  bool fw_retracted_ = false;
  bool reported_before_homing_ = false;
  // Tags.
  int layer_ = -1;
  Feature feature_ = Feature::unknown;
  int object_id_ = -1;
  float width_hint_mm_ = 0, height_hint_mm_ = 0;
  long moves_ = 0;
  long last_line_ = 0;
};

/// Machine limits that the slicer wrote in its config block (`; machine_max_acceleration_x =
/// 500`, `; machine_max_jerk_x = 8`, ...; PrusaSlicer and SuperSlicer at the end,
/// OrcaSlicer / Bambu Studio / Creality Print name the speeds `machine_max_speed_*` and put
/// the block at the end or the start), as the limits its own time estimator used: classic
/// jerk with PrusaSlicer's safe-speed rule, no minimum segment time, and for the Orca family
/// MotionLimits::orca_compat. `text` is the part of the file to search (the caller passes
/// the head and the tail). Error when no block is found.
[[nodiscard]] Result<MotionLimits> limits_from_prusaslicer_config(std::string_view text,
                                                                  const MotionLimits& base);

}  // namespace printtwin
