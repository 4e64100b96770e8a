// Multi-tool and multi-material G-code: filament changes on a shared nozzle (Bambu AMS,
// Prusa MMU), tool changes with a heater per tool (Marlin M104/M109 T<n>, Klipper
// ACTIVATE_EXTRUDER), the tools the slicers' settings declare and the filament per tool
// they state. The G-code is written here in each dialect.
#include <gtest/gtest.h>

#include <sstream>

#include "printtwin/machine.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/simulate.hpp"

namespace printtwin {
namespace {

/// Runs `text` on the Ender-3 profile with the firmware flavour `firmware`.
SimulationResult sim(const std::string& text, const std::string& firmware,
                     const SimulateOptions& o) {
  std::istringstream in(text);
  PrinterProfile profile = ender3_marlin2();
  profile.firmware = firmware;
  auto r = simulate_gcode(in, profile, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : SimulationResult{};
}

int count(const SimulationResult& r, const std::string& code) {
  int n = 0;
  for (const auto& f : r.findings) n += f.code == code ? 1 : 0;
  return n;
}

/// A 10 mm line at height z pushing `e` mm of filament (relative E).
std::string line_at(double z, double e) {
  return "G1 X50 Y50 Z" + std::to_string(z) + " F6000\nG1 X60 E" + std::to_string(e) + " F1200\n";
}

TEST(ToolChange, AmsFilamentChangeWaitsUnloadPlusLoadAndSplitsFilamentPerSlot) {
  // Bambu: one nozzle, four AMS slots. The change sequence M620 S<n>A .. T<n> .. M621 S<n>A
  // unloads the old filament and loads the new one; the purge is ordinary E moves.
  SimulateOptions o;
  o.interpreter.tool_count = 4;
  o.interpreter.shared_nozzle = true;
  o.interpreter.filament_load_s = {29};
  o.interpreter.filament_unload_s = {28};
  const std::string text = "G28\nM109 S220\nM83\nM620 S0A\nT0\nM621 S0A\n" + line_at(0.2, 1.0) +
                           "M620 S2A\nM104 S220\nT2\nG1 E5 F300\nM621 S2A\n" + line_at(0.4, 2.0) +
                           "M620 S255\nT255\nM621 S255\n";
  const auto r = sim(text, "bambu", o);
  EXPECT_EQ(count(r, "bad_tool"), 0);
  EXPECT_EQ(count(r, "cold_extrusion"), 0);
  EXPECT_EQ(r.tool_changes, 1);  // T0 was loaded already; T255 unloads at the end
  EXPECT_NEAR(r.tool_change_time_s, 57.0, 1e-9);
  ASSERT_EQ(r.tool_filament_mm.size(), 3U);
  EXPECT_NEAR(r.tool_filament_mm[0], 1.0, 1e-9);
  EXPECT_NEAR(r.tool_filament_mm[1], 0.0, 1e-9);
  EXPECT_NEAR(r.tool_filament_mm[2], 7.0, 1e-9);  // the purge counts for the new filament
  // Without stated times the change takes only its G-code's moves.
  SimulateOptions quiet = o;
  quiet.interpreter.filament_load_s.clear();
  quiet.interpreter.filament_unload_s.clear();
  const auto q = sim(text, "bambu", quiet);
  EXPECT_NEAR(r.dwell_time_s - q.dwell_time_s, 57.0, 1e-6);
  EXPECT_EQ(q.tool_change_time_s, 0);
}

TEST(ToolChange, PerToolTemperaturesDoNotCoolTheActiveNozzle) {
  // Dual extruder, Marlin: M104 T1 S0 turns off tool 1's heater, not the active tool 0's;
  // M109 T1 waits for tool 1. Tool 1 extruding while cold is a cold extrusion.
  SimulateOptions o;
  o.interpreter.tool_count = 2;
  const std::string warm = "G28\nM109 T0 S210\nM104 T1 S0\nM83\n" + line_at(0.2, 1.0);
  auto r = sim(warm, "marlin2", o);
  EXPECT_EQ(count(r, "cold_extrusion"), 0);
  EXPECT_EQ(count(r, "bad_tool"), 0);
  r = sim(warm + "T1\n" + line_at(0.4, 1.0), "marlin2", o);
  EXPECT_EQ(count(r, "cold_extrusion"), 1);
  ASSERT_EQ(r.tool_filament_mm.size(), 2U);
  EXPECT_NEAR(r.tool_filament_mm[1], 0.0, 1e-9);  // the firmware dropped the cold E
  const auto heated = sim(warm + "M109 T1 S205\nT1\n" + line_at(0.4, 1.0), "marlin2", o);
  EXPECT_EQ(count(heated, "cold_extrusion"), 0);
  EXPECT_GT(heated.heating_time_s, r.heating_time_s);
  EXPECT_NEAR(heated.tool_filament_mm[1], 1.0, 1e-9);
  // A file that declares no second tool: T1 is a tool the printer does not have.
  EXPECT_EQ(count(sim("G28\nT1\n", "marlin2", {}), "bad_tool"), 1);
  SimulateOptions three;
  three.interpreter.tool_count = 3;
  EXPECT_EQ(count(sim("G28\nT2\n", "marlin2", three), "bad_tool"), 0);
  EXPECT_EQ(count(sim("G28\nT3\n", "marlin2", three), "bad_tool"), 1);
}

TEST(ToolChange, KlipperActivateExtruderAndNamedHeaters) {
  // Klipper: a T1 macro's body is ACTIVATE_EXTRUDER EXTRUDER=extruder1; heaters and sensors
  // are named extruder, extruder1, ...
  const std::string text =
      "G28\nSET_HEATER_TEMPERATURE HEATER=extruder TARGET=215\n"
      "TEMPERATURE_WAIT SENSOR=extruder MINIMUM=215\nM83\n" +
      line_at(0.2, 1.0) +
      "SET_HEATER_TEMPERATURE HEATER=extruder1 TARGET=230\n"
      "TEMPERATURE_WAIT SENSOR=extruder1 MINIMUM=230\nACTIVATE_EXTRUDER EXTRUDER=extruder1\n" +
      line_at(0.4, 2.0) + "ACTIVATE_EXTRUDER EXTRUDER=extruder\n" + line_at(0.6, 1.0);
  const auto r = sim(text, "klipper", {});
  EXPECT_EQ(count(r, "cold_extrusion"), 0);
  EXPECT_EQ(count(r, "bad_tool"), 0);
  EXPECT_EQ(r.tool_changes, 2);
  ASSERT_EQ(r.tool_filament_mm.size(), 2U);
  EXPECT_NEAR(r.tool_filament_mm[0], 2.0, 1e-9);
  EXPECT_NEAR(r.tool_filament_mm[1], 2.0, 1e-9);
  // The second extruder never heated: its extrusion is cold.
  const auto cold =
      sim("G28\nM109 S215\nM83\nACTIVATE_EXTRUDER EXTRUDER=extruder1\n" + line_at(0.2, 1.0),
          "klipper", {});
  EXPECT_EQ(count(cold, "cold_extrusion"), 1);
}

TEST(ToolChange, SlicerSettingsDeclareToolsNozzleSharingAndChangeTimes) {
  // PrusaSlicer MMU: five extruders on one nozzle, load/unload time per filament.
  const std::string prusa =
      "; generated by PrusaSlicer 2.8.1\n; nozzle_diameter = 0.4,0.4,0.4,0.4,0.4\n"
      "; single_extruder_multi_material = 1\n; filament_load_time = 15,15,16,15,15\n"
      "; filament_unload_time = 12,12,12,13,12\n";
  auto st = stated_printer(parse_slicer_settings(prusa, prusa, 1));
  ASSERT_TRUE(st.tool_count);
  EXPECT_EQ(st.tool_count->value, 5);
  ASSERT_TRUE(st.shared_nozzle);
  EXPECT_TRUE(st.shared_nozzle->value);
  ASSERT_EQ(st.filament_load_s.size(), 5U);
  EXPECT_EQ(st.filament_load_s[2], 16);
  EXPECT_EQ(st.filament_unload_s[3], 13);
  // Bambu Studio: filaments (AMS slots) in filament_colour, one nozzle, machine times.
  const std::string bambu =
      "; BambuStudio 01.10.01.50\n; filament_colour = #808080;#0080FF;#FF0000\n"
      "; single_extruder_multi_material = 1\n; machine_load_filament_time = 29\n"
      "; machine_unload_filament_time = 28\n; nozzle_diameter = 0.4\n";
  st = stated_printer(parse_slicer_settings(bambu, bambu, 1));
  ASSERT_TRUE(st.tool_count);
  EXPECT_EQ(st.tool_count->value, 3);
  EXPECT_EQ(st.filament_load_s, std::vector<double>{29});
  // Cura (Griffin header): one block per extruder train, separate nozzles.
  const std::string cura =
      ";FLAVOR:Griffin\n;EXTRUDER_TRAIN.0.INITIAL_TEMPERATURE:210\n"
      ";EXTRUDER_TRAIN.1.INITIAL_TEMPERATURE:215\n";
  st = stated_printer(parse_slicer_settings(cura, cura, 1));
  ASSERT_TRUE(st.tool_count);
  EXPECT_EQ(st.tool_count->value, 2);
  EXPECT_FALSE(st.shared_nozzle && st.shared_nozzle->value);
}

TEST(ToolChange, SlicerFilamentPerToolIsReadInEachDialect) {
  SimulateOptions o;
  o.interpreter.tool_count = 4;
  // Bambu Studio lists the used filaments' lengths, then which filaments they are.
  auto r = sim("; total filament length [mm] : 100.5,20.25\n; filament: 1,3\nG28\n", "bambu", o);
  ASSERT_EQ(r.slicer_tool_filament_mm.size(), 3U);
  EXPECT_DOUBLE_EQ(r.slicer_tool_filament_mm[0], 100.5);
  EXPECT_DOUBLE_EQ(r.slicer_tool_filament_mm[1], 0.0);
  EXPECT_DOUBLE_EQ(r.slicer_tool_filament_mm[2], 20.25);
  ASSERT_TRUE(r.slicer_filament_mm);
  EXPECT_DOUBLE_EQ(*r.slicer_filament_mm, 120.75);
  // PrusaSlicer: one value per extruder.
  r = sim("; filament used [mm] = 252.22, 0.00, 10.5\nG28\n", "marlin2", o);
  ASSERT_EQ(r.slicer_tool_filament_mm.size(), 3U);
  EXPECT_DOUBLE_EQ(r.slicer_tool_filament_mm[2], 10.5);
  // Cura Griffin: mm3 per extruder train.
  const double area = ender3_marlin2().filament_area_mm2();
  r =
      sim(";EXTRUDER_TRAIN.0.MATERIAL.VOLUME_USED:730\n;EXTRUDER_TRAIN.1.MATERIAL.VOLUME_USED:628\n"
          "G28\n",
          "marlin2", o);
  ASSERT_EQ(r.slicer_tool_filament_mm.size(), 2U);
  EXPECT_NEAR(r.slicer_tool_filament_mm[1], 628 / area, 1e-9);
  ASSERT_TRUE(r.slicer_filament_mm);
  EXPECT_NEAR(*r.slicer_filament_mm, 1358 / area, 1e-9);
}

}  // namespace
}  // namespace printtwin
