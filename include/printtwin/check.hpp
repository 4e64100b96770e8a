#pragma once
// Printability check of a mesh, before any slicing (`printtwin check`).
//
//   Mesh --check_printability(mesh, printer, settings)--> CheckReport { health, placement,
//                                                                       findings, printable }
//
// Three groups of checks, each also callable on its own (unit tests, other stages):
//  - mesh health (analyze_mesh_health, find_self_intersections): counts of triangles,
//    shells, open and non-manifold edges, degenerate/duplicate faces, orientation,
//    self-intersections; volume, area, bounding box. Pure topology + exact predicates.
//  - placement (place like a slicer: lowest point on z = 0, bbox centred on the bed unless
//    told otherwise): fits the build volume, footprint on the bed.
//  - print risks on the placed mesh: overhangs (find_overhangs), thin walls and narrow gaps
//    (measure_thickness, Embree rays along the normal), small shells, tall slender parts.
// Every problem is a Finding with a stable `code` (docs/check.md lists them all); nothing
// is repaired here. repair_mesh() is separate and reports each change it makes.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"

namespace printtwin {

class MeshQuery;  // mesh_query.hpp

/// Thresholds of the check. Defaults follow the stock Ender-3 (0.4 mm nozzle).
struct CheckSettings {
  /// A downward-facing surface leaning more than this from vertical needs support
  /// (0 = vertical wall, 90 = horizontal ceiling).
  double overhang_angle_deg = 45.0;
  /// Walls thinner than this are reported (thin_wall). <= 0: the printer's nozzle diameter.
  double min_thickness_mm = 0.0;
  /// Line width; gaps narrower than it close up (narrow_gap) and shells smaller than it do
  /// not print (small_feature). <= 0: 1.125 x nozzle diameter (0.45 mm for 0.4).
  double line_width_mm = 0.0;
  /// Faces whose vertices are all within this height of the bed rest on it (not overhangs).
  double bed_contact_mm = 0.01;
  /// height / smallest footprint side above which the part is tall_slender.
  double slender_ratio = 6.0;
  /// Overhang regions smaller than this are not reported (tessellation noise).
  double min_overhang_area_mm2 = 1.0;
  /// Placement: centre the bbox on (center_x_mm, center_y_mm); unset = the bed centre.
  bool center = true;
  std::optional<double> center_x_mm;
  std::optional<double> center_y_mm;
  /// At most this many locations are listed for findings that occur many times.
  std::size_t max_locations = 5;
  /// Skip the self-intersection test (it dominates the run time of very large meshes).
  bool self_intersections = true;
  /// Optional BVH of the mesh as given to check_printability (before placement), built by
  /// the caller for other uses too (verify shares one with the deviation stage); null: the
  /// thickness rays build their own.
  const MeshQuery* mesh_query = nullptr;
  /// Measure walls thicker than min_thickness_mm too (the thinnest wall overall, which
  /// `printtwin check` prints). false: the inward rays stop at the limit, so the thin-wall
  /// finding is the same but ThicknessResult::min_thickness_mm is +inf when no wall is thin
  /// (what `verify` needs: it reports findings only).
  bool thickness_beyond_limit = true;
  /// The sag model of bridges (the printer profile's, which check_printability uses): a
  /// bridge of bridge_sag_span_mm sags bridge_sag_mm at mid-span, sag ~ span^2; spans over
  /// twice bridge_sag_span_mm are not bridged.
  double bridge_sag_mm = 0.8;
  double bridge_sag_span_mm = 50;
  /// A bridge predicted to sag more than this is a warning (bridge_sag), else info (bridge).
  double bridge_sag_warn_mm = 0.1;
};

/// Topological and geometric health of a mesh (frame of the input, before placement).
struct MeshHealth {
  std::size_t triangles = 0;
  std::size_t vertices = 0;            ///< vertices referenced by at least one triangle
  std::size_t shells = 0;              ///< connected components over shared edges
  std::size_t boundary_edges = 0;      ///< edges with one face (holes)
  std::size_t non_manifold_edges = 0;  ///< edges with more than two faces, not touching
  std::size_t touching_edges = 0;      ///< edges where closed bodies touch (faces pair around them)
  std::size_t non_manifold_vertices = 0;  ///< vertices whose faces form several fans
  std::size_t degenerate_faces = 0;       ///< zero area (repeated index or collinear)
  std::size_t duplicate_faces = 0;        ///< same three vertices as an earlier face
  std::size_t inconsistent_edges = 0;     ///< manifold edges whose two faces run the same way
  std::size_t inverted_shells = 0;        ///< closed shells with negative volume, not a cavity
  std::size_t self_intersections = 0;     ///< intersecting face pairs (not sharing an edge)
  std::vector<Vec3> self_intersection_locations_mm;  ///< first few, a point of each pair
  bool self_intersections_checked = false;
  bool closed = false;    ///< no boundary and no non-manifold edge (touching edges allowed)
  double volume_mm3 = 0;  ///< signed (divergence theorem)
  double area_mm2 = 0;
  Box3 bbox_mm;
  std::vector<Box3> shell_bbox_mm;                 ///< bounding box of each shell
  std::vector<std::size_t> shell_faces;            ///< faces of each shell
  std::optional<Vec3> first_boundary_edge_mm;      ///< midpoint of one open edge
  std::optional<Vec3> first_non_manifold_edge_mm;  ///< midpoint of one non-manifold edge
  std::optional<Vec3> first_non_manifold_vertex_mm;
  std::optional<Vec3> first_degenerate_face_mm;
  std::optional<Vec3> first_inconsistent_edge_mm;
};

/// Counts everything in MeshHealth except self-intersections (O(n log n), no CGAL).
[[nodiscard]] MeshHealth analyze_mesh_health(const Mesh& mesh);

struct SelfIntersections {
  std::size_t pairs = 0;           ///< intersecting face pairs
  std::vector<Vec3> locations_mm;  ///< a point of each of the first pairs (centroid
                                   ///< of the first face's intersecting region)
  std::vector<std::array<std::uint32_t, 2>> first_pairs;  ///< their face indices
  std::vector<std::uint32_t> faces;  ///< every face in at least one pair, sorted
};

/// What self-intersections do to the sliced part. Layers are cut at the heights of the
/// intersecting faces; each section is measured by its winding number w (loops oriented by
/// the face normals): where w >= 2 the surface encloses the same solid twice (slicers merge
/// it: printed once, but the mesh volume counts it twice); where w < 0 the surface is folded
/// inside out (union slicers drop that area, even-odd ones fill it: the print depends on the
/// slicer). w in {0, 1} everywhere: the intersections change no layer outline.
struct IntersectionEffect {
  bool measured = false;  ///< false: the mesh is open (sections are not closed)
  double layer_height_mm = 0.2;
  std::size_t layers = 0;          ///< layers cut through the intersecting faces
  std::size_t layers_changed = 0;  ///< layers with area enclosed twice or inside out
  double twice_volume_mm3 = 0;     ///< enclosed more than once (w - 1 summed where w >= 2)
  double max_twice_area_mm2 = 0;   ///< largest in one layer
  double inverted_volume_mm3 = 0;  ///< w < 0
  double max_inverted_area_mm2 = 0;
  Box3 changed_bbox_mm;  ///< bounding box of the layers that change (input frame)
};

/// Measures the effect of the faces `faces` (find_self_intersections' SelfIntersections::faces)
/// on the layer sections of a closed mesh (see IntersectionEffect). At most 400 layers are cut
/// (evenly spread when the faces span more).
[[nodiscard]] IntersectionEffect measure_intersection_effect(
    const Mesh& mesh, const std::vector<std::uint32_t>& faces, double layer_height_mm = 0.2);

/// Pairs of faces that intersect other than along a shared edge or at a shared vertex.
/// Broad phase over a uniform grid of face bounding boxes, exact predicates (CGAL Epick)
/// in the narrow phase. Degenerate faces are skipped. `max_locations` bounds the lists.
/// `health` (analyze_mesh_health of the same mesh), when given, lets pairs of faces around a
/// vertex be settled at once where the mesh is closed and manifold (the same pairs result).
[[nodiscard]] SelfIntersections find_self_intersections(const Mesh& mesh,
                                                        std::size_t max_locations = 5,
                                                        const MeshHealth* health = nullptr);

/// Where the slicer would put the part.
struct Placement {
  Vec3 offset_mm = Vec3::Zero();  ///< translation applied to the input
  Box3 bbox_mm;                   ///< placed bounding box (machine frame)
  bool fits = false;              ///< inside the build volume
  double footprint_area_mm2 = 0;  ///< area of the faces resting on the bed
  Box3 footprint_mm;              ///< their bounding box (empty when none)
};

/// An overhang region that prints as a bridge: flat, and held at both ends along one
/// direction (docs/check.md, "Bridges").
struct BridgeSpan {
  double span_mm = 0;        ///< the longest unsupported line across it, along direction_deg
  double direction_deg = 0;  ///< of the bridge's lines, from +x, in [0, 180)
  double sag_mm = 0;         ///< predicted mid-span sag of the longest line
  bool flat = true;          ///< a flat ceiling (else an arch: a hole's or vault's top)
  /// Every point lies within half a line width of what holds it: a ledge that narrow prints
  /// as it is (span_mm is then how far it reaches beyond that; direction_deg means nothing).
  bool ledge = false;
};

/// An area of downward-facing faces steeper than the limit, connected over shared edges.
struct OverhangRegion {
  double area_mm2 = 0;
  double max_angle_deg = 0;         ///< from vertical
  Vec3 centroid_mm = Vec3::Zero();  ///< area-weighted centroid
  Box3 bbox_mm;
  std::size_t faces = 0;
  std::uint32_t first_face = 0;
  std::optional<BridgeSpan> bridge;  ///< set when the region prints as a bridge
};

/// Overhang regions of a placed mesh (z = 0 is the bed), largest first.
[[nodiscard]] std::vector<OverhangRegion> find_overhangs(const Mesh& placed,
                                                         const CheckSettings& settings);

/// Local thickness (inward rays) and gap width (outward rays) sampled at every face.
struct ThicknessResult {
  double min_thickness_mm = 0;  ///< thinnest wall seen; +inf if no ray hit
  Vec3 min_thickness_at_mm = Vec3::Zero();
  std::size_t thin_faces = 0;  ///< faces thinner than the limit
  double thin_area_mm2 = 0;
  Box3 thin_bbox_mm;
  double min_gap_mm = 0;  ///< narrowest gap between facing surfaces; +inf if none
  Vec3 min_gap_at_mm = Vec3::Zero();
  std::size_t narrow_gap_faces = 0;  ///< faces facing another surface closer than the line width
  double narrow_gap_area_mm2 = 0;
  Box3 narrow_gap_bbox_mm;
};

/// Casts a ray from each face's centroid inward along -normal (first back-facing hit =
/// wall thickness) and outward along +normal (first front-facing hit of a surface facing
/// back within 30 degrees = gap width). Uses MeshQuery (Embree). Fails only when the ray
/// tracer cannot be built.
/// `query` (optional): a BVH of the same mesh translated by -query_offset_mm (rays are cast
/// from the face centroids minus the offset); null: one is built for the call.
/// `beyond_limit` false: inward rays stop at min_thickness_mm (same thin faces, area, box and,
/// when some wall is thin, the same thinnest wall; +inf otherwise), much cheaper on thick parts.
/// `skip_internal_faces`: faces lying inside the solid or on another shell's surface (shells
/// that overlap or touch; found by the winding number just outside each face) neither cast
/// rays nor stop them, so touching faces do not read as 0 mm walls or gaps. It costs one
/// more ray walk per face; check_printability turns it on when the mesh has several shells
/// or self-intersections.
[[nodiscard]] Result<ThicknessResult> measure_thickness(const Mesh& mesh, double min_thickness_mm,
                                                        double line_width_mm,
                                                        const MeshQuery* query = nullptr,
                                                        const Vec3& query_offset_mm = Vec3::Zero(),
                                                        bool beyond_limit = true,
                                                        bool skip_internal_faces = false);

/// One way to stand the part on the bed, and how it scores.
struct OrientationCandidate {
  Vec3 down = Vec3(0, 0, -1);            ///< direction of the part (input frame) that points down
  Vec3 rotation_xyz_deg = Vec3::Zero();  ///< rotation about X, then Y, then Z (as `--place`)
  std::string label;        ///< "as modelled", "axis +X down", "flat face of 120.0 mm2"
  double overhang_mm2 = 0;  ///< faces steeper than the overhang limit, not on the bed
  double contact_mm2 = 0;   ///< faces resting on the bed
  double height_mm = 0;
  double score = 0;  ///< overhang - contact (lower is better)
};

/// Orientation advice: the 6 axis directions (the 24 axis-aligned rotations differ only by a
/// turn about Z, which changes neither overhang nor contact) and every flat face group of at
/// least 1 % of the area (faces with the same normal within 1 degree) laid down, scored by
/// overhang area minus bed contact area. `best` is the lowest score (ties: the lower part,
/// then the earlier candidate); `current` is the part as modelled.
struct OrientationAdvice {
  OrientationCandidate current;
  OrientationCandidate best;
  std::size_t candidates = 0;
  /// best saves at least 10 % of the current overhang and 1 mm2, or adds contact with no
  /// more overhang.
  bool better = false;
};
[[nodiscard]] OrientationAdvice advise_orientation(const Mesh& mesh,
                                                   const CheckSettings& settings = {});

/// The mesh rotated by `rotation_xyz_deg` (about X, then Y, then Z, around the origin).
[[nodiscard]] Mesh rotated_mesh(const Mesh& mesh, const Vec3& rotation_xyz_deg);

/// Everything `printtwin check` reports.
struct CheckReport {
  MeshHealth health;  ///< input frame
  Placement placement;
  std::vector<OverhangRegion> overhangs;     ///< placed frame
  std::optional<ThicknessResult> thickness;  ///< unset when the mesh could not be ray traced
  std::optional<IntersectionEffect>
      intersection_effect;  ///< set when self-intersections were found
  std::optional<OrientationAdvice>
      orientation;                    ///< set by check_printability (finding orientation)
  double min_thickness_limit_mm = 0;  ///< thresholds actually used
  double line_width_mm = 0;
  double overhang_angle_deg = 0;
  std::vector<Finding> findings;  ///< errors first, then warnings, then info
  bool printable = false;         ///< no finding with severity error
};

/// Runs every check. Positions in findings are in the placed (machine) frame.
[[nodiscard]] Result<CheckReport> check_printability(const Mesh& mesh,
                                                     const PrinterProfile& printer,
                                                     const CheckSettings& settings = {});

/// One kind of change made by repair_mesh.
struct RepairChange {
  std::string code;  ///< merged_vertices, removed_degenerate_faces, removed_duplicate_faces,
                     ///< stitched_edges, reoriented_faces, filled_holes, added_faces,
                     ///< inverted_shells_flipped
  std::size_t count = 0;
  std::string message;
};

struct RepairSettings {
  /// Holes with at most this many boundary edges are filled (larger ones are left open).
  std::size_t max_hole_edges = 64;
  /// Open seams are welded first: the ends of an open facet edge move onto those of an open
  /// edge running the other way when each lies within this distance (admesh --nearby). 0:
  /// no weld; negative: admesh's default (nearby_weld_tolerance_mm).
  double weld_tolerance_mm = -1;
};

/// admesh's default tolerance for --nearby: the shortest edge of the mesh (the largest
/// coordinate difference of its ends, over faces without a repeated corner) plus the
/// increment of its second iteration, 0.01 % of the bounding box's diagonal.
[[nodiscard]] double nearby_weld_tolerance_mm(const Mesh& mesh);

/// What a repair changed, measured by comparing the mesh before and after (faces matched by
/// their corner positions), in the counters admesh prints. Edge counters count facet edges,
/// as admesh does: an edge shared by two faces counts twice.
struct RepairCounters {
  std::size_t degenerate_facets = 0;  ///< zero-area faces of the input
  /// Facet edges of kept input faces that were open or non-manifold and are shared by exactly
  /// two faces afterwards (vertices at one position joined, as the written file reads), none
  /// of them added (closed by stitching or by removing extra faces).
  std::size_t edges_fixed = 0;
  std::size_t facets_removed = 0;  ///< input faces not in the result (degenerate, duplicate, loose)
  std::size_t facets_added = 0;    ///< result faces not in the input (hole fills)
  std::size_t facets_reversed = 0;  ///< faces kept with their winding turned (net, once each)
  std::size_t backwards_edges = 0;  ///< facet edges of the result whose neighbour runs the same way
  std::size_t holes_filled = 0;     ///< patches of added faces (connected over shared edges)
  std::size_t parts = 0;            ///< shells of the result
  /// Open facet edges of the input whose two ends each lie within the nearby tolerance of the
  /// ends of another face's open facet edge running the other way (not at them): the seams
  /// that the weld closes (admesh --nearby).
  std::size_t nearby_edges = 0;
  /// Open facet edges of the input (after the weld) with a vertex of other open edges on their
  /// middle, within the nearby tolerance (a T-junction): the edges the repair splits.
  std::size_t t_junction_edges = 0;
};

/// The tolerance of RepairCounters::nearby_edges when the repair does not weld.
inline constexpr double kNearbyEdgeMm = 0.01;

/// Counts what changed from `before` to `after` (see RepairCounters). `after` reuses the
/// positions of `moved` (the input after the weld: its vertices, some moved; by default the
/// input itself); `nearby_mm` is the tolerance of nearby_edges.
[[nodiscard]] RepairCounters measure_repair(const Mesh& before, const Mesh& after,
                                            double nearby_mm = kNearbyEdgeMm,
                                            const Mesh* moved = nullptr);

/// "edges fixed 0, facets removed 2, facets added 2, facets reversed 2, backwards edges 0,
/// holes filled 1, degenerate facets 0, parts 1, nearby edges 0": every counter, admesh's
/// names and order, then the nearby edges.
[[nodiscard]] std::string repair_counters_text(const RepairCounters& c);

struct RepairResult {
  Mesh mesh;
  std::vector<RepairChange> changes;  ///< only kinds with count > 0
  RepairCounters counters;            ///< measured from the meshes (measure_repair)
  double weld_tolerance_mm = 0;       ///< the weld's tolerance (0: no weld)
  MeshHealth before;
  MeshHealth
      after;  ///< of the repaired mesh with vertices at one position joined (as its STL reads)
};

/// Repairs with CGAL Polygon_mesh_processing: merge duplicate points, remove degenerate and
/// duplicate faces, orient, stitch borders, fill small holes, make closed shells bound a
/// volume. Never called implicitly; the caller reports `changes`.
[[nodiscard]] Result<RepairResult> repair_mesh(const Mesh& mesh,
                                               const RepairSettings& settings = {});

/// The unit a mesh was likely modelled in, judged by its size (`--units auto`).
struct UnitGuess {
  std::string unit;          ///< "m" or "in" (the names of `--units`)
  double mm_per_unit = 1.0;  ///< scale to apply
  double size_units = 0;     ///< largest dimension of the largest shell, in file units
};

/// Judges the size of the largest piece (faces connected through shared vertices; stray
/// far-away facets do not count): under 0.3 units
/// a part in millimetres would not print at all, so metres (x1000); under 3 units, inches
/// (x25.4; centimetres are as likely and need `--units cm`). nullopt when millimetres are
/// plausible; a part too large is left alone (does_not_fit says what scale fits).
[[nodiscard]] std::optional<UnitGuess> guess_mesh_units(const Mesh& mesh);

/// The finding that states a unit guess (code units_guessed, warning): the size before and
/// after, the unit applied, and the option that overrides it.
[[nodiscard]] Finding units_guessed_finding(const UnitGuess& guess, const Vec3& size_mm);

/// How a part too big for the printer could fit: a rotation by quarter turns about the axes
/// (dimensions permuted), or failing that the largest uniform scale with the best of them.
struct FitAdvice {
  bool fits_as_is = false;
  std::string rotation;         ///< e.g. "rotated 90 deg about X"; empty: as it is
  double scale = 1.0;           ///< < 1 when only a smaller part fits (rounded down to 0.1 %)
  Vec3 size_mm = Vec3::Zero();  ///< its size after the rotation and the scale
};
[[nodiscard]] FitAdvice advise_fit(const Vec3& size_mm, const PrinterProfile& printer);

/// Where the checked mesh came from, for the JSON report.
struct CheckSource {
  std::string file;          ///< as given on the command line
  std::string sha256;        ///< of the file's bytes
  std::string units = "mm";  ///< unit the file was read in
  double scale = 1.0;        ///< extra scale applied
  std::string printer;       ///< profile name
};

/// Version of the JSON written by check_report_to_json (docs/check.md). Bumped when a key
/// changes meaning or disappears; new keys do not bump it.
inline constexpr int kCheckJsonVersion = 1;

/// The report as JSON text (schema "printtwin.check", version kCheckJsonVersion). Numbers
/// are rounded to 1e-4 and written locale-independently; the same input gives the same
/// bytes. `repair` (optional) adds the "repair" object with `repair_file`.
[[nodiscard]] std::string check_report_to_json(const CheckReport& report, const CheckSource& source,
                                               const RepairResult* repair = nullptr,
                                               const std::string& repair_file = {});

}  // namespace printtwin
