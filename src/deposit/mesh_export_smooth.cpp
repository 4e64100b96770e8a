// Sub-voxel smoothing of the as-printed mesh: its vertices move from the voxel lattice onto
// the true surface of the beads that laid the voxels around them (the stadium beads of the
// deposit's model, the same ones the deviation stage places its surface points on).
//
// Safety, so the mesh stays closed, 2-manifold, oriented and free of self-intersections:
// - only positions change, never the connectivity;
// - every vertex stays within kMaxShiftVoxels of its lattice point on each axis (< 1/2): two
//   voxel faces that share no lattice point are at least one voxel apart on some axis, so the
//   triangles made from them stay at least (1 - 2 kMaxShiftVoxels) voxel apart;
// - triangles that share a vertex could fold over each other: every triangle whose normal
//   turns by more than kMaxTurn from its voxel face's normal (or whose area collapses) puts
//   its vertices back on the lattice, repeated until no triangle does; then every pair of
//   triangles that still intersects (exact test of the check stage) does the same.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "deposit/mesh_export_internal.hpp"
#include "deviation/surface_internal.hpp"
#include "printtwin/check.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin::detail {

namespace {

/// The bead surface point for a vertex at p (its outward normal `normal`), or nothing: the
/// nearest bead of the lines of the occupied voxels touching p, when its surface there faces
/// the same way as the mesh.
bool bead_point(const VoxelGrid& grid, std::span<const SurfaceBead> beads, const Vec3& p,
                const Vec3& normal, Vec3& target) {
  const double v = grid.voxel_mm();
  const Vec3 q = (p - grid.origin_mm()) / v;
  std::array<int, 3> lo{}, n{};
  for (int a = 0; a < 3; ++a) {
    const double r = std::round(q[a]);
    const bool on_plane = std::abs(q[a] - r) < 1e-6;
    lo[static_cast<std::size_t>(a)] =
        on_plane ? static_cast<int>(r) - 1 : static_cast<int>(std::floor(q[a]));
    n[static_cast<std::size_t>(a)] = on_plane ? 2 : 1;
  }
  std::array<std::uint32_t, 8> lines{};
  int nl = 0;
  for (int dz = 0; dz < n[2]; ++dz)
    for (int dy = 0; dy < n[1]; ++dy)
      for (int dx = 0; dx < n[0]; ++dx) {
        const auto tag = grid.tag({lo[0] + dx, lo[1] + dy, lo[2] + dz});
        if (!tag || is_auxiliary_feature(tag->feature)) continue;
        if (std::find(lines.begin(), lines.begin() + nl, tag->line) == lines.begin() + nl)
          lines[static_cast<std::size_t>(nl++)] = tag->line;
      }
  // Where voxels of several lines meet (a layer groove, the inside of a corner), the beads'
  // surfaces cross at a crease and their nearest points jump: the lattice point stays.
  if (nl != 1) return false;
  BeadDistance best;
  for (int i = 0; i < nl; ++i) {
    const BeadDistance d = nearest_bead(beads, lines[static_cast<std::size_t>(i)], p);
    if (d.signed_mm < best.signed_mm) best = d;
  }
  if (best.bead == kNoBead) return false;
  Vec3 out = p - best.core_point;
  const double len = out.norm();
  if (!(len > 1e-12)) return false;
  out /= len;
  if (out.dot(normal) <= 0) return false;  // the far side of the bead: another surface
  target = best.core_point + (0.5 * beads[best.bead].height_mm) * out;
  return true;
}

}  // namespace

std::size_t smooth_onto_beads(Mesh& mesh, const VoxelGrid& grid,
                              std::span<const SurfaceBead> beads) {
  const std::size_t nv = mesh.vertices_mm.size(), nt = mesh.triangles.size();
  if (beads.empty() || nv == 0 || nt > kMaxCheckedTriangles) return 0;
  const double v = grid.voxel_mm();
  const double max_shift = kMaxShiftVoxels * v;
  // Outward vertex normals (area-weighted; the triangles are oriented outward).
  std::vector<Vec3> normal(nv, Vec3::Zero());
  for (const auto& t : mesh.triangles) {
    const Vec3& a = mesh.vertices_mm[t[0]];
    const Vec3 c = (mesh.vertices_mm[t[1]] - a).cross(mesh.vertices_mm[t[2]] - a);
    for (const std::uint32_t i : t) normal[i] += c;
  }
  std::vector<Vec3> moved(nv);
  std::vector<std::uint8_t> is_moved(nv, 0);
  tbb::parallel_for(std::size_t{0}, (nv + 4095) / 4096, [&](std::size_t c) {
    for (std::size_t i = c * 4096; i < std::min(nv, (c + 1) * 4096); ++i) {
      const Vec3& p = mesh.vertices_mm[i];
      Vec3 target;
      if (!bead_point(grid, beads, p, normal[i], target)) continue;
      Vec3 d = target - p;
      // A bead surface more than a voxel away does not explain this vertex (the deposit
      // differs from the nominal bead there: squeezed, sagged or merged).
      if (!(d.norm() <= v)) continue;
      for (int a = 0; a < 3; ++a) d[a] = std::clamp(d[a], -max_shift, max_shift);
      moved[i] = p + d;
      is_moved[i] = 1;
    }
  });
  normal = {};
  // Triangles that would fold: their vertices go back to the lattice, until none is left.
  const double min_cos = std::cos(kMaxTurnDegrees * 3.14159265358979323846 / 180.0);
  auto pos = [&](std::uint32_t i) -> const Vec3& {
    return is_moved[i] != 0 ? moved[i] : mesh.vertices_mm[i];
  };
  constexpr std::size_t kChunk = 65536;
  std::vector<std::vector<std::uint32_t>> folded((nt + kChunk - 1) / kChunk);
  for (;;) {
    tbb::parallel_for(std::size_t{0}, folded.size(), [&](std::size_t c) {
      folded[c].clear();
      for (std::size_t ti = c * kChunk; ti < std::min(nt, (c + 1) * kChunk); ++ti) {
        const auto& t = mesh.triangles[ti];
        if (is_moved[t[0]] == 0 && is_moved[t[1]] == 0 && is_moved[t[2]] == 0) continue;
        const Vec3& a = mesh.vertices_mm[t[0]];
        const Vec3 n0 = (mesh.vertices_mm[t[1]] - a).cross(mesh.vertices_mm[t[2]] - a);
        const Vec3 n1 = (pos(t[1]) - pos(t[0])).cross(pos(t[2]) - pos(t[0]));
        const double l0 = n0.norm(), l1 = n1.norm();
        if (n1.dot(n0) >= min_cos * l0 * l1 && l1 >= kMinAreaRatio * l0) continue;
        folded[c].push_back(static_cast<std::uint32_t>(ti));
      }
    });
    bool any = false;
    for (const auto& f : folded)
      for (const std::uint32_t ti : f) {
        for (const std::uint32_t i : mesh.triangles[ti]) is_moved[i] = 0;
        any = true;
      }
    if (!any) break;
  }
  // Triangles of rectangles that touch may still cross where they turn differently (at the
  // corners of a loop): the vertices of every intersecting pair go back too, until none is
  // left (or, after a few rounds, all of them: the voxel-face mesh has none).
  const std::vector<Vec3> lattice = mesh.vertices_mm;
  auto apply = [&] {
    for (std::size_t i = 0; i < nv; ++i)
      mesh.vertices_mm[i] = is_moved[i] != 0 ? moved[i] : lattice[i];
  };
  for (int round = 0;; ++round) {
    apply();
    const SelfIntersections si = find_self_intersections(mesh, 0);
    if (si.pairs == 0) break;
    if (round == kMaxIntersectionRounds) {
      std::fill(is_moved.begin(), is_moved.end(), 0);
      apply();
      break;
    }
    // Their vertices and the vertices of every triangle around those (fewer rounds).
    std::vector<std::uint8_t> hit(nv, 0);
    for (const std::uint32_t f : si.faces)
      for (const std::uint32_t i : mesh.triangles[f]) hit[i] = 1;
    for (const auto& t : mesh.triangles)
      if (hit[t[0]] != 0 || hit[t[1]] != 0 || hit[t[2]] != 0)
        for (const std::uint32_t i : t) is_moved[i] = 0;
  }
  return static_cast<std::size_t>(std::count(is_moved.begin(), is_moved.end(), 1));
}

}  // namespace printtwin::detail
