#pragma once
// Private to src/ (the check stage and the tests): many rays of MeshQuery traced together.
#include <optional>
#include <span>

#include "printtwin/mesh_query.hpp"

namespace printtwin::detail {

/// One ray of a batch: `origin + t * dir` for t in (t_min, t_max]; `dir` need not be unit.
struct RayRequest {
  Vec3 origin = Vec3::Zero();
  Vec3 dir = Vec3::Zero();
  double t_min = 0;
  double t_max = 1e30;
};

/// First hits of many rays in one call: the same hit as MeshQuery::first_hit gives each ray
/// (same tie rule), traced as one stream of coherent rays (Embree forms packets of
/// neighbouring rays, which share the BVH nodes they visit). `out` has rays.size() slots.
void first_hits(const MeshQuery& query, std::span<const RayRequest> rays,
                std::span<std::optional<RayHit>> out);

}  // namespace printtwin::detail
