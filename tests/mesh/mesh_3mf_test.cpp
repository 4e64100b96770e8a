// 3MF packages, read by printtwin: objects in the root model or in other model files of the
// archive (the production extension's p:path, as Bambu Studio and OrcaSlicer save them),
// components followed and their transforms composed, build items placed, units converted,
// the slicers' modifier parts left out, one error per bad input.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

constexpr const char* kRels =
    R"(<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel-1" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>)";

constexpr const char* kModelOpen =
    R"(<?xml version="1.0" encoding="UTF-8"?>
<model unit="%UNIT%" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02" xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06" requiredextensions="p">
 <resources>
)";

/// The vertices of the unit cube scaled by `edge` and moved `dx` along x, written with the
/// XML variations a scanner must take: ' quotes, attributes in another order, white space
/// around '='.
std::string cube_vertices(double edge, double dx = 0) {
  std::string s;
  for (int k = 0; k < 8; ++k) {
    const std::string x = format_number((k & 1) != 0 ? edge + dx : dx);
    const std::string y = (k & 2) != 0 ? format_number(edge) : "0";
    const std::string z = (k & 4) != 0 ? format_number(edge) : "0";
    std::string v = k % 2 == 0 ? "     <vertex x=\"X\" y=\"Y\" z=\"Z\"/>\n"
                               : "     <vertex z='Z' x = 'X' y='Y' />\n";
    v.replace(v.find('X'), 1, x);
    v.replace(v.find('Y'), 1, y);
    v.replace(v.find('Z'), 1, z);
    s += v;
  }
  return s;
}

/// The cube's 12 outward triangles, its vertex k (x = bit 0, y = bit 1, z = bit 2) being
/// vertex `base` + k of the object.
std::string cube_triangles(int base = 0) {
  static constexpr int kFaces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6},
                                        {0, 1, 4}, {1, 5, 4}, {2, 6, 3}, {3, 6, 7},
                                        {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  std::string s;
  for (const auto& f : kFaces)
    s += "     <triangle v1=\"" + std::to_string(base + f[0]) + "\" v2=\"" +
         std::to_string(base + f[1]) + "\" v3=\"" + std::to_string(base + f[2]) + "\"/>\n";
  return s;
}

/// An object of `vertices` and `triangles`, written as a Bambu object file does (with a
/// comment holding a tag).
std::string mesh_object(int id, const std::string& vertices, const std::string& triangles,
                        const std::string& type = "model") {
  return "  <object id=\"" + std::to_string(id) + "\" type='" + type + "'>\n   <mesh>\n" +
         "    <vertices>\n     <!-- <vertex x=\"99\" y=\"99\" z=\"99\"/> -->\n" + vertices +
         "    </vertices>\n    <triangles>\n" + triangles + "    </triangles>\n   </mesh>\n" +
         "  </object>\n";
}

/// The unit cube scaled by `edge` as <object id=..>.
std::string cube_object(int id, double edge, const std::string& type = "model") {
  return mesh_object(id, cube_vertices(edge), cube_triangles(), type);
}

/// A model file: `resources` (objects) and `build` (items) inside the usual frame.
std::string model(const std::string& resources, const std::string& build = "",
                  const std::string& unit = "millimeter") {
  std::string s = kModelOpen;
  s.replace(s.find("%UNIT%"), 6, unit);
  return s + resources + " </resources>\n <build>\n" + build + " </build>\n</model>\n";
}

std::string component(int id, const std::string& path, const std::string& transform) {
  return "    <component " + (path.empty() ? "" : "p:path=\"" + path + "\" ") + "objectid=\"" +
         std::to_string(id) + "\" transform=\"" + transform + "\"/>\n";
}

std::string assembly(int id, const std::string& components) {
  return "  <object id=\"" + std::to_string(id) + "\" type=\"model\">\n   <components>\n" +
         components + "   </components>\n  </object>\n";
}

std::string item(int id, const std::string& transform, const std::string& printable = "1") {
  return "  <item objectid=\"" + std::to_string(id) + "\" transform=\"" + transform +
         "\" printable=\"" + printable + "\"/>\n";
}

std::string translate(double x, double y, double z) {
  return "1 0 0 0 1 0 0 0 1 " + format_number(x) + " " + format_number(y) + " " + format_number(z);
}

using Entries = std::vector<std::pair<std::string, std::string>>;

/// The package: relationships, the root model and the other model files.
std::string package(const std::string& root, const Entries& others) {
  Entries entries = {{"[Content_Types].xml", "<Types/>"}, {"_rels/.rels", kRels}};
  for (const auto& e : others) entries.push_back(e);
  entries.emplace_back("3D/3dmodel.model", root);
  return test::make_zip(entries, true);
}

/// The usual Bambu layout: object 2 of the root is one component, object 1 of
/// 3D/Objects/object_1.model, moved by `component_t`; one item moves it by `item_t`.
std::string bambu_cube(const std::string& component_t, const std::string& item_t) {
  const std::string root =
      model(assembly(2, component(1, "/3D/Objects/object_1.model", component_t)), item(2, item_t));
  return package(root, {{"3D/Objects/object_1.model", model(cube_object(1, 10))}});
}

Mesh load(const std::string& zip) {
  auto m = load_mesh_from_memory(zip, "part.3mf");
  EXPECT_TRUE(m.ok()) << m.error().describe();
  return m.ok() ? *m : Mesh{};
}

void expect_box(const Mesh& m, const Vec3& lo, const Vec3& hi) {
  const Box3 b = bounding_box(m);
  EXPECT_NEAR((b.min - lo).norm(), 0, 1e-9) << b.min.transpose();
  EXPECT_NEAR((b.max - hi).norm(), 0, 1e-9) << b.max.transpose();
}

void expect_error(const std::string& zip, const std::vector<std::string>& parts) {
  auto m = load_mesh_from_memory(zip, "part.3mf");
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().code, ErrorCode::bad_input);
  EXPECT_EQ(m.error().file, "part.3mf");
  for (const auto& p : parts)
    EXPECT_NE(m.error().message.find(p), std::string::npos) << p << " in " << m.error().message;
}

TEST(Mesh3mf, ComponentInAnotherModelFilePlacedByItsItem) {
  const Mesh m = load(bambu_cube(translate(1, 2, 3), translate(128, 128, 5)));
  EXPECT_EQ(m.triangles.size(), 12U);
  EXPECT_EQ(m.vertices_mm.size(), 8U);
  EXPECT_NEAR(signed_volume_mm3(m), 1000.0, 1e-9);
  expect_box(m, Vec3(129, 130, 8), Vec3(139, 140, 18));
}

TEST(Mesh3mf, TransformsAreRowVectorMatricesComposedItemAfterComponent) {
  // The component turns the cube 90 degrees about z (x' = -y, y' = x), then the item
  // doubles it along x and moves it: the turn acts first.
  const Mesh m = load(bambu_cube("0 1 0 -1 0 0 0 0 1 0 0 0", "2 0 0 0 1 0 0 0 1 100 0 0"));
  EXPECT_NEAR(signed_volume_mm3(m), 2000.0, 1e-9);
  expect_box(m, Vec3(80, 0, 0), Vec3(100, 10, 10));
}

TEST(Mesh3mf, TwoItemsOfOneObjectAndADisabledOneLeftOut) {
  const std::string root =
      model(assembly(2, component(1, "/3D/Objects/object_1.model", translate(0, 0, 0))),
            item(2, translate(0, 0, 0)) + item(2, translate(50, 0, 0)) +
                item(2, translate(200, 0, 0), "0"));
  const Mesh m = load(package(root, {{"3D/Objects/object_1.model", model(cube_object(1, 10))}}));
  EXPECT_EQ(m.triangles.size(), 24U);
  EXPECT_EQ(m.vertices_mm.size(), 16U);
  EXPECT_NEAR(signed_volume_mm3(m), 2000.0, 1e-9);
  expect_box(m, Vec3(0, 0, 0), Vec3(60, 10, 10));
}

TEST(Mesh3mf, NestedComponentsAcrossFilesAndWithinOne) {
  // root object 3 -> object 5 of parts.model (scaled by 2) -> object 1 of the same file,
  // and object 3 also holds object 1 directly, mirrored in x: the mirror keeps the faces
  // pointing out (positive volume).
  const std::string parts =
      model(cube_object(1, 5) + assembly(5, component(1, "", "2 0 0 0 2 0 0 0 2 0 0 0")) +
            cube_object(7, 1, "support"));
  const std::string root =
      model(assembly(3, component(5, "/3D/Objects/parts.model", translate(0, 0, 0)) +
                            component(1, "/3D/Objects/parts.model", "-1 0 0 0 1 0 0 0 1 -1 0 0") +
                            component(7, "/3D/Objects/parts.model", translate(0, 0, 0))),
            item(3, translate(10, 0, 0)));
  const Mesh m = load(package(root, {{"3D/Objects/parts.model", parts}}));
  EXPECT_EQ(m.triangles.size(), 24U);  // the support object is left out
  EXPECT_NEAR(signed_volume_mm3(m), 1000.0 + 125.0, 1e-9);
  expect_box(m, Vec3(4, 0, 0), Vec3(20, 10, 10));
}

TEST(Mesh3mf, UnitOfTheRootModelIsConverted) {
  const std::string root =
      model(assembly(2, component(1, "/3D/Objects/object_1.model", translate(0, 0, 0))),
            item(2, translate(1, 0, 0)), "inch");
  const std::string zip =
      package(root, {{"3D/Objects/object_1.model", model(cube_object(1, 1), "", "inch")}});
  const Mesh m = load(zip);
  EXPECT_NEAR(signed_volume_mm3(m), 25.4 * 25.4 * 25.4, 1e-6);
  expect_box(m, Vec3(25.4, 0, 0), Vec3(50.8, 25.4, 25.4));
  // --scale multiplies after the unit.
  MeshLoadOptions twice;
  twice.scale = 2.0;
  auto scaled = load_mesh_from_memory(zip, "part.3mf", twice);
  ASSERT_TRUE(scaled.ok());
  expect_box(*scaled, Vec3(50.8, 0, 0), Vec3(101.6, 50.8, 50.8));
}

TEST(Mesh3mf, BadReferencesAndNumbersNameTheEntry) {
  const std::string cube = model(cube_object(1, 10));
  const auto root_with = [](const std::string& comp) {
    return model(assembly(2, comp), item(2, translate(0, 0, 0)));
  };
  expect_error(package(root_with(component(1, "/3D/Objects/missing.model", translate(0, 0, 0))),
                       {{"3D/Objects/object_1.model", cube}}),
               {"3D/3dmodel.model", "'/3D/Objects/missing.model' is not in the archive"});
  expect_error(package(root_with(component(4, "/3D/Objects/object_1.model", translate(0, 0, 0))),
                       {{"3D/Objects/object_1.model", cube}}),
               {"3D/3dmodel.model", "object 4 is not defined in '/3D/Objects/object_1.model'"});
  expect_error(package(root_with(component(1, "/3D/Objects/object_1.model", "1 0 0 0 1 0")),
                       {{"3D/Objects/object_1.model", cube}}),
               {"3D/3dmodel.model", "transform '1 0 0 0 1 0' is not 12 numbers"});
  std::string bad_index = cube;
  bad_index.replace(bad_index.find("v3=\"1\""), 6, "v3=\"8\"");
  expect_error(package(root_with(component(1, "/3D/Objects/object_1.model", translate(0, 0, 0))),
                       {{"3D/Objects/object_1.model", bad_index}}),
               {"3D/Objects/object_1.model, line", "triangle 0: v3 '8'", "8 vertices"});
  std::string bad_number = cube;
  bad_number.replace(bad_number.find("y=\"10\""), 6, "y=\"1,5\"");
  expect_error(package(root_with(component(1, "/3D/Objects/object_1.model", translate(0, 0, 0))),
                       {{"3D/Objects/object_1.model", bad_number}}),
               {"3D/Objects/object_1.model, line", "y is not a number ('1,5')"});
}

TEST(Mesh3mf, CycleOfComponentsIsAnError) {
  const std::string a = model(assembly(1, component(2, "/3D/Objects/b.model", translate(0, 0, 0))));
  const std::string b = model(assembly(2, component(1, "/3D/Objects/a.model", translate(1, 0, 0))));
  const std::string root =
      model(assembly(9, component(1, "/3D/Objects/a.model", translate(0, 0, 0))),
            item(9, translate(0, 0, 0)));
  expect_error(package(root, {{"3D/Objects/a.model", a}, {"3D/Objects/b.model", b}}),
               {"3D/Objects/b.model, line", "the components form a cycle",
                "/3D/Objects/a.model object 1 -> /3D/Objects/b.model object 2 -> "
                "/3D/Objects/a.model object 1"});
}

TEST(Mesh3mf, ComponentsTooDeepOrTooManyAreErrors) {
  // A chain of 1001 objects, each the component of the one before: deeper than 1000 levels.
  std::string chain;
  for (int id = 1; id <= 1001; ++id)
    chain += assembly(id, component(id + 1, "", translate(0, 0, 0)));
  const std::string deep = model(chain + cube_object(1002, 1));
  const std::string root_deep =
      model(assembly(9000, component(1, "/3D/Objects/deep.model", translate(0, 0, 0))),
            item(9000, translate(0, 0, 0)));
  expect_error(package(root_deep, {{"3D/Objects/deep.model", deep}}),
               {"3D/Objects/deep.model, line", "components nest deeper than 1000 levels"});
  // 21 levels that each place the next level twice: 2^21 placed objects.
  std::string doubling;
  for (int id = 1; id <= 21; ++id)
    doubling += assembly(
        id, component(id + 1, "", translate(0, 0, 0)) + component(id + 1, "", translate(1, 0, 0)));
  doubling += "  <object id=\"22\" type=\"model\"/>\n";
  const std::string root_many =
      model(assembly(9000, component(1, "/3D/Objects/many.model", translate(0, 0, 0))),
            item(9000, translate(0, 0, 0)));
  expect_error(package(root_many, {{"3D/Objects/many.model", model(doubling)}}),
               {"the components expand to more than", "placed objects"});
}

TEST(Mesh3mf, EveryItemDisabledIsAnError) {
  const std::string root =
      model(assembly(2, component(1, "/3D/Objects/object_1.model", translate(0, 0, 0))),
            item(2, translate(0, 0, 0), "0"));
  expect_error(package(root, {{"3D/Objects/object_1.model", model(cube_object(1, 10))}}),
               {"printable=\"0\""});
}

TEST(Mesh3mf, BrokenXmlIsAnError) {
  const std::string root =
      model(assembly(2, component(1, "/3D/Objects/o.model", translate(0, 0, 0))),
            item(2, translate(0, 0, 0)));
  expect_error(
      package(root, {{"3D/Objects/o.model", "<model><object id=\"1\"><mesh><vertex x=\"1"}}),
      {"3D/Objects/o.model", "is not closed"});
}

TEST(Mesh3mf, OnlyBuildItemsOfTheRootModelArePrinted) {
  // PrusaSlicer's and Cura's layout: the objects in the root model itself. Object 3 is
  // defined but no item places it (3MF core: not printed); object 4 is an assembly of
  // object 1 twice within the same file, as the 3MF Consortium's samples are.
  const std::string root = model(
      cube_object(1, 10) + cube_object(3, 50) +
          assembly(4, component(1, "", translate(0, 0, 0)) + component(1, "", translate(20, 0, 0))),
      item(1, translate(5, 0, 0)) + item(4, translate(0, 30, 0)));
  const Mesh m = load(package(root, {}));
  EXPECT_NEAR(signed_volume_mm3(m), 3000.0, 1e-9);
  expect_box(m, Vec3(0, 0, 0), Vec3(30, 40, 10));
}

TEST(Mesh3mf, FuzzedPackageReadsThroughItsCentralDirectory) {
  // A package of the fuzz corpus (a local header damaged, the central directory sound) that
  // assimp's reader took for one without a root model.
  auto fuzzed = load_mesh(test::source_path("tests/data/mesh/no_root_model.3mf"));
  ASSERT_TRUE(fuzzed.ok()) << fuzzed.error().describe();
  EXPECT_EQ(fuzzed->triangles.size(), 4U);
}

/// One object of two cubes (a 10 mm part at the origin, a 4 mm cube at x = 20 mm) and its
/// Metadata/Slic3r_PE_model.config typing the second `volume` as PrusaSlicer does.
std::string prusa_project(const std::string& volume_metadata) {
  const std::string two = mesh_object(1, cube_vertices(10) + cube_vertices(4, 20),
                                      cube_triangles(0) + cube_triangles(8));
  const std::string config =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<config>\n <object id=\"1\" "
      "instances_count=\"1\">\n  <metadata type=\"object\" key=\"name\" value=\"part\"/>\n"
      "  <volume firstid=\"0\" lastid=\"11\">\n   <metadata type=\"volume\" "
      "key=\"volume_type\" value=\"ModelPart\"/>\n  </volume>\n  <volume firstid=\"12\" "
      "lastid=\"23\">\n" +
      volume_metadata + "  </volume>\n </object>\n</config>\n";
  return package(model(two, item(1, translate(0, 0, 0))),
                 {{"Metadata/Slic3r_PE_model.config", config}});
}

TEST(Mesh3mf, PrusaSlicerModifierVolumesAreLeftOut) {
  for (const char* type :
       {"ParameterModifier", "NegativeVolume", "SupportBlocker", "SupportEnforcer"}) {
    const Mesh m = load(
        prusa_project(std::string("   <metadata type=\"volume\" key=\"volume_type\" value=\"") +
                      type + "\"/>\n"));
    EXPECT_EQ(m.triangles.size(), 12U) << type;
    expect_box(m, Vec3(0, 0, 0), Vec3(10, 10, 10));
  }
  // Before PrusaSlicer 2.4 a modifier was key="modifier" value="1".
  EXPECT_EQ(load(prusa_project("   <metadata type=\"volume\" key=\"modifier\" value=\"1\"/>\n"))
                .triangles.size(),
            12U);
  // A second printed part stays.
  const Mesh both = load(
      prusa_project("   <metadata type=\"volume\" key=\"volume_type\" value=\"ModelPart\"/>\n"));
  EXPECT_EQ(both.triangles.size(), 24U);
  EXPECT_NEAR(signed_volume_mm3(both), 1064.0, 1e-9);
}

TEST(Mesh3mf, BambuModifierPartsAreLeftOut) {
  // Object 2 of the root: part 1 (the 10 mm cube) and part 3 (a 4 mm cube), both in
  // 3D/Objects/object_1.model; Metadata/model_settings.config types part 3.
  const std::string root =
      model(assembly(2, component(1, "/3D/Objects/object_1.model", translate(0, 0, 0)) +
                            component(3, "/3D/Objects/object_1.model", translate(20, 0, 0))),
            item(2, translate(0, 0, 0)));
  const std::string parts = model(cube_object(1, 10) + cube_object(3, 4));
  for (const char* subtype :
       {"modifier_part", "negative_part", "support_blocker", "support_enforcer"}) {
    const std::string config =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<config>\n  <object id=\"2\">\n"
        "    <part id=\"1\" subtype=\"normal_part\"/>\n    <part id=\"3\" subtype=\"" +
        std::string(subtype) + "\">\n      <metadata key=\"name\" value=\"m\"/>\n    </part>\n" +
        "  </object>\n</config>\n";
    const Mesh m = load(package(
        root, {{"3D/Objects/object_1.model", parts}, {"Metadata/model_settings.config", config}}));
    EXPECT_EQ(m.triangles.size(), 12U) << subtype;
    expect_box(m, Vec3(0, 0, 0), Vec3(10, 10, 10));
  }
  EXPECT_EQ(load(package(root, {{"3D/Objects/object_1.model", parts}})).triangles.size(), 24U);
}

TEST(Mesh3mf, PackageWithoutTrianglesOrRootModelIsAnError) {
  // A beam lattice (3MF's beam extension): beams, no triangles.
  const std::string lattice =
      "  <object id=\"1\" type=\"model\">\n   <mesh>\n    <vertices>\n"
      "     <vertex x=\"0\" y=\"0\" z=\"0\"/>\n     <vertex x=\"0\" y=\"0\" z=\"9\"/>\n"
      "    </vertices>\n    <triangles/>\n    <b:beamlattice radius=\"1\" minlength=\"0.1\">\n"
      "     <b:beams>\n      <b:beam v1=\"0\" v2=\"1\"/>\n     </b:beams>\n"
      "    </b:beamlattice>\n   </mesh>\n  </object>\n";
  expect_error(package(model(lattice, item(1, translate(0, 0, 0))), {}),
               {"holds no triangles", "1 beams of the beam lattice"});
  expect_error(package(model(cube_object(1, 10)), {}), {"holds no triangles", "0 build items"});
  expect_error(test::make_zip({{"_rels/.rels", kRels}, {"3D/other.model", "<model/>"}}, true),
               {"root model '/3D/3dmodel.model'", "is not in the archive"});
}
}  // namespace
}  // namespace printtwin
