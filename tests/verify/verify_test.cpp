#include <atomic>
#include <cmath>
// `printtwin verify` end to end on the committed samples, plus the library's verify().
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/report.hpp"
#include "printtwin/verify.hpp"
#include "support/test_support.hpp"
#include "verify/pipeline.hpp"

namespace printtwin {
namespace {

using test::read_json;

/// The 10 mm cube PrusaSlicer sliced for samples/gcode/prusa_cube10.gcode (the 20 mm
/// calibration cube at scale 0.5), written where the test can pass it to the CLI.
std::filesystem::path cube10_stl(const std::filesystem::path& dir) {
  const auto path = dir / "cube10.stl";
  EXPECT_TRUE(save_stl(test::make_cube_mm(10.0, Vec3(-5, -5, 0)), path).ok());
  return path;
}

/// verify() of the 10 mm cube against PrusaSlicer's G-code, at 0.1 mm voxels.
VerifyOptions cube10_options(const std::filesystem::path& dir) {
  VerifyOptions options;
  options.mesh_path = cube10_stl(dir);
  options.gcode_path = test::source_path("samples/gcode/prusa_cube10.gcode");
  options.settings.voxel_mm = 0.1;
  return options;
}

TEST(VerifyCli, PrusaSlicerCubePassesAtPointThreeWithAFullReport) {
  const auto dir = test::temp_dir("verify_cube");
  const auto stl = cube10_stl(dir);
  const auto out = dir / "report";
  const auto run = test::run_cli("verify " + stl.string() + " --gcode " +
                                 test::source_path("samples/gcode/prusa_cube10.gcode").string() +
                                 " --tolerance 0.3 --out " + out.string());
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("PASS"), std::string::npos);
  const auto j = read_json(out / "report.json");
  EXPECT_EQ(j["schema"], "printtwin.verify/2");
  EXPECT_EQ(j["pass"], true);
  EXPECT_DOUBLE_EQ(j["tolerance_mm"].get<double>(), 0.3);
  // PrusaSlicer centred the part on (110, 110): the cube's min corner (-5, -5) lands on 105.
  const auto offset = j["deviation"]["registration"]["offset_mm"];
  EXPECT_NEAR(offset[0].get<double>(), 110.0, 0.01);
  EXPECT_NEAR(offset[1].get<double>(), 110.0, 0.01);
  EXPECT_NEAR(offset[2].get<double>(), 0.0, 1e-9);
  for (const char* dir_name : {"deposit_to_mesh", "mesh_to_deposit"}) {
    const auto& s = j["deviation"][dir_name];
    for (const char* key :
         {"min_mm", "max_mm", "mean_mm", "rms_mm", "std_mm", "p95_mm", "within_tolerance_pct"})
      ASSERT_TRUE(s.contains(key)) << dir_name << "." << key;
    EXPECT_GT(s["samples"].get<double>(), 50000);
    EXPECT_LT(std::abs(s["mean_mm"].get<double>()), 0.05) << dir_name;
    EXPECT_LT(s["rms_mm"].get<double>(), 0.1) << dir_name;
    EXPECT_GE(s["within_tolerance_pct"].get<double>(), 99.5) << dir_name;
  }
  // The mesh is 1000 mm^3; the deposit holds 20 % infill, so less material but the same shell.
  EXPECT_NEAR(j["deviation"]["mesh_volume_mm3"].get<double>(), 1000.0, 1e-6);
  EXPECT_TRUE(j["regions"].is_array());
  EXPECT_TRUE(j["findings"].is_array());
  EXPECT_GT(j["simulate"]["layers"].get<int>(), 45);
  EXPECT_EQ(j["check"]["triangles"].get<int>(), 12);
  ASSERT_EQ(j["inputs"].size(), 3U);
  EXPECT_EQ(j["inputs"][0]["sha256"].get<std::string>().size(), 64U);
  EXPECT_TRUE(std::filesystem::exists(out / "deviation.ply"));
  EXPECT_TRUE(std::filesystem::exists(out / "report.html"));
  EXPECT_TRUE(std::filesystem::exists(out / "junit.xml"));
}

TEST(VerifyCli, TightGateFailsWithExitOne) {
  const auto dir = test::temp_dir("verify_cube_tight");
  const auto stl = cube10_stl(dir);
  const auto out = dir / "report";
  const auto run =
      test::run_cli("verify " + stl.string() + " --gcode " +
                    test::source_path("samples/gcode/prusa_cube10.gcode").string() +
                    " --tolerance 0.3 --max-deficit 0.01 --quiet --out " + out.string());
  ASSERT_EQ(run.exit_code, 1) << run.out << run.err;
  const auto j = read_json(out / "report.json");
  EXPECT_EQ(j["pass"], false);
  bool deficit_gate_failed = false;
  for (const auto& g : j["gates"])
    if (g["name"] == "max_deficit")
      deficit_gate_failed = !g["pass"].get<bool>() && g["limit"].get<double>() == 0.01;
  EXPECT_TRUE(deficit_gate_failed);
}

TEST(VerifyCli, MisplacedMeshFailsWithMissingAndExcessRegions) {
  // --place shifts the mesh 2 mm off the print: the report shows both kinds of region.
  const auto dir = test::temp_dir("verify_cube_misplaced");
  const auto stl = cube10_stl(dir);
  const auto out = dir / "report";
  const auto run = test::run_cli("verify " + stl.string() + " --gcode " +
                                 test::source_path("samples/gcode/prusa_cube10.gcode").string() +
                                 " --place 112,110,0 --voxel 0.1 --quiet --out " + out.string());
  ASSERT_EQ(run.exit_code, 1) << run.out << run.err;
  const auto j = read_json(out / "report.json");
  EXPECT_EQ(j["deviation"]["registration"]["method"], "--place");
  bool missing = false, excess = false;
  for (const auto& r : j["regions"]) {
    const double x_min = r["bbox_mm"]["min"][0].get<double>(),
                 x_max = r["bbox_mm"]["max"][0].get<double>();
    // Mesh now spans x 107..117, the print 105..115: the design sticks out at +x (missing),
    // the print at -x (excess).
    if (r["kind"] == "missing" && x_min > 114.5) missing = true;
    if (r["kind"] == "excess" && x_max < 107.5) excess = true;
    EXPECT_FALSE(r["gcode_lines"].empty());
  }
  EXPECT_TRUE(missing);
  EXPECT_TRUE(excess);
  EXPECT_NEAR(j["deviation"]["max_deficit_mm"].get<double>(), 2.0, 0.15);
}

TEST(VerifyCli, ThinWallsDroppedByTheSlicerAreMissingRegionsAtTheirPlace) {
  // No --gcode: printtwin slices the part with a thin-wall limit of one 0.45 mm line, so the
  // slicer drops the 0.2 and 0.4 mm walls; both must come back as missing regions exactly
  // where the walls stand. The regions are mesh samples with no deposit within tolerance, so
  // 0.2 mm voxels place them as 0.1 mm do (areas within 0.5 %) at a quarter of the cost: a
  // 10 mm wall with no deposit is the deviation stage's slow case (minutes under ASan).
  const auto dir = test::temp_dir("verify_thin_walls");
  const auto out = dir / "report";
  const auto run = test::run_cli(
      "verify " + test::source_path("samples/models/thin_walls.stl").string() +
      " --set thin_wall_min_width=0.45 --tolerance 0.3 --voxel 0.2 --quiet --out " + out.string());
  ASSERT_EQ(run.exit_code, 1) << run.out << run.err;
  const auto j = read_json(out / "report.json");
  EXPECT_EQ(j["settings"]["gcode_source"], "printtwin slice");
  EXPECT_EQ(j["settings"]["slice_overrides"]["thin_wall_min_width"], "0.45");
  // Placed like the slicer places it: the 30 x 24 mm footprint centred on the bed.
  const auto offset = j["deviation"]["registration"]["offset_mm"];
  const double ox = offset[0].get<double>(), oy = offset[1].get<double>();
  // The walls: x 0..30, z 1..11, y 4..4.2 (0.2 mm) and 9..9.4 (0.4 mm) in the model's frame.
  const double wall_y[2][2] = {{4.0, 4.2}, {9.0, 9.4}};
  for (const auto& wall : wall_y) {
    bool found = false;
    for (const auto& r : j["regions"]) {
      if (r["kind"] != "missing") continue;
      const auto& b = r["bbox_mm"];
      if (std::abs(b["min"][1].get<double>() - (oy + wall[0])) > 0.05) continue;
      if (std::abs(b["max"][1].get<double>() - (oy + wall[1])) > 0.05) continue;
      found = true;
      EXPECT_NEAR(b["min"][0].get<double>(), ox + 0.0, 0.5);
      EXPECT_NEAR(b["max"][0].get<double>(), ox + 30.0, 0.5);
      EXPECT_NEAR(b["max"][2].get<double>(), 11.0, 0.05);
      // Its two 30 x 10 mm faces and the top strip, less the foot within tolerance.
      EXPECT_GT(r["area_mm2"].get<double>(), 550.0);
      EXPECT_LT(r["area_mm2"].get<double>(), 630.0);
      EXPECT_LT(r["worst_mm"].get<double>(), -4.0);
      EXPECT_FALSE(r["gcode_lines"].empty());
    }
    EXPECT_TRUE(found) << "no missing region at the wall y " << wall[0] << ".." << wall[1];
  }
  int dropped = 0;
  bool finding = false;
  for (const auto& f : j["findings"]) {
    finding = finding || f["code"] == "deviation_missing";
    dropped += f["code"] == "thin_wall_dropped";
  }
  EXPECT_TRUE(finding);
  EXPECT_EQ(dropped, 2);
}

TEST(VerifyCli, SlicerSettingsNeedNoGcode) {
  const auto dir = test::temp_dir("verify_set_with_gcode");
  const auto run = test::run_cli(
      "verify " + test::source_path("samples/models/thin_walls.stl").string() + " --gcode " +
      test::source_path("samples/gcode/prusa_thin_walls.gcode").string() +
      " --set layer_height=0.1 --quiet --out " + (dir / "r").string());
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_NE(run.err.find("--set"), std::string::npos) << run.err;
}

TEST(VerifyCli, UsageAndBadInputExitCodes) {
  const auto dir = test::temp_dir("verify_errors");
  const auto stl = cube10_stl(dir);
  const auto gcode = test::source_path("samples/gcode/prusa_cube10.gcode").string();
  EXPECT_EQ(
      test::run_cli("verify " + stl.string() + " --gcode " + gcode + " --place 1,2").exit_code, 2);
  EXPECT_EQ(
      test::run_cli("verify " + stl.string() + " --gcode " + gcode + " --tolerance 0").exit_code,
      2);
  EXPECT_EQ(test::run_cli("verify " + stl.string() + " --gcode " + gcode + " --voxel 5").exit_code,
            2);
  EXPECT_EQ(test::run_cli("verify " + stl.string() + " --bogus-flag").exit_code, 2);
  const auto missing = test::run_cli("verify " + (dir / "nope.stl").string() + " --gcode " + gcode);
  EXPECT_EQ(missing.exit_code, 3);
  EXPECT_NE(missing.err.find("nope.stl"), std::string::npos);
  EXPECT_EQ(test::run_cli("verify " + stl.string() + " --gcode " + (dir / "nope.gcode").string())
                .exit_code,
            3);
}

TEST(VerifyLibrary, ReportJsonIsDeterministicApartFromTimings) {
  const auto dir = test::temp_dir("verify_lib");
  VerifyOptions options = cube10_options(dir);
  options.settings.gates.tolerance_mm = 0.3;
  auto a = verify(options);
  auto b = verify(options);
  ASSERT_TRUE(a.ok()) << a.error().describe();
  ASSERT_TRUE(b.ok());
  EXPECT_GT(a->elapsed_s, 0.0);
  a->timings.clear();
  b->timings.clear();
  a->elapsed_s = b->elapsed_s = 0;
  EXPECT_EQ(verify_report_json(*a), verify_report_json(*b));
  EXPECT_EQ(a->placed_mesh.vertices_mm.size(), a->deviation.vertex_deviation_mm.size());
  EXPECT_TRUE(a->pass);
  // Gates: no error finding, excess and deficit within the tolerance.
  ASSERT_GE(a->gates.size(), 3U);
  EXPECT_EQ(a->gates[0].name, "no_error_findings");
}

TEST(VerifyLibrary, SideBySideHalvesGiveTheReportOfTheSequentialPipeline) {
  // verify() runs the part's side and the G-code's side concurrently; the same steps run
  // one after the other (prepare_part, print_gcode, measure_printed) give the same report.
  const auto dir = test::temp_dir("verify_halves");
  VerifyOptions options = cube10_options(dir);
  options.settings.gates.tolerance_mm = 0.3;
  auto together = verify(options);
  ASSERT_TRUE(together.ok()) << together.error().describe();

  // --printer auto (the default): the printer the G-code names, as verify() resolves it.
  auto resolved = resolve_printer(options.settings.printer, options.gcode_path);
  ASSERT_TRUE(resolved.ok());
  const std::optional<PrinterProfile> printer(resolved->profile);
  auto part = prepare_part(options.mesh_path, *printer, options.settings);
  ASSERT_TRUE(part.ok());
  auto gcode = read_gcode_input(options.gcode_path);
  ASSERT_TRUE(gcode.ok());
  auto printed = print_gcode(*printer, options.settings, std::move(*gcode));
  ASSERT_TRUE(printed.ok()) << printed.error().describe();
  EXPECT_GT(printed->deposit.voxels, 1000U);
  EXPECT_GT(printed->extent.moves, 0U);
  auto apart = measure_printed(*part, options.settings, std::move(*printed));
  ASSERT_TRUE(apart.ok());
  // The stages are timed in the same order: part's, then the G-code's, then the deviation.
  std::vector<std::string> stages_together, stages_apart;
  for (const auto& t : together->timings) stages_together.push_back(t.stage);
  for (const auto& t : apart->timings) stages_apart.push_back(t.stage);
  EXPECT_EQ(stages_together, stages_apart);
  EXPECT_EQ(stages_together, (std::vector<std::string>{"load", "index", "check", "simulate",
                                                       "deposit", "registration", "deviation"}));
  // verify() measures its own wall time; the halves called one by one do not.
  EXPECT_GT(together->elapsed_s, 0.0);
  EXPECT_EQ(apart->elapsed_s, 0.0);
  together->timings.clear();
  apart->timings.clear();
  together->elapsed_s = 0;
  EXPECT_EQ(verify_report_json(*together), verify_report_json(*apart));
}

TEST(VerifyLibrary, ABadMeshIsReportedBeforeABadGcode) {
  const auto dir = test::temp_dir("verify_both_bad");
  ASSERT_TRUE(write_file_atomic(dir / "bad.stl", "solid x\nfacet normal 0 0 1\n hello\n").ok());
  ASSERT_TRUE(write_file_atomic(dir / "bad.gcode", "G28\nG1 X10 Y10 Z0.2 E1\n").ok());
  VerifyOptions options;
  options.mesh_path = dir / "bad.stl";
  options.gcode_path = dir / "missing.gcode";
  auto r = verify(options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().describe().find("bad.stl"), std::string::npos) << r.error().describe();
  // A good mesh with G-code that lays nothing of the part: the G-code's error.
  options.mesh_path = cube10_stl(dir);
  options.gcode_path = dir / "bad.gcode";
  r = verify(options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().describe().find("bad.gcode"), std::string::npos) << r.error().describe();
}

TEST(VerifyLibrary, OnPlacedGetsThePlacedMeshOnceBeforeVerifyReturns) {
  const auto dir = test::temp_dir("verify_on_placed");
  VerifyOptions options = cube10_options(dir);
  std::atomic<int> calls{0};
  Mesh seen;
  const auto on_placed = [&](const Mesh& placed) {
    ++calls;
    seen = placed;
  };
  auto r = verify_detail::verify_with(options, on_placed);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(calls.load(), 1);
  EXPECT_TRUE(seen == r->placed_mesh);
  // --place: the hook gets the mesh at the given offset.
  options.settings.place_mm = Vec3(100, 100, 0);
  calls = 0;
  r = verify_detail::verify_with(options, on_placed);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(calls.load(), 1);
  EXPECT_TRUE(seen == r->placed_mesh);
  EXPECT_NEAR(bounding_box(seen).min.x(), 95.0, 1e-9);
  // A bad G-code: verify fails, and the placement is never known.
  calls = 0;
  options.settings.place_mm.reset();
  options.gcode_path = dir / "missing.gcode";
  EXPECT_FALSE(verify_detail::verify_with(options, on_placed).ok());
  EXPECT_EQ(calls.load(), 0);
}

// verify_to_folder traces the heatmaps while the deposit runs: the folder holds the same
// files as verify + write_report_folder + write_verify_outputs, the same bytes wherever the
// run's timings do not show (the images, the deviation PLY).
TEST(VerifyLibrary, VerifyToFolderWritesWhatTheCallsOneAfterTheOtherWrite) {
  const auto dir = test::temp_dir("verify_to_folder");
  const VerifyOptions options = cube10_options(dir);
  ReportOptions report_options;
  report_options.generated_utc = "2026-11-21T10:20:00Z";
  auto together = verify_to_folder(options, dir / "together", report_options);
  ASSERT_TRUE(together.ok()) << together.error().describe();
  auto alone = verify(options);
  ASSERT_TRUE(alone.ok());
  ReportOptions with_outputs = report_options;
  with_outputs.extra_outputs = [&](const std::filesystem::path& staging) {
    return write_verify_outputs(*alone, staging);
  };
  ASSERT_TRUE(write_report_folder(*alone, dir / "apart", with_outputs).ok());
  EXPECT_TRUE(together->placed_mesh == alone->placed_mesh);
  EXPECT_EQ(together->deviation.max_excess_mm, alone->deviation.max_excess_mm);
  std::size_t compared = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir / "apart")) {
    const std::string name = entry.path().filename().string();
    ASSERT_TRUE(std::filesystem::exists(dir / "together" / name)) << name;
    if (name.ends_with(".png") || name.ends_with(".ply")) {
      EXPECT_EQ(*read_file(entry.path()), *read_file(dir / "together" / name)) << name;
      ++compared;
    }
  }
  EXPECT_GE(compared, 2u);
  EXPECT_TRUE(std::filesystem::exists(dir / "together" / "report.json"));
  // A failing verify writes no folder.
  VerifyOptions bad = options;
  bad.gcode_path = dir / "missing.gcode";
  EXPECT_FALSE(verify_to_folder(bad, dir / "failed", report_options).ok());
  EXPECT_FALSE(std::filesystem::exists(dir / "failed"));
}

}  // namespace
}  // namespace printtwin
