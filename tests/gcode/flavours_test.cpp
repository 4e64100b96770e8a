// Firmware flavours (Marlin, Prusa, Klipper, RepRapFirmware, Bambu), printer-side start and
// end macros, helical arcs and the P turn count, and every slicer's layer and feature
// markers, on small G-code written in the test in each dialect.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/simulate.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

PrinterProfile with_firmware(const std::string& firmware) {
  PrinterProfile p = ender3_marlin2();
  p.firmware = firmware;
  return p;
}

Result<SimulationResult> run(const std::string& text,
                             const PrinterProfile& profile = ender3_marlin2(),
                             const SimulateOptions& o = {}) {
  std::istringstream in(text);
  return simulate_gcode(in, profile, o);
}

SimulationResult sim(const std::string& text, const PrinterProfile& profile = ender3_marlin2(),
                     const SimulateOptions& o = {}) {
  auto r = run(text, profile, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : SimulationResult{};
}

std::vector<Move> moves(const std::string& text, const PrinterProfile& profile = ender3_marlin2(),
                        const SimulateOptions& o = {}) {
  std::istringstream in(text);
  auto r = interpret_gcode(in, profile, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : std::vector<Move>{};
}

const Finding* find(const SimulationResult& r, const std::string& code) {
  for (const auto& f : r.findings)
    if (f.code == code) return &f;
  return nullptr;
}

int count_severity(const SimulationResult& r, Severity s) {
  int n = 0;
  for (const auto& f : r.findings) n += f.severity == s ? 1 : 0;
  return n;
}

/// No error, no warning, no unknown command.
void expect_clean(const SimulationResult& r) {
  EXPECT_EQ(count_severity(r, Severity::error), 0);
  EXPECT_EQ(count_severity(r, Severity::warning), 0);
  EXPECT_TRUE(r.unknown_commands.empty()) << r.unknown_commands.begin()->first;
}

/// Records what the interpreter sends to the planner.
struct Recorder final : InterpreterOutput {
  std::vector<Move> moves;
  MotionLimits last;
  int changes = 0;
  void move(const Move& m) override { moves.push_back(m); }
  void limits(const MotionLimits& l) override { last = l, ++changes; }
  void synchronize() override {}
  void wait(double, bool, long) override {}
};

void execute_line(GcodeInterpreter& interp, const std::string& line, Recorder& out) {
  GcodeCommand c;
  ASSERT_TRUE(parse_gcode_line(line, 1, c).ok()) << line;
  ASSERT_TRUE(interp.execute(c, line, out).ok()) << line;
}

/// A square of side 10 mm at height z, extruded with relative E.
std::string square(double z, double x0 = 100, double y0 = 100) {
  std::ostringstream s;
  s << "G1 Z" << z << " F600\nG1 X" << x0 << " Y" << y0 << " F6000\n";
  s << "G1 X" << x0 + 10 << " Y" << y0 << " E0.5 F1800\nG1 X" << x0 + 10 << " Y" << y0 + 10
    << " E0.5\n";
  s << "G1 X" << x0 << " Y" << y0 + 10 << " E0.5\nG1 X" << x0 << " Y" << y0 << " E0.5\n";
  return s.str();
}

// --- Parser: Prusa's quoted strings and version strings ---------------------------------

TEST(GcodeParserDialects, QuotedStringsAndVersionStrings) {
  GcodeCommand c;
  ASSERT_TRUE(parse_gcode_line("M862.3 P \"MK4S\"", 1, c).ok());
  EXPECT_EQ(c.code, 862);
  EXPECT_EQ(c.subcode, 3);
  EXPECT_TRUE(c.has('P'));
  EXPECT_EQ(c.args, "MK4S");
  ASSERT_TRUE(parse_gcode_line("M862.6 P\"Input shaper\"", 2, c).ok());
  EXPECT_EQ(c.args, "Input shaper");
  ASSERT_TRUE(parse_gcode_line("M115 U6.1.3+7898", 3, c).ok());
  EXPECT_EQ(c.code, 115);
  EXPECT_EQ(c.args, "U6.1.3+7898");
  ASSERT_TRUE(parse_gcode_line("M1002 gcode_claim_action : 2", 4, c).ok());
  ASSERT_TRUE(parse_gcode_line("M98 P\"config.g\" S1", 5, c).ok());
  EXPECT_DOUBLE_EQ(c.get('S'), 1.0);
  // An unterminated string is still bad input, with the line.
  auto bad = parse_gcode_line("M862.3 P \"MK4S", 6, c);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("closing"), std::string::npos);
}

// --- Prusa firmware ---------------------------------------------------------------------

TEST(FlavourPrusa, StartCodeOfAnMk4sRunsWithoutErrorsOrUnknownCommands) {
  const std::string text =
      "M17\nM862.1 P0.4 A0 F0\nM862.3 P \"MK4S\"\nM862.5 P2\nM862.6 P\"Input shaper\"\n"
      "M115 U6.1.3+7898\nM555 X118.75 Y94.75 W32 H16.5\nM140 S60\nM104 T0 S170\nM109 T0 R170\n"
      "M84 E\nG28\nM302 S160\nG29 P9 X10 Y-4 W32 H4\nM190 S60\nG29 P1\nG29 P1 X0 Y0 W50 H20 C\n"
      "G29 P3.2\nG29 P3.13\nG29 A\nM104 S230\nM109 S230\nM569 S0 E\nM593 X T2 F0\nM572 S0.036\n"
      "M142 S36\nM74 W0.03\nM73 P0 R3\nM83\n" +
      square(0.2);
  const auto r = sim(text, with_firmware("prusa"));
  expect_clean(r);
  const Finding* levelling = find(r, "bed_levelling_not_timed");
  ASSERT_NE(levelling, nullptr);  // said once, counted
  EXPECT_EQ(levelling->severity, Severity::info);
  EXPECT_EQ(levelling->count, 6);
  EXPECT_NEAR(r.filament_mm, 2.0, 1e-9);
}

TEST(FlavourMarlin, StartCodeSettingsAreAcceptedQuietly) {
  // Start codes that set PID values, power-loss recovery and the probe before printing.
  const auto r =
      sim(std::string("M301 P24.63 I2.05 D74.05\nM304 P134.53 I26.22 D460.11\n") +
          "M413 S0\nM80\nM140 S60\nM104 S200\nM190 S60\nM109 S200\nG28\n" +
          "M280 P0 S160\nM401\nM402\nM42 P4 S255\nM120\nM121\nM710 S255\nM83\n" + square(0.2));
  expect_clean(r);
  EXPECT_NEAR(r.filament_mm, 2.0, 1e-9);
}

TEST(FlavourMarlin, M221FlowScalesTheExtrusionAndSaysSo) {
  // Prusa MINI start codes set "M221 S95": the printer lays 95 % of the commanded E, which
  // the slicer's filament figure does not include.
  const auto r = sim("G28\nM104 S200\nM109 S200\nM83\nM221 S95\n" + square(0.2));
  EXPECT_NEAR(r.filament_mm, 0.95 * 2.0, 1e-9);
  const Finding* flow = find(r, "flow_override");
  ASSERT_NE(flow, nullptr);
  EXPECT_EQ(flow->severity, Severity::info);
  EXPECT_NE(flow->message.find("M221 S95 "), std::string::npos) << flow->message;
  // Back to 100 % says nothing.
  EXPECT_EQ(find(sim("G28\nM104 S200\nM109 S200\nM83\nM221 S100\n" + square(0.2)), "flow_override"),
            nullptr);
}

TEST(FlavourPrusa, M862ChecksTheNozzleAndTheModelLikeTheFirmware) {
  PrinterProfile mk4s = with_firmware("prusa");
  mk4s.model = "Original Prusa MK4S";
  const auto same = sim("M862.1 P0.4\nM862.3 P \"MK4S\"\n", mk4s);
  expect_clean(same);
  PrinterProfile mini = with_firmware("prusa");
  mini.model = "MINI";
  mini.nozzle_diameter_mm = 0.6;
  const auto other = sim("M862.1 P0.4\nM862.3 P \"MK4S\"\n", mini);
  ASSERT_NE(find(other, "nozzle_mismatch"), nullptr);
  EXPECT_EQ(find(other, "nozzle_mismatch")->line, 1);
  ASSERT_NE(find(other, "printer_model_mismatch"), nullptr);
  EXPECT_NE(find(other, "printer_model_mismatch")->message.find("MK4S"), std::string::npos);
  // Marlin does not know M862: nothing to check.
  const auto marlin = sim("M862.3 P \"MK4S\"\n", ender3_marlin2());
  EXPECT_EQ(find(marlin, "printer_model_mismatch"), nullptr);
}

TEST(GcodeFlavours, G90AndG91MoveEAsEachFirmwareDoes) {
  // M83 then G90: Marlin 2 (and Prusa's, Bambu's firmware) makes E absolute again; Marlin 1
  // and Klipper keep M83.
  const std::string m83_g90 = "G28\nM109 S210\nM83\nG90\nG1 X10 Y10 Z0.2 E1 F1200\nG1 X20 E1\n";
  EXPECT_NEAR(sim(m83_g90, ender3_marlin2()).filament_mm, 1.0, 1e-9);
  EXPECT_NEAR(sim(m83_g90, with_firmware("prusa")).filament_mm, 1.0, 1e-9);
  EXPECT_NEAR(sim(m83_g90, with_firmware("marlin1")).filament_mm, 2.0, 1e-9);
  EXPECT_NEAR(sim(m83_g90, with_firmware("klipper")).filament_mm, 2.0, 1e-9);
  // M82 then G91: E follows G91 on Marlin and Klipper.
  const std::string m82_g91 =
      "G28\nM109 S210\nM82\nG90\nG1 X10 Y10 Z0.2 E5 F1200\nG91\nG1 X1 E1\nG90\n";
  EXPECT_NEAR(sim(m82_g91, ender3_marlin2()).filament_mm, 6.0, 1e-9);
  EXPECT_NEAR(sim(m82_g91, with_firmware("klipper")).filament_mm, 6.0, 1e-9);
  EXPECT_NEAR(sim(m82_g91, with_firmware("marlin1")).filament_mm, 6.0, 1e-9);
}

TEST(GcodeStatedFigures, CuraEnginesUnfilledHeaderIsNotTheSlicersFigure) {
  const auto r =
      sim(";FLAVOR:Marlin\n;TIME:6666\n;Filament used: 0m\n;Layer height: 0.2\n"
          ";Generated with Cura_SteamEngine 4.13.0\nG28\nM109 S200\nM83\n;LAYER:0\n" +
          square(0.2));
  EXPECT_FALSE(r.slicer_estimate_s.has_value());
  EXPECT_FALSE(r.slicer_filament_mm.has_value());
  ASSERT_NE(find(r, "slicer_header_placeholders"), nullptr);
  EXPECT_EQ(r.layers.size(), 1u);
}

TEST(FlavourPrusa, M302SetsTheColdExtrusionLimit) {
  // M302 S160 then 165 C: extrusion allowed; the profile's 170 C would have refused it.
  const auto r = sim("G28\nM302 S160\nM109 S165\nM83\n" + square(0.2), with_firmware("prusa"));
  EXPECT_EQ(find(r, "cold_extrusion"), nullptr);
  EXPECT_NEAR(r.filament_mm, 2.0, 1e-9);
}

// --- Klipper ----------------------------------------------------------------------------

TEST(FlavourKlipper, StartMacroWithParametersHomesAndHeats) {
  const std::string text =
      "M140 S0\nM104 S0\nSTART_PRINT EXTRUDER_TEMP=220 BED_TEMP=60\nG90\nM83\n" + square(0.2) +
      "END_PRINT\n";
  const auto r = sim(text, with_firmware("klipper"));
  EXPECT_EQ(count_severity(r, Severity::error), 0);
  EXPECT_EQ(find(r, "move_before_homing"), nullptr);
  EXPECT_EQ(find(r, "cold_extrusion"), nullptr);
  EXPECT_EQ(find(r, "macro_temperature_assumed"), nullptr);
  EXPECT_NEAR(r.filament_mm, 2.0, 1e-9);
  EXPECT_GT(r.homing_time_s, 0.0);
  // Bed 25 -> 60 C at 0.5 C/s and hotend 25 -> 220 C at 2 C/s, one after the other.
  EXPECT_NEAR(r.heating_time_s, 35.0 / 0.5 + 195.0 / 2.0, 1e-6);
  EXPECT_TRUE(r.unknown_commands.empty());
  // Voron profiles call it in lower case with EXT_TEMP (Klipper upper-cases commands).
  const auto voron = sim("print_start EXT_TEMP=220 BED_TEMP=60\nG90\nM83\n" + square(0.2),
                         with_firmware("klipper"));
  EXPECT_EQ(find(voron, "macro_temperature_assumed"), nullptr);
  EXPECT_NEAR(voron.heating_time_s, r.heating_time_s, 1e-6);
}

TEST(FlavourKlipper, StartMacroWithoutParametersUsesTheSlicersTemperaturesOrSaysItAssumes) {
  const std::string text = "PRINT_START\nM83\n" + square(0.2) + "PRINT_END\n";
  SimulateOptions o;
  o.interpreter.macro_hotend_c = 240;
  o.interpreter.macro_bed_c = 80;
  const auto known = sim(text, with_firmware("klipper"), o);
  EXPECT_EQ(count_severity(known, Severity::error), 0);
  EXPECT_EQ(find(known, "macro_temperature_assumed"), nullptr);
  EXPECT_NEAR(known.heating_time_s, 55.0 / 0.5 + 215.0 / 2.0, 1e-6);

  const auto unknown = sim(text, with_firmware("klipper"));
  EXPECT_EQ(count_severity(unknown, Severity::error), 0);
  const Finding* assumed = find(unknown, "macro_temperature_assumed");
  ASSERT_NE(assumed, nullptr);
  EXPECT_EQ(assumed->severity, Severity::info);
  EXPECT_NE(assumed->message.find("PRINT_START"), std::string::npos);
  EXPECT_NEAR(unknown.filament_mm, 2.0, 1e-9);
}

TEST(FlavourKlipper, MacrosAreRecognisedByShapeNotByOneName) {
  for (const char* name :
       {"START_PRINT", "PRINT_START", "START_PRINT_K1", "_PRINT_START", "PRINT_BEGIN"}) {
    const auto r = sim(std::string(name) + " BED=55 HOTEND=215\nM83\n" + square(0.2),
                       with_firmware("klipper"));
    EXPECT_EQ(count_severity(r, Severity::error), 0) << name;
    EXPECT_TRUE(r.unknown_commands.empty()) << name;
  }
  // Not macros of the print's start: listed once as unknown, with their count.
  const auto r =
      sim("START_TIMER\nSTART_TIMER\nEXCLUDE_OBJECT_START NAME=a\n", with_firmware("klipper"));
  ASSERT_EQ(r.unknown_commands.size(), 1u);
  EXPECT_EQ(r.unknown_commands.at("START_TIMER"), 2);
}

TEST(FlavourKlipper, TemperatureWaitAndLevellingMacros) {
  const std::string text =
      "G28\nSET_HEATER_TEMPERATURE HEATER=heater_bed TARGET=60\nTEMPERATURE_WAIT SENSOR=heater_bed "
      "MINIMUM=60\n"
      "SET_HEATER_TEMPERATURE HEATER=extruder TARGET=215\nTEMPERATURE_WAIT SENSOR=extruder "
      "MINIMUM=210\n"
      "QUAD_GANTRY_LEVEL\nBED_MESH_CALIBRATE\nM83\n" +
      square(0.2);
  const auto r = sim(text, with_firmware("klipper"));
  EXPECT_EQ(count_severity(r, Severity::error), 0);
  EXPECT_TRUE(r.unknown_commands.empty());
  EXPECT_NEAR(r.heating_time_s, 35.0 / 0.5 + 185.0 / 2.0, 1e-6);
  ASSERT_NE(find(r, "bed_levelling_not_timed"), nullptr);
  EXPECT_EQ(find(r, "bed_levelling_not_timed")->count, 2);
  EXPECT_NEAR(r.filament_mm, 2.0, 1e-9);
}

TEST(FlavourKlipper, SetVelocityLimitAndM204AsKlipperReadsThem) {
  GcodeInterpreter interp(with_firmware("klipper"), {});
  Recorder out;
  auto exec = [&](const std::string& line) { execute_line(interp, line, out); };
  exec(
      "SET_VELOCITY_LIMIT VELOCITY=300 ACCEL=5000 SQUARE_CORNER_VELOCITY=9 "
      "MINIMUM_CRUISE_RATIO=0.3");
  EXPECT_DOUBLE_EQ(out.last.max_feedrate_mm_s[0], 300);
  EXPECT_DOUBLE_EQ(out.last.print_accel_mm_s2, 5000);
  EXPECT_DOUBLE_EQ(out.last.travel_accel_mm_s2, 5000);
  EXPECT_DOUBLE_EQ(out.last.square_corner_velocity_mm_s, 9);
  EXPECT_DOUBLE_EQ(out.last.minimum_cruise_ratio, 0.3);
  exec("SET_VELOCITY_LIMIT ACCEL=500 ACCEL_TO_DECEL=250");  // Creality Print's older form
  EXPECT_DOUBLE_EQ(out.last.print_accel_mm_s2, 500);
  EXPECT_DOUBLE_EQ(out.last.minimum_cruise_ratio, 0.5);
  exec("M204 S2000");
  EXPECT_DOUBLE_EQ(out.last.print_accel_mm_s2, 2000);
  EXPECT_DOUBLE_EQ(out.last.travel_accel_mm_s2, 2000);
  exec("M204 P1500 T3000");  // both: the smaller
  EXPECT_DOUBLE_EQ(out.last.print_accel_mm_s2, 1500);
  EXPECT_DOUBLE_EQ(out.last.travel_accel_mm_s2, 1500);
  const int before = out.changes;
  exec("M204 P800");  // a lone P: Klipper ignores it
  EXPECT_EQ(out.changes, before);
  EXPECT_DOUBLE_EQ(interp.limits().print_accel_mm_s2, 1500);
  // Marlin reads the same lone P as the printing acceleration.
  GcodeInterpreter marlin(ender3_marlin2(), {});
  GcodeCommand c;
  ASSERT_TRUE(parse_gcode_line("M204 P800", 1, c).ok());
  ASSERT_TRUE(marlin.execute(c, "M204 P800", out).ok());
  EXPECT_DOUBLE_EQ(marlin.limits().print_accel_mm_s2, 800);
}

TEST(FlavourKlipper, MarlinLimitCommandsLeaveKlippersLimitsAlone) {
  // Klipper has no M201/M203/M205: its [printer] limits stay, and the twin says so once.
  GcodeInterpreter interp(with_firmware("klipper"), {});
  Recorder out;
  const MotionLimits before = interp.limits();
  for (const char* line : {"M201 X20000 Y20000", "M203 X900 Y900", "M205 X20 Y20"})
    execute_line(interp, line, out);
  EXPECT_EQ(out.changes, 0);
  EXPECT_DOUBLE_EQ(interp.limits().max_accel_mm_s2[0], before.max_accel_mm_s2[0]);
  EXPECT_DOUBLE_EQ(interp.limits().max_feedrate_mm_s[0], before.max_feedrate_mm_s[0]);
  EXPECT_DOUBLE_EQ(interp.limits().jerk_mm_s[0], before.jerk_mm_s[0]);
  int notes = 0;
  for (const auto& f : interp.findings())
    if (f.code == "klipper_ignores") {
      ++notes;
      EXPECT_EQ(f.severity, Severity::info);
      EXPECT_EQ(f.count, 3);
    }
  EXPECT_EQ(notes, 1);
}

TEST(FlavourKlipper, QuietCommandsAndFirmwareRetraction) {
  PrinterProfile p = with_firmware("klipper");
  const std::string text =
      "G28\nM109 S210\nM83\nEXCLUDE_OBJECT_DEFINE NAME=a CENTER=105,105\nSET_PRESSURE_ADVANCE "
      "ADVANCE=0.04\n"
      "TIMELAPSE_TAKE_FRAME\nSET_FAN_SPEED FAN=aux SPEED=0.5\nSET_PRINT_STATS_INFO "
      "CURRENT_LAYER=1\n"
      "SET_RETRACTION RETRACT_LENGTH=0.8 RETRACT_SPEED=35 UNRETRACT_EXTRA_LENGTH=0.1 "
      "UNRETRACT_SPEED=20\n"
      "EXCLUDE_OBJECT_START NAME=a\n" +
      square(0.2) + "G10\nG10\nG11\nEXCLUDE_OBJECT_END NAME=a\n";
  const auto ms = moves(text, p);
  double retracted = 0, recovered = 0;
  for (const auto& m : ms) {
    if (m.kind == MoveKind::retract) {
      retracted -= m.e_mm;
      EXPECT_NEAR(m.feedrate_mm_s, 35, 1e-9);
    }
    if (m.kind == MoveKind::unretract) {
      recovered += m.e_mm;
      EXPECT_NEAR(m.feedrate_mm_s, 20, 1e-9);
    }
    if (m.kind == MoveKind::extrude) {
      EXPECT_EQ(m.object_id, 0);
    }
  }
  EXPECT_NEAR(retracted, 0.8, 1e-9);  // the second G10 does nothing
  EXPECT_NEAR(recovered, 0.9, 1e-9);  // length + extra
  const auto r = sim(text, p);
  EXPECT_TRUE(r.unknown_commands.empty());
}

// --- RepRapFirmware ---------------------------------------------------------------------

TEST(FlavourRrf, JerkAndFeedrateInMmPerMinuteAndG10ToolTemperatures) {
  GcodeInterpreter interp(with_firmware("rrf"), {});
  Recorder out;
  auto exec = [&](const std::string& line) { execute_line(interp, line, out); };
  exec("M566 X900 Y600 Z60 E120");
  EXPECT_DOUBLE_EQ(interp.limits().jerk_mm_s[0], 15);
  EXPECT_DOUBLE_EQ(interp.limits().jerk_mm_s[1], 10);
  EXPECT_DOUBLE_EQ(interp.limits().jerk_mm_s[3], 2);
  exec("M203 X18000 Y18000 Z600");
  EXPECT_DOUBLE_EQ(interp.limits().max_feedrate_mm_s[0], 300);
  EXPECT_DOUBLE_EQ(interp.limits().max_feedrate_mm_s[2], 10);
  exec("M201 X3000");
  EXPECT_DOUBLE_EQ(interp.limits().max_accel_mm_s2[0], 3000);
  // G10 P0 S215 R150: tool temperatures, not a retraction.
  exec("G28");
  exec("G10 P0 S215 R150");
  exec("M116");
  exec("G4 S120");  // long enough to reach 215 C at 2 C/s
  exec("M83");
  exec("G1 X20 E1 F600");
  ASSERT_FALSE(out.moves.empty());
  EXPECT_EQ(out.moves.back().kind, MoveKind::extrude);
  EXPECT_NEAR(out.moves.back().e_mm, 1.0, 1e-12);
  bool cold = false;
  for (const auto& f : interp.findings()) cold = cold || f.code == "cold_extrusion";
  EXPECT_FALSE(cold);
}

TEST(FlavourRrf, M0StopsAndCoolsWhileMarlinM0IsAPause) {
  const auto rrf = sim("G28\nM109 S200\nM0\n", with_firmware("rrf"));
  EXPECT_EQ(find(rrf, "user_pause"), nullptr);
  const auto marlin = sim("G28\nM0\n", ender3_marlin2());
  ASSERT_NE(find(marlin, "user_pause"), nullptr);
  EXPECT_EQ(find(marlin, "user_pause")->severity, Severity::info);
}

// --- Bambu ------------------------------------------------------------------------------

TEST(FlavourBambu, VendorCommandsAreAcceptedQuietly) {
  const std::string text =
      "M1002 gcode_claim_action : 2\nM1002 set_filament_type:PLA\nM620 M\nM620 S0A\nM621 S0A\n"
      "M1002 judge_flag g29_before_print_flag\nM622 J1\nG29.1 Z0\nG29.2 S0\nM623\nM960 S5 P1\n"
      "M971 S11 C10 O0\nM975 S1\nM981 S1 P20000\nM991 S0 P0\nG380 S2 Z-0.1 F300\nM412 S1\n"
      "M963 S1\nM964\nM969 S1 N3 A2000\nM977 S1 P60\nM984 A0.1 E1 S1 F2 H0.4\n"
      "M1006 A0 B10 L100 C37 D10 M60 E37 F10 N60\nM1007 S1\nG392 S0\nM630 S0 P0\n"
      "M9833.2\nG28\nM109 S220\nM83\n" +
      square(0.2);
  const auto r = sim(text, with_firmware("bambu"));
  expect_clean(r);
}

TEST(FlavourBambu, M211SwitchesTheSoftEndstopsPerAxisWithAStack) {
  // Bambu's start and end codes switch the soft endstops off (per axis, the state pushed
  // with a bare S and popped with R) to park beyond the printable travel.
  const PrinterProfile p = with_firmware("bambu");
  const std::string beyond = "G0 X" + std::to_string(p.travel_max_x_mm + 5) + " F6000\n";
  const std::string start = "G28\nM109 S220\nM83\n";
  const auto off = sim(start + "M211 S\nM211 X0 Y0 Z0\n" + beyond + square(0.2), p);
  EXPECT_EQ(find(off, "out_of_bounds"), nullptr);
  expect_clean(off);
  // The X1's start code says the same with M221 (its flow stays 100 %).
  const auto x1 = sim(start + "M221 S\nM221 X0 Y0 Z0\n" + beyond + square(0.2), p);
  EXPECT_EQ(find(x1, "out_of_bounds"), nullptr);
  EXPECT_NEAR(x1.filament_mm, 2.0, 1e-9);
  // Popped back on: the same move is clamped at the travel's end.
  const auto popped = sim(start + "M211 S\nM211 X0 Y0 Z0\nM211 R\n" + beyond + square(0.2), p);
  EXPECT_NE(find(popped, "out_of_bounds"), nullptr);
  // Marlin's M211 S0 / S1 switch every axis; Y left on stays clamped.
  EXPECT_EQ(find(sim(start + "M211 S0\n" + beyond + square(0.2)), "out_of_bounds"), nullptr);
  EXPECT_NE(find(sim(start + "M211 S0\nM211 S1\n" + beyond + square(0.2)), "out_of_bounds"),
            nullptr);
  EXPECT_NE(find(sim(start + "M211 X0\nG0 Y" + std::to_string(p.travel_max_y_mm + 5) + " F6000\n" +
                     square(0.2)),
                 "out_of_bounds"),
            nullptr);
}

TEST(FlavourBambu, G28XHomesXyAndALiftBeforeHomingIsQuiet) {
  // The A1 mini's start code: the bed lowered by a relative Z move before any homing, "G28 X"
  // (X and Y on Bambu's firmware), a move to Y 175, then Z homed alone.
  auto a1m = load_printer_profile("bambu-a1-mini");
  ASSERT_TRUE(a1m.ok()) << a1m.error().describe();
  const std::string start =
      "G91\nG1 Z5 F1200\nG90\nG28 X\nG0 X25 Y175 F20000\nG28 Z P0 T300\nM109 S220\nM83\n";
  const auto r = sim(start + square(0.2, 50, 50), *a1m);
  EXPECT_EQ(find(r, "move_before_homing"), nullptr);
  EXPECT_EQ(find(r, "hits_frame"), nullptr);
  expect_clean(r);
  // On Marlin "G28 X" homes X alone: the move to Y 175 drives an unhomed Y.
  const auto marlin = sim("G28 X\nG0 X25 Y175 F6000\nG28\nM109 S210\nM83\n" + square(0.2));
  ASSERT_NE(find(marlin, "move_before_homing"), nullptr);
  EXPECT_NE(find(marlin, "move_before_homing")->message.find("G0 X25 Y175"), std::string::npos);
  // A relative lift before homing needs no position: quiet on Marlin, refused by Klipper.
  EXPECT_EQ(find(sim("G91\nG1 Z5\nG90\nG28\n"), "move_before_homing"), nullptr);
  EXPECT_NE(find(sim("G91\nG1 Z5\nG90\nG28\n", with_firmware("klipper")), "move_before_homing"),
            nullptr);
}

TEST(FlavourBambu, FilamentSlotsAndSpecialToolsAreNotSecondExtruders) {
  // T<n> loads AMS slot n into the one nozzle; T255 unloads; T1000 / T1100 pick the nozzle or
  // the lidar. "M624 <base64>" opens an object's block, "M400 S7" waits 7 s.
  // "M221 S" alone pushes the soft endstops' state (Bambu), no flow of 0 %.
  const std::string text =
      "G28\nM109 S220\nM83\nT1\nT255\nT1000\nT1100\nM221 S\nM221 X0 Y0 Z0\nM221 R\n"
      "M624 AQAAAAAAAAA=\n" +
      square(0.2) + "M625\nM400 S7\nM400 P500\n";
  const auto r = sim(text, with_firmware("bambu"));
  EXPECT_EQ(find(r, "bad_tool"), nullptr);
  expect_clean(r);
  const auto base = sim("G28\nM109 S220\nM83\n" + square(0.2) + "M400\n", with_firmware("bambu"));
  EXPECT_NEAR(r.dwell_time_s - base.dwell_time_s, 7.5, 1e-9);
  EXPECT_DOUBLE_EQ(r.filament_mm, base.filament_mm);
  EXPECT_GT(r.filament_mm, 1.9);
  // On a Marlin printer T1 is a second extruder it does not have.
  EXPECT_NE(find(sim("G28\nT1\n"), "bad_tool"), nullptr);
}

// --- Arcs -------------------------------------------------------------------------------

TEST(GcodeArcs, HelicalLiftWithoutXyMotionMakesOneTurnPerP) {
  // OrcaSlicer / Bambu Studio spiral lift: G2 Z.. I.. J.. P1 at the same XY.
  const std::string head = "G28\nG1 X100 Y100 Z0.2 F6000\n";
  for (int turns : {1, 2}) {
    const auto ms = moves(head + "G2 Z0.6 I1.5 J0 P" + std::to_string(turns) + " F3000\n");
    double xy = 0, dz = 0;
    Vec3 end = Vec3::Zero();
    for (const auto& m : ms)
      if (m.line == 3) xy += m.xy_length_mm(), dz += m.end_mm.z() - m.start_mm.z(), end = m.end_mm;
    EXPECT_NEAR(xy, turns * 2 * 3.14159265358979 * 1.5, 0.02 * turns) << turns;
    EXPECT_NEAR(dz, 0.4, 1e-9);
    EXPECT_NEAR(end.x(), 100, 1e-9);
    EXPECT_NEAR(end.y(), 100, 1e-9);
  }
  // Without P a closed arc is one full circle; P adds turns to a partial arc.
  const auto circle = moves(head + "G3 I5 J0\n");
  double len = 0;
  for (const auto& m : circle)
    if (m.line == 3) len += m.xy_length_mm();
  EXPECT_NEAR(len, 2 * 3.14159265358979 * 5, 0.05);
  const auto half_plus = moves(head + "G3 X110 Y100 I5 J0 P1\n");
  len = 0;
  for (const auto& m : half_plus)
    if (m.line == 3) len += m.xy_length_mm();
  EXPECT_NEAR(len, 3 * 3.14159265358979 * 5, 0.08);
}

TEST(GcodeArcs, ZeroRadiusArcIsAFindingAndAnErrorUnderStrict) {
  const std::string text =
      "G28\nM109 S200\nM82\nG1 X100 Y100 Z0.2 F6000\nG2 X100 Y100 I0 J0 E1.5\nG1 X110 E2\n";
  const auto r = sim(text);
  const Finding* f = find(r, "bad_arc");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::warning);
  EXPECT_EQ(f->line, 5);
  EXPECT_NE(f->message.find("1.500 mm of filament"), std::string::npos) << f->message;
  // The rejected arc leaves E where it was: the next absolute E2 pushes 2 mm.
  EXPECT_NEAR(r.filament_mm, 2.0, 1e-9);
  SimulateOptions strict;
  strict.interpreter.strict = true;
  auto s = run(text, ender3_marlin2(), strict);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().line, 5);
  EXPECT_NE(s.error().message.find("zero radius"), std::string::npos);
}

// --- Slicers' layer and feature markers --------------------------------------------------

struct Dialect {
  const char* name;
  std::string header;                          // the slicer's first lines
  std::string (*marker)(int index, double z);  // its layer change
  const char* outer;                           // its outer-wall label line
  const char* infill;                          // its infill label line
  const char* stated;                          // its stated time and filament
  double time_s, filament_mm;
};

std::string prusa_marker(int, double z) {
  return ";LAYER_CHANGE\n;Z:" + format_fixed(z, 2) + "\n;HEIGHT:0.2\n";
}
std::string orca_marker(int, double z) {
  return "; CHANGE_LAYER\n; Z_HEIGHT: " + format_fixed(z, 2) + "\n; LAYER_HEIGHT: 0.2\n";
}
std::string cura_marker(int i, double) { return ";LAYER:" + std::to_string(i) + "\n"; }
std::string idea_marker(int i, double z) {
  return ";LAYER:" + std::to_string(i) + "\n;Z:" + format_fixed(z, 3) + "\n";
}
std::string kiss_marker(int, double z) {
  return "; BEGIN_LAYER_OBJECT z=" + format_fixed(z, 2) + "\n";
}
std::string s3d_marker(int i, double z) {
  return "; layer " + std::to_string(i + 1) + ", Z = " + format_fixed(z, 3) + "\n";
}

class SlicerMarkers : public ::testing::TestWithParam<Dialect> {};

TEST_P(SlicerMarkers, LayersFeaturesAndStatedFigures) {
  const Dialect& d = GetParam();
  std::string text = d.header + d.stated + "G28\nM109 S210\nM83\n";
  text += "G1 X5 Y5 Z0.3 F6000\nG1 X60 Y5 E3 F1500\n";  // a purge line before the first layer
  for (int i = 0; i < 4; ++i) {
    const double z = 0.2 * (i + 1);
    text += d.marker(i, z);
    text += std::string(d.outer) + "\n" + square(z);
    text += std::string(d.infill) + "\nG1 X105 Y105 E0.25\n";
    if (i == 1)
      text += d.marker(i, z);  // a second marker at the same height (KISSlicer: one per object)
  }
  text += "G1 E-0.8 F2100\nG1 Z20 F600\n";  // end code: retract and lift
  const auto r = sim(text);
  EXPECT_EQ(r.layers.size(), 4u) << d.name;
  EXPECT_EQ(r.layers_from, "markers") << d.name;
  if (!r.layers.empty()) {
    EXPECT_NEAR(r.layers.front().z_mm, 0.2, 1e-9) << d.name;
  }
  EXPECT_NEAR(r.filament_mm, 3.0 + 4 * 2.25 - 0.8, 1e-9) << d.name;
  EXPECT_NEAR(r.filament_part_mm, 4 * 2.25, 1e-9) << d.name;
  EXPECT_GT(r.time_by_feature_s.count("outer_perimeter"), 0u) << d.name;
  EXPECT_GT(r.time_by_feature_s.count("sparse_infill"), 0u) << d.name;
  ASSERT_TRUE(r.slicer_estimate_s.has_value()) << d.name;
  EXPECT_NEAR(*r.slicer_estimate_s, d.time_s, 1e-6) << d.name;
  ASSERT_TRUE(r.slicer_filament_mm.has_value()) << d.name;
  EXPECT_NEAR(*r.slicer_filament_mm, d.filament_mm, 0.01) << d.name;
  EXPECT_FALSE(r.slicer.empty()) << d.name;
}

INSTANTIATE_TEST_SUITE_P(
    Dialects, SlicerMarkers,
    ::testing::Values(
        Dialect{"prusaslicer", "; generated by PrusaSlicer 2.8.1 on 2024-10-21 at 06:38:01 UTC\n",
                prusa_marker, ";TYPE:External perimeter", ";TYPE:Internal infill",
                "; filament used [mm] = 252.22\n; estimated printing time (normal mode) = 3m 41s\n",
                221, 252.22},
        Dialect{"superslicer", "; generated by SuperSlicer 2.5.59 on 2024-01-01 at 10:00:00 UTC\n",
                prusa_marker, ";TYPE:External perimeter", ";TYPE:Internal infill",
                "; filament used [mm] = 10.5, 0.0\n; estimated printing time (normal mode) = 1h 2m "
                "3s\n",
                3723, 10.5},
        Dialect{"orcaslicer",
                "; HEADER_BLOCK_START\n; generated by OrcaSlicer 2.1.1 on 2024-06-01 at 10:00:00\n",
                orca_marker, "; FEATURE: Outer wall", "; FEATURE: Sparse infill",
                "; filament used [mm] = 99.5\n; model printing time: 10m 2s; total estimated time: "
                "11m 3s\n",
                663, 99.5},
        Dialect{"bambustudio", "; HEADER_BLOCK_START\n; BambuStudio 01.10.02.76\n", orca_marker,
                "; FEATURE: Outer wall", "; FEATURE: Sparse infill",
                "; estimated printing time (normal mode) = 13m 5s\n; total filament length [mm] : "
                "1503.61\n",
                785, 1503.61},
        Dialect{
            "crealityprint",
            "; HEADER_BLOCK_START\n; generated by Creality_Print V5.1.4.10249 on 2025-03-09\n",
            prusa_marker, ";TYPE:Outer wall", ";TYPE:Sparse infill",
            "; total estimated time: 39m 16s\n; estimated printing time (normal mode) = 39m 45s\n"
            "; filament used [mm] = 10882.04\n",
            2385, 10882.04},
        Dialect{"crealityprint4", "; generated by Creality Print 4.3.8 on 2024-01-01\n",
                prusa_marker, ";TYPE:WALL-OUTER", ";TYPE:FILL", ";TIME:600\n;Filament used: 1.5m\n",
                600, 1500},
        Dialect{"cura",
                ";FLAVOR:Marlin\n;TIME:1509\n;Filament used: 1.23865m\n;Layer height: 0.2\n"
                ";Generated with Cura_SteamEngine 5.7.1\n",
                cura_marker, ";TYPE:WALL-OUTER", ";TYPE:FILL", "", 1509, 1238.65},
        Dialect{"ideamaker",
                ";Sliced by ideaMaker 4.2.1.4764, 2022-01-01\n;Print Time: 3657\n;Material#1 Used: "
                "3476.51\n",
                idea_marker, ";TYPE:WALL-OUTER", ";TYPE:FILL", "", 3657, 3476.51},
        Dialect{"kisslicer", "; KISSlicer - FREE\n; version 1.4.5.10\n", kiss_marker,
                "; 'Perimeter Path', 0.3 [feed mm/s], 9.5 [head mm/s]",
                "; 'Sparse Infill Path', 0.3 [feed mm/s], 9.5 [head mm/s]",
                "; Estimated Build Time:   113.73 minutes\n; Estimated Build Volume: 2.405 cm^3\n",
                6823.8, 2405.0 / (0.25 * 3.14159265358979 * 1.75 * 1.75)},
        Dialect{"simplify3d", "; G-Code generated by Simplify3D(R) Version 4.1.2\n", s3d_marker,
                "; feature outer perimeter", "; feature infill",
                ";   Build time: 1 hours 23 minutes\n;   Filament length: 4217.9 mm (4.22 m)\n",
                4980, 4217.9}),
    [](const ::testing::TestParamInfo<Dialect>& i) { return std::string(i.param.name); });

TEST(SlicerMarkers, AFileCutBeforeTheSlicersClosingLinesIsTruncated) {
  // Each slicer writes lines after its end code; a file without them was cut.
  const std::string body = "G28\nM109 S210\nM83\n" + square(0.2);
  const std::string cura = ";FLAVOR:Marlin\n;Generated with Cura_SteamEngine 5.9.0\n" + body;
  const auto cut = sim(cura);
  const Finding* t = find(cut, "truncated_file");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->severity, Severity::warning);
  EXPECT_NE(t->message.find(";End of Gcode"), std::string::npos) << t->message;
  EXPECT_EQ(find(sim(cura + ";End of Gcode\n"), "truncated_file"), nullptr);

  const std::string bambu =
      "; HEADER_BLOCK_START\n; BambuStudio 02.01.01.52\n"
      "; HEADER_BLOCK_END\n; EXECUTABLE_BLOCK_START\n" +
      body;
  EXPECT_NE(find(sim(bambu), "truncated_file"), nullptr);
  EXPECT_EQ(find(sim(bambu + "; EXECUTABLE_BLOCK_END\n"), "truncated_file"), nullptr);

  const std::string prusa = "; generated by PrusaSlicer 2.7.4 on 2024-05-26\n" + body;
  EXPECT_NE(find(sim(prusa), "truncated_file"), nullptr);
  EXPECT_EQ(find(sim(prusa + "; filament used [mm] = 2.00\n; prusaslicer_config = begin\n"
                             "; prusaslicer_config = end\n"),
                 "truncated_file"),
            nullptr);
  // A file from no known slicer says nothing of the kind.
  EXPECT_EQ(find(sim(body), "truncated_file"), nullptr);
}

TEST(SlicerMarkers, JsonAndSummaryCarryThePartFilamentAndTheSlicersFigures) {
  const std::string text =
      "; generated by PrusaSlicer 2.8.1 on 2024-10-21\n; filament used [mm] = 2.5\n"
      "; estimated printing time (normal mode) = 1m 5s\nG28\nM109 S210\nM83\n"
      "G1 X5 Y5 Z0.3 F6000\nG1 X60 Y5 E3 F1500\n;LAYER_CHANGE\n;Z:0.2\n" +
      square(0.2);
  const auto r = sim(text);
  const auto doc = nlohmann::json::parse(simulation_to_json(r, "x.gcode"));
  EXPECT_DOUBLE_EQ(doc["filament_part_mm"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(doc["filament_mm"].get<double>(), 5.0);
  EXPECT_DOUBLE_EQ(doc["slicer_filament_mm"].get<double>(), 2.5);
  EXPECT_DOUBLE_EQ(doc["slicer_estimate_s"].get<double>(), 65.0);
  EXPECT_EQ(doc["layers"]["from"], "markers");
  EXPECT_EQ(doc["layers"]["count"], 1);
  const std::string summary = simulation_summary(r);
  EXPECT_NE(summary.find("part 2.00 mm"), std::string::npos) << summary;
  EXPECT_NE(summary.find("part differs by -20.00 %"), std::string::npos) << summary;
  const auto none = nlohmann::json::parse(simulation_to_json(sim("G28\n"), "y.gcode"));
  EXPECT_TRUE(none["slicer_filament_mm"].is_null());
  EXPECT_EQ(none["layers"]["from"], "z");
}

TEST(SlicerMarkers, OrcaFamilysModelTimeAndFilamentAreComparedTheirWay) {
  // The Orca family states the model's time apart from its start sequence, and counts the
  // filament of every extruding move (the purge line in, E-only priming and unretractions
  // out). The start code here primes 10 mm in place, draws a 3 mm purge line and retracts.
  const std::string text =
      "; HEADER_BLOCK_START\n; BambuStudio 02.03.01.51\n"
      "; model printing time: 1m 0s; total estimated time: 5m 0s\n; total layer number: 1\n"
      "; total filament length [mm] : 5.00\n; HEADER_BLOCK_END\n"
      "G28\nM109 S210\nM83\nG1 X5 Y5 Z0.3 F6000\nG1 E10 F300\nG1 X60 Y5 E3 F1500\n"
      "G1 E-0.8 F1800\n; CHANGE_LAYER\n; Z_HEIGHT: 0.2\nG1 E0.8 F1800\n" +
      square(0.2);
  const auto r = sim(text);
  EXPECT_NEAR(r.filament_extruding_mm, 5.0, 1e-9);  // 3 (purge line) + 2 (the square)
  EXPECT_NEAR(r.filament_mm, 15.0, 1e-9);           // + the 10 mm primed in place
  ASSERT_TRUE(r.slicer_part_estimate_s.has_value());
  EXPECT_DOUBLE_EQ(*r.slicer_part_estimate_s, 60.0);
  EXPECT_DOUBLE_EQ(r.slicer_estimate_s.value_or(0), 300.0);
  EXPECT_EQ(find(r, "truncated_file"), nullptr);
  const auto doc = nlohmann::json::parse(simulation_to_json(r, "x.gcode"));
  EXPECT_DOUBLE_EQ(doc["filament_extruding_mm"].get<double>(), 5.0);
  EXPECT_DOUBLE_EQ(doc["slicer_part_estimate_s"].get<double>(), 60.0);
  const std::string summary = simulation_summary(r);
  EXPECT_NE(summary.find("1m 0s for the model (5m 0s with its start sequence); the layers' time"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("extruding moves by 0.00 %"), std::string::npos) << summary;
  // Without the model's time the total is compared with the motion time, as before.
  const auto prusa =
      sim("; generated by PrusaSlicer 2.8.1 on 2024-10-21\n"
          "; estimated printing time (normal mode) = 1m 5s\nG28\nM109 S210\nM83\n"
          ";LAYER_CHANGE\n;Z:0.2\n" +
          square(0.2));
  EXPECT_FALSE(prusa.slicer_part_estimate_s.has_value());
  EXPECT_NE(simulation_summary(prusa).find("motion time differs by"), std::string::npos);
}

TEST(SlicerMarkers, AFileCutShortOfTheLayersItsHeaderAnnouncesIsAnError) {
  auto layers = [](int n) {
    std::string t;
    for (int i = 0; i < n; ++i) t += ";LAYER:" + std::to_string(i) + "\n" + square(0.2 * (i + 1));
    return t;
  };
  const std::string cura = ";FLAVOR:Marlin\n;Generated with Cura_SteamEngine 4.13.0\n";
  // Cura's header counts one layer more than it marks on some files: one layer of slack.
  EXPECT_EQ(
      find(sim(cura + ";LAYER_COUNT:4\nG28\nM109 S200\nM83\n" + layers(3) + ";End of Gcode\n"),
           "truncated_file"),
      nullptr);
  const auto cut =
      sim(cura + ";LAYER_COUNT:40\nG28\nM109 S200\nM83\n" + layers(3) + ";End of Gcode\n");
  const Finding* f = find(cut, "truncated_file");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::error);
  EXPECT_NE(f->message.find("announces 40 layers but the file ends after 3"), std::string::npos)
      << f->message;
  // The Orca family's header, and a file cut inside its start code, in the middle of a line.
  const auto orca =
      sim("; HEADER_BLOCK_START\n; generated by OrcaSlicer 2.3.1 on 2025-09-09 at 10:28:50\n"
          "; total layer number: 143\n; HEADER_BLOCK_END\nG28\nG1 Y-4 F6000\nG1 Y18");
  f = find(orca, "truncated_file");
  ASSERT_NE(f, nullptr);
  EXPECT_NE(f->message.find("ends after 0 layer markers (line 7, without a newline)"),
            std::string::npos)
      << f->message;
  // A whole file whose layers repeat one height (colour passes of a post-processed file):
  // the markers are counted, not the heights.
  std::string passes =
      "; HEADER_BLOCK_START\n; BambuStudio 02.00.03.54\n; total layer number: 3\n"
      "; HEADER_BLOCK_END\nG28\nM109 S210\nM83\n";
  for (int i = 0; i < 3; ++i) passes += "; CHANGE_LAYER\n; Z_HEIGHT: 0.2\n" + square(0.2);
  const auto flat = sim(passes);
  EXPECT_EQ(flat.layers.size(), 1u);
  EXPECT_EQ(find(flat, "truncated_file"), nullptr);
}

TEST(SlicerMarkers, PrusaSlicerFileWithoutItsClosingConfigLineWasCut) {
  // PrusaSlicer 2.8 states its figures at the top; since 2.4 its config block's end is the
  // file's last line.
  const std::string head =
      "; generated by PrusaSlicer 2.8.1 on 2024-10-21 at 06:38:01 UTC\n"
      "; filament used [mm] = 2.00\nG28\nM109 S210\nM83\n;LAYER_CHANGE\n;Z:0.2\n" +
      square(0.2);
  const auto cut = sim(head);
  const Finding* f = find(cut, "truncated_file");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::warning);
  EXPECT_NE(f->message.find("prusaslicer_config = end"), std::string::npos) << f->message;
  const std::string whole =
      head + "; prusaslicer_config = begin\n; layer_height = 0.2\n; prusaslicer_config = end\n";
  EXPECT_EQ(find(sim(whole), "truncated_file"), nullptr);
}

TEST(SlicerMarkers, ColdExtrusionInTheStartCodeLosesAPrimeNotThePart) {
  // A vendor start code that pushes filament before the nozzle is hot (Bambu's A1 does):
  // the prime is lost, the part prints. The same push inside a layer loses the part's plastic.
  const std::string head = "; generated by PrusaSlicer 2.8.1 on 2024-10-21\nG28\nM104 S210\nM83\n";
  const auto start = sim(head + "G1 E10 F1200\nM109 S210\n;LAYER_CHANGE\n;Z:0.2\n" + square(0.2));
  const Finding* f = find(start, "cold_extrusion");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::warning);
  EXPECT_EQ(count_severity(start, Severity::error), 0);
  const auto part = sim(head + ";LAYER_CHANGE\n;Z:0.2\n" + square(0.2));
  f = find(part, "cold_extrusion");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::error);
}

TEST(SlicerMarkers, SpiralVaseCountsTheSlicersLayersNotEveryZStep) {
  // A PrusaSlicer-style spiral vase: Z rises along every extrusion; one marker per turn.
  std::string text =
      "; generated by PrusaSlicer 2.8.1 on 2024-10-21 at 06:38:01 UTC\nG28\nM109 S210\nM83\n";
  text += ";LAYER_CHANGE\n;Z:0.2\n" + square(0.2);
  double z = 0.2;
  for (int layer = 1; layer < 30; ++layer) {
    text += ";LAYER_CHANGE\n;Z:" + format_fixed(0.2 * (layer + 1), 2) + "\n";
    for (int k = 0; k < 20; ++k) {
      z += 0.01;
      const double a = 2 * 3.14159265358979 * (k + 1) / 20.0;
      text += "G1 X" + format_fixed(105 + 5 * std::cos(a), 3) + " Y" +
              format_fixed(105 + 5 * std::sin(a), 3) + " Z" + format_fixed(z, 3) + " E0.05\n";
    }
  }
  const auto r = sim(text);
  EXPECT_EQ(r.layers.size(), 30u);
  // Without markers (a file whose slicer is unknown) layers come from Z: every step.
  std::string bare;
  for (std::size_t p = 0; p < text.size();) {
    const auto nl = text.find('\n', p);
    const std::string line = text.substr(p, nl - p);
    if (line.rfind(';', 0) != 0) bare += line + "\n";
    p = nl + 1;
  }
  const auto by_z = sim(bare);
  EXPECT_EQ(by_z.layers_from, "z");
  EXPECT_GT(by_z.layers.size(), 500u);
}

TEST(SlicerMarkers, AMarkingSlicersFileWithoutMarkersSaysSo) {
  const auto r =
      sim("; generated by PrusaSlicer 2.8.1 on 2024-10-21\nG28\nM109 S210\nM83\n" + square(0.2));
  EXPECT_TRUE(r.layers.empty());
  ASSERT_NE(find(r, "no_layer_markers"), nullptr);
  EXPECT_EQ(find(r, "no_layer_markers")->severity, Severity::warning);
  EXPECT_NEAR(r.filament_mm, 2.0, 1e-9);
}

TEST(SlicerMarkers, Simplify3DToolLineGivesHeightAndWidthHints) {
  const auto ms = moves(
      "G28\nM109 S210\nM83\n; feature outer perimeter\n; tool H0.250 W0.480\nG1 Z0.25\n"
      "G1 X20 Y20 E1 F1200\n");
  ASSERT_FALSE(ms.empty());
  EXPECT_EQ(ms.back().feature, Feature::outer_perimeter);
  EXPECT_FLOAT_EQ(ms.back().height_hint_mm, 0.25f);
  EXPECT_FLOAT_EQ(ms.back().width_hint_mm, 0.48f);
}

TEST(SlicerMarkers, FeatureLabelsOfEverySlicerMapToTheTwinsKinds) {
  EXPECT_EQ(feature_from_label("WALL-OUTER"), Feature::outer_perimeter);
  EXPECT_EQ(feature_from_label("Outer wall"), Feature::outer_perimeter);
  EXPECT_EQ(feature_from_label("outer perimeter"), Feature::outer_perimeter);
  EXPECT_EQ(feature_from_label("Perimeter Path"), Feature::outer_perimeter);
  EXPECT_EQ(feature_from_label("Loop Path"), Feature::perimeter);
  EXPECT_EQ(feature_from_label("Inner wall"), Feature::perimeter);
  EXPECT_EQ(feature_from_label("SKIRT"), Feature::skirt);
  EXPECT_EQ(feature_from_label("Skirt Path"), Feature::skirt);
  EXPECT_EQ(feature_from_label("SUPPORT"), Feature::support);
  EXPECT_EQ(feature_from_label("SUPPORT-INTERFACE"), Feature::support_interface);
  EXPECT_EQ(feature_from_label("dense support"), Feature::support_interface);
  EXPECT_EQ(feature_from_label("SOLID-FILL"), Feature::solid_infill);
  EXPECT_EQ(feature_from_label("solid layer"), Feature::solid_infill);
  EXPECT_EQ(feature_from_label("Internal Bridge"), Feature::bridge_infill);
  EXPECT_EQ(feature_from_label("Bridge"), Feature::bridge_infill);
  EXPECT_EQ(feature_from_label("Gap infill"), Feature::gap_fill);
  EXPECT_EQ(feature_from_label("PRIME-TOWER"), Feature::wipe_tower);
  EXPECT_EQ(feature_from_label("Ironing"), Feature::top_solid_infill);
  EXPECT_EQ(feature_from_label("Crown Path"), Feature::top_solid_infill);
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

/// The layer count a slicer states or marks in its own file, counted here independently of
/// the interpreter: "; total layer number: N" when the header says it, else the number of
/// distinct layer markers.
long slicers_layer_count(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  long stated = -1, markers = 0;
  std::set<std::string> object_layers;  // KISSlicer writes one marker per object and layer
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.rfind("; total layer number: ", 0) == 0) stated = std::stol(line.substr(22));
    if (line == ";LAYER_CHANGE" || line == "; CHANGE_LAYER" || line.rfind("; layer ", 0) == 0)
      ++markers;
    if (line.rfind(";LAYER:", 0) == 0 && line.size() > 7 &&
        (std::isdigit(line[7]) || line[7] == '-'))
      ++markers;
    if (line.rfind("; BEGIN_LAYER_OBJECT z=", 0) == 0) object_layers.insert(line.substr(23));
  }
  markers += static_cast<long>(object_layers.size());
  return stated >= 0 ? stated : markers;
}

TEST(RealWorldGcode, LayersFilamentAndNoMacroErrorsOnEveryRealFile) {
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no shared/realworld folder (set PRINTTWIN_REALWORLD_DIR)";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(*dir / "gcode")) {
    if (entry.path().extension() != ".gcode") continue;
    ++files;
    const std::string name = entry.path().filename().string();
    auto r = simulate_gcode_file(entry.path(), ender3_marlin2(), {});
    ASSERT_TRUE(r.ok()) << name << ": " << r.error().describe();
    for (const auto& f : r->findings) {
      EXPECT_NE(f.severity, Severity::error) << name << ": " << f.code << " " << f.message;
      EXPECT_NE(f.code, "cold_extrusion") << name;
      EXPECT_NE(f.code, "move_before_homing") << name;
    }
    EXPECT_GT(r->filament_mm, 0.0) << name;
    EXPECT_EQ(static_cast<long>(r->layers.size()), slicers_layer_count(entry.path())) << name;
    EXPECT_EQ(r->layers_from, "markers") << name;
    ASSERT_TRUE(r->slicer_filament_mm.has_value()) << name;
    const double s = *r->slicer_filament_mm;
    const double off =
        std::min(std::fabs(r->filament_part_mm - s), std::fabs(r->filament_mm - s)) / s;
    EXPECT_LT(off, 0.005) << name << ": part " << r->filament_part_mm << ", total "
                          << r->filament_mm << ", slicer " << s;
    EXPECT_TRUE(r->slicer_estimate_s.has_value()) << name;
    EXPECT_FALSE(r->slicer.empty()) << name;
  }
  if (files == 0) GTEST_SKIP() << "no .gcode in " << dir->string();
}

}  // namespace
}  // namespace printtwin
