// Sag, droop and elephant's foot: the model's pure functions (deposit/droop.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "deposit/droop.hpp"

namespace printtwin::detail {
namespace {

DroopModel stock() { return DroopModel::from(ender3_marlin2()); }

TEST(DroopModel, DefaultsComeFromTheProfile) {
  const auto p = ender3_marlin2();
  const auto m = stock();
  EXPECT_EQ(m.bridge_sag_mm, p.bridge_sag_mm);
  EXPECT_EQ(m.bridge_sag_span_mm, p.bridge_sag_span_mm);
  EXPECT_EQ(m.overhang_fall_mm, p.overhang_fall_mm);
  EXPECT_EQ(m.overhang_droop_mm, p.overhang_droop_mm);
  EXPECT_EQ(m.elephant_foot_mm, p.elephant_foot_mm);
  EXPECT_TRUE(m.deforms());
}

TEST(DroopModel, BridgeSagGrowsWithTheSquareOfTheSpanAndIsParabolic) {
  const auto m = stock();
  // Mid-span sag: 0.8 mm at 50 mm, so 0.008 / 0.032 / 0.128 / 0.512 mm at 5 / 10 / 20 / 40 mm.
  EXPECT_NEAR(m.bridge_sag(5, 2.5), 0.008, 1e-12);
  EXPECT_NEAR(m.bridge_sag(10, 5), 0.032, 1e-12);
  EXPECT_NEAR(m.bridge_sag(20, 10), 0.128, 1e-12);
  EXPECT_NEAR(m.bridge_sag(40, 20), 0.512, 1e-12);
  EXPECT_LT(m.bridge_sag(5, 2.5), 0.2);
  // Zero at the anchors, 3/4 of the mid-span sag a quarter of the way across, symmetric.
  EXPECT_EQ(m.bridge_sag(40, 0), 0);
  EXPECT_EQ(m.bridge_sag(40, 40), 0);
  EXPECT_NEAR(m.bridge_sag(40, 10), 0.75 * 0.512, 1e-12);
  EXPECT_NEAR(m.bridge_sag(40, 10), m.bridge_sag(40, 30), 1e-12);
}

TEST(DroopModel, CantileverDroopGrowsWithTheDistanceBeyondTheEdgeAndFalls) {
  const auto m = stock();
  EXPECT_EQ(m.cantilever_droop(-0.1), 0);  // centre still over the layer below
  EXPECT_EQ(m.cantilever_droop(0), 0);
  // Single-bead walls, 0.2 mm layers, 0.45 mm line: the bead's centre is h tan(theta) - w/2
  // beyond the edge below.
  auto beyond = [](double deg) { return 0.2 * std::tan(deg * std::numbers::pi / 180) - 0.225; };
  EXPECT_EQ(m.cantilever_droop(beyond(30)), 0);
  EXPECT_EQ(m.cantilever_droop(beyond(45)), 0);
  EXPECT_LT(m.cantilever_droop(beyond(60)), 0.02);
  EXPECT_GT(m.cantilever_droop(beyond(75)), 0.2);
  EXPECT_NEAR(m.cantilever_droop(0.75), 0.5, 1e-12);
  EXPECT_NEAR(m.cantilever_droop(1.5), 2.0, 1e-12);
  EXPECT_NEAR(m.cantilever_droop(5.0), 2.0, 1e-12);
}

TEST(DroopModel, PredictDropPicksTheHoldAndNeverSinksIntoWhatIsBelow) {
  const auto m = stock();
  // Held at both ends 10 and 30 mm away: a 40 mm bridge.
  Drop d = predict_drop(m, 10, 30, kNoAnchor, 100);
  EXPECT_EQ(d.kind, DropKind::bridge);
  EXPECT_NEAR(d.mm, 0.75 * 0.512, 1e-12);
  // The same, but an edge 0.3 mm away holds it better.
  d = predict_drop(m, 10, 30, 0.3, 100);
  EXPECT_EQ(d.kind, DropKind::cantilever);
  EXPECT_NEAR(d.mm, 0.08, 1e-12);
  // Held on one side only, 0.75 mm beyond the edge.
  d = predict_drop(m, 2, kNoAnchor, 0.75, 100);
  EXPECT_EQ(d.kind, DropKind::cantilever);
  EXPECT_NEAR(d.mm, 0.5, 1e-12);
  // Too far out: it falls, and hangs overhang_droop_mm when nothing is below...
  d = predict_drop(m, kNoAnchor, kNoAnchor, kNoAnchor, 100);
  EXPECT_EQ(d.kind, DropKind::fallen);
  EXPECT_NEAR(d.mm, 2.0, 1e-12);
  // ...or lands on what is below.
  d = predict_drop(m, kNoAnchor, kNoAnchor, kNoAnchor, 0.6);
  EXPECT_EQ(d.kind, DropKind::fallen);
  EXPECT_NEAR(d.mm, 0.6, 1e-12);
  d = predict_drop(m, 10, 30, kNoAnchor, 0.1);
  EXPECT_NEAR(d.mm, 0.1, 1e-12);
  // A model without sag or droop leaves every bead where it is.
  DroopModel off = m;
  off.bridge_sag_mm = off.overhang_droop_mm = 0;
  EXPECT_FALSE(off.deforms());
  EXPECT_EQ(predict_drop(off, kNoAnchor, kNoAnchor, kNoAnchor, 100).mm, 0);
}

TEST(DroopModel, KnotsFollowTheDropsWithinTolerance) {
  std::vector<DropKnot> knots;
  std::vector<double> drops(100, 0.0);
  drop_knots(drops, 10, 0.01, knots);
  EXPECT_TRUE(knots.empty());  // nothing drops: lay the bead as it is
  for (std::size_t i = 0; i < drops.size(); ++i) drops[i] = 0.25;
  drop_knots(drops, 10, 0.01, knots);
  ASSERT_EQ(knots.size(), 2u);  // a level drop: the bead's two ends
  EXPECT_EQ(knots.front().t, 0);
  EXPECT_EQ(knots.back().t, 1);
  EXPECT_EQ(knots.front().mm, 0.25);
  // A parabola (a bridge): every sample lies within the tolerance of the lowering.
  const auto m = stock();
  for (std::size_t i = 0; i < drops.size(); ++i)
    drops[i] = m.bridge_sag(40, 40 * (i + 0.5) / 100.0);
  drop_knots(drops, 5, 0.005, knots);
  EXPECT_GT(knots.size(), 3u);
  EXPECT_LE(knots.size(), 21u);
  for (std::size_t i = 0; i < drops.size(); ++i) {
    const double t = (i + 0.5) / 100.0;
    std::size_t k = 1;
    while (knots[k].t < t) ++k;
    const double f = (t - knots[k - 1].t) / (knots[k].t - knots[k - 1].t);
    EXPECT_NEAR(knots[k - 1].mm + f * (knots[k].mm - knots[k - 1].mm), drops[i], 0.012) << i;
  }
}

// A long bridge, as the deposit samples it (40 mm at 0.05 mm, a candidate every 0.5 mm):
// the parabola bends little from one candidate to the next, but the lowering must follow it
// over the whole span, its mid-span sag included.
TEST(DroopModel, KnotsFollowALongSagOverItsWholeSpan) {
  const auto m = stock();
  std::vector<double> drops(800);
  for (std::size_t i = 0; i < drops.size(); ++i)
    drops[i] = m.bridge_sag(40, 40 * (i + 0.5) / 800.0);
  std::vector<DropKnot> knots;
  drop_knots(drops, 10, 0.01, knots);
  std::size_t k = 1;
  for (std::size_t i = 0; i < drops.size(); ++i) {
    const double t = (i + 0.5) / 800.0;
    while (knots[k].t < t) ++k;
    const double f = (t - knots[k - 1].t) / (knots[k].t - knots[k - 1].t);
    EXPECT_NEAR(knots[k - 1].mm + f * (knots[k].mm - knots[k - 1].mm), drops[i], 0.012) << i;
  }
}

TEST(DroopModel, ElephantFootWidensTheOpenSideAndKeepsTheArea) {
  const double w = 0.45, h = 0.2;
  const double area = (w - h) * h + std::numbers::pi * h * h / 4;
  auto area_of = [](const FootSection& s) {
    return (s.w - s.h) * s.h + std::numbers::pi * s.h * s.h / 4;
  };
  const FootSection out = elephant_foot(area, w, h, 0.1, false, true);  // open on the right
  EXPECT_NEAR(out.w, 0.55, 1e-12);
  EXPECT_NEAR(out.shift, -0.05, 1e-12);  // the left edge stays where it was
  EXPECT_LT(out.h, h);
  EXPECT_NEAR(area_of(out), area, 1e-12);
  const FootSection both = elephant_foot(area, w, h, 0.1, true, true);
  EXPECT_NEAR(both.w, 0.65, 1e-12);
  EXPECT_EQ(both.shift, 0);
  EXPECT_NEAR(area_of(both), area, 1e-12);
  const FootSection closed = elephant_foot(area, w, h, 0.1, false, false);
  EXPECT_EQ(closed.w, w);
  EXPECT_EQ(closed.h, h);
}

TEST(DroopModel, AnchorSearchFindsTheNearestEdge) {
  // An edge at x = 1 (everything with x <= 1 holds), searched from x = 1.5.
  auto edge = [](double x, double) { return x <= 1.0; };
  const Vec2 p(1.5, 0), d(0, 1);
  EXPECT_NEAR(distance_to_anchor(p, Vec2(-1, 0), 0.05, 2.0, edge), 0.5, 1e-9);
  EXPECT_EQ(distance_to_anchor(p, Vec2(1, 0), 0.05, 2.0, edge), kNoAnchor);
  EXPECT_NEAR(nearest_anchor(p, d, 0.05, 2.0, edge), 0.5, 1e-9);
  EXPECT_EQ(nearest_anchor(p, d, 0.05, 0.4, edge), kNoAnchor);
}

}  // namespace
}  // namespace printtwin::detail
