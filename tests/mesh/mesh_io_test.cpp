// Mesh intake: every supported format, units and scale, and one clear error per bad input.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out << bytes;
}

std::string ascii_stl(const Mesh& m) {
  std::string s = "solid test\n";
  for (const auto& t : m.triangles) {
    s += " facet normal 0 0 0\n  outer loop\n";
    for (auto v : t) {
      const Vec3& p = m.vertices_mm[v];
      s += "   vertex " + format_number(p.x()) + " " + format_number(p.y()) + " " +
           format_number(p.z()) + "\n";
    }
    s += "  endloop\n endfacet\n";
  }
  return s + "endsolid test\n";
}

std::string binary_stl(const Mesh& m, std::uint32_t count_in_header) {
  std::string s(80, ' ');
  s.append(reinterpret_cast<const char*>(&count_in_header), 4);
  for (const auto& t : m.triangles) {
    float f[12] = {};
    for (int v = 0; v < 3; ++v)
      for (int i = 0; i < 3; ++i) f[3 + 3 * v + i] = static_cast<float>(m.vertices_mm[t[v]][i]);
    s.append(reinterpret_cast<const char*>(f), sizeof(f));
    s.append(2, '\0');
  }
  return s;
}

std::string obj(const Mesh& m) {
  std::string s;
  for (const auto& v : m.vertices_mm)
    s += "v " + format_number(v.x()) + " " + format_number(v.y()) + " " + format_number(v.z()) +
         "\n";
  for (const auto& t : m.triangles)
    s += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " +
         std::to_string(t[2] + 1) + "\n";
  return s;
}

std::string off(const Mesh& m) {
  std::string s = "OFF\n" + std::to_string(m.vertices_mm.size()) + " " +
                  std::to_string(m.triangles.size()) + " 0\n";
  for (const auto& v : m.vertices_mm)
    s += format_number(v.x()) + " " + format_number(v.y()) + " " + format_number(v.z()) + "\n";
  for (const auto& t : m.triangles)
    s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) +
         "\n";
  return s;
}

std::string ply(const Mesh& m) {
  std::string s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(m.vertices_mm.size()) +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                  std::to_string(m.triangles.size()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : m.vertices_mm)
    s += format_number(v.x()) + " " + format_number(v.y()) + " " + format_number(v.z()) + "\n";
  for (const auto& t : m.triangles)
    s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) +
         "\n";
  return s;
}

std::string amf(const Mesh& m) {
  std::string s =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<amf unit=\"millimeter\">\n"
      "<object id=\"0\"><mesh><vertices>\n";
  for (const auto& v : m.vertices_mm)
    s += "<vertex><coordinates><x>" + format_number(v.x()) + "</x><y>" + format_number(v.y()) +
         "</y><z>" + format_number(v.z()) + "</z></coordinates></vertex>\n";
  s += "</vertices><volume>\n";
  for (const auto& t : m.triangles)
    s += "<triangle><v1>" + std::to_string(t[0]) + "</v1><v2>" + std::to_string(t[1]) +
         "</v2><v3>" + std::to_string(t[2]) + "</v3></triangle>\n";
  return s + "</volume></mesh></object>\n</amf>\n";
}

class MeshIoTest : public ::testing::Test {
 protected:
  fs::path dir = test::temp_dir("mesh_io");
  Mesh cube = test::make_cube_mm(10, Vec3(1, 2, 3));

  fs::path put(const std::string& name, const std::string& bytes) {
    const fs::path p = dir / name;
    write(p, bytes);
    return p;
  }
  /// Loading must fail with a bad-input error that names the file and contains `what`.
  void expect_error(const fs::path& p, const std::string& what) {
    auto r = load_mesh(p);
    ASSERT_FALSE(r.ok()) << p;
    EXPECT_EQ(r.error().code, ErrorCode::bad_input);
    EXPECT_EQ(r.error().file, p.string());
    EXPECT_NE(r.error().message.find(what), std::string::npos) << r.error().describe();
  }
};

void expect_cube(const Mesh& m, double size, const Vec3& min_mm) {
  EXPECT_EQ(m.triangles.size(), 12U);
  EXPECT_EQ(m.vertices_mm.size(), 8U) << "identical vertices must be joined";
  EXPECT_NEAR(signed_volume_mm3(m), size * size * size, 1e-6 * size * size * size);
  const Box3 b = bounding_box(m);
  EXPECT_TRUE(b.min.isApprox(min_mm, 1e-6)) << b.min.transpose();
  EXPECT_NEAR(b.size().x(), size, 1e-5);
}

TEST_F(MeshIoTest, LoadsEveryFormatWithJoinedVertices) {
  expect_cube(*load_mesh(put("c.stl", ascii_stl(cube))), 10, Vec3(1, 2, 3));
  expect_cube(*load_mesh(put("b.stl", binary_stl(cube, 12))), 10, Vec3(1, 2, 3));
  expect_cube(*load_mesh(put("c.obj", obj(cube))), 10, Vec3(1, 2, 3));
  expect_cube(*load_mesh(put("c.off", off(cube))), 10, Vec3(1, 2, 3));
  expect_cube(*load_mesh(put("c.ply", ply(cube))), 10, Vec3(1, 2, 3));
  expect_cube(*load_mesh(put("c.amf", amf(cube))), 10, Vec3(1, 2, 3));
  expect_cube(*load_mesh(put("UPPER.STL", binary_stl(cube, 12))), 10, Vec3(1, 2, 3));
}

TEST_F(MeshIoTest, BinaryStlStartingWithSolidIsReadAsBinary) {
  std::string b = binary_stl(cube, 12);
  std::memcpy(b.data(), "solid but binary", 16);
  expect_cube(*load_mesh(put("solid.stl", b)), 10, Vec3(1, 2, 3));
}

TEST_F(MeshIoTest, UnitsAndScale) {
  const fs::path p = put("c.stl", binary_stl(cube, 12));
  auto inch = load_mesh(p, {1.0, LengthUnit::inch});
  ASSERT_TRUE(inch.ok());
  EXPECT_NEAR(bounding_box(*inch).size().x(), 254.0, 1e-4);
  auto cm = load_mesh(p, {0.5, LengthUnit::cm});
  ASSERT_TRUE(cm.ok());
  EXPECT_NEAR(bounding_box(*cm).size().x(), 50.0, 1e-4);
  EXPECT_NEAR(bounding_box(*cm).min.x(), 5.0, 1e-4);
  auto bad = load_mesh(p, {-1.0, LengthUnit::mm});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::usage);
}

TEST_F(MeshIoTest, EmptyFile) { expect_error(put("empty.stl", ""), "empty file"); }

TEST_F(MeshIoTest, TruncatedBinaryStl) {
  expect_error(put("short.stl", std::string(40, '\x01')), "truncated binary STL: 40 bytes");
  std::string b = binary_stl(cube, 12);
  b.resize(b.size() - 30);  // last triangle cut
  expect_error(put("cut.stl", b), "announces 12 triangles");
}

TEST_F(MeshIoTest, TriangleCountLargerThanFile) {
  expect_error(put("count.stl", binary_stl(cube, 4000000000U)), "announces 4000000000 triangles");
}

TEST_F(MeshIoTest, ZeroTriangles) {
  expect_error(put("zero.stl", binary_stl(Mesh{}, 0)), "0 triangles");
  expect_error(put("zero_ascii.stl", "solid empty\nendsolid empty\n"), "0 facets");
  expect_error(put("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), "no triangles");
}

TEST_F(MeshIoTest, NanAndInfiniteCoordinates) {
  Mesh m = cube;
  m.vertices_mm[3].y() = std::numeric_limits<double>::quiet_NaN();
  expect_error(put("nan.stl", binary_stl(m, 12)), "NaN or infinite");
  m.vertices_mm[3].y() = std::numeric_limits<double>::infinity();
  expect_error(put("inf.stl", binary_stl(m, 12)), "NaN or infinite");
  std::string text = ascii_stl(cube);
  const auto at = text.find("vertex ", text.find("vertex ") + 1);
  text.replace(at, 7, "vertex nan ");
  auto r = load_mesh(put("nan_ascii.stl", text));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("NaN or infinite"), std::string::npos) << r.error().describe();
  EXPECT_EQ(r.error().line, 5);
  const std::string inf_text =
      "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
      "vertex inf 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
  auto ri = load_mesh(put("inf_ascii.stl", inf_text));
  ASSERT_FALSE(ri.ok());
  EXPECT_EQ(ri.error().line, 5);
  EXPECT_NE(ri.error().message.find("NaN or infinite"), std::string::npos);
}

TEST_F(MeshIoTest, AsciiStlWithGarbageNamesTheLine) {
  std::string text = ascii_stl(cube);
  const auto at = text.find("endloop", text.find("endloop") + 1);  // second facet
  text.insert(at, "hello world\n");
  auto r = load_mesh(put("garbage.stl", text));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::bad_input);
  EXPECT_EQ(r.error().line, 14);
  EXPECT_NE(r.error().message.find("expected 'endloop', found 'hello'"), std::string::npos)
      << r.error().describe();
  expect_error(put("words.stl", "solid x\nthis is not a mesh\n"), "expected 'facet'");
  expect_error(put("noend.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"),
               "expected 'vertex', found 'end of file'");
  expect_error(put("badnum.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0x\n"),
               "expected a number, found '0x'");
}

TEST_F(MeshIoTest, UnknownExtension) {
  expect_error(put("part.xyz", ascii_stl(cube)), "unknown mesh extension '.xyz'");
  expect_error(put("noext", ascii_stl(cube)), "unknown mesh extension ''");
}

TEST_F(MeshIoTest, Directory) {
  fs::create_directories(dir / "folder.stl");
  expect_error(dir / "folder.stl", "directory");
}

TEST_F(MeshIoTest, MissingFile) { expect_error(dir / "nope.stl", "not found"); }

TEST_F(MeshIoTest, UnreadableFile) {
  // Root reads anything, so the content is also invalid: either way one clear error.
  const fs::path p = put("locked.stl", "solid locked\ngarbage\n");
  ::chmod(p.c_str(), 0);
  auto r = load_mesh(p);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::bad_input);
  EXPECT_EQ(r.error().file, p.string());
  const bool denied = r.error().message.find("cannot open") != std::string::npos;
  const bool garbage = r.error().message.find("expected 'facet'") != std::string::npos;
  EXPECT_TRUE(denied || (::geteuid() == 0 && garbage)) << r.error().describe();
  ::chmod(p.c_str(), 0644);
}

TEST_F(MeshIoTest, GarbageObjHasNoTriangles) {
  expect_error(put("garbage.obj", "this is not\nan obj file at all\n"), "");
}

TEST_F(MeshIoTest, SaveStlRoundTrip) {
  const fs::path p = dir / "out.stl";
  ASSERT_TRUE(save_stl(cube, p).ok());
  EXPECT_EQ(fs::file_size(p), 84U + 50U * 12U);
  expect_cube(*load_mesh(p), 10, Vec3(1, 2, 3));
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

/// load_mesh_from_memory gives exactly what load_mesh gives for the same bytes, in every
/// format, and names the given path in its errors without touching the file system.
TEST_F(MeshIoTest, FromMemoryMatchesFromFile) {
  const std::vector<std::pair<std::string, std::string>> files = {
      {"m.stl", ascii_stl(cube)}, {"mb.stl", binary_stl(cube, 12)},
      {"m.obj", obj(cube)},       {"m.off", off(cube)},
      {"m.ply", ply(cube)},       {"m.amf", amf(cube)}};
  for (const auto& [name, bytes] : files) {
    auto from_file = load_mesh(put(name, bytes), {2.0, LengthUnit::cm});
    auto from_memory =
        load_mesh_from_memory(bytes, dir / "not_on_disk" / name, {2.0, LengthUnit::cm});
    ASSERT_TRUE(from_file.ok()) << name;
    ASSERT_TRUE(from_memory.ok()) << name << ": " << from_memory.error().describe();
    EXPECT_EQ(*from_file, *from_memory) << name;
    EXPECT_NEAR(signed_volume_mm3(*from_memory), 200.0 * 200.0 * 200.0, 1e-3) << name;
  }
  auto bad = load_mesh_from_memory("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n",
                                   "mem/part.stl");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().file, "mem/part.stl");
  EXPECT_NE(bad.error().message.find("expected 'vertex', found 'end of file'"), std::string::npos);
  EXPECT_FALSE(load_mesh_from_memory(ascii_stl(cube), "part.xyz").ok());
  EXPECT_NE(load_mesh_from_memory("", "part.stl").error().message.find("empty file"),
            std::string::npos);
}

/// Binary STL is read straight from its bytes; assimp's import (PRINTTWIN_PLAIN=stl_direct)
/// gives the same mesh: vertices in order of first use, -0 and +0 one vertex, repeated and
/// zero-area facets kept, the same scaled coordinates.
TEST_F(MeshIoTest, DirectBinaryStlMatchesAssimp) {
  Mesh m = test::make_cube_mm(10, Vec3(-5, -0.0, 3.25));
  m.vertices_mm[1].x() = -0.0;            // -0 (written as a float -0) joins +0
  m.triangles.push_back(m.triangles[3]);  // a repeated facet
  m.triangles.push_back({m.triangles[0][0], m.triangles[0][0], m.triangles[0][1]});
  const std::string bytes = binary_stl(m, static_cast<std::uint32_t>(m.triangles.size()));
  for (const MeshLoadOptions& o : {MeshLoadOptions{}, MeshLoadOptions{0.3, LengthUnit::inch}}) {
    auto direct = load_mesh_from_memory(bytes, "p.stl", o);
    ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "stl_direct", 1), 0);
    auto assimp = load_mesh_from_memory(bytes, "p.stl", o);
    ::unsetenv("PRINTTWIN_PLAIN");
    ASSERT_TRUE(direct.ok() && assimp.ok());
    EXPECT_EQ(*direct, *assimp);
    EXPECT_EQ(direct->triangles.size(), 14U);
  }
}

/// ASCII STL is read from the tokens the grammar check parsed; assimp's import
/// (PRINTTWIN_PLAIN=stl_direct) gives the same mesh up to its approximate decimal reading
/// (within a float's rounding), in the same vertex order. Several solids in one file are one
/// mesh; padding after the last endsolid is ignored.
TEST_F(MeshIoTest, DirectAsciiStlMatchesAssimp) {
  Mesh m = test::make_cube_mm(10, Vec3(-5.1, -0.0, 3.25));
  m.vertices_mm[1].x() = -0.0;
  m.vertices_mm[2].y() = 0.3;  // not a float: rounded
  m.triangles.push_back(m.triangles[3]);
  const std::string one = ascii_stl(m);
  const std::string two = one + one + "\n \n";  // a second solid, then padding
  for (const std::string& text : {one, two})
    for (const MeshLoadOptions& o : {MeshLoadOptions{}, MeshLoadOptions{0.3, LengthUnit::inch}}) {
      auto direct = load_mesh_from_memory(text, "p.stl", o);
      ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "stl_direct", 1), 0);
      auto assimp = load_mesh_from_memory(text, "p.stl", o);
      ::unsetenv("PRINTTWIN_PLAIN");
      ASSERT_TRUE(direct.ok() && assimp.ok()) << direct.error().describe();
      EXPECT_EQ(direct->triangles, assimp->triangles);
      ASSERT_EQ(direct->vertices_mm.size(), assimp->vertices_mm.size());
      for (std::size_t i = 0; i < direct->vertices_mm.size(); ++i)
        EXPECT_LT((direct->vertices_mm[i] - assimp->vertices_mm[i]).norm(), 1e-5);
      EXPECT_EQ(direct->triangles.size(), (text == one ? 1U : 2U) * 13U);
      EXPECT_EQ(direct->vertices_mm.size(), 8U);
      // The float STL stores, correctly rounded, then scaled.
      const double want =
          (o.units == LengthUnit::inch ? 25.4 : 1.0) * o.scale * static_cast<double>(0.3F);
      EXPECT_TRUE(std::any_of(direct->vertices_mm.begin(), direct->vertices_mm.end(),
                              [&](const Vec3& p) { return p.y() == want; }));
    }
  // A second solid is checked as the first: a bad token in it names its line.
  std::string broken = one + one;
  const std::size_t second = broken.find("vertex", one.size());
  broken.replace(second, 6, "vortex");
  const long line = 1 + std::count(broken.begin(), broken.begin() + second, '\n');
  auto bad = load_mesh_from_memory(broken, "p.stl");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().line, std::optional<long>(line));
  EXPECT_NE(bad.error().message.find("expected 'vertex', found 'vortex'"), std::string::npos);
}

TEST_F(MeshIoTest, AsciiStlAfterAByteOrderMark) {
  // A text editor's UTF-8 byte order mark before "solid": the same mesh, read directly, through
  // assimp and from a file (whose header check comes first).
  const std::string text = ascii_stl(test::make_cube_mm(10, Vec3(0, 0, 0)));
  const std::string marked = "\xEF\xBB\xBF" + text;
  auto plain = load_mesh_from_memory(text, "p.stl");
  auto direct = load_mesh_from_memory(marked, "p.stl");
  ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "stl_direct", 1), 0);
  auto assimp = load_mesh_from_memory(marked, "p.stl");
  ::unsetenv("PRINTTWIN_PLAIN");
  const auto path = test::temp_dir("stl_bom") / "bom.stl";
  ASSERT_TRUE(write_file_atomic(path, marked).ok());
  auto file = load_mesh(path);
  ASSERT_TRUE(plain.ok());
  for (const auto* m : {&direct, &assimp, &file}) {
    ASSERT_TRUE(m->ok()) << m->error().describe();
    EXPECT_EQ((*m)->triangles, plain->triangles);
    EXPECT_EQ((*m)->vertices_mm, plain->vertices_mm);
  }
}

TEST_F(MeshIoTest, TextFormatsAfterAByteOrderMark) {
  // OBJ (its first line a vertex), OFF and ASCII PLY with a UTF-8 byte order mark read as
  // without it.
  const std::vector<std::pair<std::string, std::string>> files = {
      {"t.obj", "v 0 0 0\nv 10 0 0\nv 0 10 0\nv 0 0 10\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"},
      {"t.off", "OFF\n4 4 0\n0 0 0\n10 0 0\n0 10 0\n0 0 10\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"},
      {"t.ply",
       "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
       "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
       "0 0 0\n10 0 0\n0 10 0\n0 0 10\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"}};
  for (const auto& [name, text] : files) {
    SCOPED_TRACE(name);
    auto plain = load_mesh_from_memory(text, name);
    auto marked = load_mesh_from_memory("\xEF\xBB\xBF" + text, name);
    ASSERT_TRUE(plain.ok()) << plain.error().describe();
    ASSERT_TRUE(marked.ok()) << marked.error().describe();
    EXPECT_EQ(marked->triangles, plain->triangles);
    EXPECT_EQ(marked->vertices_mm, plain->vertices_mm);
    EXPECT_EQ(marked->triangles.size(), 4U);
  }
}

TEST_F(MeshIoTest, PlyHeaderFreeTextAndLongAsciiLinesAreTolerated) {
  // Blender 2.4x wrote its credit line into the header without 'comment'; VCG/MeshLab files
  // carry values past their header's properties at the end of a face line. Both read as the
  // same tetrahedron as the plain file.
  const std::string head = "ply\nformat ascii 1.0\n";
  const std::string elements =
      "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 4\nproperty list uchar int vertex_indices\nproperty uchar red\nend_header\n"
      "0 0 0\n10 0 0\n0 10 0\n0 0 10\n";
  const std::string faces = "3 0 2 1 7\n3 0 1 3 7\n3 0 3 2 7\n3 1 2 3 7\n";
  auto plain = load_mesh_from_memory(head + elements + faces, "t.ply");
  ASSERT_TRUE(plain.ok()) << plain.error().describe();
  EXPECT_EQ(plain->triangles.size(), 4U);
  auto blender = load_mesh_from_memory(
      head + "Created by Blender3D 247 - www.blender.org, source file: 't.blend'\n" + elements +
          faces,
      "t.ply");
  ASSERT_TRUE(blender.ok()) << blender.error().describe();
  EXPECT_EQ(blender->triangles, plain->triangles);
  EXPECT_EQ(blender->vertices_mm, plain->vertices_mm);
  auto longer = load_mesh_from_memory(
      head + elements + "3 0 2 1 7 9 1 1 1\n3 0 1 3 7 9 1\n3 0 3 2 7\n3 1 2 3 7 0.5 0.25\n",
      "t.ply");
  ASSERT_TRUE(longer.ok()) << longer.error().describe();
  EXPECT_EQ(longer->triangles, plain->triangles);
  // A line short of its element's values is still an error.
  auto shorter = load_mesh_from_memory(head + elements + "3 0 2 1 7\n3 0 1\n", "t.ply");
  ASSERT_FALSE(shorter.ok());
}

/// Vertices are numbered in order of first use; -0 and +0 are one coordinate; sub-meshes
/// (OBJ objects) share the vertices they have in common.
TEST_F(MeshIoTest, WeldKeepsFirstUseOrderAndJoinsAcrossSubMeshes) {
  const std::string text =
      "o a\nv 1 0 0\nv 0 1 0\nv -0 0 0\nv 0 0 1\nf 3 1 2\nf 3 2 4\n"
      "o b\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 5 6 7\n";
  auto m = load_mesh_from_memory(text, "two.obj");
  ASSERT_TRUE(m.ok()) << m.error().describe();
  ASSERT_EQ(m->triangles.size(), 3U);
  ASSERT_EQ(m->vertices_mm.size(), 4U);
  EXPECT_EQ(m->vertices_mm[0], Vec3(0, 0, 0));  // first corner of the first face
  EXPECT_EQ(m->vertices_mm[1], Vec3(1, 0, 0));
  EXPECT_EQ(m->vertices_mm[2], Vec3(0, 1, 0));
  EXPECT_EQ(m->vertices_mm[3], Vec3(0, 0, 1));
  const std::array<std::uint32_t, 3> first = {0, 1, 2}, third = {0, 1, 3};
  EXPECT_EQ(m->triangles[0], first);
  EXPECT_EQ(m->triangles[2], third);
}

/// The ASCII STL grammar check accepts every number form from_chars accepts (fast path or
/// not) and rejects the rest with the line.
TEST_F(MeshIoTest, AsciiStlNumberForms) {
  auto stl = [](const std::string& a, const std::string& b) {
    return "solid t\nfacet normal " + a + " 0 1\nouter loop\nvertex " + b +
           " 0 0\nvertex 10 0 0\nvertex 0 10 0\nendloop\nendfacet\nendsolid t\n";
  };
  for (const std::string num :
       {"1.", ".5", "-0", "+2", "1e1", "1E+01", "-1.5e-2", "0.000000000000000000000000000001",
        "12345678901234567890123456789012345678", "3.4e38"}) {
    auto m = load_mesh_from_memory(stl("nan", num), "n.stl");
    ASSERT_TRUE(m.ok()) << num << ": " << m.error().describe();
    EXPECT_NEAR(bounding_box(*m).min.x(), std::min(0.0, std::stod(num)), 1e-6) << num;
  }
  // Beyond single precision (STL's type; assimp would read a wrong finite number or infinity).
  for (const std::string num :
       {"1e39", "-1e308", "12345678901234567890123456789012345678901234567890"}) {
    auto m = load_mesh_from_memory(stl("0", num), "n.stl");
    ASSERT_FALSE(m.ok()) << num;
    EXPECT_EQ(m.error().line, 4) << num;
    EXPECT_NE(m.error().message.find("beyond the single-precision range"), std::string::npos)
        << m.error().describe();
  }
  for (const std::string num : {"1e400", "1.5.5", "1e", "--1", "0x10", "1,5"}) {
    auto m = load_mesh_from_memory(stl("0", num), "n.stl");
    ASSERT_FALSE(m.ok()) << num;
    EXPECT_EQ(m.error().line, 4) << num;
    EXPECT_NE(m.error().message.find("expected a number, found '" + num + "'"), std::string::npos)
        << m.error().describe();
  }
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

TEST(MeshMeasures, SliversAndDegenerateTrianglesHaveNoReliableNormal) {
  Mesh m;
  m.vertices_mm = {Vec3(0, 0, 0), Vec3(1, 0, 0),    Vec3(0, 1, 0),        // a fair triangle
                   Vec3(2, 0, 0), Vec3(3, 0, 1e-9), Vec3(4, 0, 0),        // a sliver (height 1e-9)
                   Vec3(5, 0, 0), Vec3(6, 1, 1),    Vec3(7, 2, 2),        // collinear
                   Vec3(8, 0, 0), Vec3(8, 0, 0),    Vec3(9, 1, 0),        // a repeated vertex
                   Vec3(0, 0, 0), Vec3(1, 0, 0),    Vec3(0.5, 1e-5, 0)};  // thin but sound
  for (std::uint32_t t = 0; t < 5; ++t) m.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
  EXPECT_TRUE(has_reliable_normal(m, 0));
  EXPECT_FALSE(has_reliable_normal(m, 1));
  EXPECT_FALSE(has_reliable_normal(m, 2));
  EXPECT_FALSE(has_reliable_normal(m, 3));
  EXPECT_TRUE(has_reliable_normal(m, 4));
}

}  // namespace
}  // namespace printtwin
