// Tests of the voxel grid and the bead model: volume faithfulness, traceability, overlap,
// extrusion into air, the memory budget. Geometry is built as Moves in code.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "deposit/deposit_run.hpp"
#include "deposit/deposit_test_support.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"

namespace printtwin {
namespace {

using test::bead_e_mm;
using test::BeadWriter;

/// One closed rectangular loop of 0.45 mm beads at height z.
void add_rectangle(BeadWriter& w, double x0, double y0, double x1, double y1, double z, double h) {
  w.travel({x0, y0, z});
  w.extrude({x1, y0, z}, 0.45, h);
  w.extrude({x1, y1, z}, 0.45, h);
  w.extrude({x0, y1, z}, 0.45, h);
  w.extrude({x0, y0, z}, 0.45, h);
}

/// Vase-mode helix of 0.2 mm layers: one flat loop (layer 0), then `turns` turns rising
/// 0.2 mm each (one layer per turn); like the slicers, the first rising turn ramps the flow
/// up with the gap beneath it.
void add_vase_spiral(BeadWriter& w, const Vec3& c, double radius, int per_turn, int turns) {
  const double h = 0.2;
  auto at = [&](double turn, double z) {
    const double t = 2 * std::numbers::pi * turn;
    return Vec3(c.x() + radius * std::cos(t), c.y() + radius * std::sin(t), z);
  };
  w.layer = 0;
  w.travel(at(0, h));
  for (int i = 1; i <= per_turn; ++i) w.extrude(at(static_cast<double>(i) / per_turn, h), 0.45, h);
  for (int i = 1; i <= turns * per_turn; ++i) {
    const double turn = static_cast<double>(i) / per_turn;
    w.layer = 1 + i / per_turn;
    w.extrude(at(turn, h + h * turn), 0.45, h, std::min(1.0, turn - 0.5 / per_turn));
  }
}

TEST(VoxelGrid, SetTagCountAndOrder) {
  VoxelGrid g(0.1, Vec3(1, 2, 0), Eigen::Vector3i(20, 17, 9));
  EXPECT_EQ(g.count(), 0u);
  EXPECT_FALSE(g.occupied({3, 4, 5}));
  const VoxelTag t1{12, 3, Feature::perimeter};
  EXPECT_TRUE(g.set({3, 4, 5}, t1));
  EXPECT_FALSE(g.set({3, 4, 5}, t1));
  EXPECT_TRUE(g.set({19, 16, 8}, VoxelTag{13, 4, Feature::sparse_infill}));
  EXPECT_FALSE(g.set({20, 0, 0}, t1));  // out of range
  EXPECT_FALSE(g.set({-1, 0, 0}, t1));
  EXPECT_EQ(g.count(), 2u);
  ASSERT_TRUE(g.tag({3, 4, 5}).has_value());
  EXPECT_EQ(*g.tag({3, 4, 5}), t1);
  EXPECT_EQ(g.tag({19, 16, 8})->line, 13u);
  EXPECT_FALSE(g.tag({0, 0, 0}).has_value());
  EXPECT_EQ(detail::VoxelBlocks::block_count(g), 2u);

  const VoxelKey k = g.key_of(Vec3(1.35, 2.05, 0.99));
  EXPECT_EQ(k, (VoxelKey{3, 0, 9}));
  EXPECT_NEAR(g.center_mm({3, 4, 5}).x(), 1.35, 1e-12);

  // fill_row across block borders, overlap counted by the return value.
  EXPECT_EQ(
      detail::VoxelBlocks::fill_row(
          g, 4, 5, 0, 20, detail::VoxelBlocks::add_tag(g, VoxelTag{20, 3, Feature::solid_infill})),
      19u);
  EXPECT_EQ(g.count(), 21u);
  EXPECT_EQ(g.tag({3, 4, 5})->line, 20u);  // the last writer owns the voxel
  EXPECT_EQ(detail::VoxelBlocks::fill_row(g, 4, 5, -5, 40, 0), 0u);

  // Deterministic order: z-major by block, then within the block.
  const auto keys = g.occupied_keys();
  ASSERT_EQ(keys.size(), g.count());
  EXPECT_EQ(keys.front(), (VoxelKey{0, 4, 5}));
  EXPECT_EQ(keys.back(), (VoxelKey{19, 16, 8}));
  std::size_t visited = 0;
  g.for_each([&](const VoxelKey& key, const VoxelTag& tag) {
    EXPECT_TRUE(g.occupied(key));
    EXPECT_EQ(tag, *g.tag(key));
    ++visited;
  });
  EXPECT_EQ(visited, g.count());

  VoxelGrid copy = g;
  g.clear({3, 4, 5});
  EXPECT_EQ(g.count(), 20u);
  EXPECT_EQ(copy.count(), 21u);
  EXPECT_TRUE(copy.occupied({3, 4, 5}));
  EXPECT_LE(VoxelGrid::estimate_bytes(g.dims(), 1000),
            3 * 4 * 4 + 8 * detail::VoxelBlocks::kBlockBytes);
}

// A block keeps up to 16 distinct tags as 4-bit palette indices. Tags far apart in the
// table (70000 moves) share a palette; a 17th tag first drops the entries that only
// overwritten voxels referred to; a block that really holds more than 16 becomes wide. Every
// reader (tag(), for_each(), the block view, a copy) sees the same tags throughout.
TEST(VoxelGrid, ManyTagsInOneBlockReadBackExactly) {
  VoxelGrid g(0.1, Vec3::Zero(), Eigen::Vector3i(16, 16, 16));
  std::vector<std::uint32_t> index;
  for (std::uint32_t i = 0; i < 70010; ++i)
    index.push_back(detail::VoxelBlocks::add_tag(
        g, VoxelTag{i + 1, static_cast<std::int32_t>(i), Feature::perimeter}));
  const auto check_all = [&](const VoxelGrid& grid) {
    std::size_t visited = 0;
    grid.for_each([&](const VoxelKey& k, const VoxelTag& t) {
      EXPECT_EQ(t, *grid.tag(k));
      ++visited;
    });
    EXPECT_EQ(visited, grid.count());
    detail::VoxelBlocks::visit_blocks(grid, [&](const detail::VoxelBlocks::BlockView& b) {
      for (int z = 0; z < 8; ++z)
        for (std::uint64_t m = b.occupancy[z]; m != 0; m &= m - 1) {
          const int bit = std::countr_zero(m);
          const VoxelKey k{b.base.x + (bit & 7), b.base.y + (bit >> 3), b.base.z + z};
          EXPECT_EQ(b.tag_index(z * 64 + bit), *detail::VoxelBlocks::tag_index(grid, k));
        }
    });
  };
  EXPECT_TRUE(detail::VoxelBlocks::set_index(g, {1, 1, 1}, index[5]));
  EXPECT_TRUE(detail::VoxelBlocks::set_index(g, {2, 1, 1}, index[70000]));
  EXPECT_EQ(detail::VoxelBlocks::write_tile(g, 0, 0, 2, 0x0101ull, index[69999]), 2u);
  EXPECT_EQ(detail::VoxelBlocks::fill_row(g, 3, 3, 0, 8, index[3]), 8u);
  EXPECT_EQ(detail::VoxelBlocks::write_tile(g, 0, 0, 4, 0xFFull, index[60000]), 8u);
  EXPECT_EQ(g.tag({1, 1, 1})->line, 6u);
  EXPECT_EQ(g.tag({2, 1, 1})->line, 70001u);
  EXPECT_EQ(g.tag({0, 0, 2})->line, 70000u);
  EXPECT_EQ(g.tag({0, 1, 2})->line, 70000u);
  EXPECT_EQ(g.tag({5, 3, 3})->line, 4u);
  EXPECT_EQ(g.tag({7, 0, 4})->line, 60001u);
  EXPECT_EQ(g.count(), 20u);
  check_all(g);

  // Overwrite row (3, 3) with 20 tags in turn: only the last one is referred to, so the
  // palette is compacted and the block stays narrow.
  for (std::uint32_t i = 0; i < 20; ++i)
    detail::VoxelBlocks::fill_row(g, 3, 3, 0, 8, index[100 + i]);
  EXPECT_EQ(g.tag({0, 3, 3})->line, 120u);
  EXPECT_EQ(detail::VoxelBlocks::wide_block_count(g), 0u);
  check_all(g);

  // 30 different tags on 30 voxels of z-slice 6: the block becomes wide, nothing is lost.
  for (int i = 0; i < 30; ++i)
    detail::VoxelBlocks::set_index(g, {i % 8, i / 8, 6}, index[1000 + static_cast<std::size_t>(i)]);
  EXPECT_EQ(detail::VoxelBlocks::wide_block_count(g), 1u);
  for (int i = 0; i < 30; ++i)
    EXPECT_EQ(g.tag({i % 8, i / 8, 6})->line, 1001u + static_cast<unsigned>(i));
  EXPECT_EQ(g.tag({2, 1, 1})->line, 70001u);
  detail::VoxelBlocks::write_tile(g, 0, 0, 6, 0xFFull, index[7]);  // writes to a wide block
  EXPECT_EQ(g.tag({3, 0, 6})->line, 8u);
  EXPECT_EQ(g.tag({3, 1, 6})->line, 1012u);
  check_all(g);
  const VoxelGrid copy = g;
  EXPECT_EQ(detail::VoxelBlocks::wide_block_count(copy), 1u);
  EXPECT_EQ(copy.tag({0, 0, 2})->line, 70000u);
  EXPECT_EQ(copy.tag({5, 3, 6})->line, 1030u);
  check_all(copy);
}

TEST(DepositBead, StadiumWidth) {
  // w = A/h + (1 - pi/4) h; inverse of A = (w - h) h + pi h^2 / 4.
  const double a = (0.45 - 0.2) * 0.2 + std::numbers::pi * 0.04 / 4;
  EXPECT_NEAR(stadium_width_mm(a, 0.2), 0.45, 1e-12);
}

TEST(DepositBead, SingleLineVolumeMatchesExtrusion) {
  const auto profile = ender3_marlin2();
  for (const double angle_deg : {0.0, 30.0, 90.0, 133.0}) {
    BeadWriter w(profile);
    const double t = angle_deg * std::numbers::pi / 180;
    const Vec3 a(60, 60, 0.2);
    w.travel(a);
    w.extrude(a + 25.0 * Vec3(std::cos(t), std::sin(t), 0), 0.45, 0.2);
    auto r = deposit_moves(w.moves, profile, DepositSettings{});
    ASSERT_TRUE(r.ok()) << r.error().describe();
    EXPECT_NEAR(r->volume_mm3 / r->extruded_mm3, 1.0, 0.02) << angle_deg;
    EXPECT_LT(r->overlap_mm3, 1e-9);
    EXPECT_EQ(r->beads, 1u);
    EXPECT_NEAR(r->bbox_mm.min.z(), 0.0, 1e-9);
    EXPECT_NEAR(r->bbox_mm.max.z(), 0.2, 1e-9);
    EXPECT_TRUE(r->findings.empty());
    if (angle_deg == 0.0) {  // round ends: half a bead width past each end
      EXPECT_NEAR(r->bbox_mm.size().y(), 0.45, 0.051);
      EXPECT_NEAR(r->bbox_mm.size().x(), 25.45, 0.051);
    }
  }
}

// The sweep tests only the tiles the bead's footprint reaches. Short moves between sharp
// mitres (the footprint is a triangle there), steep and shallow diagonals and a spiral must
// give exactly the voxels of testing every voxel of each bead's box.
TEST(DepositBead, FootprintBoundsMissNoVoxel) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int layer = 0; layer < 3; ++layer) {
    const double z = 0.2 * (layer + 1);
    w.layer = layer;
    Vec3 p(40 + 3 * u(rng), 40 + 3 * u(rng), z);
    w.travel(p);
    double heading = 2 * std::numbers::pi * u(rng);
    for (int i = 0; i < 400; ++i) {
      // Turns up to +-118 degrees (still mitred) and lengths down to 0.02 mm.
      heading += (u(rng) < 0.5 ? -1 : 1) * (0.3 + 1.75 * u(rng));
      const double len = i % 3 == 0 ? 0.02 + 0.1 * u(rng) : 0.2 + 1.5 * u(rng);
      p += len * Vec3(std::cos(heading), std::sin(heading), 0);
      p.x() = std::clamp(p.x(), 30.0, 60.0), p.y() = std::clamp(p.y(), 30.0, 60.0);
      w.extrude(p, 0.3 + 0.3 * u(rng), 0.2);
    }
  }
  w.layer = 3;
  w.travel({50, 45, 0.9});
  for (int i = 1; i <= 200; ++i) {  // a vase-mode spiral: every move climbs
    const double t = 0.05 * i;
    w.extrude({50 + 5 * std::cos(t), 45 + 5 * std::sin(t), 0.9 + 0.001 * i}, 0.45, 0.2);
  }
  DepositSettings fast;
  detail::DepositRunSettings exhaustive;
  exhaustive.exhaustive_tiles = true;
  auto a = deposit_moves(w.moves, profile, fast);
  auto b = detail::DepositRun::moves(w.moves, profile, exhaustive);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_GT(a->voxels, 100000u);
  EXPECT_EQ(a->voxels, b->voxels);
  EXPECT_EQ(a->overlap_mm3, b->overlap_mm3);
  EXPECT_EQ(a->grid.occupied_keys(), b->grid.occupied_keys());
}

TEST(DepositBead, FirstLayerHeightFollowsTheGapToTheBed) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.travel({50, 50, 0.3});
  w.extrude({70, 50, 0.3}, 0.5, 0.3);
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->bbox_mm.max.z(), 0.3, 1e-9);
  EXPECT_NEAR(r->bbox_mm.size().y(), 0.5, 0.051);
  EXPECT_NEAR(r->volume_mm3 / r->extruded_mm3, 1.0, 0.02);
}

TEST(DepositBead, SingleWallPrintVolumeMatchesExtrusion) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const double h = 0.2;
  for (int layer = 0; layer < 40; ++layer) {
    const double z = h * (layer + 1);
    w.layer = layer;
    add_rectangle(w, 40, 40, 60, 55, z, h);
  }
  DepositSettings lay_only;  // the beads as laid (the squeeze widens the wall at the corners)
  lay_only.conserve_volume = false;
  auto r = deposit_moves(w.moves, profile, lay_only);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->volume_mm3 / r->extruded_mm3, 1.0, 0.02);
  // The 90 degree corners are round joins: the beads' square ends overlap inside the corner
  // (counted) and the join places that material outside it, but for (1 - pi/4) hw^2 per corner.
  // Each loop closes on its own start (no seam gap): its round end cap lies on the first bead
  // and the last bead on the round start cap, two caps (0.0132 mm3 each) per layer of 5.7 mm3.
  EXPECT_LT(r->overlap_mm3 - r->squeezed_mm3, 0.01 * r->extruded_mm3);
  EXPECT_NEAR(r->bbox_mm.max.z(), 8.0, 1e-9);
  EXPECT_NEAR(r->bbox_mm.size().x(), 20.45, 0.06);
  EXPECT_TRUE(r->findings.empty());
}

// Slic3r/PrusaSlicer space neighbouring lines w - h (1 - pi/4) apart, so that the stadium
// sections' areas add up to spacing x height. The sections then overlap where their
// half-discs meet (a lens: two discs of diameter h, centres pi h / 4 apart) and leave the
// same area empty at the cusps above and below: the deposit reports the lens as overlap.
// This is the modelling part of the overlap measured on real G-code (docs/deposit.md).
TEST(DepositBead, NeighbouringLinesAtSlicerSpacingOverlapByTheLens) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const double wd = 0.45, h = 0.2, len = 30.0;
  const double spacing = wd - h * (1.0 - std::numbers::pi / 4.0);
  w.travel({40, 40.02, h});
  w.extrude({40 + len, 40.02, h}, wd, h);
  w.travel({40, 40.02 + spacing, h});
  w.extrude({40 + len, 40.02 + spacing, h}, wd, h);
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  const double rr = h / 2, dd = std::numbers::pi * h / 4;  // disc radius, centre distance
  const double lens_mm2 =
      2 * rr * rr * std::acos(dd / (2 * rr)) - 0.5 * dd * std::sqrt(4 * rr * rr - dd * dd);
  EXPECT_NEAR(r->overlap_mm3 / (lens_mm2 * len), 1.0, 0.15);
  // ~4.5 % of one line: what an inner perimeter or a solid infill line shows per neighbour.
  EXPECT_NEAR(r->overlap_mm3 / (0.5 * r->extruded_mm3), 0.0446, 0.007);
  EXPECT_NEAR((r->volume_mm3 + r->overlap_mm3 - r->squeezed_mm3) / r->extruded_mm3, 1.0, 0.02);
}

TEST(DepositBead, SpiralVolumeMatchesExtrusion) {
  // Vase-mode helix: one flat first loop, then Z rises 0.2 mm per turn.
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  add_vase_spiral(w, Vec3(100, 100, 0), 12.0, 120, 25);
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->volume_mm3 / r->extruded_mm3, 1.0, 0.02);
  EXPECT_LT(r->overlap_mm3, 0.01 * r->extruded_mm3);
  EXPECT_TRUE(r->findings.empty());
}

// With the squeeze on, the helix's overflow is placed nearby and still counted once: a later
// turn that lands on squeezed material displaces it again as its own overflow, not as new
// overlap, and the local squeeze stays between the bead's own end cuts (the next segment's
// stretch of the path is its own).
TEST(DepositBead, SpiralSqueezeCountsItsOverlapOnce) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  add_vase_spiral(w, Vec3(100, 100, 0), 12.0, 120, 25);
  DepositSettings conserve;
  conserve.conserve_volume = true;
  auto r = deposit_moves(w.moves, profile, conserve);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->volume_mm3 / r->extruded_mm3, 1.0, 0.005);
  EXPECT_LT(r->overlap_mm3, 0.01 * r->extruded_mm3) << r->overlap_mm3;
  EXPECT_LE(r->squeezed_mm3, r->overlap_mm3);
}

// A path turning by more than 60 degrees is cut square at the turn and joined round: the
// nozzle's footprint is a disc, so the tip of a sharp corner is filled out to the bead's
// half-width, and no further.
TEST(DepositBead, SharpHairpinIsJoinedRoundToTheDisc) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const double h = 0.2, bw = 0.45, hw = 0.5 * bw;
  const Vec3 v(60, 50, h);
  const double half = 15.0 * std::numbers::pi / 180.0;  // a 30 degree hairpin about -x
  const Vec3 a = v + 8.0 * Vec3(-std::cos(half), std::sin(half), 0);
  const Vec3 b = v + 8.0 * Vec3(-std::cos(half), -std::sin(half), 0);
  w.travel(a);
  w.extrude(v, bw, h);
  w.extrude(b, bw, h);
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  // Beyond the vertex, along the bisector at mid-height: filled to the disc's edge, empty past it.
  auto filled = [&](double t) {
    return r->grid.occupied(r->grid.key_of(Vec3(v.x() + t, v.y() + 0.01, 0.5 * h)));
  };
  for (double t = 0.0; t <= hw - 0.05; t += 0.025) EXPECT_TRUE(filled(t)) << t;
  for (double t = hw + 0.05; t <= hw + 0.3; t += 0.025) EXPECT_FALSE(filled(t)) << t;
  // The tip reaches the disc's edge (hw), not the square cuts' corners.
  EXPECT_NEAR(r->bbox_mm.max.x(), v.x() + hw, 0.051);
  // The join's voxels take material of the overlap inside the hairpin; none is made.
  EXPECT_GT(r->squeezed_mm3, 0.0);
  EXPECT_LE(r->squeezed_mm3, r->overlap_mm3);
  EXPECT_LE(r->volume_mm3, r->extruded_mm3);
}

// A path's start and end are round: the nozzle's footprint is a disc, so a straight bead
// ends in half-discs of its half-width, made of its own material.
TEST(DepositBead, PathEndsAreRoundHalfDiscs) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const double h = 0.2, bw = 0.45, hw = 0.5 * bw;
  const Vec3 a(50, 50, h), b(60, 50, h);
  w.travel(a);
  w.extrude(b, bw, h);
  DepositSettings lay_only;
  lay_only.conserve_volume = false;
  auto r = deposit_moves(w.moves, profile, lay_only);
  ASSERT_TRUE(r.ok());
  // At mid-height, around each end: filled to the disc's edge, empty past it, at every angle.
  auto filled = [&](const Vec3& c, double angle, double rho) {
    const Vec3 p = c + rho * Vec3(std::cos(angle), std::sin(angle), 0);
    return r->grid.occupied(r->grid.key_of(Vec3(p.x(), p.y(), 0.5 * h)));
  };
  for (double deg = -80; deg <= 80; deg += 20) {
    const double t = deg * std::numbers::pi / 180.0;
    for (double rho = 0.02; rho <= hw - 0.06; rho += 0.025) {
      EXPECT_TRUE(filled(b, t, rho)) << deg << " " << rho;
      EXPECT_TRUE(filled(a, std::numbers::pi + t, rho)) << deg << " " << rho;
    }
    for (double rho = hw + 0.05; rho <= hw + 0.2; rho += 0.025) {
      EXPECT_FALSE(filled(b, t, rho)) << deg << " " << rho;
      EXPECT_FALSE(filled(a, std::numbers::pi + t, rho)) << deg << " " << rho;
    }
  }
  EXPECT_NEAR(r->bbox_mm.min.x(), a.x() - hw, 0.051);
  EXPECT_NEAR(r->bbox_mm.max.x(), b.x() + hw, 0.051);
  // The caps are the bead's own material: the section is narrower by their volume.
  EXPECT_NEAR(r->volume_mm3 / r->extruded_mm3, 1.0, 0.01);
  EXPECT_LT(r->overlap_mm3, 1e-9);
}

// A perimeter loop with a seam gap (the path stops 0.06 mm short of its start, at a corner):
// the two round ends fill the seam's outer corner out to the bead's half-width, as a round
// join does at the other corners; square ends left a quarter disc of it empty.
TEST(DepositBead, LoopSeamCornerIsFilledByTheRoundEnds) {
  const auto profile = ender3_marlin2();
  const double h = 0.2, bw = 0.45, hw = 0.5 * bw, gap = 0.06;
  BeadWriter w(profile);
  for (int layer = 0; layer < 3; ++layer) {
    const double z = h * (layer + 1);
    w.layer = layer;
    w.travel({50, 50, z});
    w.extrude({60, 50, z}, bw, h);
    w.extrude({60, 60, z}, bw, h);
    w.extrude({50, 60, z}, bw, h);
    w.extrude({50, 50 + gap, z}, bw, h);
  }
  DepositSettings lay_only;  // the beads as laid (the squeeze places the seam's overlap)
  lay_only.conserve_volume = false;
  auto r = deposit_moves(w.moves, profile, lay_only);
  ASSERT_TRUE(r.ok());
  const double diag = std::numbers::pi * 1.25;  // outward from the seam corner
  auto filled = [&](const Vec3& c, double angle, double rho, double z) {
    const Vec3 p = c + rho * Vec3(std::cos(angle), std::sin(angle), 0);
    return r->grid.occupied(r->grid.key_of(Vec3(p.x(), p.y(), z)));
  };
  for (int layer = 0; layer < 3; ++layer) {
    const double z = h * (layer + 0.5);
    for (double rho = 0.0; rho <= hw - 0.06; rho += 0.025) {
      EXPECT_TRUE(filled({50, 50, 0}, diag, rho, z)) << layer << " " << rho;
      EXPECT_TRUE(filled({60, 60, 0}, diag - std::numbers::pi, rho, z)) << layer << " " << rho;
    }
    for (double rho = hw + 0.05; rho <= hw + 0.2; rho += 0.025)
      EXPECT_FALSE(filled({50, 50, 0}, diag, rho, z)) << layer << " " << rho;
  }
  // The seam corner reaches as far out as the joined corners do.
  EXPECT_NEAR(r->bbox_mm.min.x(), 50 - hw, 0.051);
  EXPECT_NEAR(r->bbox_mm.min.y(), 50 - hw, 0.051);
  // Where the round ends lie on each other is overlap; squeezed, the volume is kept.
  EXPECT_GT(r->overlap_mm3, 0.0);
  DepositSettings conserve;
  conserve.conserve_volume = true;
  auto kept = deposit_moves(w.moves, profile, conserve);
  ASSERT_TRUE(kept.ok());
  EXPECT_NEAR(kept->volume_mm3 / kept->extruded_mm3, 1.0, 0.005);
}

TEST(DepositBead, ZigZagInfillKeepsEveryBead) {
  // Turns into and out of the short connecting moves are mitred; nothing is lost.
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.feature = Feature::sparse_infill;
  w.travel({100, 100, 0.2});
  for (int i = 0; i < 12; ++i) {
    const double x = 100 + 2.25 * i;
    const bool up = i % 2 == 0;
    if (i > 0) w.extrude({x, up ? 100.0 - 0.4 * i : 120.0 + 0.4 * i, 0.2}, 0.45, 0.2);
    w.extrude({x, up ? 120.0 + 0.4 * i : 100.0 - 0.4 * (i + 1), 0.2}, 0.45, 0.2);
  }
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR((r->volume_mm3 + r->overlap_mm3 - r->squeezed_mm3) / r->extruded_mm3, 1.0, 0.02);
  EXPECT_LT(r->overlap_mm3, 0.05 * r->extruded_mm3);
}

TEST(DepositBead, VoxelsNameTheirLineLayerAndFeature) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.travel({50, 50, 0.2});
  w.feature = Feature::outer_perimeter;
  w.extrude({60, 50, 0.2}, 0.45, 0.2);  // line 2
  w.layer = 1;
  w.feature = Feature::sparse_infill;
  w.travel({50, 50, 0.4});
  w.extrude({60, 50, 0.4}, 0.45, 0.2);  // line 4
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  const auto low = r->grid.tag(r->grid.key_of({55, 50, 0.1}));
  const auto high = r->grid.tag(r->grid.key_of({55, 50, 0.3}));
  ASSERT_TRUE(low && high);
  EXPECT_EQ(low->line, 2u);
  EXPECT_EQ(low->layer, 0);
  EXPECT_EQ(low->feature, Feature::outer_perimeter);
  EXPECT_EQ(high->line, 4u);
  EXPECT_EQ(high->layer, 1);
  EXPECT_EQ(high->feature, Feature::sparse_infill);
}

TEST(DepositBead, RetractsAndWipesLayNothing) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.travel({50, 50, 0.2});
  w.extrude({60, 50, 0.2}, 0.45, 0.2);
  auto base = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(base.ok());
  w.retract({62, 50, 0.2}, -0.8);  // wipe: moves while retracting
  w.retract({62, 50, 0.2}, -0.5);  // plain retract
  w.unretract(1.3);
  w.travel({80, 80, 0.2});
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->voxels, base->voxels);
  EXPECT_DOUBLE_EQ(r->extruded_mm3, base->extruded_mm3);
}

TEST(DepositBead, OverlappingBeadsReportTheOverlap) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.travel({50, 50, 0.2});
  w.extrude({70, 50, 0.2}, 0.45, 0.2);
  w.travel({50, 50, 0.2});
  w.extrude({70, 50, 0.2}, 0.45, 0.2);  // the same bead again: no room left
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->overlap_mm3 / (0.5 * r->extruded_mm3), 1.0, 0.02);
  EXPECT_NEAR((r->volume_mm3 + r->overlap_mm3 - r->squeezed_mm3) / r->extruded_mm3, 1.0, 0.02);
}

TEST(DepositBead, MemoryBudgetStopsBeforeAllocating) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.travel({20, 20, 0.2});
  for (int layer = 0; layer < 50; ++layer) {
    const double z = 0.2 * (layer + 1);
    w.layer = layer;
    w.travel({20, 20, z});
    w.extrude({200, 20, z}, 0.45, 0.2);
    w.extrude({200, 200, z}, 0.45, 0.2);
  }
  DepositSettings s;
  s.max_memory_bytes = 8u << 20;
  auto est = estimate_deposit(w.moves, profile, s);
  ASSERT_TRUE(est.ok());
  EXPECT_GT(est->bytes, s.max_memory_bytes);
  auto r = deposit_moves(w.moves, profile, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::usage);
  EXPECT_NE(r.error().message.find("--voxel"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("MiB"), std::string::npos);
  // The suggested voxel size fits.
  const auto pos = r.error().message.find("--voxel ") + 8;
  s.voxel_mm = std::stod(r.error().message.substr(pos));
  EXPECT_GT(s.voxel_mm, 0.05);
  auto again = deposit_moves(w.moves, profile, s);
  ASSERT_TRUE(again.ok()) << again.error().describe();
  EXPECT_LE(again->memory_bytes, s.max_memory_bytes);
  EXPECT_NEAR(again->volume_mm3 / again->extruded_mm3, 1.0, 0.03);
}

TEST(DepositBead, EstimateIsCloseToTheMemoryUsed) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  for (int layer = 0; layer < 30; ++layer) {
    const double z = 0.2 * (layer + 1);
    w.layer = layer;
    w.travel({40, 40, z});
    w.extrude({60, 40, z}, 0.45, 0.2);
    w.extrude({60, 60, z}, 0.45, 0.2);
    w.extrude({40, 60, z}, 0.45, 0.2);
    w.extrude({40, 40, z}, 0.45, 0.2);
  }
  auto est = estimate_deposit(w.moves, profile, DepositSettings{});
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(est.ok() && r.ok());
  EXPECT_NEAR(static_cast<double>(detail::VoxelBlocks::block_count(r->grid)) /
                  static_cast<double>(est->blocks),
              1.0, 0.25);
  EXPECT_GE(static_cast<double>(est->bytes), 0.8 * static_cast<double>(r->memory_bytes));
}

TEST(DepositBead, BadSettingsAreUsageErrors) {
  const auto profile = ender3_marlin2();
  DepositSettings s;
  s.voxel_mm = 0;
  EXPECT_FALSE(deposit_moves({}, profile, s).ok());
  s.voxel_mm = 0.05;
  s.support_fraction = 1.5;
  auto r = deposit_moves({}, profile, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::usage);
}

}  // namespace
}  // namespace printtwin
