// The only file that includes Embree: closest-point, ray and inside queries on a mesh.
//
// Embree's BVH works in single precision, so vertices are stored relative to the mesh's
// bounding-box centre (smaller magnitudes, finer float spacing) and every distance is
// recomputed in double precision from the original mesh in the point-query callback:
// the BVH only culls candidates, it never decides a distance.
#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>

#include "core/plain_path.hpp"
#include "mesh/kernels.hpp"
#include "mesh/mesh_query_ball.hpp"
#include "mesh/mesh_query_rays.hpp"
#include "printtwin/mesh_query.hpp"

namespace printtwin {

using detail::box_may_win;
using detail::offer_unboxed;
using detail::PointQueryState;
using detail::TriangleBounds;

Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Voronoi-region walk (Ericson, Real-Time Collision Detection, 5.1.5).
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

struct MeshQuery::Impl {
  Mesh mesh;
  /// Per triangle, two cheap lower bounds of the point-triangle distance: its plane and its
  /// bounding box.
  std::vector<TriangleBounds> bounds;
  Vec3 center = Vec3::Zero();
  double scale_mm = 1.0;  // 1 + the bounding box's diagonal: the step past a ray hit scales with it
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;

  ~Impl() {
    if (scene != nullptr) rtcReleaseScene(scene);
    if (device != nullptr) rtcReleaseDevice(device);
  }
};

namespace detail {
/// Offers triangle `t` after its box test: rejected by its plane when it cannot win or tie
/// (the margin keeps rounding from rejecting a triangle that would tie or win in the exact
/// test), else tested exactly. True when it became the best.
bool offer_unboxed(PointQueryState& st, std::uint32_t t) {
  const TriangleBounds& tb = (*st.bounds)[t];
  const Vec3& p = st.p;
  const double plane_d = tb.n[0] * p.x() + tb.n[1] * p.y() + tb.n[2] * p.z() - tb.offset;
  const double lower =
      std::abs(plane_d) - 1e-9 * (1.0 + std::abs(tb.offset) + p.cwiseAbs().maxCoeff());
  if (lower > 0 && lower * lower > st.best_d2) return false;
  const auto& tri = st.mesh->triangles[t];
  const auto& v = st.mesh->vertices_mm;
  const Vec3 q = closest_point_on_triangle(p, v[tri[0]], v[tri[1]], v[tri[2]]);
  const double d2 = (q - p).squaredNorm();
  if (d2 < st.best_d2 || (d2 == st.best_d2 && t < st.best_triangle)) {
    st.best_d2 = d2;
    st.best_point = q;
    st.best_triangle = t;
    return true;
  }
  return false;
}
}  // namespace detail

namespace {

/// Squared distance from p to the box [lo, hi] (0 inside).
inline double box_distance2(const Vec3& p, const float* lo, const float* hi) {
  double box2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double e =
        std::max({0.0, static_cast<double>(lo[a]) - p[a], p[a] - static_cast<double>(hi[a])});
    box2 += e * e;
  }
  return box2;
}

/// Offers triangle `t` to the search (box, plane, then exact). True when it became the best.
bool offer(PointQueryState& st, std::uint32_t t) {
  const TriangleBounds& tb = (*st.bounds)[t];
  if (!box_may_win(box_distance2(st.p, tb.lo, tb.hi), st.best_d2)) return false;
  return offer_unboxed(st, t);
}

/// The candidates of a ball query (`c.ids`) as columns: their boxes (for the box test).
void load_boxes(detail::BallScratch& c, const std::vector<TriangleBounds>& bounds) {
  const std::size_t n = c.ids.size();
  for (int a = 0; a < 3; ++a) {
    c.lo[a].resize(n);
    c.hi[a].resize(n);
  }
  for (std::size_t k = 0; k < n; ++k)
    for (int a = 0; a < 3; ++a) {
      c.lo[a][k] = static_cast<double>(bounds[c.ids[k]].lo[a]);
      c.hi[a][k] = static_cast<double>(bounds[c.ids[k]].hi[a]);
    }
}

/// Swaps candidates i and j of a loaded BallScratch (ids and boxes).
void swap_candidates(detail::BallScratch& c, std::size_t i, std::size_t j) {
  std::swap(c.ids[i], c.ids[j]);
  for (int a = 0; a < 3; ++a) {
    std::swap(c.lo[a][i], c.lo[a][j]);
    std::swap(c.hi[a][i], c.hi[a][j]);
  }
}

bool point_query_callback(RTCPointQueryFunctionArguments* args) {
  auto* st = static_cast<PointQueryState*>(args->userPtr);
  if (!offer(*st, args->primID)) return false;
  // Shrink the search radius (float, padded so that float rounding never culls a
  // triangle that is closer in double precision).
  args->query->radius = static_cast<float>(std::sqrt(st->best_d2) * (1.0 + 1e-6) + 1e-6);
  return true;
}

/// Gathers every triangle the BVH reports for the query ball (the radius never shrinks).
bool gather_callback(RTCPointQueryFunctionArguments* args) {
  static_cast<std::vector<std::uint32_t>*>(args->userPtr)->push_back(args->primID);
  return false;
}

// Three fixed directions, far from axes and face diagonals, for the parity vote.
const Vec3 kVoteDirections[3] = {Vec3(0.5773502691896258, 0.5773502691896258, 0.5773502691896258)
                                     .cross(Vec3(0.1, 0.7, -0.3))
                                     .normalized(),
                                 Vec3(0.3141592, -0.8660254, 0.3883721).normalized(),
                                 Vec3(-0.7071068, 0.1234567, 0.6962132).normalized()};

}  // namespace

MeshQuery::MeshQuery(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MeshQuery::MeshQuery(MeshQuery&&) noexcept = default;
MeshQuery& MeshQuery::operator=(MeshQuery&&) noexcept = default;
MeshQuery::~MeshQuery() = default;

Result<MeshQuery> MeshQuery::build(const Mesh& mesh) { return build_scene(mesh, false); }

Result<MeshQuery> MeshQuery::build_for_rays(const Mesh& mesh) { return build_scene(mesh, true); }

Result<MeshQuery> MeshQuery::build_scene(const Mesh& mesh, bool rays_only) {
  if (mesh.triangles.empty()) return bad_input("mesh has no triangles to query");
  auto impl = std::make_unique<Impl>();
  impl->mesh = mesh;
  const Box3 box = bounding_box(mesh);
  impl->center = box.center();
  impl->scale_mm = 1.0 + box.size().norm();
  impl->device = rtcNewDevice("threads=0");
  if (impl->device == nullptr) return internal_error("cannot create the Embree device");
  impl->scene = rtcNewScene(impl->device);
  rtcSetSceneFlags(impl->scene, static_cast<RTCSceneFlags>(RTC_SCENE_FLAG_ROBUST |
                                                           RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION));
  // Ray hits do not depend on the BVH (the closest hit along the ray is the same); the
  // quality only trades build time against traversal time.
  const RTCBuildQuality quality = rays_only ? RTC_BUILD_QUALITY_LOW : RTC_BUILD_QUALITY_HIGH;
  rtcSetSceneBuildQuality(impl->scene, quality);

  RTCGeometry geom = rtcNewGeometry(impl->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetGeometryBuildQuality(geom, quality);
  auto* verts = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                            RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                            mesh.vertices_mm.size()));
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0,
                                                             RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                                             mesh.triangles.size()));
  if (verts == nullptr || idx == nullptr) {
    rtcReleaseGeometry(geom);
    return internal_error("Embree could not allocate the mesh buffers");
  }
  for (std::size_t i = 0; i < mesh.vertices_mm.size(); ++i)
    for (int k = 0; k < 3; ++k)
      verts[3 * i + k] = static_cast<float>(mesh.vertices_mm[i][k] - impl->center[k]);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      if (mesh.triangles[t][k] >= mesh.vertices_mm.size()) {
        rtcReleaseGeometry(geom);
        return bad_input("triangle " + std::to_string(t) + " refers to a missing vertex");
      }
      idx[3 * t + k] = mesh.triangles[t][k];
    }
  if (!rays_only) impl->bounds.resize(mesh.triangles.size());
  const auto down = [](double x) {
    const auto f = static_cast<float>(x);
    return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity())
                                      : f;
  };
  const auto up = [](double x) {
    const auto f = static_cast<float>(x);
    return static_cast<double>(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity())
                                      : f;
  };
  for (std::size_t t = 0; t < impl->bounds.size(); ++t) {
    const Vec3 n = triangle_normal(mesh, t);
    const double len = n.norm();
    const auto& tri = mesh.triangles[t];
    // A sliver's computed normal is not perpendicular to its edges (the cross product of
    // nearly parallel edges is mostly rounding), so its plane is no lower bound: a zero
    // normal disables the plane test for it.
    const bool planar = has_reliable_normal(mesh, t);
    const Vec3 u = planar ? Vec3(n / len) : Vec3::Zero();
    TriangleBounds& b = impl->bounds[t];
    b.n[0] = u.x();
    b.n[1] = u.y();
    b.n[2] = u.z();
    b.offset = u.dot(mesh.vertices_mm[tri[0]]);
    for (int a = 0; a < 3; ++a) {
      const double v0 = mesh.vertices_mm[tri[0]][a], v1 = mesh.vertices_mm[tri[1]][a],
                   v2 = mesh.vertices_mm[tri[2]][a];
      b.lo[a] = down(std::min({v0, v1, v2}));
      b.hi[a] = up(std::max({v0, v1, v2}));
    }
  }
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl->scene);
  if (rtcGetDeviceError(impl->device) != RTC_ERROR_NONE)
    return internal_error("Embree failed to build the BVH");
  return MeshQuery(std::move(impl));
}

const Mesh& MeshQuery::mesh() const { return impl_->mesh; }

namespace {
/// One Embree point query around p (original frame) with `radius` (infinite, or padded like
/// the callback's shrinking radius so float rounding never culls a candidate).
void run_point_query(RTCScene scene, const Vec3& local, double radius, RTCPointQueryFunction fn,
                     void* user) {
  RTCPointQuery query;
  query.x = static_cast<float>(local.x());
  query.y = static_cast<float>(local.y());
  query.z = static_cast<float>(local.z());
  query.time = 0.f;
  query.radius = std::isinf(radius) ? std::numeric_limits<float>::infinity()
                                    : static_cast<float>(radius * (1.0 + 1e-6) + 1e-6);
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(scene, &query, &context, fn, user);
}
}  // namespace

ClosestPoint MeshQuery::closest_point(const Vec3& p) const {
  PointQueryState st{&impl_->mesh, &impl_->bounds, p};
  run_point_query(impl_->scene, p - impl_->center, std::numeric_limits<double>::infinity(),
                  point_query_callback, &st);
  return ClosestPoint{st.best_point, std::sqrt(st.best_d2), st.best_triangle};
}

std::optional<ClosestPoint> MeshQuery::closest_point_within(const Vec3& p,
                                                            double max_distance_mm) const {
  PointQueryState st{&impl_->mesh, &impl_->bounds, p};
  st.best_d2 = max_distance_mm * max_distance_mm;
  run_point_query(impl_->scene, p - impl_->center, max_distance_mm, point_query_callback, &st);
  if (!(st.best_d2 < max_distance_mm * max_distance_mm)) return std::nullopt;
  return ClosestPoint{st.best_point, std::sqrt(st.best_d2), st.best_triangle};
}

void detail::closest_points_in_ball(const MeshQuery& query, const Vec3& center, double radius,
                                    std::span<const Vec3> points,
                                    std::vector<std::optional<ClosestPoint>>& out,
                                    BallScratch& boxes) {
  const auto* impl = &MeshQueryAccess::impl(query);
  out.assign(points.size(), std::nullopt);
  std::vector<std::uint32_t>& candidates = boxes.ids;
  candidates.clear();
  run_point_query(impl->scene, center - impl->center, radius, gather_callback, &candidates);
  if (candidates.empty()) return;
  load_boxes(boxes, impl->bounds);
  for (std::size_t i = 0; i < points.size(); ++i) {
    PointQueryState st{&impl->mesh, &impl->bounds, points[i]};
    detail::scan_candidates(st, boxes);
    if (!std::isfinite(st.best_d2)) continue;
    // The winner usually wins the next point too: moved first, so that its distance prunes
    // the other candidates by box (the answer does not depend on the order).
    if (st.best_slot > 0) swap_candidates(boxes, 0, st.best_slot);
    const double d = std::sqrt(st.best_d2);
    // Every triangle within d of the point meets the query ball, so was a candidate.
    if ((points[i] - center).norm() + d * (1 + 1e-9) + 1e-9 <= radius)
      out[i] = ClosestPoint{st.best_point, d, st.best_triangle};
  }
}

void MeshQuery::closest_points(std::span<const Vec3> points, std::vector<ClosestPoint>& out) const {
  closest_points(points, out, {});
}

void MeshQuery::closest_points(std::span<const Vec3> points, std::vector<ClosestPoint>& out,
                               std::span<const std::uint32_t> hints) const {
  out.resize(points.size());
  const bool hinted = hints.size() == points.size() && !detail::plain_path("closest_hints");
  const std::size_t triangles = impl_->mesh.triangles.size();
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, points.size(), 1024),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          if (!hinted || hints[i] >= triangles) {
            out[i] = closest_point(points[i]);
            continue;
          }
          // The hint's exact distance is an upper bound of the closest one:
          // the ball of that radius (padded like the callback's) holds every
          // triangle that wins or ties, so the answer is unchanged.
          PointQueryState st{&impl_->mesh, &impl_->bounds, points[i]};
          detail::offer_unboxed(st, hints[i]);
          run_point_query(impl_->scene, points[i] - impl_->center, std::sqrt(st.best_d2),
                          point_query_callback, &st);
          out[i] = ClosestPoint{st.best_point, std::sqrt(st.best_d2), st.best_triangle};
        }
      });
}

namespace {
/// The closest hit's state while one ray is traced: hits at the same distance (the ray
/// through an edge, or coincident faces) are resolved to the lowest triangle index, so the
/// hit does not depend on the BVH's traversal order (which differs with the build quality).
struct TieBreakContext {
  RTCIntersectContext base;  // first member: Embree passes &base to the filter
  float best_t = std::numeric_limits<float>::infinity();
  unsigned best_prim = RTC_INVALID_GEOMETRY_ID;
};

void lowest_triangle_on_ties(const RTCFilterFunctionNArguments* args) {
  if (args->N != 1 || args->valid[0] == 0) return;
  auto* ctx = reinterpret_cast<TieBreakContext*>(args->context);
  const float t = RTCRayN_tfar(args->ray, 1, 0);  // the candidate's distance
  const unsigned prim = RTCHitN_primID(args->hit, 1, 0);
  if (t == ctx->best_t && prim > ctx->best_prim) {
    args->valid[0] = 0;
    return;
  }
  ctx->best_t = t;
  ctx->best_prim = prim;
}

/// Stream tracing's tie rule: the same as lowest_triangle_on_ties, per ray of the stream
/// (each ray's id is its index).
struct StreamTieBreakContext {
  RTCIntersectContext base;  // first member: Embree passes &base to the filter
  float* best_t = nullptr;
  unsigned* best_prim = nullptr;
};

void lowest_triangle_on_ties_stream(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<StreamTieBreakContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const unsigned id = RTCRayN_id(args->ray, args->N, i);
    const float t = RTCRayN_tfar(args->ray, args->N, i);
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    if (t == ctx->best_t[id] && prim > ctx->best_prim[id]) {
      args->valid[i] = 0;
      continue;
    }
    ctx->best_t[id] = t;
    ctx->best_prim[id] = prim;
  }
}

/// Embree's ray for origin + t * dir (dir unit), t in (t_min, t_max], in the BVH's frame.
void set_ray(RTCRayHit& rh, const Vec3& o, const Vec3& d, double t_min, double t_max) {
  rh.ray.org_x = static_cast<float>(o.x());
  rh.ray.org_y = static_cast<float>(o.y());
  rh.ray.org_z = static_cast<float>(o.z());
  rh.ray.dir_x = static_cast<float>(d.x());
  rh.ray.dir_y = static_cast<float>(d.y());
  rh.ray.dir_z = static_cast<float>(d.z());
  rh.ray.tnear = static_cast<float>(t_min);
  rh.ray.tfar = static_cast<float>(std::min(t_max, 1e30));
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

/// The hit of a traced ray with the triangle's unit normal: the one kept for the plane bound
/// (the same division); a sliver keeps none there, a query for rays only keeps no bounds.
std::optional<RayHit> ray_hit(const Mesh& mesh, const std::vector<TriangleBounds>& bounds,
                              const RTCRayHit& rh) {
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  Vec3 n = Vec3::Zero();
  if (!bounds.empty()) {
    const TriangleBounds& tb = bounds[rh.hit.primID];
    n = Vec3(tb.n[0], tb.n[1], tb.n[2]);
  }
  if (n.isZero(0)) {
    n = triangle_normal(mesh, rh.hit.primID);
    const double nl = n.norm();
    if (nl > 0) n /= nl;
  }
  return RayHit{static_cast<double>(rh.ray.tfar), rh.hit.primID, n};
}
}  // namespace

std::optional<RayHit> MeshQuery::first_hit(const Vec3& origin, const Vec3& dir, double t_min,
                                           double t_max) const {
  const double len = dir.norm();
  if (!(len > 0)) return std::nullopt;
  RTCRayHit rh{};
  set_ray(rh, origin - impl_->center, dir / len, t_min, t_max);
  TieBreakContext context;
  rtcInitIntersectContext(&context.base);
  context.base.filter = lowest_triangle_on_ties;
  rtcIntersect1(impl_->scene, &context.base, &rh);
  return ray_hit(impl_->mesh, impl_->bounds, rh);
}

void detail::first_hits(const MeshQuery& query, std::span<const RayRequest> rays,
                        std::span<std::optional<RayHit>> out) {
  const auto& impl = MeshQueryAccess::impl(query);
  thread_local std::vector<RTCRayHit> stream;
  thread_local std::vector<float> best_t;
  thread_local std::vector<unsigned> best_prim;
  stream.assign(rays.size(), RTCRayHit{});
  best_t.assign(rays.size(), std::numeric_limits<float>::infinity());
  best_prim.assign(rays.size(), RTC_INVALID_GEOMETRY_ID);
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const RayRequest& r = rays[i];
    const double len = r.dir.norm();
    if (len > 0) {
      set_ray(stream[i], r.origin - impl.center, r.dir / len, r.t_min, r.t_max);
    } else {  // no direction: no hit (an empty interval)
      set_ray(stream[i], Vec3::Zero(), Vec3::UnitX(), 1, 0);
    }
    stream[i].ray.id = static_cast<unsigned>(i);
  }
  StreamTieBreakContext context;
  rtcInitIntersectContext(&context.base);
  context.base.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  context.base.filter = lowest_triangle_on_ties_stream;
  context.best_t = best_t.data();
  context.best_prim = best_prim.data();
  rtcIntersect1M(impl.scene, &context.base, stream.data(), static_cast<unsigned>(rays.size()),
                 sizeof(RTCRayHit));
  for (std::size_t i = 0; i < rays.size(); ++i)
    out[i] = rays[i].dir.norm() > 0 ? ray_hit(impl.mesh, impl.bounds, stream[i]) : std::nullopt;
}

int MeshQuery::crossings(const Vec3& origin, const Vec3& dir) const {
  // March along the ray hit by hit. Two triangles hit at the same t (the ray passes through
  // a shared edge) are one crossing, so the next search starts just past the hit.
  int count = 0;
  double t = 0;
  const double step = 1e-7 * impl_->scale_mm;
  for (int guard = 0; guard < 100000; ++guard) {
    auto hit = first_hit(origin, dir, t);
    if (!hit) break;
    ++count;
    t = hit->t_mm + step;
  }
  return count;
}

bool MeshQuery::inside(const Vec3& p) const {
  int votes = 0;
  for (const auto& d : kVoteDirections) votes += crossings(p, d) % 2;
  return votes >= 2;
}

double MeshQuery::signed_distance(const Vec3& p) const {
  const double d = closest_point(p).distance_mm;
  return inside(p) ? -d : d;
}

}  // namespace printtwin
