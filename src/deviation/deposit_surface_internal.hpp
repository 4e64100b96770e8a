#pragma once
// Internals of the deposit-surface distance search, for the tests.
#include <cstdint>
#include <span>
#include <vector>

#include "deviation/outer_surface.hpp"

namespace printtwin::detail {

/// Query points in the order distances_to_deposit visits them (cells of 4 voxels, column by
/// column): it depends on the voxel size only, so it can be made before the surface.
struct DepositQueryGroups {
  std::vector<std::uint32_t> order, group;
};
DepositQueryGroups group_deposit_queries(std::span<const Vec3> points, double voxel_mm);

/// distances_to_deposit with the nearest face of each point, from the query groups made
/// beforehand when given; groups with an empty order say that the points are in visiting
/// order already (the outputs are then in that order too, read and written linearly).
void distances_to_deposit_with(const DepositSurface& surface, std::span<const Vec3> points,
                               std::vector<double>& signed_mm,
                               std::vector<std::uint32_t>* nearest_face,
                               const DepositQueryGroups* pregrouped = nullptr);

/// The surface's faces in groups of neighbours for DeviationTarget::signed_distances: its
/// non-empty cells (of 4 voxels), as run boundaries into the face arrays.
std::vector<std::uint32_t> face_cell_groups(const DepositSurface& surface);

}  // namespace printtwin::detail
