// Deviation stage: sampling, statistics, outer surface, signed distances with known answers,
// Embree vs CGAL reference, registration, regions, PLY export.
#include <gtest/gtest.h>

#include <set>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <tuple>

#include "deviation/deposit_surface_internal.hpp"
#include "deviation/outer_surface.hpp"
#include "deviation/point_groups.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/mesh_query.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

/// Grid of `voxel_mm` covering `box` (+1 mm), with a deliberately unaligned origin, filled
/// where `inside(voxel centre)`; the tag's layer is z / 0.2 and its line 1000 + layer.
VoxelGrid voxelise(double voxel_mm, const Box3& box, const std::function<bool(const Vec3&)>& inside,
                   Feature feature = Feature::outer_perimeter,
                   const Vec3& margin = Vec3(1.0123, 1.0061, 1.0037)) {
  const Vec3 origin = box.min - margin;
  const Eigen::Vector3i dims = ((box.max - origin + Vec3::Constant(1.0)) / voxel_mm).cast<int>();
  VoxelGrid grid(voxel_mm, origin, dims);
  for (int z = 0; z < dims.z(); ++z)
    for (int y = 0; y < dims.y(); ++y)
      for (int x = 0; x < dims.x(); ++x) {
        const VoxelKey k{x, y, z};
        const Vec3 c = grid.center_mm(k);
        if (!inside(c)) continue;
        const int layer = static_cast<int>(std::floor(c.z() / 0.2));
        grid.set(k, VoxelTag{static_cast<std::uint32_t>(1000 + layer), layer, feature});
      }
  return grid;
}

/// Distance from p to an axis-aligned box (0 inside).
double box_distance(const Vec3& p, const Box3& b) {
  const Vec3 d = (b.min - p).cwiseMax(p - b.max).cwiseMax(0.0);
  return d.norm();
}

/// Distance from p to the nearest edge of box b (the 12 edge lines, clamped).
bool near_edge(const Vec3& p, const Box3& b, double margin) {
  int near_faces = 0;
  for (int a = 0; a < 3; ++a)
    if (std::abs(p[a] - b.min[a]) < margin || std::abs(p[a] - b.max[a]) < margin) ++near_faces;
  return near_faces >= 2;
}

TEST(DeviationStats, KnownValues) {
  const std::vector<double> d{-0.3, -0.1, 0.0, 0.1, 0.2};
  const DeviationStats s = deviation_stats(d, 0.15);
  EXPECT_EQ(s.samples, 5U);
  EXPECT_DOUBLE_EQ(s.min_mm, -0.3);
  EXPECT_DOUBLE_EQ(s.max_mm, 0.2);
  EXPECT_NEAR(s.mean_mm, -0.02, 1e-15);
  EXPECT_NEAR(s.mean_abs_mm, 0.14, 1e-15);
  EXPECT_NEAR(s.rms_mm, std::sqrt((0.09 + 0.01 + 0.01 + 0.04) / 5), 1e-15);
  EXPECT_NEAR(s.std_mm, std::sqrt(0.15 / 5 - 0.02 * 0.02), 1e-15);
  // |d| sorted: 0, 0.1, 0.1, 0.2, 0.3; type-7 percentiles.
  EXPECT_NEAR(s.p50_abs_mm, 0.1, 1e-15);
  EXPECT_NEAR(s.p95_abs_mm, 0.2 + 0.8 * 0.1, 1e-12);
  EXPECT_NEAR(s.hausdorff_mm, 0.3, 1e-15);
  EXPECT_NEAR(s.within_tolerance_pct, 60.0, 1e-12);
  const DeviationStats empty = deviation_stats({}, 0.1);
  EXPECT_EQ(empty.samples, 0U);
  EXPECT_EQ(empty.within_tolerance_pct, 100.0);
}

TEST(DeviationStats, PercentilesAreTheSortedOrderStatisticsAtEverySize) {
  // Histogram selection (from 512 values on, bins over the range of |d|'s bit patterns, up
  // to 2^16 of them) and plain selection below: percentiles and Hausdorff equal the type-7
  // percentiles of a full sort, to the bit, with many ties (values on a 1 um grid), zeros,
  // both signs, one far outlier, and a run of equal values (a range of one bin).
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 0.08);
  std::vector<double> d(300000);
  for (double& x : d) x = std::round(g(rng) * 1000.0) / 1000.0;
  d[5] = 2.5;  // one far outlier
  const auto type7 = [&](const std::vector<double>& v, double q) {
    const double h = q * static_cast<double>(v.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(h));
    const std::size_t hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (h - static_cast<double>(lo)) * (v[hi] - v[lo]);
  };
  const auto check = [&](const std::vector<double>& part) {
    std::vector<double> a(part.size());
    for (std::size_t i = 0; i < part.size(); ++i) a[i] = std::abs(part[i]);
    std::sort(a.begin(), a.end());
    const DeviationStats s = deviation_stats(part, 0.1);
    EXPECT_EQ(s.p50_abs_mm, type7(a, 0.50)) << part.size();
    EXPECT_EQ(s.p95_abs_mm, type7(a, 0.95)) << part.size();
    EXPECT_EQ(s.p99_abs_mm, type7(a, 0.99)) << part.size();
    EXPECT_EQ(s.hausdorff_mm, a.back()) << part.size();
  };
  for (const std::size_t n : {std::size_t{300000}, std::size_t{20000}, std::size_t{1001},
                              std::size_t{512}, std::size_t{300}, std::size_t{7}})
    check(std::vector<double>(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(n)));
  check(std::vector<double>(2000, -0.042));
  EXPECT_EQ(deviation_stats(d, 0.1).hausdorff_mm, 2.5);
}

TEST(DeviationSampling, AreaUniformDeterministicAndOnSurface) {
  const Mesh box = make_box_mesh(Vec3(0, 0, 0), Vec3(10, 4, 2));  // area 2*(40+20+8) = 136
  const auto a = sample_surface(box, 0.1, 7);
  const auto b = sample_surface(box, 0.1, 7);
  const auto c = sample_surface(box, 0.1, 8);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].position_mm, b[i].position_mm);
  EXPECT_NE(a.front().position_mm, c.front().position_mm);
  // Expected count area / spacing^2 = 13600; the random rounding per triangle is +-1 each.
  EXPECT_NEAR(static_cast<double>(a.size()), 13600.0, 12.0);
  // Area-uniform: the share on the top face (40 of 136 mm^2) and in one half of it.
  std::size_t top = 0, top_left = 0;
  for (const auto& s : a) {
    EXPECT_LT(box_distance(s.position_mm, bounding_box(box)), 1e-12);
    const bool on_surface =
        std::abs(s.position_mm.x()) < 1e-9 || std::abs(s.position_mm.x() - 10) < 1e-9 ||
        std::abs(s.position_mm.y()) < 1e-9 || std::abs(s.position_mm.y() - 4) < 1e-9 ||
        std::abs(s.position_mm.z()) < 1e-9 || std::abs(s.position_mm.z() - 2) < 1e-9;
    EXPECT_TRUE(on_surface);
    if (std::abs(s.position_mm.z() - 2) < 1e-9) {
      ++top;
      if (s.position_mm.x() < 5) ++top_left;
    }
  }
  EXPECT_NEAR(static_cast<double>(top) / static_cast<double>(a.size()), 40.0 / 136.0, 0.003);
  EXPECT_NEAR(static_cast<double>(top_left) / static_cast<double>(top), 0.5, 0.02);
}

TEST(DeviationSurface, EnclosedVoidsAreNotSurfaceOpenHolesAre) {
  // A 2 x 2 x 1 mm block of 0.1 mm voxels with a closed cavity (like sparse infill) and a
  // blind hole open at the top.
  const Box3 block{Vec3(0, 0, 0), Vec3(2, 2, 1)};
  const Box3 cavity{Vec3(0.5, 0.5, 0.3), Vec3(0.9, 0.9, 0.7)};
  const Box3 hole{Vec3(1.3, 1.3, 0.5), Vec3(1.5, 1.5, 1.5)};
  const VoxelGrid grid = voxelise(
      0.1, block,
      [&](const Vec3& c) { return block.contains(c) && !cavity.contains(c) && !hole.contains(c); },
      Feature::outer_perimeter, Vec3(1, 1, 1));
  const DepositSurface s = extract_outer_surface(grid, block);
  // Outer box faces (20*20*2 + 20*10*4) + blind hole walls (2*5 voxels * 4 sides) + its floor
  // (2*2) - the top faces the hole removes (2*2).
  EXPECT_EQ(s.faces.size(), 800U + 800U + 40U + 4U - 4U);
  EXPECT_EQ(s.occupied_voxels, 4000U - 64U - 20U);
  EXPECT_EQ(s.filled_voxels, 4000U - 20U);  // the cavity counts as filled, the hole does not
  EXPECT_TRUE(s.filled(Vec3(0.7, 0.7, 0.5)));
  EXPECT_FALSE(s.filled(Vec3(1.4, 1.4, 0.8)));
  EXPECT_FALSE(s.filled(Vec3(3, 3, 0.5)));
  ASSERT_EQ(s.face_centers_mm().size(), s.faces.size());
  for (std::size_t i = 0; i < s.faces.size(); ++i) {
    EXPECT_FALSE(cavity.contains(s.face_center(i), 1e-9)) << s.face_center(i).transpose();
    EXPECT_EQ(grid.tag(s.faces[i].voxel).has_value(), true);
  }
}

TEST(DeviationSurface, NoDepositIsAllOutside) {
  // An empty grid (or one whose only voxels are outside the region): no faces, nothing
  // filled, and every point of the design is missing.
  const Box3 region{Vec3(0, 0, 0), Vec3(2, 2, 1)};
  VoxelGrid grid(0.1, Vec3(-1, -1, -1), Eigen::Vector3i(60, 60, 40));
  grid.set(grid.key_of(Vec3(3.5, 3.5, 0.5)),
           VoxelTag{1, 0, Feature::perimeter});  // far from the region
  const DepositSurface s = extract_outer_surface(grid, region, 0.2);
  EXPECT_TRUE(s.faces.empty());
  EXPECT_EQ(s.occupied_voxels, 0U);
  EXPECT_EQ(s.filled_voxels, 0U);
  EXPECT_FALSE(s.filled(Vec3(1, 1, 0.5)));
  std::vector<double> d;
  const std::vector<Vec3> points{Vec3(1, 1, 0.5), Vec3(0.2, 1.8, 0.1)};
  distances_to_deposit(s, points, d, nullptr);
  ASSERT_EQ(d.size(), 2U);
  EXPECT_LT(d[0], 0);
  EXPECT_LT(d[1], 0);
}

TEST(DeviationSurface, AuxiliaryFeaturesAreIgnored) {
  const Box3 block{Vec3(0, 0, 0), Vec3(1, 1, 1)};
  VoxelGrid grid = voxelise(
      0.1, block, [&](const Vec3& c) { return block.contains(c); }, Feature::support);
  EXPECT_EQ(extract_outer_surface(grid, block).faces.size(), 0U);
  grid.set(grid.key_of(Vec3(0.55, 0.55, 0.55)), VoxelTag{5, 2, Feature::perimeter});
  const DepositSurface s = extract_outer_surface(grid, block);
  EXPECT_EQ(s.faces.size(), 6U);
  EXPECT_EQ(s.face_tags[0].line, 5U);
  // A block holding only later, non-auxiliary tags skips the per-voxel test (its tag range
  // has no auxiliary tag) and still shows; one that mixes both is still filtered voxel by voxel.
  VoxelGrid wide = voxelise(
      0.1, Box3{Vec3(0, 0, 0), Vec3(2, 1, 1)}, [&](const Vec3& c) { return block.contains(c); },
      Feature::skirt);
  wide.set(wide.key_of(Vec3(1.55, 0.55, 0.55)), VoxelTag{9, 3, Feature::perimeter});
  wide.set(wide.key_of(Vec3(0.55, 0.55, 0.55)), VoxelTag{7, 3, Feature::outer_perimeter});
  const DepositSurface w = extract_outer_surface(wide, Box3{Vec3(0, 0, 0), Vec3(2, 1, 1)});
  ASSERT_EQ(w.faces.size(), 12U);
  std::set<std::uint32_t> lines;
  for (const auto& t : w.face_tags) lines.insert(t.line);
  EXPECT_EQ(lines, (std::set<std::uint32_t>{7U, 9U}));
}

TEST(DeviationPointGroups, CellsArePermutationsOfSmallGroupsEvenOnLongParts) {
  // Points along a 300 mm bar (1500 cells of 0.2 mm: more than the 10 bits per axis hold)
  // and 1 mm across: every point once, groups in input order inside, and no group wider
  // than one cell (grown to 300 / 1000 mm, so that 10 bits per axis hold the bar).
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> along(0, 300), across(0, 1);
  std::vector<Vec3> pts;
  for (int i = 0; i < 20000; ++i) pts.emplace_back(along(rng), across(rng), across(rng));
  std::vector<std::uint32_t> order, group;
  detail::group_by_cell(pts, 0.2, order, group);
  ASSERT_EQ(order.size(), pts.size());
  std::vector<std::uint32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i);
  ASSERT_GE(group.size(), 2U);
  EXPECT_EQ(group.front(), 0U);
  EXPECT_EQ(group.back(), pts.size());
  for (std::size_t g = 0; g + 1 < group.size(); ++g) {
    Box3 box;
    for (std::uint32_t j = group[g]; j < group[g + 1]; ++j) {
      box.extend(pts[order[j]]);
      if (j > group[g]) {
        EXPECT_LT(order[j - 1], order[j]);
      }
    }
    EXPECT_LE(box.size().maxCoeff(), 0.3 + 1e-9) << g;
  }
}

TEST(DeviationSurface, BlockFloodMatchesAVoxelByVoxelFloodFill) {
  // A random deposit over many 8^3 blocks (the flood runs block by block): solid boxes with
  // holes, an open-topped cup and pinholes, at 0.05 mm, unsealed and sealed at 0.1, 0.25
  // and 0.95 mm (r = 1, 2 and 9: more than a block, two dilation steps); and in a grid whose
  // origin lies inside the region (negative keys and blocks, part of the region outside the
  // grid), sealed at 0.1 and 1.75 mm (r = 17, three steps). The filled set, its count and the faces
  // must be those of a plain voxel-by-voxel version of the same rules: the occupancy dilated by r
  // (a cube), empty voxels 6-connected to the padding are outside, the outside dilated back by r,
  // filled = not (outside and empty); a face wherever a filled, occupied voxel meets a not-filled
  // one.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Box3> solids, holes;
  for (int i = 0; i < 14; ++i) {
    const Vec3 lo(u(rng) * 5.0, u(rng) * 5.0, u(rng) * 1.5);
    solids.push_back({lo, lo + Vec3(0.3 + u(rng) * 2.0, 0.3 + u(rng) * 2.0, 0.2 + u(rng) * 1.2)});
    const Vec3 hl(u(rng) * 5.0, u(rng) * 5.0, u(rng) * 1.5);
    holes.push_back({hl, hl + Vec3(0.05 + u(rng) * 0.6, 0.05 + u(rng) * 0.6, 0.05 + u(rng) * 0.6)});
  }
  const Box3 cup{Vec3(3.0, 0.5, 0.0), Vec3(4.6, 2.1, 1.4)},
      cup_inside{Vec3(3.2, 0.7, 0.2), Vec3(4.4, 1.9, 2.0)};
  const Box3 all{Vec3(0, 0, 0), Vec3(7.5, 7.5, 3.0)};
  const auto part = [&](const Vec3& c) {
    bool in = cup.contains(c) && !cup_inside.contains(c);
    for (const Box3& b : solids) in = in || b.contains(c);
    for (const Box3& h : holes) in = in && !h.contains(c);
    return in;
  };
  const VoxelGrid padded = voxelise(0.05, all, part);
  const VoxelGrid shifted =
      voxelise(0.05, all, part, Feature::outer_perimeter, Vec3(0.0, -0.3, 0.0));
  // With a groove depth, what the seal closed opens again to that many 6-connected steps
  // through empty voxels from the outside found (0.25 mm: 5 steps; 0.45 mm: 9, past a block;
  // 0.6 mm: 12, with r = 5 the filled volume reaches 17 voxels, past two blocks).
  const std::vector<std::tuple<const VoxelGrid*, double, double>> cases{
      {&padded, 0.1, 0.0},   {&padded, 0.0, 0.0},    {&padded, 0.25, 0.0},
      {&padded, 0.95, 0.0},  {&shifted, 0.1, 0.0},   {&shifted, 1.75, 0.0},
      {&padded, 0.25, 0.25}, {&shifted, 0.95, 0.45}, {&padded, 0.5, 0.6}};
  for (const auto& [grid_of_case, seal_mm, groove_mm] : cases) {
    const VoxelGrid& grid = *grid_of_case;
    const DepositSurface s = extract_outer_surface(grid, all, seal_mm, groove_mm);
    const int nx = s.dims.x(), ny = s.dims.y(), nz = s.dims.z();
    ASSERT_GT(ny, 64);  // many blocks
    const int r = static_cast<int>(std::floor(seal_mm / 0.1 + 1e-9));
    const auto at = [&](int x, int y, int z) {
      return (static_cast<std::size_t>(y) * nx + x) * static_cast<std::size_t>(nz) + z;
    };
    const auto interior = [&](int x, int y, int z) {
      return x > 0 && y > 0 && z > 0 && x < nx - 1 && y < ny - 1 && z < nz - 1;
    };
    // A cube of 2r + 1 voxels, clipped to the region, as three segments: along z, x, then y.
    const auto dilated = [&](const std::vector<std::uint8_t>& in) {
      std::vector<std::uint8_t> a = in;
      for (int axis = 0; axis < 3 && r > 0; ++axis) {
        std::vector<std::uint8_t> b(a.size(), 0);
        for (int y = 0; y < ny; ++y)
          for (int x = 0; x < nx; ++x)
            for (int z = 0; z < nz; ++z) {
              if (!a[at(x, y, z)]) continue;
              for (int d = -r; d <= r; ++d) {
                const int xx = x + (axis == 1 ? d : 0), yy = y + (axis == 2 ? d : 0),
                          zz = z + (axis == 0 ? d : 0);
                if (xx >= 0 && yy >= 0 && zz >= 0 && xx < nx && yy < ny && zz < nz)
                  b[at(xx, yy, zz)] = 1;
              }
            }
        a.swap(b);
      }
      return a;
    };
    std::vector<std::uint8_t> occ(static_cast<std::size_t>(nx) * ny * nz, 0);
    std::size_t occupied = 0;
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (int z = 0; z < nz; ++z) {
          const VoxelKey k{s.origin_key.x + x, s.origin_key.y + y, s.origin_key.z + z};
          occ[at(x, y, z)] = interior(x, y, z) && grid.occupied(k) ? 1 : 0;
          occupied += occ[at(x, y, z)];
        }
    EXPECT_EQ(s.occupied_voxels, occupied);
    std::vector<std::uint8_t> blocked = dilated(occ);
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (int z = 0; z < nz; ++z)
          if (!interior(x, y, z)) blocked[at(x, y, z)] = 0;
    std::vector<std::uint8_t> outside(blocked.size(), 0);
    std::vector<std::array<int, 3>> stack;
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (int z = 0; z < nz; ++z)
          if (!interior(x, y, z)) {
            outside[at(x, y, z)] = 1;
            stack.push_back({x, y, z});
          }
    while (!stack.empty()) {
      const auto [x, y, z] = stack.back();
      stack.pop_back();
      const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                            {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
      for (const auto& n : nb) {
        if (n[0] < 0 || n[1] < 0 || n[2] < 0 || n[0] >= nx || n[1] >= ny || n[2] >= nz) continue;
        const std::size_t i = at(n[0], n[1], n[2]);
        if (outside[i] || blocked[i]) continue;
        outside[i] = 1;
        stack.push_back({n[0], n[1], n[2]});
      }
    }
    std::vector<std::uint8_t> out_dilated = dilated(outside);
    const int reopen = r > 0 ? static_cast<int>(std::floor(groove_mm / 0.05 + 1e-9)) : 0;
    for (int step = 0; step < reopen; ++step) {
      std::vector<std::uint8_t> grown = out_dilated;
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x)
          for (int z = 0; z < nz; ++z) {
            const std::size_t i = at(x, y, z);
            if (occ[i] || grown[i]) continue;
            const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                                  {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
            for (const auto& n : nb)
              if (n[0] >= 0 && n[1] >= 0 && n[2] >= 0 && n[0] < nx && n[1] < ny && n[2] < nz &&
                  out_dilated[at(n[0], n[1], n[2])] && !occ[at(n[0], n[1], n[2])])
                grown[i] = 1;
          }
      out_dilated.swap(grown);
    }
    std::vector<std::uint8_t> filled(occ.size());
    std::size_t n_filled = 0, mismatches = 0;
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x)
        for (int z = 0; z < nz; ++z) {
          const std::size_t i = at(x, y, z);
          filled[i] = (out_dilated[i] && !occ[i]) ? 0 : 1;
          n_filled += filled[i];
          const Vec3 c = s.origin_mm + s.voxel_mm * Vec3(x + 0.5, y + 0.5, z + 0.5);
          mismatches += s.filled(c) != (filled[i] != 0) ? 1 : 0;
        }
    EXPECT_EQ(mismatches, 0U) << "seal " << seal_mm;
    EXPECT_EQ(s.filled_voxels, n_filled);
    // Faces, in the surface's order: by grid block (y, x, z), by 4^3 cell of the block (its y,
    // x and z halves), then voxel rows by y then x, voxels by z, -x +x -y +y -z +z.
    std::vector<std::pair<VoxelKey, int>> faces;
    for (int y = 1; y < ny - 1; ++y)
      for (int x = 1; x < nx - 1; ++x)
        for (int z = 0; z < nz; ++z) {
          if (!(filled[at(x, y, z)] && occ[at(x, y, z)])) continue;
          const bool open[6] = {
              !filled[at(x - 1, y, z)],           !filled[at(x + 1, y, z)],
              !filled[at(x, y - 1, z)],           !filled[at(x, y + 1, z)],
              z == 0 || !filled[at(x, y, z - 1)], z == nz - 1 || !filled[at(x, y, z + 1)]};
          for (int k = 0; k < 6; ++k)
            if (open[k])
              faces.push_back(
                  {VoxelKey{s.origin_key.x + x, s.origin_key.y + y, s.origin_key.z + z}, k});
        }
    const auto cell_rank = [](const VoxelKey& k) {  // keys may be negative: >> is the floor
      return std::array<int, 6>{k.y >> 3,       k.x >> 3,       k.z >> 3,
                                (k.y >> 2) & 1, (k.x >> 2) & 1, (k.z >> 2) & 1};
    };
    std::stable_sort(faces.begin(), faces.end(), [&](const auto& a, const auto& b) {
      return cell_rank(a.first) < cell_rank(b.first);
    });
    ASSERT_EQ(s.faces.size(), faces.size()) << "seal " << seal_mm;
    // The cell ranges: every face inside its cell's range, the ranges in order.
    ASSERT_EQ(s.face_cell_begin.size(), 8 * s.face_blocks.size() + 1);
    EXPECT_EQ(s.face_cell_begin.back(), s.faces.size());
    for (std::size_t k = 0; k < s.face_blocks.size(); ++k)
      for (std::size_t c = 0; c < 8; ++c)
        for (std::uint32_t f = s.face_cell_begin[8 * k + c]; f < s.face_cell_begin[8 * k + c + 1];
             ++f) {
          const VoxelKey& key = s.faces[f].voxel;
          const std::size_t block =
              (static_cast<std::size_t>((key.y >> 3) - s.filled_blocks_lo.y()) *
                   s.filled_blocks_dims.x() +
               static_cast<std::size_t>((key.x >> 3) - s.filled_blocks_lo.x())) *
                  s.filled_blocks_dims.z() +
              static_cast<std::size_t>((key.z >> 3) - s.filled_blocks_lo.z());
          ASSERT_EQ(block, s.face_blocks[k]) << f;
          ASSERT_EQ(static_cast<std::size_t>((((key.y >> 2) & 1) << 2) | (((key.x >> 2) & 1) << 1) |
                                             ((key.z >> 2) & 1)),
                    c)
              << f;
        }
    for (std::size_t i = 0; i < faces.size(); ++i) {
      ASSERT_EQ(s.faces[i].voxel, faces[i].first) << i;
      ASSERT_EQ(s.faces[i].axis, faces[i].second >> 1) << i;
      ASSERT_EQ(s.faces[i].side, (faces[i].second & 1) != 0 ? 1 : -1) << i;
      ASSERT_EQ(s.face_tags[i], grid.tag(faces[i].first).value()) << i;
    }
  }
}

TEST(DeviationSurface, SealingClosesPinholesButNotOpenings) {
  // A hollow 2 x 2 x 1 mm box (0.05 mm voxels, 0.2 mm walls) whose wall has a slit: 1 voxel
  // wide (and 2 high), sealed at 0.2 mm (gaps up to 4 voxels), so the cavity stays inside;
  // a 0.5 x 0.4 mm window is an opening and the cavity's walls become surface.
  const Box3 outer{Vec3(0, 0, 0), Vec3(2, 2, 1)};
  const Box3 cavity{Vec3(0.2, 0.2, 0.2), Vec3(1.8, 1.8, 0.8)};
  for (const double slit_mm : {0.05, 0.5}) {
    const double half_height = slit_mm < 0.2 ? 0.05 : 0.2;
    const Box3 slit{Vec3(0.9, -1, 0.5 - half_height), Vec3(0.9 + slit_mm, 0.3, 0.5 + half_height)};
    const VoxelGrid grid = voxelise(
        0.05, outer,
        [&](const Vec3& c) {
          return outer.contains(c) && !cavity.contains(c) && !slit.contains(c);
        },
        Feature::outer_perimeter, Vec3(1, 1, 1));
    const DepositSurface sealed = extract_outer_surface(grid, outer, 0.2);
    const DepositSurface open = extract_outer_surface(grid, outer, 0.0);
    // Unsealed, the slit always lets the outside into the cavity.
    EXPECT_FALSE(open.filled(Vec3(1, 1, 0.5)));
    if (slit_mm < 0.2) {
      EXPECT_GT(open.faces.size(), sealed.faces.size());
      EXPECT_TRUE(sealed.filled(Vec3(1, 1, 0.5))) << slit_mm;
      // Only the outer box and the slit's mouth: no face inside the cavity's box.
      for (const Vec3& c : sealed.face_centers_mm())
        EXPECT_FALSE(cavity.contains(c, 1e-6)) << c.transpose();
    } else {
      // An opening wider than the seal: the same surface as without sealing.
      EXPECT_FALSE(sealed.filled(Vec3(1, 1, 0.5))) << slit_mm;
      EXPECT_EQ(open.faces.size(), sealed.faces.size());
    }
  }
}

TEST(DeviationSurface, DistancesToTheDepositAreTheNearestFaceByBruteForce) {
  // A lumpy deposit (a block with a bump, a notch and a through hole) and points around,
  // inside and far from it: the bucket search must give
  // the minimum over every face, to the bit, with ties on the lowest face index.
  const Box3 block{Vec3(0, 0, 0), Vec3(1.6, 1.2, 0.8)};
  const Box3 bump{Vec3(0.3, 0.3, 0.8), Vec3(0.7, 0.6, 1.1)};
  const Box3 notch{Vec3(1.0, -1, 0.4), Vec3(1.3, 0.5, 1)};
  const Box3 hole{Vec3(0.9, 0.8, -1), Vec3(1.1, 1.0, 2)};
  const VoxelGrid grid = voxelise(0.05, block, [&](const Vec3& c) {
    return (block.contains(c) || bump.contains(c)) && !notch.contains(c) && !hole.contains(c);
  });
  const Box3 region{Vec3(-0.5, -0.5, -0.5), Vec3(2.1, 1.7, 1.6)};
  const DepositSurface s = extract_outer_surface(grid, region, 0.2);
  ASSERT_GT(s.faces.size(), 1000U);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ux(-0.6, 2.2), uy(-0.6, 1.8), uz(-0.6, 1.7);
  std::vector<Vec3> points;
  for (int i = 0; i < 600; ++i) points.emplace_back(ux(rng), uy(rng), uz(rng));
  points.emplace_back(4, 5, 6);         // far outside the region
  points.push_back(s.face_center(17));  // on a face (distance 0)
  points.emplace_back(0.4, 0.2, 0.4);   // deep inside
  const double half = 0.025;
  std::vector<double> d;
  std::vector<std::uint32_t> nearest;
  detail::distances_to_deposit_with(s, points, d, &nearest);
  ASSERT_EQ(d.size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    double best = std::numeric_limits<double>::infinity();
    std::uint32_t best_face = 0;
    for (std::size_t f = 0; f < s.faces.size(); ++f) {
      const Vec3 c = s.face_center(f);
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double e = std::max(0.0, std::abs(p[a] - c[a]) - (a == s.faces[f].axis ? 0.0 : half));
        d2 += e * e;
      }
      if (d2 < best) {
        best = d2;
        best_face = static_cast<std::uint32_t>(f);
      }
    }
    const double expected = s.filled(p) ? std::sqrt(best) : -std::sqrt(best);
    EXPECT_EQ(d[i], expected) << "point " << i;
    EXPECT_EQ(nearest[i], best_face) << "point " << i;
  }
  EXPECT_GT(d[points.size() - 1], 0.1);  // inside: positive, about 0.2 from the nearest side
  EXPECT_LT(d[points.size() - 3], -5.0);
  EXPECT_EQ(d[points.size() - 2], 0.0);
}

class DeviationKnownOffset : public ::testing::Test {
 protected:
  const Box3 box{Vec3(3, 2, 0), Vec3(13, 10, 6)};
  const Mesh mesh = make_box_mesh(box.min, box.max);
  static constexpr double kVoxel = 0.05;
};

TEST_F(DeviationKnownOffset, LargerDepositReadsPlusOffsetAwayFromEdges) {
  // Deposit: the box 0.1 mm larger on every side, voxelised on an unaligned grid.
  const Box3 outer{box.min - Vec3::Constant(0.1), box.max + Vec3::Constant(0.1)};
  const VoxelGrid grid = voxelise(kVoxel, box, [&](const Vec3& c) { return outer.contains(c); });
  DeviationSettings settings;
  settings.tolerance_mm = 0.2;
  settings.mesh_sample_spacing_mm = 0.1;
  const auto r = compute_deviation(mesh, grid, settings);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  ASSERT_GT(r->deposit_samples.size(), 50000U);
  ASSERT_GT(r->mesh_samples.size(), 30000U);
  const double half = kVoxel / 2 + 1e-9;
  // Mesh -> deposit: the nearest deposit face is always the parallel one, 0.1 mm out.
  for (const auto& s : r->mesh_samples)
    ASSERT_NEAR(s.distance_mm, 0.1, half) << s.position_mm.transpose();
  // Deposit -> mesh: 0.1 mm except along the deposit's sharp edges, where the closest point
  // of the mesh is its edge, up to sqrt(3) * 0.1 mm away.
  std::size_t checked = 0;
  for (const auto& s : r->deposit_samples) {
    if (near_edge(s.position_mm, outer, 0.15)) {
      ASSERT_GE(s.distance_mm, 0.1 - half);
      ASSERT_LE(s.distance_mm, (0.1 + half) * std::sqrt(3.0));
      continue;
    }
    ++checked;
    ASSERT_NEAR(s.distance_mm, 0.1, half) << s.position_mm.transpose();
  }
  EXPECT_GT(checked, 50000U);
  EXPECT_NEAR(r->deposit_to_mesh.p50_abs_mm, 0.1, 0.01);
  EXPECT_NEAR(r->mesh_to_deposit.mean_mm, 0.1, 0.01);
  EXPECT_EQ(r->mesh_to_deposit.within_tolerance_pct, 100.0);
  EXPECT_TRUE(r->regions.empty());
  // Volumes: 10.2 x 8.2 x 6.2 within voxelisation noise; the mesh exactly.
  EXPECT_NEAR(r->deposit_volume_mm3, 10.2 * 8.2 * 6.2, 0.01 * 10.2 * 8.2 * 6.2);
  EXPECT_NEAR(r->mesh_volume_mm3, 480.0, 1e-9);
  // Vertices are the box's corners: the deposit's corner is 0.1 mm out on each axis.
  ASSERT_EQ(r->vertex_deviation_mm.size(), mesh.vertices_mm.size());
  for (const double d : r->vertex_deviation_mm) EXPECT_NEAR(d, 0.1, half);
  // Per-layer stats exist for every 0.2 mm layer of the part.
  EXPECT_GE(r->per_layer.size(), 30U);
}

TEST_F(DeviationKnownOffset, RoundedOffsetStaysWithinTheStaircaseBound) {
  // Every point within 0.1 mm of the box: the true offset surface, rounded at edges. On
  // curved parts the voxel staircase deviates by up to half a voxel's diagonal.
  const VoxelGrid grid =
      voxelise(kVoxel, box, [&](const Vec3& c) { return box_distance(c, box) <= 0.1; });
  DeviationSettings settings;
  settings.mesh_sample_spacing_mm = 0.1;
  const auto r = compute_deviation(mesh, grid, settings);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const double bound = kVoxel * std::sqrt(3.0) / 2 + 1e-9;
  for (const auto& s : r->deposit_samples) ASSERT_NEAR(s.distance_mm, 0.1, bound);
  for (const auto& s : r->mesh_samples) ASSERT_NEAR(s.distance_mm, 0.1, bound);
  EXPECT_NEAR(r->mesh_to_deposit.mean_mm, 0.1, 0.005);
  const double grown = 480 + 0.1 * 2 * (80 + 60 + 48) +
                       std::numbers::pi * 0.01 / 4 * 4 * (10 + 8 + 6) +
                       4.0 / 3 * std::numbers::pi * 0.001;
  EXPECT_NEAR(r->deposit_volume_mm3, grown, 0.01 * grown);
}

TEST_F(DeviationKnownOffset, SmallerDepositReadsMinusOffsetAwayFromEdges) {
  Box3 inner{box.min + Vec3::Constant(0.1), box.max - Vec3::Constant(0.1)};
  const VoxelGrid grid = voxelise(kVoxel, box, [&](const Vec3& c) { return inner.contains(c); });
  DeviationSettings settings;
  settings.tolerance_mm = 0.3;
  settings.mesh_sample_spacing_mm = 0.1;
  const auto r = compute_deviation(mesh, grid, settings);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const double half = kVoxel / 2 + 1e-9;
  std::size_t checked = 0;
  for (const auto& s : r->deposit_samples)
    ASSERT_NEAR(s.distance_mm, -0.1, half) << s.position_mm.transpose();
  for (const auto& s : r->mesh_samples) {
    // At the mesh's edges the nearest deposit is the shrunken box's edge, sqrt(2) * 0.1 away.
    if (near_edge(s.position_mm, box, 0.15)) {
      ASSERT_LE(s.distance_mm, -0.1 + half);
      ASSERT_GE(s.distance_mm, -(0.1 + half) * std::sqrt(3.0));
      continue;
    }
    ++checked;
    ASSERT_NEAR(s.distance_mm, -0.1, half) << s.position_mm.transpose();
  }
  EXPECT_GT(checked, 25000U);
  EXPECT_NEAR(r->deposit_to_mesh.mean_mm, -0.1, 0.01);
  EXPECT_NEAR(r->mesh_to_deposit.p50_abs_mm, 0.1, 0.01);
}

/// A closed UV sphere of radius r (outward CCW).
Mesh uv_sphere(double r, int stacks, int slices, const Vec3& c) {
  Mesh m;
  m.vertices_mm.push_back(c + Vec3(0, 0, -r));
  for (int i = 1; i < stacks; ++i) {
    const double phi = std::numbers::pi * i / stacks - std::numbers::pi / 2;
    for (int j = 0; j < slices; ++j) {
      const double th = 2 * std::numbers::pi * j / slices;
      m.vertices_mm.push_back(
          c + r * Vec3(std::cos(phi) * std::cos(th), std::cos(phi) * std::sin(th), std::sin(phi)));
    }
  }
  m.vertices_mm.push_back(c + Vec3(0, 0, r));
  const auto ring = [&](int i, int j) {
    return static_cast<std::uint32_t>(1 + (i - 1) * slices + (j % slices));
  };
  const auto top = static_cast<std::uint32_t>(m.vertices_mm.size() - 1);
  for (int j = 0; j < slices; ++j) m.triangles.push_back({0, ring(1, j + 1), ring(1, j)});
  for (int i = 1; i < stacks - 1; ++i)
    for (int j = 0; j < slices; ++j) {
      m.triangles.push_back({ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)});
      m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)});
    }
  for (int j = 0; j < slices; ++j)
    m.triangles.push_back({ring(stacks - 1, j), ring(stacks - 1, j + 1), top});
  return m;
}

TEST(DeviationMeshDistance, EmbreeMatchesCgalReferenceAndSignsAreRight) {
  const Mesh sphere = uv_sphere(5.0, 24, 48, Vec3(1, 2, 3));
  ASSERT_GT(signed_volume_mm3(sphere), 0);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-7.5, 7.5);
  std::vector<Vec3> points;
  for (int i = 0; i < 4000; ++i) points.emplace_back(Vec3(1, 2, 3) + Vec3(u(rng), u(rng), u(rng)));
  // Points on vertices and edges too, where the pseudo-normal choice matters.
  for (std::size_t v = 0; v < sphere.vertices_mm.size(); v += 7)
    points.push_back(sphere.vertices_mm[v] +
                     0.2 * (sphere.vertices_mm[v] - Vec3(1, 2, 3)).normalized());
  const auto ours = signed_distances_to_mesh(sphere, points);
  ASSERT_TRUE(ours.ok());
  const auto ref = reference_distances_cgal(sphere, points);
  ASSERT_EQ(ref.size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(std::abs((*ours)[i]), ref[i], 1e-9 * std::max(1.0, ref[i])) << i;
    const bool inside =
        (points[i] - Vec3(1, 2, 3)).norm() < 5.0 * std::cos(std::numbers::pi / 24) - 1e-6;
    const bool outside = (points[i] - Vec3(1, 2, 3)).norm() > 5.0 + 1e-6;
    if (inside) {
      EXPECT_LT((*ours)[i], 0) << i;
    }
    if (outside) {
      EXPECT_GT((*ours)[i], 0) << i;
    }
  }
}

TEST(DeviationMeshDistance, OpenMeshFallsBackToRayParity) {
  // A sphere with one triangle missing: points just outside and inside its open edges get
  // their sign from the ray-parity vote, and it is right.
  Mesh sphere = uv_sphere(5.0, 24, 48, Vec3::Zero());
  const std::size_t hole = 24 * 48;  // a triangle near the equator
  const auto tri = sphere.triangles[hole];
  sphere.triangles.erase(sphere.triangles.begin() + static_cast<long>(hole));
  std::vector<Vec3> points;
  for (int k = 0; k < 3; ++k) {
    const Vec3 mid = 0.5 * (sphere.vertices_mm[tri[static_cast<std::size_t>(k)]] +
                            sphere.vertices_mm[tri[static_cast<std::size_t>((k + 1) % 3)]]);
    points.push_back(mid * (1.0 + 0.3 / mid.norm()));
    points.push_back(mid * (1.0 - 0.3 / mid.norm()));
  }
  const auto d = signed_distances_to_mesh(sphere, points);
  ASSERT_TRUE(d.ok());
  const auto ref = reference_distances_cgal(sphere, points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(std::abs((*d)[i]), ref[i], 1e-9);
    if (i % 2 == 0) {
      EXPECT_GT((*d)[i], 0) << i;
    } else {
      EXPECT_LT((*d)[i], 0) << i;
    }
  }
}

/// A square loop of extrusion moves (one per side) at height z.
void add_loop(std::vector<Move>& moves, const Vec3& lo, const Vec3& hi, double z, Feature f,
              long& line) {
  const std::array<Vec3, 4> c{Vec3(lo.x(), lo.y(), z), Vec3(hi.x(), lo.y(), z),
                              Vec3(hi.x(), hi.y(), z), Vec3(lo.x(), hi.y(), z)};
  for (int i = 0; i < 4; ++i) {
    Move m;
    m.start_mm = c[static_cast<std::size_t>(i)];
    m.end_mm = c[static_cast<std::size_t>((i + 1) % 4)];
    m.e_mm = 0.05 * m.xy_length_mm();
    m.kind = MoveKind::extrude;
    m.feature = f;
    m.line = line++;
    m.layer = static_cast<int>(z / 0.2);
    moves.push_back(m);
  }
}

TEST(DeviationRegistration, RecoversTheSlicersPlacementWithAndWithoutTags) {
  // The mesh as designed: a 20 x 12 x 8 box around (-3, 4, 5).
  const Mesh mesh = make_box_mesh(Vec3(-13, -2, 1), Vec3(7, 10, 9));
  // The slicer centred it at (117.3, 95.2): the part's loops span that box (centre lines),
  // with a skirt 6 mm out, a purge line along the bed's edge and support beside it.
  const Vec3 centre(117.3, 95.2, 0);
  for (const bool tagged : {true, false}) {
    std::vector<Move> moves;
    long line = 1;
    Move purge;
    purge.start_mm = Vec3(0.1, 20, 0.3);
    purge.end_mm = Vec3(0.1, 200, 0.3);
    purge.e_mm = 15;
    purge.kind = MoveKind::extrude;
    purge.feature = tagged ? Feature::custom : Feature::unknown;
    purge.line = line++;
    moves.push_back(purge);
    add_loop(moves, centre - Vec3(16, 12, 0), centre + Vec3(16, 12, 0), 0.2,
             tagged ? Feature::skirt : Feature::unknown, line);
    for (int layer = 1; layer <= 40; ++layer)
      add_loop(moves, centre - Vec3(9.8, 5.8, 0), centre + Vec3(9.8, 5.8, 0), 0.2 * layer,
               tagged ? Feature::outer_perimeter : Feature::unknown, line);
    const PartExtent part = find_part_extent(moves);
    EXPECT_EQ(part.method, tagged ? "tags" : "connectivity");
    EXPECT_EQ(part.moves, 160U);
    const Vec3 offset = registration_offset(mesh, part);
    const Mesh placed = translated(mesh, offset);
    const Box3 pb = bounding_box(placed);
    EXPECT_NEAR(pb.center().x(), 117.3, 1e-9);
    EXPECT_NEAR(pb.center().y(), 95.2, 1e-9);
    EXPECT_NEAR(pb.min.z(), 0.0, 1e-12);
    EXPECT_NEAR(offset.x(), 117.3 + 3, 1e-9);
    EXPECT_NEAR(offset.y(), 95.2 - 4, 1e-9);
    EXPECT_NEAR(offset.z(), -1, 1e-12);
  }
}

TEST(DeviationRegions, MissingWallAndExcessBlobAreFoundWhereTheyAre) {
  // Design: a 10 mm block and a separate 0.8 mm wall beside it. Deposit: the block only, plus
  // a 1 mm blob stuck on the block's +y face.
  const Box3 block{Vec3(0, 0, 0), Vec3(10, 10, 10)};
  const Box3 wall{Vec3(12, 0, 0), Vec3(12.8, 10, 10)};
  const Box3 blob{Vec3(4, 10, 4), Vec3(5, 11, 5)};
  Mesh mesh = make_box_mesh(block.min, block.max);
  const Mesh w = make_box_mesh(wall.min, wall.max);
  for (const auto& t : w.triangles) mesh.triangles.push_back({t[0] + 8, t[1] + 8, t[2] + 8});
  mesh.vertices_mm.insert(mesh.vertices_mm.end(), w.vertices_mm.begin(), w.vertices_mm.end());
  Box3 all = block;
  all.extend(wall);
  const VoxelGrid grid =
      voxelise(0.1, all, [&](const Vec3& c) { return block.contains(c) || blob.contains(c); });
  DeviationSettings settings;
  settings.tolerance_mm = 0.3;
  settings.mesh_sample_spacing_mm = 0.1;
  settings.cluster_radius_mm = 0.3;
  const auto r = compute_deviation(mesh, grid, settings);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  ASSERT_EQ(r->regions.size(), 2U);
  const DeviationRegion& missing = r->regions[0];
  EXPECT_EQ(missing.kind, RegionKind::missing);
  EXPECT_TRUE(missing.bbox_mm.contains(wall.min + Vec3(0.05, 0.05, 0.05), 0.0));
  EXPECT_NEAR(missing.bbox_mm.min.x(), 12.0, 0.05);
  EXPECT_NEAR(missing.bbox_mm.max.x(), 12.8, 0.05);
  EXPECT_NEAR(missing.bbox_mm.max.z(), 10.0, 0.05);
  // All of the wall's surface: 2 * (0.8 * 10 + 10 * 10 + 0.8 * 10) = 232 mm^2.
  EXPECT_NEAR(missing.area_mm2, 232.0, 0.05 * 232.0);
  EXPECT_LT(missing.worst_mm, -2.0);
  EXPECT_EQ(missing.layer_min, 0);
  EXPECT_EQ(missing.layer_max, 49);
  EXPECT_FALSE(missing.gcode_lines.empty());
  const DeviationRegion& excess = r->regions[1];
  EXPECT_EQ(excess.kind, RegionKind::excess);
  EXPECT_TRUE(blob.contains(excess.worst_position_mm, 0.051));
  EXPECT_NEAR(excess.worst_mm, 1.0, 0.06);
  EXPECT_EQ(excess.layer_min, 20);
  EXPECT_EQ(excess.layer_max, 24);
  EXPECT_EQ(excess.gcode_lines.front(), 1020);
}

TEST(DeviationPly, MeshWithDeviationScalarAndColour) {
  const Mesh cube = test::make_cube_mm(1.0);
  std::vector<double> dev(cube.vertices_mm.size(), 0.0);
  dev[0] = -0.5;
  dev[1] = 0.5;
  const std::string ply = deviation_ply(cube, dev, 0.1);
  const auto header_end = ply.find("end_header\n");
  ASSERT_NE(header_end, std::string::npos);
  const std::string header = ply.substr(0, header_end);
  EXPECT_NE(header.find("element vertex 8"), std::string::npos);
  EXPECT_NE(header.find("property float quality"), std::string::npos);
  EXPECT_NE(header.find("property uchar red"), std::string::npos);
  EXPECT_NE(header.find("element face 12"), std::string::npos);
  // 8 vertices * (12 + 3 + 8) bytes + 12 faces * 13 bytes.
  EXPECT_EQ(ply.size() - header_end - 11, 8U * 23U + 12U * 13U);
  float q0 = 0;
  std::memcpy(&q0, ply.data() + header_end + 11 + 15, 4);
  EXPECT_FLOAT_EQ(q0, -0.5F);
  const auto red0 = static_cast<unsigned char>(ply[header_end + 11 + 12]);
  const auto blue0 = static_cast<unsigned char>(ply[header_end + 11 + 14]);
  EXPECT_GT(blue0, red0);  // deficit is blue
}

}  // namespace
}  // namespace printtwin
