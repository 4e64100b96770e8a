// Signed point-to-mesh distances: Embree closest points (MeshQuery) and the sign from
// angle-weighted pseudo-normals (J. A. Baerentzen, H. Aanaes, "Signed distance computation
// using the angle weighted pseudonormal", IEEE TVCG 11(3), 2005), falling back to the
// ray-parity vote of MeshQuery::inside near open or non-manifold edges.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "deviation/point_groups.hpp"
#include "deviation/sharp_edges.hpp"
#include "mesh/mesh_query_ball.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {

/// Pseudo-normals of a mesh: per face, per vertex (angle weighted), per edge (sum of the two
/// face normals). Features next to an edge that does not have exactly two consistently
/// oriented faces are flagged `open` and get the ray test instead.
struct PseudoNormals {
  std::vector<Vec3> face;
  std::vector<Vec3> vertex;
  std::vector<std::uint8_t> vertex_open;
  /// Per triangle, per edge (v0v1, v1v2, v2v0): pseudo-normal and open flag.
  std::vector<std::array<Vec3, 3>> edge;
  std::vector<std::array<std::uint8_t, 3>> edge_open;
  /// Per triangle, the lines of its edges in its plane (inward unit normal m and offset o:
  /// m . q - o is q's distance from the edge's line, positive inside) and the feature test's
  /// eps (1e-9 x the longest edge): a closest point farther than a few eps from all three
  /// lines lies on no vertex and no edge, so the sign test needs only the face normal and
  /// reads no vertex.
  struct EdgeLines {
    std::array<Vec3, 3> m;
    std::array<double, 3> o{};
    double eps = 0;
  };
  std::vector<EdgeLines> lines;

  explicit PseudoNormals(const Mesh& m) {
    const std::size_t nt = m.triangles.size();
    face.resize(nt);
    vertex.assign(m.vertices_mm.size(), Vec3::Zero());
    vertex_open.assign(m.vertices_mm.size(), 0);
    edge.resize(nt);
    edge_open.assign(nt, {0, 0, 0});
    lines.resize(nt);
    for (std::size_t t = 0; t < nt; ++t) {
      const auto& tri = m.triangles[t];
      const std::array<Vec3, 3> v{m.vertices_mm[tri[0]], m.vertices_mm[tri[1]],
                                  m.vertices_mm[tri[2]]};
      // The same eps as the full test in signed_from_closest.
      lines[t].eps =
          1e-9 * std::sqrt(std::max({(v[1] - v[0]).squaredNorm(), (v[2] - v[1]).squaredNorm(),
                                     (v[0] - v[2]).squaredNorm()}));
      const Vec3 n = (v[1] - v[0]).cross(v[2] - v[0]);
      // A sliver's computed normal is mostly rounding (as in MeshQuery's plane bound): its
      // lines would be wrong, so they never certify and the full test decides.
      const bool sliver = !has_reliable_normal(m, t);
      for (int k = 0; k < 3; ++k) {
        const Vec3& a = v[static_cast<std::size_t>(k)];
        const Vec3& b = v[static_cast<std::size_t>((k + 1) % 3)];
        const Vec3 inward = n.cross(b - a);  // in the plane, towards the third vertex
        const double len = inward.norm();
        auto& ln = lines[t];
        if (sliver || !(len > 0) || !std::isfinite(len)) {  // degenerate: never certifies
          ln.m[static_cast<std::size_t>(k)] = Vec3::Zero();
          ln.o[static_cast<std::size_t>(k)] = std::numeric_limits<double>::infinity();
          continue;
        }
        ln.m[static_cast<std::size_t>(k)] = inward / len;
        ln.o[static_cast<std::size_t>(k)] = ln.m[static_cast<std::size_t>(k)].dot(a);
      }
    }
    // Edge uses sorted by their undirected key (cheaper than a hash map of vectors).
    struct EdgeUse {
      std::uint64_t key = 0;
      std::uint32_t tri = 0;
      std::uint8_t slot = 0;
      bool forward = true;  // v_lo -> v_hi in the triangle's winding
    };
    std::vector<EdgeUse> uses;
    uses.reserve(nt * 3);
    for (std::size_t t = 0; t < nt; ++t) {
      const auto& tri = m.triangles[t];
      const Vec3 n = triangle_normal(m, t);
      const double len = n.norm();
      face[t] = len > 0 ? Vec3(n / len) : Vec3::Zero();
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = tri[static_cast<std::size_t>(k)],
                            b = tri[static_cast<std::size_t>((k + 1) % 3)],
                            c = tri[static_cast<std::size_t>((k + 2) % 3)];
        // Angle at vertex a.
        const Vec3 e1 = m.vertices_mm[b] - m.vertices_mm[a];
        const Vec3 e2 = m.vertices_mm[c] - m.vertices_mm[a];
        const double angle = std::atan2(e1.cross(e2).norm(), e1.dot(e2));
        vertex[a] += angle * face[t];
        const std::uint32_t lo = std::min(a, b), hi = std::max(a, b);
        uses.push_back({(std::uint64_t{lo} << 32) | hi, static_cast<std::uint32_t>(t),
                        static_cast<std::uint8_t>(k), a == lo});
      }
    }
    // Sorted by (key, triangle): a counting sort by the low vertex (uses were made in
    // triangle order, and it is stable), then an insertion sort of each low vertex's few
    // uses by the high vertex (stable too).
    {
      std::vector<std::uint32_t> start(m.vertices_mm.size() + 1, 0);
      for (const EdgeUse& u : uses) ++start[(u.key >> 32) + 1];
      for (std::size_t k = 0; k + 1 < start.size(); ++k) start[k + 1] += start[k];
      std::vector<EdgeUse> sorted(uses.size());
      for (const EdgeUse& u : uses) sorted[start[u.key >> 32]++] = u;
      std::size_t lo = 0;
      for (std::size_t k = 0; k + 1 < start.size(); ++k) {
        const std::size_t hi = start[k];  // the cursor ended at the next vertex's start
        for (std::size_t i = lo + 1; i < hi; ++i)
          for (std::size_t j = i; j > lo && sorted[j - 1].key > sorted[j].key; --j)
            std::swap(sorted[j - 1], sorted[j]);
        lo = hi;
      }
      uses = std::move(sorted);
    }
    for (std::size_t i = 0; i < uses.size();) {
      std::size_t j = i;
      while (j < uses.size() && uses[j].key == uses[i].key) ++j;
      const bool ok = j - i == 2 && uses[i].forward != uses[i + 1].forward;
      Vec3 n = Vec3::Zero();
      for (std::size_t k = i; k < j; ++k) n += face[uses[k].tri];
      for (std::size_t k = i; k < j; ++k) {
        edge[uses[k].tri][uses[k].slot] = n;
        edge_open[uses[k].tri][uses[k].slot] = ok ? 0 : 1;
      }
      if (!ok) {
        vertex_open[static_cast<std::size_t>(uses[i].key >> 32)] = 1;
        vertex_open[static_cast<std::size_t>(uses[i].key & 0xffffffffU)] = 1;
      }
      i = j;
    }
  }
};

}  // namespace

struct DeviationTarget::Impl {
  Mesh mesh;
  MeshQuery query;
  PseudoNormals pn;
  Box3 bbox;
  double volume_mm3 = 0;
  double spacing_mm = 0;
  std::uint64_t seed = 1;
  std::vector<SurfaceSample> samples;
  std::unique_ptr<const detail::SharpEdges> edges;  ///< for the layer-line figures

  Impl(const Mesh& m, MeshQuery q) : mesh(m), query(std::move(q)), pn(m) {}
};

DeviationTarget::DeviationTarget(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

Result<DeviationTarget> DeviationTarget::build(const Mesh& mesh, const DeviationSettings& settings,
                                               double voxel_mm) {
  if (mesh.triangles.empty()) return bad_input("deviation: the mesh has no triangles");
  if (settings.mesh_sample_spacing_mm < 0)
    return usage_error("deviation: mesh sample spacing must be >= 0 mm");
  const double spacing = settings.mesh_sample_spacing_mm > 0
                             ? settings.mesh_sample_spacing_mm
                             : (voxel_mm > 0 ? 2.0 * voxel_mm : 0.0);
  if (auto st = check_sample_budget(mesh, spacing); !st) return st.error();
  auto query = MeshQuery::build(mesh);
  if (!query) return query.error();
  auto impl = std::make_shared<Impl>(mesh, std::move(*query));
  impl->bbox = bounding_box(mesh);
  impl->volume_mm3 = signed_volume_mm3(mesh);
  impl->seed = settings.seed;
  impl->spacing_mm = spacing;
  tbb::parallel_invoke(
      [&] {
        if (impl->spacing_mm > 0)
          impl->samples = sample_surface(mesh, impl->spacing_mm, impl->seed);
      },
      [&] {
        impl->edges = std::make_unique<const detail::SharpEdges>(mesh, detail::kSharpDeg,
                                                                 detail::kWallEdgeMarginMm);
      });
  return DeviationTarget(std::move(impl));
}

const detail::SharpEdges& detail::DeviationTargetAccess::sharp_edges(
    const DeviationTarget& target) {
  return *target.impl_->edges;
}

const Mesh& DeviationTarget::mesh() const { return impl_->mesh; }
const MeshQuery& DeviationTarget::query() const { return impl_->query; }
const Box3& DeviationTarget::bbox_mm() const { return impl_->bbox; }
double DeviationTarget::volume_mm3() const { return impl_->volume_mm3; }
double DeviationTarget::sample_spacing_mm() const { return impl_->spacing_mm; }
std::uint64_t DeviationTarget::sample_seed() const { return impl_->seed; }
std::span<const SurfaceSample> DeviationTarget::samples() const { return impl_->samples; }

namespace {

/// Signed distance of p (mesh frame) from its exact closest point: the pseudo-normal of the
/// feature (vertex, edge or face) that holds the closest point, or the ray-parity vote
/// where that feature touches an open or non-manifold edge.
double signed_from_closest(const Mesh& mesh, const MeshQuery& query, const PseudoNormals& pn,
                           const Vec3& p, const ClosestPoint& cp) {
  const Vec3 dir = p - cp.point_mm;
  if (cp.distance_mm == 0) return 0.0;
  {
    // Clear of all three edge lines by 4 eps (plus the rounding of m . q - o): the full
    // test below would find no vertex and no edge within eps, so the face decides.
    const PseudoNormals::EdgeLines& ln = pn.lines[cp.triangle];
    const Vec3& q = cp.point_mm;
    const double round = 1e-13 * (1.0 + q.cwiseAbs().sum());
    bool clear = true;
    for (int k = 0; k < 3 && clear; ++k)
      clear = ln.m[static_cast<std::size_t>(k)].dot(q) - ln.o[static_cast<std::size_t>(k)] >
              4 * ln.eps + round + 1e-13 * std::abs(ln.o[static_cast<std::size_t>(k)]);
    if (clear) {
      const double s = dir.dot(pn.face[cp.triangle]);
      if (s != 0 && std::isfinite(s)) return s > 0 ? cp.distance_mm : -cp.distance_mm;
    }
  }
  // Which feature holds the closest point: a vertex, an edge or the face interior.
  const auto& tri = mesh.triangles[cp.triangle];
  const std::array<Vec3, 3> v{mesh.vertices_mm[tri[0]], mesh.vertices_mm[tri[1]],
                              mesh.vertices_mm[tri[2]]};
  // sqrt is monotonic and correctly rounded: the root of the largest squared edge is the
  // largest edge, exactly.
  const double scale = std::sqrt(std::max(
      {(v[1] - v[0]).squaredNorm(), (v[2] - v[1]).squaredNorm(), (v[0] - v[2]).squaredNorm()}));
  const double eps = 1e-9 * scale;
  // |x| <= eps, with the root taken only when |x|^2 is not clearly above eps^2 (the same
  // answer: beyond the widened square, the rounded root is above eps too).
  const double eps2_wide = (eps * (1 + 1e-6)) * (eps * (1 + 1e-6));
  const auto within_eps = [&](const Vec3& x) {
    const double x2 = x.squaredNorm();
    return x2 <= eps2_wide && std::sqrt(x2) <= eps;
  };
  Vec3 normal = pn.face[cp.triangle];
  bool open = false;
  bool found = false;
  for (int k = 0; k < 3 && !found; ++k) {
    if (within_eps(cp.point_mm - v[static_cast<std::size_t>(k)])) {
      normal = pn.vertex[tri[static_cast<std::size_t>(k)]];
      open = pn.vertex_open[tri[static_cast<std::size_t>(k)]] != 0;
      found = true;
    }
  }
  for (int k = 0; k < 3 && !found; ++k) {
    const Vec3& a = v[static_cast<std::size_t>(k)];
    const Vec3& b = v[static_cast<std::size_t>((k + 1) % 3)];
    const Vec3 ab = b - a;
    // The segment is at least as far as its line, |(cp - a) x ab| / |ab|: clearly beyond
    // 2 eps (rounding is ~1e-16 of the terms), the exact test below cannot pass.
    const double ab2 = ab.squaredNorm();
    if ((cp.point_mm - a).cross(ab).squaredNorm() > 4 * eps2_wide * ab2) continue;
    const double t = std::clamp((cp.point_mm - a).dot(ab) / ab2, 0.0, 1.0);
    if (within_eps(a + t * ab - cp.point_mm)) {
      normal = pn.edge[cp.triangle][static_cast<std::size_t>(k)];
      open = pn.edge_open[cp.triangle][static_cast<std::size_t>(k)] != 0;
      found = true;
    }
  }
  bool outside = false;
  const double s = dir.dot(normal);
  if (open || s == 0 || !std::isfinite(s))
    outside = !query.inside(p);
  else
    outside = s > 0;
  return outside ? cp.distance_mm : -cp.distance_mm;
}

}  // namespace

void DeviationTarget::signed_distances(const Vec3& offset_mm, std::span<const Vec3> points_mm,
                                       double near_mm, std::vector<double>& out,
                                       std::vector<std::uint32_t>* triangles,
                                       std::span<const std::uint32_t> groups) const {
  const Mesh& mesh = impl_->mesh;
  const MeshQuery& query = impl_->query;
  const PseudoNormals& pn = impl_->pn;
  out.resize(points_mm.size());
  if (triangles != nullptr) triangles->resize(points_mm.size());
  // Points in cells of near_mm, a cell at a time: one BVH query gathers the triangles near
  // the cell and each point takes the closest of them, exactly (closest_points_in_ball);
  // the few points it cannot vouch for (farther from the mesh than the ball reaches) get a
  // query of their own.
  const double cell_mm = near_mm > 0 ? near_mm : 0.0;
  std::vector<std::uint32_t> order, own_group;
  std::span<const std::uint32_t> group = groups;
  const bool in_order = !groups.empty() && cell_mm > 0;
  // Grouped by the caller, each group is a run of the input; otherwise grouped here.
  if (in_order) {
    group = groups;
  } else if (cell_mm > 0) {
    detail::group_by_cell(points_mm, cell_mm, order, own_group);
    group = own_group;
  } else {  // no expected distance: input order, in runs of 1024 for the threads
    order.resize(points_mm.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
    for (std::size_t i = 0; i < points_mm.size(); i += 1024)
      own_group.push_back(static_cast<std::uint32_t>(i));
    own_group.push_back(static_cast<std::uint32_t>(points_mm.size()));
    group = own_group;
  }
  if (group.size() < 2) return;
  // The point at place j of the visiting order.
  const auto point_at = [&](std::uint32_t j) -> std::size_t { return in_order ? j : order[j]; };
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, group.size() - 1, cell_mm > 0 ? 64 : 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<Vec3> local;
        std::vector<std::optional<ClosestPoint>> batch;
        detail::BallScratch scratch;
        // The previous point and its distance: the closest point of p is at most
        // prev_d + |p - prev_p| away (triangle inequality), and the previous point's closest
        // triangle is a second bound, often much tighter. The bounds only change the speed: the
        // closest point (ties: lowest triangle) is exact.
        Vec3 prev_p = Vec3::Zero();
        double prev_d = std::numeric_limits<double>::infinity();
        std::optional<std::uint32_t> prev_tri;
        for (std::size_t g = r.begin(); g != r.end(); ++g) {
          const std::uint32_t g0 = group[g], g1 = group[g + 1];
          local.clear();
          Box3 box;
          for (std::uint32_t j = g0; j < g1; ++j) {
            local.push_back(points_mm[point_at(j)] - offset_mm);  // into the mesh's frame
            box.extend(local.back());
          }
          batch.assign(local.size(), std::nullopt);
          if (cell_mm > 0 && local.size() > 1) {
            const Vec3 center = box.center();
            detail::closest_points_in_ball(query, center, 0.5 * box.size().norm() + 0.5 * near_mm,
                                           local, batch, scratch);
          }
          for (std::size_t k = 0; k < local.size(); ++k) {
            const Vec3& p = local[k];
            const std::size_t i = point_at(g0 + static_cast<std::uint32_t>(k));
            if (!batch[k]) {
              // Most points lie near the surface: a bounded query first, the full one if it fails.
              double bound = (prev_d + (p - prev_p).norm()) * (1 + 1e-9) + 1e-9;
              if (prev_tri) {
                const auto& t = mesh.triangles[*prev_tri];
                const double d0 =
                    (closest_point_on_triangle(p, mesh.vertices_mm[t[0]], mesh.vertices_mm[t[1]],
                                               mesh.vertices_mm[t[2]]) -
                     p)
                        .norm();
                bound = std::min(bound, d0 * (1 + 1e-9) + 1e-9);
              }
              if (bound < near_mm) batch[k] = query.closest_point_within(p, bound);
              if (!batch[k] && near_mm > 0) batch[k] = query.closest_point_within(p, near_mm);
              if (!batch[k]) batch[k] = query.closest_point(p);
            }
            const ClosestPoint& cp = *batch[k];
            prev_p = p;
            prev_d = cp.distance_mm;
            prev_tri = cp.triangle;
            if (triangles != nullptr) (*triangles)[i] = cp.triangle;
            out[i] = signed_from_closest(mesh, query, pn, p, cp);
          }
        }
      });
}

Result<std::vector<double>> signed_distances_to_mesh(const Mesh& mesh, std::span<const Vec3> points,
                                                     double near_mm) {
  DeviationSettings no_samples;
  no_samples.mesh_sample_spacing_mm = 0;
  auto target = DeviationTarget::build(mesh, no_samples, 0);
  if (!target) return target.error();
  std::vector<double> out;
  target->signed_distances(Vec3::Zero(), points, near_mm, out);
  return out;
}

}  // namespace printtwin
