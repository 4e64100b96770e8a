// --printer printer.cfg: Klipper's config with includes, the SAVE_CONFIG block and clear
// errors (file:line).
#include <gtest/gtest.h>

#include <fstream>

#include "printtwin/printer.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

const char* kPrinter =
    "# a Voron-like printer\n"
    "[include hardware.cfg]\n"
    "[include macros/*.cfg]\n"
    "\n"
    "[printer]\n"
    "kinematics: corexy\n"
    "max_velocity: 300   # mm/s\n"
    "max_accel = 3000\n"
    "max_accel_to_decel: 1500\n"
    "max_z_velocity: 15\n"
    "max_z_accel: 350\n"
    "square_corner_velocity: 5.0\n"
    "\n"
    "[stepper_x]\n"
    "position_min: 0\n"
    "position_max: 300\n"
    "homing_speed: 25\n"
    "[stepper_y]\n"
    "position_max: 300\n"
    "[stepper_z]\n"
    "position_min: -5\n"
    "position_max: 260\n"
    "\n"
    "[gcode_macro PRINT_START]\n"
    "gcode:\n"
    "    G28\n"
    "    G1 Z10 F600 ; a continuation line, not an option\n"
    "\n"
    "[firmware_retraction]\n"
    "retract_length: 0.5\n"
    "retract_speed: 35\n"
    "\n"
    "#*# <---------------------- SAVE_CONFIG ---------------------->\n"
    "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n"
    "#*#\n"
    "#*# [extruder]\n"
    "#*# nozzle_diameter = 0.6\n";

TEST(KlipperConfig, ReadsPrinterSteppersExtruderIncludesAndSaveConfig) {
  const auto dir = test::temp_dir("klipper_cfg");
  write(dir / "printer.cfg", kPrinter);
  write(
      dir / "hardware.cfg",
      "[extruder]\nnozzle_diameter: 0.4\nfilament_diameter: 1.75\nmax_extrude_only_velocity: 120\n"
      "min_extrude_temp: 180\n");
  write(dir / "macros" / "a.cfg", "[gcode_macro A]\ngcode:\n  M117 a\n");
  write(dir / "macros" / "b.cfg", "[gcode_macro B]\ngcode:\n  M117 b\n");
  auto secs = read_klipper_config(dir / "printer.cfg");
  ASSERT_TRUE(secs) << secs.error().describe();
  bool a = false, b = false;
  for (const auto& s : *secs) {
    a = a || s.name == "gcode_macro A";
    b = b || s.name == "gcode_macro B";
    if (s.name == "gcode_macro PRINT_START") {
      EXPECT_NE(s.find("gcode")->value.find("G1 Z10 F600"), std::string::npos);
    }
  }
  EXPECT_TRUE(a && b);

  auto p = load_printer_profile((dir / "printer.cfg").string());
  ASSERT_TRUE(p) << p.error().describe();
  EXPECT_EQ(p->firmware, "klipper");
  EXPECT_EQ(p->max_feedrate_mm_s[0], 300);
  EXPECT_EQ(p->max_feedrate_mm_s[2], 15);
  EXPECT_EQ(p->max_accel_mm_s2[1], 3000);
  EXPECT_EQ(p->max_accel_mm_s2[2], 350);
  EXPECT_DOUBLE_EQ(p->minimum_cruise_ratio, 0.5);  // 1 - max_accel_to_decel / max_accel
  EXPECT_EQ(p->square_corner_velocity_mm_s, 5.0);
  EXPECT_EQ(p->bed_max_x_mm, 300);
  EXPECT_EQ(p->travel_min_z_mm, -5);
  EXPECT_EQ(p->max_z_mm, 260);
  EXPECT_EQ(p->homing_feedrate_mm_s[0], 25);
  EXPECT_EQ(p->nozzle_diameter_mm, 0.6);  // SAVE_CONFIG wins over the included file
  EXPECT_EQ(p->max_extrude_only_velocity_mm_s, 120);
  EXPECT_EQ(p->min_extrude_temp_c, 180);
  EXPECT_TRUE(p->firmware_retraction);
  EXPECT_EQ(p->fw_retract_length_mm, 0.5);
  EXPECT_EQ(p->fw_recover_speed_mm_s, 10);  // Klipper's default unretract_speed
  const auto* o = p->origin.find("max_accel_mm_s2");
  ASSERT_NE(o, nullptr);
  EXPECT_EQ(o->source, "config");
  EXPECT_NE(o->detail.find("printer.cfg:8"), std::string::npos) << o->detail;
  EXPECT_EQ(p->origin.find("steps_per_mm")->source, "default");
}

TEST(KlipperConfig, BadInputNamesTheFileAndLine) {
  const auto dir = test::temp_dir("klipper_cfg_bad");
  auto error_of = [&](const std::string& text) {
    write(dir / "printer.cfg", text);
    auto p = load_printer_profile((dir / "printer.cfg").string());
    return p ? std::string("no error") : p.error().describe();
  };
  const std::string steppers =
      "[stepper_x]\nposition_max: 200\n[stepper_y]\nposition_max: 200\n[stepper_z]\nposition_max: "
      "200\n";
  EXPECT_NE(
      error_of("[printer]\nkinematics: corexy\nmax_velocity: fast\nmax_accel: 1000\n" + steppers)
          .find("printer.cfg:3: [printer] max_velocity: expected a number, got \"fast\""),
      std::string::npos);
  EXPECT_NE(
      error_of("[printer]\nkinematics: corexy\nmax_velocity: 0x10\nmax_accel: 1000\n" + steppers)
          .find("printer.cfg:3"),
      std::string::npos);
  EXPECT_NE(error_of("max_velocity: 300\n")
                .find("printer.cfg:1: option \"max_velocity\" outside any [section]"),
            std::string::npos);
  EXPECT_NE(error_of("[include missing.cfg]\n")
                .find("printer.cfg:1: [include missing.cfg]: no such file"),
            std::string::npos);
  EXPECT_NE(error_of("[printer]\nkinematics: delta\nmax_velocity: 300\nmax_accel: 1000\n")
                .find("delta is not simulated"),
            std::string::npos);
  EXPECT_NE(error_of("[printer]\nkinematics: corexy\nmax_accel: 1000\n" + steppers)
                .find("no max_velocity"),
            std::string::npos);
  EXPECT_NE(
      error_of("[printer]\nkinematics: corexy\nmax_velocity: 300\nmax_accel: 1000\n[stepper_x]\n")
          .find("[stepper_x] has no position_max"),
      std::string::npos);
  EXPECT_NE(error_of("[printer\n").find("printer.cfg:1: expected \"[section]\""),
            std::string::npos);
  EXPECT_NE(error_of("[printer]\njust words\n").find("printer.cfg:2: expected \"key: value\""),
            std::string::npos);
  // Each option in range, but the Z range makes a 0.27 mm tall printer (found by
  // klipper_cfg_fuzz): refused with the option's line, as a .json profile would be.
  EXPECT_NE(error_of("[printer]\nkinematics: corexy\nmax_velocity: 300\nmax_accel: "
                     "1000\n[stepper_x]\nposition_max: "
                     "200\n[stepper_y]\nposition_max: 200\n[stepper_z]\nposition_max: .27\n")
                .find("printer.cfg:10: the printer this config describes is not simulated: key "
                      "\"max_z_mm\": value 0.27 "
                      "outside [1, 2000]"),
            std::string::npos);
  write(dir / "loop.cfg", "[include printer.cfg]\n");
  EXPECT_NE(error_of("[include loop.cfg]\n").find("recursive [include]"), std::string::npos);
  // A glob that matches nothing is fine (as in Klipper); the config still needs [printer].
  EXPECT_NE(error_of("[include none/*.cfg]\n").find("no [printer] section"), std::string::npos);
}

TEST(KlipperConfig, TheRepositorysEnder3ConfigNumbers) {
  // The numbers of Klipper's config/printer-creality-ender3-2018.cfg, written here.
  const auto dir = test::temp_dir("klipper_cfg_ender3");
  write(dir / "printer.cfg",
        "[stepper_x]\nposition_endstop: 0\nposition_max: 235\nhoming_speed: 50\n"
        "[stepper_y]\nposition_endstop: 0\nposition_max: 235\nhoming_speed: 50\n"
        "[stepper_z]\nposition_endstop: 0.0\nposition_max: 250\n"
        "[extruder]\nnozzle_diameter: 0.400\nfilament_diameter: 1.750\n"
        "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\nmax_z_velocity: "
        "5\nmax_z_accel: 100\n");
  auto p = load_printer_profile((dir / "printer.cfg").string());
  ASSERT_TRUE(p) << p.error().describe();
  EXPECT_EQ(p->bed_max_x_mm, 235);
  EXPECT_EQ(p->max_feedrate_mm_s[2], 5);
  EXPECT_EQ(p->square_corner_velocity_mm_s, 5.0);  // Klipper's default
  EXPECT_EQ(p->origin.find("square_corner_velocity_mm_s")->source, "default");
}

TEST(KlipperConfig, SimulateWithAPrinterCfg) {
  const auto dir = test::temp_dir("klipper_cfg_cli");
  write(dir / "printer.cfg",
        "[printer]\nkinematics: corexy\nmax_velocity: 250\nmax_accel: 4000\n"
        "[stepper_x]\nposition_max: 120\n[stepper_y]\nposition_max: "
        "120\n[stepper_z]\nposition_max: 120\n");
  write(dir / "part.gcode", "G28\nG1 X100 Y100 Z1 F6000\nG1 X130 Y10\n");
  const auto run = test::run_cli("simulate --printer " + (dir / "printer.cfg").string() + " " +
                                 (dir / "part.gcode").string());
  EXPECT_NE(run.out.find("printer       Klipper corexy printer (printer.cfg)"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("out_of_bounds"), std::string::npos)
      << run.out;  // X 130 on a 120 mm printer
  write(dir / "bad.cfg", "[printer]\nkinematics: corexy\nmax_velocity: -\n");
  const auto bad = test::run_cli("simulate --printer " + (dir / "bad.cfg").string() + " " +
                                 (dir / "part.gcode").string());
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("bad.cfg:3: [printer] max_velocity: expected a number"), std::string::npos)
      << bad.err;
}

}  // namespace
}  // namespace printtwin
