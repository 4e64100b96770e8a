#pragma once
// Helpers shared by the two halves of the registration (registration.cpp,
// registration_search.cpp).
#include <cstdint>
#include <vector>

#include "printtwin/geometry.hpp"

namespace printtwin::detail {

/// Convex hull of points in the plane (Andrew's monotone chain), counter-clockwise, without
/// collinear points; fewer than 3 distinct points come back as they are (deduplicated).
std::vector<Vec2> convex_hull(std::vector<Vec2> points);

/// Key of an occupancy cell (21 bits per axis, cells counted from the origin).
inline std::uint64_t cell_key(int x, int y, int z) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(x) & 0x1FFFFF) << 42) |
         (static_cast<std::uint64_t>(static_cast<std::uint32_t>(y) & 0x1FFFFF) << 21) |
         static_cast<std::uint64_t>(static_cast<std::uint32_t>(z) & 0x1FFFFF);
}

}  // namespace printtwin::detail
