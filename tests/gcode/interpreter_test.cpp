// Interpreter: modal state, arcs, homing, tags and findings, on the scenario files in
// tests/data/gcode/ and on G-code built in the test.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "printtwin/simulate.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

std::vector<Move> moves_of(const std::string& file, const SimulateOptions& o = {}) {
  auto r = interpret_gcode_file(test::source_path("tests/data/gcode/" + file), ender3_marlin2(), o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : std::vector<Move>{};
}

SimulationResult sim_text(const std::string& text, const SimulateOptions& o = {}) {
  std::istringstream in(text);
  auto r = simulate_gcode(in, ender3_marlin2(), o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : SimulationResult{};
}

const Finding* find(const SimulationResult& r, const std::string& code) {
  for (const auto& f : r.findings)
    if (f.code == code) return &f;
  return nullptr;
}

double sum_e(const std::vector<Move>& moves) {
  double e = 0;
  for (const auto& m : moves) e += m.e_mm;
  return e;
}

TEST(GcodeInterpreter, PositioningAndExtruderModes) {
  const auto moves = moves_of("modes.gcode");
  ASSERT_FALSE(moves.empty());
  EXPECT_NEAR(sum_e(moves), 6.254, 1e-6);
  // After G92 X0 Y0 at machine (55, 15), logical (1, 1) is machine (56, 16).
  bool found_56 = false, found_inch = false, found_vol = false, found_g91e = false;
  for (const auto& m : moves) {
    if (m.line == 20) {
      found_56 = true;
      EXPECT_NEAR(m.end_mm.x(), 56.0, 1e-9);
      EXPECT_NEAR(m.end_mm.y(), 16.0, 1e-9);
    }
    if (m.line == 22) {
      EXPECT_NEAR(m.e_mm, 0.5, 1e-9);  // M221 S50
    }
    if (m.line == 26) {
      found_inch = true;
      EXPECT_NEAR(m.end_mm.x(), 2.5 * 25.4 + 55.0, 1e-9);
      EXPECT_NEAR(m.e_mm, 0.254, 1e-9);
    }
    if (m.line == 29) {
      found_vol = true;
      EXPECT_NEAR(m.e_mm, 1.0, 1e-5);
    }
    if (m.line == 17) {
      found_g91e = true;
      EXPECT_EQ(m.kind, MoveKind::unretract);
      EXPECT_NEAR(m.e_mm, 0.5, 1e-9);
    }
    if (m.line == 16) {
      EXPECT_NEAR(m.end_mm.x(), 55.0, 1e-9);
      EXPECT_NEAR(m.end_mm.y(), 15.0, 1e-9);
    }
  }
  EXPECT_TRUE(found_56 && found_inch && found_vol && found_g91e);
}

TEST(GcodeInterpreter, ArcsIjAndRSegmentedLikeMarlin) {
  const auto moves = moves_of("arcs.gcode");
  const Vec2 center(110, 100);
  int half_cw = 0, half_ccw = 0, full = 0;
  double len_full = 0, e_half = 0;
  for (const auto& m : moves) {
    if (m.line < 8) continue;
    // Every vertex lies on the circle of radius 10 around (110, 100).
    EXPECT_NEAR((m.end_mm.head<2>() - center).norm(), 10.0, 1e-6) << "line " << m.line;
    EXPECT_LE(m.length_mm(), 1.0 + 1e-9);  // arc_max_segment_mm
    if (m.line == 8) {
      ++half_cw;
      e_half += m.e_mm;
      EXPECT_GE(m.end_mm.y(), 100.0 - 1e-9);  // clockwise from the left goes over the top
    }
    if (m.line == 9) {
      ++half_ccw;
      EXPECT_GE(m.end_mm.y(), 100.0 - 1e-9);  // counter-clockwise from the right: over the top too
    }
    if (m.line == 10) {
      ++full;
      len_full += m.length_mm();
    }
  }
  // Half circle: pi * 10 = 31.4 mm at the profile's segment length (2*pi*10/72 = 0.87 mm).
  EXPECT_EQ(half_cw, 36);
  EXPECT_EQ(half_ccw, 36);
  EXPECT_EQ(full, 72);
  EXPECT_NEAR(e_half, 1.0, 1e-9);
  EXPECT_NEAR(len_full, 2 * M_PI * 10, 0.05);  // chords are slightly shorter than the arc
  EXPECT_LT(len_full, 2 * M_PI * 10);
}

TEST(GcodeInterpreter, HomingStateMachineAtProfileFeedrates) {
  SimulateOptions o;
  o.interpreter.power_on_position_mm = Vec3(100, 80, 10);
  std::istringstream in("G28\n");
  auto r = interpret_gcode(in, ender3_marlin2(), o);
  ASSERT_TRUE(r.ok());
  const auto& m = *r;
  // Quick home diagonal to Y=0 (Y is nearer), X alone, then per axis: fast, bump, slow.
  ASSERT_EQ(m.size(), 2u + 2u + 2u + 3u);  // X fast approach is empty after the quick home
  for (const auto& mv : m) EXPECT_EQ(mv.kind, MoveKind::home);
  EXPECT_NEAR(m[0].end_mm.x(), 20.0, 1e-9);
  EXPECT_NEAR(m[0].end_mm.y(), 0.0, 1e-9);
  EXPECT_NEAR(m[0].feedrate_mm_s, std::hypot(20.0, 20.0), 1e-9);
  EXPECT_NEAR(m[1].end_mm.x(), 0.0, 1e-9);
  EXPECT_NEAR(m[2].end_mm.x(), 5.0, 1e-9);      // bump back 5 mm
  EXPECT_NEAR(m[3].feedrate_mm_s, 10.0, 1e-9);  // slow: 20 / 2
  EXPECT_NEAR(m[6].start_mm.z(), 10.0, 1e-9);   // Z last, from 10 mm
  EXPECT_NEAR(m[6].feedrate_mm_s, 4.0, 1e-9);
  EXPECT_NEAR(m[7].end_mm.z(), 2.0, 1e-9);     // bump 2 mm
  EXPECT_NEAR(m[8].feedrate_mm_s, 1.0, 1e-9);  // 4 / 4
  EXPECT_NEAR(m.back().end_mm.norm(), 0.0, 1e-9);

  // Timing: the homing time is the sum of its trapezoids; Z alone needs at least 10/4 s.
  std::istringstream in2("G28\n");
  auto s = simulate_gcode(in2, ender3_marlin2(), o);
  ASSERT_TRUE(s.ok());
  const double z_min_time = 10.0 / 4 + 2.0 / 4 + 2.0 / 1.0;
  const double xy_min_time = 80 / 20.0 + 20 / 20.0 + 2 * 5 / 20.0 + 2 * 5 / 10.0;
  EXPECT_GT(s->homing_time_s, z_min_time + xy_min_time);
  EXPECT_LT(s->homing_time_s, z_min_time + xy_min_time + 1.0);  // plus acceleration ramps
  EXPECT_DOUBLE_EQ(s->motion_time_s, 0.0);
}

TEST(GcodeInterpreter, SlicerTagsObjectsAndUnknownCommands) {
  const auto moves = moves_of("tags.gcode");
  auto at = [&](long line) -> const Move& {
    for (const auto& m : moves)
      if (m.line == line) return m;
    static Move none;
    ADD_FAILURE() << "no move at line " << line;
    return none;
  };
  EXPECT_EQ(at(11).feature, Feature::outer_perimeter);
  EXPECT_FLOAT_EQ(at(11).width_hint_mm, 0.45f);
  EXPECT_FLOAT_EQ(at(11).height_hint_mm, 0.2f);
  EXPECT_EQ(at(11).object_id, 0);
  EXPECT_EQ(at(15).feature, Feature::perimeter);      // Cura WALL-INNER
  EXPECT_EQ(at(15).object_id, 1);                     // ;MESH:part_b.stl
  EXPECT_EQ(at(19).feature, Feature::sparse_infill);  // Orca "; FEATURE: Sparse infill"
  EXPECT_FLOAT_EQ(at(19).width_hint_mm, 0.42f);
  EXPECT_EQ(at(19).object_id, 2);  // EXCLUDE_OBJECT_START NAME=third
  EXPECT_EQ(at(23).feature, Feature::support);
  EXPECT_EQ(at(23).object_id, 7);  // M486 S7
  EXPECT_EQ(at(27).feature, Feature::skirt);
  EXPECT_EQ(at(27).layer, 1);  // Z 0.4: the second layer
  EXPECT_EQ(at(11).layer, 0);

  const auto r = sim_text("M104 S200\nM109 S200\nG28\nM7\nM7\nG26\nM7\n");
  ASSERT_EQ(r.unknown_commands.size(), 2u);
  EXPECT_EQ(r.unknown_commands.at("M7"), 3);
  EXPECT_EQ(r.unknown_commands.at("G26"), 1);
  int reported = 0;
  for (const auto& f : r.findings)
    if (f.code == "unknown_command") {
      ++reported;
      if (f.message.rfind("M7", 0) == 0) {
        EXPECT_EQ(f.line, 4);
        EXPECT_EQ(f.count, 3);
      }
    }
  EXPECT_EQ(reported, 2);  // once per code
}

TEST(GcodeInterpreter, OutOfBoundsIsClampedAndReported) {
  auto r = simulate_gcode_file(test::source_path("tests/data/gcode/out_of_bounds.gcode"),
                               ender3_marlin2(), {});
  ASSERT_TRUE(r.ok());
  const Finding* f = find(*r, "out_of_bounds");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->line, 9);
  EXPECT_EQ(f->severity, Severity::warning);
  ASSERT_TRUE(f->position_mm.has_value());
  EXPECT_NEAR(f->position_mm->x(), 250.0, 1e-9);
  EXPECT_NEAR(r->motion_bounds_mm.max.x(), 235.0, 1e-9);  // clamped like the firmware
}

TEST(GcodeInterpreter, MovesBeforeHomingAndColdExtrusion) {
  auto r = simulate_gcode_file(test::source_path("tests/data/gcode/before_homing_cold.gcode"),
                               ender3_marlin2(), {});
  ASSERT_TRUE(r.ok());
  const Finding* h = find(*r, "move_before_homing");
  ASSERT_NE(h, nullptr);
  EXPECT_EQ(h->line, 4);
  const Finding* c = find(*r, "cold_extrusion");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->line, 7);
  EXPECT_EQ(c->severity, Severity::error);
  EXPECT_NEAR(r->filament_mm, 2.0, 1e-9);  // the cold 2 mm were dropped
  // Heating from 25 C to 210 C at 2 C/s.
  EXPECT_NEAR(r->heating_time_s, (210 - 25) / 2.0, 0.5);

  SimulateOptions lenient;
  lenient.interpreter.prevent_cold_extrusion = false;
  auto r2 = simulate_gcode_file(test::source_path("tests/data/gcode/before_homing_cold.gcode"),
                                ender3_marlin2(), lenient);
  ASSERT_TRUE(r2.ok());
  EXPECT_NEAR(r2->filament_mm, 4.0, 1e-9);
}

TEST(GcodeInterpreter, BadInputIsAWarningWithLineOrAnErrorInStrictMode) {
  std::string text = "M104 S200\nM109 S200\nG28\nM83\n";
  text += "G1 Z[next_layer_z] F600\n";              // 5: placeholder
  text += std::string("G1 X\x01\x02\xfe\n", 8);     // 6: binary garbage
  text += "G1 X10 Y10 Z0.2 F0\n";                   // 7: zero feedrate
  text += "G1 X20 F-100\n";                         // 8: negative feedrate
  text += "G1 X1e308\n";                            // 9: out of range
  text += "G1 X30 E-5000\n";                        // 10: E backwards by metres
  text += "; " + std::string(1 << 20, 'x') + "\n";  // 11: 1 MB line
  text += "G1 X40 E1";                              // 12: file ends mid-line
  const auto r = sim_text(text);
  std::map<long, std::string> by_line;
  for (const auto& f : r.findings)
    if (f.line) by_line[*f.line] += f.code + " ";
  EXPECT_NE(by_line[5].find("bad_line"), std::string::npos);
  EXPECT_NE(by_line[6].find("bad_line"), std::string::npos);
  EXPECT_NE(by_line[7].find("bad_feedrate"), std::string::npos);
  EXPECT_NE(by_line[8].find("bad_feedrate"), std::string::npos);
  EXPECT_NE(by_line[9].find("bad_line"), std::string::npos);
  EXPECT_NE(by_line[10].find("lengthy_extrusion"), std::string::npos);
  EXPECT_NE(by_line[11].find("bad_line"), std::string::npos);
  EXPECT_NE(by_line[12].find("no_final_newline"), std::string::npos);
  EXPECT_NEAR(r.filament_mm, 1.0, 1e-9);  // only the last line extrudes
  EXPECT_EQ(r.lines, 12);

  SimulateOptions strict;
  strict.interpreter.strict = true;
  std::istringstream in(text);
  auto s = simulate_gcode(in, ender3_marlin2(), strict);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().line, 5);
  EXPECT_NE(s.error().message.find("G1 Z[next_layer_z] F600"), std::string::npos);
}

TEST(GcodeInterpreter, LayersComeFromZOfExtrusionsNotComments) {
  // Cura writes ;LAYER: after the Z move; a marker's Z that lies (by more than any layer
  // could be thick) is ignored: the layer takes the Z of its extrusions.
  const auto r = sim_text(
      "M104 S200\nM109 S200\nG28\nM83\n"
      ";LAYER:0\nG0 Z0.3\nG1 X10 Y10 E1 F1200\n"
      "G0 Z0.8 ; z-hop travel makes no layer\nG0 X20 Y20\nG0 Z0.3\nG1 X30 E1\n"
      "G0 Z0.5\n;LAYER:1\n;Z:7\nG1 X40 E1\nG1 X50 E1\n");
  ASSERT_EQ(r.layers.size(), 2u);
  EXPECT_NEAR(r.layers[0].z_mm, 0.3, 1e-12);
  EXPECT_NEAR(r.layers[0].height_mm, 0.3, 1e-12);
  EXPECT_NEAR(r.layers[1].z_mm, 0.5, 1e-12);
  EXPECT_NEAR(r.layers[1].height_mm, 0.2, 1e-12);
  EXPECT_NEAR(r.layers[0].filament_mm + r.layers[1].filament_mm, 4.0, 1e-12);
  EXPECT_EQ(r.layers[1].first_line, 15);
  double layer_time = 0;
  for (const auto& l : r.layers) layer_time += l.time_s;
  EXPECT_GT(layer_time, 0.0);
  EXPECT_LE(layer_time, r.print_time_s);
}

TEST(GcodeInterpreter, FirmwareRetractionWhenTheProfileEnablesIt) {
  PrinterProfile p = ender3_marlin2();
  p.firmware_retraction = true;
  p.fw_retract_length_mm = 4;
  std::istringstream in("M104 S200\nM109 S200\nG28\nG10\nG1 X10\nG11\nG11\n");
  auto r = interpret_gcode(in, p, {});
  ASSERT_TRUE(r.ok());
  double e = 0;
  int retracts = 0;
  for (const auto& m : *r) {
    e += m.e_mm;
    if (m.kind == MoveKind::retract) ++retracts;
  }
  EXPECT_EQ(retracts, 1);
  EXPECT_NEAR(e, 0.0, 1e-12);  // the second G11 does nothing
  // Without it, G10 is an unknown command.
  const auto s = sim_text("G28\nG10\n");
  EXPECT_EQ(s.unknown_commands.count("G10"), 1u);
}

}  // namespace
}  // namespace printtwin
