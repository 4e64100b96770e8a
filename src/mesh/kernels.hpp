#pragma once
// The mesh query's candidate scan (the inner loop of a ball query) and the per-query state
// it shares with mesh_query_embree.cpp.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "mesh/mesh_query_ball.hpp"
#include "printtwin/mesh_query.hpp"

namespace printtwin::detail {

/// One cache line per triangle: unit normal (zero when degenerate), its offset n . a, and
/// the bounding box in single precision rounded outwards (never smaller than the triangle's).
struct alignas(64) TriangleBounds {
  double n[3] = {0, 0, 0};
  double offset = 0;
  float lo[3] = {0, 0, 0};
  float hi[3] = {0, 0, 0};
};

/// One closest-point query: the point and the best triangle so far.
struct PointQueryState {
  const Mesh* mesh;
  const std::vector<TriangleBounds>* bounds;
  Vec3 p;  // query point, original frame, double precision
  double best_d2 = std::numeric_limits<double>::infinity();
  Vec3 best_point = Vec3::Zero();
  std::uint32_t best_triangle = 0;
  std::size_t best_slot = 0;  ///< column of the best in a BallScratch (the candidate kernels)
};

/// Whether a box at squared distance box2 may hold a triangle that wins or ties.
inline bool box_may_win(double box2, double best_d2) { return !(box2 > best_d2 * (1 + 1e-9)); }

/// Offers triangle `t` after its box test: its plane, then the exact closest point. True
/// when it became the best (mesh_query_embree.cpp).
bool offer_unboxed(PointQueryState& st, std::uint32_t t);

/// Offers every candidate of a loaded BallScratch whose box may win (the same arithmetic as
/// box_distance2, so the same candidates pass); sets best_slot to the winner's column.
void scan_candidates(PointQueryState& st, const BallScratch& candidates);

}  // namespace printtwin::detail
