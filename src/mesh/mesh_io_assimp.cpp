// The only file that includes assimp: loads any supported mesh format into a Mesh. OFF and
// PLY are read here (assimp's readers trust their headers' counts and abort or leak on
// malformed files); STL is validated here and then read by assimp, OBJ and AMF by
// assimp behind a container check and its structure validation. 3MF is read by printtwin
// (mesh_3mf.cpp): assimp's 3MF reader frees memory twice or crashes on real packages
// (slices, production and PrusaSlicer/3MF Consortium files) and reads unreferenced objects.
//
// assimp is forgiving to a fault: it reads an ASCII STL full of garbage as "some triangles",
// and a binary STL whose header promises more triangles than the file holds as a shorter
// mesh. STL input is therefore validated here first (size against the header count, ASCII
// grammar with line numbers, finite coordinates) and then read here, straight from the bytes
// (binary) or the tokens the grammar check parsed (ASCII); PRINTTWIN_PLAIN=stl_direct hands
// the validated file to assimp instead.
//
// Speed (a 37 MB ASCII STL of 200k triangles is the benchmark): the bytes are read once
// (load_mesh_from_memory takes them from the caller, who also hashes them), the ASCII
// grammar check scans tokens with a table instead of the C locale, decimal numbers are
// checked by their grammar (from_chars only for the unusual ones) and read as floats in the
// same pass, and the weld is one pass with an open-addressing table. Other formats' welds
// take assimp's vertices the same way.
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "core/plain_path.hpp"
#include "mesh/mesh_3mf.hpp"
#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"

// assimp checks its own invariants with ai_assert, whose failure calls this function and
// then abort(): a malformed file (a 3MF whose root model could not be opened did) reaches one.
// printtwin defines the function itself, so that the dynamic linker binds assimp's calls to
// this definition: the failure becomes an exception, which assimp's importer catches and
// turns into an error (the import returns no scene), and load_mesh reports it as bad input
// naming the file. Defined once, in the only file that links assimp.
namespace Assimp {
namespace {
thread_local std::string last_assertion;
}  // namespace
[[noreturn]] void aiAssertViolation(const char* expression, const char* file, int line) {
  last_assertion = std::string(expression != nullptr ? expression : "?") + " (" +
                   (file != nullptr ? file : "?") + ":" + std::to_string(line) + ")";
  throw std::runtime_error("assimp's internal check failed: " + last_assertion);
}
}  // namespace Assimp

namespace printtwin {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kStlHeaderBytes = 84;    // 80-byte header + uint32 triangle count
constexpr std::size_t kStlTriangleBytes = 50;  // normal, 3 vertices (12 floats) + uint16
constexpr double kStlMaxCoordinate = 3.4028234663852886e38;  // FLT_MAX

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// A UTF-8 byte order mark, which a text editor may put before an ASCII STL's "solid".
constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";
bool starts_with_bom(std::string_view bytes) {
  return bytes.substr(0, kUtf8Bom.size()) == kUtf8Bom;
}

bool starts_with_solid(std::string_view bytes) {
  std::size_t i = starts_with_bom(bytes) ? kUtf8Bom.size() : 0;
  while (i < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[i])) != 0) ++i;
  return bytes.substr(i, 5) == "solid";
}

/// True when bytes past the 80-byte header of an STL starting with "solid" cannot be ASCII
/// STL text: a NUL or a control byte other than white space among the first records (the
/// triangle count and the floats of a binary STL whose header begins with "solid", as some
/// exporters write it).
bool binary_after_header(std::string_view bytes) {
  const std::string_view body = bytes.substr(std::min<std::size_t>(80, bytes.size()), 1024);
  return std::any_of(body.begin(), body.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u < 0x20 && std::isspace(u) == 0;
  });
}

std::uint32_t stl_header_count(std::string_view bytes) {
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);  // little endian on every supported host
  return n;
}

/// A binary STL's triangle count against its file size (at least the 84-byte header).
Status check_binary_stl_size(std::uint64_t count, std::uint64_t size, const std::string& name) {
  if (count == 0) return bad_input("binary STL with 0 triangles, expected a mesh", name);
  const std::uint64_t need = kStlHeaderBytes + kStlTriangleBytes * count;
  if (need > size) {
    const std::uint64_t present = (size - kStlHeaderBytes) / kStlTriangleBytes;
    return bad_input("binary STL header announces " + std::to_string(count) + " triangles (" +
                         std::to_string(need) + " bytes) but the file has " + std::to_string(size) +
                         " bytes (" + std::to_string(present) +
                         " whole triangles): truncated or corrupt",
                     name);
  }
  return Ok{};
}

/// A binary STL's size must be 84 + 50 * count. Some writers append a few bytes; more
/// bytes than announced is accepted, fewer is not.
Status validate_binary_stl(std::string_view bytes, const std::string& name) {
  if (bytes.size() < kStlHeaderBytes)
    return bad_input("truncated binary STL: " + std::to_string(bytes.size()) +
                         " bytes, the header alone needs 84",
                     name);
  const std::uint64_t count = stl_header_count(bytes);
  if (auto st = check_binary_stl_size(count, bytes.size(), name); !st) return st;
  for (std::uint64_t t = 0; t < count; ++t) {
    std::array<float, 9> v{};
    std::memcpy(v.data(), bytes.data() + kStlHeaderBytes + t * kStlTriangleBytes + 12, sizeof(v));
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
/// std::from_chars reads whole into a double that is finite as a float: at most 40
/// characters, at most 20 integer digits, a one- or two-digit exponent and a value below
/// 1e31. False means "not sure" (the caller asks from_chars).
bool is_plain_finite_decimal(std::string_view tok) {
  if (tok.empty() || tok.size() > 40) return false;
  std::size_t i = tok[0] == '-' ? 1 : 0;
  std::size_t digits = 0;
  while (i < tok.size() && is_digit(tok[i])) ++i, ++digits;
  const std::size_t int_digits = digits;
  if (i < tok.size() && tok[i] == '.') {
    ++i;
    while (i < tok.size() && is_digit(tok[i])) ++i, ++digits;
  }
  if (digits == 0 || int_digits > 20) return false;  // beyond 1e20: ask from_chars
  if (i == tok.size()) return true;
  if (tok[i] != 'e' && tok[i] != 'E') return false;
  ++i;
  const bool negative_exp = i < tok.size() && tok[i] == '-';
  if (i < tok.size() && (tok[i] == '+' || tok[i] == '-')) ++i;
  std::size_t exp_digits = 0;
  std::size_t exp_value = 0;
  while (i < tok.size() && is_digit(tok[i]))
    exp_value = 10 * exp_value + static_cast<std::size_t>(tok[i] - '0'), ++i, ++exp_digits;
  // Below 1e31, well inside float's range (3.4e38); tiny values just round to 0.
  return i == tok.size() && exp_digits >= 1 && exp_digits <= 2 &&
         (negative_exp || int_digits + exp_value <= 30);
}

/// A vertex coordinate token already checked as a number: the float STL stores, correctly
/// rounded (from_chars; a leading '+' skipped).
float stl_float(std::string_view tok) {
  const char* first = tok.data();
  if (!tok.empty() && *first == '+') ++first;
  float out = 0;
  if (std::from_chars(first, tok.data() + tok.size(), out).ec == std::errc()) return out;
  // Beyond float's range at the edges (under its smallest normal, or rounding up to its
  // largest): through double, as the grammar check read it.
  double wide = 0;
  std::from_chars(first, tok.data() + tok.size(), wide);
  return static_cast<float>(wide);
}

/// A token as it may be shown in a message: at most 40 bytes, control bytes (a NUL in a
/// damaged file) as '?'.
std::string shown(std::string_view tok) {
  if (tok.empty()) return "end of file";
  std::string out(tok.substr(0, 40));
  for (char& ch : out)
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) ch = '?';
  return out;
}

/// Checks the ASCII STL grammar: one or more of solid, { facet normal n n n, outer loop,
/// 3 x vertex x y z, endloop, endfacet }, endsolid. Reports the first deviation with its line.
/// With `coords`, also reads the vertex coordinates (9 per facet, as the single-precision
/// floats STL stores, correctly rounded) into it.
Status validate_ascii_stl(std::string_view text, const std::string& name,
                          std::vector<float>* coords) {
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
    return bad_input("ASCII STL: expected '" + std::string(word) + "', found '" + shown(got) + "'",
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
      return bad_input("ASCII STL: expected a number, found '" + shown(tok) + "'", name,
                       token_line);
    if (must_be_finite && !std::isfinite(out))
      return bad_input("ASCII STL: NaN or infinite coordinate '" + shown(tok) + "'", name,
                       token_line);
    // STL stores single-precision floats: a larger coordinate becomes infinite when read.
    if (must_be_finite && std::abs(out) > kStlMaxCoordinate)
      return bad_input("ASCII STL: coordinate '" + shown(tok) +
                           "' is beyond the single-precision range of STL (+-3.4e38)",
                       name, token_line);
    return Ok{};
  };
  // One token per call, checked on the fast path; anything unusual takes the slow path,
  // which produces the error (or accepts e.g. "+1", "nan" normals, "1e300").
#define PRINTTWIN_EXPECT_WORD(word)                       \
  do {                                                    \
    const std::string_view got_ = next();                 \
    if (got_ != (word)) return fail_expect((word), got_); \
  } while (false)
#define PRINTTWIN_EXPECT_NUMBER(finite)                                    \
  do {                                                                     \
    const std::string_view tok_ = next();                                  \
    if (!is_plain_finite_decimal(tok_))                                    \
      if (auto st_ = slow_number(tok_, (finite)); !st_) return st_;        \
    if ((finite) && coords != nullptr) coords->push_back(stl_float(tok_)); \
  } while (false)

  PRINTTWIN_EXPECT_WORD("solid");
  rest_of_line();  // the solid's name
  long facets = 0;
  for (;;) {
    const std::string_view tok = next();
    if (tok == "endsolid") {
      rest_of_line();  // the solid's name again
      const std::string_view after = next();
      // Some exporters write one solid per body: another solid may follow. Anything else
      // after the last endsolid (padding some writers leave) is not part of the mesh.
      if (after != "solid") break;
      rest_of_line();
      continue;
    }
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
    return bad_input(
        "unknown mesh extension '" + ext + "', expected .stl, .obj, .ply, .off, .3mf or .amf",
        path.string());
  return Ok{};
}

double unit_factor(LengthUnit u) {
  switch (u) {
    case LengthUnit::mm:
      return 1.0;
    case LengthUnit::cm:
      return 10.0;
    case LengthUnit::inch:
      return 25.4;
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

/// `raw`'s triangles with vertices joined as welded_mesh joins assimp's (exact positions,
/// numbered in order of first use, unreferenced ones dropped).
Mesh welded_copy(const Mesh& raw) {
  Mesh mesh;
  mesh.triangles.reserve(raw.triangles.size());
  mesh.vertices_mm.reserve(raw.triangles.size() / 2 + 16);
  PointIndex index(raw.triangles.size() / 2 + 16);
  for (const auto& t : raw.triangles)
    mesh.triangles.push_back({index.find_or_add(raw.vertices_mm[t[0]], mesh.vertices_mm),
                              index.find_or_add(raw.vertices_mm[t[1]], mesh.vertices_mm),
                              index.find_or_add(raw.vertices_mm[t[2]], mesh.vertices_mm)});
  return mesh;
}

/// STL triangles given as 9 floats each (corner by corner), welded as assimp's import followed
/// by welded_mesh would: vertices in order of first use, the same weld, without assimp's copies.
/// `corners(t, v)` writes triangle t's 9 coordinates into v.
template <class Corners>
Mesh stl_triangles_mesh(std::size_t count, double s, const Corners& corners) {
  Mesh mesh;
  mesh.triangles.resize(count);
  mesh.vertices_mm.reserve(count / 2 + 16);
  PointIndex index(count / 2 + 16);
  for (std::size_t t = 0; t < count; ++t) {
    std::array<float, 9> v{};
    corners(t, v);
    for (int k = 0; k < 3; ++k)
      mesh.triangles[t][k] = index.find_or_add(
          Vec3(s * v[3 * k], s * v[3 * k + 1], s * v[3 * k + 2]), mesh.vertices_mm);
  }
  return mesh;
}

/// A binary STL whose size matches its header count, read straight from the bytes (already
/// validated: size and finite coordinates). PRINTTWIN_PLAIN=stl_direct reads it through
/// assimp instead.
Mesh binary_stl_mesh(std::string_view bytes, double s) {
  const char* records = bytes.data() + kStlHeaderBytes;
  return stl_triangles_mesh(stl_header_count(bytes), s, [&](std::size_t t, auto& v) {
    // after the stored normal
    std::memcpy(v.data(), records + t * kStlTriangleBytes + 12, sizeof(v));
  });
}

/// An ASCII STL's vertex coordinates as the grammar check read them (9 per facet).
/// PRINTTWIN_PLAIN=stl_direct reads the file through assimp instead.
Mesh ascii_stl_mesh(const std::vector<float>& coords, double s) {
  return stl_triangles_mesh(coords.size() / 9, s, [&](std::size_t t, auto& v) {
    std::copy_n(coords.begin() + static_cast<std::ptrdiff_t>(9 * t), 9, v.begin());
  });
}

/// The checks every format's mesh ends with.
Result<Mesh> finish_mesh(Mesh mesh, double s, const std::string& name) {
  if (mesh.triangles.empty())
    return bad_input("the file holds no triangles, expected a mesh", name);
  for (const auto& v : mesh.vertices_mm)
    if (!v.allFinite())
      return bad_input("a coordinate overflows after scaling by " + format_number(s), name);
  return mesh;
}

// --- OFF, read here -----------------------------------------------------------------------
// assimp's OFF importer trusts the header's counts: a file announcing more faces than it
// holds reaches an assertion inside assimp (an abort, no message). OFF is a few lines of
// grammar, so it is read here with every count and index checked:
//   [ST][C][N]OFF [nv nf ne]   (the counts may also stand on the next line)
//   nv lines: x y z [normal, colour, texture: ignored]
//   nf lines: n i1 .. in [colour: ignored]
// '#' starts a comment anywhere. Faces of 4 or more corners are split into a fan from their
// first corner (exact for convex faces, as OFF writers emit them).

/// Cursor over the non-blank, non-comment lines of a text, with their 1-based numbers.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}
  /// The next line with content (comment stripped), or false at the end.
  bool next(std::string_view& line, long& number) {
    while (pos_ < text_.size()) {
      const std::size_t nl = text_.find('\n', pos_);
      const std::size_t end = nl == std::string_view::npos ? text_.size() : nl;
      std::string_view l = text_.substr(pos_, end - pos_);
      pos_ = end + 1;
      ++line_;
      if (const auto hash = l.find('#'); hash != std::string_view::npos) l = l.substr(0, hash);
      std::size_t b = 0;
      while (b < l.size() && is_space(l[b])) ++b;
      if (b == l.size()) continue;
      line = l.substr(b);
      number = line_;
      return true;
    }
    return false;
  }
  [[nodiscard]] long line() const { return line_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  long line_ = 0;
};

/// Splits a line into tokens separated by blanks (no allocation beyond the vector's reuse).
void split_tokens(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t b = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
}

template <class T>
bool parse_token(std::string_view tok, T& out) {
  const char* first = tok.data();
  const char* last = tok.data() + tok.size();
  if (first != last && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, out);
  return ec == std::errc() && ptr == last;
}

Result<Mesh> read_off(std::string_view text, double s, const std::string& name) {
  LineReader lines(text);
  std::string_view line;
  long at = 0;
  std::vector<std::string_view> tok;
  if (!lines.next(line, at)) return bad_input("OFF: empty file, expected the 'OFF' keyword", name);
  split_tokens(line, tok);
  const std::string_view key = tok[0];
  if (key.size() < 3 || key.substr(key.size() - 3) != "OFF")
    return bad_input(
        "OFF: expected the keyword 'OFF' (or COFF, NOFF, STOFF...), found '" + shown(key) + "'",
        name, at);
  const std::string_view prefix = key.substr(0, key.size() - 3);
  if (prefix.find_first_not_of("STCN") != std::string_view::npos)
    return bad_input(
        "OFF: '" + shown(key) +
            "' (4D, n-dimensional or homogeneous OFF) is not supported, expected 3D OFF",
        name, at);
  if (tok.size() > 1 && tok[1] == "BINARY")
    return bad_input("OFF: binary OFF is not supported, expected ASCII OFF", name, at);
  std::size_t first_count = 1;
  if (tok.size() == 1) {
    if (!lines.next(line, at))
      return bad_input("OFF: missing the vertex and face counts", name, lines.line());
    split_tokens(line, tok);
    first_count = 0;
  }
  std::uint64_t nv = 0, nf = 0;
  if (tok.size() < first_count + 2 || !parse_token(tok[first_count], nv) ||
      !parse_token(tok[first_count + 1], nf))
    return bad_input("OFF: expected the counts 'vertices faces edges', found '" + shown(line) + "'",
                     name, at);
  const long header_line = at;
  // Every vertex needs at least "0 0 0\n" and every face "3 0 0 0\n": counts the file cannot
  // hold are rejected before anything is allocated for them.
  if (nv > text.size() / 6 || nf > text.size() / 8)
    return bad_input("OFF: the header announces " + std::to_string(nv) + " vertices and " +
                         std::to_string(nf) + " faces, more than a file of " +
                         std::to_string(text.size()) + " bytes can hold",
                     name, header_line);
  if (nf == 0)
    return bad_input("OFF: the header announces 0 faces, expected a mesh", name, header_line);
  auto ended_early = [&](std::uint64_t announced, const char* what, std::uint64_t read) -> Error {
    return bad_input("OFF: the header (line " + std::to_string(header_line) + ") announces " +
                         std::to_string(announced) + " " + what + ", the file ends after " +
                         std::to_string(read),
                     name, lines.line());
  };
  std::vector<Vec3> points;
  points.reserve(nv);
  for (std::uint64_t v = 0; v < nv; ++v) {
    if (!lines.next(line, at)) return ended_early(nv, "vertices", v);
    split_tokens(line, tok);
    std::array<double, 3> c{};
    for (std::size_t k = 0; k < 3; ++k) {
      if (k >= tok.size() || !parse_token(tok[k], c[k]))
        return bad_input("OFF: vertex " + std::to_string(v) +
                             ": expected three numbers x y z, found '" + shown(line) + "'",
                         name, at);
      if (!std::isfinite(c[k]))
        return bad_input("OFF: vertex " + std::to_string(v) + " has a NaN or infinite coordinate",
                         name, at);
    }
    points.emplace_back(s * c[0], s * c[1], s * c[2]);
  }
  Mesh mesh;
  mesh.triangles.reserve(nf);
  PointIndex index(nv + 16);
  std::vector<std::uint32_t> corners;
  for (std::uint64_t f = 0; f < nf; ++f) {
    if (!lines.next(line, at)) return ended_early(nf, "faces", f);
    split_tokens(line, tok);
    std::uint64_t n = 0;
    if (tok.empty() || !parse_token(tok[0], n) || n == 0 || tok.size() < n + 1)
      return bad_input("OFF: face " + std::to_string(f) +
                           ": expected a corner count n and n vertex indices, found '" +
                           shown(line) + "'",
                       name, at);
    corners.clear();
    for (std::uint64_t k = 1; k <= n; ++k) {
      std::uint64_t i = 0;
      if (!parse_token(tok[k], i) || i >= nv)
        return bad_input("OFF: face " + std::to_string(f) + ": vertex index '" + shown(tok[k]) +
                             "' is not one of the " + std::to_string(nv) + " vertices (0.." +
                             std::to_string(nv == 0 ? 0 : nv - 1) + ")",
                         name, at);
      corners.push_back(index.find_or_add(points[i], mesh.vertices_mm));
    }
    // Points and lines carry no volume; polygons become a fan of triangles.
    for (std::size_t k = 1; k + 1 < corners.size(); ++k)
      mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
  }
  // Numbering: vertices in order of first use by the faces, as for the other formats.
  return mesh;
}

// --- PLY, read here --------------------------------------------------------------------
// assimp's PLY importer trusts the header's counts and the list lengths: a face with no
// corners reaches an assertion in its triangulation, and its error paths leak. PLY is read
// here instead, every count, length and index checked against the file:
//   ply / format ascii|binary_little_endian|binary_big_endian 1.0 / comment, obj_info
//   element <name> <count> / property <type> <name> / property list <type> <type> <name>
//   end_header, then the elements in header order; other header lines are free text.
// ASCII PLY holds one element per line: values a line holds past its element's properties
// (VCG/MeshLab files whose face lines carry more than their header declares) are skipped.
// Vertices are the `vertex` element's x, y, z; faces the `face` element's `vertex_indices`
// (or `vertex_index`) lists, split into fans; other elements and properties are skipped.

struct PlyProperty {
  std::string name;
  char kind = 'f';  ///< 'i' signed, 'u' unsigned, 'f' floating
  int bytes = 4;
  bool list = false;
  char count_kind = 'u';  ///< the list length's type
  int count_bytes = 1;
};
struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  long line = 0;
  std::vector<PlyProperty> properties;
};

bool ply_type(std::string_view t, char& kind, int& bytes) {
  static constexpr std::array<std::tuple<std::string_view, char, int>, 16> kTypes = {
      {{"char", 'i', 1},
       {"int8", 'i', 1},
       {"uchar", 'u', 1},
       {"uint8", 'u', 1},
       {"short", 'i', 2},
       {"int16", 'i', 2},
       {"ushort", 'u', 2},
       {"uint16", 'u', 2},
       {"int", 'i', 4},
       {"int32", 'i', 4},
       {"uint", 'u', 4},
       {"uint32", 'u', 4},
       {"float", 'f', 4},
       {"float32", 'f', 4},
       {"double", 'f', 8},
       {"float64", 'f', 8}}};
  for (const auto& [n, k, b] : kTypes)
    if (n == t) {
      kind = k;
      bytes = b;
      return true;
    }
  return false;
}

/// One binary value at `p` (bounds checked by the caller) as a double.
double ply_binary_value(const char* p, char kind, int bytes, bool big_endian) {
  std::array<unsigned char, 8> b{};
  const auto n = static_cast<std::size_t>(std::clamp(bytes, 1, 8));
  for (std::size_t i = 0; i < n; ++i)
    b[i] = static_cast<unsigned char>(p[big_endian ? n - 1 - i : i]);
  switch (kind == 'f' ? bytes : (kind == 'i' ? -bytes : 10 + bytes)) {
    case 4: {
      float v;
      std::memcpy(&v, b.data(), 4);
      return v;
    }
    case 8: {
      double v;
      std::memcpy(&v, b.data(), 8);
      return v;
    }
    case -1: {
      std::int8_t v;
      std::memcpy(&v, b.data(), 1);
      return v;
    }
    case -2: {
      std::int16_t v;
      std::memcpy(&v, b.data(), 2);
      return v;
    }
    case -4: {
      std::int32_t v;
      std::memcpy(&v, b.data(), 4);
      return v;
    }
    case 11:
      return b[0];
    case 12: {
      std::uint16_t v;
      std::memcpy(&v, b.data(), 2);
      return v;
    }
    default: {
      std::uint32_t v;
      std::memcpy(&v, b.data(), 4);
      return v;
    }
  }
}

/// A PLY header: the format and the elements with their properties.
struct PlyHeader {
  int format = -1;  ///< 0 ascii, 1 little endian, 2 big endian
  std::vector<PlyElement> elements;
  std::size_t body = std::string_view::npos;  ///< byte offset of the body
  long last_line = 0;                         ///< the header's last line
};

Result<PlyHeader> read_ply_header(std::string_view bytes, const std::string& name) {
  LineReader lines(bytes);
  std::string_view line;
  long at = 0;
  std::vector<std::string_view> tok;
  if (!lines.next(line, at) || line.substr(0, 3) != "ply")
    return bad_input("PLY: expected the magic word 'ply' on the first line", name, 1);
  PlyHeader h;
  int& format = h.format;
  std::vector<PlyElement>& elements = h.elements;
  std::size_t& body = h.body;
  while (lines.next(line, at)) {
    split_tokens(line, tok);
    if (tok[0] == "end_header") {
      const std::size_t nl =
          bytes.find('\n', static_cast<std::size_t>(tok[0].data() - bytes.data()));
      body = nl == std::string_view::npos ? bytes.size() : nl + 1;
      break;
    }
    if (tok[0] == "comment" || tok[0] == "obj_info") continue;
    if (tok[0] == "format") {
      if (tok.size() < 2 ||
          (tok[1] != "ascii" && tok[1] != "binary_little_endian" && tok[1] != "binary_big_endian"))
        return bad_input("PLY: expected 'format ascii|binary_little_endian|binary_big_endian 1.0'",
                         name, at);
      format = tok[1] == "ascii" ? 0 : (tok[1] == "binary_little_endian" ? 1 : 2);
    } else if (tok[0] == "element") {
      PlyElement e;
      if (tok.size() != 3 || !parse_token(tok[2], e.count))
        return bad_input("PLY: expected 'element <name> <count>', found '" + shown(line) + "'",
                         name, at);
      e.name = std::string(tok[1].substr(0, 40));
      e.line = at;
      elements.push_back(std::move(e));
    } else if (tok[0] == "property") {
      if (elements.empty()) return bad_input("PLY: a property before any element", name, at);
      PlyProperty p;
      p.list = tok.size() == 5 && tok[1] == "list";
      const bool ok = p.list ? ply_type(tok[2], p.count_kind, p.count_bytes) &&
                                   p.count_kind != 'f' && ply_type(tok[3], p.kind, p.bytes)
                             : tok.size() == 3 && ply_type(tok[1], p.kind, p.bytes);
      if (!ok)
        return bad_input(
            "PLY: expected 'property <type> <name>' or 'property list <integer type> <type> "
            "<name>', "
            "found '" +
                shown(line) + "'",
            name, at);
      p.name = std::string(tok.back().substr(0, 40));
      elements.back().properties.push_back(std::move(p));
    }
    // Any other line is free text: Blender 2.4x's exporter wrote its credit line ("Created by
    // Blender3D 247 - www.blender.org, source file: ...") without 'comment'.
  }
  if (body == std::string_view::npos)
    return bad_input("PLY: the header has no 'end_header'", name, lines.line());
  if (format < 0) return bad_input("PLY: the header has no 'format' line", name);

  h.last_line = at;
  return h;
}

/// The body as a stream of values: binary reads, or the ASCII tokens with their lines.
struct PlyValues {
  const char* pos;
  const char* end;
  int format;
  long ascii_line;
  const std::string& name;
  const std::string* element_name = nullptr;  ///< where the stream is, for messages
  std::uint64_t element_index = 0;

  [[nodiscard]] std::string where() const {
    return "element '" + *element_name + "' " + std::to_string(element_index);
  }
  Status next(char kind, int size, double& out) {
    if (format != 0) {
      if (end - pos < size) return bad_input("PLY: the file ends inside " + where(), name);
      out = ply_binary_value(pos, kind, size, format == 2);
      pos += size;
    } else {
      while (pos < end && is_space(*pos)) ascii_line += *pos++ == '\n' ? 1 : 0;
      const char* b = pos;
      while (pos < end && !is_space(*pos)) ++pos;
      const std::string_view t(b, static_cast<std::size_t>(pos - b));
      if (t.empty()) return bad_input("PLY: the file ends inside " + where(), name, ascii_line);
      if (!parse_token(t, out))
        return bad_input("PLY: " + where() + ": expected a number, found '" + shown(t) + "'", name,
                         ascii_line);
    }
    if (!std::isfinite(out))
      return bad_input("PLY: " + where() + " has a NaN or infinite value", name,
                       format == 0 ? std::optional<long>(ascii_line) : std::nullopt);
    return Ok{};
  }
  /// ASCII: skips what the current line holds past the element just read.
  void end_line() {
    if (format != 0) return;
    while (pos < end && *pos != '\n') ++pos;
  }
};

/// Reads every item of one element: vertices (x, y, z scaled by s), faces (fans of their
/// vertex indices), and skips any other element's values.
Status read_ply_element(const PlyElement& e, double s, PlyValues& in, std::vector<Vec3>& points,
                        Mesh& mesh, PointIndex& index, std::vector<std::uint32_t>& corners) {
  const std::string& name = in.name;
  // A count the rest of the file cannot hold (one byte or one token per value at least).
  if (e.count >
      static_cast<std::uint64_t>(in.end - in.pos) / std::max<std::size_t>(e.properties.size(), 1) +
          1)
    return bad_input("PLY: the header (line " + std::to_string(e.line) + ") announces " +
                         std::to_string(e.count) + " '" + e.name +
                         "' elements, more than the rest of the file holds",
                     name, e.line);
  const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
  std::array<int, 3> xyz = {-1, -1, -1};
  int indices = -1;
  for (std::size_t k = 0; k < e.properties.size(); ++k) {
    const auto& p = e.properties[k];
    if (is_vertex && !p.list && (p.name == "x" || p.name == "y" || p.name == "z"))
      xyz[static_cast<std::size_t>(p.name[0] - 'x')] = static_cast<int>(k);
    if (is_face && p.list && (p.name == "vertex_indices" || p.name == "vertex_index"))
      indices = static_cast<int>(k);
  }
  if (is_vertex && (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0))
    return bad_input("PLY: the 'vertex' element (line " + std::to_string(e.line) +
                         ") has no x, y and z properties",
                     name, e.line);
  if (is_face && indices < 0)
    return bad_input("PLY: the 'face' element (line " + std::to_string(e.line) +
                         ") has no 'vertex_indices' list",
                     name, e.line);
  if (is_vertex) points.reserve(e.count);
  for (std::uint64_t i = 0; i < e.count; ++i) {
    in.element_name = &e.name;
    in.element_index = i;
    std::array<double, 3> c{};
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const auto& p = e.properties[k];
      double v = 0;
      if (auto st = in.next(p.list ? p.count_kind : p.kind, p.list ? p.count_bytes : p.bytes, v);
          !st)
        return st.error();
      if (!p.list) {
        for (int a = 0; a < 3; ++a)
          if (xyz[static_cast<std::size_t>(a)] == static_cast<int>(k))
            c[static_cast<std::size_t>(a)] = v;
        continue;
      }
      if (v < 0 || v > static_cast<double>(in.end - in.pos) + 1)
        return bad_input("PLY: " + in.where() + ": a list of " + format_number(v) +
                             " values does not fit the file",
                         name);
      const auto n = static_cast<std::size_t>(v);
      const bool take = static_cast<int>(k) == indices;
      if (take) corners.clear();
      for (std::size_t j = 0; j < n; ++j) {
        double idx = 0;
        if (auto st = in.next(p.kind, p.bytes, idx); !st) return st.error();
        if (!take) continue;
        if (!(idx >= 0 && idx < static_cast<double>(points.size())) || idx != std::floor(idx))
          return bad_input("PLY: " + in.where() + ": vertex index " + format_number(idx) +
                               " is not one of the " + std::to_string(points.size()) +
                               " vertices read before the faces",
                           name,
                           in.format == 0 ? std::optional<long>(in.ascii_line) : std::nullopt);
        corners.push_back(
            index.find_or_add(points[static_cast<std::size_t>(idx)], mesh.vertices_mm));
      }
      if (take)  // points and lines carry no volume; polygons become a fan
        for (std::size_t j = 1; j + 1 < corners.size(); ++j)
          mesh.triangles.push_back({corners[0], corners[j], corners[j + 1]});
    }
    if (is_vertex) points.emplace_back(s * c[0], s * c[1], s * c[2]);
    in.end_line();
  }
  return Ok{};
}

Result<Mesh> read_ply(std::string_view bytes, double s, const std::string& name) {
  auto header = read_ply_header(bytes, name);
  if (!header) return header.error();
  const PlyHeader& h = *header;
  PlyValues in{bytes.data() + h.body, bytes.data() + bytes.size(), h.format, h.last_line + 1, name};
  std::vector<Vec3> points;
  Mesh mesh;
  PointIndex index(16);
  std::vector<std::uint32_t> corners;
  bool have_faces = false;
  for (const PlyElement& e : h.elements) {
    if (e.name == "face") have_faces = true;
    if (auto st = read_ply_element(e, s, in, points, mesh, index, corners); !st) return st.error();
  }
  if (!have_faces) return bad_input("PLY: no 'face' element: a point cloud, expected a mesh", name);
  return mesh;
}

/// 3MF is a zip archive; AMF is XML, plain or zipped. Anything else would reach assimp's zip
/// or XML reader and come back as an error in assimp's terms.
Status check_container(std::string_view bytes, const std::string& ext, const std::string& name) {
  const bool zip = bytes.size() >= 4 && bytes.substr(0, 4) == std::string_view("PK\x03\x04", 4);
  if (ext == ".3mf" && !zip)
    return bad_input(
        "not a 3MF file: a 3MF is a zip archive (it starts with 'PK'), this file does not", name);
  // A zip ends with its central directory's end record (22 bytes and a comment of up to
  // 64 KiB): without it the archive is truncated, and assimp's zip reader leaks on it.
  if (zip) {
    const std::size_t tail = std::min<std::size_t>(bytes.size(), 22 + 65535);
    if (bytes.substr(bytes.size() - tail).rfind(std::string_view("PK\x05\x06", 4)) ==
        std::string_view::npos)
      return bad_input(
          "not a complete zip archive (no end-of-central-directory record): truncated or damaged " +
              std::string(ext == ".3mf" ? "3MF" : "AMF") + " file",
          name);
  }
  if (ext == ".amf" && !zip) {
    std::size_t i = bytes.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;  // UTF-8 byte order mark
    while (i < bytes.size() && is_space(bytes[i])) ++i;
    if (i >= bytes.size() || bytes[i] != '<')
      return bad_input("not an AMF file: expected XML (starting with '<') or a zip archive", name);
  }
  return Ok{};
}
}  // namespace

Status check_mesh_file_header(const fs::path& path) {
  auto size = input_file_size(path);
  if (!size) return size.error();
  if (lower(path.extension().string()) != ".stl") return Ok{};
  // A binary STL's 84-byte header gives its size: a count of 0 or one the file cannot hold
  // is reported before the body is read (a 1 GB file of zeros is 0 triangles).
  auto head = read_file_head(path, kStlHeaderBytes);
  if (!head) return head.error();
  if (starts_with_solid(*head) || head->size() < kStlHeaderBytes)
    return Ok{};  // ASCII, or checked when read
  const std::uint64_t count = stl_header_count(*head);
  if (kStlHeaderBytes + kStlTriangleBytes * count == *size) return Ok{};
  return check_binary_stl_size(count, *size, path.string());
}

Result<Mesh> load_mesh(const fs::path& path, const MeshLoadOptions& options) {
  if (auto st = check_mesh_request(path, options); !st) return st.error();
  if (auto st = check_mesh_file_header(path); !st) return st.error();
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
    // some exporters write) or when binary bytes follow a "solid" header (such a file cut
    // short: its size error, not an ASCII grammar error); ASCII when it starts with "solid";
    // binary otherwise.
    const bool size_matches_binary =
        bytes.size() >= kStlHeaderBytes &&
        kStlHeaderBytes + kStlTriangleBytes * std::uint64_t{stl_header_count(bytes)} ==
            bytes.size();
    const bool binary =
        size_matches_binary || !starts_with_solid(bytes) || binary_after_header(bytes);
    if (!binary && starts_with_bom(bytes))
      bytes.remove_prefix(kUtf8Bom.size());  // ASCII text after a byte order mark
    const bool direct = !detail::plain_path("stl_direct");
    std::vector<float> coords;
    Status valid = binary ? validate_binary_stl(bytes, name)
                          : validate_ascii_stl(bytes, name, direct ? &coords : nullptr);
    if (!valid) return valid.error();
    const double s = unit_factor(options.units) * options.scale;
    if (direct && size_matches_binary) return finish_mesh(binary_stl_mesh(bytes, s), s, name);
    if (direct && !binary) return finish_mesh(ascii_stl_mesh(coords, s), s, name);
  }
  // The text formats' first line after a byte order mark (assimp's OBJ reader would drop it).
  if ((ext == ".obj" || ext == ".off" || ext == ".ply") && starts_with_bom(bytes))
    bytes.remove_prefix(kUtf8Bom.size());

  const double s = unit_factor(options.units) * options.scale;
  if (ext == ".off" || ext == ".ply") {
    auto mesh = ext == ".off" ? read_off(bytes, s, name) : read_ply(bytes, s, name);
    if (!mesh) return mesh.error();
    return finish_mesh(std::move(*mesh), s, name);
  }
  if (auto st = check_container(bytes, ext, name); !st) return st.error();
  if (ext == ".3mf") {
    auto mesh = detail::read_3mf(bytes, s, name);
    if (!mesh) return mesh.error();
    return finish_mesh(welded_copy(*mesh), s, name);
  }

  Assimp::last_assertion.clear();
  Assimp::Importer importer;
  // Identical vertices are joined after import (welded_mesh): without it an STL is a soup of
  // loose triangles and nothing is closed. assimp's own aiProcess_JoinIdenticalVertices also
  // compares normals (an STL gives every corner its facet's normal) and took 0.2 s of CPU for
  // 200k triangles. STL needs no post-processing at all (triangles only, one identity node);
  // other formats are triangulated and their node transforms baked in (3MF/AMF build items).
  // For them assimp's validation step runs first: a face indexing past its mesh's vertices,
  // or any other inconsistent structure an importer let through, is then an error instead of
  // an assertion inside the triangulation.
  const unsigned flags = is_stl ? 0U
                                : unsigned{aiProcess_ValidateDataStructure | aiProcess_Triangulate |
                                           aiProcess_PreTransformVertices};
  const aiScene* scene =
      importer.ReadFileFromMemory(bytes.data(), bytes.size(), flags, ext.c_str() + 1);
  if (scene == nullptr) {
    std::string why = importer.GetErrorString();
    if (why.empty() && !Assimp::last_assertion.empty())
      why = "assimp's internal check failed: " + Assimp::last_assertion;
    if (why.empty()) why = "unknown reason";
    if (lower(why).find("no output meshes") != std::string::npos ||
        lower(why).find("no meshes") != std::string::npos ||
        lower(why).find("contains no faces") != std::string::npos)
      return bad_input("the file holds no triangles, expected a mesh (assimp: " + why + ")", name);
    return bad_input("cannot read mesh: " + why, name);
  }

  auto mesh = welded_mesh(*scene, s, name);
  if (!mesh) return mesh.error();
  return finish_mesh(std::move(*mesh), s, name);
}

}  // namespace printtwin
