// Planner invariants on real slicer G-code and on hand-made moves: no axis above its
// feedrate or acceleration limit, speed continuous at junctions, every trapezoid covers its
// length, segment and wait times add up to the clock.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "printtwin/planner.hpp"
#include "printtwin/simulate.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

struct Recorder final : MoveSink {
  std::vector<MotionSegment> segments;
  std::vector<std::pair<double, double>> waits;  // start, duration
  void on_segment(const MotionSegment& s) override { segments.push_back(s); }
  void on_wait(double start, double duration, bool, long) override { waits.emplace_back(start, duration); }
};

double profile_distance(const MotionSegment& s) {
  const double ta = s.accel_time_s, tc = s.cruise_time_s, td = s.decel_time_s, a = s.accel_mm_s2;
  return s.start_speed_mm_s * ta + 0.5 * a * ta * ta + s.cruise_speed_mm_s * tc + s.cruise_speed_mm_s * td -
         0.5 * a * td * td;
}

/// Checks every invariant on a recorded simulation. `limits` are the limits in force
/// (the fixtures do not change them mid-file except M204 P, which is <= the limits used).
void check_invariants(const Recorder& rec, const MotionLimits& limits, double clock_s, bool continuous) {
  ASSERT_FALSE(rec.segments.empty());
  double total = 0;
  std::size_t wait_i = 0;
  double t = 0;
  for (std::size_t k = 0; k < rec.segments.size(); ++k) {
    const MotionSegment& s = rec.segments[k];
    // Waits between segments.
    while (wait_i < rec.waits.size() && rec.waits[wait_i].first <= s.start_time_s + 1e-9) {
      EXPECT_NEAR(rec.waits[wait_i].first, t, 1e-6);
      t += rec.waits[wait_i].second;
      total += rec.waits[wait_i].second;
      ++wait_i;
    }
    EXPECT_NEAR(s.start_time_s, t, 1e-6) << "segment " << k << " line " << s.line;
    t = s.end_time_s();
    total += s.duration_s();
    // Trapezoid: covers exactly its length, speeds ordered.
    EXPECT_NEAR(profile_distance(s), s.length_mm, 1e-6 * std::max(1.0, s.length_mm)) << "line " << s.line;
    EXPECT_LE(s.cruise_speed_mm_s, s.nominal_speed_mm_s + 1e-9);
    EXPECT_LE(s.start_speed_mm_s, s.cruise_speed_mm_s + 1e-9);
    EXPECT_LE(s.end_speed_mm_s, s.cruise_speed_mm_s + 1e-9);
    // Per-axis limits (X, Y, Z; E for moves that also move XYZ).
    const double xyz = (s.end_mm - s.start_mm).norm();
    if (s.kind != MoveKind::home) {
      for (int i = 0; i < 3; ++i) {
        const double u = std::fabs(s.end_mm[i] - s.start_mm[i]) / s.length_mm;
        EXPECT_LE(u * s.cruise_speed_mm_s, limits.max_feedrate_mm_s[i] * (1 + 1e-9)) << "axis " << i << " line " << s.line;
        EXPECT_LE(u * s.accel_mm_s2, limits.max_accel_mm_s2[i] * (1 + 1e-9)) << "axis " << i << " line " << s.line;
      }
      const double ue = std::fabs(s.e_mm) / s.length_mm;
      EXPECT_LE(ue * s.cruise_speed_mm_s, limits.max_feedrate_mm_s[3] * (1 + 1e-9)) << "E, line " << s.line;
      if (xyz > 0) {
        EXPECT_LE(ue * s.accel_mm_s2, limits.max_accel_mm_s2[3] * (1 + 1e-9));
      }
    }
    // Continuity: the next segment starts at the speed this one ends with.
    if (continuous && k + 1 < rec.segments.size() &&
        std::fabs(rec.segments[k + 1].start_time_s - s.end_time_s()) < 1e-9) {
      EXPECT_NEAR(rec.segments[k + 1].start_speed_mm_s, s.end_speed_mm_s, 1e-9) << "line " << s.line;
    }
  }
  for (; wait_i < rec.waits.size(); ++wait_i) total += rec.waits[wait_i].second;
  EXPECT_NEAR(total, clock_s, 1e-6 * clock_s);
}

class PlannerOnFixture : public ::testing::TestWithParam<std::string> {};

TEST_P(PlannerOnFixture, InvariantsHoldWithJunctionDeviation) {
  Recorder rec;
  const PrinterProfile p = ender3_marlin2();
  auto r = simulate_gcode_file(test::source_path("samples/gcode/" + GetParam()), p, {}, &rec);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  check_invariants(rec, motion_limits_from_profile(p), r->print_time_s, true);
  EXPECT_EQ(static_cast<long>(rec.segments.size()), r->segments);
  // The first segment after a stop starts from rest.
  EXPECT_LE(rec.segments.front().start_speed_mm_s, kMinimumPlannerSpeed_mm_s + 1e-12);
  EXPECT_LE(rec.segments.back().end_speed_mm_s, kMinimumPlannerSpeed_mm_s + 1e-12);
}

TEST_P(PlannerOnFixture, InvariantsHoldWithClassicJerk) {
  Recorder rec;
  const PrinterProfile p = ender3_marlin1();
  auto r = simulate_gcode_file(test::source_path("samples/gcode/" + GetParam()), p, {}, &rec);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  // Classic jerk allows speed steps at junctions (up to the jerk), so no continuity check.
  check_invariants(rec, motion_limits_from_profile(p), r->print_time_s, false);
}

INSTANTIATE_TEST_SUITE_P(Fixtures, PlannerOnFixture,
                         ::testing::Values("prusa_cube10.gcode", "prusa_curved_part.gcode", "cura_cube10.gcode",
                                           "slic3r_cube10.gcode", "seed_square_box.gcode"));

Move line_move(const Vec3& a, const Vec3& b, double f, double e = 0) {
  Move m;
  m.start_mm = a;
  m.end_mm = b;
  m.feedrate_mm_s = f;
  m.e_mm = e;
  m.kind = e > 0 ? MoveKind::extrude : MoveKind::travel;
  return m;
}

TEST(Planner, SingleMoveIsATextbookTrapezoid) {
  MotionLimits l;
  Planner planner(l, 16);
  Recorder rec;
  planner.add(line_move(Vec3(0, 0, 0), Vec3(100, 0, 0), 100), rec);
  planner.flush(rec);
  ASSERT_EQ(rec.segments.size(), 1u);
  const auto& s = rec.segments[0];
  // 0 -> 100 mm/s at 500 mm/s^2: 0.2 s and 10 mm each way, 80 mm cruise.
  EXPECT_NEAR(s.accel_time_s, 0.2, 1e-3);
  EXPECT_NEAR(s.decel_time_s, 0.2, 1e-3);
  EXPECT_NEAR(s.cruise_time_s, 0.8, 1e-3);
  EXPECT_NEAR(planner.clock_s(), 1.2, 1e-3);
  EXPECT_NEAR(s.position_at(0.6).x(), 50.0, 0.05);
  EXPECT_NEAR(s.speed_at(0.6), 100.0, 1e-9);
}

TEST(Planner, PerAxisLimitsScaleDiagonalsAndZ) {
  MotionLimits l;
  Planner planner(l, 16);
  Recorder rec;
  // Z is limited to 5 mm/s and 100 mm/s^2.
  planner.add(line_move(Vec3(0, 0, 0), Vec3(0, 0, 10), 50), rec);
  planner.flush(rec);
  ASSERT_EQ(rec.segments.size(), 1u);
  EXPECT_NEAR(rec.segments[0].nominal_speed_mm_s, 5.0, 1e-12);
  EXPECT_NEAR(rec.segments[0].accel_mm_s2, 100.0, 1e-12);
  // A 45 degree XY move may accelerate at 500 * sqrt(2) along the path (each axis 500).
  l.travel_accel_mm_s2 = 3000;
  Planner p2(l, 16);
  Recorder rec2;
  p2.add(line_move(Vec3(0, 0, 0), Vec3(50, 50, 0), 100), rec2);
  p2.flush(rec2);
  EXPECT_NEAR(rec2.segments[0].accel_mm_s2, 500 * std::sqrt(2.0), 1e-9);
}

TEST(Planner, JunctionDeviationSpeedAtARightAngleAndStraightJoin) {
  MotionLimits l;
  Planner planner(l, 16);
  Recorder rec;
  planner.add(line_move(Vec3(0, 0, 0), Vec3(50, 0, 0), 100), rec);
  planner.add(line_move(Vec3(50, 0, 0), Vec3(50, 50, 0), 100), rec);
  planner.add(line_move(Vec3(50, 50, 0), Vec3(50, 100, 0), 100), rec);
  planner.flush(rec);
  ASSERT_EQ(rec.segments.size(), 3u);
  // 90 degrees: v^2 = a * JD * s / (1 - s), s = sin(45 deg); a = the block's 500 mm/s^2
  // (the per-axis limit along the junction vector (-1, 1)/sqrt2 would allow 707).
  const double s = std::sqrt(0.5);
  const double a = 500;
  EXPECT_NEAR(rec.segments[0].end_speed_mm_s, std::sqrt(a * 0.08 * s / (1 - s)), 1e-6);
  // Straight continuation: no slowdown at all.
  EXPECT_NEAR(rec.segments[1].end_speed_mm_s, 100.0, 1e-6);
}

TEST(Planner, ShortSegmentsOfACurveShareTheArcSpeed) {
  // 72-gon of radius 10 at 100 mm/s: the small-segment rule caps the junction at
  // v^2 = a * L / theta, the centripetal limit of the circle the polygon approximates.
  MotionLimits l;
  Planner planner(l, 16);
  Recorder rec;
  Vec3 prev(10, 0, 0);
  for (int i = 1; i <= 144; ++i) {
    const double t = 2 * M_PI * i / 72;
    const Vec3 p(10 * std::cos(t), 10 * std::sin(t), 0);
    planner.add(line_move(prev, p, 100), rec);  // travel: no E in the junction vector
    prev = p;
  }
  planner.flush(rec);
  const double seg = 2 * 10 * std::sin(M_PI / 72);
  const double theta = 2 * M_PI / 72;
  double vmax = 0;
  for (std::size_t k = 10; k + 10 < rec.segments.size(); ++k) vmax = std::max(vmax, rec.segments[k].end_speed_mm_s);
  // (Junction deviation alone would allow ~205 mm/s at these 5 degree corners.)
  const double expected = std::sqrt(500 * seg / theta);
  EXPECT_NEAR(vmax, expected, 0.005 * expected);
  EXPECT_LT(vmax, 100.0);
}

TEST(Planner, WindowBoundsMemoryAndClassicJerkStartsAtSafeSpeed) {
  MotionLimits l;
  l.junction = JunctionModel::classic_jerk;
  Planner planner(l, 16);
  Recorder rec;
  for (int i = 0; i < 1000; ++i) {
    planner.add(line_move(Vec3(i % 2 ? 10 : 0, 0, 0), Vec3(i % 2 ? 0 : 10, 0, 0), 50), rec);
    EXPECT_LT(planner.queued(), 16);
  }
  planner.flush(rec);
  ASSERT_EQ(rec.segments.size(), 1000u);
  // Reversals at 50 mm/s with 10 mm/s X jerk: the safe speed is 10 mm/s and no junction
  // is faster (a reversal's jerk is the larger of both speeds).
  EXPECT_NEAR(rec.segments.front().start_speed_mm_s, 10.0, 1e-9);
  for (std::size_t k = 1; k + 1 < rec.segments.size(); ++k) EXPECT_LE(rec.segments[k].end_speed_mm_s, 10.0 + 1e-9);
}

}  // namespace
}  // namespace printtwin
