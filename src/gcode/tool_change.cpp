// Tool changes: T<n> on multi-extruder printers (tool changers, IDEX, dual nozzles) and on
// single-nozzle multi-material printers (Bambu AMS, Prusa MMU), with per-tool heaters.
// References for behaviour (not code): Marlin gcode/control/T.cpp and module/tool_change.cpp
// (T<n> selects active_extruder; M104/M109 T<n> address that tool's heater), Klipper
// klippy/kinematics/extruder.py (ACTIVATE_EXTRUDER), RepRapFirmware's G-code dictionary
// (T<n>, G10 P<tool> S<active C>), Bambu Studio's filament-change G-code (M620 S<n>A ...
// T<n> ... M621 S<n>A) and PrusaSlicer's single_extruder_multi_material tool changes.
#include <algorithm>
#include <cmath>
#include <string>

#include "printtwin/gcode.hpp"

namespace printtwin {

int GcodeInterpreter::heater_of_tool(long tool) const {
  if (tool < 0 || tool >= kMaxTools) return -1;
  return options_.shared_nozzle ? 0 : static_cast<int>(tool);
}

namespace {
/// The value for `tool` of a per-tool list the slicer states (the last one when the list
/// is shorter, as the slicers repeat a single value); 0 when the list is empty.
double per_tool(const std::vector<double>& values, int tool) {
  if (values.empty() || tool < 0) return 0;
  return values[std::min(static_cast<std::size_t>(tool), values.size() - 1)];
}
}  // namespace

Status GcodeInterpreter::select_tool(long tool, long line, std::string_view text,
                                     InterpreterOutput& out, bool named) {
  if (flavour_ == Flavour::bambu && tool >= 255) {
    // Bambu: T255 unloads the filament back to the AMS (end code); T1000 and T1100 pick
    // the nozzle or the lidar as the reference point of the moves that follow.
    if (tool == 255) tool_ = -1;
    return Ok{};
  }
  const int declared = options_.tool_count;
  // A file that declares no tools was written for a single extruder; T0 is a no-op there
  // and Bambu files (one nozzle, AMS slots) name their filaments by T<n> anyway.
  const bool known =
      declared > 0 ? tool < declared : (tool == 0 || named || flavour_ == Flavour::bambu);
  if (tool >= kMaxTools || !known) {
    return warn(line, text,
                "tool T" + std::to_string(tool) +
                    (declared > 0 ? " selected, but the file's settings declare " +
                                        std::to_string(declared) + " tools; ignored"
                                  : " selected on a single-extruder printer"),
                "bad_tool");
  }
  if (tool == tool_) return Ok{};
  const int from = tool_;
  tool_ = static_cast<int>(tool);
  ++tool_changes_;
  if (options_.shared_nozzle) {
    // One nozzle: the printer unloads the old filament (AMS: cut and pull back; MMU: ram,
    // cool and pull back) and loads the new one. The purge that follows is G-code.
    const double s = (from >= 0 ? per_tool(options_.filament_unload_s, from) : 0.0) +
                     per_tool(options_.filament_load_s, tool_);
    if (s > 0) {
      out.synchronize();
      out.wait(s, false, line);
      nominal_clock_s_ += s;
      tool_change_time_s_ += s;
    }
    return Ok{};
  }
  // Separate nozzles: the new tool's own heater is active from now on; the switch itself
  // (parking one tool, picking the other) takes the time the slicer states, if any.
  if (options_.tool_change_s > 0 && from >= 0) {
    out.synchronize();
    out.wait(options_.tool_change_s, false, line);
    nominal_clock_s_ += options_.tool_change_s;
    tool_change_time_s_ += options_.tool_change_s;
  }
  // RepRapFirmware brings the new tool to its active temperature (G10 P<n> S<C>).
  if (flavour_ == Flavour::rrf && !std::isnan(rrf_active_c_[static_cast<std::size_t>(tool)]))
    set_hotend_target(rrf_active_c_[static_cast<std::size_t>(tool)]);
  return Ok{};
}

}  // namespace printtwin
