#pragma once
// Private to src/ (the deviation stage and the tests): batched closest-point queries of
// MeshQuery that need a per-thread scratch buffer.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "printtwin/mesh_query.hpp"

namespace printtwin::detail {

/// Candidate triangles gathered by closest_points_in_ball, kept between calls (one per
/// thread; its contents mean nothing to the caller), so that a search over many cells
/// allocates nothing.
struct BallScratch {
  std::vector<std::uint32_t> ids;
  std::vector<double> lo[3], hi[3];
};

/// Closest points of a group of nearby points from one BVH query of `query`: the triangles
/// whose BVH leaves meet the ball (center, radius) are gathered once, and each point takes
/// the closest of them (same answer and tie rule as MeshQuery::closest_point). A point's
/// answer is only certain when the ball of that distance around it lies inside the query
/// ball: then it is written to out[i]; otherwise out[i] is left empty (ask
/// closest_point_within or closest_point). `out` is resized to points.size().
void closest_points_in_ball(const MeshQuery& query, const Vec3& center, double radius,
                            std::span<const Vec3> points,
                            std::vector<std::optional<ClosestPoint>>& out, BallScratch& scratch);

/// Reaches MeshQuery's state for the functions above.
struct MeshQueryAccess {
  static const MeshQuery::Impl& impl(const MeshQuery& query) { return *query.impl_; }
};

}  // namespace printtwin::detail
