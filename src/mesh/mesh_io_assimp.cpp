// The only file that includes assimp: loads any supported mesh format into a Mesh.
//
// assimp is forgiving to a fault: it reads an ASCII STL full of garbage as "some triangles",
// and a binary STL whose header promises more triangles than the file holds as a shorter
// mesh. STL input is therefore validated here first (size against the header count, ASCII
// grammar with line numbers, finite coordinates) and only then handed to assimp.
//
// Speed (a 37 MB ASCII STL of 200k triangles is the benchmark): the bytes are read once
// (load_mesh_from_memory takes them from the caller, who also hashes them), the ASCII
// grammar check scans tokens with a table instead of the C locale, decimal numbers are
// checked by their grammar (from_chars only for the unusual ones), assimp reads STL without
// post-processing (STL holds only triangles under one identity node), and the weld is one
// pass with an open-addressing table straight from assimp's vertices.
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string_view>
#include <vector>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"

namespace printtwin {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kStlHeaderBytes = 84;     // 80-byte header + uint32 triangle count
constexpr std::size_t kStlTriangleBytes = 50;   // normal, 3 vertices (12 floats) + uint16

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool starts_with_solid(std::string_view bytes) {
  std::size_t i = 0;
  while (i < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[i])) != 0) ++i;
  return bytes.substr(i, 5) == "solid";
}

std::uint32_t stl_header_count(std::string_view bytes) {
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);  // little endian on every supported host
  return n;
}

/// A binary STL's size must be 84 + 50 * count. Some writers append a few bytes; more
/// bytes than announced is accepted, fewer is not.
Status validate_binary_stl(std::string_view bytes, const std::string& name) {
  if (bytes.size() < kStlHeaderBytes)
    return bad_input("truncated binary STL: " + std::to_string(bytes.size()) +
                         " bytes, the header alone needs 84",
                     name);
  const std::uint64_t count = stl_header_count(bytes);
  if (count == 0) return bad_input("binary STL with 0 triangles, expected a mesh", name);
  const std::uint64_t need = kStlHeaderBytes + kStlTriangleBytes * count;
  if (need > bytes.size()) {
    const std::uint64_t present = (bytes.size() - kStlHeaderBytes) / kStlTriangleBytes;
    return bad_input("binary STL header announces " + std::to_string(count) +
                         " triangles (" + std::to_string(need) + " bytes) but the file has " +
                         std::to_string(bytes.size()) + " bytes (" + std::to_string(present) +
                         " whole triangles): truncated or corrupt",
                     name);
  }
  for (std::uint64_t t = 0; t < count; ++t) {
    std::array<float, 9> v{};
    std::memcpy(v.data(), bytes.data() + kStlHeaderBytes + t * kStlTriangleBytes + 12,
                sizeof(v));
    for (float x : v)
      if (!std::isfinite(x))
        return bad_input("triangle " + std::to_string(t) + " (byte offset " +
                             std::to_string(kStlHeaderBytes + t * kStlTriangleBytes) +
                             ") has a NaN or infinite vertex coordinate",
                         name);
  }
  return Ok{};
}

constexpr std::array<bool, 256> kSpace = [] {
  std::array<bool, 256> t{};
  for (unsigned char c : {' ', '\t', '\n', '\r', '\v', '\f'}) t[c] = true;  // C-locale isspace
  return t;
}();

bool is_space(char c) { return kSpace[static_cast<unsigned char>(c)]; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// True when `tok` is a plain decimal number ([-]digits[.digits][e[+-]digits]) that
/// std::from_chars reads whole into a finite double: at most 40 characters and a one- or
/// two-digit exponent. False means "not sure" (the caller asks from_chars).
bool is_plain_finite_decimal(std::string_view tok) {
  if (tok.empty() || tok.size() > 40) return false;
  std::size_t i = tok[0] == '-' ? 1 : 0;
  std::size_t digits = 0;
  while (i < tok.size() && is_digit(tok[i])) ++i, ++digits;
  if (i < tok.size() && tok[i] == '.') {
    ++i;
    while (i < tok.size() && is_digit(tok[i])) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i == tok.size()) return true;
  if (tok[i] != 'e' && tok[i] != 'E') return false;
  ++i;
  if (i < tok.size() && (tok[i] == '+' || tok[i] == '-')) ++i;
  std::size_t exp_digits = 0;
  while (i < tok.size() && is_digit(tok[i])) ++i, ++exp_digits;
  return i == tok.size() && exp_digits >= 1 && exp_digits <= 2;
}

/// Checks the ASCII STL grammar: solid, { facet normal n n n, outer loop, 3 x vertex x y z,
/// endloop, endfacet }, endsolid. Reports the first deviation with its line.
Status validate_ascii_stl(std::string_view text, const std::string& name) {
  long line = 1;
  const char* pos = text.data();
  const char* const end = text.data() + text.size();
  long token_line = 1;
  auto next = [&]() -> std::string_view {
    while (pos < end && is_space(*pos)) {
      line += *pos == '\n' ? 1 : 0;
      ++pos;
    }
    token_line = line;
    const char* start = pos;
    while (pos < end && !is_space(*pos)) ++pos;
    return {start, static_cast<std::size_t>(pos - start)};
  };
  auto rest_of_line = [&] {
    while (pos < end && *pos != '\n') ++pos;
  };
  auto fail_expect = [&](std::string_view word, std::string_view got) -> Status {
    return bad_input("ASCII STL: expected '" + std::string(word) + "', found '" +
                         std::string(got.empty() ? "end of file" : got.substr(0, 40)) + "'",
                     name, token_line);
  };
  // Normals are ignored (recomputed from the vertices), so writers' "nan" normals of
  // zero-area facets pass; vertex coordinates must be finite.
  auto slow_number = [&](std::string_view tok, bool must_be_finite) -> Status {
    const char* first = tok.data();
    const char* last = tok.data() + tok.size();
    if (!tok.empty() && *first == '+') ++first;
    double out = 0;
    const auto [ptr, ec] = std::from_chars(first, last, out);
    if (tok.empty() || ec != std::errc() || ptr != last)
      return bad_input("ASCII STL: expected a number, found '" +
                           std::string(tok.empty() ? "end of file" : tok.substr(0, 40)) + "'",
                       name, token_line);
    if (must_be_finite && !std::isfinite(out))
      return bad_input("ASCII STL: NaN or infinite coordinate '" + std::string(tok) + "'", name,
                       token_line);
    return Ok{};
  };
  // One token per call, checked on the fast path; anything unusual takes the slow path,
  // which produces the error (or accepts e.g. "+1", "nan" normals, "1e300").
#define PRINTTWIN_EXPECT_WORD(word)                       \
  do {                                                    \
    const std::string_view got_ = next();                 \
    if (got_ != (word)) return fail_expect((word), got_); \
  } while (false)
#define PRINTTWIN_EXPECT_NUMBER(finite)                                     \
  do {                                                                      \
    const std::string_view tok_ = next();                                   \
    if (!is_plain_finite_decimal(tok_))                                     \
      if (auto st_ = slow_number(tok_, (finite)); !st_) return st_;         \
  } while (false)

  PRINTTWIN_EXPECT_WORD("solid");
  rest_of_line();  // the solid's name
  long facets = 0;
  for (;;) {
    const std::string_view tok = next();
    if (tok == "endsolid") break;
    if (tok.empty()) return bad_input("ASCII STL: missing 'endsolid' at the end", name, token_line);
    if (tok != "facet") return fail_expect("facet", tok);
    PRINTTWIN_EXPECT_WORD("normal");
    for (int i = 0; i < 3; ++i) PRINTTWIN_EXPECT_NUMBER(false);
    PRINTTWIN_EXPECT_WORD("outer");
    PRINTTWIN_EXPECT_WORD("loop");
    for (int k = 0; k < 3; ++k) {
      PRINTTWIN_EXPECT_WORD("vertex");
      for (int i = 0; i < 3; ++i) PRINTTWIN_EXPECT_NUMBER(true);
    }
    PRINTTWIN_EXPECT_WORD("endloop");
    PRINTTWIN_EXPECT_WORD("endfacet");
    ++facets;
  }
#undef PRINTTWIN_EXPECT_WORD
#undef PRINTTWIN_EXPECT_NUMBER
  if (facets == 0) return bad_input("ASCII STL with 0 facets, expected a mesh", name);
  return Ok{};
}

/// Scale and extension checks shared by both entry points.
Status check_mesh_request(const fs::path& path, const MeshLoadOptions& options) {
  if (!(options.scale > 0) || !std::isfinite(options.scale))
    return usage_error("scale must be a positive number, got " + format_number(options.scale));
  const std::string ext = lower(path.extension().string());
  static constexpr std::array<std::string_view, 6> kKnown = {".stl", ".obj", ".ply",
                                                             ".off", ".3mf", ".amf"};
  if (std::find(kKnown.begin(), kKnown.end(), ext) == kKnown.end())
    return bad_input("unknown mesh extension '" + ext +
                         "', expected .stl, .obj, .ply, .off, .3mf or .amf",
                     path.string());
  return Ok{};
}

double unit_factor(LengthUnit u) {
  switch (u) {
    case LengthUnit::mm: return 1.0;
    case LengthUnit::cm: return 10.0;
    case LengthUnit::inch: return 25.4;
  }
  return 1.0;
}

/// Open-addressing table from a point to its index in `points` (linear probing; the
/// power-of-two capacity doubles whenever it is half full, so probes stay short and the
/// table stays small enough for the cache: an STL has about one vertex per six corners).
class PointIndex {
 public:
  explicit PointIndex(std::size_t expected_keys) { resize(expected_keys); }
  /// Index of `p` in `points`, appending it when new. -0 and +0 are one coordinate.
  std::uint32_t find_or_add(const Vec3& p, std::vector<Vec3>& points) {
    for (std::size_t slot = hash(p) & mask_;; slot = (slot + 1) & mask_) {
      const std::uint32_t idx = slots_[slot];
      if (idx == kEmpty) {
        const auto added = static_cast<std::uint32_t>(points.size());
        points.push_back(p);
        slots_[slot] = added;
        if (2 * points.size() > slots_.size()) rehash(points);
        return added;
      }
      const Vec3& q = points[idx];
      if (q.x() == p.x() && q.y() == p.y() && q.z() == p.z()) return idx;
    }
  }

 private:
  static constexpr std::uint32_t kEmpty = UINT32_MAX;
  static std::uint64_t bits(double d) {
    const double z = d == 0 ? 0.0 : d;  // -0 -> +0
    std::uint64_t b = 0;
    std::memcpy(&b, &z, 8);
    return b;
  }
  static std::uint64_t hash(const Vec3& p) {
    std::uint64_t h = bits(p.x()) * 0x9E3779B97F4A7C15ULL ^ bits(p.y()) * 0xC2B2AE3D27D4EB4FULL ^
                      bits(p.z()) * 0x165667B19E3779F9ULL;
    h ^= h >> 31;
    h *= 0xD6E8FEB86659FD93ULL;
    return h ^ (h >> 32);
  }
  void resize(std::size_t keys) {
    std::size_t cap = 64;
    while (cap < 2 * keys) cap *= 2;
    slots_.assign(cap, kEmpty);
    mask_ = cap - 1;
  }
  void rehash(const std::vector<Vec3>& points) {
    resize(2 * points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      std::size_t slot = hash(points[i]) & mask_;
      while (slots_[slot] != kEmpty) slot = (slot + 1) & mask_;
      slots_[slot] = static_cast<std::uint32_t>(i);
    }
  }
  std::vector<std::uint32_t> slots_;
  std::size_t mask_ = 0;
};

/// Copies assimp's triangles into a Mesh scaled by `s`, joining vertices with identical
/// (scaled) coordinates, also across the sub-meshes of one file (assimp joins only within a
/// sub-mesh, and not at all for STL). Vertices are numbered in order of first use by the
/// triangles; unreferenced vertices are dropped; faces that are not triangles are skipped.
Result<Mesh> welded_mesh(const aiScene& scene, double s, const std::string& name) {
  std::size_t faces = 0;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh* am = scene.mMeshes[m];
    faces += am->mNumFaces;
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return bad_input("mesh " + std::to_string(m) + ", vertex " + std::to_string(v) +
                             " has a NaN or infinite coordinate",
                         name);
    }
  }
  Mesh mesh;
  mesh.triangles.reserve(faces);
  mesh.vertices_mm.reserve(faces / 2 + 16);  // a closed mesh has about half as many vertices
  PointIndex index(faces / 2 + 16);
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh* am = scene.mMeshes[m];
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines carry no volume
      std::array<std::uint32_t, 3> tri{};
      for (int k = 0; k < 3; ++k) {
        const aiVector3D& p = am->mVertices[face.mIndices[k]];
        tri[k] = index.find_or_add(Vec3(s * p.x, s * p.y, s * p.z), mesh.vertices_mm);
      }
      mesh.triangles.push_back(tri);
    }
  }
  return mesh;
}

}  // namespace

Result<Mesh> load_mesh(const fs::path& path, const MeshLoadOptions& options) {
  if (auto st = check_mesh_request(path, options); !st) return st.error();
  auto bytes = read_file(path);  // existence, directory and readability errors
  if (!bytes) return bytes.error();
  return load_mesh_from_memory(*bytes, path, options);
}

Result<Mesh> load_mesh_from_memory(std::string_view bytes, const fs::path& path,
                                   const MeshLoadOptions& options) {
  const std::string name = path.string();
  if (auto st = check_mesh_request(path, options); !st) return st.error();
  if (bytes.empty()) return bad_input("empty file, expected a mesh", name);

  const std::string ext = lower(path.extension().string());
  const bool is_stl = ext == ".stl";
  if (is_stl) {
    // Binary when the size matches the header count (even if it starts with "solid", as
    // some exporters write); ASCII when it starts with "solid"; binary otherwise.
    const bool size_matches_binary =
        bytes.size() >= kStlHeaderBytes &&
        kStlHeaderBytes + kStlTriangleBytes * std::uint64_t{stl_header_count(bytes)} == bytes.size();
    Status valid = (size_matches_binary || !starts_with_solid(bytes)) ? validate_binary_stl(bytes, name)
                                                                      : validate_ascii_stl(bytes, name);
    if (!valid) return valid.error();
  }

  Assimp::Importer importer;
  // Identical vertices are joined after import (welded_mesh): without it an STL is a soup of
  // loose triangles and nothing is closed. assimp's own aiProcess_JoinIdenticalVertices also
  // compares normals (an STL gives every corner its facet's normal) and took 0.2 s of CPU for
  // 200k triangles. STL needs no post-processing at all (triangles only, one identity node);
  // other formats are triangulated and their node transforms baked in (3MF/AMF build items).
  const unsigned flags = is_stl ? 0U : unsigned{aiProcess_Triangulate | aiProcess_PreTransformVertices};
  const aiScene* scene = importer.ReadFileFromMemory(bytes.data(), bytes.size(), flags, ext.c_str() + 1);
  if (scene == nullptr) {
    std::string why = importer.GetErrorString();
    if (why.empty()) why = "unknown reason";
    if (lower(why).find("no output meshes") != std::string::npos ||
        lower(why).find("no meshes") != std::string::npos)
      return bad_input("the file holds no triangles, expected a mesh (assimp: " + why + ")", name);
    return bad_input("cannot read mesh: " + why, name);
  }

  const double s = unit_factor(options.units) * options.scale;
  auto mesh = welded_mesh(*scene, s, name);
  if (!mesh) return mesh.error();
  if (mesh->triangles.empty()) return bad_input("the file holds no triangles, expected a mesh", name);
  for (const auto& v : mesh->vertices_mm)
    if (!v.allFinite())
      return bad_input("a coordinate overflows after scaling by " + format_number(s), name);
  return mesh;
}

}  // namespace printtwin
