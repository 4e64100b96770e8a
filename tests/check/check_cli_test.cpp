// End-to-end `printtwin check`: every sample against its .expect.json, exit codes, JSON keys,
// bad inputs, printer profiles and --repair.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json read_json(const fs::path& p) {
  auto text = read_file(p);
  EXPECT_TRUE(text.ok()) << p;
  return text.ok() ? json::parse(*text) : json();
}

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

TEST(CheckCli, EverySampleMatchesItsExpectation) {
  const fs::path models = test::source_path("samples/models");
  const fs::path out = test::temp_dir("check_cli_samples");
  int seen = 0;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(models))
    if (e.path().string().ends_with(".expect.json")) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& exp_path : files) {
    const json exp = read_json(exp_path);
    const std::string model = exp["model"];
    SCOPED_TRACE(model);
    const fs::path json_out = out / (model + ".json");
    const auto run = test::run_cli("check " + q(models / model) + " --json " + q(json_out));
    EXPECT_EQ(run.exit_code, exp["exit_code"].get<int>()) << run.out << run.err;
    const json got = read_json(json_out);
    EXPECT_EQ(got["schema"], "printtwin.check");
    EXPECT_EQ(got["schema_version"], 1);
    EXPECT_EQ(got["printable"], exp["printable"]);
    EXPECT_EQ(got["mesh"]["triangles"], exp["mesh"]["triangles"]);
    EXPECT_EQ(got["mesh"]["closed"], exp["mesh"]["closed"]);
    EXPECT_EQ(got["mesh"]["shells"], exp["mesh"]["shells"]);
    EXPECT_NEAR(got["mesh"]["volume_mm3"].get<double>(), exp["mesh"]["volume_mm3"].get<double>(),
                exp["tolerance"]["volume_mm3"].get<double>());
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(got["mesh"]["bbox_mm"]["size"][a].get<double>(),
                  exp["mesh"]["bbox_size_mm"][a].get<double>(),
                  exp["tolerance"]["size_mm"].get<double>());
    std::vector<std::string> codes, want;
    for (const auto& f : got["findings"]) {
      codes.push_back(f["code"]);
      for (const char* key : {"severity", "code", "message", "position_mm"})
        EXPECT_TRUE(f.contains(key)) << key;
    }
    for (const auto& c : exp["findings"]) want.push_back(c);
    std::sort(codes.begin(), codes.end());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(codes, want);
    for (const auto& [code, v] : exp["values"].items()) {
      double best = -1;
      for (const auto& f : got["findings"])
        if (f["code"] == code && f.contains("value"))
          best = std::max(best, f["value"].get<double>());
      EXPECT_NEAR(best, v[0].get<double>(), v[1].get<double>()) << code;
    }
    // Text for people: a verdict line.
    EXPECT_NE(run.out.find(exp["printable"].get<bool>() ? "result     PRINTABLE" : "NOT PRINTABLE"),
              std::string::npos)
        << run.out;
    ++seen;
  }
  EXPECT_GE(seen, 6);
}

TEST(CheckCli, JsonIsDeterministic) {
  const fs::path out = test::temp_dir("check_cli_det");
  const fs::path model = test::source_path("samples/models/overhangs.stl");
  ASSERT_EQ(test::run_cli("check " + q(model) + " --json " + q(out / "a.json")).exit_code, 0);
  ASSERT_EQ(test::run_cli("check " + q(model) + " --json " + q(out / "b.json")).exit_code, 0);
  EXPECT_EQ(*read_file(out / "a.json"), *read_file(out / "b.json"));
}

TEST(CheckCli, BadInputsExitThreeNamingTheFile) {
  const fs::path dir = test::temp_dir("check_cli_bad");
  struct Case {
    std::string name, bytes, message;
  };
  std::string truncated(84, ' ');
  const std::uint32_t n = 1000;
  std::memcpy(truncated.data() + 80, &n, 4);
  const std::vector<Case> cases = {
      {"empty.stl", "", "empty file"},
      {"short.stl", std::string(50, 'x'), "truncated binary STL"},
      {"count.stl", truncated, "announces 1000 triangles"},
      {"garbage.stl", "solid a\nfacet normal 0 0 1\nouter loop\nvertex 1 2 3\nvertex oops\n",
       "garbage.stl:5: ASCII STL: expected a number, found 'oops'"},
      {"part.step", "ISO-10303-21;", "unknown mesh extension '.step'"},
  };
  for (const auto& c : cases) {
    std::ofstream(dir / c.name, std::ios::binary) << c.bytes;
    const auto run = test::run_cli("check " + q(dir / c.name));
    EXPECT_EQ(run.exit_code, 3) << c.name << run.err;
    EXPECT_NE(run.err.find(c.message), std::string::npos) << run.err;
    EXPECT_NE(run.err.find(c.name), std::string::npos) << run.err;
    EXPECT_TRUE(run.out.empty()) << "no report for bad input: " << run.out;
  }
  fs::create_directories(dir / "dir.stl");
  const auto d = test::run_cli("check " + q(dir / "dir.stl"));
  EXPECT_EQ(d.exit_code, 3);
  EXPECT_NE(d.err.find("directory"), std::string::npos) << d.err;
  EXPECT_EQ(test::run_cli("check " + q(dir / "missing.stl")).exit_code, 3);
}

TEST(CheckCli, UsageErrorsExitTwo) {
  const fs::path cube = test::source_path("samples/models/calibration_cube_20mm.stl");
  EXPECT_EQ(test::run_cli("check").exit_code, 2);
  EXPECT_EQ(test::run_cli("check " + q(cube) + " --units furlong").exit_code, 2);
  EXPECT_EQ(test::run_cli("check " + q(cube) + " --overhang-angle 120").exit_code, 2);
  EXPECT_EQ(test::run_cli("check " + q(cube) + " --center 10").exit_code, 2);
  EXPECT_EQ(test::run_cli("check " + q(cube) + " --center 1,2 --no-center").exit_code, 2);
  EXPECT_EQ(test::run_cli("check " + q(cube) + " --scale -2").exit_code, 2);
}

TEST(CheckCli, UnitsScaleAndPlacementOptions) {
  const fs::path out = test::temp_dir("check_cli_units");
  const fs::path cube = test::source_path("samples/models/calibration_cube_20mm.stl");
  // 20 inch = 508 mm: does not fit, exit 1.
  const auto inch = test::run_cli("check " + q(cube) + " --units inch --json " + q(out / "i.json"));
  EXPECT_EQ(inch.exit_code, 1);
  const json ji = read_json(out / "i.json");
  EXPECT_NEAR(ji["mesh"]["bbox_mm"]["size"][0].get<double>(), 508.0, 1e-3);
  EXPECT_EQ(ji["placement"]["fits"], false);
  EXPECT_EQ(ji["findings"][0]["code"], "does_not_fit");
  EXPECT_EQ(ji["input"]["units"], "inch");
  EXPECT_EQ(test::run_cli("check " + q(cube) + " --units cm --scale 0.5 --center 30,40 --json " +
                          q(out / "c.json"))
                .exit_code,
            1);
  const json jc = read_json(out / "c.json");
  EXPECT_NEAR(jc["mesh"]["bbox_mm"]["size"][2].get<double>(), 100.0, 1e-3);
  EXPECT_NEAR(jc["placement"]["bbox_mm"]["min"][0].get<double>(), -20.0, 1e-3);
  EXPECT_EQ(jc["placement"]["fits"], false) << "centred at x 30, a 100 mm cube leaves the bed";
  ASSERT_EQ(
      test::run_cli("check " + q(cube) + " --no-center --json " + q(out / "n.json")).exit_code, 0);
  const json jn = read_json(out / "n.json");
  EXPECT_NEAR(jn["placement"]["bbox_mm"]["min"][0].get<double>(), 0.0, 1e-9);
}

TEST(CheckCli, UnitsAutoReadsAMetreFileAtItsTrueSize) {
  const fs::path out = test::temp_dir("check_cli_units_auto");
  ASSERT_TRUE(
      save_stl(make_box_mesh(Vec3(0, 0, 0), Vec3(0.02, 0.03, 0.01)), out / "metres.stl").ok());
  const auto r = test::run_cli("check " + q(out / "metres.stl") + " --json " + q(out / "a.json"));
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("units_guessed"), std::string::npos) << r.out;
  const json j = read_json(out / "a.json");
  EXPECT_NEAR(j["mesh"]["bbox_mm"]["size"][1].get<double>(), 30.0, 1e-3);
  EXPECT_EQ(j["input"]["units"], "m");
  // An explicit --units wins (the same names as verify --units).
  const auto mm =
      test::run_cli("check " + q(out / "metres.stl") + " --units mm --json " + q(out / "b.json"));
  EXPECT_EQ(mm.exit_code, 1);
  EXPECT_EQ(mm.out.find("units_guessed"), std::string::npos);
  EXPECT_NEAR(read_json(out / "b.json")["mesh"]["bbox_mm"]["size"][1].get<double>(), 0.03, 1e-6);
  EXPECT_EQ(test::run_cli("check " + q(out / "metres.stl") + " --units m").exit_code, 0);
  EXPECT_EQ(test::run_cli("check " + q(out / "metres.stl") + " --units 1000").exit_code, 0);
}

TEST(CheckCli, RealPartsInMetresAndTooBig) {
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no realworld folder";
  const fs::path out = test::temp_dir("check_cli_realworld_units");
  const fs::path lid = *dir / "models" / "kisslicer_pair_musicutility_lid.stl";
  if (fs::exists(lid)) {
    const auto r = test::run_cli("check " + q(lid) + " --json " + q(out / "lid.json"));
    EXPECT_NE(r.out.find("read as metres"), std::string::npos) << r.out;
    const double y = read_json(out / "lid.json")["mesh"]["bbox_mm"]["size"][1].get<double>();
    EXPECT_GT(y, 100.0);
    EXPECT_LT(y, 200.0);
  }
  const fs::path scan = *dir / "models" / "nefertiti_scan.obj";
  if (fs::exists(scan)) {
    const auto r = test::run_cli("check " + q(scan));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.out.find("units_guessed"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("the largest scale that fits is"), std::string::npos) << r.out;
  }
}

TEST(CheckCli, BatchOfPartsGivesOneSummaryJunitAndJson) {
  const fs::path dir = test::temp_dir("check_cli_batch");
  fs::remove_all(dir / "parts");
  fs::create_directories(dir / "parts" / "folder.stl");  // a folder where a part should be
  ASSERT_TRUE(save_stl(test::make_cube_mm(20), dir / "parts" / "good.stl").ok());
  Mesh open = test::make_cube_mm(20);
  open.triangles.pop_back();
  ASSERT_TRUE(save_stl(open, dir / "parts" / "open.stl").ok());
  { std::ofstream(dir / "parts" / "empty.stl"); }
  {
    auto bytes = read_file(dir / "parts" / "good.stl");
    ASSERT_TRUE(bytes.ok());
    std::ofstream(dir / "parts" / "truncated.stl", std::ios::binary) << bytes->substr(0, 200);
  }
  { std::ofstream(dir / "parts" / "notes.txt") << "not a mesh"; }
  const auto r = test::run_cli("check " + q(dir / "parts") + " --summary " + q(dir / "s.md") +
                               " --junit " + q(dir / "j.xml") + " --json " + q(dir / "all.json"));
  EXPECT_EQ(r.exit_code, 3) << "the worst part is unreadable\n" << r.out << r.err;
  auto md = read_file(dir / "s.md");
  ASSERT_TRUE(md.ok());
  EXPECT_EQ(*md, r.out);
  EXPECT_NE(md->find("1 of 5 parts printable"), std::string::npos) << *md;
  EXPECT_EQ(md->find("notes.txt"), std::string::npos);
  for (const char* name : {"good.stl", "open.stl", "empty.stl", "truncated.stl", "folder.stl"})
    EXPECT_NE(md->find(name), std::string::npos) << name;
  EXPECT_NE(md->find("| **UNREADABLE** |"), std::string::npos);
  EXPECT_NE(md->find("| **NOT PRINTABLE** |"), std::string::npos);
  auto xml = read_file(dir / "j.xml");
  ASSERT_TRUE(xml.ok());
  EXPECT_NE(xml->find("tests=\"5\" failures=\"4\""), std::string::npos) << *xml;
  std::size_t cases = 0;
  for (auto at = xml->find("<testcase "); at != std::string::npos;
       at = xml->find("<testcase ", at + 1))
    ++cases;
  EXPECT_EQ(cases, 5U);
  const json j = read_json(dir / "all.json");
  EXPECT_EQ(j["schema"], "printtwin.check.batch");
  ASSERT_EQ(j["parts"].size(), 5U);
  std::map<std::string, std::string> verdicts;
  for (const auto& p : j["parts"])
    verdicts[fs::path(p["file"].get<std::string>()).filename().string()] = p["verdict"];
  EXPECT_EQ(verdicts["good.stl"], "PRINTABLE");
  EXPECT_EQ(verdicts["open.stl"], "NOT PRINTABLE");
  EXPECT_EQ(verdicts["empty.stl"], "UNREADABLE");
  EXPECT_EQ(verdicts["truncated.stl"], "UNREADABLE");
  EXPECT_EQ(verdicts["folder.stl"], "UNREADABLE");
  for (const auto& p : j["parts"])
    if (p["verdict"] == "PRINTABLE") {
      EXPECT_EQ(p["report"]["schema"], "printtwin.check");
    }
  // A glob of printable and not printable parts: exit 1; a glob that matches nothing: usage.
  EXPECT_EQ(
      test::run_cli("check " + q(dir / "parts" / "good.stl") + " " + q(dir / "parts" / "o*.stl"))
          .exit_code,
      1);
  EXPECT_EQ(test::run_cli("check " + q(dir / "parts" / "g*.stl")).exit_code, 0);
  EXPECT_EQ(test::run_cli("check " + q(dir / "parts" / "zz*.stl")).exit_code, 2);
  // --repair of a batch names a folder: one repaired mesh per part, counters in the summary.
  std::ofstream(dir / "r.stl") << "a file, not a folder";
  EXPECT_EQ(test::run_cli("check " + q(dir / "parts") + " --repair " + q(dir / "r.stl")).exit_code,
            2);
  const auto rep = test::run_cli("check " + q(dir / "parts" / "good.stl") + " " +
                                 q(dir / "parts" / "open.stl") + " --repair " + q(dir / "fixed") +
                                 " --summary " + q(dir / "r.md") + " --json " + q(dir / "r.json"));
  EXPECT_EQ(rep.exit_code, 1) << rep.out << rep.err;
  EXPECT_TRUE(fs::exists(dir / "fixed" / "good.stl"));
  EXPECT_TRUE(fs::exists(dir / "fixed" / "open.stl"));
  auto summary = read_file(dir / "r.md");
  ASSERT_TRUE(summary.ok());
  EXPECT_NE(summary->find("| repair |"), std::string::npos) << *summary;
  EXPECT_NE(summary->find("holes filled 1"), std::string::npos) << *summary;
  const json rj = read_json(dir / "r.json");
  for (const auto& p : rj["parts"]) {
    if (fs::path(p["file"].get<std::string>()).filename() == "open.stl") {
      EXPECT_EQ(p["report"]["repair"]["counters"]["holes_filled"], 1);
    }
  }
}

TEST(CheckCli, OrientAppliesTheAdviceToTheRepairedMesh) {
  const fs::path dir = test::temp_dir("check_cli_orient");
  ASSERT_TRUE(save_stl(make_box_mesh(Vec3(0, 0, 0), Vec3(40, 2, 30)), dir / "plate.stl").ok());
  const auto plain = test::run_cli("check " + q(dir / "plate.stl"));
  EXPECT_NE(plain.out.find("orientation"), std::string::npos) << plain.out;
  const auto r =
      test::run_cli("check " + q(dir / "plate.stl") + " --orient --repair " + q(dir / "flat.stl"));
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("oriented"), std::string::npos) << r.out;
  auto flat = load_mesh(dir / "flat.stl");
  ASSERT_TRUE(flat.ok());
  EXPECT_NEAR(bounding_box(*flat).size().z(), 2.0, 1e-4);
}

TEST(CheckCli, PrinterProfiles) {
  const fs::path dir = test::temp_dir("check_cli_printer");
  const fs::path cube = test::source_path("samples/models/calibration_cube_20mm.stl");
  for (const char* p : {"ender3", "ender3-marlin1", "ender3-klipper"})
    EXPECT_EQ(test::run_cli("check " + q(cube) + " --printer " + p).exit_code, 0) << p;
  for (const char* f : {"ender3.json", "ender3-marlin1.json", "ender3-klipper.json"})
    EXPECT_EQ(test::run_cli("check " + q(cube) + " --printer " +
                            q(test::source_path(std::string("samples/printers/") + f)))
                  .exit_code,
              0)
        << f;
  // A tiny bed: the 20 mm cube no longer fits.
  std::ofstream(dir / "tiny.json")
      << R"({"base": "ender3", "bed_max_x_mm": 15, "bed_max_y_mm": 15})";
  const auto tiny = test::run_cli("check " + q(cube) + " --printer " + q(dir / "tiny.json"));
  EXPECT_EQ(tiny.exit_code, 1) << tiny.out << tiny.err;
  EXPECT_NE(tiny.out.find("does_not_fit"), std::string::npos);
  std::ofstream(dir / "bad.json") << R"({"bed_max_x_mmm": 15})";
  const auto bad = test::run_cli("check " + q(cube) + " --printer " + q(dir / "bad.json"));
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("bed_max_x_mmm"), std::string::npos) << bad.err;
}

/// `check DIR/in.stl --repair DIR/fixed.stl --json DIR/r.json` on `mesh` written to in.stl;
/// the exit code is the input's (still reported as it is).
test::CliRun repair_run(const Mesh& mesh, const fs::path& dir) {
  EXPECT_TRUE(save_stl(mesh, dir / "in.stl").ok());
  auto run = test::run_cli("check " + q(dir / "in.stl") + " --repair " + q(dir / "fixed.stl") +
                           " --json " + q(dir / "r.json"));
  EXPECT_EQ(run.exit_code, 1) << "the input is still reported as it is";
  return run;
}

TEST(CheckCli, RepairWritesAFixedMeshAndListsChanges) {
  const fs::path dir = test::temp_dir("check_cli_repair");
  // The cube without one of its faces.
  Mesh open = test::make_cube_mm(20);
  open.triangles.pop_back();
  const auto run = repair_run(open, dir);
  EXPECT_NE(run.out.find("holes filled: 1"), std::string::npos) << run.out;
  const json j = read_json(dir / "r.json");
  ASSERT_TRUE(j.contains("repair"));
  EXPECT_EQ(j["repair"]["after"]["closed"], true);
  bool filled = false;
  for (const auto& c : j["repair"]["changes"]) filled = filled || c["code"] == "filled_holes";
  EXPECT_TRUE(filled);
  const auto again = test::run_cli("check " + q(dir / "fixed.stl"));
  EXPECT_EQ(again.exit_code, 0) << again.out;
  auto fixed = load_mesh(dir / "fixed.stl");
  ASSERT_TRUE(fixed.ok());
  EXPECT_NEAR(signed_volume_mm3(*fixed), 8000.0, 1e-3);
}

TEST(CheckCli, RepairWeldsAnOpenSeamWithinTheTolerance) {
  // The 20 mm cube with its top on corners of its own, 0.01 mm higher: a seam of 8 open
  // facet edges. The default tolerance (admesh's: the shortest edge, 20 mm, + 0.01 % of the
  // diagonal) joins it as admesh does; 0.005 mm does not, and the top goes as a loose piece.
  const fs::path dir = test::temp_dir("check_cli_weld");
  const Mesh m = test::make_seam_cube_mm(20, 0.01);
  const auto run = repair_run(m, dir);
  EXPECT_NE(run.out.find("open seams welded within 20.0035 mm"), std::string::npos) << run.out;
  const json j = read_json(dir / "r.json");
  EXPECT_NEAR(j["repair"]["weld_tolerance_mm"].get<double>(), 20.0035, 1e-4);
  EXPECT_EQ(j["repair"]["counters"]["edges_fixed"], 8);
  EXPECT_EQ(j["repair"]["counters"]["facets_removed"], 0);
  EXPECT_EQ(j["repair"]["counters"]["facets_added"], 0);
  EXPECT_EQ(j["repair"]["counters"]["nearby_edges"], 8);
  EXPECT_EQ(j["repair"]["changes"][0]["code"], "welded_vertices");
  EXPECT_EQ(j["repair"]["after"]["closed"], true);
  auto fixed = load_mesh(dir / "fixed.stl");
  ASSERT_TRUE(fixed.ok());
  // Each joined pair takes the position of the vertex first in the file: the top's (its faces
  // come first), so the cube is 20.01 mm tall.
  EXPECT_NEAR(signed_volume_mm3(*fixed), 8004.0, 1e-3);

  const auto tight =
      test::run_cli("check " + q(dir / "in.stl") + " --repair " + q(dir / "tight.stl") +
                    " --weld-tolerance 0.005 --json " + q(dir / "t.json"));
  EXPECT_EQ(tight.exit_code, 1);
  const json t = read_json(dir / "t.json");
  EXPECT_EQ(t["repair"]["weld_tolerance_mm"], 0.005);
  EXPECT_EQ(t["repair"]["counters"]["nearby_edges"], 0);
  EXPECT_EQ(t["repair"]["counters"]["facets_removed"], 2);
  EXPECT_EQ(test::run_cli("check " + q(dir / "in.stl") + " --weld-tolerance -1").exit_code, 2);
}

TEST(CheckCli, RepairOfTheBrokenSample) {
  const fs::path dir = test::temp_dir("check_cli_repair_broken");
  const auto run =
      test::run_cli("check " + q(test::source_path("samples/models/broken.stl")) + " --repair " +
                    q(dir / "fixed.stl") + " --json " + q(dir / "r.json"));
  EXPECT_EQ(run.exit_code, 1);
  const json j = read_json(dir / "r.json");
  std::map<std::string, int> changes;
  for (const auto& c : j["repair"]["changes"]) changes[c["code"]] = c["count"];
  EXPECT_EQ(changes["removed_degenerate_faces"], 1);
  EXPECT_EQ(changes["removed_small_pieces"], 1) << "the fin";
  EXPECT_EQ(changes["filled_holes"], 1) << "the missing top";
  EXPECT_EQ(j["repair"]["after"]["closed"], true);
  const auto again =
      test::run_cli("check " + q(dir / "fixed.stl") + " --json " + q(dir / "a.json"));
  EXPECT_EQ(again.exit_code, 0) << again.out;
  EXPECT_NEAR(read_json(dir / "a.json")["mesh"]["volume_mm3"].get<double>(), 8000.0, 1e-3);
}

}  // namespace
}  // namespace printtwin
