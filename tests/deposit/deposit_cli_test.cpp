// `printtwin simulate --deposit ...` end to end on PrusaSlicer's G-code of a 10 mm cube.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

TEST(DepositCli, SimulateWritesOctomapPlyAndJson) {
  const auto dir = test::temp_dir("deposit_cli");
  const auto gcode = test::source_path("samples/gcode/prusa_cube10.gcode");
  const auto run =
      test::run_cli("simulate '" + gcode.string() + "' --voxel 0.1 --deposit '" +
                    (dir / "cube.bt").string() + "' --deposit-ply '" + (dir / "cube.ply").string() +
                    "' --json '" + (dir / "cube.json").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("deposit: "), std::string::npos) << run.out;
  auto text = read_file(dir / "cube.json");
  ASSERT_TRUE(text.ok());
  const auto j = nlohmann::json::parse(*text);
  ASSERT_TRUE(j.contains("deposit"));
  const auto& d = j["deposit"];
  EXPECT_DOUBLE_EQ(d["voxel_mm"].get<double>(), 0.1);
  const double volume = d["volume_mm3"].get<double>();
  const double extruded = d["extruded_mm3"].get<double>();
  const double overlap = d["overlap_mm3"].get<double>();
  const double squeezed = d["squeezed_mm3"].get<double>();
  // Deposited plus overlapping material not squeezed elsewhere accounts for what was extruded.
  EXPECT_NEAR((volume + overlap - squeezed) / extruded, 1.0, 0.02);
  // The cube (10 mm, centred at 110,110 by the slicer) is inside the deposit's box.
  EXPECT_NEAR(d["bbox_mm"]["max"][2].get<double>(), 10.0, 0.11);
  EXPECT_LE(d["bbox_mm"]["min"][0].get<double>(), 105.0);
  EXPECT_GE(d["bbox_mm"]["max"][0].get<double>(), 115.0);
  auto voxels = count_octomap_voxels(dir / "cube.bt");
  ASSERT_TRUE(voxels.ok()) << voxels.error().describe();
  EXPECT_EQ(*voxels, d["voxels"].get<std::size_t>());
  auto ply = read_file(dir / "cube.ply");
  ASSERT_TRUE(ply.ok());
  EXPECT_EQ(ply->rfind("ply\n", 0), 0u);
}

TEST(DepositCli, MemoryBudgetStopsWithASuggestedVoxelSize) {
  const auto dir = test::temp_dir("deposit_cli_budget");
  const auto gcode = test::source_path("samples/gcode/prusa_cube10.gcode");
  const auto run = test::run_cli("simulate '" + gcode.string() + "' --deposit '" +
                                 (dir / "cube.ot").string() + "' --max-memory 4M");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--voxel"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("MiB"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "cube.ot"));
  const auto bad =
      test::run_cli("simulate '" + gcode.string() + "' --deposit-summary --max-memory lots");
  EXPECT_EQ(bad.exit_code, 2);
}

TEST(DepositCli, ConserveVolumePlacesTheVaseOverlap) {
  // The spiral vase's overlap is squeezed beside the bead by default (--conserve-volume, still
  // accepted, says the same) and lost with --no-conserve-volume. What the outer wall's seam and
  // the floor's top layer find no room for (they keep the outside's grooves and the top) stays
  // under 0.5 % of the volume.
  const auto gcode = test::source_path("samples/gcode/prusa_vase10.gcode");
  const auto off =
      test::run_cli("simulate '" + gcode.string() + "' --deposit-summary --no-conserve-volume");
  const auto on = test::run_cli("simulate '" + gcode.string() + "' --deposit-summary");
  const auto flag =
      test::run_cli("simulate '" + gcode.string() + "' --deposit-summary --conserve-volume");
  ASSERT_EQ(off.exit_code, 0) << off.err;
  ASSERT_EQ(on.exit_code, 0) << on.err;
  ASSERT_EQ(flag.exit_code, 0) << flag.err;
  EXPECT_EQ(flag.out, on.out);
  // "deposit: N voxels of 0.05 mm, V mm3 (P % of E mm3 extruded)".
  auto percent = [](const std::string& out) {
    const auto at = out.find(" % of ");
    if (at == std::string::npos) return 0.0;
    const auto open = out.rfind('(', at);
    return std::stod(out.substr(open + 1, at - open - 1));
  };
  EXPECT_LT(percent(off.out), 95.0) << off.out;
  EXPECT_GE(percent(on.out), 99.5) << on.out;
  EXPECT_NE(on.out.find("squeezed into free space nearby"), std::string::npos) << on.out;
  EXPECT_NE(off.out.find("lost; --conserve-volume places it"), std::string::npos) << off.out;
}

}  // namespace
}  // namespace printtwin
