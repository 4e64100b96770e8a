// Sliced 3MF files (".gcode.3mf", Bambu Studio / OrcaSlicer): the plate's G-code is read as
// if it were the file given, by simulate, verify and the printer detection.
#include <gtest/gtest.h>

#include <string>

#include "printtwin/gcode_3mf.hpp"
#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/simulate.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

/// A sliced 3MF as Bambu Studio writes one: the project's files around the plate's G-code.
std::string sliced_3mf(const std::vector<std::pair<std::string, std::string>>& plates) {
  std::vector<std::pair<std::string, std::string>> entries = {
      {"[Content_Types].xml", "<?xml version=\"1.0\"?><Types/>"},
      {"3D/3dmodel.model", "<?xml version=\"1.0\"?><model unit=\"millimeter\"/>"},
      {"Metadata/project_settings.config", "{}"}};
  for (const auto& [n, text] : plates) {
    entries.emplace_back("Metadata/plate_" + n + ".gcode", text);
    entries.emplace_back("Metadata/plate_" + n + ".gcode.md5", "0123456789abcdef");
  }
  return test::make_zip(entries, true);
}

TEST(Gcode3mf, ThePlatesGcodeIsSimulatedAsTheTextItself) {
  const auto dir = test::temp_dir("gcode_3mf");
  const auto text_path = test::source_path("samples/gcode/prusa_cube10.gcode");
  auto text = read_file(text_path);
  ASSERT_TRUE(text.ok());
  ASSERT_TRUE(write_file_atomic(dir / "cube.gcode.3mf", sliced_3mf({{"1", *text}})).ok());
  // Detected by its bytes, not its name.
  ASSERT_TRUE(write_file_atomic(dir / "cube.bin", sliced_3mf({{"1", *text}})).ok());
  EXPECT_TRUE(is_gcode_3mf_file(dir / "cube.bin"));
  EXPECT_FALSE(is_gcode_3mf_file(text_path));
  const PrinterProfile printer = ender3_marlin2();
  auto a = simulate_gcode_file(text_path, printer, {});
  auto b = simulate_gcode_file(dir / "cube.bin", printer, {});
  ASSERT_TRUE(a.ok()) << a.error().describe();
  ASSERT_TRUE(b.ok()) << b.error().describe();
  EXPECT_EQ(a->moves, b->moves);
  EXPECT_EQ(a->layers.size(), b->layers.size());
  EXPECT_DOUBLE_EQ(a->print_time_s, b->print_time_s);
  EXPECT_DOUBLE_EQ(a->filament_mm, b->filament_mm);
  // The printer detection reads the plate's settings (PrusaSlicer names its printer there).
  auto sa = read_slicer_settings(text_path);
  auto sb = read_slicer_settings(dir / "cube.gcode.3mf");
  ASSERT_TRUE(sa.ok() && sb.ok());
  EXPECT_EQ(sa->slicer, sb->slicer);
  EXPECT_EQ(sa->entries.size(), sb->entries.size());
  EXPECT_FALSE(sb->empty());
  // verify reads it too: the same report as from the text.
  test::expect_same_cube10_verify(text_path, dir / "cube.gcode.3mf", dir);
}

TEST(Gcode3mf, ProjectsWithoutGcodeAndSeveralPlatesAreClearErrors) {
  const auto dir = test::temp_dir("gcode_3mf_bad");
  const std::string g = "G28\nG1 X10 Y10 F3000\n";
  auto none = gcode_of_3mf(sliced_3mf({}), "project.3mf");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().describe().find("no sliced G-code"), std::string::npos)
      << none.error().describe();
  auto two = gcode_of_3mf(sliced_3mf({{"2", g}, {"1", g}, {"10", g}}), "plates.gcode.3mf");
  ASSERT_FALSE(two.ok());
  EXPECT_NE(two.error().describe().find("3 plates (1, 2, 10)"), std::string::npos)
      << two.error().describe();
  EXPECT_NE(two.error().describe().find("Metadata/plate_1.gcode"), std::string::npos);
  // A damaged archive names the file; the command line exits 3 on each.
  std::string cut = sliced_3mf({{"1", g}});
  cut.resize(cut.size() / 2);
  ASSERT_TRUE(write_file_atomic(dir / "cut.gcode.3mf", cut).ok());
  ASSERT_TRUE(write_file_atomic(dir / "two.gcode.3mf", sliced_3mf({{"1", g}, {"2", g}})).ok());
  for (const char* name : {"cut.gcode.3mf", "two.gcode.3mf"}) {
    const auto run = test::run_cli("simulate " + (dir / name).string() + " --printer ender3");
    EXPECT_EQ(run.exit_code, 3) << name << run.out << run.err;
    EXPECT_NE(run.err.find(name), std::string::npos) << run.err;
  }
}

}  // namespace
}  // namespace printtwin
