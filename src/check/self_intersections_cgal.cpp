// Self-intersections: our own broad phase (uniform grid over face bounding boxes) and CGAL's
// exact predicates (Epick kernel: filtered, exact for the yes/no answer) in the narrow phase.
// This file and repair_cgal.cpp are the only ones that include CGAL.
//
// PMP::does_self_intersect builds a box-intersection tree per call and was measured slower
// than this grid on the ~200k-face benchmark mesh (docs/check.md); the pair rules for faces
// that share a vertex or an edge follow PMP's definitions so both count the same pairs.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/intersections.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"

namespace printtwin {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using T3 = K::Triangle_3;
using S3 = K::Segment_3;

P3 to_p3(const Vec3& v) { return P3(v.x(), v.y(), v.z()); }
Vec3 to_vec(const P3& p) { return Vec3(p.x(), p.y(), p.z()); }

/// Do faces f and g intersect other than along what they share (PMP's rules)?
bool faces_intersect(const Mesh& mesh, const std::array<std::uint32_t, 3>& f,
                     const std::array<std::uint32_t, 3>& g) {
  int shared = 0;
  int fi[3] = {-1, -1, -1};  // for each corner of f, the corner of g with the same vertex
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (f[i] == g[j]) {
        fi[i] = j;
        ++shared;
      }
  const auto p = [&](std::uint32_t v) { return to_p3(mesh.vertices_mm[v]); };
  if (shared >= 3) return false;  // duplicate face: reported as such
  if (shared == 2) {
    // Shared edge (a, b); opposite corners r (of f) and s (of g). They overlap only when
    // both faces lie in one plane on the same side of the edge (a fold).
    int r = 0;
    while (fi[r] >= 0) ++r;
    const std::uint32_t a = f[(r + 1) % 3];
    const std::uint32_t b = f[(r + 2) % 3];
    std::uint32_t s = 0;
    for (auto v : g)
      if (v != a && v != b) s = v;
    const P3 pa = p(a), pb = p(b), pr = p(f[r]), ps = p(s);
    return CGAL::coplanar(pa, pb, pr, ps) &&
           CGAL::coplanar_orientation(pa, pb, pr, ps) == CGAL::POSITIVE;
  }
  const T3 tf(p(f[0]), p(f[1]), p(f[2]));
  const T3 tg(p(g[0]), p(g[1]), p(g[2]));
  if (shared == 1) {
    // Shared vertex: they intersect elsewhere iff an edge opposite the shared vertex meets
    // the other face.
    int i = 0;
    while (fi[i] < 0) ++i;
    const int j = fi[i];
    const S3 opp_f(p(f[(i + 1) % 3]), p(f[(i + 2) % 3]));
    const S3 opp_g(p(g[(j + 1) % 3]), p(g[(j + 2) % 3]));
    return CGAL::do_intersect(opp_f, tg) || CGAL::do_intersect(opp_g, tf);
  }
  return CGAL::do_intersect(tf, tg);
}

/// A point of the intersection of two faces known to intersect (for the report).
Vec3 intersection_point(const Mesh& mesh, const std::array<std::uint32_t, 3>& f,
                        const std::array<std::uint32_t, 3>& g) {
  const auto p = [&](std::uint32_t v) { return to_p3(mesh.vertices_mm[v]); };
  const T3 tf(p(f[0]), p(f[1]), p(f[2]));
  const T3 tg(p(g[0]), p(g[1]), p(g[2]));
  const auto result = CGAL::intersection(tf, tg);
  if (result) {
    if (const P3* pt = boost::get<P3>(&*result)) return to_vec(*pt);
    if (const S3* sg = boost::get<S3>(&*result)) return to_vec(CGAL::midpoint(sg->source(), sg->target()));
    if (const T3* tr = boost::get<T3>(&*result)) return to_vec(CGAL::centroid(*tr));
    if (const auto* poly = boost::get<std::vector<P3>>(&*result); poly != nullptr && !poly->empty()) {
      Vec3 sum = Vec3::Zero();
      for (const auto& q : *poly) sum += to_vec(q);
      return sum / static_cast<double>(poly->size());
    }
  }
  // Touching only through the shared-vertex/edge rules: the midpoint of the centroids.
  Vec3 sum = Vec3::Zero();
  for (auto v : f) sum += mesh.vertices_mm[v];
  for (auto v : g) sum += mesh.vertices_mm[v];
  return sum / 6.0;
}

}  // namespace

SelfIntersections find_self_intersections(const Mesh& mesh, std::size_t max_locations) {
  SelfIntersections out;
  const std::size_t nf = mesh.triangles.size();
  if (nf < 2) return out;

  // Face boxes; degenerate faces are left out (reported as degenerate_face).
  std::vector<Box3> boxes(nf);
  std::vector<std::uint32_t> faces;
  faces.reserve(nf);
  Box3 all;
  double extent_sum = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    if (detail::is_degenerate_face(mesh, f)) continue;
    for (auto v : mesh.triangles[f]) boxes[f].extend(mesh.vertices_mm[v]);
    all.extend(boxes[f]);
    extent_sum += boxes[f].size().maxCoeff();
    faces.push_back(static_cast<std::uint32_t>(f));
  }
  if (faces.size() < 2) return out;

  // Cell edge: twice the mean face extent, so that a face covers a few cells.
  const Vec3 size = all.size();
  double cell = 2.0 * extent_sum / static_cast<double>(faces.size());
  cell = std::max({cell, size.maxCoeff() / 1e6, 1e-9});
  const Vec3 origin = all.min;
  const auto cells_along = [&](double len) {
    return static_cast<std::int64_t>(std::floor(len / cell)) + 1;
  };
  const std::int64_t nx = cells_along(size.x()), ny = cells_along(size.y());
  auto cell_range = [&](const Box3& b, Eigen::Matrix<std::int64_t, 3, 1>& lo,
                        Eigen::Matrix<std::int64_t, 3, 1>& hi) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = static_cast<std::int64_t>(std::floor((b.min[a] - origin[a]) / cell));
      hi[a] = static_cast<std::int64_t>(std::floor((b.max[a] - origin[a]) / cell));
    }
  };

  std::vector<std::pair<std::int64_t, std::uint32_t>> entries;
  entries.reserve(faces.size() * 4);
  for (auto f : faces) {
    Eigen::Matrix<std::int64_t, 3, 1> lo, hi;
    cell_range(boxes[f], lo, hi);
    for (std::int64_t z = lo.z(); z <= hi.z(); ++z)
      for (std::int64_t y = lo.y(); y <= hi.y(); ++y)
        for (std::int64_t x = lo.x(); x <= hi.x(); ++x)
          entries.emplace_back(x + nx * (y + ny * z), f);
  }
  std::sort(entries.begin(), entries.end());
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t i = 0; i < entries.size();) {
    std::size_t j = i + 1;
    while (j < entries.size() && entries[j].first == entries[i].first) ++j;
    if (j - i > 1) runs.emplace_back(i, j);
    i = j;
  }

  // Each box pair is tested only in the cell that holds the min corner of the boxes'
  // overlap, so no pair is tested twice.
  tbb::enumerable_thread_specific<std::vector<std::array<std::uint32_t, 2>>> found;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, runs.size(), 64),
                    [&](const tbb::blocked_range<std::size_t>& r) {
    auto& local = found.local();
    for (std::size_t ri = r.begin(); ri != r.end(); ++ri) {
      const auto [begin, end] = runs[ri];
      const std::int64_t id = entries[begin].first;
      for (std::size_t i = begin; i < end; ++i) {
        const std::uint32_t f = entries[i].second;
        for (std::size_t j = i + 1; j < end; ++j) {
          const std::uint32_t g = entries[j].second;
          const Box3& bf = boxes[f];
          const Box3& bg = boxes[g];
          if ((bf.min.array() > bg.max.array()).any() || (bg.min.array() > bf.max.array()).any())
            continue;
          Box3 overlap;
          overlap.min = bf.min.cwiseMax(bg.min);
          overlap.max = bf.max.cwiseMin(bg.max);
          Eigen::Matrix<std::int64_t, 3, 1> lo, hi;
          cell_range(overlap, lo, hi);
          if (lo.x() + nx * (lo.y() + ny * lo.z()) != id) continue;
          if (faces_intersect(mesh, mesh.triangles[f], mesh.triangles[g]))
            local.push_back({std::min(f, g), std::max(f, g)});
        }
      }
    }
  });
  std::vector<std::array<std::uint32_t, 2>> pairs;
  for (auto& local : found) pairs.insert(pairs.end(), local.begin(), local.end());
  std::sort(pairs.begin(), pairs.end());
  out.pairs = pairs.size();
  for (std::size_t i = 0; i < pairs.size() && i < max_locations; ++i) {
    out.first_pairs.push_back(pairs[i]);
    out.locations_mm.push_back(
        intersection_point(mesh, mesh.triangles[pairs[i][0]], mesh.triangles[pairs[i][1]]));
  }
  return out;
}

}  // namespace printtwin
