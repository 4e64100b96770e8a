#include <algorithm>
// Tests of printtwin's slicer: layers, perimeters, flow, thin walls, settings, .ini, CLI.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <sstream>
#include <string>

#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/slice.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

// Facts read back from our own G-code: per layer and type, the extent of the XY points and
// the extruded filament; the widths announced.
struct GcodeFacts {
  int layers = 0;
  std::map<std::string, double> e_by_type;
  std::map<int, std::map<std::string, Box3>> extent;  // layer -> type -> box of end points
  std::map<std::string, std::vector<double>> widths;
  bool relative_e = false;
};

double field(const std::string& line, char c, bool& found) {
  found = false;
  const auto pos = line.find(std::string(" ") + c);
  if (pos == std::string::npos) return 0;
  found = true;
  return std::stod(line.substr(pos + 2));
}

GcodeFacts read_facts(const std::string& gcode) {
  GcodeFacts f;
  std::istringstream in(gcode);
  std::string line, type = "Custom";
  int layer = -1;
  double width = 0;
  while (std::getline(in, line)) {
    if (line.rfind(";LAYER_CHANGE", 0) == 0) {
      ++layer;
      ++f.layers;
    } else if (line.rfind(";TYPE:", 0) == 0) {
      type = line.substr(6);
    } else if (line.rfind(";WIDTH:", 0) == 0) {
      width = std::stod(line.substr(7));
    } else if (line.rfind("M83", 0) == 0) {
      f.relative_e = true;
    } else if (line.rfind("G1 ", 0) == 0 && layer >= 0) {
      bool hx = false, hy = false, he = false;
      const double x = field(line, 'X', hx);
      const double y = field(line, 'Y', hy);
      const double e = field(line, 'E', he);
      if (he && e > 0 && (hx || hy)) {
        f.e_by_type[type] += e;
        auto& ws = f.widths[type + (layer == 0 ? "@0" : "")];  // first layer apart
        if (ws.empty() || ws.back() != width) ws.push_back(width);
        f.extent[layer][type].extend(Vec3(x, y, 0));
      }
    }
  }
  return f;
}

SliceSettings no_time() {
  SliceSettings s;
  s.estimate_time = false;
  return s;
}

TEST(SliceLayers, CubeLayerCountAndHeights) {
  const Mesh cube = place_on_bed(test::make_cube_mm(20.0), 110, 110);
  auto layers = slice_layers(cube, no_time());
  ASSERT_TRUE(layers.ok()) << layers.error().describe();
  ASSERT_EQ(layers->size(), 100u);
  for (const auto& l : *layers) {
    EXPECT_NEAR(l.height_mm, 0.2, 1e-9);
    EXPECT_NEAR(l.slice_z_mm, l.print_z_mm - 0.1, 1e-9);
    ASSERT_EQ(l.polygons.size(), 1u);
    EXPECT_EQ(l.polygons[0].size(), 4u);
  }
  EXPECT_NEAR(layers->back().print_z_mm, 20.0, 1e-9);
}

TEST(SliceLayers, FirstLayerAndThinnerLastLayer) {
  SliceSettings s = no_time();
  s.first_layer_height_mm = 0.3;
  s.layer_height_mm = 0.15;
  // 0.3 + 64 x 0.15 = 9.9; the rest (0.1 mm) makes a thinner last layer.
  const auto z = layer_print_z(10.0, s);
  ASSERT_EQ(z.size(), 66u);
  EXPECT_NEAR(z[0], 0.3, 1e-12);
  EXPECT_NEAR(z[1], 0.45, 1e-12);
  EXPECT_NEAR(z[64], 9.9, 1e-9);
  EXPECT_NEAR(z[65], 10.0, 1e-12);
  // A rest under a quarter layer is dropped.
  EXPECT_EQ(layer_print_z(9.92, s).size(), 65u);
}

TEST(SliceLayers, HoleIsClockwiseAndAreaMatches) {
  // A 20 mm cube with a 10 mm square hole through it: two boxes sliced as one mesh would
  // overlap, so build the frame from four boxes that touch.
  Mesh m;
  auto add = [&m](const Mesh& b) {
    const auto base = static_cast<std::uint32_t>(m.vertices_mm.size());
    m.vertices_mm.insert(m.vertices_mm.end(), b.vertices_mm.begin(), b.vertices_mm.end());
    for (auto t : b.triangles) m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  };
  add(make_box_mesh(Vec3(0, 0, 0), Vec3(20, 5, 10)));
  add(make_box_mesh(Vec3(0, 15, 0), Vec3(20, 20, 10)));
  add(make_box_mesh(Vec3(0, 5, 0), Vec3(5, 15, 10)));
  add(make_box_mesh(Vec3(15, 5, 0), Vec3(20, 15, 10)));
  auto layers = slice_layers(m, no_time());
  ASSERT_TRUE(layers.ok()) << layers.error().describe();
  const auto& polys = (*layers)[10].polygons;
  ASSERT_EQ(polys.size(), 2u);  // touching boxes are merged: one outer, one hole
  double total = 0;
  int holes = 0;
  for (const auto& p : polys) {
    double a = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const auto& u = p[i];
      const auto& v = p[(i + 1) % p.size()];
      a += double(u.x_um) * double(v.y_um) - double(v.x_um) * double(u.y_um);
    }
    a *= 0.5e-6;
    if (a < 0) ++holes;
    total += a;
  }
  EXPECT_EQ(holes, 1);
  EXPECT_NEAR(total, 400.0 - 100.0, 0.01);
}

TEST(SliceLayers, VerticesOnASlicingPlaneGiveTheWholeOutline) {
  // A 10 mm box whose sides have a ring of vertices exactly at a slicing plane (z = 2.625:
  // 0.25 mm layers cut at 0.125 + 0.25 k, all exact in binary). The triangles below the ring
  // have their top corners on the plane: they must be cut there too, or the layer loses its
  // outline (CAD and scanned meshes put vertices on round heights all the time).
  Mesh m;
  const double zs[3] = {0.0, 2.625, 5.0};
  const double xy[4][2] = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  for (double z : zs)
    for (const auto& c : xy) m.vertices_mm.emplace_back(c[0], c[1], z);
  auto at = [](int ring, int corner) { return static_cast<std::uint32_t>(ring * 4 + corner % 4); };
  for (int ring = 0; ring < 2; ++ring)
    for (int c = 0; c < 4; ++c) {  // outward: counter-clockwise seen from outside
      m.triangles.push_back({at(ring, c), at(ring, c + 1), at(ring + 1, c + 1)});
      m.triangles.push_back({at(ring, c), at(ring + 1, c + 1), at(ring + 1, c)});
    }
  m.triangles.push_back({at(0, 0), at(0, 2), at(0, 1)});  // bottom, facing down
  m.triangles.push_back({at(0, 0), at(0, 3), at(0, 2)});
  m.triangles.push_back({at(2, 0), at(2, 1), at(2, 2)});  // top, facing up
  m.triangles.push_back({at(2, 0), at(2, 2), at(2, 3)});
  ASSERT_NEAR(signed_volume_mm3(m), 500.0, 1e-9);
  SliceSettings s = no_time();
  s.first_layer_height_mm = 0.25;
  s.layer_height_mm = 0.25;
  auto layers = slice_layers(place_on_bed(m, 110, 110), s);
  ASSERT_TRUE(layers.ok()) << layers.error().describe();
  ASSERT_EQ(layers->size(), 20u);
  const LayerOutline& ring = (*layers)[10];
  ASSERT_EQ(ring.slice_z_mm, 2.625);
  ASSERT_EQ(ring.polygons.size(), 1u);
  EXPECT_EQ(ring.closed_gaps, 0);
  double a = 0;
  const auto& p = ring.polygons[0];
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto& u = p[i];
    const auto& v = p[(i + 1) % p.size()];
    a += double(u.x_um) * double(v.y_um) - double(v.x_um) * double(u.y_um);
  }
  EXPECT_NEAR(a * 0.5e-6, 100.0, 1e-6);
}

TEST(SliceLayers, OpenMeshIsAnError) {
  Mesh cube = test::make_cube_mm(10.0);
  cube.triangles.pop_back();
  auto layers = slice_layers(cube, no_time());
  ASSERT_FALSE(layers.ok());
  EXPECT_EQ(layers.error().code, ErrorCode::bad_input);
  EXPECT_NE(layers.error().message.find("not closed"), std::string::npos);
}

TEST(SliceFlow, BeadAreaIsPrusaSlicersStadium) {
  // 0.45 x 0.2: (0.45 - 0.2) * 0.2 + pi * 0.04 / 4
  EXPECT_NEAR(bead_area_mm2(0.45, 0.2), 0.05 + std::numbers::pi * 0.01, 1e-12);
  EXPECT_NEAR(bead_spacing_mm(0.45, 0.2), 0.45 - 0.2 * (1 - std::numbers::pi / 4), 1e-12);
  EXPECT_NEAR(bead_area_mm2(0.45, 0.2), bead_spacing_mm(0.45, 0.2) * 0.2, 1e-12);
}

TEST(SliceGcode, PerimetersCountPositionsAndWidths) {
  const Mesh cube = test::make_cube_mm(20.0);
  SliceSettings s = no_time();
  s.center_mm = Vec2(100, 100);
  auto out = slice_mesh(cube, ender3_marlin2(), s);
  ASSERT_TRUE(out.ok()) << out.error().describe();
  const GcodeFacts f = read_facts(out->gcode);
  EXPECT_EQ(f.layers, 100);
  EXPECT_TRUE(f.relative_e);
  // Layer 50: external loop centred 0.225 mm inside the 90..110 square, the inner loop one
  // mean spacing further in: 0.225 + (0.4071 + 0.4071) / 2.
  const auto& l50 = f.extent.at(50);
  const Box3 ext = l50.at("External perimeter");
  const Box3 per = l50.at("Perimeter");
  const double s_per = bead_spacing_mm(0.45, 0.2);
  EXPECT_NEAR(ext.min.x(), 90.225, 0.002);
  EXPECT_NEAR(ext.max.y(), 109.775, 0.002);
  EXPECT_NEAR(per.min.x(), 90.225 + s_per, 0.002);
  EXPECT_NEAR(per.max.x(), 109.775 - s_per, 0.002);
  // Two perimeters: no third loop type, and the infill stays inside the inner loop.
  const Box3 inf = l50.at("Internal infill");
  EXPECT_GT(inf.min.x(), per.min.x());
  EXPECT_LT(inf.max.x(), per.max.x());
  for (double w : f.widths.at("External perimeter")) EXPECT_NEAR(w, 0.45, 1e-9);
  for (double w : f.widths.at("Perimeter")) EXPECT_NEAR(w, 0.45, 1e-9);
  // First layer width 0.4 (200 % of 0.2), then 0.45; top solid infill 0.4.
  for (double w : f.widths.at("External perimeter@0")) EXPECT_NEAR(w, 0.4, 1e-9);
  EXPECT_NEAR(f.widths.at("Skirt/Brim@0").front(), 0.4, 1e-9);
  EXPECT_NEAR(f.widths.at("Top solid infill").back(), 0.4, 1e-9);
  ASSERT_TRUE(f.e_by_type.count("Top solid infill"));
  ASSERT_TRUE(f.e_by_type.count("Solid infill"));
  EXPECT_EQ(out->stats.layer_count, 100);
  EXPECT_TRUE(out->findings.empty());
}

TEST(SliceGcode, FullInfillFilamentMatchesPartVolume) {
  const Mesh cube = test::make_cube_mm(20.0);
  SliceSettings s = no_time();
  s.infill_density = 1.0;
  s.skirts = 0;
  auto out = slice_mesh(cube, ender3_marlin2(), s);
  ASSERT_TRUE(out.ok()) << out.error().describe();
  // Filament volume (excluding the start code's purge) ~ part volume.
  EXPECT_NEAR(out->stats.filament_volume_mm3 / 8000.0, 1.0, 0.03);
  EXPECT_NEAR(out->stats.part_volume_mm3, 8000.0, 1e-6);
  // The per-feature volumes add up to the total.
  const auto& st = out->stats;
  const double sum = st.external_perimeter_mm3 + st.perimeter_mm3 + st.sparse_infill_mm3 +
                     st.solid_infill_mm3 + st.top_solid_infill_mm3 + st.bridge_infill_mm3 +
                     st.gap_fill_mm3 + st.skirt_brim_mm3;
  EXPECT_NEAR(sum, st.filament_volume_mm3, 1e-6 * sum);
  EXPECT_EQ(st.sparse_infill_mm3, 0.0);
}

TEST(SliceGcode, SparseInfillScalesWithDensity) {
  const Mesh cube = test::make_cube_mm(30.0);
  SliceSettings s20 = no_time();
  SliceSettings s40 = no_time();
  s40.infill_density = 0.4;
  auto a = slice_mesh(cube, ender3_marlin2(), s20);
  auto b = slice_mesh(cube, ender3_marlin2(), s40);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NEAR(b->stats.sparse_infill_mm3 / a->stats.sparse_infill_mm3, 2.0, 0.1);
  EXPECT_NEAR(b->stats.perimeter_mm3, a->stats.perimeter_mm3, 1e-6);
}

TEST(SliceGcode, ThinWallSample) {
  auto mesh = load_mesh(test::source_path("samples/models/thin_walls.stl"));
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  SliceSettings s = no_time();
  s.center_mm = Vec2(110, 110);
  auto out = slice_mesh(*mesh, ender3_marlin2(), s);
  ASSERT_TRUE(out.ok()) << out.error().describe();
  // By default every wall PrusaSlicer prints is printed (thin-wall limit nozzle / 3): the
  // 0.2 mm and 0.4 mm walls as single lines of their own width, nothing dropped.
  EXPECT_TRUE(out->findings.empty());
  const GcodeFacts facts = read_facts(out->gcode);
  bool has_02 = false, has_04 = false;
  for (double w : facts.widths.at("External perimeter")) {
    has_02 |= std::abs(w - 0.2) < 0.02;
    has_04 |= std::abs(w - 0.4) < 0.02;
  }
  EXPECT_TRUE(has_02);
  EXPECT_TRUE(has_04);
  // The 1.2 mm wall gets a gap fill line between its external loops.
  ASSERT_TRUE(facts.e_by_type.count("Gap fill"));
  EXPECT_GT(facts.e_by_type.at("Gap fill"), 1.0);
}

TEST(SliceGcode, ThinWallsBelowTheLimitAreDroppedWithFindings) {
  auto mesh = load_mesh(test::source_path("samples/models/thin_walls.stl"));
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  SliceSettings s = no_time();
  s.center_mm = Vec2(110, 110);
  ASSERT_TRUE(set_slice_setting(s, "thin_wall_min_width", "0.45").ok());
  EXPECT_NEAR(min_thin_wall_width_mm(s), 0.45, 1e-12);
  auto out = slice_mesh(*mesh, ender3_marlin2(), s);
  ASSERT_TRUE(out.ok()) << out.error().describe();
  // The 0.2 and 0.4 mm walls (narrower than a 0.45 mm line) are dropped, each reported
  // with its width and its 30 mm extent up to the wall top.
  ASSERT_EQ(out->findings.size(), 2u);
  std::vector<double> widths;
  for (const Finding& f : out->findings) {
    EXPECT_EQ(f.code, "thin_wall_dropped");
    ASSERT_TRUE(f.value.has_value());
    widths.push_back(*f.value);
    ASSERT_TRUE(f.extent_mm.has_value());
    EXPECT_NEAR(f.extent_mm->size().x(), 30.0, 0.5);
    EXPECT_NEAR(f.extent_mm->max.z(), 11.0, 0.01);
  }
  std::sort(widths.begin(), widths.end());
  EXPECT_NEAR(widths[0], 0.2, 0.02);
  EXPECT_NEAR(widths[1], 0.4, 0.02);
}

TEST(SliceGcode, DeterministicAndMarlinFraming) {
  const Mesh cube = test::make_cube_mm(10.0);
  auto a = slice_mesh(cube, ender3_marlin2(), no_time());
  auto b = slice_mesh(cube, ender3_marlin2(), no_time());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->gcode, b->gcode);
  const std::string& g = a->gcode;
  EXPECT_NE(g.find("M190 S60"), std::string::npos);    // {bed_temp} substituted
  EXPECT_NE(g.find("M109 S210"), std::string::npos);   // {nozzle_temp}: first layer 210
  EXPECT_NE(g.find("M104 S200"), std::string::npos);   // 200 from layer 1 on
  EXPECT_NE(g.find("G1 X0 Y235"), std::string::npos);  // {bed_max_y}
  EXPECT_EQ(g.find('{'), std::string::npos);
  EXPECT_NE(g.find(";Z:0.2\n;HEIGHT:0.2\n"), std::string::npos);
  EXPECT_NE(g.find("; filament used [mm] = "), std::string::npos);
  EXPECT_NE(g.find("; layer_height = 0.2\n"), std::string::npos);
  std::istringstream lines(g);
  std::string line;
  long g1 = 0;
  while (std::getline(lines, line))
    if (line.rfind("G1 ", 0) == 0) {
      ++g1;
      EXPECT_EQ(line.find(','), std::string::npos) << line;  // no locale commas in numbers
    }
  EXPECT_GT(g1, 1000);
}

TEST(SliceGcode, OpenMeshIsRepairedAndReported) {
  Mesh cube = test::make_cube_mm(10.0);
  cube.triangles.pop_back();  // a hole of one triangle: CGAL's repair fills it
  auto out = slice_mesh(cube, ender3_marlin2(), no_time());
  ASSERT_TRUE(out.ok()) << out.error().describe();
  EXPECT_TRUE(out->stats.mesh_repaired);
  EXPECT_EQ(out->stats.layer_count, 50);
  ASSERT_FALSE(out->findings.empty());
  EXPECT_EQ(out->findings[0].code, "mesh_repaired");
  EXPECT_NE(out->findings[0].message.find("3 open edges"), std::string::npos)
      << out->findings[0].message;
}

TEST(SliceGcode, FooterTimeComesFromTheSimulator) {
  SliceSettings s;  // estimate_time on
  auto out = slice_mesh(test::make_cube_mm(10.0), ender3_marlin2(), s);
  ASSERT_TRUE(out.ok()) << out.error().describe();
  EXPECT_TRUE(out->stats.time_from_simulator);
  // Heating from ambient, homing, purge and 50 layers of a 10 mm cube: minutes, not hours.
  EXPECT_GT(out->stats.estimated_time_s, 300.0);
  EXPECT_LT(out->stats.estimated_time_s, 1800.0);
  const std::string key = "; printtwin estimated printing time [s] = ";
  const auto pos = out->gcode.find(key);
  ASSERT_NE(pos, std::string::npos);
  EXPECT_NEAR(std::stod(out->gcode.substr(pos + key.size())), out->stats.estimated_time_s, 0.05);
}

TEST(SliceSettingsTest, DefaultsMatchThePrusaSlicerEnder3Ini) {
  SliceSettings loaded;
  loaded.layer_height_mm = 0.3;  // must be reset by the file
  auto rep = load_prusa_ini(loaded, test::source_path("tests/data/slice/prusa_ender3.ini"));
  ASSERT_TRUE(rep.ok()) << rep.error().describe();
  EXPECT_EQ(loaded, SliceSettings{});
  // Keys printtwin does not use are listed, not errors.
  auto has = [](const std::vector<std::string>& v, const std::string& k) {
    return std::find(v.begin(), v.end(), k) != v.end();
  };
  EXPECT_TRUE(has(rep->ignored_keys, "gcode_flavor"));
  EXPECT_TRUE(has(rep->ignored_keys, "start_gcode"));
  EXPECT_TRUE(has(rep->used_keys, "fill_density"));
  EXPECT_GE(rep->used_keys.size(), 30u);
}

TEST(SliceSettingsTest, SetByKeyAliasAndPercent) {
  SliceSettings s;
  ASSERT_TRUE(set_slice_setting(s, "fill_density", "35%").ok());
  EXPECT_NEAR(s.infill_density, 0.35, 1e-12);
  ASSERT_TRUE(set_slice_setting(s, "infill-density", "0.5").ok());
  EXPECT_NEAR(s.infill_density, 0.5, 1e-12);
  ASSERT_TRUE(set_slice_setting(s, "line_width", "0.5").ok());
  EXPECT_NEAR(resolve_widths(s).perimeter_mm, 0.5, 1e-12);
  ASSERT_TRUE(set_slice_setting(s, "first_layer_extrusion_width", "150%").ok());
  EXPECT_NEAR(resolve_widths(s).first_layer_mm, 0.3, 1e-12);
  ASSERT_TRUE(set_slice_setting(s, "fill_pattern", "rectilinear").ok());
  EXPECT_EQ(s.infill_pattern, InfillPattern::rectilinear);
  ASSERT_TRUE(set_slice_setting(s, "seam_position", "aligned").ok());
  EXPECT_EQ(s.seam, SeamPosition::aligned);
  ASSERT_TRUE(set_slice_setting(s, "z_hop", "0.4").ok());
  EXPECT_NEAR(s.retract_lift_mm, 0.4, 1e-12);
}

TEST(SliceSettingsTest, ErrorsNameTheKey) {
  SliceSettings s;
  auto unknown = set_slice_setting(s, "layer_hieght", "0.2");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::usage);
  EXPECT_NE(unknown.error().message.find("layer_hieght"), std::string::npos);
  auto bad = set_slice_setting(s, "perimeters", "two");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("perimeters"), std::string::npos);
  EXPECT_FALSE(set_slice_setting(s, "fill_pattern", "honeycomb-ish").ok());
  EXPECT_FALSE(set_slice_setting(s, "thin_walls", "maybe").ok());
  // Impossible values are caught by validation.
  SliceSettings tall;
  tall.layer_height_mm = 0.5;  // above 80 % of a 0.4 mm nozzle
  auto v = validate_slice_settings(tall);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error().code, ErrorCode::usage);
  EXPECT_NE(v.error().message.find("layer_height"), std::string::npos);
  SliceSettings dense;
  dense.infill_density = 1.5;
  EXPECT_FALSE(validate_slice_settings(dense).ok());
  SliceSettings slow;
  slow.travel_speed_mm_s = 0;
  EXPECT_FALSE(validate_slice_settings(slow).ok());
  auto sliced = slice_mesh(test::make_cube_mm(10), ender3_marlin2(), tall);
  ASSERT_FALSE(sliced.ok());
  EXPECT_EQ(sliced.error().code, ErrorCode::usage);
}

TEST(SliceSettingsTest, IniErrorsCarryFileAndLine) {
  SliceSettings s;
  auto r = apply_prusa_ini(s, "# comment\nlayer_height = 0.2\nperimeters = lots\n", "x.ini");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::bad_input);
  EXPECT_EQ(r.error().file, "x.ini");
  ASSERT_TRUE(r.error().line.has_value());
  EXPECT_EQ(*r.error().line, 3);
  auto garbage = apply_prusa_ini(s, "layer_height 0.2\n", "y.ini");
  ASSERT_FALSE(garbage.ok());
  EXPECT_EQ(*garbage.error().line, 1);
  auto bundle = apply_prusa_ini(s, "[print:0.2mm]\nlayer_height = 0.2\n", "z.ini");
  ASSERT_FALSE(bundle.ok());
}

TEST(SliceCli, EndToEnd) {
  const auto dir = test::temp_dir("slice_cli");
  ASSERT_TRUE(save_stl(test::make_cube_mm(15.0), dir / "cube.stl").ok());
  const std::string stl = (dir / "cube.stl").string();
  const std::string gcode = (dir / "cube.gcode").string();
  auto run =
      test::run_cli("slice " + stl + " -o " + gcode +
                    " --layer-height 0.25 --perimeters 3 --infill-density 30% --no-time-estimate");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("60 layers"), std::string::npos) << run.out;
  auto text = read_file(gcode);
  ASSERT_TRUE(text.ok());
  EXPECT_NE(text->find("; perimeters = 3\n"), std::string::npos);
  EXPECT_NE(text->find("; fill_density = 30%\n"), std::string::npos);
  EXPECT_NE(text->find(";HEIGHT:0.25\n"), std::string::npos);

  auto json = test::run_cli("slice " + stl + " -o " + gcode +
                            " --json --no-time-estimate --set perimeters=1");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_NE(json.out.find("\"schema\": \"printtwin.slice/1\""), std::string::npos);

  // Usage errors: unknown key, impossible value, malformed --set.
  EXPECT_EQ(test::run_cli("slice " + stl + " -o " + gcode + " --set nonsense=1").exit_code, 2);
  EXPECT_EQ(test::run_cli("slice " + stl + " -o " + gcode + " --layer-height 0.9").exit_code, 2);
  EXPECT_EQ(test::run_cli("slice " + stl + " -o " + gcode + " --set perimeters").exit_code, 2);
  // Bad files: missing mesh, malformed config.
  EXPECT_EQ(test::run_cli("slice " + (dir / "missing.stl").string() + " -o " + gcode).exit_code, 3);
  ASSERT_TRUE(write_file_atomic(dir / "bad.ini", "layer_height = thick\n").ok());
  auto bad =
      test::run_cli("slice " + stl + " -o " + gcode + " --config " + (dir / "bad.ini").string());
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("bad.ini:1"), std::string::npos) << bad.err;
  // A config with keys printtwin does not use lists them.
  auto ini = test::run_cli("slice " + stl + " -o " + gcode + " --no-time-estimate --config " +
                           test::source_path("tests/data/slice/prusa_ender3.ini").string());
  EXPECT_EQ(ini.exit_code, 0) << ini.err;
  EXPECT_NE(ini.err.find("gcode_flavor"), std::string::npos);
}

}  // namespace
}  // namespace printtwin
