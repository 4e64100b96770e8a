// External slicer back-ends: the command lines built for PrusaSlicer, CuraEngine and Slic3r,
// the error paths without a slicer (not installed, failing, hanging) through stand-in
// scripts, the slicing of shared variants once, and a real PrusaSlicer run when installed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

namespace fs = std::filesystem;

SlicerProgram program(const std::string& name) {
  return SlicerProgram{name, "/usr/bin/" + name, ""};
}

// A shell script standing in for a slicer.
fs::path script(const fs::path& dir, const std::string& name, const std::string& body) {
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << "#!/bin/sh\n" << body << "\n";
  fs::permissions(p, fs::perms::owner_all);
  return p;
}

TEST(SlicerBackend, PrusaSlicerCommandLoadsTheConfigThenTheSettings) {
  SlicerJob job{"part.stl",
                "ender3.ini",
                {{"layer_height", "0.3"}, {"fill_density", "15%"}, {"layer_height", "0.1"}},
                "",
                "out/a.gcode"};
  auto argv = slicer_command(program("prusa-slicer"), job);
  ASSERT_TRUE(argv) << argv.error().describe();
  // The last value of a key wins; keys become the slicer's --flags, sorted.
  EXPECT_EQ(shell_quote(*argv),
            "/usr/bin/prusa-slicer --load ender3.ini --fill-density 15% --layer-height 0.1 "
            "--export-gcode "
            "-o out/a.gcode part.stl");
}

TEST(SlicerBackend, Slic3rCommandHasNoExportFlag) {
  SlicerJob job{"part.stl", "", {{"perimeters", "3"}}, "", "a.gcode"};
  auto argv = slicer_command(program("slic3r"), job);
  ASSERT_TRUE(argv);
  EXPECT_EQ(shell_quote(*argv), "/usr/bin/slic3r --perimeters 3 -o a.gcode part.stl");
}

TEST(SlicerBackend, CuraCommandPassesConfigLinesThenSettingsWithS) {
  const auto dir = test::temp_dir("slicer_cura_cfg");
  std::ofstream(dir / "ender.cfg")
      << "# Ender-3 settings\nlayer_height = 0.2\n\nwall_line_count=2\n";
  SlicerJob job{"part.stl",
                (dir / "ender.cfg").string(),
                {{"layer_height", "0.1"}},
                "/defs/creality_ender3.def.json",
                "a.gcode"};
  auto argv = slicer_command(program("cura"), job);
  ASSERT_TRUE(argv) << argv.error().describe();
  EXPECT_EQ(shell_quote(*argv),
            "/usr/bin/cura slice -v -j /defs/creality_ender3.def.json -s layer_height=0.1 -s "
            "wall_line_count=2 -l part.stl -o a.gcode");
  job.cura_definition.clear();
  auto missing = slicer_command(program("cura"), job);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::usage);
  EXPECT_NE(missing.error().message.find("--cura-definition"), std::string::npos);
  std::ofstream(dir / "bad.cfg") << "layer_height 0.2\n";
  job.cura_definition = "/defs/x.def.json";
  job.config_path = (dir / "bad.cfg").string();
  auto bad = slicer_command(program("cura"), job);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().line, 1);
}

// CuraEngine evaluates no formula: the children of a varied parent are written out.
TEST(SlicerBackend, CuraParentsReachTheirChildren) {
  const auto dir = test::temp_dir("slicer_cura_children");
  std::ofstream(dir / "c.cfg")
      << "infill_line_distance = 9\ntop_bottom_thickness = 0.8\nspeed_wall_0 = 20\n";
  SlicerJob job{"p.stl",
                (dir / "c.cfg").string(),
                {{"infill_sparse_density", "10"}, {"layer_height", "0.2"}, {"speed_print", "60"}},
                "/d/x.def.json",
                "o.gcode"};
  auto argv = slicer_command(program("cura"), job);
  ASSERT_TRUE(argv) << argv.error().describe();
  const std::string line = shell_quote(*argv);
  // A child the user set is kept (as Cura keeps it): the file's infill_line_distance stays.
  EXPECT_NE(line.find("-s infill_line_distance=9 "), std::string::npos) << line;
  EXPECT_NE(line.find("-s top_layers=4 "), std::string::npos) << line;
  EXPECT_NE(line.find("-s speed_infill=60 "), std::string::npos) << line;
  EXPECT_NE(line.find("-s speed_wall=30 "), std::string::npos) << line;
  EXPECT_NE(line.find("-s speed_wall_0=20 "), std::string::npos) << line;
  job.config_path.clear();
  auto fresh = slicer_command(program("cura"), job);
  ASSERT_TRUE(fresh);
  // grid: 0.4 mm lines * 100 / 10 % * 2 lines per cell.
  EXPECT_NE(shell_quote(*fresh).find("-s infill_line_distance=8 "), std::string::npos)
      << shell_quote(*fresh);
  // The re-run line names the search path the definition needs.
  auto text = slicer_command_line(program("cura"), job);
  ASSERT_TRUE(text);
  EXPECT_EQ(text->rfind("CURA_ENGINE_SEARCH_PATH=", 0), 0u) << *text;
}

TEST(SlicerBackend, ShellQuoteQuotesSpacesAndQuotes) {
  EXPECT_EQ(shell_quote({"a b", "it's", "plain-1.0"}), "'a b' 'it'\\''s' plain-1.0");
}

TEST(SlicerBackend, SlicerPathsNeedANameWithSeveralSlicers) {
  auto one = parse_slicer_paths({"/opt/ps"}, {"prusa-slicer"});
  ASSERT_TRUE(one);
  EXPECT_EQ(one->at(0), (SettingKV{"prusa-slicer", "/opt/ps"}));
  EXPECT_FALSE(parse_slicer_paths({"/opt/ps"}, {"prusa-slicer", "cura"}));
  auto named = parse_slicer_paths({"cura=/opt/CuraEngine"}, {"prusa-slicer", "cura"});
  ASSERT_TRUE(named);
  EXPECT_EQ(named->at(0), (SettingKV{"cura", "/opt/CuraEngine"}));
}

TEST(SlicerBackend, UnknownSlicerIsAUsageError) {
  SweepSpec spec;
  spec.slicers = {"simplify3d"};
  auto v = expand_variants(spec);
  ASSERT_FALSE(v);
  EXPECT_EQ(v.error().code, ErrorCode::usage);
}

TEST(SlicerBackend, SeveralSlicersMakeOneVariantSetEach) {
  SweepSpec spec;
  spec.slicers = {"prusa-slicer", "cura"};
  spec.axes = {SweepAxis{"layer_height", {"0.1", "0.2"}}};
  auto v = expand_variants(spec);
  ASSERT_TRUE(v);
  ASSERT_EQ(v->size(), 4u);
  EXPECT_EQ((*v)[0].slicer, "prusa-slicer");
  EXPECT_EQ((*v)[0].label, "prusa-slicer layer_height=0.1");
  EXPECT_EQ((*v)[3].slicer, "cura");
  EXPECT_EQ((*v)[3].label, "cura layer_height=0.2");
}

TEST(SlicerBackend, MixedComparisonMapsSharedSettingsAndConfigsPerSlicer) {
  SweepSpec spec;
  spec.slicers = {"prusa-slicer", "cura"};
  spec.configs = {"prusa-slicer=p.ini", "cura=c.cfg"};
  spec.common_settings = {{"perimeters", "3"}, {"fill_density", "15%"}};
  auto v = expand_variants(spec);
  ASSERT_TRUE(v) << v.error().describe();
  ASSERT_EQ(v->size(), 2u);
  EXPECT_EQ((*v)[0].config_path, "p.ini");
  EXPECT_EQ((*v)[1].config_path, "c.cfg");
  EXPECT_EQ((*v)[1].label, "cura c");
  EXPECT_EQ(slicer_settings("cura", (*v)[1].settings),
            (std::vector<SettingKV>{{"wall_line_count", "3"}, {"infill_sparse_density", "15"}}));
  EXPECT_EQ(slicer_settings("slic3r", {{"infill_sparse_density", "15"}, {"layer_height", "0.2"}}),
            (std::vector<SettingKV>{{"fill_density", "15%"}, {"layer_height", "0.2"}}));
  spec.configs = {"slic3r=s.ini"};
  EXPECT_FALSE(expand_variants(spec));  // a config for a slicer that is not in the comparison
}

// Shares and merges run slicer variants unchanged: the manifest keeps the back-end, the
// timeout and the definition; the programs' paths do not change the plan id.
TEST(SlicerBackend, ManifestKeepsTheSlicerBackEnd) {
  ComparePlan plan;
  plan.mesh_path = "part.stl";
  plan.slicer_timeout_s = 42;
  plan.cura_definition = "/defs/creality_ender3.def.json";
  plan.slicer_paths = {{"cura", "/opt/CuraEngine"}};
  SweepSpec spec;
  spec.slicers = {"prusa-slicer", "cura"};
  spec.axes = {SweepAxis{"layer_height", {"0.1", "0.2"}}};
  plan.variants = expand_variants(spec).value();
  auto back = parse_compare_plan(compare_plan_json(plan), "plan.json");
  ASSERT_TRUE(back) << back.error().describe();
  EXPECT_EQ(back->variants, plan.variants);
  EXPECT_EQ(back->slicer_timeout_s, 42);
  EXPECT_EQ(back->cura_definition, plan.cura_definition);
  EXPECT_EQ(back->slicer_paths, plan.slicer_paths);
  ComparePlan elsewhere = plan;
  elsewhere.slicer_paths = {{"cura", "/usr/bin/CuraEngine"}};
  EXPECT_EQ(compare_plan_id(elsewhere), compare_plan_id(plan));
}

TEST(SlicerBackend, MissingSlicerNamesTheDebianPackage) {
  const char* old = std::getenv("PATH");
  const std::string saved = old ? old : "";
  const auto empty = test::temp_dir("slicer_empty_path");
  ::setenv("PATH", empty.c_str(), 1);
  auto cura = find_slicer_program("cura", "");
  auto slic3r = find_slicer_program("slic3r", "");
  ::setenv("PATH", saved.c_str(), 1);
  ASSERT_FALSE(cura);
  EXPECT_EQ(cura.error().code, ErrorCode::usage);  // exit 2
  EXPECT_NE(cura.error().message.find("cura-engine"), std::string::npos) << cura.error().message;
  ASSERT_FALSE(slic3r);
  EXPECT_NE(slic3r.error().message.find("package slic3r"), std::string::npos);
  auto wrong = find_slicer_program("prusa-slicer", "/nonexistent/prusa-slicer");
  ASSERT_FALSE(wrong);
  EXPECT_EQ(wrong.error().code, ErrorCode::usage);
}

TEST(SlicerBackend, FailingSlicerReportsItsOwnMessage) {
  const auto dir = test::temp_dir("slicer_failing");
  const auto fake =
      script(dir, "prusa-slicer", "echo 'Objects could not fit on the bed' >&2; exit 1");
  SlicerProgram p{"prusa-slicer", fake.string(), "PrusaSlicer 9.9"};
  SlicerJob job{"part.stl", "", {}, "", (dir / "out.gcode").string()};
  std::string command;
  const Status st = run_external_slicer(p, job, 10, &command);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("Objects could not fit on the bed"), std::string::npos)
      << st.error().message;
  EXPECT_NE(st.error().message.find("exit 1"), std::string::npos);
  EXPECT_NE(command.find("--export-gcode"), std::string::npos);
}

TEST(SlicerBackend, TheSlicersErrorLineBeatsItsHelpText) {
  const auto dir = test::temp_dir("slicer_help");
  const auto fake =
      script(dir, "prusa-slicer",
             "echo 'Unknown option --layer-heigth'; echo; echo 'Usage: prusa-slicer [ ACTIONS ]';"
             "echo '  --help  shows this'; echo '  --info  prints info'; exit 1");
  SlicerProgram p{"prusa-slicer", fake.string(), ""};
  SlicerJob job{"part.stl", "", {}, "", (dir / "out.gcode").string()};
  const Status st = run_external_slicer(p, job, 10);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("Unknown option --layer-heigth"), std::string::npos)
      << st.error().message;
  EXPECT_EQ(st.error().message.find("--info"), std::string::npos) << st.error().message;
}

TEST(SlicerBackend, HangingSlicerIsStoppedAtTheTimeout) {
  const auto dir = test::temp_dir("slicer_hanging");
  const auto fake = script(dir, "slic3r", "sleep 30");
  SlicerProgram p{"slic3r", fake.string(), ""};
  SlicerJob job{"part.stl", "", {}, "", (dir / "out.gcode").string()};
  const Status st = run_external_slicer(p, job, 0.3);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("--slicer-timeout"), std::string::npos) << st.error().message;
  const ProcessRun r = run_process({fake.string()}, {}, 0.2);
  EXPECT_TRUE(r.timed_out);
  EXPECT_LT(r.seconds, 5.0);
}

// Two variants with the same effective settings: the slicer runs once, both rows carry its
// message; the sweep goes on past the failures.
TEST(SlicerBackend, SharedVariantsAreSlicedOnceAndFailuresAreRows) {
  const auto dir = test::temp_dir("slicer_shared");
  const auto log = dir / "calls.log";
  const auto fake = script(dir, "prusa-slicer",
                           "case \"$1\" in --help) echo 'PrusaSlicer-7.7.7+test'; exit 0;; esac\n"
                           "echo called >> '" +
                               log.string() + "'\necho 'Nothing to print' >&2; exit 3");
  auto printer = load_printer_profile("ender3");
  ASSERT_TRUE(printer);
  auto part = prepare_shared_part(test::make_cube_mm(10), "cube", *printer);
  ASSERT_TRUE(part) << part.error().describe();
  ComparePlan plan;
  plan.printer = "ender3";
  plan.mesh_path = (dir / "cube.stl").string();
  plan.slicer_paths = {{"prusa-slicer", fake.string()}};
  VariantSpec a;
  a.slicer = "prusa-slicer";
  a.settings = {{"layer_height", "0.2"}, {"perimeters", "2"}};
  a.label = "a";
  VariantSpec b = a;
  b.index = 1;
  b.label = "b";
  b.settings = {{"perimeters", "2"}, {"layer_height", "0.3"}, {"layer_height", "0.2"}};
  plan.variants = {a, b};
  ASSERT_TRUE(validate_plan(plan));
  CompareRunOptions options;
  options.out_dir = dir / "out";
  options.variant_reports = false;
  auto result = run_compare(*part, plan, {}, options);
  ASSERT_TRUE(result) << result.error().describe();
  ASSERT_EQ(result->variants.size(), 2u);
  for (const auto& row : result->variants) {
    EXPECT_FALSE(row.ran);
    EXPECT_NE(row.error.find("Nothing to print"), std::string::npos) << row.error;
    EXPECT_NE(row.error.find("PrusaSlicer 7.7.7"), std::string::npos) << row.error;
  }
  std::ifstream in(log);
  int calls = 0;
  for (std::string line; std::getline(in, line);) ++calls;
  EXPECT_EQ(calls, 1);
  // The JSON keeps the back-end of each variant.
  auto back = parse_compare_json(compare_json(*result), "compare.json");
  ASSERT_TRUE(back) << back.error().describe();
  EXPECT_EQ(back->variants[0].variant.slicer, "prusa-slicer");
}

// compare of the 20 mm cube through the real PrusaSlicer: `config`, one swept axis.
Result<CompareResult> compare_cube_with_prusa_slicer(const std::string& config,
                                                     const SweepAxis& axis, const fs::path& out) {
  const std::string mesh = test::source_path("samples/models/calibration_cube_20mm.stl").string();
  auto printer = load_printer_profile("auto");
  if (!printer) return printer.error();
  auto part = prepare_shared_part(fs::path(mesh), *printer);
  if (!part) return part.error();
  ComparePlan plan;
  plan.mesh_path = mesh;
  plan.verify.voxel_mm = 0.1;
  SweepSpec spec;
  spec.slicers = {"prusa-slicer"};
  spec.configs = {config};
  spec.axes = {axis};
  auto variants = expand_variants(spec);
  if (!variants) return variants.error();
  plan.variants = std::move(*variants);
  if (auto st = validate_plan(plan); !st) return st.error();
  CompareRunOptions options;
  options.out_dir = out;
  options.variant_reports = false;
  return run_compare(*part, plan, {}, options);
}

// The real PrusaSlicer, when installed: a layer-height pair of the 20 mm cube.
TEST(SlicerBackend, RealPrusaSlicerSweep) {
  auto found = find_slicer_program("prusa-slicer", "");
  if (!found) GTEST_SKIP() << "prusa-slicer is not installed (" << found.error().message << ")";
  EXPECT_NE(found->version.find("PrusaSlicer"), std::string::npos) << found->version;
  const auto dir = test::temp_dir("slicer_real_prusa");
  const std::string ini = test::source_path("samples/configs/ender3_prusaslicer.ini").string();
  auto result = compare_cube_with_prusa_slicer(ini, SweepAxis{"layer_height", {"0.1", "0.3"}}, dir);
  ASSERT_TRUE(result) << result.error().describe();
  ASSERT_EQ(result->variants.size(), 2u);
  for (const auto& row : result->variants) {
    ASSERT_TRUE(row.ran) << row.error;
    EXPECT_NE(row.slicer.find("PrusaSlicer"), std::string::npos);
    EXPECT_NE(row.command.find("--layer-height"), std::string::npos);
  }
  EXPECT_GT(result->variants[0].print_time_s, result->variants[1].print_time_s);
  EXPECT_NEAR(result->variants[0].layer_height_mm, 0.1, 0.005);
  EXPECT_NEAR(result->variants[1].layer_height_mm, 0.3, 0.005);
}

// A PrusaSlicer 3MF project as the config: its stored settings reach the real PrusaSlicer
// (through an .ini beside the G-code, since its --load reads no 3MF) and the twin.
TEST(SlicerBackend, RealPrusaSlicerTakesA3mfProjectAsTheConfig) {
  auto found = find_slicer_program("prusa-slicer", "");
  if (!found) GTEST_SKIP() << "prusa-slicer is not installed (" << found.error().message << ")";
  const auto dir = test::temp_dir("slicer_real_prusa_3mf");
  auto ini = read_file(test::source_path("samples/configs/ender3_prusaslicer.ini"));
  ASSERT_TRUE(ini);
  std::string config;  // the sample's settings with 0.3 mm layers, as a project stores them
  for (std::size_t at = 0; at < ini->size();) {
    std::size_t end = ini->find('\n', at);
    if (end == std::string::npos) end = ini->size();
    const std::string line = ini->substr(at, end - at);
    config += line.rfind("layer_height =", 0) == 0 ? "layer_height = 0.3" : line;
    config += '\n';
    at = end + 1;
  }
  const fs::path project = dir / "ender3.3mf";
  std::ofstream(project, std::ios::binary) << test::make_zip(
      {{"3D/3dmodel.model", "<model/>"}, {"Metadata/Slic3r_PE.config", config}}, true);
  auto result =
      compare_cube_with_prusa_slicer(project.string(), SweepAxis{"perimeters", {"2"}}, dir / "out");
  ASSERT_TRUE(result) << result.error().describe();
  ASSERT_EQ(result->variants.size(), 1u);
  const auto& row = result->variants[0];
  ASSERT_TRUE(row.ran) << row.error;
  EXPECT_NE(row.command.find(".ini"), std::string::npos) << row.command;
  EXPECT_NEAR(row.layer_height_mm, 0.3, 0.01);
}

TEST(SlicerBackend, A3mfProjectForCuraIsRefusedWithTheReason) {
  const auto dir = test::temp_dir("slicer_cura_3mf");
  const fs::path project = dir / "cura.3mf";
  std::ofstream(project, std::ios::binary) << test::make_zip({{"3D/3dmodel.model", "<m/>"}}, false);
  auto r = slicer_config_file("cura", project.string(), dir / "x.ini");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("key=value"), std::string::npos) << r.error().message;
  // Without PrusaSlicer's settings in it, PrusaSlicer's back-end names the missing entry.
  auto p = slicer_config_file("prusa-slicer", project.string(), dir / "x.ini");
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().message.find("Slic3r_PE.config"), std::string::npos);
  // An .ini passes through untouched.
  auto plain = slicer_config_file(
      "prusa-slicer", test::source_path("samples/configs/ender3_prusaslicer.ini").string(),
      dir / "x.ini");
  ASSERT_TRUE(plain);
  EXPECT_EQ(fs::path(*plain).filename(), "ender3_prusaslicer.ini");
  EXPECT_FALSE(fs::exists(dir / "x.ini"));
}

// The real CuraEngine with the cura package's Ender-3 definition, when both are installed.
TEST(SlicerBackend, RealCuraEngineSlicesWithTheDefinitionsPrinter) {
  auto found = find_slicer_program("cura", "");
  if (!found) GTEST_SKIP() << "CuraEngine is not installed (" << found.error().message << ")";
  const fs::path def = "/usr/share/cura/resources/definitions/creality_ender3.def.json";
  if (!fs::exists(def)) GTEST_SKIP() << "the cura package (Cura's definitions) is not installed";
  EXPECT_NE(found->version.find("CuraEngine"), std::string::npos) << found->version;
  const auto dir = test::temp_dir("slicer_real_cura");
  const std::string mesh = test::source_path("samples/models/calibration_cube_20mm.stl").string();
  auto printer = load_printer_profile("auto");
  ASSERT_TRUE(printer);
  auto part = prepare_shared_part(fs::path(mesh), *printer);
  ASSERT_TRUE(part) << part.error().describe();
  ComparePlan plan;
  plan.mesh_path = mesh;
  plan.verify.voxel_mm = 0.1;
  plan.cura_definition = def.string();
  SweepSpec spec;
  spec.slicers = {"cura"};
  spec.configs = {test::source_path("samples/configs/ender3_cura.cfg").string()};
  spec.axes = {SweepAxis{"layer_height", {"0.15", "0.3"}}};
  plan.variants = expand_variants(spec).value();
  ASSERT_TRUE(validate_plan(plan));
  CompareRunOptions options;
  options.out_dir = dir;
  options.variant_reports = false;
  auto result = run_compare(*part, plan, {}, options);
  ASSERT_TRUE(result) << result.error().describe();
  for (const auto& row : result->variants) {
    ASSERT_TRUE(row.ran) << row.error;
    EXPECT_NE(row.command.find("CURA_ENGINE_SEARCH_PATH="), std::string::npos);
    EXPECT_NE(row.command.find("-s infill_line_distance="), std::string::npos);
  }
  EXPECT_GT(result->variants[0].print_time_s, result->variants[1].print_time_s);
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

TEST(SlicerBackendCli, MissingOrUnknownSlicerExitsTwo) {
  const std::string cube = test::source_path("samples/models/calibration_cube_20mm.stl").string();
  const auto out = test::temp_dir("slicer_cli");
  auto unknown =
      test::run_cli("compare " + cube + " --slicer simplify3d -o " + (out / "a").string());
  EXPECT_EQ(unknown.exit_code, 2) << unknown.err;
  auto missing =
      test::run_cli("verify " + cube + " --slicer slic3r --slicer-path /nonexistent/slic3r --out " +
                    (out / "b").string());
  EXPECT_EQ(missing.exit_code, 2) << missing.err;
  EXPECT_NE(missing.err.find("--slicer-path"), std::string::npos) << missing.err;
  auto no_definition =
      test::run_cli("compare " + cube + " --slicer cura -o " + (out / "c").string());
  EXPECT_EQ(no_definition.exit_code, 2) << no_definition.err;
  EXPECT_NE(no_definition.err.find("--cura-definition"), std::string::npos) << no_definition.err;
}

}  // namespace
}  // namespace printtwin
