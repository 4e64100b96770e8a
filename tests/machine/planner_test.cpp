// Planner invariants on real slicer G-code and on hand-made moves: no axis above its
// feedrate or acceleration limit, speed continuous at junctions, every trapezoid covers its
// length, segment and wait times add up to the clock.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "printtwin/gcode.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/simulate.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

struct Recorder final : MoveSink {
  std::vector<MotionSegment> segments;
  std::vector<std::pair<double, double>> waits;  // start, duration
  void on_segment(const MotionSegment& s) override { segments.push_back(s); }
  void on_wait(double start, double duration, bool, long) override {
    waits.emplace_back(start, duration);
  }
};

double profile_distance(const MotionSegment& s) {
  const double ta = s.accel_time_s, tc = s.cruise_time_s, td = s.decel_time_s, a = s.accel_mm_s2;
  return s.start_speed_mm_s * ta + 0.5 * a * ta * ta + s.cruise_speed_mm_s * tc +
         s.cruise_speed_mm_s * td - 0.5 * a * td * td;
}

/// Checks every invariant on a recorded simulation. `limits` are the limits in force
/// (the fixtures do not change them mid-file except M204 P, which is <= the limits used).
void check_invariants(const Recorder& rec, const MotionLimits& limits, double clock_s,
                      bool continuous) {
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
    EXPECT_NEAR(profile_distance(s), s.length_mm, 1e-6 * std::max(1.0, s.length_mm))
        << "line " << s.line;
    EXPECT_LE(s.cruise_speed_mm_s, s.nominal_speed_mm_s + 1e-9);
    EXPECT_LE(s.start_speed_mm_s, s.cruise_speed_mm_s + 1e-9);
    EXPECT_LE(s.end_speed_mm_s, s.cruise_speed_mm_s + 1e-9);
    // Per-axis limits (X, Y, Z; E for moves that also move XYZ).
    const double xyz = (s.end_mm - s.start_mm).norm();
    if (s.kind != MoveKind::home) {
      for (int i = 0; i < 3; ++i) {
        const double u = std::fabs(s.end_mm[i] - s.start_mm[i]) / s.length_mm;
        EXPECT_LE(u * s.cruise_speed_mm_s, limits.max_feedrate_mm_s[i] * (1 + 1e-9))
            << "axis " << i << " line " << s.line;
        EXPECT_LE(u * s.accel_mm_s2, limits.max_accel_mm_s2[i] * (1 + 1e-9))
            << "axis " << i << " line " << s.line;
      }
      const double ue = std::fabs(s.e_mm) / s.length_mm;
      EXPECT_LE(ue * s.cruise_speed_mm_s, limits.max_feedrate_mm_s[3] * (1 + 1e-9))
          << "E, line " << s.line;
      if (xyz > 0) {
        EXPECT_LE(ue * s.accel_mm_s2, limits.max_accel_mm_s2[3] * (1 + 1e-9));
      }
    }
    // Continuity: the next segment starts at the speed this one ends with.
    if (continuous && k + 1 < rec.segments.size() &&
        std::fabs(rec.segments[k + 1].start_time_s - s.end_time_s()) < 1e-9) {
      EXPECT_NEAR(rec.segments[k + 1].start_speed_mm_s, s.end_speed_mm_s, 1e-9)
          << "line " << s.line;
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
                         ::testing::Values("prusa_cube10.gcode", "prusa_curved_part.gcode",
                                           "cura_cube10.gcode", "slic3r_cube10.gcode",
                                           "seed_square_box.gcode"));

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
  for (std::size_t k = 10; k + 10 < rec.segments.size(); ++k)
    vmax = std::max(vmax, rec.segments[k].end_speed_mm_s);
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
  for (std::size_t k = 1; k + 1 < rec.segments.size(); ++k)
    EXPECT_LE(rec.segments[k].end_speed_mm_s, 10.0 + 1e-9);
}

// ---------------------------------------------------------------------------------------
// Klipper's planning model (toolhead.py). Expected figures are worked out from Klipper's
// published rules, not read back from the planner.

MotionLimits klipper_limits(double accel = 3000) {
  MotionLimits l = motion_limits_from_profile(ender3_klipper());
  EXPECT_TRUE(l.klipper);
  l.print_accel_mm_s2 = accel;
  return l;
}

/// Plans `moves` with `limits` to a stop; the segments in order.
std::vector<MotionSegment> plan(const MotionLimits& limits, std::initializer_list<Move> moves) {
  Planner planner(limits, 16);
  Recorder rec;
  for (const Move& m : moves) planner.add(m, rec);
  planner.flush(rec);
  EXPECT_EQ(rec.segments.size(), moves.size());
  return rec.segments;
}

TEST(KlipperPlanner, SquareCornerVelocityStaysConstantWhenTheAccelerationChanges) {
  for (double accel : {1000.0, 3000.0, 20000.0}) {
    const auto seg =
        plan(klipper_limits(accel), {line_move(Vec3(0, 0, 0), Vec3(100, 0, 0), 200),
                                     line_move(Vec3(100, 0, 0), Vec3(100, 100, 0), 200)});
    ASSERT_EQ(seg.size(), 2u);
    // 90 degrees: the junction deviation scv^2 (sqrt2 - 1) / a makes v = scv = 5 mm/s.
    EXPECT_NEAR(seg[0].end_speed_mm_s, 5.0, 1e-9) << accel;
    EXPECT_NEAR(seg[1].start_speed_mm_s, 5.0, 1e-9) << accel;
    EXPECT_DOUBLE_EQ(seg[0].accel_mm_s2, accel);
  }
  EXPECT_NEAR(klipper_junction_deviation_mm(5, 3000), 25 * (std::sqrt(2.0) - 1) / 3000, 1e-15);
}

TEST(KlipperPlanner, MinimumCruiseRatioLowersThePeakOfAShortMove) {
  // 10 mm at 300 mm/s, 3000 mm/s^2, from rest to rest. Without the ratio the peak is
  // v^2 = L a (173 mm/s); with minimum_cruise_ratio 0.5 it is v^2 = L a (1 - 0.5), so half
  // of the move is cruise.
  for (double mcr : {0.0, 0.5}) {
    MotionLimits l = klipper_limits();
    l.minimum_cruise_ratio = mcr;
    const auto seg = plan(l, {line_move(Vec3(0, 0, 0), Vec3(10, 0, 0), 300)});
    ASSERT_EQ(seg.size(), 1u);
    const MotionSegment& s = seg[0];
    EXPECT_NEAR(s.cruise_speed_mm_s, std::sqrt(10 * 3000 * (1 - mcr)), 1e-9) << mcr;
    EXPECT_NEAR(s.cruise_time_s * s.cruise_speed_mm_s, 10 * mcr, 1e-9) << mcr;
    EXPECT_NEAR(profile_distance(s), 10.0, 1e-9);
  }
}

TEST(KlipperPlanner, JunctionSpeedIsCappedByTheLengthsOfBothMoves) {
  // A 10 degree bend through a 0.1 mm move: the corner's circle may touch each move no
  // further than its middle, so v^2 <= 0.5 L a tan(theta / 2) with theta = 170 degrees
  // (far below the 52 mm/s that the junction deviation alone allows).
  const double dev = 10 * M_PI / 180;
  const Vec3 a(0, 0, 0), b(50, 0, 0);
  const Vec3 c = b + 0.1 * Vec3(std::cos(dev), std::sin(dev), 0);
  const Vec3 d = c + 50 * Vec3(std::cos(2 * dev), std::sin(2 * dev), 0);
  const auto seg =
      plan(klipper_limits(), {line_move(a, b, 200), line_move(b, c, 200), line_move(c, d, 200)});
  ASSERT_EQ(seg.size(), 3u);
  const double expected = std::sqrt(0.5 * 0.1 * 3000 * std::tan(0.5 * (M_PI - dev)));
  EXPECT_NEAR(seg[0].end_speed_mm_s, expected, 1e-9);
  EXPECT_NEAR(seg[1].end_speed_mm_s, expected, 1e-9);
  // The junction deviation alone would allow more.
  const double s2 = std::sqrt(0.5 * (1 + std::cos(dev)));
  EXPECT_GT(std::sqrt(s2 / (1 - s2) * klipper_junction_deviation_mm(5, 3000) * 3000), expected + 5);
}

TEST(KlipperPlanner, CornerAnglesComeFromXyzOnly) {
  // A travel then a collinear extrusion: E does not bend the corner (Marlin's junction
  // vector includes E); the extruder's instantaneous corner velocity (1 mm/s over a change
  // of 0.05 mm of filament per mm) caps it at 20 mm/s.
  const auto seg = plan(klipper_limits(), {line_move(Vec3(0, 0, 0), Vec3(50, 0, 0), 100),
                                           line_move(Vec3(50, 0, 0), Vec3(100, 0, 0), 100, 2.5),
                                           line_move(Vec3(100, 0, 0), Vec3(150, 0, 0), 100, 2.5)});
  ASSERT_EQ(seg.size(), 3u);
  EXPECT_NEAR(seg[0].end_speed_mm_s, 20.0, 1e-9);
  EXPECT_NEAR(seg[1].end_speed_mm_s, 100.0, 1e-9);  // same ratio: no corner at all
}

TEST(KlipperPlanner, ExtrudeOnlyMovesUseTheExtruderLimits) {
  // No max_extrude_only_* in the profile: Klipper derives them from max_velocity (300) and
  // max_accel (3000) times 4 d^2 / filament area (0.4 mm nozzle, 1.75 mm filament).
  const double ratio = 4 * 0.4 * 0.4 / (M_PI * 1.75 * 1.75 / 4);
  EXPECT_NEAR(klipper_default_extrude_ratio(0.4, 1.75), ratio, 1e-12);
  MotionLimits l = klipper_limits();
  EXPECT_NEAR(l.max_extrude_only_velocity_mm_s, 300 * ratio, 1e-9);
  EXPECT_NEAR(l.max_extrude_only_accel_mm_s2, 3000 * ratio, 1e-9);
  // Retraction at 200 mm/s requested, then a wipe (XY with E < 0), then a travel.
  const auto seg = plan(l, {line_move(Vec3(0, 0, 0), Vec3(0, 0, 0), 200, -5),
                            line_move(Vec3(0, 0, 0), Vec3(10, 0, 0), 200, -5),
                            line_move(Vec3(10, 0, 0), Vec3(60, 0, 0), 200)});
  ASSERT_EQ(seg.size(), 3u);
  const MotionSegment& r = seg[0];
  EXPECT_NEAR(r.length_mm, 5.0, 1e-12);
  EXPECT_NEAR(r.nominal_speed_mm_s, 300 * ratio, 1e-9);
  EXPECT_NEAR(r.accel_mm_s2, 3000 * ratio, 1e-9);
  EXPECT_EQ(r.start_speed_mm_s, 0.0);
  EXPECT_EQ(r.end_speed_mm_s, 0.0);  // extrude-only moves start and end at rest
  // The wipe: E moves 0.5 mm per mm, so XY is limited to (extruder limit) / 0.5.
  const MotionSegment& w = seg[1];
  EXPECT_NEAR(w.nominal_speed_mm_s, 300 * ratio / 0.5, 1e-9);
  EXPECT_NEAR(w.accel_mm_s2, 3000 * ratio / 0.5, 1e-9);
  EXPECT_EQ(w.start_speed_mm_s, 0.0);
  // Configured values win over the derived ones.
  l.max_extrude_only_velocity_mm_s = 40;
  l.max_extrude_only_accel_mm_s2 = 1000;
  const auto push = plan(l, {line_move(Vec3(0, 0, 0), Vec3(0, 0, 0), 200, 3)});
  ASSERT_EQ(push.size(), 1u);
  EXPECT_NEAR(push[0].nominal_speed_mm_s, 40.0, 1e-12);
  EXPECT_NEAR(push[0].accel_mm_s2, 1000.0, 1e-12);
}

TEST(KlipperPlanner, ZMovesAreLimitedByMaxZVelocityAndAccel) {
  const auto seg =
      plan(klipper_limits(), {line_move(Vec3(0, 0, 0), Vec3(3, 0, 4), 100)});  // 4 of 5 mm in Z
  ASSERT_EQ(seg.size(), 1u);
  EXPECT_NEAR(seg[0].nominal_speed_mm_s, 5.0 * 5 / 4, 1e-12);
  EXPECT_NEAR(seg[0].accel_mm_s2, 100.0 * 5 / 4, 1e-12);
}

TEST(KlipperPlanner, LazyFlushStreamsWithBoundedQueueAndContinuousSpeed) {
  // 2000 collinear 1 mm moves at 100 mm/s: Klipper releases moves once 150 ms of them are
  // queued, so segments arrive long before the end and the queue stays short; the chain
  // is one trapezoid: 0 -> 100 mm/s -> 0.
  Planner planner(klipper_limits(), 16);
  Recorder rec;
  int max_queued = 0;
  for (int i = 0; i < 2000; ++i) {
    planner.add(line_move(Vec3(i, 0, 0), Vec3(i + 1, 0, 0), 100), rec);
    max_queued = std::max(max_queued, planner.queued());
  }
  EXPECT_GT(rec.segments.size(), 1900u);
  EXPECT_LT(max_queued, 120);
  planner.flush(rec);
  ASSERT_EQ(rec.segments.size(), 2000u);
  double clock = 0;
  for (std::size_t k = 0; k < rec.segments.size(); ++k) {
    const MotionSegment& s = rec.segments[k];
    EXPECT_NEAR(s.start_time_s, clock, 1e-9);
    clock = s.end_time_s();
    EXPECT_NEAR(profile_distance(s), 1.0, 1e-9);
    if (k + 1 < rec.segments.size()) {
      EXPECT_NEAR(rec.segments[k + 1].start_speed_mm_s, s.end_speed_mm_s, 1e-9);
    }
  }
  // 2000 mm at 100 mm/s with 3000 mm/s^2 ramps: 20 s + v/a = 20.0333 s.
  EXPECT_NEAR(planner.clock_s(), 2000.0 / 100 + 100.0 / 3000, 1e-9);
}

TEST(KlipperPlanner, LimitsThatAreNotPositiveLimitNothing) {
  // An incomplete profile (max velocity, Z and extruder limits 0) must not give infinite or
  // zero-length times: those limits are treated as absent.
  MotionLimits l = klipper_limits();
  l.max_feedrate_mm_s.setZero();
  l.max_accel_mm_s2.setZero();
  l.max_extrude_only_velocity_mm_s = l.max_extrude_only_accel_mm_s2 = 0;
  const auto seg = plan(l, {line_move(Vec3(0, 0, 0), Vec3(30, 0, 4), 100, 1),
                            line_move(Vec3(30, 0, 4), Vec3(30, 0, 4), 30, -1)});
  ASSERT_EQ(seg.size(), 2u);
  for (const auto& s : seg) {
    EXPECT_TRUE(std::isfinite(s.duration_s()));
    EXPECT_GT(s.duration_s(), 0.0);
    EXPECT_NEAR(profile_distance(s), s.length_mm, 1e-9);
  }
  EXPECT_NEAR(seg[0].nominal_speed_mm_s, 100.0, 1e-9);
}

TEST(KlipperPlanner, MatchesKlippersOwnPlannerOnTheSamples) {
  // Reference: Klipper (klippy/toolhead.py, 2026) in batch mode with the numbers of the
  // ender3-klipper profile, summing accel_t + cruise_t + decel_t of every move its
  // look-ahead queue released (docs/simulate.md, "Klipper's planner against Klipper").
  const std::pair<const char*, double> reference[] = {{"cura_cube10.gcode", 332.659372284},
                                                      {"slic3r_cube10.gcode", 381.115914979},
                                                      {"seed_square_box.gcode", 37.663976913}};
  for (const auto& [file, klipper_s] : reference) {
    auto r = simulate_gcode_file(test::source_path(std::string("samples/gcode/") + file),
                                 ender3_klipper(), {});
    ASSERT_TRUE(r.ok()) << r.error().describe();
    EXPECT_NEAR(r->motion_time_s, klipper_s, 1e-6 * klipper_s) << file;
  }
}

TEST_P(PlannerOnFixture, KlipperSegmentsAreContinuousAndAddUpToTheClock) {
  Recorder rec;
  const PrinterProfile p = ender3_klipper();
  auto r = simulate_gcode_file(test::source_path("samples/gcode/" + GetParam()), p, {}, &rec);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  ASSERT_FALSE(rec.segments.empty());
  double total = 0;
  for (const auto& w : rec.waits) total += w.second;
  for (std::size_t k = 0; k < rec.segments.size(); ++k) {
    const MotionSegment& s = rec.segments[k];
    total += s.duration_s();
    EXPECT_NEAR(profile_distance(s), s.length_mm, 1e-6 * std::max(1.0, s.length_mm))
        << "line " << s.line;
    EXPECT_LE(s.cruise_speed_mm_s, s.nominal_speed_mm_s + 1e-9);
    EXPECT_LE(s.cruise_speed_mm_s, 300 + 1e-9);
    if (k + 1 < rec.segments.size() &&
        std::fabs(rec.segments[k + 1].start_time_s - s.end_time_s()) < 1e-9) {
      EXPECT_NEAR(rec.segments[k + 1].start_speed_mm_s, s.end_speed_mm_s, 1e-6)
          << "line " << s.line;
    }
  }
  EXPECT_NEAR(total, r->print_time_s, 1e-6 * r->print_time_s);
}

// ---------------------------------------------------------------------------------------
// The estimator of OrcaSlicer / Bambu Studio / Creality Print (--limits-from-gcode).

MotionLimits orca_limits() {
  // A config block as these slicers write it (speeds as machine_max_speed_*, "normal,silent").
  const std::string block =
      "; HEADER_BLOCK_START\n; CONFIG_BLOCK_START\n"
      "; machine_max_acceleration_e = 5000,5000\n; machine_max_acceleration_extruding = "
      "20000,20000\n"
      "; machine_max_acceleration_retracting = 5000,5000\n; machine_max_acceleration_travel = "
      "9000,9000\n"
      "; machine_max_acceleration_x = 20000,20000\n; machine_max_acceleration_y = 20000,20000\n"
      "; machine_max_acceleration_z = 500,500\n; machine_max_jerk_e = 2.5,2.5\n"
      "; machine_max_jerk_x = 12,12\n; machine_max_jerk_y = 12,12\n; machine_max_jerk_z = 2,2\n"
      "; machine_max_speed_e = 100,100\n; machine_max_speed_x = 800,800\n; machine_max_speed_y = "
      "800,800\n"
      "; machine_max_speed_z = 20,20\n; CONFIG_BLOCK_END\n";
  auto l = limits_from_prusaslicer_config(block, motion_limits_from_profile(ender3_klipper()));
  EXPECT_TRUE(l.ok());
  return l.ok() ? *l : MotionLimits{};
}

TEST(OrcaEstimator, ReadsTheOrcaConfigBlockAndItsKeys) {
  const MotionLimits l = orca_limits();
  EXPECT_TRUE(l.prusaslicer_compat);
  EXPECT_TRUE(l.orca_compat);
  EXPECT_FALSE(l.klipper);  // the slicer's estimator, not the firmware
  EXPECT_EQ(l.junction, JunctionModel::classic_jerk);
  EXPECT_DOUBLE_EQ(l.max_feedrate_mm_s[0], 800.0);
  EXPECT_DOUBLE_EQ(l.max_feedrate_mm_s[2], 20.0);
  EXPECT_DOUBLE_EQ(l.print_accel_mm_s2, 20000.0);
  EXPECT_DOUBLE_EQ(l.travel_accel_mm_s2, 9000.0);
  EXPECT_DOUBLE_EQ(l.square_corner_velocity_mm_s, 12.0);  // X/Y jerk until SET_VELOCITY_LIMIT
  // PrusaSlicer's names keep PrusaSlicer's estimator.
  auto prusa = limits_from_prusaslicer_config(
      "; machine_max_acceleration_e = 5000\n; machine_max_acceleration_extruding = 1250\n"
      "; machine_max_acceleration_retracting = 1250\n; machine_max_acceleration_travel = 1250\n"
      "; machine_max_acceleration_x = 1000\n; machine_max_acceleration_y = 1000\n"
      "; machine_max_acceleration_z = 200\n; machine_max_feedrate_e = 120\n; "
      "machine_max_feedrate_x = 200\n"
      "; machine_max_feedrate_y = 200\n; machine_max_feedrate_z = 12\n; machine_max_jerk_x = 8\n",
      MotionLimits{});
  ASSERT_TRUE(prusa.ok());
  EXPECT_FALSE(prusa->orca_compat);
  EXPECT_FALSE(limits_from_prusaslicer_config("; no limits here\n", MotionLimits{}).ok());
}

TEST(OrcaEstimator, SquareCornerVelocityIsTheXyJerk) {
  // 90 degrees at 200 mm/s: the junction is the X/Y jerk, which SET_VELOCITY_LIMIT
  // SQUARE_CORNER_VELOCITY sets in Orca's estimator.
  for (double scv : {7.0, 12.0}) {
    MotionLimits l = orca_limits();
    l.square_corner_velocity_mm_s = scv;
    const auto seg = plan(l, {line_move(Vec3(0, 0, 0), Vec3(100, 0, 0), 200, 5),
                              line_move(Vec3(100, 0, 0), Vec3(100, 100, 0), 200, 5)});
    ASSERT_EQ(seg.size(), 2u);
    EXPECT_NEAR(seg[0].end_speed_mm_s, scv, 1e-9) << scv;
  }
}

TEST(OrcaEstimator, GentleBendsAreCappedByTheCircleThroughTheMove) {
  // A 10 degree bend into a 0.5 mm move: Orca caps the second move at sqrt(a r), r the radius
  // of the circle through the 0.5 mm chord and the bend.
  const double dev = 10 * M_PI / 180;
  const Vec3 b(50, 0, 0), c = b + 0.5 * Vec3(std::cos(dev), std::sin(dev), 0);
  const auto seg =
      plan(orca_limits(), {line_move(Vec3(0, 0, 0), b, 400, 2), line_move(b, c, 400, 0.1)});
  ASSERT_EQ(seg.size(), 2u);
  const double r = 0.5 * 0.5 / std::sin(dev / 2);
  EXPECT_NEAR(seg[1].nominal_speed_mm_s, std::sqrt(20000 * r), 1e-6);
  EXPECT_NEAR(seg[0].nominal_speed_mm_s, 400.0, 1e-9);
}

TEST(OrcaEstimator, SegmentsOfOneArcJoinWithoutAJerkLimit) {
  // Orca plans a G2/G3 as one block; the twin's segments of it (same G-code line) join at
  // full speed, while separate G1 lines with the same bends are jerk-limited.
  for (bool one_arc : {true, false}) {
    Planner planner(orca_limits(), 64);
    Recorder rec;
    Vec3 prev(20, 0, 0);
    for (int i = 1; i <= 36; ++i) {
      const double t = 2 * M_PI * i / 36;
      const Vec3 p(20 * std::cos(t), 20 * std::sin(t), 0);
      Move m = line_move(prev, p, 100, 0.1);
      m.line = one_arc ? 7 : 7 + i;
      planner.add(m, rec);
      prev = p;
    }
    planner.flush(rec);
    ASSERT_EQ(rec.segments.size(), 36u);
    const double mid = rec.segments[18].end_speed_mm_s;
    if (one_arc) {
      EXPECT_NEAR(mid, 100.0, 1e-6);  // sqrt(20000 * 20) = 632 > 100 requested
    } else {
      EXPECT_LT(mid, 100.0 - 1);
    }
  }
}

TEST(OrcaEstimator, BambuStudiosJunctionIsNotCappedByTheSlowerMove) {
  // 50 mm/s into 200 mm/s with a 5 degree bend. Orca's rule takes the per-axis difference
  // of the two velocities (150 mm/s along X: the junction nearly stops); Bambu Studio's
  // takes jerk / |change of the unit direction| (12 / sin 5deg = 138 mm/s) and keeps it
  // above the slower move's speed, so the slow move ends at its full 50 mm/s.
  const double bend = 5 * M_PI / 180;
  const Vec3 b(50, 0, 0), c = b + 50 * Vec3(std::cos(bend), std::sin(bend), 0);
  for (bool bambu : {false, true}) {
    MotionLimits l = orca_limits();
    l.bambu_junction = bambu;
    const auto seg = plan(l, {line_move(Vec3(0, 0, 0), b, 50, 0.01), line_move(b, c, 200, 0.01)});
    ASSERT_EQ(seg.size(), 2u);
    if (bambu)
      EXPECT_NEAR(seg[0].end_speed_mm_s, 50.0, 1e-9);
    else
      EXPECT_NEAR(seg[0].end_speed_mm_s, 12.0, 1e-9);  // no more than the safe speed
  }
}

TEST(OrcaEstimator, HeaderAndFlavourChooseTheJunctionAndTheTravelClamp) {
  const std::string limits =
      "; machine_max_acceleration_e = 5000,5000\n; machine_max_acceleration_extruding = "
      "20000,20000\n; machine_max_acceleration_retracting = 5000,5000\n"
      "; machine_max_acceleration_travel = 9000,9000\n; machine_max_acceleration_x = 20000\n"
      "; machine_max_acceleration_y = 20000\n; machine_max_acceleration_z = 500\n"
      "; machine_max_jerk_e = 2.5\n; machine_max_jerk_x = 5\n; machine_max_jerk_y = 5\n"
      "; machine_max_jerk_z = 2\n; machine_max_speed_e = 100\n; machine_max_speed_x = 1000\n"
      "; machine_max_speed_y = 1000\n; machine_max_speed_z = 30\n";
  const MotionLimits base = motion_limits_from_profile(ender3_klipper());
  // Bambu Studio's header line picks its junction rule; OrcaSlicer's does not.
  auto bambu = limits_from_prusaslicer_config(
      "; HEADER_BLOCK_START\n; BambuStudio 01.10.02.76\n" + limits, base);
  auto orca = limits_from_prusaslicer_config(
      "; generated by OrcaSlicer 2.1.1 on 2024-09-01\n" + limits, base);
  ASSERT_TRUE(bambu.ok() && orca.ok());
  EXPECT_TRUE(bambu->bambu_junction);
  EXPECT_FALSE(orca->bambu_junction);
  // Marlin 2 has M204 T: the estimators clamp travel by machine_max_acceleration_travel.
  EXPECT_DOUBLE_EQ(orca->accel_cap_mm_s2[2], 9000.0);
  EXPECT_DOUBLE_EQ(orca->travel_accel_mm_s2, 9000.0);
  // Klipper has none: travel is what M204 S / SET_VELOCITY_LIMIT set, 1250 until then.
  auto klipper = limits_from_prusaslicer_config("; gcode_flavor = klipper\n" + limits, base);
  ASSERT_TRUE(klipper.ok());
  EXPECT_TRUE(std::isinf(klipper->accel_cap_mm_s2[2]));
  EXPECT_DOUBLE_EQ(klipper->travel_accel_mm_s2, 1250.0);
  EXPECT_DOUBLE_EQ(klipper->accel_cap_mm_s2[0], 20000.0);
  // PrusaSlicer with machine_limits_usage = time_estimate_only: no travel clamp either.
  auto estimate_only = limits_from_prusaslicer_config(
      "; gcode_flavor = marlin2\n; machine_limits_usage = time_estimate_only\n" + limits, base);
  ASSERT_TRUE(estimate_only.ok());
  EXPECT_TRUE(std::isinf(estimate_only->accel_cap_mm_s2[2]));
}

TEST(SlicerEstimate, RealFilesWithinTwoPercentOfTheirSlicersEstimate) {
  // Every real file whose slicer writes machine limits and an estimate (PrusaSlicer, Bambu
  // Studio, OrcaSlicer, Creality Print, SuperSlicer), on the printer its settings name
  // (../shared/realworld; skipped without it). The text twin of a .bgcode counts too.
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no realworld folder";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(*dir / "gcode")) {
    if (entry.path().extension() != ".gcode") continue;
    auto printer = resolve_printer("auto", entry.path());
    ASSERT_TRUE(printer.ok()) << printer.error().describe();
    SimulateOptions o;
    o.limits_from_gcode = true;
    apply_printer_to_options(*printer, o.interpreter);
    auto r = simulate_gcode_file(entry.path(), printer->profile, o);
    if (!r.ok()) continue;  // no machine limits in the file (Cura, KISSlicer...)
    if (!r->slicer_estimate_s) continue;
    ++files;
    EXPECT_NEAR(r->motion_time_s, *r->slicer_estimate_s, 0.02 * *r->slicer_estimate_s)
        << entry.path().filename().string() << " (" << r->slicer << ")";
  }
  if (files == 0) GTEST_SKIP() << "no file with machine limits and an estimate";
  std::cout << files << " real files within 2 % of their slicer's estimate\n";
}

TEST(SlicerEstimate, RealPrusaSlicerFileWithinTwoPercentOfItsEstimate) {
  // A real PrusaSlicer 2.8 file for the MK4S (../shared/realworld; skipped without it).
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no realworld folder";
  std::filesystem::path file;
  for (const auto& entry : std::filesystem::directory_iterator(*dir / "gcode")) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("prusaslicer-", 0) == 0 && entry.path().extension() == ".gcode")
      file = entry.path();
  }
  if (file.empty()) GTEST_SKIP() << "no PrusaSlicer text G-code in " << dir->string();
  SimulateOptions o;
  o.limits_from_gcode = true;
  auto r = simulate_gcode_file(file, ender3_marlin2(), o);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  ASSERT_TRUE(r->slicer_estimate_s.has_value());
  EXPECT_FALSE(r->limits_used.orca_compat);
  EXPECT_NEAR(r->motion_time_s, *r->slicer_estimate_s, 0.02 * *r->slicer_estimate_s) << file;
}

}  // namespace
}  // namespace printtwin
