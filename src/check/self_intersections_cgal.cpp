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
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>

#include "check/check_internal.hpp"
#include "core/plain_path.hpp"
#include "printtwin/check.hpp"

namespace printtwin {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using T3 = K::Triangle_3;
using S3 = K::Segment_3;

P3 to_p3(const Vec3& v) { return P3(v.x(), v.y(), v.z()); }

/// Sign of the orientation of d against the plane of (a, b, c) when floating point decides
/// it for certain, else 0. Shewchuk's orient3d with its first error bound (Adaptive
/// Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates, 1997): the
/// rounded determinant has the exact one's sign whenever its magnitude exceeds the bound.
/// Only the sign's consistency matters here (same side or not), not its convention.
inline int certain_orientation(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  constexpr double kEps = 0x1p-53;
  constexpr double kBound = (7.0 + 56.0 * kEps) * kEps;
  const double adx = a.x() - d.x(), bdx = b.x() - d.x(), cdx = c.x() - d.x();
  const double ady = a.y() - d.y(), bdy = b.y() - d.y(), cdy = c.y() - d.y();
  const double adz = a.z() - d.z(), bdz = b.z() - d.z(), cdz = c.z() - d.z();
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const double permanent = (std::abs(bdxcdy) + std::abs(cdxbdy)) * std::abs(adz) +
                           (std::abs(cdxady) + std::abs(adxcdy)) * std::abs(bdz) +
                           (std::abs(adxbdy) + std::abs(bdxady)) * std::abs(cdz);
  const double bound = kBound * permanent;
  return det > bound ? 1 : (-det > bound ? -1 : 0);
}

/// Sign of the orientation of the triangle (a, b, c) projected along axis `ax` (the other two
/// coordinates in cyclic order) when floating point decides it for certain, else 0.
/// Shewchuk's orient2d with its first error bound; dropping a coordinate is exact.
inline int certain_orientation_2d(const Vec3& a, const Vec3& b, const Vec3& c, int ax) {
  constexpr double kEps = 0x1p-53;
  constexpr double kBound = (3.0 + 16.0 * kEps) * kEps;
  const int x = (ax + 1) % 3, y = (ax + 2) % 3;
  const double left = (a[x] - c[x]) * (b[y] - c[y]);
  const double right = (a[y] - c[y]) * (b[x] - c[x]);
  const double det = left - right;
  const double bound = kBound * (std::abs(left) + std::abs(right));
  return det > bound ? 1 : (-det > bound ? -1 : 0);
}

/// True when every point of `pts` lies strictly on one side of the plane of (a, b, c),
/// certainly (so nothing of theirs can meet the plane's triangle).
inline bool certainly_one_side(const Vec3& a, const Vec3& b, const Vec3& c,
                               std::initializer_list<const Vec3*> pts) {
  int side = 0;
  for (const Vec3* q : pts) {
    const int s = certain_orientation(a, b, c, *q);
    if (s == 0 || (side != 0 && s != side)) return false;
    side = s;
  }
  return true;
}

/// True when segment pq certainly misses triangle abc: both ends strictly on one side of
/// its plane, or on strictly opposite sides with the line through them certainly passing
/// outside the triangle (two of the line's orientations against the triangle's edges of
/// certainly opposite signs: the line meets the plane at one point, the segment's).
inline bool segment_certainly_misses(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b,
                                     const Vec3& c) {
  const int sp = certain_orientation(a, b, c, p);
  if (sp == 0) return false;
  const int sq = certain_orientation(a, b, c, q);
  if (sq == sp) return true;
  if (sq == 0) return false;
  const int o1 = certain_orientation(p, q, a, b), o2 = certain_orientation(p, q, b, c),
            o3 = certain_orientation(p, q, c, a);
  return (o1 > 0 || o2 > 0 || o3 > 0) && (o1 < 0 || o2 < 0 || o3 < 0);
}

/// The axis along which the plane of (a, b, c) is most nearly flat when projected (the
/// largest component of its normal): coplanar faces keep their shapes best there.
inline int projection_axis(const Vec3& a, const Vec3& b, const Vec3& c) {
  int ax = 0;
  (b - a).cross(c - a).cwiseAbs().maxCoeff(&ax);
  return ax;
}

/// True when every point of `pts` lies certainly strictly outside edge uv of a triangle of
/// orientation `o` (projected along `ax`): the edge's line separates them from it.
inline bool certainly_beyond_2d(const Vec3& u, const Vec3& v, int o,
                                std::initializer_list<const Vec3*> pts, int ax) {
  for (const Vec3* q : pts)
    if (certain_orientation_2d(u, v, *q, ax) != -o) return false;
  return true;
}

/// True when the projections along `ax` of triangle abc and the points `pts` (a segment or
/// a triangle) are certainly apart: a line through an edge of abc, or (for a segment) the
/// segment's own line, separates them. Apart in projection means apart in space. This
/// settles the coplanar pairs (flat caps, fans of slivers) that the 3D filters cannot.
inline bool certainly_apart_2d(const Vec3& a, const Vec3& b, const Vec3& c,
                               std::initializer_list<const Vec3*> pts, int ax) {
  const int o = certain_orientation_2d(a, b, c, ax);
  if (o == 0) return false;
  if (certainly_beyond_2d(a, b, o, pts, ax) || certainly_beyond_2d(b, c, o, pts, ax) ||
      certainly_beyond_2d(c, a, o, pts, ax))
    return true;
  if (pts.size() != 2) return false;
  const Vec3& p = **pts.begin();
  const Vec3& q = **(pts.begin() + 1);
  const int sa = certain_orientation_2d(p, q, a, ax);
  return sa != 0 && sa == certain_orientation_2d(p, q, b, ax) &&
         sa == certain_orientation_2d(p, q, c, ax);
}

/// Do faces f and g intersect other than along what they share (PMP's rules)? A
/// floating-point filter first: a pair it settles (nearly every pair of a mesh's
/// neighbouring faces, which is most of what the broad phase hands over) gets the exact
/// predicates' answer without them.
bool faces_intersect(const Mesh& mesh, const std::array<std::uint32_t, 3>& f,
                     const std::array<std::uint32_t, 3>& g, bool filter = true) {
  int shared = 0;
  int fi[3] = {-1, -1, -1};  // for each corner of f, the corner of g with the same vertex
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (f[i] == g[j]) {
        fi[i] = j;
        ++shared;
      }
  const auto& v = mesh.vertices_mm;
  const auto p = [&](std::uint32_t k) { return to_p3(v[k]); };
  if (shared >= 3) return false;  // duplicate face: reported as such
  if (shared == 2) {
    // Shared edge (a, b); opposite corners r (of f) and s (of g). They overlap only when
    // both faces lie in one plane on the same side of the edge (a fold).
    int r = 0;
    while (fi[r] >= 0) ++r;
    const std::uint32_t a = f[(r + 1) % 3];
    const std::uint32_t b = f[(r + 2) % 3];
    std::uint32_t s = 0;
    for (auto k : g)
      if (k != a && k != b) s = k;
    if (filter && certain_orientation(v[a], v[b], v[f[r]], v[s]) != 0)
      return false;  // not coplanar
    // Coplanar or nearly: projected along an axis where (a, b, r) certainly keeps its
    // orientation (so the projection of their plane is one-to-one), r and s certainly on
    // opposite sides of ab means no fold: false whether s is in that plane or not.
    if (filter) {
      const Vec3 n = (v[b] - v[a]).cross(v[f[r]] - v[a]);
      int ax = 0;
      n.cwiseAbs().maxCoeff(&ax);
      const int o_r = certain_orientation_2d(v[a], v[b], v[f[r]], ax);
      const int o_s = certain_orientation_2d(v[a], v[b], v[s], ax);
      if (o_r != 0 && o_s != 0 && o_r != o_s) return false;
    }
    const P3 pa = p(a), pb = p(b), pr = p(f[r]), ps = p(s);
    return CGAL::coplanar(pa, pb, pr, ps) &&
           CGAL::coplanar_orientation(pa, pb, pr, ps) == CGAL::POSITIVE;
  }
  const Vec3 &f0 = v[f[0]], &f1 = v[f[1]], &f2 = v[f[2]];
  const Vec3 &g0 = v[g[0]], &g1 = v[g[1]], &g2 = v[g[2]];
  if (shared == 1) {
    // Shared vertex: they intersect elsewhere iff an edge opposite the shared vertex meets
    // the other face.
    int i = 0;
    while (fi[i] < 0) ++i;
    const int j = fi[i];
    const Vec3& fa = v[f[(i + 1) % 3]];
    const Vec3& fb = v[f[(i + 2) % 3]];
    const Vec3& ga = v[g[(j + 1) % 3]];
    const Vec3& gb = v[g[(j + 2) % 3]];
    const int ax = filter ? projection_axis(f0, f1, f2) : 0;
    const bool f_edge_clear = filter && (segment_certainly_misses(fa, fb, g0, g1, g2) ||
                                         certainly_apart_2d(g0, g1, g2, {&fa, &fb}, ax));
    const bool g_edge_clear = filter && (segment_certainly_misses(ga, gb, f0, f1, f2) ||
                                         certainly_apart_2d(f0, f1, f2, {&ga, &gb}, ax));
    if (f_edge_clear && g_edge_clear) return false;
    const T3 tf(p(f[0]), p(f[1]), p(f[2]));
    const T3 tg(p(g[0]), p(g[1]), p(g[2]));
    return (!f_edge_clear && CGAL::do_intersect(S3(to_p3(fa), to_p3(fb)), tg)) ||
           (!g_edge_clear && CGAL::do_intersect(S3(to_p3(ga), to_p3(gb)), tf));
  }
  if (filter && (certainly_one_side(f0, f1, f2, {&g0, &g1, &g2}) ||
                 certainly_one_side(g0, g1, g2, {&f0, &f1, &f2})))
    return false;
  if (filter) {
    const int ax = projection_axis(f0, f1, f2);
    if (certainly_apart_2d(f0, f1, f2, {&g0, &g1, &g2}, ax) ||
        certainly_apart_2d(g0, g1, g2, {&f0, &f1, &f2}, ax))
      return false;
  }
  return CGAL::do_intersect(T3(p(f[0]), p(f[1]), p(f[2])), T3(p(g[0]), p(g[1]), p(g[2])));
}

/// Whether q, a point of the plane of (a, b, c), lies in that triangle (barycentric
/// coordinates of its projection on the plane, with a little slack).
bool in_triangle(const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = (b - a).cross(c - a);
  const double n2 = n.squaredNorm();
  if (!(n2 > 0)) return false;
  const double u = (c - b).cross(q - b).dot(n) / n2, v = (a - c).cross(q - c).dot(n) / n2;
  constexpr double kSlack = 1e-9;
  return u >= -kSlack && v >= -kSlack && 1 - u - v >= -kSlack;
}

/// A point of the intersection of two faces known to intersect (for the report): the mean
/// of the points where an edge of one crosses the other, else (coplanar overlap) of the
/// corners of each inside the other, else the midpoint of their centroids. Plain double
/// arithmetic: CGAL's intersection constructions in an inexact kernel can divide by zero
/// on nearly coplanar faces, and the exact fallback then traps on the infinity.
Vec3 intersection_point(const Mesh& mesh, const std::array<std::uint32_t, 3>& f,
                        const std::array<std::uint32_t, 3>& g) {
  const auto& v = mesh.vertices_mm;
  const std::array<Vec3, 3> tf{v[f[0]], v[f[1]], v[f[2]]}, tg{v[g[0]], v[g[1]], v[g[2]]};
  Vec3 sum = Vec3::Zero();
  int count = 0;
  for (int side = 0; side < 2; ++side) {
    const auto& e = side == 0 ? tf : tg;  // edges of e against the face t
    const auto& t = side == 0 ? tg : tf;
    const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]);
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = e[k];
      const Vec3& q = e[(k + 1) % 3];
      const double dp = n.dot(p - t[0]), dq = n.dot(q - t[0]);
      if (!((dp < 0 && dq > 0) || (dp > 0 && dq < 0))) continue;
      const Vec3 x = p + (dp / (dp - dq)) * (q - p);
      if (in_triangle(x, t[0], t[1], t[2])) {
        sum += x;
        ++count;
      }
    }
  }
  if (count == 0)
    for (int side = 0; side < 2; ++side) {
      const auto& e = side == 0 ? tf : tg;
      const auto& t = side == 0 ? tg : tf;
      for (const Vec3& p : e)
        if (in_triangle(p, t[0], t[1], t[2])) {
          sum += p;
          ++count;
        }
    }
  if (count > 0 && sum.allFinite()) return sum / count;
  // Touching only through the shared-vertex/edge rules: the midpoint of the centroids.
  sum = Vec3::Zero();
  for (const Vec3& p : tf) sum += p;
  for (const Vec3& p : tg) sum += p;
  return sum / 6.0;
}

}  // namespace

namespace {
using Cell3 = std::array<std::int32_t, 3>;

/// A uniform grid over the face boxes: the faces of every cell that holds two or more.
struct FaceGrid {
  Vec3 origin = Vec3::Zero();
  double cell = 1;
  std::uint64_t nx = 0, ny = 0, nz = 0;
  std::vector<Cell3> lo_cell;             ///< cell of each face box's min corner
  std::vector<std::uint32_t> cell_faces;  ///< faces listed cell by cell, ascending in a cell
  std::vector<std::pair<std::size_t, std::size_t>> runs;  ///< [begin, end) of cells with 2+ faces
  std::vector<std::uint64_t> run_cell;                    ///< the cell of each run
};

/// Lists the faces by cell. Cell edge: twice the mean face extent, so that a face covers a
/// few cells.
FaceGrid build_face_grid(const std::vector<Box3>& boxes, const std::vector<std::uint32_t>& faces,
                         const Box3& all, double extent_sum) {
  // Cell edge: twice the mean face extent, so that a face covers a few cells.
  const Vec3 size = all.size();
  FaceGrid g;
  double& cell = g.cell;
  cell = 2.0 * extent_sum / static_cast<double>(faces.size());
  cell = std::max({cell, size.maxCoeff() / 1e6, 1e-9});
  g.origin = all.min;
  const Vec3& origin = g.origin;
  const auto cell_of = [&](const Vec3& q) {
    Cell3 c{};
    for (int a = 0; a < 3; ++a)
      c[a] = static_cast<std::int32_t>(std::floor((q[a] - origin[a]) / cell));
    return c;
  };
  const Cell3 top = cell_of(all.max);
  g.nx = static_cast<std::uint64_t>(top[0]) + 1;
  g.ny = static_cast<std::uint64_t>(top[1]) + 1;
  g.nz = static_cast<std::uint64_t>(top[2]) + 1;
  const std::uint64_t nx = g.nx, ny = g.ny, nz = g.nz;
  const auto cell_id = [&](std::int32_t x, std::int32_t y, std::int32_t z) {
    return static_cast<std::uint64_t>(x) +
           nx * (static_cast<std::uint64_t>(y) + ny * static_cast<std::uint64_t>(z));
  };
  // The cells of each face's box. The cell of a box's min corner is monotone in the
  // corner, so the cell of the min corner of two boxes' overlap is the per-axis max of
  // their min cells: each box pair is tested only there, never twice.
  const std::size_t nf = boxes.size();
  g.lo_cell.resize(nf);
  std::vector<Cell3> hi_cell(nf);
  std::vector<Cell3>& lo_cell = g.lo_cell;
  std::size_t n_entries = 0;
  for (auto f : faces) {
    lo_cell[f] = cell_of(boxes[f].min);
    hi_cell[f] = cell_of(boxes[f].max);
    n_entries += static_cast<std::size_t>(hi_cell[f][0] - lo_cell[f][0] + 1) *
                 static_cast<std::size_t>(hi_cell[f][1] - lo_cell[f][1] + 1) *
                 static_cast<std::size_t>(hi_cell[f][2] - lo_cell[f][2] + 1);
  }
  const auto for_each_cell = [&](std::uint32_t f, auto&& fn) {
    for (std::int32_t z = lo_cell[f][2]; z <= hi_cell[f][2]; ++z)
      for (std::int32_t y = lo_cell[f][1]; y <= hi_cell[f][1]; ++y)
        for (std::int32_t x = lo_cell[f][0]; x <= hi_cell[f][0]; ++x) fn(cell_id(x, y, z));
  };
  // Faces by cell, ascending within a cell (faces are visited in order): a counting sort
  // when the cells are not many more than the entries, else a comparison sort of the
  // (cell, face) entries; both give the same runs.
  g.cell_faces.resize(n_entries);
  std::vector<std::uint32_t>& cell_faces = g.cell_faces;
  std::vector<std::pair<std::size_t, std::size_t>>& runs = g.runs;
  std::vector<std::uint64_t>& run_cell = g.run_cell;
  const double n_cells =
      static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz);
  if (n_cells <= 4.0 * static_cast<double>(n_entries) + 1e6) {
    std::vector<std::uint32_t> start(static_cast<std::size_t>(n_cells) + 1, 0);
    for (auto f : faces) for_each_cell(f, [&](std::uint64_t id) { ++start[id + 1]; });
    for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
    for (std::size_t k = 0; k + 1 < start.size(); ++k)
      if (start[k + 1] - start[k] > 1) {
        runs.emplace_back(start[k], start[k + 1]);
        run_cell.push_back(k);
      }
    for (auto f : faces) for_each_cell(f, [&](std::uint64_t id) { cell_faces[start[id]++] = f; });
  } else {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> entries;
    entries.reserve(n_entries);
    for (auto f : faces) for_each_cell(f, [&](std::uint64_t id) { entries.emplace_back(id, f); });
    std::sort(entries.begin(), entries.end());
    for (std::size_t i = 0; i < entries.size();) {
      std::size_t j = i + 1;
      while (j < entries.size() && entries[j].first == entries[i].first) ++j;
      if (j - i > 1) {
        runs.emplace_back(i, j);
        run_cell.push_back(entries[i].first);
      }
      i = j;
    }
    for (std::size_t i = 0; i < entries.size(); ++i) cell_faces[i] = entries[i].second;
  }

  return g;
}

/// Vertices whose fan of faces certainly meets itself only along its shared edges and at
/// the vertex: projected along the axis nearest the vertex normal (exact), every face of the
/// fan keeps one orientation for certain and the fan winds around the vertex exactly once,
/// so the projected faces tile the plane around it without overlap, and faces whose
/// projections meet only in a shared edge or vertex meet in 3D there only. Needs every
/// vertex's fan to be one closed cycle (a closed, consistently oriented mesh with manifold
/// edges and vertices and no duplicate faces); vertices of degenerate faces are never
/// certified. Pairs sharing a certified vertex need no test.
std::vector<char> certified_fans(const Mesh& mesh) {
  const auto& v = mesh.vertices_mm;
  const std::size_t nf = mesh.triangles.size();
  std::vector<Vec3> normal(v.size(), Vec3::Zero());
  std::vector<char> ok(v.size(), 1);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = mesh.triangles[f];
    if (detail::is_degenerate_face(mesh, f)) {
      for (auto k : t) ok[k] = 0;
      continue;
    }
    const Vec3 n = (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]);
    for (auto k : t) normal[k] += n;
  }
  std::vector<std::int16_t> axis(v.size()), sign(v.size());
  for (std::size_t k = 0; k < v.size(); ++k) {
    int ax = 0;
    normal[k].cwiseAbs().maxCoeff(&ax);
    axis[k] = static_cast<std::int16_t>(ax);
    sign[k] = normal[k][ax] > 0 ? 1 : -1;
  }
  // Winding of the link (the edges opposite the vertex, a -> b for each face (v, a, b)):
  // with every wedge positive, each upward crossing of the horizontal through v lies to its
  // right and counts +1, and no other crossing does (half-open rule: exact comparisons);
  // with every wedge negative, the downward crossings count.
  std::vector<std::uint32_t> crossings(v.size(), 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = mesh.triangles[f];
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t c = t[i];
      if (ok[c] == 0) continue;
      const Vec3 &pc = v[c], &pa = v[t[(i + 1) % 3]], &pb = v[t[(i + 2) % 3]];
      const int ax = axis[c];
      if (certain_orientation_2d(pc, pa, pb, ax) != sign[c]) {
        ok[c] = 0;
        continue;
      }
      const int y = (ax + 2) % 3;
      const bool up = pa[y] <= pc[y] && pc[y] < pb[y];
      const bool down = pb[y] <= pc[y] && pc[y] < pa[y];
      if (sign[c] > 0 ? up : down) ++crossings[c];
    }
  }
  for (std::size_t k = 0; k < v.size(); ++k)
    if (crossings[k] != 1) ok[k] = 0;
  return ok;
}

/// A face of one cell, with what the pair tests read, side by side. `here` has bit a set
/// when the face's box starts in this cell along axis a: the min corner of two boxes'
/// overlap lies in this cell exactly when the two faces' bits cover all three axes.
struct CellEntry {
  Box3 box;
  std::uint32_t face;
  std::uint32_t here;
  std::array<std::uint32_t, 3> corner;  ///< the face's vertices, certified ones only
};

/// CellEntry::corner of a vertex whose fan is not certified.
constexpr std::uint32_t kNotCertified = UINT32_MAX;

/// Tests the pairs of one cell's faces whose boxes overlap and whose overlap's min corner is
/// in this cell (`here`), sweeping the faces in order of their boxes' min x; appends the
/// intersecting ones to `out`.
void test_cell(const Mesh& mesh, std::vector<CellEntry>& entries,
               std::vector<std::array<std::uint32_t, 2>>& out) {
  // Sweep axis: the one along which the boxes overlap least (their mean extent against the
  // spread of their min corners).
  int ax = 0;
  {
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo, ext = Vec3::Zero();
    for (const CellEntry& e : entries) {
      lo = lo.cwiseMin(e.box.min);
      hi = hi.cwiseMax(e.box.min);
      ext += e.box.max - e.box.min;
    }
    double best = -1;
    for (int a = 0; a < 3; ++a) {
      const double score = (hi[a] - lo[a]) / (ext[a] + 1e-300);
      if (score > best) {
        best = score;
        ax = a;
      }
    }
  }
  std::sort(entries.begin(), entries.end(),
            [ax](const CellEntry& a, const CellEntry& b) { return a.box.min[ax] < b.box.min[ax]; });
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const CellEntry& ef = entries[i];
    const Box3& bf = ef.box;
    for (std::size_t j = i + 1; j < entries.size() && entries[j].box.min[ax] <= bf.max[ax]; ++j) {
      const CellEntry& eg = entries[j];
      if ((ef.here | eg.here) != 7U) continue;  // the pair's overlap starts in another cell
      const Box3& bg = eg.box;
      if (bf.min.x() > bg.max.x() || bg.min.x() > bf.max.x() || bf.min.y() > bg.max.y() ||
          bg.min.y() > bf.max.y() || bf.min.z() > bg.max.z() || bg.min.z() > bf.max.z())
        continue;
      // A certified vertex of both: no test (see certified_fans).
      const auto& cf = ef.corner;
      const auto& cg = eg.corner;
      bool shared = false;
      for (int a = 0; a < 3; ++a)
        shared |=
            cf[a] != kNotCertified && ((cf[a] == cg[0]) | (cf[a] == cg[1]) | (cf[a] == cg[2]));
      if (shared) continue;
      const auto& tf = mesh.triangles[ef.face];
      const auto& tg = mesh.triangles[eg.face];
      if (faces_intersect(mesh, tf, tg))
        out.push_back({std::min(ef.face, eg.face), std::max(ef.face, eg.face)});
    }
  }
}

/// Tests every pair of faces that share a cell, in the cell holding the min corner of the two
/// boxes' overlap only (the per-axis max of their min cells), so never twice.
std::vector<std::array<std::uint32_t, 2>> intersecting_pairs(const Mesh& mesh,
                                                             const std::vector<Box3>& boxes,
                                                             const FaceGrid& grid,
                                                             const std::vector<char>& certified) {
  const std::uint64_t nx = grid.nx, ny = grid.ny;
  const auto& runs = grid.runs;
  const auto& run_cell = grid.run_cell;
  const auto& cell_faces = grid.cell_faces;
  const auto& lo_cell = grid.lo_cell;
  tbb::enumerable_thread_specific<std::vector<std::array<std::uint32_t, 2>>> found;
  tbb::enumerable_thread_specific<std::vector<CellEntry>> scratch;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, runs.size(), 64),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      auto& local = found.local();
                      auto& entries = scratch.local();
                      for (std::size_t ri = r.begin(); ri != r.end(); ++ri) {
                        const std::uint64_t id = run_cell[ri];
                        const Cell3 here{static_cast<std::int32_t>(id % nx),
                                         static_cast<std::int32_t>((id / nx) % ny),
                                         static_cast<std::int32_t>(id / (nx * ny))};
                        entries.clear();
                        for (std::size_t i = runs[ri].first; i < runs[ri].second; ++i) {
                          const std::uint32_t f = cell_faces[i];
                          const std::uint32_t bits = (lo_cell[f][0] == here[0] ? 1U : 0U) |
                                                     (lo_cell[f][1] == here[1] ? 2U : 0U) |
                                                     (lo_cell[f][2] == here[2] ? 4U : 0U);
                          std::array<std::uint32_t, 3> corner{};
                          for (int k = 0; k < 3; ++k) {
                            const std::uint32_t v = mesh.triangles[f][k];
                            corner[k] = !certified.empty() && certified[v] != 0 ? v : kNotCertified;
                          }
                          entries.push_back({boxes[f], f, bits, corner});
                        }
                        test_cell(mesh, entries, local);
                      }
                    });
  std::vector<std::array<std::uint32_t, 2>> pairs;
  for (auto& local : found) pairs.insert(pairs.end(), local.begin(), local.end());
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}
}  // namespace

SelfIntersections find_self_intersections(const Mesh& mesh, std::size_t max_locations,
                                          const MeshHealth* health) {
  SelfIntersections out;
  const std::size_t nf = mesh.triangles.size();
  if (nf < 2) return out;
  // Fans are one closed cycle each only on a closed, consistently oriented, manifold mesh.
  // PRINTTWIN_PLAIN=check_fans tests every pair instead (bench/RESULTS.md).
  const bool manifold = health != nullptr && health->closed && health->inconsistent_edges == 0 &&
                        health->non_manifold_vertices == 0 && health->duplicate_faces == 0 &&
                        health->touching_edges == 0;
  // A surface star-shaped about a point meets itself nowhere: no pair to test
  // (PRINTTWIN_PLAIN=check_star tests them).
  if (manifold && !detail::plain_path("check_star") && detail::star_shaped_surface(mesh))
    return out;

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

  const FaceGrid grid = build_face_grid(boxes, faces, all, extent_sum);
  const bool cycles = manifold && !detail::plain_path("check_fans");
  const std::vector<char> certified = cycles ? certified_fans(mesh) : std::vector<char>();
  const std::vector<std::array<std::uint32_t, 2>> pairs =
      intersecting_pairs(mesh, boxes, grid, certified);
  out.pairs = pairs.size();
  for (const auto& pr : pairs) {
    out.faces.push_back(pr[0]);
    out.faces.push_back(pr[1]);
  }
  std::sort(out.faces.begin(), out.faces.end());
  out.faces.erase(std::unique(out.faces.begin(), out.faces.end()), out.faces.end());
  for (std::size_t i = 0; i < pairs.size() && i < max_locations; ++i) {
    out.first_pairs.push_back(pairs[i]);
    out.locations_mm.push_back(
        intersection_point(mesh, mesh.triangles[pairs[i][0]], mesh.triangles[pairs[i][1]]));
  }
  return out;
}

namespace detail {

bool star_shaped_surface(const Mesh& mesh) {
  const auto& v = mesh.vertices_mm;
  if (mesh.triangles.empty() || v.empty()) return false;
  Vec3 p = Vec3::Zero();
  for (const Vec3& q : v) p += q;
  p /= static_cast<double>(v.size());
  int sign = 0;
  for (const auto& t : mesh.triangles) {
    const int s = certain_orientation(v[t[0]], v[t[1]], v[t[2]], p);
    if (s == 0 || (sign != 0 && s != sign)) return false;
    sign = s;
  }
  // Solid angles (Van Oosterom and Strackee): every face's has the same sign, so their sum
  // is 4 pi times the winding number, to rounding far below a whole turn.
  double sum = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 a = v[t[0]] - p, b = v[t[1]] - p, c = v[t[2]] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    sum += 2.0 * std::atan2(num, den);
  }
  constexpr double kFourPi = 4.0 * 3.14159265358979323846;
  return std::abs(std::abs(sum) / kFourPi - 1.0) < 0.25;
}

std::vector<std::array<std::uint32_t, 2>> self_intersecting_pairs_exhaustive(const Mesh& mesh) {
  std::vector<std::array<std::uint32_t, 2>> pairs;
  const auto nf = static_cast<std::uint32_t>(mesh.triangles.size());
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (is_degenerate_face(mesh, f)) continue;
    for (std::uint32_t g = f + 1; g < nf; ++g)
      if (!is_degenerate_face(mesh, g) &&
          faces_intersect(mesh, mesh.triangles[f], mesh.triangles[g], false))
        pairs.push_back({f, g});
  }
  return pairs;
}

}  // namespace detail

}  // namespace printtwin
