#pragma once
// PrinterProfile: every number of the simulated printer. The stock Ender-3 with Marlin 2.1
// is built in (`ender3_marlin2()`); JSON files in samples/printers/ replace or override any
// value (docs/printer-profile.md lists the keys).
#include <Eigen/Core>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/result.hpp"

namespace printtwin {

/// How the planner limits speed at the junction between two moves.
enum class JunctionModel { junction_deviation, classic_jerk };

/// Where one value of a profile came from (docs/printer-profile.md, "Provenance").
struct ValueOrigin {
  std::string key;     ///< profile key, e.g. "bed_max_x_mm"
  std::string source;  ///< "file", "library", "config" (a JSON or printer.cfg), "default"
  std::string detail;  ///< the G-code setting key, the library id, or "file:line"
};

/// How a run's printer was chosen (printer.hpp, resolve_printer) and where each value came
/// from. Empty `values` means nothing was recorded (a profile built in code).
struct PrinterOrigin {
  std::string how;         ///< "auto", "explicit" or "" (built in code)
  std::string summary;     ///< one line for people: which printer and why
  std::string library_id;  ///< library profile used ("" if none)
  std::string slicer;      ///< slicer whose embedded settings were read ("" if none)
  std::vector<ValueOrigin> values;
  /// About the identification itself (unknown printer, file made for a larger bed...).
  std::vector<Finding> findings;
  /// First-layer temperatures the file's settings state (°C, NaN = not stated): what a
  /// start macro called without parameters heats to.
  double macro_hotend_c = std::numeric_limits<double>::quiet_NaN();
  double macro_bed_c = std::numeric_limits<double>::quiet_NaN();
  /// Tools the file's settings declare (StatedPrinter; 0 = not stated), whether they share
  /// one nozzle, and the stated filament unload / load and tool change times (s).
  int tool_count = 0;
  bool shared_nozzle = false;
  std::vector<double> filament_load_s, filament_unload_s;
  double tool_change_s = 0;

  /// Records (or replaces) the origin of `key`.
  void set(const std::string& key, const std::string& source, const std::string& detail);
  [[nodiscard]] const ValueOrigin* find(std::string_view key) const;
};

/// Per-axis values are ordered X, Y, Z, E.
struct PrinterProfile {
  std::string name = "Creality Ender-3 (Marlin 2.1)";
  /// Firmware flavour: "marlin2", "marlin1", "prusa" (Prusa's Marlin fork), "klipper",
  /// "rrf" (RepRapFirmware), "bambu". Decides how flavour-specific commands and start/end
  /// macros behave (docs/gcode-coverage.md) and which planner times the moves.
  std::string firmware = "marlin2";
  /// Printer model as the vendor names it ("MK4S", "K1 Max"), "" when unknown.
  std::string model;

  // Build volume (machine frame, mm). The seed's gantry: Joint_X moves the head along the
  // X beam, Joint_Y moves the bed, Joint_Z lifts the gantry.
  double bed_min_x_mm = 0, bed_min_y_mm = 0;
  double bed_max_x_mm = 235, bed_max_y_mm = 235, max_z_mm = 250;
  /// Physical travel of the joints (the endstops sit at the min ends).
  double travel_min_x_mm = 0, travel_min_y_mm = 0, travel_min_z_mm = 0;
  double travel_max_x_mm = 235, travel_max_y_mm = 235, travel_max_z_mm = 250;
  bool software_endstops = true;

  Eigen::Vector4d steps_per_mm{80, 80, 400, 93};
  Eigen::Vector4d max_feedrate_mm_s{500, 500, 5, 25};
  Eigen::Vector4d max_accel_mm_s2{500, 500, 100, 5000};
  double print_accel_mm_s2 = 500;    ///< M204 P
  double retract_accel_mm_s2 = 500;  ///< M204 R
  double travel_accel_mm_s2 = 500;   ///< M204 T
  JunctionModel junction = JunctionModel::junction_deviation;
  double junction_deviation_mm = 0.08;
  Eigen::Vector4d jerk_mm_s{10, 10, 0.3, 5};  ///< classic jerk (M205 X Y Z E)
  double min_feedrate_mm_s = 0;               ///< M205 S
  double min_travel_feedrate_mm_s = 0;        ///< M205 T
  double min_segment_time_s = 0.02;           ///< M205 B (Marlin MIN_SEGMENT_TIME_US 20000)
  int block_buffer_size = 16;                 ///< look-ahead window (Marlin BLOCK_BUFFER_SIZE)
  double max_accel_to_decel_ratio = 1.0;  ///< Klipper's minimum_cruise_ratio-style limit (1 = off)
  // Klipper's planner ([printer] section of printer.cfg); used when firmware == "klipper".
  double square_corner_velocity_mm_s = 5.0;  ///< Klipper square_corner_velocity
  double minimum_cruise_ratio = 0.5;         ///< Klipper minimum_cruise_ratio (0 = off)
  double max_extrude_only_velocity_mm_s =
      0;                                    ///< [extruder] max_extrude_only_velocity (0 = derived)
  double max_extrude_only_accel_mm_s2 = 0;  ///< [extruder] max_extrude_only_accel (0 = derived)

  // Homing (G28): min endstops, fast approach, bump back, slow re-approach.
  Eigen::Vector3d homing_feedrate_mm_s{20, 20, 4};
  Eigen::Vector3d homing_bump_mm{5, 5, 2};
  Eigen::Vector3d homing_bump_divisor{2, 2, 4};
  bool quick_home = true;  ///< X and Y approach together on a diagonal

  // Arcs (G2/G3), like Marlin's plan_arc.
  double arc_min_segment_mm = 0.1;
  double arc_max_segment_mm = 1.0;
  int arc_min_segments_per_circle = 72;

  // Extruder and thermal.
  double nozzle_diameter_mm = 0.4;
  double filament_diameter_mm = 1.75;
  double min_extrude_temp_c = 170;
  double hotend_heat_rate_c_s = 2.0;  ///< average heat-up rate for M109 waits
  double bed_heat_rate_c_s = 0.5;     ///< average heat-up rate for M190 waits
  double ambient_temp_c = 25;
  bool firmware_retraction = false;  ///< G10/G11 enabled
  double fw_retract_length_mm = 5.0;
  double fw_retract_speed_mm_s = 45.0;
  double fw_recover_speed_mm_s = 45.0;
  double fw_retract_zraise_mm = 0.0;

  // How the material behaves where it is laid over air or pressed on the bed (the deposit's
  // sag, droop and elephant's foot; docs/deposit.md gives the model and the sources).
  double bridge_sag_mm = 0.8;  ///< mid-span sag of a bridge of bridge_sag_span_mm (sag ~ span^2)
  double bridge_sag_span_mm = 50;  ///< reference span of bridge_sag_mm
  double overhang_fall_mm = 1.5;   ///< a cantilevered bead this far beyond the layer below falls
  double overhang_droop_mm =
      2.0;  ///< droop at overhang_fall_mm (droop ~ distance^2); a fallen bead's hang
  double elephant_foot_mm = 0.1;  ///< outward bulge of the first layer's outer edge

  std::string start_gcode;  ///< used by the slicer
  std::string end_gcode;

  PrinterOrigin origin;  ///< where the values came from (filled by resolve_printer)

  [[nodiscard]] double filament_area_mm2() const {
    return 0.25 * 3.14159265358979323846 * filament_diameter_mm * filament_diameter_mm;
  }
  [[nodiscard]] double bed_center_x_mm() const { return 0.5 * (bed_min_x_mm + bed_max_x_mm); }
  [[nodiscard]] double bed_center_y_mm() const { return 0.5 * (bed_min_y_mm + bed_max_y_mm); }
};

/// Stock Ender-3, Marlin 2.1 defaults (junction deviation 0.08 mm).
[[nodiscard]] PrinterProfile ender3_marlin2();
/// Ender-3 with Marlin 1.1.9: classic jerk 10/10/0.3/5.
[[nodiscard]] PrinterProfile ender3_marlin1();
/// Ender-3 driven by Klipper (printer-creality-ender3-2018.cfg numbers).
[[nodiscard]] PrinterProfile ender3_klipper();

/// "ender3", "ender3-marlin1", "ender3-klipper", or a path to a JSON profile. A JSON file
/// may name a `base` built-in and override any key; unknown keys and wrong types are
/// errors naming the key and the file.
[[nodiscard]] Result<PrinterProfile> load_printer_profile(std::string_view name_or_path);
/// Parses a JSON profile text (see load_printer_profile); `source` names it in errors.
[[nodiscard]] Result<PrinterProfile> parse_printer_profile(std::string_view json_text,
                                                           std::string_view source);
/// The profile as JSON (every key), e.g. for reports.
[[nodiscard]] std::string printer_profile_to_json(const PrinterProfile& profile);
/// The `printer` object of the simulate JSON and report.json: name, model, firmware, how it
/// was chosen, and every value the run used with its source (docs/printer-profile.md).
[[nodiscard]] std::string printer_provenance_json(const PrinterProfile& profile);
/// One line for text summaries: "Prusa MK4S (library prusa-mk4s, 21 values from the file)".
[[nodiscard]] std::string printer_provenance_summary(const PrinterProfile& profile);
/// Names of the profile keys (as in JSON profiles), in a stable order.
[[nodiscard]] std::vector<std::string> printer_profile_keys();

}  // namespace printtwin
