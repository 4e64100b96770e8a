#pragma once
// Move: one straight nozzle move as the interpreter resolved it from G-code (arcs already
// segmented). It is the link between the G-code interpreter (gcode.hpp), the motion
// planner (planner.hpp) and the deposit (deposit.hpp). Machine frame, millimetres.
#include <cstdint>
#include <string_view>

#include "printtwin/geometry.hpp"

namespace printtwin {

/// Feature type of a move, from the slicers' `;TYPE:` / `; FEATURE:` comments.
enum class Feature : std::uint8_t {
  unknown = 0,
  outer_perimeter,  ///< PrusaSlicer "External perimeter", Cura WALL-OUTER
  perimeter,        ///< PrusaSlicer "Perimeter", Cura WALL-INNER
  overhang_perimeter,
  sparse_infill,  ///< "Internal infill", Cura FILL
  solid_infill,   ///< "Solid infill", Cura SKIN
  top_solid_infill,
  bridge_infill,
  gap_fill,
  skirt,  ///< skirt and brim
  support,
  support_interface,
  wipe_tower,
  custom,  ///< start/end code, purge lines
  count_
};

[[nodiscard]] std::string_view to_string(Feature f);
/// Maps a slicer's feature label (PrusaSlicer, Slic3r, Cura, Orca) to a Feature.
[[nodiscard]] Feature feature_from_label(std::string_view label);

enum class MoveKind : std::uint8_t {
  travel,     ///< no extrusion
  extrude,    ///< E increases while XY(Z) moves: lays a bead
  retract,    ///< E decreases (with or without XY motion: wipes)
  unretract,  ///< E increases without XY motion (deretraction / priming)
  home,       ///< part of a G28 homing sequence
};

struct Move {
  Vec3 start_mm = Vec3::Zero();  ///< nozzle tip at the start
  Vec3 end_mm = Vec3::Zero();    ///< nozzle tip at the end
  /// Filament pushed into the hotend during the move, mm of filament, after M221 flow and
  /// M200 volumetric conversion (negative: retraction).
  double e_mm = 0;
  double feedrate_mm_s = 0;  ///< requested speed of the move (after M220)
  long line = 0;             ///< 1-based G-code line that produced it
  int layer = -1;            ///< layer index (by Z of extrusions), -1 before the first
  Feature feature = Feature::unknown;
  MoveKind kind = MoveKind::travel;
  /// Active tool (T<n>): the extruder, or on a single-nozzle multi-material printer (AMS,
  /// MMU) the loaded filament. 0 on single-extruder files.
  std::uint8_t tool = 0;
  int object_id = -1;        ///< M486 / EXCLUDE_OBJECT label index, -1 when none
  float width_hint_mm = 0;   ///< `;WIDTH:` of the slicer, 0 when absent
  float height_hint_mm = 0;  ///< `;HEIGHT:` of the slicer, 0 when absent

  [[nodiscard]] double length_mm() const { return (end_mm - start_mm).norm(); }
  [[nodiscard]] double xy_length_mm() const { return (end_mm - start_mm).head<2>().norm(); }
};

}  // namespace printtwin
