// docs/ci.md's GitHub workflow, run as the runner would: its `printtwin check` and
// `printtwin verify` lines, taken from the page, in a parts folder built from the samples
// with a manifest, with GITHUB_STEP_SUMMARY set. Also the manifest's errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

/// The first line of the "## GitHub Actions" section of docs/ci.md that starts with `prefix`
/// (leading blanks ignored), or "".
std::string workflow_line(const std::string& prefix) {
  auto doc = read_file(test::source_path("docs/ci.md"));
  if (!doc) return "";
  const std::size_t from = doc->find("## GitHub Actions");
  const std::size_t to = doc->find("\n## ", from + 1);
  if (from == std::string::npos) return "";
  std::size_t pos = from;
  while (pos < to && pos < doc->size()) {
    const std::size_t eol = doc->find('\n', pos);
    std::string line = doc->substr(pos, (eol == std::string::npos ? doc->size() : eol) - pos);
    line.erase(0, line.find_first_not_of(' '));
    if (line.rfind(prefix, 0) == 0) return line;
    if (eol == std::string::npos) break;
    pos = eol + 1;
  }
  return "";
}

/// Runs `command` with sh in `dir`, printtwin on the PATH and GITHUB_STEP_SUMMARY set.
int run_step(const fs::path& dir, const std::string& command, const fs::path& step_summary,
             std::string* out) {
  const std::string bin = fs::path(PRINTTWIN_CLI).parent_path().string();
  const std::string cmd = "cd " + q(dir) + " && CI=true PATH=" + q(bin) +
                          ":\"$PATH\" GITHUB_STEP_SUMMARY=" + q(step_summary) + " sh -c " +
                          q(fs::path(command)) + " 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) out->append(buf.data(), n);
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// A repository of parts: six of the samples/models STLs in parts/, with printtwin.json
/// (a fixed list, so that new samples do not change the counts below).
fs::path make_parts_repo(const std::string& name) {
  const fs::path repo = test::temp_dir(name);
  fs::create_directories(repo / "parts");
  for (const char* part : {"broken.stl", "calibration_cube_20mm.stl", "curved_part.stl",
                           "overhangs.stl", "small_holes.stl", "thin_walls.stl"})
    fs::copy_file(test::source_path("samples/models") / part, repo / "parts" / part);
  fs::create_directories(repo / "parts" / "gcode");
  fs::copy_file(test::source_path("samples/gcode/prusa_thin_walls.gcode"),
                repo / "parts" / "gcode" / "thin_walls.gcode");
  std::ofstream(repo / "parts" / "printtwin.json") << R"({
  "version": 1,
  "defaults": {"printer": "ender3"},
  "parts": [
    {"file": "thin_walls.stl", "min_thickness_mm": 0.15, "gcode": "gcode/thin_walls.gcode", "tolerance_mm": 0.3},
    {"file": "renamed_away.stl"}
  ]
})";
  return repo;
}

TEST(CiWorkflow, CheckStepOfTheGitHubWorkflow) {
  const std::string line = workflow_line("printtwin check ");
  ASSERT_FALSE(line.empty()) << "docs/ci.md has no printtwin check line in its GitHub workflow";
  const fs::path repo = make_parts_repo("ci_workflow_check");
  const fs::path step_summary = repo / "step_summary.md";
  std::string out;
  const int rc = run_step(repo, line, step_summary, &out);
  EXPECT_EQ(rc, 3) << "broken.stl is not printable and the listed renamed_away.stl is missing\n"
                   << out;

  auto summary = read_file(step_summary);
  ASSERT_TRUE(summary.ok()) << out;
  for (const char* part :
       {"broken.stl", "calibration_cube_20mm.stl", "curved_part.stl", "overhangs.stl",
        "small_holes.stl", "thin_walls.stl", "renamed_away.stl"})
    EXPECT_NE(summary->find(std::string("parts/") + part), std::string::npos) << part << "\n"
                                                                              << *summary;
  EXPECT_NE(summary->find("5 of 7 parts printable"), std::string::npos) << *summary;
  EXPECT_NE(summary->find("listed in parts/printtwin.json but not found"), std::string::npos)
      << *summary;

  // JUnit and JSON named by the workflow, beside the checkout.
  auto junit = read_file(repo / "printtwin-junit.xml");
  ASSERT_TRUE(junit.ok());
  EXPECT_NE(junit->find("tests=\"7\" failures=\"2\""), std::string::npos) << *junit;
  const json all = test::read_json(repo / "printtwin-check.json");
  bool saw_thin = false;
  for (const auto& p : all["parts"]) {
    if (fs::path(p["file"].get<std::string>()).filename() != "thin_walls.stl") continue;
    saw_thin = true;
    // The manifest's 0.15 mm limit: the 0.2 mm walls are no longer thin.
    EXPECT_EQ(p["verdict"], "PRINTABLE");
    for (const auto& f : p["report"]["findings"]) EXPECT_NE(f["code"], "thin_wall") << f.dump();
  }
  EXPECT_TRUE(saw_thin);
}

TEST(CiWorkflow, VerifyStepOfTheGitHubWorkflow) {
  const std::string line = workflow_line("printtwin verify ");
  ASSERT_FALSE(line.empty()) << "docs/ci.md has no printtwin verify line in its GitHub workflow";
  const fs::path repo = make_parts_repo("ci_workflow_verify");
  // Only the parts with G-code: the part whose manifest lists thin_walls.stl and a missing one.
  std::string out;
  const int rc = run_step(repo, line, repo / "step_summary.md", &out);
  EXPECT_EQ(rc, 3) << "the listed renamed_away.stl is missing\n" << out;
  auto junit = read_file(repo / "printtwin-verify-junit.xml");
  ASSERT_TRUE(junit.ok()) << out;
  EXPECT_NE(junit->find("tests=\"2\" failures=\"1\""), std::string::npos) << *junit;
  EXPECT_NE(junit->find("renamed_away.stl: listed in parts/printtwin.json but not found"),
            std::string::npos)
      << *junit;
  EXPECT_TRUE(fs::exists(repo / "reports" / "thin_walls" / "report.json")) << out;
  auto md = read_file(repo / "verify.md");
  ASSERT_TRUE(md.ok());
  EXPECT_NE(md->find("1 of 2 parts pass"), std::string::npos) << *md;
  EXPECT_NE(md->find("| parts/thin_walls.stl | PASS | parts/gcode/thin_walls.gcode |"),
            std::string::npos)
      << *md;
}

TEST(Manifest, ErrorsNameTheFileAndTheKey) {
  const fs::path dir = test::temp_dir("manifest_errors");
  ASSERT_TRUE(save_stl(test::make_cube_mm(20), dir / "cube.stl").ok());
  struct Case {
    const char* text;
    const char* expect;
  };
  for (const Case& c :
       {Case{R"({"parts": [{"file": "cube.stl", "toleranc": 0.1}]})",
             "parts[0]: unknown key 'toleranc'"},
        Case{R"({"parts": [], "printer": "ender3"})", "unknown key 'printer'"},
        Case{R"({"defaults": {"file": "x.stl"}, "parts": []})", "defaults: unknown key 'file'"},
        Case{R"({"parts": [{"file": "cube.stl", "orient": "yes"}]})",
             "parts[0].orient: expected true or false"},
        Case{R"({"parts": [{"file": "cube.stl", "units": "furlong"}]})", "unknown unit 'furlong'"},
        Case{R"({"parts": [{"file": "cube.stl", "scale": -1}]})",
             "parts[0].scale: expected a number > 0"},
        Case{R"({"defaults": {"weld_tolerance_mm": -0.1}, "parts": []})",
             "defaults.weld_tolerance_mm: expected a number >= 0"},
        Case{R"({"parts": [{"file": "cube.stl"}, {"file": "./cube.stl"}]})", "listed twice"},
        Case{R"({"parts": [{"printer": "ender3"}]})", "parts[0]: expected \"file\""},
        Case{R"({"version": 2, "parts": []})", "version: expected 1"},
        Case{R"({"parts": [)", "not valid JSON"}}) {
    std::ofstream(dir / "m.json") << c.text;
    const auto r = test::run_cli("check --manifest " + q(dir / "m.json"));
    EXPECT_EQ(r.exit_code, 3) << c.text << "\n" << r.out << r.err;
    EXPECT_NE(r.err.find((dir / "m.json").string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.text << "\n" << r.err;
  }
  // The same errors stop `verify --manifest` and a check that picks printtwin.json up.
  std::ofstream(dir / "printtwin.json") << R"({"parts": [{"file": "cube.stl", "toleranc": 0.1}]})";
  const auto picked = test::run_cli("check " + q(dir / "cube.stl"));
  EXPECT_EQ(picked.exit_code, 3);
  EXPECT_NE(picked.err.find("printtwin.json: parts[0]: unknown key 'toleranc'"), std::string::npos)
      << picked.err;
  const auto verify = test::run_cli("verify --manifest " + q(dir / "printtwin.json"));
  EXPECT_EQ(verify.exit_code, 3);
  EXPECT_NE(verify.err.find("unknown key 'toleranc'"), std::string::npos) << verify.err;
  // Neither parts nor a manifest; both a part and a manifest for verify.
  EXPECT_EQ(test::run_cli("check").exit_code, 2);
  EXPECT_EQ(
      test::run_cli("verify " + q(dir / "cube.stl") + " --manifest " + q(dir / "printtwin.json"))
          .exit_code,
      2);
}

TEST(Manifest, PartSettingsWinOverDefaultsAndTheCommandLine) {
  const fs::path dir = test::temp_dir("manifest_precedence");
  // A 20 mm cube written in cm units (2 units) and a 0.3 mm wall.
  Mesh small = test::make_cube_mm(2);
  ASSERT_TRUE(save_stl(small, dir / "cm_cube.stl").ok());
  ASSERT_TRUE(save_stl(make_box_mesh(Vec3(0, 0, 0), Vec3(20, 0.3, 10)), dir / "wall.stl").ok());
  std::ofstream(dir / "printtwin.json") << R"({"defaults": {"min_thickness_mm": 0.2},
    "parts": [{"file": "cm_cube.stl", "units": "cm"}, {"file": "wall.stl"}]})";
  // A single file keeps the single-part output, with its manifest settings.
  const auto one = test::run_cli("check " + q(dir / "cm_cube.stl") + " --units mm --json " +
                                 q(dir / "one.json"));
  EXPECT_EQ(one.exit_code, 0) << one.out << one.err;
  const json j = test::read_json(dir / "one.json");
  EXPECT_EQ(j["input"]["units"], "cm") << j["input"].dump();
  EXPECT_NEAR(
      j["mesh"]["bbox_mm"]["max"][0].get<double>() - j["mesh"]["bbox_mm"]["min"][0].get<double>(),
      20.0, 1e-6);
  // The defaults' 0.2 mm limit beats the command line's 0.5 mm: the 0.3 mm wall is not thin.
  const auto wall = test::run_cli("check " + q(dir / "wall.stl") + " --min-thickness 0.5");
  EXPECT_EQ(wall.out.find("thin_wall"), std::string::npos) << wall.out;
  // --manifest without parts: exactly the listed parts, as a batch.
  const auto listed = test::run_cli("check --manifest " + q(dir / "printtwin.json"));
  EXPECT_EQ(listed.exit_code, 0) << listed.out << listed.err;
  EXPECT_NE(listed.out.find("2 of 2 parts printable"), std::string::npos) << listed.out;
}

TEST(Manifest, WeldToleranceOfEachPartGoesToItsRepair) {
  // Two copies of a 10 mm cube whose top sits on its own corners 0.001 mm above the sides
  // (a seam of 8 open facet edges): the manifest's weld tolerance closes one seam and turns
  // the weld off for the other (its top is then a loose piece, removed, the hole filled).
  const fs::path dir = test::temp_dir("manifest_weld");
  const Mesh m = test::make_seam_cube_mm(10, 0.001);
  ASSERT_TRUE(save_stl(m, dir / "welded.stl").ok());
  ASSERT_TRUE(save_stl(m, dir / "unwelded.stl").ok());
  std::ofstream(dir / "printtwin.json") << R"({"defaults": {"weld_tolerance_mm": 0.01},
    "parts": [{"file": "welded.stl"}, {"file": "unwelded.stl", "weld_tolerance_mm": 0}]})";
  const auto r = test::run_cli("check " + q(dir) + " --weld-tolerance 5 --repair " +
                               q(dir / "fixed") + " --json " + q(dir / "all.json"));
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;  // the seams are open edges
  const json j = test::read_json(dir / "all.json");
  ASSERT_EQ(j["parts"].size(), 2U) << j.dump();
  for (const auto& part : j["parts"]) {
    const json& repair = part["report"]["repair"];
    const bool welded = part["file"].get<std::string>().find("unwelded") == std::string::npos;
    EXPECT_DOUBLE_EQ(repair["weld_tolerance_mm"].get<double>(), welded ? 0.01 : 0.0)
        << part["file"];
    EXPECT_EQ(repair["counters"]["edges_fixed"].get<int>(), welded ? 8 : 0) << repair.dump();
    EXPECT_EQ(repair["counters"]["facets_added"].get<int>(), welded ? 0 : 2) << repair.dump();
  }
}

}  // namespace
}  // namespace printtwin
