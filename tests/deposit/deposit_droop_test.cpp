// Sag, droop and elephant's foot in the deposit: beads laid in code over air end up lower by
// the model's drop (docs/deposit.md, "Sag, droop and elephant's foot"), keep their volume,
// and the extrusion-into-air findings say how far.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "deposit/deposit_test_support.hpp"
#include "printtwin/deposit.hpp"

namespace printtwin {
namespace {

using test::BeadWriter;

constexpr double kH = 0.2, kW = 0.45;

/// Two pillars (3 beads x 2 mm, 10 layers) `span` mm apart, then one bridge bead across.
std::vector<Move> bridge(const PrinterProfile& p, double span) {
  BeadWriter w(p);
  const double x1 = 42.0 + span;
  for (int layer = 0; layer < 10; ++layer) {
    w.layer = layer;
    const double z = kH * (layer + 1);
    for (double x0 : {40.0, x1})
      for (double y : {50.0, 50.4, 50.8}) {
        w.travel({x0, y, z});
        w.extrude({x0 + 2, y, z}, kW, kH);
      }
  }
  w.layer = 10;
  w.feature = Feature::bridge_infill;
  const double z = kH * 11;
  w.travel({40.5, 50.4, z});
  w.extrude({x1 + 1.5, 50.4, z}, kW, kH);
  return w.moves;
}

/// Lowest occupied voxel (mm, its bottom) in the columns around (x, y), above z_min.
double lowest_bottom(const DepositResult& r, double x, double y, double z_min) {
  double low = std::numeric_limits<double>::infinity();
  r.grid.for_each([&](const VoxelKey& k, const VoxelTag&) {
    const Vec3 c = r.grid.center_mm(k);
    if (std::abs(c.x() - x) < 0.3 && std::abs(c.y() - y) < 0.1 && c.z() > z_min)
      low = std::min(low, c.z() - 0.5 * r.voxel_mm);
  });
  return low;
}

PrinterProfile rigid() {
  auto p = ender3_marlin2();
  p.bridge_sag_mm = 0;
  p.overhang_droop_mm = 0;
  p.elephant_foot_mm = 0;
  return p;
}

TEST(DepositDroop, BridgeSagGrowsWithSpanAndKeepsTheVolume) {
  const auto profile = ender3_marlin2();
  double last = -1;
  for (const double span : {5.0, 10.0, 20.0, 40.0}) {
    SCOPED_TRACE(span);
    DepositSettings lay_only;  // the sag alone (the squeeze moves the strand's overlap)
    lay_only.conserve_volume = false;
    auto r = deposit_moves(bridge(profile, span), profile, lay_only);
    auto flat = deposit_moves(bridge(rigid(), span), rigid(), lay_only);
    ASSERT_TRUE(r.ok() && flat.ok());
    ASSERT_EQ(r->unsupported.size(), 1u);
    const auto& s = r->unsupported.front();
    EXPECT_TRUE(s.bridge);
    EXPECT_FALSE(s.falls);
    // Mid-span sag of the model, 0.8 (L / 50)^2 mm, over the unsupported span.
    const double want = 0.8 * (span / 50) * (span / 50);
    EXPECT_NEAR(s.drop_mm, want, 0.15 * want + 0.01);
    EXPECT_GT(s.drop_mm, last);
    last = s.drop_mm;
    // The bead's bottom at mid-span sits that much lower than the rigid bead's.
    const double mid = 42.0 + 0.5 * span;
    const double sag = lowest_bottom(*flat, mid, 50.4, 1.9) - lowest_bottom(*r, mid, 50.4, 0.1);
    EXPECT_NEAR(sag, s.drop_mm, 0.06);
    if (span == 5.0) {
      EXPECT_LT(sag, 0.2);
    }
    // Sagging moves the bead, it does not make or lose plastic.
    // (The round joins at the corners follow the wider foot: within 1 %.)
    EXPECT_NEAR(r->volume_mm3, flat->volume_mm3, 0.01 * flat->volume_mm3);
    ASSERT_EQ(r->findings.size(), 1u);
    EXPECT_NE(r->findings[0].message.find("predicted to sag up to"), std::string::npos)
        << r->findings[0].message;
  }
}

/// Single-bead walls leaning theta from vertical (layer i at x0 + i h tan(theta)).
std::vector<Move> leaning_wall(const PrinterProfile& p, double deg, int layers) {
  BeadWriter w(p);
  for (int layer = 0; layer < layers; ++layer) {
    w.layer = layer;
    const double z = kH * (layer + 1);
    const double x = 30.0 + layer * kH * std::tan(deg * std::numbers::pi / 180.0);
    w.travel({x, 40, z});
    w.extrude({x, 60, z}, kW, kH);
  }
  return w.moves;
}

TEST(DepositDroop, OverhangDroopGrowsWithTheAngle) {
  const auto profile = ender3_marlin2();
  const int layers = 12;
  double drop[4] = {};
  const double angles[4] = {30, 45, 60, 75};
  for (int i = 0; i < 4; ++i) {
    auto r = deposit_moves(leaning_wall(profile, angles[i], layers), profile, DepositSettings{});
    ASSERT_TRUE(r.ok());
    for (const auto& s : r->unsupported) {
      drop[i] = std::max(drop[i], s.drop_mm);
      EXPECT_FALSE(s.falls);
    }
    // The wall's top layer: its bottom lies `drop` below where the rigid model puts it.
    auto flat = deposit_moves(leaning_wall(rigid(), angles[i], layers), rigid(), DepositSettings{});
    ASSERT_TRUE(flat.ok());
    const double x_top = 30.0 + (layers - 1) * kH * std::tan(angles[i] * std::numbers::pi / 180.0);
    const double z_min = kH * (layers - 1) - 1.0;
    EXPECT_NEAR(lowest_bottom(*flat, x_top, 50, z_min) - lowest_bottom(*r, x_top, 50, z_min),
                drop[i], 0.06)
        << angles[i];
    // (The round joins at the corners follow the wider foot: within 1 %.)
    EXPECT_NEAR(r->volume_mm3, flat->volume_mm3, 0.01 * flat->volume_mm3);
  }
  EXPECT_EQ(drop[0], 0);  // 30 deg: 74 % of the bead rests on the layer below
  EXPECT_EQ(drop[1], 0);  // 45 deg: 56 %
  EXPECT_GT(drop[2], 0);  // 60 deg: 0.12 mm beyond the edge
  EXPECT_LT(drop[2], 0.05);
  // 75 deg: 0.52 mm beyond the edge, 2.0 (0.52 / 1.5)^2 = 0.24 mm (the edge is found in
  // voxel steps: 0.55-0.6 mm, 0.27-0.32 mm), the same on every layer: each bead hangs from
  // the drooped one below, no collapse.
  EXPECT_GT(drop[3], 0.2);
  EXPECT_LT(drop[3], 0.35);
}

TEST(DepositDroop, ABeadFarBeyondTheEdgeFallsOntoWhatIsBelow) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  for (int layer = 0; layer < 5; ++layer) {  // a 3-bead pillar, 1 mm tall
    w.layer = layer;
    const double z = kH * (layer + 1);
    for (double y : {50.0, 50.4, 50.8}) {
      w.travel({40, y, z});
      w.extrude({45, y, z}, kW, kH);
    }
  }
  w.layer = 5;
  w.travel({42, 50.4, 1.2});
  w.extrude({50, 50.4, 1.2}, kW, kH);  // runs 5 mm out beyond the pillar: a ledge in air
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->unsupported.size(), 1u);
  const auto& s = r->unsupported.front();
  EXPECT_FALSE(s.bridge);
  EXPECT_TRUE(s.falls);
  // It would hang 2 mm, but the bed is 1.0 mm below the bead's bottom: it lands there.
  EXPECT_NEAR(s.drop_mm, 1.0, 0.06);
  EXPECT_NEAR(lowest_bottom(*r, 49, 50.4, -1), 0.0, 1e-9);
  ASSERT_EQ(r->findings.size(), 1u);
  EXPECT_EQ(r->findings[0].code, "extrusion_into_air_cantilever");
  EXPECT_NE(r->findings[0].message.find("falls onto what is below"), std::string::npos);
}

/// A plate over a support grid: two pillars (x 26-28 and 62-64, y 39-53) up to the plate's
/// bottom, support lines along x every 2.5 mm (y 40-50) between them, one layer short of the
/// plate (the support's Z gap), then the plate's walls along x over the whole width: three
/// between support lines and one 1.4 mm beyond the last. `with_support` false: the same
/// without the support, a bridge from pillar to pillar.
constexpr int kPlateLayer = 6;
constexpr double kPlateWallY[4] = {41.25, 43.75, 46.25, 51.4};
std::vector<Move> plate_over_support(const PrinterProfile& p, bool with_support) {
  BeadWriter w(p);
  for (int layer = 0; layer < kPlateLayer; ++layer) {
    w.layer = layer;
    const double z = kH * (layer + 1);
    w.feature = Feature::perimeter;
    for (const double x0 : {26.2, 62.2})
      for (double x = x0; x < x0 + 1.7; x += 0.4) {
        w.travel({x, 39, z});
        w.extrude({x, 53, z}, kW, kH);
      }
    if (!with_support || layer + 1 >= kPlateLayer) continue;  // the Z gap: one layer
    w.feature = Feature::support;
    for (double y = 40; y < 50.1; y += 2.5) {
      w.travel({29, y, z});
      w.extrude({61, y, z}, kW, kH);
    }
  }
  w.layer = kPlateLayer;
  w.feature = Feature::perimeter;
  const double z = kH * (kPlateLayer + 1);
  for (const double y : kPlateWallY) {
    w.travel({26.5, y, z});
    w.extrude({63.5, y, z}, kW, kH);
  }
  return w.moves;
}

TEST(DepositDroop, BeadsOverASupportGridRestOnItAcrossTheZGap) {
  const auto profile = ender3_marlin2();
  auto on = deposit_moves(plate_over_support(profile, true), profile, DepositSettings{});
  auto off = deposit_moves(plate_over_support(profile, false), profile, DepositSettings{});
  ASSERT_TRUE(on.ok() && off.ok());
  const double bottom = kH * kPlateLayer;             // the walls' nominal bottom
  const double support_top = kH * (kPlateLayer - 1);  // one layer lower: the Z gap
  const double gap = bottom - support_top;
  for (const double y : kPlateWallY) {
    SCOPED_TRACE(y);
    for (const double x : {35.0, 45.0, 55.0}) {
      // On the support grid the wall falls at most onto the support's top.
      const double rest = lowest_bottom(*on, x, y, 0.1);
      EXPECT_GE(rest, support_top - on->voxel_mm - 1e-9) << x;
      EXPECT_LE(rest, bottom + on->voxel_mm) << x;
    }
    // Without the support it is a 34 mm bridge from pillar to pillar: 0.8 (34 / 50)^2 = 0.37
    // mm at mid-span, below where the support's top would be.
    EXPECT_LT(lowest_bottom(*off, 45.0, y, 0.1), support_top - off->voxel_mm);
  }
  double drop = 0;
  for (const auto& s : on->unsupported) drop = std::max(drop, s.drop_mm);
  EXPECT_LE(drop, gap + on->voxel_mm);
  double sag = 0;
  for (const auto& s : off->unsupported) sag = std::max(sag, s.drop_mm);
  // At least the parabola's 0.37 mm (the walls also hang from the pillars' rounded flanks).
  EXPECT_GT(sag, 0.8 * (34.0 / 50) * (34.0 / 50) - 0.02);
}

TEST(DepositDroop, SparseInfillOverTheCellsBelowIsInfoAndStaysInPlace) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.feature = Feature::sparse_infill;
  for (int layer = 0; layer < 5; ++layer) {  // infill lines along Y every 5 mm
    w.layer = layer;
    for (double x : {40.0, 45.0}) {
      w.travel({x, 40, kH * (layer + 1)});
      w.extrude({x, 50, kH * (layer + 1)}, kW, kH);
    }
  }
  w.layer = 5;
  w.travel({39, 45, 1.2});
  w.extrude({46, 45, 1.2}, kW, kH);  // crosses the 5 mm cell
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->findings.size(), 1u);
  EXPECT_EQ(r->findings[0].code, "extrusion_into_air_sparse_infill");
  EXPECT_EQ(r->findings[0].severity, Severity::info);
  for (const auto& s : r->unsupported) EXPECT_EQ(s.drop_mm, 0);
  EXPECT_NEAR(lowest_bottom(*r, 42.5, 45, 0.5), 1.0, 1e-9);
}

/// A first-layer square: an inner perimeter loop, then the outer one around it.
std::vector<Move> first_layer_square(const PrinterProfile& p) {
  BeadWriter w(p);
  const double spacing = kW - kH * (1 - std::numbers::pi / 4);
  for (const auto& [inset, feature] :
       {std::pair{spacing, Feature::perimeter}, std::pair{0.0, Feature::outer_perimeter}}) {
    w.feature = feature;
    const double lo = 50 + inset, hi = 60 - inset;
    w.travel({lo, lo, kH});
    w.extrude({hi, lo, kH}, kW, kH);
    w.extrude({hi, hi, kH}, kW, kH);
    w.extrude({lo, hi, kH}, kW, kH);
    w.extrude({lo, lo, kH}, kW, kH);
  }
  return w.moves;
}

TEST(DepositDroop, FirstLayerOuterEdgeBulgesIntoAnElephantFoot) {
  const auto profile = ender3_marlin2();  // elephant_foot_mm 0.1
  auto r = deposit_moves(first_layer_square(profile), profile, DepositSettings{});
  auto flat = deposit_moves(first_layer_square(rigid()), rigid(), DepositSettings{});
  ASSERT_TRUE(r.ok() && flat.ok());
  // The outer edge moves out by the profile's 0.1 mm on every side (2 voxels); the inner
  // perimeter's side stays.
  for (int a = 0; a < 2; ++a) {
    EXPECT_NEAR(flat->bbox_mm.min[a] - r->bbox_mm.min[a], 0.1, 0.051) << a;
    EXPECT_NEAR(r->bbox_mm.max[a] - flat->bbox_mm.max[a], 0.1, 0.051) << a;
  }
  // Pressed down, not made: the same plastic, no more overlap with the inner loop.
  // (The round joins at the corners follow the wider foot: within 1 %.)
  EXPECT_NEAR(r->volume_mm3, flat->volume_mm3, 0.01 * flat->volume_mm3);
  EXPECT_NEAR(r->overlap_mm3, flat->overlap_mm3, 0.005 * flat->volume_mm3);
}

}  // namespace
}  // namespace printtwin
