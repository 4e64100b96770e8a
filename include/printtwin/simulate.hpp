#pragma once
// simulate_gcode(): any slicer's G-code on the simulated Ender-3 in one call.
//
// Pipeline (streaming, memory bounded by the planner's look-ahead window):
//   text -> GcodeLineReader -> parse_gcode_line -> GcodeInterpreter -> Move
//        -> Planner (Marlin 2.1 look-ahead) -> MotionSegment (timed)
// Every Move and every MotionSegment can be observed through a MoveSink (planner.hpp),
// which is how the deposit (deposit.hpp) and the trace writer consume the simulation.
//
//   auto profile = load_printer_profile("ender3");
//   std::ifstream in("part.gcode", std::ios::binary);
//   auto sim = simulate_gcode(in, *profile, {});
//   if (!sim) return sim.error();      // bad input: file:line: message
//   sim->print_time_s, sim->layers, sim->findings ...
#include <array>
#include <filesystem>
#include <istream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/gcode.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/result.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin {

struct SimulateOptions {
  InterpreterOptions interpreter;  ///< strict mode, cold extrusion, power-on state
  /// Use the machine limits of PrusaSlicer's config block at the end of the file (and its
  /// estimator's junction model) instead of the profile's; error if the block is missing.
  bool limits_from_gcode = false;
  /// Name of the input for error messages ("part.gcode").
  std::string source_name;
};

/// One layer (index = Move::layer): the slicer's layer markers when the file has them
/// (docs/gcode-coverage.md), otherwise made by the Z of extrusion moves.
struct LayerStats {
  int index = 0;
  double z_mm = 0;         ///< Z of its extrusions
  double height_mm = 0;    ///< z minus the Z of the highest lower layer (the bed for the first)
  double time_s = 0;       ///< motion + waits while this layer was current
  double filament_mm = 0;  ///< net filament of its moves
  long first_line = 0;     ///< G-code line of its first extrusion
};

/// Everything the simulation measured. Times in seconds on the simulated printer's clock.
struct SimulationResult {
  double print_time_s = 0;    ///< motion + homing + dwell + heating
  double motion_time_s = 0;   ///< planned moves except homing
  double homing_time_s = 0;   ///< G28 sequences
  double dwell_time_s = 0;    ///< G4
  double heating_time_s = 0;  ///< M109/M190 waits (profile heat rates)
  double filament_mm = 0;     ///< net filament pushed (sum of Move::e_mm)
  /// Filament of the part alone: net filament of the moves in the slicer's layers that are
  /// not start/end code (purge lines, priming, anything before the first layer marker),
  /// up to the last extrusion of the last layer (the end code's retraction is not counted).
  double filament_part_mm = 0;
  /// Filament pushed by the moves that extrude while the nozzle moves (sum of Move::e_mm
  /// of extrusion moves): what PrusaSlicer, the Orca family and KISSlicer state, start-code
  /// purge lines included, E-only priming and unretractions left out.
  double filament_extruding_mm = 0;
  double filament_mm3 = 0;         ///< filament_mm times the filament cross-section
  double retracted_mm = 0;         ///< sum of retractions (positive)
  double extrude_distance_mm = 0;  ///< nozzle path length of extrusion moves
  double travel_distance_mm = 0;   ///< nozzle path length of travel moves
  double max_speed_mm_s = 0;       ///< highest cruise speed of any segment
  std::vector<LayerStats> layers;
  /// Motion time by feature (to_string(Feature) of extrusions), plus "travel", "retract",
  /// "homing" for the other move kinds.
  std::map<std::string, double> time_by_feature_s;
  std::vector<Finding> findings;
  /// Unknown commands ("M600", "G29") with how often each occurred (reported once each).
  std::map<std::string, long> unknown_commands;
  long lines = 0;            ///< lines read
  long moves = 0;            ///< Moves interpreted (arcs count their pieces)
  long segments = 0;         ///< planned segments
  Box3 extrusion_bounds_mm;  ///< box of all extrusion moves (machine frame)
  Box3 motion_bounds_mm;     ///< box of all nozzle positions
  std::string slicer;        ///< "PrusaSlicer 2.5.0", "Cura_SteamEngine 4.13.1", ...
  /// Names of the labelled objects by Move::object_id (EXCLUDE_OBJECT, PrusaSlicer's
  /// "printing object", Cura's ;MESH:); M486 objects numbered only are absent.
  std::map<int, std::string> object_names;
  /// The slicer's own time estimate found in the file (PrusaSlicer normal mode, Orca's total
  /// estimated time, Cura ;TIME:, ...; docs/gcode-coverage.md), if any.
  std::optional<double> slicer_estimate_s;
  /// The slicer's estimate for the model alone, without its start sequence (the Orca
  /// family's "model printing time"), if it states one; compared with the layers' time.
  std::optional<double> slicer_part_estimate_s;
  /// The filament the slicer says the file uses (mm), if it states it.
  std::optional<double> slicer_filament_mm;
  /// Multi-tool files: net filament per tool (index = T<n>; for a shared nozzle, per
  /// filament), the tool changes, the time spent unloading and loading filament (or
  /// switching tools) at them (part of dwell_time_s), and the filament per tool the slicer
  /// states. Empty / 0 for single-tool files.
  std::vector<double> tool_filament_mm;
  long tool_changes = 0;
  double tool_change_time_s = 0;
  std::vector<double> slicer_tool_filament_mm;
  /// "markers" when layers follow the slicer's layer markers, "z" when made by Z.
  std::string layers_from = "z";
  MotionLimits limits_used;  ///< limits in force at the start (after --limits-from-gcode)
  bool limits_from_gcode = false;
  /// The printer the run used, with the source of each value (profile.origin; JSON "printer").
  PrinterProfile printer;
};

/// Runs G-code text on the simulated printer. `sink` (optional) sees every Move and
/// MotionSegment as they are produced. Bad input -> Error with file and line; print defects
/// -> SimulationResult::findings. With options.limits_from_gcode the stream must be
/// seekable (a file), since PrusaSlicer writes its limits at the end.
[[nodiscard]] Result<SimulationResult> simulate_gcode(std::istream& in,
                                                      const PrinterProfile& profile,
                                                      const SimulateOptions& options,
                                                      MoveSink* sink = nullptr);
/// Same, reading a file (errors name the file).
[[nodiscard]] Result<SimulationResult> simulate_gcode_file(const std::filesystem::path& path,
                                                           const PrinterProfile& profile,
                                                           const SimulateOptions& options,
                                                           MoveSink* sink = nullptr);

/// Only interprets (no planning): every Move of the file in order. Convenience for small
/// files and tests; for big files prefer simulate_gcode with a MoveSink.
[[nodiscard]] Result<std::vector<Move>> interpret_gcode(std::istream& in,
                                                        const PrinterProfile& profile,
                                                        const SimulateOptions& options);
[[nodiscard]] Result<std::vector<Move>> interpret_gcode_file(const std::filesystem::path& path,
                                                             const PrinterProfile& profile,
                                                             const SimulateOptions& options);

/// SimulationResult as JSON (schema "printtwin.simulate/1", docs/simulate.md).
[[nodiscard]] std::string simulation_to_json(const SimulationResult& result,
                                             const std::string& input_name);
/// Short human-readable summary (several lines).
[[nodiscard]] std::string simulation_summary(const SimulationResult& result);

}  // namespace printtwin
