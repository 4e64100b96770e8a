#pragma once
// Query points grouped by small cells, for searches that share work between neighbours.
#include <cstdint>
#include <span>
#include <vector>

#include "printtwin/geometry.hpp"

namespace printtwin::detail {

/// Points grouped by cells of `cell_mm`: `order` lists point indices cell by cell (input
/// order within a cell), `group` the start of each cell's run in `order` (and the end).
/// Cells go column by column (z fastest), like the deposit's faces, so reading points in
/// this order streams through them instead of jumping. A stable radix sort of 30-bit cell
/// codes (10 bits per axis: where the points span more than 1000 cells of `cell_mm`, the
/// cells grow to their extent / 1000), by y strip first (no pass when the input is already
/// in y order), then each strip by x and z with counters that stay in L1.
void group_by_cell(std::span<const Vec3> points, double cell_mm, std::vector<std::uint32_t>& order,
                   std::vector<std::uint32_t>& group);

}  // namespace printtwin::detail
