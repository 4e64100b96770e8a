// Sub-voxel smoothing of the as-printed mesh: its vertices move from the voxel lattice onto
// the true surface of the beads that laid the voxels around them (the stadium beads of the
// deposit's model, the same ones the deviation stage places its surface points on).
// - A vertex among the voxels of one G-code line: onto the nearest point of that line's
//   beads, at most kMaxShiftVoxels per axis.
// - A vertex where lines of two layers meet (a layer groove): straight in (or out) along the
//   level part of its normal to the crease between their beads, up to half a bead height
//   plus a voxel: the groove between stacked round beads is deeper than the voxels show.
// - Elsewhere (lines of one layer meeting, the inside of a corner), and where the nominal
//   bead lies more than a voxel from the vertex (squeezed, sagged), the vertex stays.
//
// Safety, so the mesh stays closed, 2-manifold, oriented and free of self-intersections:
// - only positions change, never the connectivity;
// - a vertex within kMaxShiftVoxels of its lattice point on each axis (< 1/2) is "near": two
//   voxel faces that share no lattice point are at least one voxel apart on some axis, so
//   triangles of near vertices made from them stay at least (1 - 2 kMaxShiftVoxels) voxel
//   apart; a crease vertex moved farther is "far";
// - triangles that share a vertex could fold over each other: every triangle whose normal
//   turns by more than kMaxTurn from its voxel face's normal (or whose area collapses) puts
//   its vertices back on the lattice (its far ones first, when it has any);
// - triangles of one lattice plane with near vertices then cannot cross: each keeps its
//   orientation seen along the plane's normal and the plane's boundary stays simple, so the
//   plane's moved triangles form a graph over it. Triangles of two different planes can,
//   where the planes meet (a step, a corner), and a triangle with a far vertex can meet any:
//   every such pair whose boxes overlap, one of them moved, is tested (a uniform grid of
//   cells of two voxels, and a conservative floating-point test: touching counts), and both
//   put their vertices back (far ones first);
// - the last two steps repeat on the triangles whose vertices went back, until none does.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "deposit/mesh_export_internal.hpp"
#include "deviation/surface_internal.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin::detail {

namespace {

/// The lines (up to 8) of the occupied part voxels touching lattice point p, and whether
/// they lie in more than one layer; returns how many.
int lines_at(const VoxelGrid& grid, const Vec3& p, std::array<std::uint32_t, 8>& lines,
             bool& layers_meet) {
  const Vec3 q = (p - grid.origin_mm()) / grid.voxel_mm();
  std::array<int, 3> lo{}, n{};
  for (int a = 0; a < 3; ++a) {
    const double r = std::round(q[a]);
    const bool on_plane = std::abs(q[a] - r) < 1e-6;
    lo[static_cast<std::size_t>(a)] =
        on_plane ? static_cast<int>(r) - 1 : static_cast<int>(std::floor(q[a]));
    n[static_cast<std::size_t>(a)] = on_plane ? 2 : 1;
  }
  int nl = 0, layer = -1;
  layers_meet = false;
  for (int dz = 0; dz < n[2]; ++dz)
    for (int dy = 0; dy < n[1]; ++dy)
      for (int dx = 0; dx < n[0]; ++dx) {
        const auto tag = grid.tag({lo[0] + dx, lo[1] + dy, lo[2] + dz});
        if (!tag || is_auxiliary_feature(tag->feature)) continue;
        layers_meet |= layer >= 0 && tag->layer != layer;
        layer = tag->layer;
        if (std::find(lines.begin(), lines.begin() + nl, tag->line) == lines.begin() + nl)
          lines[static_cast<std::size_t>(nl++)] = tag->line;
      }
  return nl;
}

/// Where the horizontal line through p along `dir` (unit, level) meets the surface of the
/// union of the beads of `lines` (and their neighbours along the path), within half a bead
/// height plus a voxel of p, when that surface lies within a voxel of p.
bool crease_point(const BeadIndex& index, std::span<const SurfaceBead> beads,
                  std::span<const std::uint32_t> lines, double v, const Vec3& p, const Vec3& dir,
                  Vec3& target) {
  double height = 0;
  // Signed distance to the union of the beads (a lower bound of the true one: the union's
  // surface is no nearer than the nearest bead's, inside or out).
  const auto union_distance = [&](const Vec3& q) {
    double best = std::numeric_limits<double>::infinity();
    for (const std::uint32_t line : lines) {
      const BeadDistance d = index.nearest(line, q);
      if (d.bead != kNoBead && d.signed_mm < best) {
        best = d.signed_mm;
        height = std::max(height, static_cast<double>(beads[d.bead].height_mm));
      }
    }
    return best;
  };
  double f = union_distance(p);
  if (!(std::abs(f) <= v)) return false;
  const double limit = 0.5 * height + v;
  // March against `dir` from outside (f > 0) or along it from inside, by the distance (never
  // past the surface) but at least a quarter voxel (a line grazing a bead's round side closes
  // in slowly), until the sign changes; then bisect.
  const double sign = f > 0 ? -1.0 : 1.0;
  double s_from = 0, s_to = 0;
  for (;;) {
    s_from = s_to;
    s_to += sign * std::max(std::abs(f), 0.25 * v);
    if (std::abs(s_to) > limit + 0.25 * v) return false;
    const double g = union_distance(p + s_to * dir);
    if ((g > 0) != (f > 0) || g == 0) break;
    f = g;
  }
  for (int it = 0; it < 20; ++it) {
    const double mid = 0.5 * (s_from + s_to);
    if ((union_distance(p + mid * dir) > 0) == (sign < 0))
      s_from = mid;
    else
      s_to = mid;
  }
  const double s = 0.5 * (s_from + s_to);
  if (std::abs(s) > limit) return false;
  target = p + s * dir;
  return true;
}

/// The bead surface point for a vertex at p (its outward normal `normal`), or nothing.
/// Occupied voxels of one line around p: the nearest point of that line's beads, when it
/// faces the same way as the mesh and lies within a voxel (moved at most kMaxShiftVoxels per
/// axis). Voxels of lines of two layers (a layer groove): the crease between their beads,
/// straight in along the normal's level part, which the voxels are too coarse to show.
/// Elsewhere (lines of one layer meeting: the inside of a corner) the vertex stays.
bool bead_point(const VoxelGrid& grid, const BeadIndex& index, std::span<const SurfaceBead> beads,
                const Vec3& p, const Vec3& normal, Vec3& target) {
  std::array<std::uint32_t, 8> lines{};
  bool layers_meet = false;
  const int nl = lines_at(grid, p, lines, layers_meet);
  const double v = grid.voxel_mm();
  if (nl > 1) {
    Vec3 level(normal.x(), normal.y(), 0.0);
    const double len = level.norm();
    if (!layers_meet || !(len > 0.5 * normal.norm())) return false;
    return crease_point(index, beads, std::span<const std::uint32_t>(lines.data(), nl), v, p,
                        level / len, target);
  }
  if (nl != 1) return false;
  const BeadDistance best = index.nearest(lines[0], p);
  if (best.bead == kNoBead) return false;
  Vec3 out = p - best.core_point;
  const double len = out.norm();
  if (!(len > 1e-12)) return false;
  out /= len;
  if (out.dot(normal) <= 0) return false;  // the far side of the bead: another surface
  Vec3 d = best.core_point + (0.5 * beads[best.bead].height_mm) * out - p;
  if (!(d.norm() <= v)) return false;
  const double max_shift = kMaxShiftVoxels * v;
  for (int a = 0; a < 3; ++a) d[a] = std::clamp(d[a], -max_shift, max_shift);
  target = p + d;
  return true;
}

// ---------------------------------------------------------------- local intersection check

/// Sign-robust enough for a conservative test: a pair is reported when the floating-point
/// test cannot tell it apart from touching (reverting its vertices is always safe).
struct TriTri {
  double eps;  // length tolerance (mm)

  /// Does segment q0-q1 meet triangle (a, b, c) (closed, within eps)?
  [[nodiscard]] bool segment_hits(const Vec3& q0, const Vec3& q1, const Vec3& a, const Vec3& b,
                                  const Vec3& c) const {
    const Vec3 n = (b - a).cross(c - a);
    const double nl = n.norm();
    if (!(nl > 0)) return false;  // degenerate: settled by its neighbours
    const double d0 = n.dot(q0 - a) / nl, d1 = n.dot(q1 - a) / nl;
    if ((d0 > eps && d1 > eps) || (d0 < -eps && d1 < -eps)) return false;
    const Vec3 u = n / nl;
    auto inside = [&](const Vec3& x) {  // x in the plane: inside the closed triangle, within eps
      return u.dot((b - a).cross(x - a)) >= -eps * (b - a).norm() &&
             u.dot((c - b).cross(x - b)) >= -eps * (c - b).norm() &&
             u.dot((a - c).cross(x - c)) >= -eps * (a - c).norm();
    };
    if (std::abs(d0) <= eps && std::abs(d1) <= eps) {  // in the plane: a 2-D test
      const Vec3 p0 = q0 - d0 * u, p1 = q1 - d1 * u;
      if (inside(p0) || inside(p1)) return true;
      const std::array<const Vec3*, 3> t{&a, &b, &c};
      for (int k = 0; k < 3; ++k)
        if (segments_cross(p0, p1, *t[static_cast<std::size_t>(k)],
                           *t[static_cast<std::size_t>((k + 1) % 3)], u))
          return true;
      return false;
    }
    const double t = std::clamp(d0 / (d0 - d1), 0.0, 1.0);
    return inside(q0 + t * (q1 - q0));
  }
  /// Coplanar segments p0-p1 and r0-r1 (plane normal u) cross or touch within eps.
  [[nodiscard]] bool segments_cross(const Vec3& p0, const Vec3& p1, const Vec3& r0, const Vec3& r1,
                                    const Vec3& u) const {
    const Vec3 dp = p1 - p0, dr = r1 - r0;
    const double lp = std::max(dp.norm(), 1e-300), lr = std::max(dr.norm(), 1e-300);
    const double s0 = u.dot(dp.cross(r0 - p0)) / lp, s1 = u.dot(dp.cross(r1 - p0)) / lp;
    const double t0 = u.dot(dr.cross(p0 - r0)) / lr, t1 = u.dot(dr.cross(p1 - r0)) / lr;
    if ((s0 > eps && s1 > eps) || (s0 < -eps && s1 < -eps)) return false;
    if ((t0 > eps && t1 > eps) || (t0 < -eps && t1 < -eps)) return false;
    // Both straddle (or touch) the other's line: they cross, unless collinear and apart.
    if (std::abs(s0) <= eps && std::abs(s1) <= eps) {
      const double a0 = 0, a1 = dp.dot(dp) / lp, b0 = dp.dot(r0 - p0) / lp,
                   b1 = dp.dot(r1 - p0) / lp;
      return std::max(a0, std::min(b0, b1)) <= std::min(a1, std::max(b0, b1)) + eps;
    }
    return true;
  }

  /// Triangles (ids ta, tb of vertex ids) meet other than along their shared vertices/edge.
  [[nodiscard]] bool meet(const std::array<std::uint32_t, 3>& ta,
                          const std::array<std::uint32_t, 3>& tb,
                          const std::vector<Vec3>& pos) const {
    int shared = 0;
    std::array<int, 3> in_b{-1, -1, -1};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (ta[static_cast<std::size_t>(i)] == tb[static_cast<std::size_t>(j)]) {
          in_b[static_cast<std::size_t>(i)] = j;
          ++shared;
        }
    const Vec3 &a0 = pos[ta[0]], &a1 = pos[ta[1]], &a2 = pos[ta[2]];
    const Vec3 &b0 = pos[tb[0]], &b1 = pos[tb[1]], &b2 = pos[tb[2]];
    if (shared >= 2) {  // a shared edge: they meet only when folded onto each other
      const Vec3 na = (a1 - a0).cross(a2 - a0), nb = (b1 - b0).cross(b2 - b0);
      return na.dot(nb) < -0.999 * na.norm() * nb.norm();
    }
    const std::array<const Vec3*, 3> pa{&a0, &a1, &a2}, pb{&b0, &b1, &b2};
    if (shared == 1) {  // each one's edge opposite the shared vertex against the other
      int ia = 0;
      while (in_b[static_cast<std::size_t>(ia)] < 0) ++ia;
      const int ib = in_b[static_cast<std::size_t>(ia)];
      const Vec3& ea0 = *pa[static_cast<std::size_t>((ia + 1) % 3)];
      const Vec3& ea1 = *pa[static_cast<std::size_t>((ia + 2) % 3)];
      const Vec3& eb0 = *pb[static_cast<std::size_t>((ib + 1) % 3)];
      const Vec3& eb1 = *pb[static_cast<std::size_t>((ib + 2) % 3)];
      return segment_hits(ea0, ea1, b0, b1, b2) || segment_hits(eb0, eb1, a0, a1, a2);
    }
    for (int k = 0; k < 3; ++k) {
      if (segment_hits(*pa[static_cast<std::size_t>(k)], *pa[static_cast<std::size_t>((k + 1) % 3)],
                       b0, b1, b2) ||
          segment_hits(*pb[static_cast<std::size_t>(k)], *pb[static_cast<std::size_t>((k + 1) % 3)],
                       a0, a1, a2))
        return true;
    }
    return false;
  }
};

/// A uniform grid of cubic cells over a mesh's box, padded by two cells: the cells a
/// triangle's box touches, each cell as one 64-bit key.
struct TriangleCells {
  const Mesh& mesh;
  double cell_mm;
  double eps = 1e-7;
  Vec3 lo;

  TriangleCells(const Mesh& m, double cell) : mesh(m), cell_mm(cell) {
    lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    for (const Vec3& p : mesh.vertices_mm) lo = lo.cwiseMin(p);
    lo -= Vec3::Constant(2 * cell_mm);
  }
  [[nodiscard]] int cell(double x, int a) const {
    return static_cast<int>(std::floor((x - lo[a]) / cell_mm));
  }
  [[nodiscard]] std::pair<Vec3, Vec3> box(std::uint32_t t) const {
    const auto& tr = mesh.triangles[t];
    const auto& pos = mesh.vertices_mm;
    return {pos[tr[0]].cwiseMin(pos[tr[1]]).cwiseMin(pos[tr[2]]),
            pos[tr[0]].cwiseMax(pos[tr[1]]).cwiseMax(pos[tr[2]])};
  }
  void range(std::uint32_t t, std::array<int, 3>& c0, std::array<int, 3>& c1) const {
    const auto [mn, mx] = box(t);
    for (int a = 0; a < 3; ++a) {
      c0[static_cast<std::size_t>(a)] = cell(mn[a] - eps, a);
      c1[static_cast<std::size_t>(a)] = cell(mx[a] + eps, a);
    }
  }
  static std::uint64_t key(int x, int y, int z) {
    return (static_cast<std::uint64_t>(z) << 42) | (static_cast<std::uint64_t>(y) << 21) |
           static_cast<std::uint64_t>(x);
  }
  /// Calls f(key) for every cell triangle t's box touches.
  template <class F>
  void for_cells(std::uint32_t t, F&& f) const {
    std::array<int, 3> c0{}, c1{};
    range(t, c0, c1);
    for (int z = c0[2]; z <= c1[2]; ++z)
      for (int y = c0[1]; y <= c1[1]; ++y)
        for (int x = c0[0]; x <= c1[0]; ++x) f(key(x, y, z));
  }
};

/// (cell, triangle) entries sorted by cell: every triangle when `all`, else only in the
/// cells that a dirty triangle touches.
void cell_entries(const TriangleCells& cells, const std::vector<std::uint8_t>& dirty, bool all,
                  std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& ids) {
  const std::size_t nt = cells.mesh.triangles.size();
  std::vector<std::uint64_t> dirty_cells;
  if (!all) {
    for (std::uint32_t t = 0; t < nt; ++t)
      if (dirty[t] != 0) cells.for_cells(t, [&](std::uint64_t k) { dirty_cells.push_back(k); });
    std::sort(dirty_cells.begin(), dirty_cells.end());
    dirty_cells.erase(std::unique(dirty_cells.begin(), dirty_cells.end()), dirty_cells.end());
  }
  constexpr std::size_t kChunk = 65536;
  const std::size_t chunks = (nt + kChunk - 1) / kChunk;
  std::vector<std::vector<std::uint64_t>> part_keys(chunks);
  std::vector<std::vector<std::uint32_t>> part_ids(chunks);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    for (std::size_t t = c * kChunk; t < std::min(nt, (c + 1) * kChunk); ++t) {
      const bool take_all = all || dirty[t] != 0;
      cells.for_cells(static_cast<std::uint32_t>(t), [&](std::uint64_t k) {
        if (!take_all && !std::binary_search(dirty_cells.begin(), dirty_cells.end(), k)) return;
        part_keys[c].push_back(k);
        part_ids[c].push_back(static_cast<std::uint32_t>(t));
      });
    }
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    keys.insert(keys.end(), part_keys[c].begin(), part_keys[c].end());
    ids.insert(ids.end(), part_ids[c].begin(), part_ids[c].end());
    part_keys[c] = {};
    part_ids[c] = {};
  }
  radix_sort(keys, &ids);
}

/// The crossing pairs among the triangles of one cell (entries [b, e)), each pair found once:
/// in the cell of the low corner of the two boxes' overlap.
void pairs_in_cell(const TriangleCells& cells, std::span<const std::uint32_t> plane,
                   const std::vector<std::uint8_t>& dirty, const std::vector<std::uint8_t>& far,
                   std::span<const std::uint32_t> ids, std::uint64_t key,
                   std::vector<std::pair<Vec3, Vec3>>& box,
                   std::vector<std::array<std::uint32_t, 2>>& found) {
  const TriTri test{cells.eps};
  const double eps = cells.eps;
  box.clear();
  for (const std::uint32_t t : ids) box.push_back(cells.box(t));
  const auto far_moved = [&](std::uint32_t t) {
    const auto& tr = cells.mesh.triangles[t];
    return (far[tr[0]] | far[tr[1]] | far[tr[2]]) != 0;
  };
  for (std::size_t i = 0; i < ids.size(); ++i)
    for (std::size_t j = i + 1; j < ids.size(); ++j) {
      const std::uint32_t ta = ids[i], tb = ids[j];
      if (dirty[ta] == 0 && dirty[tb] == 0) continue;
      if (plane[ta] == plane[tb] && !far_moved(ta) && !far_moved(tb)) continue;
      const auto& ba = box[i];
      const auto& bb = box[j];
      if ((ba.first.array() > bb.second.array() + eps).any() ||
          (bb.first.array() > ba.second.array() + eps).any())
        continue;
      // Tested only in the cell of the overlap's low corner (the boxes were padded by eps
      // the same way, so that cell holds both).
      const Vec3 m = ba.first.cwiseMax(bb.first);
      std::array<int, 3> mc{};
      for (int a = 0; a < 3; ++a)
        mc[static_cast<std::size_t>(a)] = std::max(0, cells.cell(m[a] - eps, a));
      if (TriangleCells::key(mc[0], mc[1], mc[2]) != key) continue;
      if (test.meet(cells.mesh.triangles[ta], cells.mesh.triangles[tb], cells.mesh.vertices_mm))
        found.push_back({std::min(ta, tb), std::max(ta, tb)});
    }
}

/// Triangles of different planes (or of one, when a vertex of either is `far` moved), at
/// least one of them `dirty`, whose boxes overlap and that meet (TriTri): the pairs, in a
/// deterministic order.
std::vector<std::array<std::uint32_t, 2>> crossing_pairs(const Mesh& mesh,
                                                         std::span<const std::uint32_t> plane,
                                                         const std::vector<std::uint8_t>& dirty,
                                                         const std::vector<std::uint8_t>& far,
                                                         double cell_mm) {
  const std::size_t nt = mesh.triangles.size();
  std::size_t n_dirty = 0;
  for (const std::uint8_t d : dirty) n_dirty += d;
  if (n_dirty == 0) return {};
  const TriangleCells cells(mesh, cell_mm);
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> ids;
  // Few dirty triangles: only the cells they touch take the others.
  cell_entries(cells, dirty, n_dirty * 8 > nt, keys, ids);
  // Groups of one cell, split into chunks at group starts.
  std::vector<std::size_t> starts;
  for (std::size_t i = 0; i < keys.size(); ++i)
    if (i == 0 || keys[i] != keys[i - 1]) starts.push_back(i);
  starts.push_back(keys.size());
  const std::size_t ng = starts.size() - 1;
  constexpr std::size_t kGroups = 4096;
  std::vector<std::vector<std::array<std::uint32_t, 2>>> found((ng + kGroups - 1) / kGroups);
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t c) {
    std::vector<std::pair<Vec3, Vec3>> box;
    for (std::size_t g = c * kGroups; g < std::min(ng, (c + 1) * kGroups); ++g) {
      const std::size_t b = starts[g], e = starts[g + 1];
      if (e - b < 2) continue;
      pairs_in_cell(cells, plane, dirty, far, std::span<const std::uint32_t>(ids).subspan(b, e - b),
                    keys[b], box, found[c]);
    }
  });
  std::vector<std::array<std::uint32_t, 2>> out;
  for (auto& f : found) out.insert(out.end(), f.begin(), f.end());
  return out;
}

}  // namespace

std::size_t smooth_onto_beads(Mesh& mesh, std::span<const std::uint32_t> plane_of_triangle,
                              const VoxelGrid& grid, std::span<const SurfaceBead> beads,
                              double* max_shift_mm) {
  const std::size_t nv = mesh.vertices_mm.size(), nt = mesh.triangles.size();
  if (max_shift_mm != nullptr) *max_shift_mm = 0;
  if (beads.empty() || nv == 0 || plane_of_triangle.size() != nt) return 0;
  const double v = grid.voxel_mm();
  const double near_shift = kMaxShiftVoxels * v;
  const BeadIndex index(beads);
  // Outward vertex normals (area-weighted; the triangles are oriented outward).
  std::vector<Vec3> normal(nv, Vec3::Zero());
  for (const auto& t : mesh.triangles) {
    const Vec3& a = mesh.vertices_mm[t[0]];
    const Vec3 c = (mesh.vertices_mm[t[1]] - a).cross(mesh.vertices_mm[t[2]] - a);
    for (const std::uint32_t i : t) normal[i] += c;
  }
  std::vector<Vec3> moved(nv);
  std::vector<std::uint8_t> is_moved(nv, 0);
  // Moved farther than near_shift on some axis: its triangles may cross those of their own
  // lattice plane too, so the crossing check tests those pairs as well.
  std::vector<std::uint8_t> far(nv, 0);
  tbb::parallel_for(std::size_t{0}, (nv + 4095) / 4096, [&](std::size_t c) {
    for (std::size_t i = c * 4096; i < std::min(nv, (c + 1) * 4096); ++i) {
      const Vec3& p = mesh.vertices_mm[i];
      Vec3 target;
      if (!bead_point(grid, index, beads, p, normal[i], target)) continue;
      moved[i] = target;
      is_moved[i] = 1;
      far[i] = ((target - p).cwiseAbs().array() > near_shift).any() ? 1 : 0;
    }
  });
  normal = {};
  const std::vector<Vec3> lattice = mesh.vertices_mm;
  for (std::size_t i = 0; i < nv; ++i)
    if (is_moved[i] != 0) mesh.vertices_mm[i] = moved[i];
  moved = {};
  // Triangles to look at: first those with a moved vertex, then those whose vertices went
  // back in the round before (`fold`: for the fold test; `dirty`: for the crossing check,
  // gathered until it runs).
  std::vector<std::uint8_t> dirty(nt, 0);
  tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) {
    const auto& tr = mesh.triangles[t];
    dirty[t] = (is_moved[tr[0]] | is_moved[tr[1]] | is_moved[tr[2]]) != 0 ? 1 : 0;
  });
  std::vector<std::uint8_t> fold = dirty;
  const double min_cos = std::cos(kMaxTurnDegrees * 3.14159265358979323846 / 180.0);
  constexpr std::size_t kChunk = 65536;
  std::vector<std::vector<std::uint32_t>> folded((nt + kChunk - 1) / kChunk);
  std::vector<std::uint8_t> back(nv, 0);  // vertices put back in this round
  for (;;) {
    // Triangles that fold (or collapse) against their voxel face.
    tbb::parallel_for(std::size_t{0}, folded.size(), [&](std::size_t c) {
      folded[c].clear();
      for (std::size_t ti = c * kChunk; ti < std::min(nt, (c + 1) * kChunk); ++ti) {
        if (fold[ti] == 0) continue;
        const auto& t = mesh.triangles[ti];
        if (is_moved[t[0]] == 0 && is_moved[t[1]] == 0 && is_moved[t[2]] == 0) continue;
        const Vec3& a = lattice[t[0]];
        const Vec3 n0 = (lattice[t[1]] - a).cross(lattice[t[2]] - a);
        const auto& q = mesh.vertices_mm;
        const Vec3 n1 = (q[t[1]] - q[t[0]]).cross(q[t[2]] - q[t[0]]);
        const double l0 = n0.norm(), l1 = n1.norm();
        if (n1.dot(n0) >= min_cos * l0 * l1 && l1 >= kMinAreaRatio * l0) continue;
        folded[c].push_back(static_cast<std::uint32_t>(ti));
      }
    });
    std::vector<std::uint32_t> hit;
    for (const auto& f : folded) hit.insert(hit.end(), f.begin(), f.end());
    const bool crossing_check = hit.empty();  // once nothing folds: the dirty ones are done
    if (crossing_check) {
      for (const auto& pr : crossing_pairs(mesh, plane_of_triangle, dirty, far, kCellVoxels * v)) {
        hit.push_back(pr[0]);
        hit.push_back(pr[1]);
      }
    }
    bool any = false;
    for (const std::uint32_t ti : hit) {
      // A far-moved vertex (a crease) goes back first: the others may stay.
      const auto& tr = mesh.triangles[ti];
      const bool any_far = (far[tr[0]] | far[tr[1]] | far[tr[2]]) != 0;
      for (const std::uint32_t i : tr)
        if (is_moved[i] != 0 && (!any_far || far[i] != 0)) {
          is_moved[i] = 0;
          far[i] = 0;
          mesh.vertices_mm[i] = lattice[i];
          back[i] = 1;
          any = true;
        }
    }
    if (!any) break;
    // Triangles around the vertices put back join the ones still to check for crossings.
    tbb::parallel_for(std::size_t{0}, nt, [&](std::size_t t) {
      const auto& tr = mesh.triangles[t];
      const bool near = (back[tr[0]] | back[tr[1]] | back[tr[2]]) != 0;
      dirty[t] = near || (!crossing_check && dirty[t] != 0) ? 1 : 0;
      fold[t] = near ? 1 : 0;
    });
    std::fill(back.begin(), back.end(), 0);
  }
  if (max_shift_mm != nullptr)
    for (std::size_t i = 0; i < nv; ++i)
      if (is_moved[i] != 0)
        *max_shift_mm = std::max(*max_shift_mm, (mesh.vertices_mm[i] - lattice[i]).norm());
  return static_cast<std::size_t>(std::count(is_moved.begin(), is_moved.end(), 1));
}

}  // namespace printtwin::detail
