// compare end to end on a small wedge built in code (a 45-degree slope, where layer steps
// show): a layer-height sweep through printtwin's slicer and the twin, shares and their
// merge, a variant that cannot run, and the command line (manifest, shares, --merge).
#include <gtest/gtest.h>

#include <cmath>
#include <regex>

#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/verify.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

// A closed wedge, CCW seen from outside: 12 mm along x, 8 mm deep (y), a 45-degree slope
// rising from z = 0 at x = 0 to z = 10 at x = 10 (facing up and to -x), then a 2 mm flat
// top. The flat top keeps every layer at least 2 mm wide, so what differs between layer
// heights is the staircase on the slope, not how a slicer treats a knife-edge ridge.
Mesh make_wedge() {
  Mesh m;
  const double a = 12, d = 8, h = 10;
  m.vertices_mm = {Vec3(0, 0, 0), Vec3(a, 0, 0), Vec3(a, d, 0), Vec3(0, d, 0),
                   Vec3(a, 0, h), Vec3(a, d, h), Vec3(h, 0, h), Vec3(h, d, h)};
  m.triangles = {
      {0, 2, 1}, {0, 3, 2},  // bottom (normal -z)
      {1, 2, 5}, {1, 5, 4},  // vertical back face at x = a (normal +x)
      {0, 6, 7}, {0, 7, 3},  // the slope (normal (-1, 0, 1)/sqrt 2)
      {6, 4, 5}, {6, 5, 7},  // flat top (normal +z)
      {0, 1, 4}, {0, 4, 6},  // side y = 0 (normal -y)
      {3, 5, 2}, {3, 7, 5},  // side y = d (normal +y)
  };
  return m;
}

ComparePlan wedge_plan(const std::vector<std::string>& layer_heights) {
  ComparePlan plan;
  plan.printer = "ender3";
  plan.verify.voxel_mm = 0.1;
  plan.verify.gates.tolerance_mm = 0.3;
  SweepSpec spec;
  spec.common_settings = {{"skirts", "0"}};
  SweepAxis axis{"layer_height", layer_heights};
  spec.axes = {axis};
  plan.variants = expand_variants(spec).value();
  return plan;
}

std::string without_timing(std::string json) {
  json =
      std::regex_replace(json, std::regex(R"re("run_time_s": [0-9.e+-]+)re"), "\"run_time_s\": 0");
  json =
      std::regex_replace(json, std::regex(R"re("(shared_s|total_s)": [0-9.e+-]+)re"), "\"$1\": 0");
  return json;
}

class CompareRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto printer = load_printer_profile("ender3");
    ASSERT_TRUE(printer.ok());
    auto part = prepare_shared_part(make_wedge(), "wedge", *printer);
    ASSERT_TRUE(part.ok()) << part.error().describe();
    part_ = new SharedPart(std::move(*part));
    plan_ = new ComparePlan(wedge_plan({"0.1", "0.3"}));
    auto whole = run_compare(*part_, *plan_, {}, {});
    ASSERT_TRUE(whole.ok()) << whole.error().describe();
    whole_ = new CompareResult(std::move(*whole));
  }
  static void TearDownTestSuite() {
    delete whole_;
    delete plan_;
    delete part_;
  }
  static SharedPart* part_;
  static ComparePlan* plan_;
  static CompareResult* whole_;
};
SharedPart* CompareRun::part_ = nullptr;
ComparePlan* CompareRun::plan_ = nullptr;
CompareResult* CompareRun::whole_ = nullptr;

TEST_F(CompareRun, SharedPartKnowsTheSlope) {
  ASSERT_NE(part_, nullptr);
  // Only the two slope triangles are sloped: area 10 * sqrt(2) * 8.
  EXPECT_NEAR(part_->info.sloped_area_mm2, 10 * std::sqrt(2.0) * 8, 1e-9);
  EXPECT_NEAR(part_->info.volume_mm3, (12 * 10 - 0.5 * 10 * 10) * 8, 1e-9);
  EXPECT_EQ(std::count(part_->sloped.begin(), part_->sloped.end(), 1), 2);
  EXPECT_TRUE(part_->prepared.check.watertight);
}

TEST_F(CompareRun, FinerLayersTakeLongerAndFollowTheSlopeCloser) {
  ASSERT_NE(whole_, nullptr);
  ASSERT_EQ(whole_->variants.size(), 2u);
  const VariantResult& fine = whole_->variants[0];
  const VariantResult& coarse = whole_->variants[1];
  ASSERT_TRUE(fine.ran) << fine.error;
  ASSERT_TRUE(coarse.ran) << coarse.error;
  EXPECT_DOUBLE_EQ(fine.layer_height_mm, 0.1);
  EXPECT_DOUBLE_EQ(coarse.layer_height_mm, 0.3);
  // 10 mm at 0.1 (0.2 first layer) and 0.3 mm: about 99 and 34 layers.
  EXPECT_NEAR(fine.layers, 99, 2);
  EXPECT_NEAR(coarse.layers, 34, 2);
  // Three times the layers: clearly longer, not three times (travel, heating are fixed).
  EXPECT_GT(fine.print_time_s, 1.5 * coarse.print_time_s);
  // The same part: the same material within 15 %.
  EXPECT_NEAR(fine.filament_g / coarse.filament_g, 1.0, 0.15);
  EXPECT_GT(fine.filament_g, 0.3);  // 560 mm3 solid; 20 % infill and shells: > 0.3 g
  // The staircase on the slope: finer layers follow it closer, in both directions.
  EXPECT_GT(fine.mesh_to_deposit.slope_samples, 1000u);
  EXPECT_GT(fine.deposit_to_mesh.slope_samples, 1000u);
  EXPECT_LT(fine.slope_rms_mm, coarse.slope_rms_mm);
  EXPECT_LT(fine.mesh_to_deposit.slope_rms_mm, coarse.mesh_to_deposit.slope_rms_mm);
  EXPECT_LT(fine.deposit_to_mesh.slope_rms_mm, coarse.deposit_to_mesh.slope_rms_mm);
  // Both are faster-or-better than the other: both on the front.
  EXPECT_TRUE(fine.pareto);
  EXPECT_TRUE(coarse.pareto);
  // verify's gates were evaluated.
  std::vector<std::string> gates;
  for (const auto& g : fine.gates) gates.push_back(g.name);
  EXPECT_EQ(gates, (std::vector<std::string>{"no_error_findings", "max_excess", "max_deficit"}));
}

TEST_F(CompareRun, SharesMergeIntoTheWholeRun) {
  ASSERT_NE(whole_, nullptr);
  std::vector<CompareResult> shares;
  for (int k = 0; k < 2; ++k) {
    const std::vector<int> idx = shard_indices(2, k, 2).value();
    auto share = run_compare(*part_, *plan_, idx, {});
    ASSERT_TRUE(share.ok()) << share.error().describe();
    share->shard = std::make_pair(k, 2);
    ASSERT_EQ(share->variants.size(), 1u);
    auto back = parse_compare_json(compare_json(*share), "share");
    ASSERT_TRUE(back.ok()) << back.error().describe();
    shares.push_back(std::move(*back));
  }
  auto merged = merge_compare_results(shares);
  ASSERT_TRUE(merged.ok()) << merged.error().describe();
  // Deterministic variants: the merged table is the whole run's, byte for byte (timings aside).
  EXPECT_EQ(without_timing(compare_json(*merged)), without_timing(compare_json(*whole_)));
}

TEST_F(CompareRun, AVariantIsWhatVerifyMeasuresWithTheSameSettings) {
  ASSERT_NE(whole_, nullptr);
  const auto dir = test::temp_dir("compare_vs_verify");
  const auto stl = dir / "wedge.stl";
  ASSERT_TRUE(save_stl(make_wedge(), stl).ok());
  VerifyOptions options;
  options.mesh_path = stl;
  options.settings = plan_->verify;
  options.settings.slice_overrides = {{"skirts", "0"}, {"layer_height", "0.3"}};
  auto report = verify(options);
  ASSERT_TRUE(report.ok()) << report.error().describe();
  const VariantResult& coarse = whole_->variants[1];
  ASSERT_TRUE(coarse.ran) << coarse.error;
  // The shared part and the standalone run measure the same thing, to the last bit.
  EXPECT_EQ(coarse.print_time_s, report->simulation.print_time_s);
  EXPECT_EQ(coarse.layers, report->simulation.layers);
  EXPECT_EQ(coarse.deposit_to_mesh.samples, report->deviation.deposit_to_mesh.samples);
  EXPECT_EQ(coarse.deposit_to_mesh.rms_mm, report->deviation.deposit_to_mesh.rms_mm);
  EXPECT_EQ(coarse.mesh_to_deposit.samples, report->deviation.mesh_to_deposit.samples);
  EXPECT_EQ(coarse.mesh_to_deposit.rms_mm, report->deviation.mesh_to_deposit.rms_mm);
  EXPECT_EQ(coarse.pass, report->pass);
  EXPECT_GT(coarse.deposit_to_mesh.samples, 1000u);
}

TEST_F(CompareRun, AVariantThatCannotRunIsARowNotAFailure) {
  const auto dir = test::temp_dir("compare_bad_variant");
  const auto bad = dir / "bad.gcode";
  // Moves but no extrusion: nothing to register the mesh against.
  ASSERT_TRUE(write_file_atomic(bad, "G28\nG1 X10 Y10 Z0.2 F3000\nG1 X20 Y20\n").ok());
  ComparePlan plan = *plan_;
  SweepSpec spec;
  spec.gcodes = {bad.string()};
  plan.variants = expand_variants(spec).value();
  auto r = run_compare(*part_, plan, {}, {});
  ASSERT_TRUE(r.ok()) << r.error().describe();
  ASSERT_EQ(r->variants.size(), 1u);
  EXPECT_FALSE(r->variants[0].ran);
  EXPECT_NE(r->variants[0].error.find("bad.gcode: the G-code has no extrusion"), std::string::npos)
      << r->variants[0].error;
  EXPECT_FALSE(r->variants[0].pareto);
}

TEST(CompareValidate, BadSettingIsAUsageErrorNamingTheVariant) {
  ComparePlan plan = wedge_plan({"0.2", "0.9"});  // 0.9 mm is above 80 % of a 0.4 mm nozzle
  auto st = validate_plan(plan);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::usage);
  EXPECT_NE(st.error().message.find("variant 1 (layer_height=0.9)"), std::string::npos)
      << st.error().message;
  SweepSpec spec;
  spec.axes = {SweepAxis{"no_such_setting", {"1"}}};
  plan.variants = expand_variants(spec).value();
  EXPECT_FALSE(validate_plan(plan).ok());
}

TEST(CompareCli, ManifestSharesAndMerge) {
  const auto dir = test::temp_dir("compare_cli");
  const auto stl = dir / "wedge.stl";
  ASSERT_TRUE(save_stl(make_wedge(), stl).ok());
  const std::string common = " --voxel 0.2 --tolerance 0.4 --variant-reports none";
  auto plan =
      test::run_cli("compare " + stl.string() + " --vary layer_height=0.2,0.3 --set skirts=0" +
                    common + " --write-manifest " + (dir / "plan.json").string());
  ASSERT_EQ(plan.exit_code, 0) << plan.err;
  EXPECT_NE(plan.out.find("2 variants"), std::string::npos) << plan.out;
  for (int k = 0; k < 2; ++k) {
    auto share = test::run_cli("compare --manifest " + (dir / "plan.json").string() +
                               " --variant " + std::to_string(k) +
                               " --of 2 --variant-reports none -o " + (dir / "shares").string());
    ASSERT_EQ(share.exit_code, 0) << share.err << share.out;
    EXPECT_TRUE(std::filesystem::exists(dir / "shares" / shard_file_name(k, 2)));
  }
  auto merged = test::run_cli(
      "compare --merge " + (dir / "shares" / "compare-0-of-2.json").string() + " " +
      (dir / "shares" / "compare-1-of-2.json").string() + " -o " + (dir / "merged").string());
  ASSERT_EQ(merged.exit_code, 0) << merged.err;
  auto text = read_file(dir / "merged" / "compare.json");
  ASSERT_TRUE(text.ok());
  auto result = parse_compare_json(*text, "compare.json");
  ASSERT_TRUE(result.ok()) << result.error().describe();
  ASSERT_EQ(result->variants.size(), 2u);
  EXPECT_EQ(result->variants[0].variant.label, "layer_height=0.2");
  EXPECT_TRUE(result->variants[0].ran);
  EXPECT_GT(result->variants[0].print_time_s, result->variants[1].print_time_s);
  EXPECT_TRUE(std::filesystem::exists(dir / "merged" / "compare.html"));
  EXPECT_TRUE(std::filesystem::exists(dir / "merged" / "compare.md"));

  // Merging only one share is refused, naming what is missing.
  auto partial =
      test::run_cli("compare --merge " + (dir / "shares" / "compare-0-of-2.json").string() +
                    " -o " + (dir / "partial").string());
  EXPECT_EQ(partial.exit_code, 3);
  EXPECT_NE(partial.err.find("missing (indices 1)"), std::string::npos) << partial.err;

  // Usage errors.
  EXPECT_EQ(test::run_cli("compare " + stl.string() + " --vary layer_height=").exit_code, 2);
  EXPECT_EQ(test::run_cli("compare " + stl.string() + " --vary layer_height=0.2 --variant 2 --of 2")
                .exit_code,
            2);
}

}  // namespace
}  // namespace printtwin
