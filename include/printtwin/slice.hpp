#pragma once
// printtwin's own slicer: Mesh -> layers -> toolpaths -> Marlin G-code text.
//
//   Mesh --slice_mesh(mesh, printer, settings)--> SliceOutput { gcode, findings, stats }
//
// Stages inside (src/slice/):
//  - mesh_slicer.cpp: every layer is cut at mid-height by a fast triangle/plane pass; the
//    segments are chained over shared mesh edges into closed loops (outer CCW, holes CW).
//  - layer_regions.cpp: Clipper 6.4 in integer microns: perimeters by inward offsets,
//    single-line thin walls and gap fill where a feature is narrower than two lines (a
//    `thin_wall_dropped` finding when narrower than the printable minimum), top / bottom /
//    bridge / solid / sparse regions from the layers above and below, skirt and brim.
//  - infill.cpp: rectilinear, grid, triangles, concentric patterns clipped to the regions.
//  - gcode_writer.cpp: ordering, seams, travel with retraction (and z-hop), cooling, the
//    PrusaSlicer-style `;TYPE:` / `;WIDTH:` / `;HEIGHT:` markers, relative E.
// Extrusion amounts follow the PrusaSlicer / Slic3r flow model: a bead of width w and
// height h has the stadium cross-section (w - h) h + pi h^2 / 4, and
// E = area * length / filament_area.
// The footer's time estimate comes from running the produced G-code text through the
// simulator's planner: G-code text is the only link between slicer and simulator.
// Settings keys follow PrusaSlicer's names (docs/slicer.md lists every key).
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"

namespace printtwin {

/// Sparse infill patterns. Solid layers always use rectilinear lines (monotonic order).
enum class InfillPattern { rectilinear, grid, triangles, concentric };
/// Where a closed loop starts: `nearest` to the nozzle, `aligned` (same corner on every
/// layer: the vertex nearest a fixed point at the rear-left of the part), `rear` (max y).
enum class SeamPosition { nearest, aligned, rear };

/// Every setting of a slice. Defaults are those of ../shared/peers/prusa_ender3.ini (the
/// PrusaSlicer Ender-3 profile): 0.2 mm layers, 2 perimeters, 4 top / 4 bottom, 20 % grid.
/// Widths of 0 mean "automatic" as in PrusaSlicer (1.125 x nozzle; top 1.0 x nozzle;
/// first layer 2 x first layer height). A negative width is a ratio given as a percentage:
/// -1.2 means 120 % of the nozzle diameter (of the first layer height for the first layer).
struct SliceSettings {
  // Layers
  double layer_height_mm = 0.2;
  double first_layer_height_mm = 0.2;
  // Extruder (override the printer profile's when set explicitly)
  double nozzle_diameter_mm = 0.4;
  double filament_diameter_mm = 1.75;
  double filament_density_g_cm3 = 1.24;
  double extrusion_multiplier = 1.0;
  // Widths (0 = automatic)
  double extrusion_width_mm = 0;  ///< `--line-width`: default for every feature
  double perimeter_width_mm = 0;
  double external_perimeter_width_mm = 0;
  double infill_width_mm = 0;
  double solid_infill_width_mm = 0;
  double top_infill_width_mm = 0;
  double first_layer_width_mm = 0;
  // Shells and infill
  int perimeters = 2;
  int top_solid_layers = 4;
  int bottom_solid_layers = 4;
  double infill_density = 0.20;  ///< 0..1
  InfillPattern infill_pattern = InfillPattern::grid;
  double fill_angle_deg = 45;
  double infill_overlap = 0.25;             ///< fraction of the perimeter width
  double solid_infill_below_area_mm2 = 70;  ///< smaller sparse regions are filled solid
  bool thin_walls = true;
  bool gap_fill = true;
  /// Features narrower than this are not printed (a `thin_wall_dropped` finding).
  /// 0 = a third of the nozzle diameter (0.13 mm for a 0.4 mm nozzle), PrusaSlicer's
  /// thin-wall limit, so that every wall PrusaSlicer prints is printed; negative = a
  /// fraction of the nozzle diameter (-1 drops everything narrower than the nozzle).
  double thin_wall_min_width_mm = 0;
  SeamPosition seam = SeamPosition::nearest;
  bool external_perimeters_first = false;
  // Speeds (mm/s)
  double perimeter_speed_mm_s = 40;
  double external_perimeter_speed_mm_s = 25;
  double infill_speed_mm_s = 50;
  double solid_infill_speed_mm_s = 40;
  double top_solid_infill_speed_mm_s = 30;
  double gap_fill_speed_mm_s = 30;
  double bridge_speed_mm_s = 25;
  double first_layer_speed_mm_s = 20;
  double travel_speed_mm_s = 150;
  double skirt_speed_mm_s = 0;  ///< 0 = the perimeter speed (first layer speed on layer 0)
  // Retraction
  double retract_length_mm = 5;
  double retract_speed_mm_s = 60;
  double deretract_speed_mm_s = 40;     ///< 0 = retract speed
  double retract_before_travel_mm = 2;  ///< shorter travels never retract
  bool retract_layer_change = true;
  bool only_retract_when_crossing_perimeters = false;
  double retract_lift_mm = 0;  ///< z-hop while retracted
  // Temperatures (deg C)
  double temperature_c = 200;
  double first_layer_temperature_c = 210;
  double bed_temperature_c = 60;
  double first_layer_bed_temperature_c = 60;
  // Cooling (PrusaSlicer's cooling logic; fan speeds in percent)
  bool cooling = true;
  bool fan_always_on = false;
  double min_fan_speed = 35;
  double max_fan_speed = 100;
  double bridge_fan_speed = 100;
  int disable_fan_first_layers = 3;
  double fan_below_layer_time_s = 60;
  double slowdown_below_layer_time_s = 5;
  double min_print_speed_mm_s = 10;
  // Skirt and brim
  int skirts = 1;
  double skirt_distance_mm = 3;
  int skirt_height = 1;  ///< layers
  double min_skirt_length_mm = 0;
  double brim_width_mm = 0;
  // Placement (machine frame). Default: bbox centred on the bed, lowest point on z = 0.
  std::optional<Vec2> center_mm;        ///< centre the bbox here instead of the bed centre
  std::optional<Vec3> place_offset_mm;  ///< translate by this, no centring (wins over center)
  /// Run the simulator's planner over the G-code for the footer's time estimate.
  bool estimate_time = true;

  bool operator==(const SliceSettings&) const = default;
};

/// Sets one setting from text, by PrusaSlicer key (`layer_height`, `fill_density`, ...)
/// or printtwin alias (`line_width`, `nozzle`, `infill_pattern`, ...). Accepts "20%" where
/// PrusaSlicer does. Unknown key or a value that does not parse: usage error naming both.
[[nodiscard]] Status set_slice_setting(SliceSettings& settings, std::string_view key,
                                       std::string_view value);

/// Keys of a PrusaSlicer config file that printtwin reads and the ones it ignores.
/// Where a setting was given: a config file and its 1-based line.
struct SettingSource {
  std::string file;
  long line = 0;
};
/// Setting key (PrusaSlicer's name) -> where its value came from. Keys given on the command
/// line are absent.
using SettingSources = std::map<std::string, SettingSource, std::less<>>;

struct IniLoadReport {
  std::vector<std::string> used_keys;
  std::vector<std::string> ignored_keys;  ///< known to PrusaSlicer, not used by printtwin
  SettingSources sources;                 ///< each used key's file and line (the last one)
};

/// Applies a flat PrusaSlicer .ini (`key = value` lines, `#` comments) to `settings`.
/// Keys printtwin supports are applied, others are listed in `ignored_keys`. A line that is
/// not `key = value` or a supported key whose value does not parse is an error naming the
/// file and line (bad input).
[[nodiscard]] Result<IniLoadReport> apply_prusa_ini(SliceSettings& settings, std::string_view text,
                                                    std::string_view source);
/// Where a PrusaSlicer (or SuperSlicer) 3MF project keeps its settings, in .ini syntax.
inline constexpr std::string_view kProjectConfigEntry = "Metadata/Slic3r_PE.config";
/// The text of a PrusaSlicer config: an .ini (or G-code config block) as it is, or the
/// settings a 3MF project stores (kProjectConfigEntry). A zip without them is an error.
[[nodiscard]] Result<std::string> read_prusa_config(const std::filesystem::path& path);
/// read_prusa_config on bytes already read (`source` names the file in errors).
[[nodiscard]] Result<std::string> prusa_config_text(std::string bytes, const std::string& source);
/// Reads the config (read_prusa_config) and calls apply_prusa_ini.
[[nodiscard]] Result<IniLoadReport> load_prusa_ini(SliceSettings& settings,
                                                   const std::filesystem::path& path);

/// The effective thin-wall limit of `settings` in mm (see `thin_wall_min_width_mm`).
[[nodiscard]] double min_thin_wall_width_mm(const SliceSettings& settings);

/// Rejects impossible combinations (layer height above 80 % of the nozzle, negative or
/// zero widths/speeds, density outside 0..100 %, ...) with a usage error naming the key.
[[nodiscard]] Status validate_slice_settings(const SliceSettings& settings,
                                             const SettingSources& sources = {});

/// Every setting as (PrusaSlicer key, value text) in a fixed order: the G-code header.
[[nodiscard]] std::vector<std::pair<std::string, std::string>> slice_settings_entries(
    const SliceSettings& settings);

/// Extrusion widths in effect after the automatic rules (mm).
struct ResolvedWidths {
  double external_perimeter_mm = 0, perimeter_mm = 0, infill_mm = 0, solid_infill_mm = 0,
         top_infill_mm = 0, first_layer_mm = 0;
};
[[nodiscard]] ResolvedWidths resolve_widths(const SliceSettings& settings);

/// Cross-section of a bead of width w on a layer of height h (PrusaSlicer's stadium):
/// (w - h) h + pi h^2 / 4, mm^2. For w < h the bead is a circle of diameter w.
[[nodiscard]] double bead_area_mm2(double width_mm, double height_mm);
/// Centre distance of neighbouring beads so that they just touch: w - h (1 - pi/4).
[[nodiscard]] double bead_spacing_mm(double width_mm, double height_mm);

/// A point of a layer outline in integer microns (machine frame).
struct Point2um {
  std::int64_t x_um = 0;
  std::int64_t y_um = 0;
  bool operator==(const Point2um&) const = default;
};

/// One sliced layer: closed polygons, outer contours counter-clockwise and holes clockwise
/// (after a union of all loops at this height, so shells that overlap are merged).
struct LayerOutline {
  int index = 0;
  double print_z_mm = 0;  ///< top of the layer (the nozzle height)
  double height_mm = 0;   ///< layer thickness
  double slice_z_mm = 0;  ///< where the mesh was cut: print_z - height / 2
  std::vector<std::vector<Point2um>> polygons;
  /// Gaps (at most 2 mm) between open outline pieces that were bridged: the mesh is not
  /// closed at this height. 0 for a closed mesh.
  int closed_gaps = 0;
};

/// Heights of the layers of an object `object_height_mm` tall: first layer, then
/// layer_height; the last layer is thinner when the height is not a multiple
/// (dropped when thinner than a quarter of the layer height). Returns print_z values.
[[nodiscard]] std::vector<double> layer_print_z(double object_height_mm,
                                                const SliceSettings& settings);

/// Cuts an already placed mesh (z = 0 on the bed) into layer outlines. Where the mesh is not
/// closed, open outline pieces are joined across gaps up to 2 mm (counted in `closed_gaps`);
/// a piece that cannot be closed so is an error naming the layer and where it ends.
[[nodiscard]] Result<std::vector<LayerOutline>> slice_layers(const Mesh& placed_mesh,
                                                             const SliceSettings& settings);

/// Figures of one slice.
struct SliceStats {
  int layer_count = 0;
  double object_height_mm = 0;
  double part_volume_mm3 = 0;      ///< of the mesh
  double filament_mm = 0;          ///< sum of positive E outside retract/deretract
  double filament_volume_mm3 = 0;  ///< filament_mm x filament cross-section
  double filament_g = 0;
  /// Extruded volume per feature: external perimeter, perimeter, internal infill, solid,
  /// top solid, bridge, gap fill, skirt/brim.
  double external_perimeter_mm3 = 0, perimeter_mm3 = 0, sparse_infill_mm3 = 0, solid_infill_mm3 = 0,
         top_solid_infill_mm3 = 0, bridge_infill_mm3 = 0, gap_fill_mm3 = 0, skirt_brim_mm3 = 0;
  long gcode_lines = 0;
  long retractions = 0;
  double estimated_time_s = 0;  ///< from the simulator's planner (0 when not run)
  bool time_from_simulator = false;
  Vec3 placement_offset_mm = Vec3::Zero();  ///< translation applied to the input mesh
  bool mesh_repaired = false;
};

struct SliceOutput {
  std::string gcode;              ///< complete Marlin G-code text
  std::vector<Finding> findings;  ///< thin_wall_dropped, mesh_repaired, ...
  SliceStats stats;
};

/// Slices `mesh` for `printer` with `settings`: places it (centred on the bed unless the
/// settings say otherwise), slices, plans toolpaths and writes G-code with the printer's
/// start / end code. Deterministic: same input, same bytes. Errors: settings invalid
/// (usage), mesh empty / not closed and not repairable / outside the build volume (bad input).
[[nodiscard]] Result<SliceOutput> slice_mesh(const Mesh& mesh, const PrinterProfile& printer,
                                             const SliceSettings& settings);

}  // namespace printtwin
