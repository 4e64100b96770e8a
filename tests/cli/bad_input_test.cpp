// The bad-input corpus: every input a hostile or careless user may hand the command line,
// each with the exit code and the key words of the message it must give. The promise:
// no crash (a signal or exit 4), no silent pass (a case that is not a real success says why,
// with exit 1, 2 or 3). Inputs are built here, in a temporary folder.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

namespace fs = std::filesystem;

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

void put(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
}

/// Binary STL bytes: `count` in the header, `triangles` whole records of `coord` corners.
std::string binary_stl(std::uint32_t count, std::size_t triangles, float coord = 1.0f) {
  std::string s(84, '\0');
  std::memcpy(s.data() + 80, &count, 4);
  for (std::size_t t = 0; t < triangles; ++t) {
    float v[12] = {0, 0, 1, 0, 0, 0, coord, 0, 0, 0, coord, 0};
    s.append(reinterpret_cast<const char*>(v), sizeof(v));
    s.append(2, '\0');
  }
  return s;
}

std::string ascii_facet(const std::string& a, const std::string& b, const std::string& c) {
  return "facet normal 0 0 1\n outer loop\n  vertex " + a + "\n  vertex " + b + "\n  vertex " + c +
         "\n endloop\nendfacet\n";
}

/// A closed cube as OFF text, with `faces_announced` in the header (12 are written).
std::string cube_off(int faces_announced) {
  std::string s = "OFF\n8 " + std::to_string(faces_announced) + " 0\n";
  for (int i = 0; i < 8; ++i)
    s += std::to_string(10 * (i & 1)) + " " + std::to_string(10 * ((i >> 1) & 1)) + " " +
         std::to_string(10 * ((i >> 2) & 1)) + "\n";
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& t : f)
    s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) +
         "\n";
  return s;
}

/// Writes a binary STL of `mesh` and returns its path.
fs::path stl_of(const fs::path& dir, const std::string& name, const Mesh& mesh) {
  const fs::path p = dir / name;
  EXPECT_TRUE(save_stl(mesh, p).ok());
  return p;
}

const std::string kStart = "G28\nM104 S200\nM140 S60\nM109 S200\nM190 S60\nG92 E0\n";

struct Case {
  std::string name;
  /// Builds the inputs in `dir` and returns the command line's arguments.
  std::function<std::string(const fs::path& dir)> args;
  int exit_code;
  std::vector<std::string> words;  ///< each must appear in stderr or stdout
  double max_seconds = 60;         ///< limits checked before the expensive work answer fast
};

std::vector<Case> corpus() {
  const fs::path cube20 = test::source_path("samples/models/calibration_cube_20mm.stl");
  const fs::path prusa_gcode = test::source_path("samples/gcode/prusa_cube10.gcode");
  std::vector<Case> c;
  // --- files that are not there or not files
  c.push_back({"missing file",
               [](const fs::path& d) { return "check " + q(d / "nope.stl"); },
               3,
               {"nope.stl", "file not found"}});
  c.push_back({"a directory",
               [](const fs::path& d) {
                 fs::create_directories(d / "dir.stl");
                 return "check " + q(d / "dir.stl");
               },
               3,
               {"dir.stl", "is a directory"}});
  c.push_back({"symlink loop",
               [](const fs::path& d) {
                 fs::create_symlink(d / "loop_b.stl", d / "loop_a.stl");
                 fs::create_symlink(d / "loop_a.stl", d / "loop_b.stl");
                 return "check " + q(d / "loop_a.stl");
               },
               3,
               {"loop_a.stl", "symbolic link loop"}});
  c.push_back({"dangling symlink",
               [](const fs::path& d) {
                 fs::create_symlink(d / "gone.stl", d / "dangling.stl");
                 return "check " + q(d / "dangling.stl");
               },
               3,
               {"dangling.stl", "dangling symbolic link"}});
  c.push_back({"missing G-code",
               [](const fs::path& d) { return "simulate " + q(d / "nope.gcode"); },
               3,
               {"nope.gcode", "file not found"}});
  // --- STL
  c.push_back({"empty STL",
               [](const fs::path& d) {
                 put(d / "empty.stl", "");
                 return "check " + q(d / "empty.stl");
               },
               3,
               {"empty.stl", "empty file"}});
  c.push_back({"STL shorter than its header",
               [](const fs::path& d) {
                 put(d / "short.stl", std::string(50, 'x'));
                 return "check " + q(d / "short.stl");
               },
               3,
               {"short.stl", "truncated binary STL"}});
  c.push_back({"truncated binary STL",
               [](const fs::path& d) {
                 put(d / "trunc.stl", binary_stl(10, 2));
                 return "check " + q(d / "trunc.stl");
               },
               3,
               {"trunc.stl", "announces 10 triangles", "2 whole triangles"}});
  c.push_back({"truncated binary STL whose header starts with solid",
               [](const fs::path& d) {
                 std::string bytes = binary_stl(10, 2);
                 bytes.replace(0, 12, "solid part  ");  // as some exporters name the header
                 put(d / "solidtrunc.stl", bytes);
                 return "check " + q(d / "solidtrunc.stl");
               },
               3,
               {"solidtrunc.stl", "announces 10 triangles", "2 whole triangles"}});
  c.push_back({"count 4e9",
               [](const fs::path& d) {
                 put(d / "count.stl", binary_stl(4000000000u, 1));
                 return "check " + q(d / "count.stl");
               },
               3,
               {"announces 4000000000 triangles"}});
  c.push_back({"binary STL of 0 triangles",
               [](const fs::path& d) {
                 put(d / "zero.stl", binary_stl(0, 0));
                 return "check " + q(d / "zero.stl");
               },
               3,
               {"0 triangles"}});
  // 1 GB of zeros (a sparse file): the header says 0 triangles; the body is never read.
  c.push_back({"1 GB of zeros",
               [](const fs::path& d) {
                 put(d / "zeros.stl", "");
                 fs::resize_file(d / "zeros.stl", std::uintmax_t{1} << 30);
                 return "check " + q(d / "zeros.stl");
               },
               3,
               {"zeros.stl", "0 triangles"},
               2.0});
  c.push_back({"NaN in a binary STL",
               [](const fs::path& d) {
                 put(d / "nan.stl", binary_stl(1, 1, std::nanf("")));
                 return "check " + q(d / "nan.stl");
               },
               3,
               {"nan.stl", "NaN or infinite"}});
  c.push_back({"garbage ASCII STL",
               [](const fs::path& d) {
                 put(d / "garbage.stl",
                     "solid a\nfacet normal 0 0 1\nouter loop\nvertex 1 2 3\nvertex oops\n");
                 return "check " + q(d / "garbage.stl");
               },
               3,
               {"garbage.stl:5:", "expected a number", "oops"}});
  c.push_back({"ASCII STL coordinate 1e308",
               [](const fs::path& d) {
                 put(d / "huge.stl",
                     "solid a\n" + ascii_facet("0 0 0", "1e308 0 0", "0 1 0") + "endsolid a\n");
                 return "check " + q(d / "huge.stl");
               },
               3,
               {"huge.stl:5:", "1e308", "single-precision"}});
  c.push_back({"ASCII STL NaN coordinate",
               [](const fs::path& d) {
                 put(d / "nanascii.stl",
                     "solid a\n" + ascii_facet("0 0 0", "nan 0 0", "0 1 0") + "endsolid a\n");
                 return "check " + q(d / "nanascii.stl");
               },
               3,
               {"nanascii.stl:5:", "NaN or infinite"}});
  c.push_back({"ASCII STL without endsolid",
               [](const fs::path& d) {
                 put(d / "noend.stl", "solid a\n" + ascii_facet("0 0 0", "1 0 0", "0 1 0"));
                 return "check " + q(d / "noend.stl");
               },
               3,
               {"noend.stl", "missing 'endsolid'"}});
  c.push_back({"NUL bytes in an ASCII STL",
               [](const fs::path& d) {
                 put(d / "nul.stl", std::string("solid a\nfacet normal 0 0 1\n outer\0loop\n", 40));
                 return "check " + q(d / "nul.stl");
               },
               3,
               {"nul.stl:3:", "expected 'outer', found 'outer?loop'"}});
  c.push_back({"unknown extension",
               [](const fs::path& d) {
                 put(d / "part.step", "ISO-10303-21;");
                 return "check " + q(d / "part.step");
               },
               3,
               {"unknown mesh extension '.step'"}});
  // --- OFF, PLY, OBJ, 3MF, AMF
  c.push_back({"OFF announcing 13 faces, holding 12",
               [](const fs::path& d) {
                 put(d / "part.off", cube_off(13));
                 return "check " + q(d / "part.off");
               },
               3,
               {"part.off", "announces 13 faces", "ends after 12"}});
  c.push_back({"OFF face index out of range",
               [](const fs::path& d) {
                 std::string s = cube_off(12);
                 s.replace(s.rfind("3 7 5"), 5, "3 7 9");
                 put(d / "index.off", s);
                 return "check " + q(d / "index.off");
               },
               3,
               {"index.off:22:", "vertex index '9'", "8 vertices"}});
  c.push_back({"OFF without its keyword",
               [](const fs::path& d) {
                 put(d / "nokey.off", "8 12 0\n");
                 return "check " + q(d / "nokey.off");
               },
               3,
               {"nokey.off:1:", "expected the keyword 'OFF'"}});
  c.push_back({"OFF counts beyond the file",
               [](const fs::path& d) {
                 put(d / "big.off", "OFF\n4000000000 4000000000 0\n0 0 0\n");
                 return "check " + q(d / "big.off");
               },
               3,
               {"big.off:2:", "more than a file of"}});
  c.push_back(
      {"PLY announcing more vertices than it holds",
       [](const fs::path& d) {
         put(d / "short.ply",
             "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
             "property float z\nelement face 1\nproperty list uchar int "
             "vertex_indices\nend_header\n"
             "0 0 0\n1 0 0\n");
         return "check " + q(d / "short.ply");
       },
       3,
       {"short.ply:3:", "announces 8 'vertex' elements", "more than the rest of the file holds"}});
  // Found by fuzzing: a binary PLY face of 0 corners reached an assertion in assimp.
  c.push_back({"binary PLY face of 0 corners",
               [](const fs::path& d) {
                 put(d / "zero.ply",
                     "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float "
                     "x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int "
                     "vertex_indices\nend_header\n" +
                         std::string(37, '\0'));
                 return "check " + q(d / "zero.ply");
               },
               3,
               {"zero.ply", "holds no triangles"}});
  c.push_back({"binary PLY ending inside a face",
               [](const fs::path& d) {
                 put(d / "cut.ply",
                     "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float "
                     "x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int "
                     "vertex_indices\nend_header\n" +
                         std::string(36, '\0') + "\x03" + std::string(5, '\0'));
                 return "check " + q(d / "cut.ply");
               },
               3,
               {"cut.ply", "ends inside element 'face' 0"}});
  c.push_back({"PLY face index out of range",
               [](const fs::path& d) {
                 put(d / "idx.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float "
                     "y\nproperty float z\n"
                     "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 "
                     "0 0\n0 1 0\n3 0 1 7\n");
                 return "check " + q(d / "idx.ply");
               },
               3,
               {"idx.ply:13:", "vertex index 7", "3 vertices"}});
  c.push_back({"OBJ face index out of range",
               [](const fs::path& d) {
                 put(d / "index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
                 return "check " + q(d / "index.obj");
               },
               3,
               {"index.obj"}});
  c.push_back({"3MF that is not a zip",
               [](const fs::path& d) {
                 put(d / "part.3mf", "<model>not a zip</model>");
                 return "check " + q(d / "part.3mf");
               },
               3,
               {"part.3mf", "not a 3MF file", "zip"}});
  c.push_back({"truncated 3MF zip",
               [](const fs::path& d) {
                 put(d / "cut.3mf", std::string("PK\x03\x04\x04\0]\0", 8));
                 return "check " + q(d / "cut.3mf");
               },
               3,
               {"cut.3mf", "not a complete zip archive"}});
  // The package relationships name a root model the archive lacks.
  c.push_back({"3MF package without its root model",
               [](const fs::path& d) {
                 put(d / "noroot.3mf",
                     test::make_zip({{"_rels/.rels",
                                      "<Relationships><Relationship Target=\"/3D/part.model\" "
                                      "Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/"
                                      "3dmodel\"/></Relationships>"},
                                     {"3D/3dmodel.model", "<model/>"}},
                                    true));
                 return "check " + q(d / "noroot.3mf");
               },
               3,
               {"noroot.3mf", "root model '/3D/part.model'", "is not in the archive"}});
  // A Bambu Studio / OrcaSlicer project whose component names a model file it lacks.
  c.push_back(
      {"3MF component naming a model file the archive lacks",
       [](const fs::path& d) {
         put(d / "bambu.3mf",
             test::make_zip({{"3D/Objects/object_1.model", "<model/>"},
                             {"3D/3dmodel.model",
                              "<model xmlns:p=\"p\"><resources><object id=\"2\"><components>"
                              "<component p:path=\"/3D/Objects/object_9.model\" objectid=\"1\"/>"
                              "</components></object></resources>"
                              "<build><item objectid=\"2\"/></build></model>"}},
                            true));
         return "check " + q(d / "bambu.3mf");
       },
       3,
       {"bambu.3mf", "3D/3dmodel.model", "'/3D/Objects/object_9.model' is not in the archive"}});
  c.push_back({"AMF that is neither XML nor zip",
               [](const fs::path& d) {
                 put(d / "part.amf", "solid a\n");
                 return "check " + q(d / "part.amf");
               },
               3,
               {"part.amf", "not an AMF file"}});
  // --- meshes that load but cannot print: the verdict follows the findings
  c.push_back({"0.01 mm cube",
               [](const fs::path& d) {
                 return "check " + q(stl_of(d, "tiny.stl", test::make_cube_mm(0.01))) +
                        " --units mm";
               },
               1,
               {"NOT PRINTABLE", "small_feature", "nothing will print"}});
  c.push_back({"zero-area mesh: check",
               [](const fs::path& d) {
                 put(d / "flat.stl", "solid a\n" + ascii_facet("0 0 0", "1 0 0", "2 0 0") +
                                         ascii_facet("0 0 0", "2 0 0", "1 0 0") + "endsolid a\n");
                 return "check " + q(d / "flat.stl");
               },
               1,
               {"NOT PRINTABLE"}});
  c.push_back({"zero-area mesh: slice",
               [](const fs::path& d) {
                 put(d / "flat.stl", "solid a\n" + ascii_facet("0 0 0", "1 0 0", "2 0 0") +
                                         ascii_facet("0 0 0", "2 0 0", "1 0 0") + "endsolid a\n");
                 return "slice " + q(d / "flat.stl") + " -o " + q(d / "flat.gcode");
               },
               3,
               {"flat.stl", "zero area", "not printable"}});
  c.push_back({"repair of a single triangle",
               [](const fs::path& d) {
                 put(d / "one.stl",
                     "solid a\n" + ascii_facet("0 0 0", "10 0 0", "0 10 0") + "endsolid a\n");
                 return "check " + q(d / "one.stl") + " --repair " + q(d / "fixed.stl");
               },
               3,
               {"one.stl", "repair would leave no triangles", "fewer than 4"}});
  c.push_back({"repair of an all-degenerate mesh",
               [](const fs::path& d) {
                 put(d / "degen.stl",
                     "solid a\n" + ascii_facet("0 0 0", "1 0 0", "2 0 0") + "endsolid a\n");
                 return "check " + q(d / "degen.stl") + " --repair " + q(d / "fixed.stl");
               },
               3,
               {"degen.stl", "repair would leave no triangles", "degenerate"}});
  // --- parts larger than the printer: rejected before the expensive work
  c.push_back({"10 m part: check",
               [](const fs::path& d) {
                 return "check " + q(stl_of(d, "huge.stl", test::make_cube_mm(10000)));
               },
               1,
               {"NOT PRINTABLE", "does not fit"},
               20});
  c.push_back({"10 m part: slice",
               [](const fs::path& d) {
                 return "slice " + q(stl_of(d, "huge.stl", test::make_cube_mm(10000))) + " -o " +
                        q(d / "h.gcode");
               },
               3,
               {"does not fit the build volume"},
               20});
  c.push_back({"10 m part: verify",
               [](const fs::path& d) {
                 return "verify " + q(stl_of(d, "huge.stl", test::make_cube_mm(10000))) +
                        " --out " + q(d / "r");
               },
               3,
               {"huge.stl", "larger than the build volume", "nothing to verify"},
               20});
  c.push_back(
      {"1 m plate: verify",
       [](const fs::path& d) {
         return "verify " +
                q(stl_of(d, "plate.stl", make_box_mesh(Vec3::Zero(), Vec3(1000, 1000, 2)))) +
                " --out " + q(d / "r");
       },
       3,
       {"larger than the build volume"},
       20});
  c.push_back({"box near 1e38 mm: verify",
               [prusa_gcode](const fs::path& d) {
                 return "verify " +
                        q(stl_of(d, "far.stl",
                                 make_box_mesh(Vec3::Constant(-1e38), Vec3::Constant(1e38)))) +
                        " --gcode " + q(prusa_gcode) + " --out " + q(d / "r");
               },
               3,
               {"larger than the build volume"},
               20});
  // --- outputs that cannot be written: rejected before the computation
  c.push_back({"verify --out an existing file",
               [cube20](const fs::path& d) {
                 put(d / "taken", "x");
                 return "verify " + q(cube20) + " --out " + q(d / "taken");
               },
               2,
               {"--out", "taken", "exists and is a file"},
               5});
  c.push_back({"compare --out an existing file",
               [cube20](const fs::path& d) {
                 put(d / "taken", "x");
                 return "compare " + q(cube20) + " --vary layer_height=0.2,0.3 --out " +
                        q(d / "taken");
               },
               2,
               {"--out", "exists and is a file"},
               5});
  c.push_back({"check --json a folder",
               [cube20](const fs::path& d) { return "check " + q(cube20) + " --json " + q(d); },
               2,
               {"--json", "is a folder"},
               5});
  c.push_back({"slice -o below a file",
               [cube20](const fs::path& d) {
                 put(d / "file", "x");
                 return "slice " + q(cube20) + " -o " + q(d / "file" / "part.gcode");
               },
               2,
               {"--output", "is a file, not a folder"},
               5});
  c.push_back({"simulate --deposit a folder",
               [prusa_gcode](const fs::path& d) {
                 fs::create_directories(d / "d.ot");
                 return "simulate " + q(prusa_gcode) + " --deposit " + q(d / "d.ot");
               },
               2,
               {"--deposit", "is a folder"},
               5});
  // --- G-code that is not a print
  c.push_back({"empty G-code",
               [](const fs::path& d) {
                 put(d / "empty.gcode", "");
                 return "simulate " + q(d / "empty.gcode");
               },
               3,
               {"empty.gcode", "no moves"}});
  c.push_back({"comment-only G-code, --strict",
               [](const fs::path& d) {
                 put(d / "comments.gcode", "; generated by nothing\n;LAYER:0\n\n");
                 return "simulate --strict " + q(d / "comments.gcode");
               },
               3,
               {"comments.gcode", "no moves", "3 lines"}});
  c.push_back({"comment-only G-code with --deposit",
               [](const fs::path& d) {
                 put(d / "comments.gcode", "; nothing\n");
                 return "simulate " + q(d / "comments.gcode") + " --deposit " + q(d / "c.ot");
               },
               3,
               {"no moves"}});
  c.push_back({"garbage G-code",
               [](const fs::path& d) {
                 put(d / "garbage.gcode", "this is not g-code\n");
                 return "simulate " + q(d / "garbage.gcode");
               },
               3,
               {"garbage.gcode", "no moves: 1 line but"}});
  // A line printtwin cannot run is skipped with a warning, and an error under --strict.
  for (const bool strict : {false, true}) {
    c.push_back(
        {std::string("unexpanded placeholder") + (strict ? ", --strict" : ""),
         [strict](const fs::path& d) {
           put(d / "ph.gcode", kStart + "G1 Z{layer_height} F600\nG1 X10 Y10 F3000\n");
           return std::string("simulate ") + (strict ? "--strict " : "") + q(d / "ph.gcode");
         },
         strict ? 3 : 0,
         strict ? std::vector<std::string>{"ph.gcode:7:", "unexpanded slicer placeholder"}
                : std::vector<std::string>{"bad_line (line 7)", "placeholder", "line skipped"}});
    c.push_back(
        {std::string("NUL bytes in G-code") + (strict ? ", --strict" : ""),
         [strict](const fs::path& d) {
           put(d / "nul.gcode", kStart + std::string("G1 X1\0Y2\n", 9) + "G1 X10 Y10 F3000\n");
           return std::string("simulate ") + (strict ? "--strict " : "") + q(d / "nul.gcode");
         },
         strict ? 3 : 0,
         strict ? std::vector<std::string>{"nul.gcode:7:", "byte 0x00"}
                : std::vector<std::string>{"bad_line (line 7)", "byte 0x00", "line skipped"}});
  }
  c.push_back({"1 MB line",
               [](const fs::path& d) {
                 put(d / "long.gcode",
                     kStart + "G1 X1 ;" + std::string(1 << 20, 'x') + "\nG1 X2\n");
                 return "simulate " + q(d / "long.gcode");
               },
               0,
               {"long.gcode", "lines         8", "longer than 65536 bytes"}});
  c.push_back({"1 MB number",
               [](const fs::path& d) {
                 put(d / "longnum.gcode",
                     kStart + "G1 X" + std::string(1 << 20, '1') + "\nG1 X2\n");
                 return "simulate --strict " + q(d / "longnum.gcode");
               },
               3,
               {"longnum.gcode:7:", "line longer than"}});
  c.push_back({"out-of-bounds moves",
               [](const fs::path& d) {
                 put(d / "oob.gcode", kStart + "G1 Z0.2 F600\nG1 X500 Y10 E5 F1200\n");
                 return "simulate --strict " + q(d / "oob.gcode");
               },
               1,
               {"out_of_bounds", "line 8", "leaves the build volume"}});
  // A zero-radius full circle (I0 J0 at the current position) with E: Marlin rejects it, so
  // its filament is never laid; a warning, an error under --strict.
  for (const bool strict : {false, true}) {
    c.push_back(
        {std::string("zero-radius arc with E") + (strict ? ", --strict" : ""),
         [strict](const fs::path& d) {
           put(d / "arc.gcode",
               kStart + "G1 Z0.2 F600\nG1 X50 Y50 F3000\nG2 X50 Y50 I0 J0 E5 F1200\nG1 X60 E1\n");
           return std::string("simulate ") + (strict ? "--strict " : "") + q(d / "arc.gcode");
         },
         strict ? 3 : 0,
         strict ? std::vector<std::string>{"arc.gcode:9:", "zero radius", "5.000 mm of filament"}
                : std::vector<std::string>{"bad_arc (line 9)", "zero radius", "not laid"}});
  }
  c.push_back({"verify with another part's G-code",
               [cube20, prusa_gcode](const fs::path& d) {
                 return "verify " + q(cube20) + " --gcode " + q(prusa_gcode) +
                        " --voxel 0.2 --out " + q(d / "r");
               },
               1,
               {"does not appear to be this part", "printed 9.6 x 9.6 x 9.8 mm"}});
  // --- empty deposits: every export writes a valid empty file, exit 0
  for (const char* ext : {".ot", ".bt", ".ply"}) {
    for (const char* kind : {"travel only", "all-cold extrusion"}) {
      const std::string e = ext;
      const std::string k = kind;
      c.push_back(
          {"empty deposit, " + k + ", " + e,
           [e, k](const fs::path& d) {
             const std::string body =
                 k == "travel only" ? "G28\nG1 Z0.2 F600\nG1 X50 Y50 F3000\nG1 X60\n"
                                    : "G28\nM83\nG1 Z0.2 F600\nG1 X50 Y50 E2 F1200\nG1 X60 E1\n";
             put(d / "g.gcode", body);
             return "simulate " + q(d / "g.gcode") +
                    (e == ".ply" ? " --deposit-ply " : " --deposit ") + q(d / ("d" + e));
           },
           k == "travel only" ? 0 : 1,
           k == "travel only" ? std::vector<std::string>{"deposit: 0 voxels"}
                              : std::vector<std::string>{"deposit: 0 voxels", "cold_extrusion"}});
    }
  }
  // --- option values
  c.push_back({"compare --vary unknown key",
               [cube20](const fs::path& d) {
                 return "compare " + q(cube20) + " --vary no_such_setting=1,2 --out " + q(d / "c");
               },
               2,
               {"no_such_setting"},
               10});
  c.push_back({"compare --vary negative layer height",
               [cube20](const fs::path& d) {
                 return "compare " + q(cube20) + " --vary layer_height=-0.2,0.2 --out " +
                        q(d / "c");
               },
               2,
               {"layer_height"},
               10});
  c.push_back({"slice --set unknown key",
               [cube20](const fs::path& d) {
                 return "slice " + q(cube20) + " --set no_such_setting=1 -o " + q(d / "c.gcode");
               },
               2,
               {"no_such_setting"},
               10});
  // Found by fuzzing: a number beyond double's range made the JSON reader throw past the
  // error handling (exit 4).
  c.push_back({"printer profile with a number overflow",
               [cube20](const fs::path& d) {
                 put(d / "printer.json", "{\"bed_max_x_mm\": 1E7777}");
                 return "check " + q(cube20) + " --printer " + q(d / "printer.json");
               },
               3,
               {"printer.json", "not valid JSON", "number overflow"},
               10});
  c.push_back({"compare manifest with a number overflow",
               [](const fs::path& d) {
                 put(d / "plan.json", "{\"schema\": \"printtwin.compare-plan\", \"x\": 1E7777}");
                 return "compare --manifest " + q(d / "plan.json") + " --out " + q(d / "c");
               },
               3,
               {"plan.json", "not valid JSON", "number overflow"},
               10});
  c.push_back({"Klipper printer.cfg with a word for a number",
               [cube20](const fs::path& d) {
                 put(d / "printer.cfg", "[printer]\nkinematics: cartesian\nmax_velocity: abc\n");
                 return "check " + q(cube20) + " --printer " + q(d / "printer.cfg");
               },
               3,
               {"printer.cfg:3:", "max_velocity", "expected a number"},
               10});
  c.push_back({"slicer .ini line without '='",
               [cube20](const fs::path& d) {
                 put(d / "bad.ini", "layer_height = 0.2\nperimeters 3\n");
                 return "slice " + q(cube20) + " --config " + q(d / "bad.ini") + " -o " +
                        q(d / "x.gcode");
               },
               3,
               {"bad.ini:2:", "expected 'key = value'", "perimeters 3"},
               10});
  c.push_back({"slicer .ini with an impossible layer height",
               [cube20](const fs::path& d) {
                 put(d / "neg.ini", "nozzle_diameter = 0.4\nlayer_height = -1\n");
                 return "slice " + q(cube20) + " --config " + q(d / "neg.ini") + " -o " +
                        q(d / "x.gcode");
               },
               3,
               {"neg.ini:2:", "layer_height", "-1", "(0.32 mm)"},
               10});
  c.push_back({"impossible layer height given on the command line",
               [cube20](const fs::path& d) {
                 return "slice " + q(cube20) + " --set layer_height=0.9 -o " + q(d / "x.gcode");
               },
               2,
               {"layer_height", "0.9", "80 % of the nozzle"},
               10});
  c.push_back({"printer profile that is not JSON",
               [cube20](const fs::path& d) {
                 put(d / "printer.json", "{ not json");
                 return "check " + q(cube20) + " --printer " + q(d / "printer.json");
               },
               3,
               {"printer.json"},
               10});
  return c;
}

TEST(BadInputCorpus, EveryCaseSaysWhyWithItsExitCode) {
  const std::vector<Case> cases = corpus();
  EXPECT_GE(cases.size(), 40u);
  int i = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path dir = test::temp_dir("bad_input_" + std::to_string(i++));
    const std::string args = c.args(dir);
    const auto t0 = std::chrono::steady_clock::now();
    const auto run = test::run_cli(args);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(run.exit_code, c.exit_code) << args << "\nstdout:\n"
                                          << run.out.substr(0, 2000) << "\nstderr:\n"
                                          << run.err;
    const std::string all = run.err + run.out;
    for (const auto& w : c.words)
      EXPECT_NE(all.find(w), std::string::npos) << "'" << w << "' missing in:\n"
                                                << all.substr(0, 2000);
    EXPECT_LE(seconds, c.max_seconds) << args;
    // Never a crash, never an internal error.
    EXPECT_EQ(all.find("internal error"), std::string::npos) << all;
    fs::remove_all(dir);
  }
}

}  // namespace
}  // namespace printtwin
