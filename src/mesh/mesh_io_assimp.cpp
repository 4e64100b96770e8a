// The only file that includes assimp: loads any supported mesh format into a Mesh.
//
// assimp is forgiving to a fault: it reads an ASCII STL full of garbage as "some triangles",
// and a binary STL whose header promises more triangles than the file holds as a shorter
// mesh. STL input is therefore validated here first (size against the header count, ASCII
// grammar with line numbers, finite coordinates) and only then handed to assimp.
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
#include <unordered_map>
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

/// Checks the ASCII STL grammar: solid, { facet normal n n n, outer loop, 3 x vertex x y z,
/// endloop, endfacet }, endsolid. Reports the first deviation with its line.
Status validate_ascii_stl(std::string_view text, const std::string& name) {
  long line = 1;
  std::size_t pos = 0;
  long token_line = 1;
  auto next = [&]() -> std::string_view {
    while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos])) != 0) {
      if (text[pos] == '\n') ++line;
      ++pos;
    }
    token_line = line;
    const std::size_t start = pos;
    while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos])) == 0) ++pos;
    return text.substr(start, pos - start);
  };
  auto rest_of_line = [&] {
    while (pos < text.size() && text[pos] != '\n') ++pos;
  };
  auto expect = [&](std::string_view word, std::string_view got) -> Status {
    if (got == word) return Ok{};
    return bad_input("ASCII STL: expected '" + std::string(word) + "', found '" +
                         std::string(got.empty() ? "end of file" : got.substr(0, 40)) + "'",
                     name, token_line);
  };
  // Normals are ignored (recomputed from the vertices), so writers' "nan" normals of
  // zero-area facets pass; vertex coordinates must be finite.
  auto number = [&](double& out, bool must_be_finite) -> Status {
    const std::string_view tok = next();
    const char* first = tok.data();
    const char* last = tok.data() + tok.size();
    if (!tok.empty() && *first == '+') ++first;
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

  if (auto s = expect("solid", next()); !s) return s;
  rest_of_line();  // the solid's name
  long facets = 0;
  for (;;) {
    const std::string_view tok = next();
    if (tok == "endsolid") break;
    if (tok.empty()) return bad_input("ASCII STL: missing 'endsolid' at the end", name, token_line);
    if (auto s = expect("facet", tok); !s) return s;
    if (auto s = expect("normal", next()); !s) return s;
    double v = 0;
    for (int i = 0; i < 3; ++i)
      if (auto s = number(v, false); !s) return s;
    if (auto s = expect("outer", next()); !s) return s;
    if (auto s = expect("loop", next()); !s) return s;
    for (int k = 0; k < 3; ++k) {
      if (auto s = expect("vertex", next()); !s) return s;
      for (int i = 0; i < 3; ++i)
        if (auto s = number(v, true); !s) return s;
    }
    if (auto s = expect("endloop", next()); !s) return s;
    if (auto s = expect("endfacet", next()); !s) return s;
    ++facets;
  }
  if (facets == 0) return bad_input("ASCII STL with 0 facets, expected a mesh", name);
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

/// Joins vertices with identical coordinates, also across the sub-meshes of one file (assimp
/// joins only within a sub-mesh). Unreferenced vertices are dropped.
void weld_identical_vertices(Mesh& mesh) {
  struct Hash {
    std::size_t operator()(const std::array<double, 3>& p) const {
      std::size_t h = 1469598103934665603ULL;
      for (double d : p) {
        std::uint64_t bits = 0;
        const double z = d == 0 ? 0.0 : d;  // -0 and +0 are one point
        std::memcpy(&bits, &z, 8);
        h = (h ^ bits) * 1099511628211ULL;
        h ^= h >> 29;
      }
      return h;
    }
  };
  std::unordered_map<std::array<double, 3>, std::uint32_t, Hash> index;
  index.reserve(mesh.vertices_mm.size());
  std::vector<Vec3> welded;
  welded.reserve(mesh.vertices_mm.size());
  std::vector<std::uint32_t> remap(mesh.vertices_mm.size(), UINT32_MAX);
  for (auto& t : mesh.triangles)
    for (auto& v : t) {
      if (remap[v] == UINT32_MAX) {
        const Vec3& p = mesh.vertices_mm[v];
        const std::array<double, 3> key = {p.x() == 0 ? 0.0 : p.x(), p.y() == 0 ? 0.0 : p.y(),
                                           p.z() == 0 ? 0.0 : p.z()};
        auto [it, inserted] = index.try_emplace(key, static_cast<std::uint32_t>(welded.size()));
        if (inserted) welded.push_back(p);
        remap[v] = it->second;
      }
      v = remap[v];
    }
  mesh.vertices_mm = std::move(welded);
}

}  // namespace

Result<Mesh> load_mesh(const fs::path& path, const MeshLoadOptions& options) {
  const std::string name = path.string();
  if (!(options.scale > 0) || !std::isfinite(options.scale))
    return usage_error("scale must be a positive number, got " + format_number(options.scale));

  const std::string ext = lower(path.extension().string());
  static constexpr std::array<std::string_view, 6> kKnown = {".stl", ".obj", ".ply",
                                                             ".off", ".3mf", ".amf"};
  if (std::find(kKnown.begin(), kKnown.end(), ext) == kKnown.end())
    return bad_input("unknown mesh extension '" + ext +
                         "', expected .stl, .obj, .ply, .off, .3mf or .amf",
                     name);

  auto bytes = read_file(path);  // existence, directory and readability errors
  if (!bytes) return bytes.error();
  if (bytes->empty()) return bad_input("empty file, expected a mesh", name);

  const bool is_stl = ext == ".stl";
  if (is_stl) {
    const std::string_view b = *bytes;
    // Binary when the size matches the header count (even if it starts with "solid", as
    // some exporters write); ASCII when it starts with "solid"; binary otherwise.
    const bool size_matches_binary =
        b.size() >= kStlHeaderBytes &&
        kStlHeaderBytes + kStlTriangleBytes * std::uint64_t{stl_header_count(b)} == b.size();
    Status valid = (size_matches_binary || !starts_with_solid(b)) ? validate_binary_stl(b, name)
                                                                  : validate_ascii_stl(b, name);
    if (!valid) return valid.error();
  }

  Assimp::Importer importer;
  // Identical vertices are joined after import (weld_identical_vertices): without it an STL
  // is a soup of loose triangles and nothing is closed. assimp's own
  // aiProcess_JoinIdenticalVertices also compares normals (an STL gives every corner its
  // facet's normal) and took 0.2 s of CPU for 200k triangles where the parse took 0.015 s;
  // the exact weld below does the same job in a fraction of that. Node transforms are
  // baked in (3MF/AMF build items).
  const unsigned flags = aiProcess_Triangulate | aiProcess_PreTransformVertices;
  const aiScene* scene =
      is_stl ? importer.ReadFileFromMemory(bytes->data(), bytes->size(), flags, "stl")
             : importer.ReadFile(name, flags);
  if (scene == nullptr) {
    std::string why = importer.GetErrorString();
    if (why.empty()) why = "unknown reason";
    if (lower(why).find("no output meshes") != std::string::npos ||
        lower(why).find("no meshes") != std::string::npos)
      return bad_input("the file holds no triangles, expected a mesh (assimp: " + why + ")", name);
    return bad_input("cannot read mesh: " + why, name);
  }

  const double s = unit_factor(options.units) * options.scale;
  Mesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    const auto base = static_cast<std::uint32_t>(mesh.vertices_mm.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return bad_input("mesh " + std::to_string(m) + ", vertex " + std::to_string(v) +
                             " has a NaN or infinite coordinate",
                         name);
      mesh.vertices_mm.emplace_back(s * p.x, s * p.y, s * p.z);
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines carry no volume
      mesh.triangles.push_back(
          {base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
  }
  if (mesh.triangles.empty()) return bad_input("the file holds no triangles, expected a mesh", name);
  weld_identical_vertices(mesh);
  for (const auto& v : mesh.vertices_mm)
    if (!v.allFinite())
      return bad_input("a coordinate overflows after scaling by " + format_number(s), name);
  return mesh;
}

}  // namespace printtwin
