#pragma once
// The as-printed part as a triangle mesh (`--deposit-mesh part.stl|part.3mf|part.ply`): the
// outer surface of the deposit's filled volume (voxels plus the cavities the outside cannot
// reach), made 2-manifold, its coplanar voxel faces merged into rectangles, triangulated
// without T-junctions, so the mesh is closed and consistently oriented (outward).
//
// Two surfaces (DepositMeshSurface): `layers` (default; mesh_export_layers.cpp, docs/deposit.md)
// is a slab per printed layer: the slab's traced and simplified outlines, its side as rings on
// the bead's round profile, caps over the exclusive-or of consecutive slabs; it falls back to
// `voxel` (below) without beads or when it does not close. The voxel surface:
//
// Model:
// - Filled volume: the deposit's outer-surface routine (a flood of the outside air, sealed
//   and grooved with the deviation stage's defaults, so pinholes do not open the infill);
//   voxels of skirt/brim, support, wipe tower and custom (start code, purge) are air unless
//   included.
// - Manifold: a voxel surface is a 2-manifold exactly when no 2x2 square of voxels holds two
//   diagonal filled voxels beside two empty ones and no 2x2x2 cube holds exactly two
//   opposite-corner filled (or empty) voxels (well-composed sets). Each such configuration
//   is repaired by filling one empty voxel (counted), until none is left.
// - Faces: per plane, runs of faces along one axis, stacked into rectangles when equal; every
//   rectangle corner lying on another rectangle's side is inserted into that side, so
//   neighbouring rectangles share their edges exactly.
// - Components: connected pieces of the surface with no voxel of a part feature (perimeter,
//   infill, ...) are dropped (a purge line or skirt that lies apart); a G-code without
//   feature labels keeps the pieces that span more than one layer.
// - Smoothing (full resolution, beads given, at most smooth_max_triangles): each vertex moves onto
//   the surface of the bead of the one G-code line whose voxels touch it, at most 0.45 voxel
//   per axis; where lines of two layers meet (a layer groove) it moves level into the crease
//   between their beads (up to half a bead height plus a voxel); where lines of one layer
//   meet (the inside of a corner) it stays. Folded triangles and every pair of triangles
//   that cross (of different lattice planes, or any with a vertex moved beyond 0.45 voxel; a
//   local check around the moved vertices) put their vertices back on the lattice.
// - Decimation (max_triangles): the filled volume on cells of s x s x s voxels (a cell is
//   filled when any of its voxels is), s the smallest that fits. The coarse solid contains
//   the fine one and every point of its surface lies within error_bound_mm of the
//   full-resolution voxel surface.
#include <cstddef>
#include <filesystem>
#include <span>
#include <string>

#include "printtwin/deviation.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin {

/// The surface the mesh is built as: `layers` (default) a slab per printed layer with the
/// beads' rounded sides, `voxel` the voxel faces merged into rectangles.
enum class DepositMeshSurface { layers, voxel };

struct DepositMeshOptions {
  DepositMeshSurface surface = DepositMeshSurface::layers;
  /// Layers: outlines simplified within this distance of their marching-squares outline;
  /// decimation doubles it until the mesh fits max_triangles.
  double outline_tolerance_mm = 0.025;
  /// Layers: rings per quarter of a bead's round side (2: five rings per layer).
  int profile_steps = 2;
  bool include_skirt = false;     ///< skirt and brim
  bool include_support = false;   ///< support and support interface
  bool include_custom = false;    ///< wipe tower, start/end code and purge lines
  std::size_t max_triangles = 0;  ///< 0: full resolution
  /// Full resolution with beads given: vertices move onto the bead surfaces (sub-voxel).
  bool smooth = true;
  /// Larger meshes are not smoothed (0: no limit): smoothing costs about 3.5 s of CPU per
  /// million triangles.
  std::size_t smooth_max_triangles = 2'000'000;
};

struct DepositMesh {
  Mesh mesh;
  DepositMeshSurface surface = DepositMeshSurface::voxel;  ///< the surface built
  /// Why the layered surface was not built when it was asked for (empty otherwise).
  std::string layers_fallback;
  std::size_t layers = 0;             ///< layers: slabs
  std::size_t outlines = 0;           ///< layers: outlines over all slabs
  std::size_t straight_outlines = 0;  ///< layers: outlines kept with straight sides
  double outline_tolerance_mm = 0;    ///< layers: the simplification's tolerance used
  double voxel_mm = 0;                ///< the deposit's voxel edge
  int cell_voxels = 1;  ///< s: the mesh is built on cells of s^3 voxels (1: no decimation)
  /// Every point of the mesh lies within this distance of the full-resolution voxel surface
  /// of the kept components (0 at full resolution without repairs).
  double error_bound_mm = 0;
  double volume_mm3 = 0;  ///< enclosed by the mesh
  double filled_volume_mm3 =
      0;  ///< kept components' filled voxels (full resolution, before repairs)
  std::size_t repaired_cells = 0;      ///< cells filled to make the surface a 2-manifold
  std::size_t smoothed_vertices = 0;   ///< vertices moved onto a bead surface
  bool smoothing_skipped = false;      ///< too many triangles for the smoothing's check
  std::size_t rectangles = 0;          ///< merged faces
  std::size_t full_res_triangles = 0;  ///< triangles of the full-resolution mesh
  std::size_t components = 0;          ///< kept connected pieces
  std::size_t dropped_components = 0;  ///< pieces without part voxels (skirt, purge line)
  /// Layers: inner shells the slabs close (small cavities the voxels reach from outside),
  /// filled.
  std::size_t filled_cavities = 0;
  /// Layers: one-slab pieces whose voxels touch the next slab's, merged into its cross-section.
  std::size_t merged_pieces = 0;
  double seconds = 0;  ///< time to build
};

struct DepositSurface;

/// Builds the mesh. `beads` (surface_beads of the G-code that laid the grid; may be empty):
/// at full resolution the vertices are placed on the beads' surfaces (sub-voxel smoothing).
/// `filled` (optional): the grid's filled volume as the deviation stage extracted it, sealed
/// with the default seal and groove depth over a region holding every part voxel (verify's
/// DeviationResult::filled_volume); used instead of extracting it again unless the options
/// include auxiliary features. Errors: max_triangles too small for any mesh of the part
/// (usage).
[[nodiscard]] Result<DepositMesh> build_deposit_mesh(const VoxelGrid& grid,
                                                     const DepositMeshOptions& options,
                                                     std::span<const SurfaceBead> beads = {},
                                                     const DepositSurface* filled = nullptr);

/// Checks that `path` ends in .stl, .3mf or .ply (usage error otherwise).
[[nodiscard]] Status check_deposit_mesh_path(const std::filesystem::path& path);

/// Writes the mesh atomically as binary STL, 3MF (zip with 3D/3dmodel.model) or binary
/// little-endian PLY, by extension. `deviation_mm` (PLY only, one per vertex, or empty): the
/// signed deviation from the design, written as the vertex properties `quality` (MeshLab)
/// and `scalar_deviation` (CloudCompare), float.
[[nodiscard]] Status write_deposit_mesh(const DepositMesh& mesh, const std::filesystem::path& path,
                                        std::span<const float> deviation_mm = {});

/// One line for the log: triangles, size, error bound, volume, dropped pieces.
[[nodiscard]] std::string deposit_mesh_summary(const DepositMesh& mesh,
                                               const std::filesystem::path& path);

/// The mesh's figures as compact JSON (path, triangles, vertices, bytes, cell_voxels,
/// error_bound_mm, volume_mm3, filled_volume_mm3, repaired_voxels, components,
/// dropped_components); no timings, so the same input gives the same text.
[[nodiscard]] std::string deposit_mesh_json(const DepositMesh& mesh,
                                            const std::filesystem::path& path);

/// Parses --deposit-mesh-include: comma list of skirt, brim, support, custom, purge,
/// wipe_tower, all (usage error for anything else).
[[nodiscard]] Status parse_deposit_mesh_include(const std::string& list,
                                                DepositMeshOptions& options);

}  // namespace printtwin
