#pragma once
// MeshQuery: closest-point, ray and inside/outside queries on a triangle mesh, built once
// and reused (Embree 3 BVH behind it; src/mesh/mesh_query_embree.cpp is the only file that
// includes Embree). Thread-safe for concurrent queries after construction.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "printtwin/geometry.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"

namespace printtwin {

namespace detail {
struct MeshQueryAccess;
}  // namespace detail

struct ClosestPoint {
  Vec3 point_mm = Vec3::Zero();  ///< closest point on the surface
  double distance_mm = 0;        ///< unsigned distance to it
  std::uint32_t triangle = 0;    ///< triangle that holds it
};

struct RayHit {
  double t_mm = 0;  ///< distance along the (unit) ray direction
  std::uint32_t triangle = 0;
  Vec3 normal = Vec3::Zero();  ///< unit geometric normal of the hit triangle (CCW rule)
};

class MeshQuery {
 public:
  /// Builds the BVH. Fails only when the ray-tracing device cannot be created or the
  /// mesh has no triangles.
  [[nodiscard]] static Result<MeshQuery> build(const Mesh& mesh);
  /// A BVH for ray queries only (first_hit, crossings, inside), for one pass of rays: built
  /// about four times faster (Embree's low-quality Morton builder, no closest-point data)
  /// and traced a little slower; the hits are the same. Closest-point queries on it are not
  /// allowed.
  [[nodiscard]] static Result<MeshQuery> build_for_rays(const Mesh& mesh);

  MeshQuery(MeshQuery&&) noexcept;
  MeshQuery& operator=(MeshQuery&&) noexcept;
  ~MeshQuery();

  /// Closest point on the surface (exact, point-triangle distance over BVH candidates).
  [[nodiscard]] ClosestPoint closest_point(const Vec3& p) const;
  /// Closest point within `max_distance_mm` of p, or nothing when the surface is farther.
  /// Much cheaper than closest_point() for points known to be near the surface (the BVH
  /// prunes everything outside the ball from the start).
  [[nodiscard]] std::optional<ClosestPoint> closest_point_within(const Vec3& p,
                                                                 double max_distance_mm) const;
  /// Closest points of many query points, in parallel (TBB). `out` is resized.
  void closest_points(std::span<const Vec3> points, std::vector<ClosestPoint>& out) const;
  /// The same with a hint per point: a triangle likely near it (say, its closest triangle of
  /// a previous query, as in ICP), whose distance bounds the search from the start. The
  /// results are those of closest_points() (ties go to the lowest triangle) whatever the
  /// hints; good hints only make it faster. `hints` is empty or one per point.
  void closest_points(std::span<const Vec3> points, std::vector<ClosestPoint>& out,
                      std::span<const std::uint32_t> hints) const;

  /// First surface hit along `origin + t * dir` for t in (t_min, t_max]; `dir` need not be unit.
  [[nodiscard]] std::optional<RayHit> first_hit(const Vec3& origin, const Vec3& dir,
                                                double t_min = 0.0, double t_max = 1e30) const;
  /// Number of surface crossings along the ray (each triangle counted once).
  [[nodiscard]] int crossings(const Vec3& origin, const Vec3& dir) const;
  /// Inside test robust to small defects: majority vote of ray parity along 3 fixed
  /// non-axis-aligned directions. Valid for closed or nearly closed meshes.
  [[nodiscard]] bool inside(const Vec3& p) const;
  /// Distance to the surface, negative inside.
  [[nodiscard]] double signed_distance(const Vec3& p) const;

  [[nodiscard]] const Mesh& mesh() const;

 private:
  friend struct detail::MeshQueryAccess;  // batched queries of the deviation stage (src/mesh/)
  struct Impl;
  explicit MeshQuery(std::unique_ptr<Impl> impl);
  static Result<MeshQuery> build_scene(const Mesh& mesh, bool rays_only);
  std::unique_ptr<Impl> impl_;
};

/// Closest point on triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
[[nodiscard]] Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b,
                                             const Vec3& c);

}  // namespace printtwin
