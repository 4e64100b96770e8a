// Volume conservation: the material of a bead that falls on earlier plastic squeezes into
// the free voxels nearest its section (beside and below it, up to half the nozzle diameter
// away), so the deposit holds the extruded volume. Samples, beads laid in code, and
// PrusaSlicer's G-code of the 20 mm calibration cube.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <initializer_list>
#include <numbers>
#include <optional>
#include <string>

#include "deposit/deposit_test_support.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/simulate.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

using test::BeadWriter;

DepositResult deposit_file(const std::filesystem::path& gcode, bool conserve = true) {
  const auto profile = ender3_marlin2();
  auto moves = interpret_gcode_file(gcode, profile, SimulateOptions{});
  EXPECT_TRUE(moves.ok()) << moves.error().describe();
  DepositSettings s;
  s.conserve_volume = conserve;
  auto r = deposit_moves(*moves, profile, s);
  EXPECT_TRUE(r.ok()) << r.error().describe();
  return std::move(r).value();
}

/// Settings with the squeeze on (the default: see DepositSettings::conserve_volume).
DepositSettings conserving() {
  DepositSettings s;
  s.conserve_volume = true;
  return s;
}

/// Deposited over extruded volume minus one.
double shortfall(const DepositResult& r) { return r.volume_mm3 / r.extruded_mm3 - 1.0; }

TEST(VolumeConservation, SpiralVaseDepositsItsExtrudedVolume) {
  const auto path = test::source_path("samples/gcode/prusa_vase10.gcode");
  const DepositResult lost = deposit_file(path, false);
  const DepositResult kept = deposit_file(path);
  // Without the squeeze the overlap is lost; with it, it is placed nearby.
  EXPECT_LT(shortfall(lost), -0.02);
  EXPECT_NEAR(shortfall(kept), 0.0, 0.005) << kept.volume_mm3 << " of " << kept.extruded_mm3;
  // The overlap is still reported (no smaller: squeezed material takes room later beads lay
  // on, though displacing it again is not counted a second time).
  EXPECT_GE(kept.overlap_mm3, lost.overlap_mm3);
  EXPECT_GT(kept.squeezed_mm3, 0.94 * kept.overlap_mm3);
  EXPECT_LE(kept.squeezed_mm3, kept.overlap_mm3);
}

TEST(VolumeConservation, SingleWallBoxDepositsItsExtrudedVolume) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const double h = 0.2;
  for (int layer = 0; layer < 30; ++layer) {
    const double z = h * (layer + 1);
    w.layer = layer;
    w.travel({50, 50, z});
    w.extrude({70, 50, z}, 0.45, h);
    w.extrude({70, 65, z}, 0.45, h);
    w.extrude({50, 65, z}, 0.45, h);
    w.extrude({50, 50, z}, 0.45, h);
  }
  auto r = deposit_moves(w.moves, profile, conserving());
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(shortfall(*r), 0.0, 0.005) << r->volume_mm3 << " of " << r->extruded_mm3;
  // Without the squeeze the round joins still place most of the corners' overlap; the rest,
  // (1 - pi/4) hw^2 h a corner, is lost.
  DepositSettings off;
  off.conserve_volume = false;
  auto lost = deposit_moves(w.moves, profile, off);
  ASSERT_TRUE(lost.ok());
  EXPECT_LT(lost->volume_mm3, r->volume_mm3);
  EXPECT_GT(r->squeezed_mm3, lost->squeezed_mm3);
  EXPECT_GT(lost->squeezed_mm3, 0.0);
}

/// The same 0.45 x 0.2 mm bead of `feature`, 20 mm along x at y = 50, laid twice on the bed.
DepositResult same_bead_twice(const PrinterProfile& profile, Feature feature) {
  BeadWriter w(profile);
  w.feature = feature;
  for (int twice = 0; twice < 2; ++twice) {
    w.travel({50, 50, 0.2});
    w.extrude({70, 50, 0.2}, 0.45, 0.2);
  }
  auto r = deposit_moves(w.moves, profile, conserving());
  EXPECT_TRUE(r.ok());
  return std::move(r).value();
}

TEST(VolumeConservation, SqueezeStaysWithinHalfANozzleOfTheBead) {
  // The same 0.45 x 0.2 mm bead laid twice on the bed: the second one's material has
  // nowhere to go but beside the first (the bed is below); it goes there, no further than
  // half the nozzle width from the bead's side, and on top of it only when the sides are full.
  const auto profile = ender3_marlin2();
  const auto r = std::make_optional(same_bead_twice(profile, Feature::perimeter));
  const double one = 0.5 * r->extruded_mm3;
  EXPECT_NEAR(r->overlap_mm3, one, 0.01 * one);
  EXPECT_GT(r->squeezed_mm3, 0.5 * one);
  EXPECT_NEAR(r->volume_mm3 - r->squeezed_mm3, one, 0.01 * one);  // the first bead
  const double reach = 0.5 * 0.45 + 0.5 * profile.nozzle_diameter_mm;
  r->grid.for_each([&](const VoxelKey& k, const VoxelTag&) {
    const Vec3 c = r->grid.center_mm(k);
    ASSERT_LE(std::abs(c.y() - 50.0), reach + r->voxel_mm) << c.transpose();
    ASSERT_LE(c.z(), 0.2 + 0.5 * profile.nozzle_diameter_mm) << c.transpose();
  });
}

// A bead that may form the part's outer surface (an outer perimeter) keeps its overflow off
// the open sides beyond its flat part and below its tip: there lie the grooves between layers
// and the next layer's gap. Laid twice on the bed, with earlier plastic on neither side, the
// second outer perimeter's material has no room and is reported lost; an inner perimeter's
// goes beside the first (SqueezeStaysWithinHalfANozzleOfTheBead).
TEST(VolumeConservation, OuterWallOverflowStaysOffTheOpenSidesAndTheTop) {
  auto profile = ender3_marlin2();
  profile.elephant_foot_mm = 0;  // the first layer's outer edge as laid
  const auto r = std::make_optional(same_bead_twice(profile, Feature::outer_perimeter));
  const double one = 0.5 * r->extruded_mm3;
  EXPECT_NEAR(r->overlap_mm3, one, 0.01 * one);
  EXPECT_LT(r->squeezed_mm3, 0.02 * one);
  r->grid.for_each([&](const VoxelKey& k, const VoxelTag&) {
    const Vec3 c = r->grid.center_mm(k);
    ASSERT_LE(std::abs(c.y() - 50.0), 0.5 * 0.45 + r->voxel_mm) << c.transpose();
    ASSERT_LE(c.z(), 0.2) << c.transpose();
  });
}

TEST(VolumeConservation, SqueezeFillsTheInsideBeforeGoingPastTheOpenEdge) {
  // A wall bead laid beside an earlier one at the slicers' spacing, w - h (1 - pi/4): the lens
  // where their sections overlap goes to the cusp between them (the inside), which has room
  // for it, not past the bead's edge on the side open to air, where it would fill the groove
  // between layers.
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const double bw = 0.45, h = 0.2, gap = bw - h * (1 - std::numbers::pi / 4);
  w.travel({50, 50, h});
  w.extrude({70, 50, h}, bw, h);
  w.travel({50, 50 + gap, h});
  w.extrude({70, 50 + gap, h}, bw, h);
  auto r = deposit_moves(w.moves, profile, conserving());
  DepositSettings off;
  off.conserve_volume = false;
  auto laid = deposit_moves(w.moves, profile, off);
  ASSERT_TRUE(r.ok() && laid.ok());
  ASSERT_GT(r->overlap_mm3, 0.0);
  EXPECT_NEAR(r->squeezed_mm3, r->overlap_mm3, 0.01 * r->overlap_mm3);
  // The squeezed voxels: the second bead's that it does not lay itself. The open side ends at
  // the flat part of its section, (w - h) / 2 from its line.
  const auto last = static_cast<std::uint32_t>(w.moves.back().line);
  const double edge = 50 + gap + 0.5 * (bw - h);
  std::size_t squeezed = 0, past = 0;
  r->grid.for_each([&](const VoxelKey& k, const VoxelTag& tag) {
    if (tag.line != last || laid->grid.occupied(k)) return;
    ++squeezed;
    if (r->grid.center_mm(k).y() > edge + 0.5 * r->voxel_mm) ++past;
  });
  EXPECT_GT(squeezed, 0U);
  EXPECT_EQ(past, 0U) << "of " << squeezed;
}

/// A 0.2 mm layer of beads along x at `ys`, plastic that rose 0.15 mm above it at `rise_y`, then
/// the next layer's 0.45 x 0.2 mm bead of `feature` at y = 50, 0.05 mm above that. Returns its
/// G-code line.
std::uint32_t bead_over_a_rise(BeadWriter& w, std::initializer_list<double> ys, double rise_y,
                               Feature feature) {
  for (const double y : ys) {
    w.travel({50, y, 0.2});
    w.extrude({70, y, 0.2}, 0.45, 0.2);
  }
  w.travel({50, rise_y, 0.35});
  w.extrude({70, rise_y, 0.35}, 0.45, 0.15);
  w.moves.back().height_hint_mm = 0.15;
  w.layer = 1;
  w.feature = feature;
  w.travel({50, 50, 0.4});
  w.extrude({70, 50, 0.4}, 0.45, 0.2);
  w.moves.back().height_hint_mm = 0.2;
  return static_cast<std::uint32_t>(w.moves.back().line);
}

// A bead laid in a gap much thinner than its layer (over earlier plastic that rose into it)
// spreads sideways, but no further than half a nozzle beyond each edge of the bead it would be
// at its layer height: about the nozzle's flat face. The rest is overflow the squeeze places
// (half a nozzle further at most); without the bound the stadium of a 0.05 mm gap is over
// 1.4 mm wide and stands out of a wall (the benchmark part's excess at its layers 133 and 196).
TEST(VolumeConservation, FlattenedBeadSpreadsNoFurtherThanHalfANozzle) {
  const auto profile = ender3_marlin2();
  BeadWriter w(profile);
  const auto top = bead_over_a_rise(w, {49.6, 50.0, 50.4}, 50.0, Feature::perimeter);
  DepositSettings off;
  off.conserve_volume = false;
  auto r = deposit_moves(w.moves, profile, conserving());
  auto wide = deposit_moves(w.moves, profile, off);
  ASSERT_TRUE(r.ok() && wide.ok());
  auto reach = [&](const DepositResult& d) {
    double far = 0;
    d.grid.for_each([&](const VoxelKey& k, const VoxelTag& tag) {
      if (tag.line == top) far = std::max(far, std::abs(d.grid.center_mm(k).y() - 50.0));
    });
    return far;
  };
  // The bead reaches half a nozzle beyond its nominal edge, its overflow half a nozzle more.
  const double bound = 0.5 * 0.45 + profile.nozzle_diameter_mm + r->voxel_mm;
  EXPECT_GT(reach(*wide), bound);  // the unbounded stadium
  EXPECT_LE(reach(*r), bound);
  EXPECT_NEAR(shortfall(*r), 0.0, 0.01) << r->volume_mm3 << " of " << r->extruded_mm3;
}

// An outer wall flattened the same way widens as much, but only towards the part's inside (the
// side whose plastic stands higher): its outer edge stays where the nozzle put it.
TEST(VolumeConservation, FlattenedOuterWallKeepsItsEdge) {
  auto profile = ender3_marlin2();
  profile.elephant_foot_mm = 0;
  BeadWriter w(profile);
  // The layer on the -y side only.
  const auto top = bead_over_a_rise(w, {49.6, 50.0}, 49.8, Feature::outer_perimeter);
  auto r = deposit_moves(w.moves, profile, conserving());
  ASSERT_TRUE(r.ok());
  double lo = 50, hi = 50;
  r->grid.for_each([&](const VoxelKey& k, const VoxelTag& tag) {
    if (tag.line != top) return;
    lo = std::min(lo, r->grid.center_mm(k).y());
    hi = std::max(hi, r->grid.center_mm(k).y());
  });
  const double hw = 0.5 * 0.45, d = 0.5 * profile.nozzle_diameter_mm;
  EXPECT_LE(hi, 50 + hw + r->voxel_mm);          // the outer edge
  EXPECT_LT(lo, 50 - hw - r->voxel_mm);          // widened inwards
  EXPECT_GE(lo, 50 - hw - 3 * d - r->voxel_mm);  // by a nozzle, its overflow half a nozzle more
}

// Below its own layers the squeeze fills only voxels resting on earlier plastic (the cusps of
// the layer below), not the air: a bead laid twice in mid-air (rigid, no sag) keeps all of
// its material at or above the bottom of the bead laid alone.
TEST(VolumeConservation, OverflowDoesNotHangUnderABridge) {
  auto profile = ender3_marlin2();
  profile.bridge_sag_mm = 0;
  profile.overhang_droop_mm = 0;
  BeadWriter w(profile);
  w.feature = Feature::bridge_infill;
  for (int twice = 0; twice < 2; ++twice) {
    w.travel({50, 50, 5.2});
    w.extrude({70, 50, 5.2}, 0.45, 0.2);
  }
  DepositSettings off;
  off.conserve_volume = false;
  auto r = deposit_moves(w.moves, profile, conserving());
  auto laid = deposit_moves(w.moves, profile, off);
  ASSERT_TRUE(r.ok() && laid.ok());
  EXPECT_GT(r->squeezed_mm3, 0.0);
  auto lowest = [](const DepositResult& d) {
    double z = 1e9;
    d.grid.for_each(
        [&](const VoxelKey& k, const VoxelTag&) { z = std::min(z, d.grid.center_mm(k).z()); });
    return z;
  };
  EXPECT_GE(lowest(*r), lowest(*laid) - 1e-9);  // nothing under the beads' own bottom
}

TEST(VolumeConservation, PrusaSlicerCubeWithInfillDepositsItsExtrudedVolume) {
  if (std::system("command -v prusa-slicer >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "prusa-slicer not installed";
  const auto dir = test::temp_dir("volume_cube20");
  const auto gcode = dir / "cube20.gcode";
  const std::string cmd = "timeout 300 prusa-slicer --load " +
                          test::source_path("samples/configs/ender3_prusaslicer.ini").string() +
                          " --export-gcode --center 110,110 -o " + gcode.string() + " " +
                          test::source_path("samples/models/calibration_cube_20mm.stl").string() +
                          " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const DepositResult r = deposit_file(gcode);
  EXPECT_NEAR(shortfall(r), 0.0, 0.005) << r.volume_mm3 << " of " << r.extruded_mm3 << ", overlap "
                                        << r.overlap_mm3 << ", squeezed " << r.squeezed_mm3;
}

}  // namespace
}  // namespace printtwin
