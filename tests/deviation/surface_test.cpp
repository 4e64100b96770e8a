// The deposit's outer surface with layer lines: the seal that keeps grooves, the sub-voxel
// placement on the beads and the area-weighted figures, on beads laid in code with known
// analytic answers.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>

#include "deposit/deposit_test_support.hpp"
#include "deviation/outer_surface.hpp"
#include "deviation/surface_internal.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/mesh.hpp"

namespace printtwin {
namespace {

/// A square tube: the box [lo, lo + side]^2 x [0, height] minus [lo + wall, lo + side - wall]^2,
/// a closed solid with outward normals (its inner faces face the hole).
Mesh make_square_tube(double lo, double side, double wall, double height) {
  // The outer corners are rounded with radius wall / 2 about the loop's corners, as a
  // nozzle leaves them (the deposit joins sharp turns round); the inner corners are sharp.
  constexpr int kArc = 16;  // segments per outer corner: chord error 0.0003 mm at r = 0.225
  const double r = 0.5 * wall, in_lo = lo + wall, in_hi = lo + side - wall;
  const std::array<std::array<double, 2>, 4> centre{{{lo + r, lo + r},
                                                     {lo + side - r, lo + r},
                                                     {lo + side - r, lo + side - r},
                                                     {lo + r, lo + side - r}}};
  const std::array<std::array<double, 2>, 4> inner{
      {{in_lo, in_lo}, {in_hi, in_lo}, {in_hi, in_hi}, {in_lo, in_hi}}};
  Mesh m;
  std::vector<std::array<double, 2>> outer;  // counter-clockwise, kArc + 1 points per corner
  for (int k = 0; k < 4; ++k)
    for (int a = 0; a <= kArc; ++a) {
      const double t =
          std::numbers::pi * (1.25 + 0.5 * k) + 0.5 * std::numbers::pi * (a - 0.5 * kArc) / kArc;
      outer.push_back({centre[k][0] + r * std::cos(t), centre[k][1] + r * std::sin(t)});
    }
  const auto n_out = static_cast<std::uint32_t>(outer.size());
  // Vertices: outer ring bottom, outer ring top, inner square bottom, inner square top.
  for (const double z : {0.0, height})
    for (const auto& c : outer) m.vertices_mm.emplace_back(c[0], c[1], z);
  for (const double z : {0.0, height})
    for (const auto& c : inner) m.vertices_mm.emplace_back(c[0], c[1], z);
  const auto o = [n_out](std::uint32_t i, std::uint32_t top) { return top * n_out + i % n_out; };
  const auto q = [n_out](std::uint32_t k, std::uint32_t top) {
    return 2 * n_out + top * 4 + k % 4;
  };
  const auto quad = [&m](std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
    m.triangles.push_back({a, b, c});
    m.triangles.push_back({a, c, d});
  };
  for (std::uint32_t i = 0; i < n_out; ++i) quad(o(i, 0), o(i + 1, 0), o(i + 1, 1), o(i, 1));
  for (std::uint32_t k = 0; k < 4; ++k) {
    quad(q(k + 1, 0), q(k, 0), q(k, 1), q(k + 1, 1));  // inner wall, facing the hole
    const std::uint32_t first = k * (kArc + 1), last = first + kArc;
    for (std::uint32_t i = first; i < last; ++i) {  // the corner's fan to the inner corner
      m.triangles.push_back({o(i, 1), o(i + 1, 1), q(k, 1)});  // top, facing up
      m.triangles.push_back({o(i + 1, 0), o(i, 0), q(k, 0)});  // bottom, facing down
    }
    // The straight side from this corner's last arc point to the next corner's first.
    quad(o(last, 1), o(last + 1, 1), q(k + 1, 1), q(k, 1));
    quad(o(last + 1, 0), o(last, 0), q(k, 0), q(k + 1, 0));
  }
  return m;
}

/// A wall of `layers` square loops of beads (width w, height h) whose outer and inner edges
/// touch the faces of a square tube of wall w: [lo, lo + side]^2 x [0, layers h] minus the
/// hole w inside it.
struct Wall {
  std::vector<Move> moves;
  Mesh mesh;
  DepositResult deposit;
};
Wall lay_wall(double h, double w, int layers, double side = 10.0) {
  const PrinterProfile profile = ender3_marlin2();
  test::BeadWriter bw(profile);
  bw.feature = Feature::outer_perimeter;
  const double lo = 20.0, in = 0.5 * w;
  for (int l = 0; l < layers; ++l) {
    bw.layer = l;
    const double z = h * (l + 1);
    // The loop starts and ends mid-side: the seam is not at a corner.
    const double a = lo + in, b = lo + side - in, mid = lo + 0.5 * side;
    bw.travel({mid, a, z});
    for (const Vec3& to :
         {Vec3(b, a, z), Vec3(b, b, z), Vec3(a, b, z), Vec3(a, a, z), Vec3(mid, a, z)}) {
      Move& m = bw.push(to, test::bead_e_mm(w, h, (to - bw.pos).head<2>().norm(), profile),
                        MoveKind::extrude);
      m.height_hint_mm = static_cast<float>(h);
    }
  }
  Wall wall;
  wall.moves = bw.moves;
  wall.mesh = make_square_tube(lo, side, w, h * layers);
  wall.deposit = test::deposit_at(wall.moves, profile);
  return wall;
}

/// The mean of a figure over the middle half of the layers.
template <class Get>
double middle_mean(const DeviationResult& r, const Get& get) {
  const std::size_t n = r.per_layer.size();
  double sum = 0;
  int k = 0;
  for (std::size_t i = n / 4; i < 3 * n / 4; ++i, ++k) sum += get(r.per_layer[i]);
  return k > 0 ? sum / k : 0;
}

/// The middle layers' figures of a wall of stadium beads whose outer edge touches the design
/// plane, within 10 % of the analytic ones: over one layer's round side (radius R = h / 2,
/// area-weighted), the surface lies 0.363 R inside the plane on average with an RMS of
/// 0.476 R; from the plane to the surface the RMS is 0.194 R.
void expect_wall_figures(const DeviationResult& r, double h) {
  const double R = 0.5 * h;
  const double rms =
      middle_mean(r, [](const LayerDeviation& l) { return l.deposit_to_mesh.rms_mm; });
  const double mean =
      middle_mean(r, [](const LayerDeviation& l) { return l.deposit_to_mesh.mean_mm; });
  const double back =
      middle_mean(r, [](const LayerDeviation& l) { return l.mesh_to_deposit.rms_mm; });
  EXPECT_NEAR(rms / (0.476 * R), 1.0, 0.10) << "h " << h << " rms " << rms;
  EXPECT_NEAR(mean / (-0.363 * R), 1.0, 0.10) << "h " << h << " mean " << mean;
  EXPECT_NEAR(back / (0.194 * R), 1.0, 0.10) << "h " << h << " mesh->deposit rms " << back;
}

TEST(SurfaceBeads, DistanceToAStadiumBead) {
  // A bead along +x, tip at z = 1, w = 0.5, h = 0.2: its core is the ribbon |y| <= 0.15 at
  // z = 0.9; the surface is 0.1 from it.
  const SurfaceBead b{Vec3(0, 0, 1), Vec3(10, 0, 1), 0.5F, 0.2F, 7};
  Vec3 c;
  EXPECT_NEAR(detail::bead_closest(b, Vec3(5, 0, 1.3), c), 0.3, 1e-6);     // above the flat top
  EXPECT_NEAR(detail::bead_closest(b, Vec3(5, 0.45, 0.9), c), 0.2, 1e-6);  // beside the round side
  EXPECT_NEAR(c.y(), 0.15, 1e-6);
  EXPECT_NEAR(detail::bead_closest(b, Vec3(5, 0, 0.9), c), -0.1, 1e-6);  // on the core: inside
  // The bead's side at 45 degrees up from its mid-height: exactly on the surface.
  const double s = 0.1 / std::numbers::sqrt2;
  EXPECT_NEAR(detail::bead_closest(b, Vec3(5, 0.15 + s, 0.9 + s), c), 0.0, 1e-6);
}

TEST(SurfaceBeads, BeadsFollowTheMovesWithTheStadiumWidth) {
  const Wall wall = lay_wall(0.2, 0.45, 3);
  const auto beads = surface_beads(wall.moves, ender3_marlin2());
  ASSERT_EQ(beads.size(), 15U);
  for (const SurfaceBead& b : beads) {
    EXPECT_NEAR(b.height_mm, 0.2, 1e-6);
    EXPECT_NEAR(b.width_mm, 0.45, 1e-4);
  }
  const auto [lo, hi] = detail::beads_of_line(beads, beads[5].line);
  EXPECT_EQ(lo, 5U);
  EXPECT_EQ(hi, 6U);
}

// The tube's inner and outer faces both touch the beads, so every wall point has the analytic
// answer; the deposit -> mesh points are laid on the beads' outlines down to the cusp between
// two layers (no voxel face reaches it), and mesh -> deposit measures to the beads' union.
TEST(SurfaceLayerLines, WallOfStackedBeadsGivesTheAnalyticFigures) {
  // Stadium beads whose outer edge touches the design plane: over one layer's round side
  // (radius R = h / 2, area-weighted), the surface lies 0.363 R inside the plane on average
  // with an RMS of 0.476 R; from the plane to the surface the RMS is 0.194 R.
  for (const double h : {0.1, 0.2, 0.3}) {
    const Wall wall = lay_wall(h, 0.45, static_cast<int>(std::lround(4.0 / h)));
    const auto beads = surface_beads(wall.moves, ender3_marlin2());
    DeviationSettings settings;
    auto r = compute_deviation(wall.mesh, wall.deposit.grid, settings, {}, beads);
    ASSERT_TRUE(r.ok());
    expect_wall_figures(*r, h);
  }
}

// At h = 0.1 a layer is two voxels high: the outermost column of voxels is only partly
// covered by the round side (a quarter disc of its square), so the deposit's jittered sample
// points leave about one voxel in five of it empty. Those pits are voxelisation, not print:
// the bead's outline is the surface there, and no deposit point lies deeper in the wall than
// the layer line's groove (R = h / 2) nor off the outline; the figures come within 3 %.
TEST(SurfaceLayerLines, VoxelPitsUnderTheOutlineAreNotSurface) {
  const double h = 0.1, R = 0.5 * h;
  const Wall wall = lay_wall(h, 0.45, 40);
  const auto beads = surface_beads(wall.moves, ender3_marlin2());
  DeviationSettings settings;
  auto r = compute_deviation(wall.mesh, wall.deposit.grid, settings, {}, beads);
  ASSERT_TRUE(r.ok());
  const DeviationSamples& ds = r->deposit_samples;
  std::size_t on_sides = 0;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const Vec3& p = ds.positions_mm[i];
    // The outer faces' straight parts (x or y = 20 or 30), away from the corners, mid-height.
    const double ex = std::min(std::abs(p.x() - 20.0), std::abs(p.x() - 30.0));
    const double ey = std::min(std::abs(p.y() - 20.0), std::abs(p.y() - 30.0));
    if (std::min(ex, ey) > 0.2 || std::max(ex, ey) < 1.0 || p.z() < 1.0 || p.z() > 3.0) continue;
    ++on_sides;
    double on = 1e9;
    for (const SurfaceBead& b : beads) {
      Vec3 core;
      on = std::min(on, std::abs(detail::bead_closest(b, p, core)));
    }
    EXPECT_LT(on, 1e-9) << "point off the outline " << p.transpose();
    EXPECT_GE(ds.distances_mm[i], -R - 1e-9) << "point " << p.transpose();
  }
  EXPECT_GT(on_sides, 1000U);
  const double rms =
      middle_mean(*r, [](const LayerDeviation& l) { return l.deposit_to_mesh.rms_mm; });
  const double mean =
      middle_mean(*r, [](const LayerDeviation& l) { return l.deposit_to_mesh.mean_mm; });
  const double back =
      middle_mean(*r, [](const LayerDeviation& l) { return l.mesh_to_deposit.rms_mm; });
  EXPECT_NEAR(rms / (0.476 * R), 1.0, 0.03) << "rms " << rms;
  EXPECT_NEAR(mean / (-0.363 * R), 1.0, 0.03) << "mean " << mean;
  EXPECT_NEAR(back / (0.194 * R), 1.0, 0.03) << "mesh->deposit rms " << back;
}

// Each deposit point on a bead's outline stands for its patch of the outline (cell length x
// length along the bead), also where one point stands for two rows along a straight bead: the
// points on a straight wall's outer round sides carry their area, pi R per layer of height
// h = 2 R, with about half the points of one per cell and row.
TEST(SurfaceLayerLines, OutlinePointsCarryTheirPatchArea) {
  const double h = 0.2, w = 0.45;
  const Wall wall = lay_wall(h, w, 20);
  const auto beads = surface_beads(wall.moves, ender3_marlin2());
  const DeviationSettings settings;
  const double v = wall.deposit.grid.voxel_mm();
  const Box3 region{Vec3(18, 18, -1), Vec3(32, 32, 5)};
  DepositSurface surface = extract_outer_surface(wall.deposit.grid, region, settings.seal_gap_mm,
                                                 settings.groove_depth_mm);
  place_on_beads(surface, beads, v);
  ASSERT_EQ(surface.points_mm.size(), surface.point_area_mm2.size());
  // The round sides of the face x = 30 (centre x = 30 - R), away from its corners, over the
  // ten layers from z = 1 to 3; the points on the outline (faces kept off it are not).
  const double length = 8.0, layers = 10;
  double area = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < surface.points_mm.size(); ++i) {
    const Vec3& p = surface.points_mm[i];
    if (p.x() < 30.0 - 0.5 * h - 1e-9 || p.y() < 21 || p.y() > 21 + length || p.z() < 1 ||
        p.z() > 1 + layers * h)
      continue;
    double on = 1e9;
    for (const SurfaceBead& b : beads) {
      Vec3 core;
      on = std::min(on, std::abs(detail::bead_closest(b, p, core)));
    }
    if (on > 1e-9) continue;
    area += surface.point_area_mm2[i];
    ++n;
  }
  const double expected = std::numbers::pi * 0.5 * h * length * layers;
  EXPECT_NEAR(area / expected, 1.0, 0.02) << "area " << area << " of " << n << " points";
  // At least 8 cells round a side, rows of two voxels.
  const double cells_x_rows = 8 * layers * length / (2 * v);
  EXPECT_LT(static_cast<double>(n), 0.75 * cells_x_rows) << n << " points";
  EXPECT_GT(static_cast<double>(n), 0.25 * cells_x_rows) << n << " points";
}

/// The square tube of make_square_tube with sharp outer corners too (a design a slicer's
/// loop cannot follow at its corners: the nozzle rounds them with the bead's half-width).
Mesh make_sharp_tube(double lo, double side, double wall, double height) {
  Mesh m;
  const double hi = lo + side, in_lo = lo + wall, in_hi = hi - wall;
  const std::array<std::array<double, 2>, 4> outer{{{lo, lo}, {hi, lo}, {hi, hi}, {lo, hi}}};
  const std::array<std::array<double, 2>, 4> inner{
      {{in_lo, in_lo}, {in_hi, in_lo}, {in_hi, in_hi}, {in_lo, in_hi}}};
  // Vertices: outer bottom 0-3, outer top 4-7, inner bottom 8-11, inner top 12-15.
  for (const auto* ring : {&outer, &inner})
    for (const double z : {0.0, height})
      for (const auto& c : *ring) m.vertices_mm.emplace_back(c[0], c[1], z);
  const auto quad = [&m](std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
    m.triangles.push_back({a, b, c});
    m.triangles.push_back({a, c, d});
  };
  for (std::uint32_t k = 0; k < 4; ++k) {
    const std::uint32_t j = (k + 1) % 4;
    quad(k, j, 4 + j, 4 + k);            // outer wall, facing out
    quad(8 + j, 8 + k, 12 + k, 12 + j);  // inner wall, facing the hole
    quad(4 + k, 4 + j, 12 + j, 12 + k);  // top
    quad(j, k, 8 + k, 8 + j);            // bottom
  }
  return m;
}

// At a design's sharp vertical edge the nozzle's round corner leaves the design's edge up to
// 0.41 w / 2 from the plastic: mesh -> deposit there is not the straight wall's layer line.
// The layer-line figures leave 0.3 mm round the design's sharp edges out, so they keep the
// analytic values at h = 0.1 on such a design; per_layer keeps every point and shows more.
TEST(SurfaceLayerLines, LayerLineFiguresLeaveTheSharpEdgesOut) {
  const double h = 0.1, R = 0.5 * h, w = 0.45;
  Wall wall = lay_wall(h, w, 40, 4.0);
  wall.mesh = make_sharp_tube(20.0, 4.0, w, h * 40);
  const auto beads = surface_beads(wall.moves, ender3_marlin2());
  DeviationSettings settings;
  auto r = compute_deviation(wall.mesh, wall.deposit.grid, settings, {}, beads);
  ASSERT_TRUE(r.ok());
  const double all =
      middle_mean(*r, [](const LayerDeviation& l) { return l.mesh_to_deposit.rms_mm; });
  const double walls = middle_mean(*r, [](const LayerDeviation& l) { return l.wall_rms_mm; });
  EXPECT_GT(all / (0.194 * R), 1.15) << "mesh->deposit rms, all points " << all;
  EXPECT_NEAR(r->wall_mesh_rms_mm / (0.194 * R), 1.0, 0.10) << "walls " << r->wall_mesh_rms_mm;
  EXPECT_NEAR(walls / (0.476 * R), 1.0, 0.10) << "deposit->mesh on walls " << walls;
  EXPECT_GT(r->wall_area_mm2, 0.0);
  // The same with the design in its own frame, placed by an offset: the edges move with it.
  const Vec3 offset(5.0, -3.0, 0.0);
  Mesh own = wall.mesh;
  for (Vec3& p : own.vertices_mm) p -= offset;
  auto target = DeviationTarget::build(own, settings, wall.deposit.grid.voxel_mm());
  ASSERT_TRUE(target.ok());
  auto placed = compute_deviation(*target, offset, wall.deposit.grid, settings, {}, beads);
  ASSERT_TRUE(placed.ok());
  EXPECT_NEAR(placed->wall_mesh_rms_mm, r->wall_mesh_rms_mm, 1e-6);
  EXPECT_NEAR(placed->wall_area_mm2, r->wall_area_mm2, 1e-6);
}

/// A square loop of beads per layer (width w, height h) whose outer edge touches the faces of
/// make_square_tube(lo, side, w, ...) at its straight sides: each layer's path starts at a
/// corner and stops `gap` short of it (a slicer's seam gap), so the seam is a path start and
/// a path end on a corner. Voxelised in code as the capped beads (a voxel is set where its
/// centre lies in a bead, tagged with the nearest bead's line): plastic that really ends round.
struct SeamLoop {
  std::vector<SurfaceBead> beads;
  Mesh mesh;
  VoxelGrid grid{0.05, Vec3::Zero(), Eigen::Vector3i(1, 1, 1)};
};
SeamLoop lay_seam_loop(double h, double w, int layers, double gap, double side = 10.0) {
  SeamLoop loop;
  const double lo = 20.0, a = lo + 0.5 * w, b = lo + side - 0.5 * w;
  for (int l = 0; l < layers; ++l) {
    const double z = h * (l + 1);
    const std::array<Vec3, 5> path{Vec3(a, a, z), Vec3(b, a, z), Vec3(b, b, z), Vec3(a, b, z),
                                   Vec3(a, a + gap, z)};
    for (std::uint32_t j = 0; j < 4; ++j)
      loop.beads.push_back({path[j], path[j + 1], static_cast<float>(w), static_cast<float>(h),
                            static_cast<std::uint32_t>(10 * l + j + 1)});
  }
  loop.mesh = make_square_tube(lo, side, w, h * layers);
  const double v = 0.05;
  const Vec3 origin(lo - 0.5, lo - 0.5, 0.0);
  const int n = static_cast<int>(std::lround((side + 1.0) / v));
  loop.grid = VoxelGrid(v, origin, Eigen::Vector3i(n, n, static_cast<int>(h * layers / v) + 2));
  for (int z = 0; z < loop.grid.dims().z(); ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const Vec3 c = loop.grid.center_mm({x, y, z});
        const int l = std::clamp(static_cast<int>(c.z() / h), 0, layers - 1);
        double best = 1e9;
        std::uint32_t line = 0;
        for (std::size_t k = 4 * static_cast<std::size_t>(l); k < 4 * (l + std::size_t{1}); ++k) {
          Vec3 core;
          const double d = detail::bead_closest(loop.beads[k], c, core);
          if (d < best) best = d, line = loop.beads[k].line;
        }
        if (best <= 0) loop.grid.set({x, y, z}, VoxelTag{line, l, Feature::outer_perimeter});
      }
  return loop;
}

TEST(SurfaceLayerLines, SeamOnACornerIsMeasuredOnTheRoundEnds) {
  // The seam's corner is a path's round start cap (the design's corner is round about the
  // same axis) and, 0.2 mm back, its round end: the deposit -> mesh points there lie on the
  // caps, and the wall's figures keep the analytic values with the seam in them.
  for (const double h : {0.1, 0.2, 0.3}) {
    const SeamLoop loop = lay_seam_loop(h, 0.45, static_cast<int>(std::lround(2.0 / h)), 0.2);
    DeviationSettings settings;
    auto r = compute_deviation(loop.mesh, loop.grid, settings, {}, loop.beads);
    ASSERT_TRUE(r.ok());
    expect_wall_figures(*r, h);
    const double R = 0.5 * h;
    // The seam's corner column (outside the loop's corner point, x, y < 20.225): every point
    // lies on a bead's surface (on a cap, not a voxel face), within the layer line's depth.
    const DeviationSamples& ds = r->deposit_samples;
    std::size_t at_corner = 0;
    for (std::size_t i = 0; i < ds.size(); ++i) {
      const Vec3& p = ds.positions_mm[i];
      if (!(p.x() < 20.2 && p.y() < 20.2) || p.z() < 0.5 || p.z() > 1.5) continue;
      ++at_corner;
      double on = 1e9;
      for (const SurfaceBead& b : loop.beads) {
        Vec3 core;
        on = std::min(on, std::abs(detail::bead_closest(b, p, core)));
      }
      EXPECT_LT(on, 1e-9) << "h " << h << " point " << p.transpose();
      EXPECT_LE(ds.distances_mm[i], 1e-9) << "h " << h << " point " << p.transpose();
      EXPECT_GE(ds.distances_mm[i], -R - 1e-9) << "h " << h << " point " << p.transpose();
    }
    EXPECT_GT(at_corner, 20U) << "h " << h;
    // Nowhere (the seam's corner and gap included) is the design more than a layer line's
    // groove (0.41 R at the layer boundary) and the seam gap's dip between the two round ends
    // (0.023 mm for 0.2 mm between the ends of 0.45 mm beads) from the plastic.
    EXPECT_LT(r->max_deficit_mm, 0.41 * R + 0.023) << "h " << h;
  }
}

TEST(SurfaceLayerLines, SealKeepsGroovesButNotPinholesIntoTheInfill) {
  // The wall of beads as above, sealed at 0.2 mm: without reopening, the grooves between
  // layers are closed and the surface is flat; with it, they are surface.
  const Wall wall = lay_wall(0.2, 0.45, 10);
  const Box3 region{Vec3(19, 19, -0.5), Vec3(31, 31, 2.5)};
  const DepositSurface flat = extract_outer_surface(wall.deposit.grid, region, 0.2, 0.0);
  const DepositSurface grooved = extract_outer_surface(wall.deposit.grid, region, 0.2, 0.25);
  EXPECT_GT(grooved.faces.size(), flat.faces.size());
  // The groove at the layer boundary z = 1.0 on the -x face (x = 20; the beads' round sides
  // meet 0.1 mm in, at x = 20.1): 0.01 mm in, it is outside with reopening, filled without.
  const Vec3 below(20.01, 25.0, 0.99), above(20.01, 25.0, 1.01);
  EXPECT_TRUE(flat.filled(below) && flat.filled(above));
  EXPECT_TRUE(!grooved.filled(below) || !grooved.filled(above));
  // A hollow box whose 0.4 mm wall has a 1-voxel slit: the cavity stays filled (the reopening
  // goes 0.25 mm into the slit, not through the wall).
  const Box3 outer{Vec3(0, 0, 0), Vec3(2, 2, 1)};
  const Box3 cavity{Vec3(0.4, 0.4, 0.4), Vec3(1.6, 1.6, 0.6)};
  const Box3 slit{Vec3(0.9, -1, 0.45), Vec3(0.95, 0.5, 0.55)};
  VoxelGrid grid(0.05, Vec3(-1, -1, -1), Eigen::Vector3i(80, 80, 60));
  for (int z = 0; z < 60; ++z)
    for (int y = 0; y < 80; ++y)
      for (int x = 0; x < 80; ++x) {
        const Vec3 c = grid.center_mm({x, y, z});
        if (outer.contains(c) && !cavity.contains(c) && !slit.contains(c))
          grid.set({x, y, z}, VoxelTag{1, 0, Feature::outer_perimeter});
      }
  const DepositSurface s = extract_outer_surface(grid, outer, 0.2, 0.25);
  EXPECT_TRUE(s.filled(Vec3(1, 1, 0.5)));
  EXPECT_FALSE(s.filled(Vec3(0.925, 0.1, 0.5)));   // 0.1 mm into the slit: reopened
  EXPECT_TRUE(s.filled(Vec3(0.925, 0.375, 0.5)));  // 0.375 mm in: sealed
}

TEST(SurfaceDistances, FarPointsReadTheFarLimitQuickly) {
  // A 1 mm cube of voxels: a point 5 mm beside it is measured exactly, one 50 mm away reads
  // the far limit (at least that far), and a mesh 100 mm from its print is measured quickly.
  VoxelGrid grid(0.05, Vec3(0, 0, 0), Eigen::Vector3i(20, 20, 20));
  for (int z = 0; z < 20; ++z)
    for (int y = 0; y < 20; ++y)
      for (int x = 0; x < 20; ++x) grid.set({x, y, z}, VoxelTag{1, 0, Feature::outer_perimeter});
  const DepositSurface s = extract_outer_surface(grid, Box3{Vec3(0, 0, 0), Vec3(1, 1, 1)});
  std::vector<Vec3> points{Vec3(6.0, 0.5, 0.5), Vec3(51.0, 0.5, 0.5), Vec3(0.5, 0.5, 0.5)};
  for (int i = 0; i < 20000; ++i) points.emplace_back(101.0 + 1e-3 * i, 0.5, 0.5);
  std::vector<double> d;
  distances_to_deposit(s, points, d, nullptr);
  EXPECT_NEAR(d[0], -5.0, 1e-9);
  EXPECT_DOUBLE_EQ(d[1], -kDepositFarMm);
  EXPECT_NEAR(d[2], 0.5, 1e-9);  // inside: to the nearest face
  EXPECT_DOUBLE_EQ(d.back(), -kDepositFarMm);
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

TEST(SurfaceRegions, RegionAreaIsTheSumOfItsPointsAreas) {
  // Three excess points 0.01 mm apart, standing for 0.004, 0.002 and 0.001 mm2.
  std::vector<DeviationSample> samples;
  for (int i = 0; i < 3; ++i) samples.push_back({Vec3(0.01 * i, 0, 0), 0.5, 1, 7, 0});
  const std::vector<double> area{0.004, 0.002, 0.001};
  const auto weighted =
      cluster_regions(samples, 0.3, 0.1, 0.0025, RegionKind::excess, 20, nullptr, area);
  ASSERT_EQ(weighted.size(), 1U);
  EXPECT_NEAR(weighted[0].area_mm2, 0.007, 1e-12);
  const auto counted = cluster_regions(samples, 0.3, 0.1, 0.0025, RegionKind::excess);
  ASSERT_EQ(counted.size(), 1U);
  EXPECT_NEAR(counted[0].area_mm2, 0.0075, 1e-12);
}

}  // namespace
}  // namespace printtwin
