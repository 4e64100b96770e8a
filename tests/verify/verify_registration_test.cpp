// verify's registration end to end: --place with a rotation, --units, --object, a G-code of
// another part, and the real files of ../shared/realworld (skipped when absent).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <nlohmann/json.hpp>

#include "printtwin/io.hpp"
#include "printtwin/verify.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

using test::read_json;

TEST(VerifyPlaceOption, ParsesTranslationRotationAndErrors) {
  VerifySettings s;
  ASSERT_TRUE(parse_place_option("110,110,0", s).ok());
  EXPECT_EQ(*s.place_mm, Vec3(110, 110, 0));
  EXPECT_FALSE(s.place_rotation_deg);
  ASSERT_TRUE(parse_place_option("110, 95.5, 0, 30", s).ok());
  EXPECT_EQ(*s.place_rotation_deg, Vec3(0, 0, 30));
  ASSERT_TRUE(parse_place_option("1,2,3;90,0,-45", s).ok());
  EXPECT_EQ(*s.place_mm, Vec3(1, 2, 3));
  EXPECT_EQ(*s.place_rotation_deg, Vec3(90, 0, -45));
  for (const char* bad :
       {"", "1,2", "1,2,3,4,5", "1,2,x", "1,2,3;4,5", "1,2;3,4,5", "1,2,3;", "nan,1,2", "1,,2"}) {
    VerifySettings t;
    const auto st = parse_place_option(bad, t);
    ASSERT_FALSE(st.ok()) << bad;
    EXPECT_NE(st.error().message.find("--place"), std::string::npos);
    EXPECT_NE(st.error().message.find("x,y,z;rx,ry,rz"), std::string::npos);
  }
}

TEST(VerifyUnitsOption, NamesAndNumbers) {
  VerifySettings s;
  ASSERT_TRUE(parse_units_option("m", s).ok());
  EXPECT_EQ(*s.mesh_scale, 1000);
  ASSERT_TRUE(parse_units_option("in", s).ok());
  EXPECT_EQ(*s.mesh_scale, 25.4);
  ASSERT_TRUE(parse_units_option("2.5", s).ok());
  EXPECT_EQ(*s.mesh_scale, 2.5);
  for (const char* bad : {"", "feet", "0", "-1", "inf"})
    EXPECT_FALSE(parse_units_option(bad, s).ok()) << bad;
}

TEST(VerifyRegistrationCli, AnotherPartsGcodeIsSaidPlainly) {
  // A 30 x 8 x 4 mm bar against the G-code of a 10 mm cube. Registration reads the G-code's
  // wall points, not the voxels: 0.2 mm voxels suffice. The deviation of a part this far off
  // is the deviation stage's slow case (at 0.1 mm: 1.2 s CPU in Release, minutes under ASan).
  const auto dir = test::temp_dir("verify_wrong_part");
  const auto stl = dir / "bar.stl";
  ASSERT_TRUE(save_stl(make_box_mesh(Vec3(0, 0, 0), Vec3(30, 8, 4)), stl).ok());
  const auto run = test::run_cli("verify " + stl.string() + " --gcode " +
                                 test::source_path("samples/gcode/prusa_cube10.gcode").string() +
                                 " --voxel 0.2 --out " + (dir / "r").string());
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.out.find("does not appear to be this part"), std::string::npos) << run.out;
  const auto j = read_json(dir / "r" / "report.json");
  const auto& reg = j["deviation"]["registration"];
  EXPECT_EQ(reg["matches"], false);
  bool finding = false;
  for (const auto& f : j["findings"]) finding = finding || f["code"] == "registration_mismatch";
  EXPECT_TRUE(finding);
}

TEST(VerifyRegistrationCli, PlaceWithRotationAndUnknownObject) {
  const auto dir = test::temp_dir("verify_place_rot");
  const auto stl = dir / "cube.stl";
  ASSERT_TRUE(save_stl(test::make_cube_mm(10.0, Vec3(-5, -5, 0)), stl).ok());
  const std::string gcode = test::source_path("samples/gcode/prusa_cube10.gcode").string();
  // A cube turned 90 degrees about Z is the same cube: the given pose fits.
  auto run = test::run_cli("verify " + stl.string() + " --gcode " + gcode +
                           " --voxel 0.1 --tolerance 0.3 --place '110,110,0,90' --out " +
                           (dir / "r").string());
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  const auto j = read_json(dir / "r" / "report.json");
  EXPECT_EQ(j["deviation"]["registration"]["method"], "--place");
  EXPECT_NEAR(j["deviation"]["registration"]["euler_xyz_deg"][2].get<double>(), 90, 1e-9);
  EXPECT_NEAR(j["settings"]["place_rotation_deg"][2].get<double>(), 90, 1e-9);
  run = test::run_cli("verify " + stl.string() + " --gcode " + gcode + " --place '1,2' --out " +
                      (dir / "x").string());
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("--place"), std::string::npos);
  run = test::run_cli("verify " + stl.string() + " --units in --out " + (dir / "z").string());
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("--units applies"), std::string::npos) << run.err;
  run = test::run_cli("verify " + stl.string() + " --gcode " + gcode + " --object nothing --out " +
                      (dir / "y").string());
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("no such object"), std::string::npos) << run.err;
}

TEST(VerifyRegistrationCli, PartInMetresIsCheckedAsPrinted) {
  // The 10 mm cube written in metres (0.01 units across) against its G-code: the
  // registration finds the scale, and the check judges the part at that scale (10 mm, 1000
  // mm3), not the 0.01 mm speck the file's numbers would be ("nothing will print").
  const auto dir = test::temp_dir("verify_metres_check");
  const auto stl = dir / "cube_m.stl";
  ASSERT_TRUE(save_stl(test::make_cube_mm(0.01, Vec3(-0.005, -0.005, 0)), stl).ok());
  const auto run = test::run_cli("verify " + stl.string() + " --gcode " +
                                 test::source_path("samples/gcode/prusa_cube10.gcode").string() +
                                 " --voxel 0.1 --tolerance 0.3 --out " + (dir / "r").string());
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  const auto j = read_json(dir / "r" / "report.json");
  EXPECT_DOUBLE_EQ(j["deviation"]["registration"]["scale"].get<double>(), 1000);
  EXPECT_NEAR(j["check"]["volume_mm3"].get<double>(), 1000, 1e-3);  // float STL
  EXPECT_NEAR(j["check"]["bbox_mm"]["max"][2].get<double>(), 10, 1e-4);
  EXPECT_EQ(j["check"]["errors"], 0);
  for (const auto& f : j["findings"]) EXPECT_NE(f["severity"], "error") << f.dump();
}

/// Klipper-style G-code of two labelled boxes (EXCLUDE_OBJECT): walls (outer perimeter and
/// one inner loop) and a sparse zig-zag per 0.2 mm layer. `boxes`: name, min corner, size.
std::string two_box_gcode(const std::vector<std::pair<std::string, Box3>>& boxes) {
  std::string g = "G90\nM83\nM104 S210\nM140 S60\nG28\nM109 S210\nM190 S60\n";
  const double e_per_mm = 0.4 * 0.2 / (M_PI * 1.75 * 1.75 / 4);
  char buf[160];
  const auto move = [&](double x, double y, double e) {
    std::snprintf(buf, sizeof buf, "G1 X%.3f Y%.3f E%.5f F1800\n", x, y, e);
    g += buf;
  };
  const auto loop = [&](const Box3& b, double inset) {
    const double x0 = b.min.x() + inset, y0 = b.min.y() + inset, x1 = b.max.x() - inset,
                 y1 = b.max.y() - inset;
    std::snprintf(buf, sizeof buf, "G0 X%.3f Y%.3f F6000\n", x0, y0);
    g += buf;
    move(x1, y0, (x1 - x0) * e_per_mm);
    move(x1, y1, (y1 - y0) * e_per_mm);
    move(x0, y1, (x1 - x0) * e_per_mm);
    move(x0, y0, (y1 - y0) * e_per_mm);
  };
  const double top = std::max(boxes[0].second.max.z(), boxes[1].second.max.z());
  for (int layer = 1; 0.2 * layer <= top + 1e-9; ++layer) {
    const double z = 0.2 * layer;
    std::snprintf(buf, sizeof buf, ";LAYER_CHANGE\n;Z:%.1f\nG0 Z%.3f F600\n", z, z);
    g += buf;
    for (const auto& [name, b] : boxes) {
      if (z > b.max.z() + 1e-9) continue;
      g += "EXCLUDE_OBJECT_START NAME=" + name + "\n;TYPE:External perimeter\n";
      loop(b, 0.2);
      g += ";TYPE:Perimeter\n";
      loop(b, 0.6);
      g += ";TYPE:Internal infill\n";
      for (double x = b.min.x() + 1.5; x < b.max.x() - 1.5; x += 2.0) {
        std::snprintf(buf, sizeof buf, "G0 X%.3f Y%.3f F6000\n", x, b.min.y() + 0.8);
        g += buf;
        move(x, b.max.y() - 0.8, (b.max.y() - b.min.y() - 1.6) * e_per_mm);
      }
      g += "EXCLUDE_OBJECT_END NAME=" + name + "\n";
    }
  }
  return g + "M104 S0\nM140 S0\n";
}

TEST(VerifyRegistrationCli, BedOfTwoLabelledObjectsMatchesTheOneThatFits) {
  const auto dir = test::temp_dir("verify_two_objects");
  const auto gcode = dir / "bed.gcode";
  ASSERT_TRUE(write_file_atomic(
                  gcode, two_box_gcode({{"tower", Box3{Vec3(60, 100, 0), Vec3(72, 110, 16)}},
                                        {"plate", Box3{Vec3(140, 90, 0), Vec3(170, 120, 4)}}}))
                  .ok());
  const auto stl = dir / "plate.stl";  // the plate, designed around its own origin
  ASSERT_TRUE(save_stl(make_box_mesh(Vec3(-15, -15, 0), Vec3(15, 15, 4)), stl).ok());
  // 0.2 mm voxels, as in AnotherPartsGcodeIsSaidPlainly: the deposit spans both objects
  // (110 x 30 x 16 mm) and the --object tower run measures a part 15 mm off.
  const std::string base =
      "verify " + stl.string() + " --gcode " + gcode.string() + " --voxel 0.2 --tolerance 0.3 ";
  auto run = test::run_cli(base + "--out " + (dir / "a").string());
  EXPECT_NE(run.out.find("object plate"), std::string::npos) << run.out << run.err;
  auto j = read_json(dir / "a" / "report.json");
  const auto& reg = j["deviation"]["registration"];
  EXPECT_EQ(reg["object"], "plate");
  EXPECT_EQ(reg["matches"], true) << reg;
  EXPECT_NEAR(reg["translation_mm"][0].get<double>(), 155, 0.05);
  EXPECT_NEAR(reg["translation_mm"][1].get<double>(), 105, 0.05);
  // The tower's voxels are not in the analysed region: no excess from them.
  EXPECT_LT(j["deviation"]["max_excess_mm"].get<double>(), 0.3);
  // Told to measure the tower, the plate mesh does not fit it: exit 1 and the reason.
  run = test::run_cli(base + "--object tower --out " + (dir / "b").string());
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.out.find("does not appear to be this part"), std::string::npos) << run.out;
  run = test::run_cli(base + "--object lid --out " + (dir / "c").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("'tower', 'plate'"), std::string::npos) << run.err;
}

TEST(VerifyRegistrationPrusaSlicer, FourBridgesSideBySideArePlacedByAllFour) {
  // Four bridges of different spans side by side, 9 mm apart: four islands on the bed. The
  // largest alone is centred 13.5 mm from the part's centre in Y and 0 in X.
  if (std::system("command -v prusa-slicer >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "prusa-slicer not installed";
  const auto dir = test::temp_dir("verify_bridges");
  Mesh mesh;
  const double spans[4] = {40, 30, 20, 12};
  for (int i = 0; i < 4; ++i) {
    const double y = 9.0 * i;
    for (const Mesh& b : {make_box_mesh(Vec3(0, y, 0), Vec3(5, y + 5, 10)),
                          make_box_mesh(Vec3(spans[i] - 5, y, 0), Vec3(spans[i], y + 5, 10)),
                          make_box_mesh(Vec3(0, y, 10), Vec3(spans[i], y + 5, 12))}) {
      const auto base = static_cast<std::uint32_t>(mesh.vertices_mm.size());
      mesh.vertices_mm.insert(mesh.vertices_mm.end(), b.vertices_mm.begin(), b.vertices_mm.end());
      for (const auto& t : b.triangles)
        mesh.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    }
  }
  const auto stl = dir / "bridges.stl";
  const auto gcode = dir / "bridges.gcode";
  ASSERT_TRUE(save_stl(mesh, stl).ok());
  const std::string cmd = "timeout 300 prusa-slicer --export-gcode --center 110,110 -o " +
                          gcode.string() + " " + stl.string() + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  VerifyOptions options;
  options.mesh_path = stl;
  options.gcode_path = gcode;
  options.settings.voxel_mm = 0.1;
  auto r = verify(options);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Registration& reg = r->registration;
  EXPECT_TRUE(reg.matches) << reg.mismatch;
  EXPECT_TRUE(reg.transform.translation_only());
  // PrusaSlicer centres the object's box (40 x 32 mm from the origin) on (110, 110).
  EXPECT_NEAR(reg.transform.translation_mm.x(), 90, 0.05);
  EXPECT_NEAR(reg.transform.translation_mm.y(), 94, 0.05);
  EXPECT_GT(reg.coverage_pct, 95);
  // The decks sag over their spans as the bridge model says (0.51 mm mid-span at 40 mm, 0.29 at
  // 30 mm): the bridges' undersides are part of the worst 5 %.
  EXPECT_LT(r->deviation.deposit_to_mesh.p95_abs_mm, 0.3);
}

/// A G-code and its model from shared/realworld; empty paths when either is missing.
std::pair<std::filesystem::path, std::filesystem::path> realworld_pair(const char* gcode,
                                                                       const char* model) {
  const auto found = test::realworld_dir();
  if (!found) return {};
  const std::filesystem::path rw = *found;
  if (!std::filesystem::exists(rw / "gcode" / gcode) ||
      !std::filesystem::exists(rw / "models" / model))
    return {};
  return {rw / "gcode" / gcode, rw / "models" / model};
}

// The bracket was laid flat before slicing: registration finds the turn, and the print passes
// a 0.3 mm gate: its sharp leg corners are joined round as a nozzle leaves them, and the plate
// over Cura's support rests on the support lines across the support's Z gap instead of
// sagging as a 44 mm bridge.
TEST(VerifyRealworld, CuraBracketIsFoundLaidFlatAndPassesAtPointThree) {
  const auto [gcode, stl] = realworld_pair("cura-3.6.0_Ender3_bedlevel_base_bracket_FR.gcode",
                                           "ender3_bedlevel_base_bracket_FR.stl");
  if (gcode.empty())
    GTEST_SKIP() << "no shared/realworld with cura-3.6.0_Ender3_bedlevel_base_bracket_FR.gcode";
  VerifyOptions options;
  options.mesh_path = stl;
  options.gcode_path = gcode;
  options.settings.gates.tolerance_mm = 0.3;
  auto r = verify(options);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Registration& reg = r->registration;
  EXPECT_TRUE(reg.matches) << reg.mismatch;
  EXPECT_FALSE(reg.transform.rotation.isIdentity(1e-6));
  EXPECT_LT(reg.residual_rms_mm, 0.5);
  EXPECT_GT(reg.coverage_pct, 95);
  EXPECT_TRUE(r->pass);
  EXPECT_LT(r->deviation.deposit_to_mesh.p95_abs_mm, 0.3);
  EXPECT_LT(r->deviation.mesh_to_deposit.max_mm, 0.3);
  EXPECT_GT(r->deviation.mesh_to_deposit.min_mm, -0.3);
}

TEST(VerifyRealworld, KisslicerLidInMetresRegisters) {
  const auto [gcode, stl] = realworld_pair("kisslicer-1.4.5.10_musicutility_lid.gcode",
                                           "kisslicer_pair_musicutility_lid.stl");
  if (gcode.empty())
    GTEST_SKIP() << "no shared/realworld with kisslicer-1.4.5.10_musicutility_lid.gcode";
  // KISSlicer's origin is the bed's centre: a 220 mm bed from -110 to 110 (the file states
  // only its printer's name), given as a profile so that no move is clamped.
  const auto dir = test::temp_dir("verify_lid");
  const auto printer = dir / "centred220.json";
  ASSERT_TRUE(write_file_atomic(printer, R"({"base": "ender3", "name": "centred 220",
    "bed_min_x_mm": -110, "bed_min_y_mm": -110, "bed_max_x_mm": 110, "bed_max_y_mm": 110,
    "travel_min_x_mm": -110, "travel_min_y_mm": -110, "travel_max_x_mm": 110, "travel_max_y_mm": 110})")
                  .ok());
  VerifyOptions options;
  options.mesh_path = stl;
  options.gcode_path = gcode;
  options.settings.voxel_mm = 0.1;
  options.settings.printer = printer.string();
  auto r = verify(options);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Registration& reg = r->registration;
  EXPECT_DOUBLE_EQ(reg.transform.scale, 1000);
  // Printed standing on its long edge.
  EXPECT_NEAR(std::abs(reg.transform.rotation(2, 1)), 1.0, 1e-9) << reg.transform.rotation;
  EXPECT_TRUE(reg.matches) << reg.mismatch;
  EXPECT_GT(reg.coverage_pct, 90);
}

}  // namespace
}  // namespace printtwin
