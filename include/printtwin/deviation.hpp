#pragma once
// Deviation: how far the deposit (what the printer would make) is from the mesh (what was
// designed), both ways, signed, with statistics and clusters of out-of-tolerance samples.
//
// Frames and signs
// - Everything is in the machine (G-code) frame, millimetres. The mesh must already be
//   placed there (see `register_mesh`).
// - Deposit -> mesh: from each exposed face of the deposit's outer surface, the distance to
//   the closest point of the mesh; positive when the face centre is outside the mesh
//   (excess material), negative inside (the deposit's surface lies inside the design).
// - Mesh -> deposit: from area-uniform samples on the mesh, the distance to the deposit's
//   outer surface; positive when the sample lies inside the deposit's filled volume
//   (the deposit is larger there), negative outside it (the design has material that the
//   deposit lacks: missing features).
//   So in both directions a deposit bigger than the design reads positive and a smaller one
//   negative; a box deposit 0.1 mm larger than its mesh reads +0.1 mm both ways.
//
// The deposit's outer surface
// - Flood fill from outside over the analysed region (the part's box padded by a margin):
//   empty voxels reachable from outside are "outside"; everything else (occupied voxels and
//   enclosed voids such as sparse infill cells) is the deposit's filled volume. The outer
//   surface is the set of faces between a filled voxel and an outside voxel.
// - Surface points are the centres of those faces, not voxel centres: a voxel is occupied
//   when the bead covers its centre, so the filled voxels approximate the bead's volume with
//   an error of +-half a voxel around the true boundary; voxel centres would sit half a voxel
//   inside on average (bias -voxel/2), face centres lie on the voxelised boundary and are
//   unbiased. Mesh -> deposit distances are exact distances to those face squares.
// - Voxels laid by skirt, brim, support, wipe tower and custom (purge) moves are not part of
//   the deposit here (treated as empty), so they never count as excess.
#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "printtwin/deviation_types.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"
#include "printtwin/toolpath.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin {

// ---------------------------------------------------------------- surface sampling

/// One point on a mesh surface.
struct SurfaceSample {
  Vec3 position_mm = Vec3::Zero();
  std::uint32_t triangle = 0;
};

/// Area-uniform random samples on the surface, about one per `spacing_mm`^2 of area
/// (triangle t gets floor(n_t) or ceil(n_t) samples with n_t = area_t / spacing^2, chosen by
/// a random draw, so the expected density is exact on every triangle). Deterministic for a
/// given `seed` (own splitmix64 generator, per-triangle streams: independent of threading
/// and of the standard library). Each sample stands for `spacing_mm`^2 of area.
[[nodiscard]] std::vector<SurfaceSample> sample_surface(const Mesh& mesh, double spacing_mm,
                                                        std::uint64_t seed = 1);

/// Checks, before anything is drawn, that sample_surface's samples (area / spacing^2 of
/// them) and the per-sample arrays of the deviation fit in memory: a bad_input error giving
/// the count, the estimate and the limit (the host's physical memory) otherwise.
[[nodiscard]] Status check_sample_budget(const Mesh& mesh, double spacing_mm);

// ---------------------------------------------------------------- statistics

/// Statistics of signed distances. Percentiles are of |d| with linear interpolation between
/// order statistics; `within_tolerance_pct` counts |d| <= tolerance. Empty input: all zero,
/// within 100 %.
[[nodiscard]] DeviationStats deviation_stats(std::span<const double> signed_mm,
                                             double tolerance_mm);
/// The same weighted by the area each value stands for (`area_mm2`, one per value; empty: the
/// unweighted figures): mean, RMS, std and within-tolerance are area-weighted, and the
/// percentiles are the least |d| whose share of the area reaches the quantile.
[[nodiscard]] DeviationStats deviation_stats(std::span<const double> signed_mm,
                                             std::span<const double> area_mm2, double tolerance_mm);

// ---------------------------------------------------------------- the analysed deposit

/// Features whose voxels are not part of the analysed deposit (skirt, brim, support, wipe
/// tower, purge): compute_deviation treats them as empty.
[[nodiscard]] bool is_auxiliary_feature(Feature f);

/// A bead as the deposit's model lays it, for placing the surface on the bead's true surface:
/// the stadium section (a (w - h) x h rectangle with half-discs of diameter h on its sides)
/// swept along the move, its top on the nozzle tip.
struct SurfaceBead {
  Vec3 start_mm = Vec3::Zero(), end_mm = Vec3::Zero();  ///< nozzle tip
  float width_mm = 0, height_mm = 0;
  std::uint32_t line = 0;  ///< G-code line (the voxel tags' line)
};
constexpr std::uint32_t kNoBead = 0xFFFFFFFFu;

/// The extruding moves of the part (not skirt, support, wipe tower or purge) as beads, in
/// line order, with the deposit's nominal height (`;HEIGHT:`, else the Z step between layers)
/// and the stadium width of their extrusion.
[[nodiscard]] std::vector<SurfaceBead> surface_beads(std::span<const Move> moves,
                                                     const PrinterProfile& profile);

// ---------------------------------------------------------------- mesh distances

/// Signed distances from points to the mesh (positive outside), with Embree closest
/// points. The sign comes from angle-weighted pseudo-normals (Baerentzen & Aanaes 2005) on
/// a closed, consistently oriented mesh, and from the ray-parity vote of MeshQuery::inside
/// where the closest feature touches an open or non-manifold edge. `near_mm` > 0: most
/// points are expected within this distance; each is first searched within it (cheap) and
/// only then without bound. The result does not depend on `near_mm`.
[[nodiscard]] Result<std::vector<double>> signed_distances_to_mesh(const Mesh& mesh,
                                                                   std::span<const Vec3> points,
                                                                   double near_mm = 0);

class MeshQuery;
struct DeviationSettings;
namespace detail {
struct DeviationTargetAccess;
}

/// The design side of the deviation, prepared once per mesh and reused for many deposits
/// (the variants of `compare`, G-code from several slicers): the BVH for closest points
/// (MeshQuery), the angle-weighted pseudo-normals for the sign, the area-uniform surface
/// samples, the mesh's volume and box. Everything stays in the mesh's own frame; a deposit
/// is compared with the mesh translated by a placement offset, applied to the query points
/// (never to the BVH), so one target serves variants with different registrations.
/// Copies are cheap (shared, immutable state) and safe to use from several threads.
class DeviationTarget {
 public:
  /// Prepares `mesh` (in its own frame). The surface samples are drawn with
  /// settings.seed at settings.mesh_sample_spacing_mm, or, when that is 0, at twice
  /// `voxel_mm` (compute_deviation's rule); with both 0 no samples are drawn here and
  /// compute_deviation draws them per call. Errors: empty mesh, invalid triangle indices,
  /// negative spacing.
  [[nodiscard]] static Result<DeviationTarget> build(const Mesh& mesh,
                                                     const DeviationSettings& settings,
                                                     double voxel_mm = 0);

  [[nodiscard]] const Mesh& mesh() const;        ///< the mesh, own frame
  [[nodiscard]] const MeshQuery& query() const;  ///< Embree BVH over mesh()
  [[nodiscard]] const Box3& bbox_mm() const;     ///< box of mesh(), own frame
  [[nodiscard]] double volume_mm3() const;       ///< signed_volume_mm3(mesh())
  /// Spacing and seed of samples() (spacing 0: none drawn).
  [[nodiscard]] double sample_spacing_mm() const;
  [[nodiscard]] std::uint64_t sample_seed() const;
  /// Area-uniform samples of mesh() (sample_surface), own frame.
  [[nodiscard]] std::span<const SurfaceSample> samples() const;

  /// Signed distances (positive outside) from `points_mm` (in the frame where the mesh sits
  /// at `offset_mm`, i.e. the machine frame) to the mesh translated by `offset_mm`. Same
  /// rules as signed_distances_to_mesh; `near_mm` only changes the speed.
  /// `triangles` (optional) receives the triangle of each closest point. `groups`
  /// (optional): the points already come in groups of neighbours, group g being
  /// [groups[g], groups[g + 1]) (say the deposit surface's faces, cell by cell), each no wider
  /// than about `near_mm`; otherwise they are grouped in cells of `near_mm` here. Either way
  /// the result is the same.
  void signed_distances(const Vec3& offset_mm, std::span<const Vec3> points_mm, double near_mm,
                        std::vector<double>& signed_mm,
                        std::vector<std::uint32_t>* triangles = nullptr,
                        std::span<const std::uint32_t> groups = {}) const;

 private:
  struct Impl;
  friend struct detail::DeviationTargetAccess;  // the design's sharp edges (src/deviation/)
  explicit DeviationTarget(std::shared_ptr<const Impl> impl);
  std::shared_ptr<const Impl> impl_;
};

/// Reference unsigned point-to-mesh distances from CGAL's AABB tree (tests and benchmarks
/// compare the production Embree path against it). Slow; single-threaded.
[[nodiscard]] std::vector<double> reference_distances_cgal(const Mesh& mesh,
                                                           std::span<const Vec3> points);

// ---------------------------------------------------------------- registration

/// One object of the bed as printed: a labelled object (M486, EXCLUDE_OBJECT, PrusaSlicer's
/// "printing object", Cura's ;MESH:) or, without labels, a group of connected extrusions.
struct PrintedObject {
  int id = -1;             ///< Move::object_id; -1: unlabelled (a footprint group)
  std::string name;        ///< label name (or "#<id>", or "footprint <n>")
  Box3 bbox_mm;            ///< extrusion centre lines of the object
  std::size_t moves = 0;   ///< its extrusion moves
  double extruded_mm = 0;  ///< XY length of its extrusions
  /// Points along the outer walls (Feature::outer_perimeter; every extrusion when the
  /// G-code has no wall tags), evenly spaced, at most kMaxWallSamples. Machine frame.
  std::vector<Vec3> wall_points_mm;
  /// Convex hull of the walls' XY footprint (counter-clockwise).
  std::vector<Vec2> hull_xy_mm;
  /// Cells of `cell_mm` that the object's extrusions pass through (packed keys, sorted):
  /// what the print covers, for the registration's coverage figure.
  double cell_mm = 1.0;
  Vec3 cell_origin_mm = Vec3::Zero();
  std::vector<std::uint64_t> cells;
  static constexpr std::size_t kMaxWallSamples = 3000;
};

/// Where the part is in the G-code.
struct PartExtent {
  Box3 bbox_mm;           ///< extrusion centre lines of the part (all candidate objects)
  std::size_t moves = 0;  ///< extrusion moves counted as the part
  std::string method;     ///< "tags" (features), "connectivity" (untagged) or "objects" (labels)
  /// The candidates the mesh is matched against: the labelled objects by id, or the whole
  /// part ("part") followed by each of its larger islands ("footprint <n>") when it has several.
  std::vector<PrintedObject> objects;
  bool walls_tagged = false;   ///< wall_points_mm are outer walls
  double layer_height_mm = 0;  ///< median Z step between extrusion layers (0: unknown)
};

/// Finds the part among the extrusion moves: drops skirt/brim, support, wipe tower and
/// custom (purge) features by their tags. Labelled objects are the candidates when the
/// G-code names them; otherwise the remaining extrusions are grouped by their XY footprint
/// (0.5 mm raster, 8-connected, weighted by extruded length): with feature tags, every group
/// of at least 2 % of the largest is part of the part (a part may be several islands: bridges
/// side by side, a multi-body mesh); without tags, groups no taller than two layers while
/// others are taller (untagged skirts, purge lines) are dropped. `names` maps object ids to
/// their labels (SimulationResult::object_names).
[[nodiscard]] PartExtent find_part_extent(std::span<const Move> moves,
                                          const std::map<int, std::string>& names = {});

/// Offset that places the mesh in the G-code frame the way slicers do: mesh bounding-box XY
/// centre onto the part's XY centre, lowest point at z = 0 (translation only).
[[nodiscard]] Vec3 registration_offset(const Mesh& mesh, const PartExtent& part);

/// A similarity transform mesh frame -> machine frame: x' = scale * rotation * x + translation.
struct RigidTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Vec3 translation_mm = Vec3::Zero();
  double scale = 1.0;
  [[nodiscard]] Vec3 apply(const Vec3& p) const { return scale * (rotation * p) + translation_mm; }
  [[nodiscard]] bool translation_only() const {
    return scale == 1.0 && rotation == Eigen::Matrix3d::Identity();
  }
};

/// Rotation from angles in degrees about the machine's fixed X, then Y, then Z axes
/// (R = Rz * Ry * Rx).
[[nodiscard]] Eigen::Matrix3d rotation_from_xyz_deg(const Vec3& xyz_deg);
/// Angles of `rotation_from_xyz_deg` (Z-Y-X Euler decomposition), degrees.
[[nodiscard]] Vec3 xyz_deg_of(const Eigen::Matrix3d& rotation);
/// The mesh transformed (triangle order and vertex order kept).
[[nodiscard]] Mesh transformed(Mesh mesh, const RigidTransform& transform);

/// What the registration found.
struct Registration {
  RigidTransform transform;
  std::string method;  ///< "--place", "auto (...)"; see docs/registration.md
  std::string object;  ///< name of the object matched ("" when the G-code has one part)
  int object_id = -1;
  Box3 object_bbox_mm;  ///< extrusions of the matched object
  /// Outer-wall points of the matched object: distance to the placed mesh (mm). A wall's
  /// centre line lies half a bead inside the surface, so a right match gives about 0.2 mm.
  double residual_rms_mm = 0;
  double residual_p50_mm = 0;
  /// Mesh surface samples (about 1500) with an extrusion of the object in the same or a
  /// neighbouring occupancy cell (PrintedObject::cell_mm, at least 1 mm): the share of the
  /// design the print covers (%).
  double coverage_pct = 0;
  std::size_t wall_points = 0;  ///< points the residual is measured on
  double seconds = 0;           ///< wall time of the search
  int candidates = 0;           ///< poses refined (orientations x scales x Z angles x objects)
  /// False when even the best pose leaves the G-code far from the mesh: the G-code does not
  /// appear to be this part. `mismatch` says why, with the figures.
  bool matches = true;
  std::string mismatch;
  Vec3 mesh_size_mm = Vec3::Zero();     ///< placed mesh box size
  Vec3 printed_size_mm = Vec3::Zero();  ///< the object's printed box size (centre lines)
};

/// Options of `register_mesh`.
struct RegistrationOptions {
  std::optional<double> scale;  ///< mesh units -> mm when known (--units); else searched
  std::string object;           ///< choose this object (name or id); "" = best fit
  bool allow_rotation = true;   ///< false: translation only (tests, benchmarks)
};

class MeshQuery;

/// Finds the similarity transform that maps `mesh` onto the printed part: candidate
/// orientations (the 6 "up" axes of the 24 axis-aligned rotations) and unit scales whose
/// height matches the printed height, the Z rotation from the minimum-area rectangles of
/// both footprints (4 symmetric candidates, plus a 15 degree sweep when none fits), each
/// refined by ICP of the outer-wall points against the mesh (closest points from `query`,
/// the BVH of `mesh` in its own frame), scored by the residual and the coverage; the best
/// pose over the candidate objects wins. Deterministic. Errors: no object to match, or
/// `options.object` names none (usage, listing the objects).
[[nodiscard]] Result<Registration> register_mesh(const Mesh& mesh, const MeshQuery& query,
                                                 const PartExtent& part,
                                                 const RegistrationOptions& options = {});

/// The figures of a given pose (--place): residual, coverage and the mismatch verdict on the
/// object that fits it best (`options.object` to choose); method "--place".
[[nodiscard]] Result<Registration> evaluate_registration(const Mesh& mesh, const MeshQuery& query,
                                                         const PartExtent& part,
                                                         const RigidTransform& transform,
                                                         const RegistrationOptions& options = {});

// ---------------------------------------------------------------- the whole analysis

struct DeviationSettings {
  double tolerance_mm = 0.2;
  double mesh_sample_spacing_mm = 0;  ///< 0: twice the voxel (one sample per 4 voxel faces)
  std::uint64_t seed = 1;
  double cluster_radius_mm = 0;   ///< 0: max(2 voxels, 3 x the mesh sample spacing)
  double region_margin_mm = 1.0;  ///< analysed region = mesh box (+ part box) + margin
  /// Gaps in the deposit narrower than this do not let the outside in (the outer surface).
  double seal_gap_mm = 0.2;
  /// What the seal closed opens again to this depth from the sealed outside: layer lines
  /// and the grooves between outer beads are measured; a pinhole leaks no deeper.
  double groove_depth_mm = 0.25;
  int max_regions = 50;  ///< keep the largest regions (by area)
  /// Out-of-tolerance clusters smaller than this are voxel noise, not defects: they are not
  /// regions and do not count in DeviationResult::max_excess_mm / max_deficit_mm.
  double min_region_area_mm2 = 0.1;
  std::size_t max_region_lines = 20;  ///< G-code lines listed per region
  bool keep_samples = true;           ///< fill DeviationResult::{deposit,mesh}_samples
  bool keep_filled_volume = false;    ///< fill DeviationResult::filled_volume
};

/// Two-sided deviation of a deposit against a placed mesh: statistics, per-layer stats,
/// regions, volumes, per-vertex deviation (mesh -> deposit at each vertex) and the gate
/// figures: max_excess_mm = largest deposit -> mesh distance, max_deficit_mm = largest
/// -(mesh -> deposit) distance, both ignoring clusters below min_region_area_mm2.
/// `part_box_mm` (may be empty) widens the analysed region to the part's extrusions.
/// `beads` (surface_beads of the G-code; may be empty): the surface points are placed on the
/// true bead surface (place_on_beads), the deposit -> mesh figures are area-weighted, and
/// mesh -> deposit distances near placed faces are to the bead surface.
/// Errors: empty mesh, settings out of range.
[[nodiscard]] Result<DeviationResult> compute_deviation(const Mesh& placed_mesh,
                                                        const VoxelGrid& deposit,
                                                        const DeviationSettings& settings,
                                                        const Box3& part_box_mm = {},
                                                        std::span<const SurfaceBead> beads = {});

/// The same analysis against a prepared target: the mesh sits at `placement_offset_mm`
/// (mesh frame + offset = G-code frame). Equals compute_deviation(translated(target mesh,
/// offset), ...) up to floating-point rounding of the translation (bit-identical for a
/// zero offset); the mesh overload is this with a target built for the call.
[[nodiscard]] Result<DeviationResult> compute_deviation(const DeviationTarget& target,
                                                        const Vec3& placement_offset_mm,
                                                        const VoxelGrid& deposit,
                                                        const DeviationSettings& settings,
                                                        const Box3& part_box_mm = {},
                                                        std::span<const SurfaceBead> beads = {});

/// Clusters out-of-tolerance samples into regions (union-find over a hash grid with
/// `radius_mm` links). `area_per_sample_mm2` is what one sample stands for. For `missing`,
/// samples with d < -tolerance are clustered; for `excess`, samples with d > tolerance.
/// Regions come largest first. `sample_region` (optional) receives, per sample, the index of
/// its region in the result or -1. `sample_area_mm2` (optional, one per sample) replaces
/// area_per_sample_mm2 where samples stand for different areas.
[[nodiscard]] std::vector<DeviationRegion> cluster_regions(
    std::span<const DeviationSample> samples, double tolerance_mm, double radius_mm,
    double area_per_sample_mm2, RegionKind kind, std::size_t max_lines = 20,
    std::vector<std::int32_t>* sample_region = nullptr,
    std::span<const double> sample_area_mm2 = {});

/// PLY of the mesh with a per-vertex signed deviation (`quality` for MeshLab, `deviation`
/// for CloudCompare's scalar fields) and an RGB colour (blue: deficit, green: within
/// tolerance, red: excess, saturated at 2x tolerance). Binary little endian.
[[nodiscard]] std::string deviation_ply(const Mesh& mesh, std::span<const double> vertex_mm,
                                        double tolerance_mm);

/// Points with one scalar (`deviation`) as PLY, for CloudCompare (bench/c2m_compare.sh).
[[nodiscard]] std::string points_ply(std::span<const Vec3> points_mm,
                                     std::span<const double> scalar);

}  // namespace printtwin
