// `printtwin verify -q` is the short form of --quiet, as for `simulate -q`.
#include <gtest/gtest.h>

#include <filesystem>

#include "printtwin/mesh.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

TEST(VerifyCliQuiet, ShortFlagSilencesTheSummaryLikeQuiet) {
  const auto dir = test::temp_dir("verify_quiet");
  const auto stl = dir / "cube10.stl";
  ASSERT_TRUE(save_stl(test::make_cube_mm(10.0, Vec3(-5, -5, 0)), stl).ok());
  const std::string common = "verify " + stl.string() + " --gcode " +
                             test::source_path("samples/gcode/prusa_cube10.gcode").string() +
                             " --tolerance 0.3 --voxel 0.1 --out ";
  const auto loud = test::run_cli(common + (dir / "loud").string());
  ASSERT_EQ(loud.exit_code, 0) << loud.out << loud.err;
  EXPECT_NE(loud.out.find("printtwin verify cube10: PASS"), std::string::npos) << loud.out;

  const auto quiet = test::run_cli(common + (dir / "quiet").string() + " -q");
  ASSERT_EQ(quiet.exit_code, 0) << quiet.out << quiet.err;
  EXPECT_EQ(quiet.out, "");
  EXPECT_TRUE(std::filesystem::exists(dir / "quiet" / "report.json"));
}

}  // namespace
}  // namespace printtwin
