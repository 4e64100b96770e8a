// Extrusion into air: overhang faces at 30/45/60/75 degrees from vertical, a bridge between
// two pillars, and the support fraction setting.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "deposit/deposit_test_support.hpp"
#include "printtwin/deposit.hpp"

namespace printtwin {
namespace {

using test::BeadWriter;

/// Four single-bead walls along Y; layer i of the wall at x0 sits at x0 + i h tan(theta).
std::vector<Move> overhang_walls(const PrinterProfile& profile,
                                 const std::vector<double>& angles_deg, int layers) {
  BeadWriter w(profile);
  const double h = 0.2, width = 0.45;
  for (int layer = 0; layer < layers; ++layer) {
    w.layer = layer;
    const double z = h * (layer + 1);
    for (std::size_t f = 0; f < angles_deg.size(); ++f) {
      const double x = 30.0 + 20.0 * static_cast<double>(f) +
                       layer * h * std::tan(angles_deg[f] * std::numbers::pi / 180.0);
      w.travel({x, 40, z});
      w.extrude({x, 60, z}, width, h);
    }
  }
  return w.moves;
}

/// Findings of a kind whose extent lies in the x range of wall f.
int findings_on_wall(const DepositResult& r, int wall, const std::string& code) {
  int n = 0;
  for (const auto& f : r.findings) {
    if (f.code != code || !f.extent_mm) continue;
    const double x = f.extent_mm->center().x();
    if (x >= 30.0 + 20.0 * wall - 1 && x < 30.0 + 20.0 * (wall + 1) - 1) ++n;
  }
  return n;
}

TEST(DepositSupport, StartCodeLinesAtTwoHeightsLieOnTheBed) {
  // Bambu's X1 start code: a purge line at Z 0.2, then a flow calibration line at Z 0.3 over
  // bare bed (0.3 mm tall), both before the first layer. Neither hangs in the air.
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  w.layer = -1;
  w.feature = Feature::custom;
  w.travel({30, 20, 0.2});
  w.extrude({130, 20, 0.2}, 0.5, 0.2);
  w.travel({30, 30, 0.3});
  w.extrude({130, 30, 0.3}, 0.5, 0.3);
  w.layer = 0;
  w.feature = Feature::perimeter;
  w.travel({50, 50, 0.2});
  w.extrude({70, 50, 0.2}, 0.45, 0.2);
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok()) << r.error().describe();
  for (const auto& f : r->findings)
    EXPECT_EQ(f.code.rfind("extrusion_into_air", 0), std::string::npos) << f.message;
  // The calibration line's voxels reach the bed: its column at x = 80 starts at z = 0.
  const VoxelGrid& g = r->grid;
  const double v = g.voxel_mm();
  const auto key = g.key_of(Vec3(80, 30, 0.5 * v));
  EXPECT_TRUE(g.occupied(key));
}

TEST(DepositSupport, OverhangFacesAt60And75DegreesAreFlagged) {
  const auto profile = ender3_marlin2();
  const std::vector<double> angles{30, 45, 60, 75};
  const int layers = 10;
  auto r = deposit_moves(overhang_walls(profile, angles, layers), profile, DepositSettings{});
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const std::string cantilever = "extrusion_into_air_cantilever";
  EXPECT_EQ(findings_on_wall(*r, 0, cantilever), 0);  // 30 deg: 74 % of the bead supported
  EXPECT_EQ(findings_on_wall(*r, 1, cantilever), 0);  // 45 deg: 56 %
  // 60 deg (23 % supported) and 75 deg (0 %): every layer above the first overhangs.
  EXPECT_EQ(findings_on_wall(*r, 2, cantilever), layers - 1);
  EXPECT_EQ(findings_on_wall(*r, 3, cantilever), layers - 1);
  for (const auto& f : r->findings) {
    EXPECT_EQ(f.severity, Severity::warning);
    ASSERT_TRUE(f.layer && f.line && f.position_mm && f.value);
    EXPECT_GE(*f.layer, 1);
    EXPECT_NEAR(*f.value, 20.0, 0.06);  // the whole 20 mm bead
    EXPECT_NEAR(f.position_mm->y(), 40.0, 0.06);
    EXPECT_NE(f.message.find("lines"), std::string::npos);
  }
  ASSERT_EQ(r->unsupported.size(), 2u * (layers - 1));
  double reported_mm = 0;
  for (const auto& s : r->unsupported) reported_mm += s.length_mm;
  EXPECT_NEAR(reported_mm, 2 * (layers - 1) * 20.0, 0.5);
  // Near the 50 % threshold (45 deg) a few short stretches fall under min_unsupported_mm (the
  // beads pay for their round end caps: 1.6 % less section, 56 % supported becomes 55 %).
  EXPECT_GE(r->unsupported_mm, reported_mm);
  EXPECT_LT(r->unsupported_mm, reported_mm + 40.0);
  // Each stretch names the G-code line of its bead.
  for (const auto& s : r->unsupported) {
    EXPECT_EQ(s.first_line, s.last_line);
    EXPECT_EQ(s.first_line % 2, 0);  // travel on odd lines, beads on even lines
    EXPECT_FALSE(s.bridge);
  }
  // Beads in air keep the nominal layer height: the 75 deg wall is 10 layers tall.
  EXPECT_NEAR(r->bbox_mm.max.z(), 2.0, 1e-9);
}

TEST(DepositSupport, SupportFractionIsConfigurable) {
  const auto profile = ender3_marlin2();
  const auto moves = overhang_walls(profile, {45}, 6);
  DepositSettings strict;
  strict.support_fraction = 0.7;  // 45 deg rests 56 % of its width: now flagged
  auto r = deposit_moves(moves, profile, strict);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(findings_on_wall(*r, 0, "extrusion_into_air_cantilever"), 5);
  DepositSettings loose;
  loose.support_fraction = 0.5;
  auto q = deposit_moves(moves, profile, loose);
  ASSERT_TRUE(q.ok());
  EXPECT_TRUE(q->findings.empty());
}

TEST(DepositSupport, BridgeBetweenPillarsIsTellApartFromCantilever) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const double h = 0.2;
  for (int layer = 0; layer < 10; ++layer) {  // two pillars 2 mm long, 10 mm apart
    w.layer = layer;
    const double z = h * (layer + 1);
    for (double x0 : {40.0, 52.0}) {
      for (double y : {50.0, 50.4, 50.8}) {
        w.travel({x0, y, z});
        w.extrude({x0 + 2, y, z}, 0.45, h);
      }
    }
  }
  w.layer = 10;
  w.feature = Feature::bridge_infill;
  const double z = h * 11;
  w.travel({40.5, 50.4, z});
  w.extrude({48, 50.4, z}, 0.45, h);  // two moves of one continuous path
  w.extrude({53.5, 50.4, z}, 0.45, h);
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->unsupported.size(), 1u);
  const auto& s = r->unsupported.front();
  EXPECT_TRUE(s.bridge);
  EXPECT_EQ(s.layer, 10);
  EXPECT_EQ(s.feature, Feature::bridge_infill);
  EXPECT_EQ(s.first_line, w.line - 1);
  EXPECT_EQ(s.last_line, w.line);
  // Unsupported from about x = 42.0 + half the support band to 52.0 - half of it.
  EXPECT_NEAR(s.length_mm, 10.0, 0.4);
  EXPECT_NEAR(s.start_mm.x(), 42.0, 0.3);
  EXPECT_NEAR(s.end_mm.x(), 52.0, 0.3);
  ASSERT_EQ(r->findings.size(), 1u);
  EXPECT_EQ(r->findings[0].code, "extrusion_into_air_bridge");
  EXPECT_EQ(r->findings[0].severity, Severity::info);
  EXPECT_EQ(*r->findings[0].line, w.line - 1);
}

}  // namespace
}  // namespace printtwin
