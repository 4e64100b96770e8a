// 3MF projects whose objects live in other model files of the archive (the production
// extension's p:path, as Bambu Studio and OrcaSlicer save them): components followed and
// their transforms composed, build items placed, units converted, one error per bad input.
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

/// The unit cube scaled by `edge` as <object id=..>, written as a Bambu object file does,
/// with the XML variations a scanner must take: ' quotes, attributes in another order, a
/// comment holding a tag, white space around '='.
std::string cube_object(int id, double edge, const std::string& type = "model") {
  const std::string e = format_number(edge);
  std::string s = "  <object id=\"" + std::to_string(id) + "\" type='" + type + "'>\n   <mesh>\n" +
                  "    <vertices>\n     <!-- <vertex x=\"99\" y=\"99\" z=\"99\"/> -->\n";
  for (int k = 0; k < 8; ++k) {
    const std::string x = (k & 1) != 0 ? e : "0";
    const std::string y = (k & 2) != 0 ? e : "0";
    const std::string z = (k & 4) != 0 ? e : "0";
    std::string v = k % 2 == 0 ? "     <vertex x=\"X\" y=\"Y\" z=\"Z\"/>\n"
                               : "     <vertex z='Z' x = 'X' y='Y' />\n";
    v.replace(v.find('X'), 1, x);
    v.replace(v.find('Y'), 1, y);
    v.replace(v.find('Z'), 1, z);
    s += v;
  }
  s += "    </vertices>\n    <triangles>\n";
  // Outward faces of the cube whose vertex k has x = bit 0, y = bit 1, z = bit 2.
  static constexpr int kFaces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6},
                                        {0, 1, 4}, {1, 5, 4}, {2, 6, 3}, {3, 6, 7},
                                        {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& f : kFaces)
    s += "     <triangle v1=\"" + std::to_string(f[0]) + "\" v2=\"" + std::to_string(f[1]) +
         "\" v3=\"" + std::to_string(f[2]) + "\"/>\n";
  return s + "    </triangles>\n   </mesh>\n  </object>\n";
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

TEST(Mesh3mf, PackageWithoutOtherModelFilesStaysWithAssimp) {
  // The same cube in the root model itself (PrusaSlicer's and Cura's layout).
  const std::string root = model(cube_object(1, 10), item(1, translate(5, 0, 0)));
  const Mesh m = load(package(root, {}));
  EXPECT_NEAR(signed_volume_mm3(m), 1000.0, 1e-9);
  expect_box(m, Vec3(5, 0, 0), Vec3(15, 10, 10));
}

}  // namespace
}  // namespace printtwin
