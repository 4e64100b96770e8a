#pragma once
// Private types of the slicer (src/slice/ only). Clipper 6.4 is used in integer microns;
// it never appears in a public header.
#include <polyclipping/clipper.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/slice.hpp"

namespace printtwin::slice_detail {

using CPoint = ClipperLib::IntPoint;
using CPath = ClipperLib::Path;
using CPaths = ClipperLib::Paths;

constexpr double kUmPerMm = 1000.0;
inline ClipperLib::cInt to_um(double mm) {
  return static_cast<ClipperLib::cInt>(std::llround(mm * kUmPerMm));
}
inline double to_mm(ClipperLib::cInt um) { return static_cast<double>(um) / kUmPerMm; }

/// A polygon with holes (outer CCW, holes CW).
struct ExPolygon {
  CPath contour;
  CPaths holes;
};
using ExPolygons = std::vector<ExPolygon>;

/// What an extrusion is, in PrusaSlicer's `;TYPE:` vocabulary.
enum class Role : std::uint8_t {
  external_perimeter,
  perimeter,
  sparse_infill,
  solid_infill,
  top_solid_infill,
  bridge_infill,
  gap_fill,
  skirt,
};
const char* role_label(Role r);

/// One extrusion path: a closed loop or an open polyline, in microns.
struct ExtrusionPath {
  Role role = Role::perimeter;
  CPath points;
  bool closed = false;
  double width_mm = 0;
  /// Cross-section of the bead (mm^2); bridges use a round bead of the nozzle's diameter.
  double area_mm2 = 0;
};

/// Everything printed inside one island (connected region) of a layer, in print order
/// groups: perimeters (already ordered inner -> outer or reversed), gap fill, infill.
struct Island {
  std::vector<ExtrusionPath> perimeters;
  std::vector<ExtrusionPath> gap_fill;
  std::vector<ExtrusionPath> infill;  ///< open lines, ordered later by the writer
  CPath outline;                      ///< outer contour (for ordering islands)
};

/// A thin feature that was too narrow to print.
struct DroppedFeature {
  int layer = 0;
  double width_mm = 0;
  double area_mm2 = 0;
  double x_mm = 0, y_mm = 0;
  double min_x_mm = 0, min_y_mm = 0, max_x_mm = 0, max_y_mm = 0;
};

/// The toolpaths of one layer.
struct LayerToolpaths {
  int index = 0;
  double print_z_mm = 0;
  double height_mm = 0;
  std::vector<ExtrusionPath> skirt;  ///< skirt and brim loops (layer 0.. skirt_height-1)
  std::vector<Island> islands;
  CPaths boundary;  ///< the layer's slice outlines (travel crossing test)
  std::vector<DroppedFeature> dropped;
  bool has_bridge = false;
};

/// Converts public outlines to Clipper paths.
CPaths to_paths(const std::vector<std::vector<Point2um>>& polygons);
/// Groups a PolyTree / a set of paths into polygons with holes.
ExPolygons to_expolygons(const CPaths& paths);
CPaths to_paths(const ExPolygons& polys);

// Clipper helpers (microns).
CPaths offset(const CPaths& paths, double delta_um,
              ClipperLib::JoinType join = ClipperLib::jtMiter);
CPaths offset(const ExPolygons& polys, double delta_um,
              ClipperLib::JoinType join = ClipperLib::jtMiter);
CPaths clip(const CPaths& subject, const CPaths& clip, ClipperLib::ClipType type);
CPaths unite(const CPaths& a);
/// Parts of `a` that remain after an erosion by r then a dilation by r (morphological opening).
CPaths opening(const CPaths& a, double r_um);
double area_mm2(const CPaths& paths);
/// Open polylines clipped to the inside of `region`.
CPaths clip_lines(const CPaths& lines, const CPaths& region);

/// Toolpaths of every layer, from the layer outlines (parallel over layers).
struct RegionResult {
  std::vector<LayerToolpaths> layers;
};
RegionResult plan_layers(const std::vector<LayerOutline>& outlines, const SliceSettings& settings);

/// Infill lines for `region` (paths in microns) with a pattern, spacing and angle.
CPaths infill_lines(const CPaths& region, InfillPattern pattern, double spacing_um,
                    double angle_deg, int layer_index);

/// Centre line of a narrow polygon (a strip): returns an open polyline and the strip's
/// mean width in mm (2 x area / perimeter). Holes make it a closed loop (`closed` true).
struct Centerline {
  CPaths paths;
  bool closed = false;
  double width_mm = 0;
};
Centerline centerline(const ExPolygon& strip);

/// Writes the layers as G-code (start code, layers, end code, no footer).
struct WriterResult {
  std::string gcode;
  long retractions = 0;
  double extruded_mm3[8] = {0, 0, 0, 0, 0, 0, 0, 0};  ///< per Role
  double filament_mm = 0;
};
Result<WriterResult> write_gcode(const std::vector<LayerToolpaths>& layers,
                                 const PrinterProfile& printer, const SliceSettings& settings,
                                 const std::string& source_name);

}  // namespace printtwin::slice_detail
