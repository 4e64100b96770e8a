#pragma once
// Internals of the as-printed mesh (mesh_export*.cpp), for its tests.
#include <cstddef>
#include <cstdint>
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

}  // namespace printtwin::detail
