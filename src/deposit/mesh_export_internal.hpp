#pragma once
// Internals of the as-printed mesh (mesh_export*.cpp), for its tests.
#include <cstddef>
#include <span>

#include "printtwin/deviation.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

/// Largest move of a smoothed vertex from its lattice point, per axis, in voxels (< 1/2:
/// triangles of faces that share no lattice point cannot meet).
constexpr double kMaxShiftVoxels = 0.45;
/// A smoothed triangle may turn at most this far from its voxel face's normal...
constexpr double kMaxTurnDegrees = 75.0;
/// ...and keep at least this share of its area; otherwise its vertices stay on the lattice.
constexpr double kMinAreaRatio = 0.05;
/// Rounds of the self-intersection check before every vertex goes back to the lattice.
constexpr int kMaxIntersectionRounds = 8;
/// Meshes above this many triangles are not smoothed: the exact check would take minutes
/// and the local rules alone leave intersections (at the crossings of bead surfaces).
constexpr std::size_t kMaxCheckedTriangles = 2'000'000;

/// Moves the vertices of a closed voxel-face mesh of `grid`'s deposit onto the surface of
/// the nearest bead of the occupied voxels around each vertex, where that surface faces the
/// same way and lies within a voxel (mesh_export_smooth.cpp has the safety rules). Returns
/// the number of vertices moved.
std::size_t smooth_onto_beads(Mesh& mesh, const VoxelGrid& grid,
                              std::span<const SurfaceBead> beads);

}  // namespace printtwin::detail
