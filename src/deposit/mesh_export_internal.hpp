#pragma once
// Internals of the as-printed mesh (mesh_export*.cpp), for its tests.
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "printtwin/deviation.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

/// A smoothed vertex moved farther than this from its lattice point on some axis, in voxels,
/// can bring triangles of its own lattice plane to cross: the crossing check tests those pairs
/// too (below it, triangles of faces that share no lattice point cannot meet).
constexpr double kMaxShiftVoxels = 0.45;
/// A smoothed triangle may turn at most this far from its voxel face's normal...
constexpr double kMaxTurnDegrees = 75.0;
/// ...and keep at least this share of its area; otherwise its vertices stay on the lattice.
constexpr double kMinAreaRatio = 0.05;
/// Cells of the smoothing's crossing check, in voxels.
constexpr double kCellVoxels = 2.0;

/// Moves the vertices of a closed voxel-face mesh of `grid`'s deposit onto the surface of
/// the union of the beads of the occupied voxels around each vertex, along the vertex's
/// normal, within half a bead height plus a voxel (mesh_export_smooth.cpp has the safety
/// rules). `plane_of_triangle`: the lattice plane (axis, side, coordinate) of each
/// triangle's voxel faces. Returns the number of vertices moved; `max_shift_mm` (optional):
/// the largest move.
std::size_t smooth_onto_beads(Mesh& mesh, std::span<const std::uint32_t> plane_of_triangle,
                              const VoxelGrid& grid, std::span<const SurfaceBead> beads,
                              double* max_shift_mm = nullptr);

/// Sorts `keys` ascending (LSD radix, stable); `vals` (optional, same length) move along.
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>* vals);

// ---------------------------------------------------------------- layered surface

/// The filled volume as the layered surface reads it: cells on a lattice, grouped in slabs
/// (one per printed layer) along z.
struct LayerSlabs {
  int width = 0, height = 0;  ///< cells on x and y; the cells of the border are empty
  std::vector<int> bounds;    ///< slab boundaries in cells along z, ascending (slabs: size - 1)
  double cell_mm = 0;
  Vec3 base_mm = Vec3::Zero();  ///< min corner of cell (0, 0, 0)
  /// Fills `rows` (height rows of (width + 63) / 64 words; bit x of row y) with the cells
  /// (x, y) filled at some z in [z0, z1). Called from several threads at once.
  std::function<void(int z0, int z1, std::vector<std::uint64_t>& rows)> project;
};

/// The round side of a slab as a polyline of rings at -90 .. +90 degrees (`steps` per
/// quarter), its inner rings at inset a r (1 - cos phi) and height b r sin phi: the mean and
/// RMS inset along it (lengths weighted), in units of r.
std::array<double, 2> profile_moments(int steps, double a, double b);
/// The a and b for which profile_moments equals the round profile's (1 - 2 / pi,
/// sqrt(3/2 - 4 / pi)); {1, 1} for one step.
std::array<double, 2> profile_fit(int steps);

struct LayerSurfaceOptions {
  /// Outlines are simplified within this distance of the marching-squares outline.
  double tolerance_mm = 0.025;
  /// Rings per quarter of the bead's round side (1: the slab's side is a chevron).
  int profile_steps = 2;
  /// Caps on exact constructions only (otherwise inexact first, exact where a ring is found
  /// not to bound its region).
  bool exact = false;
};

struct LayerSurface {
  Mesh mesh;
  /// One per outline: a filled cell (x, y) of slab `slab` inside it, and a triangle of its
  /// side, so that a connected piece of the mesh can be told from its voxels.
  struct Seed {
    int x = 0, y = 0, slab = 0;
    std::uint32_t triangle = 0;
  };
  std::vector<Seed> seeds;
  std::size_t outlines = 0;  ///< outlines over all slabs
  /// Outlines that keep less than half of the rounded side (length-weighted): where the inset
  /// would fold an edge or reach another part of an outline, each vertex keeps only part of
  /// it (pin holes, one-cell fins, necks: nearly straight sides).
  std::size_t straight_outlines = 0;
  std::size_t cap_triangles = 0;  ///< horizontal triangles (between slabs, bottom, top)
};

/// The layered surface (mesh_export.hpp has the model): per slab the outlines of the
/// cross-section (marching squares, simplified), the slab's side as rings on the bead's
/// rounded profile, caps over the exclusive-or of consecutive slabs (crossings split on both
/// rings; mesh_export_caps.hpp). Closed and oriented outward when every
/// outline is simple and the outlines of one slab do not cross (is_closed_oriented checks).
///
/// `memo` (optional): the slabs and caps of the previous build on the same lattice with the
/// same options; the build takes from it every slab whose cell range is unchanged and not
/// forgotten, and every cap whose two slabs reach the state they had there, and leaves its
/// own slabs and caps in it. The surface is the same as without it.
class LayerSurfaceMemo;
LayerSurface build_layer_surface(const LayerSlabs& slabs, const LayerSurfaceOptions& options,
                                 LayerSurfaceMemo* memo = nullptr);

/// What build_layer_surface keeps of a build for the next one, where cells moved between
/// slabs (one-slab pieces joined to the slab they touch): only the slabs whose cross-section
/// changed are traced again, only the caps beside them built again.
class LayerSurfaceMemo {
 public:
  LayerSurfaceMemo();
  ~LayerSurfaceMemo();
  LayerSurfaceMemo(const LayerSurfaceMemo&) = delete;
  LayerSurfaceMemo& operator=(const LayerSurfaceMemo&) = delete;
  LayerSurfaceMemo(LayerSurfaceMemo&&) noexcept;
  LayerSurfaceMemo& operator=(LayerSurfaceMemo&&) noexcept;
  /// The cross-section of the slab of cells [z0, z1) changed: the next build traces it.
  void forget(int z0, int z1);
  /// Slabs and caps the last build took from the memo.
  [[nodiscard]] std::size_t reused_slabs() const { return reused_slabs_; }
  [[nodiscard]] std::size_t reused_caps() const { return reused_caps_; }

  struct State;  ///< mesh_export_layers.cpp

 private:
  friend LayerSurface build_layer_surface(const LayerSlabs&, const LayerSurfaceOptions&,
                                          LayerSurfaceMemo*);
  std::unique_ptr<State> state_;
  std::size_t reused_slabs_ = 0, reused_caps_ = 0;
};

/// The cap between a slab's top rings (`lower`) and the next slab's bottom rings (`upper`):
/// each ring closed (first point not repeated), its region on its left, the rings of one
/// set apart. The exclusive-or of the two regions, triangulated (counter-clockwise where
/// only the lower region is: facing up). Upper vertices within `snap_mm` of a lower vertex
/// (rings running the same way) are snapped onto it. `ok` false: a ring crosses its set.
struct LayerCap {
  std::vector<Eigen::Vector2d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  bool ok = false;
};
LayerCap layer_cap(const std::vector<std::vector<Eigen::Vector2d>>& lower,
                   const std::vector<std::vector<Eigen::Vector2d>>& upper, double snap_mm,
                   bool exact = false);

/// True when every edge of the mesh is used exactly once in each direction.
bool is_closed_oriented(const Mesh& mesh);

}  // namespace printtwin::detail
