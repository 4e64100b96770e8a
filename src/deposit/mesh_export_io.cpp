// Writers of the as-printed mesh: binary STL and binary little-endian PLY (with an optional
// per-vertex `quality`, the deviation), streamed through one buffer, and 3MF (an OPC zip holding
// [Content_Types].xml, _rels/.rels and 3D/3dmodel.model, deflated with zlib).
#include <tbb/parallel_for.h>
#include <zlib.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "deposit/mesh_export.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

namespace {

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

template <class T>
void put(std::string& out, T value) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));  // little-endian hosts (x86-64, arm64)
  out.append(b, sizeof(T));
}

/// The file's bytes through one buffer of 1 MiB: written to a temporary file beside the
/// target, renamed over it when complete (so a reader never sees half a file).
class StreamedFile {
 public:
  explicit StreamedFile(std::filesystem::path path) : path_(std::move(path)) {
    buf_.reserve(kBuffer);
  }
  StreamedFile(const StreamedFile&) = delete;
  StreamedFile& operator=(const StreamedFile&) = delete;
  ~StreamedFile() {
    if (file_ != nullptr) {  // not finished: an error on the way
      std::fclose(file_);
      std::error_code ec;
      std::filesystem::remove(tmp_, ec);
    }
  }
  Status open() {
    std::error_code ec;
    if (std::filesystem::is_directory(path_, ec))
      return bad_input("is a folder, expected a file to write", path_.string());
    if (path_.has_parent_path()) std::filesystem::create_directories(path_.parent_path(), ec);
    tmp_ = path_.string() + ".tmp" + std::to_string(std::random_device{}() % 1000000);
    file_ = std::fopen(tmp_.c_str(), "wb");
    if (file_ == nullptr)
      return Error{ErrorCode::bad_input,
                   std::string("cannot write: ") + std::strerror(errno),
                   path_.string(),
                   {}};
    return Ok{};
  }
  std::string& buffer() { return buf_; }
  /// `n` records of `bytes` each, record i written by fill(i, dest): batches of pieces are
  /// filled in parallel, then written in order (the bytes do not depend on the threads).
  template <class Fill>
  void records(std::size_t n, std::size_t bytes, Fill&& fill) {
    flush();
    constexpr std::size_t kPiece = std::size_t{1} << 20, kBatch = 8;
    const std::size_t per = std::max<std::size_t>(1, kPiece / bytes);
    std::vector<std::string> pieces(kBatch);
    for (std::size_t first = 0; first < n; first += per * kBatch) {
      const std::size_t np = std::min(kBatch, (n - first + per - 1) / per);
      tbb::parallel_for(std::size_t{0}, np, [&](std::size_t p) {
        const std::size_t lo = first + p * per, hi = std::min(n, lo + per);
        std::string& piece = pieces[p];
        piece.resize((hi - lo) * bytes);
        for (std::size_t i = lo; i < hi; ++i) fill(i, piece.data() + (i - lo) * bytes);
      });
      for (std::size_t p = 0; p < np && !failed_; ++p)
        if (std::fwrite(pieces[p].data(), 1, pieces[p].size(), file_) != pieces[p].size())
          failed_ = true;
    }
  }
  Status finish() {
    flush();
    const bool failed = failed_ || std::fclose(file_) != 0;
    file_ = nullptr;
    std::error_code ec;
    if (failed) {
      std::filesystem::remove(tmp_, ec);
      return Error{ErrorCode::bad_input, "write failed (disk full?)", path_.string(), {}};
    }
    std::filesystem::rename(tmp_, path_, ec);
    if (ec) {
      const std::string why = ec.message();
      std::error_code ignored;
      std::filesystem::remove(tmp_, ignored);
      return Error{ErrorCode::bad_input, "cannot write: " + why, path_.string(), {}};
    }
    return Ok{};
  }

 private:
  static constexpr std::size_t kBuffer = std::size_t{1} << 20;
  void flush() {
    if (!buf_.empty() && std::fwrite(buf_.data(), 1, buf_.size(), file_) != buf_.size())
      failed_ = true;
    buf_.clear();
  }
  std::filesystem::path path_, tmp_;
  std::FILE* file_ = nullptr;
  std::string buf_;
  bool failed_ = false;
};

/// `p` stored as the three floats a file holds (at `out`), and those floats as a point.
/// Out of line on purpose: inlined, GCC 12 (-O3 -frounding-math) was seen to vectorize the
/// narrowing and hand some coordinates on to the normal unrounded, so a triangle's normal
/// depended on the code path (the thread count) and disagreed with its written corners.
[[gnu::noinline]] Vec3 written_as_float(const Vec3& p, float* out) {
  for (Eigen::Index k = 0; k < 3; ++k) out[k] = static_cast<float>(p[k]);
  return {static_cast<double>(out[0]), static_cast<double>(out[1]), static_cast<double>(out[2])};
}

/// Binary STL: 80-byte header, count, then per triangle its unit normal and corners (float).
Status write_stl(const Mesh& m, const std::filesystem::path& path) {
  StreamedFile f(path);
  if (auto st = f.open(); !st) return st;
  std::string& out = f.buffer();
  std::string header(80, '\0');
  const std::string_view title = "printtwin as-printed deposit mesh (binary STL)";
  std::memcpy(header.data(), title.data(), title.size());
  out += header;
  put(out, static_cast<std::uint32_t>(m.triangles.size()));
  f.records(m.triangles.size(), 50, [&](std::size_t i, char* dest) {
    const auto& t = m.triangles[i];
    // The normal of the corners as written (float), so readers that check it agree on slivers.
    std::array<float, 12> fl{};
    const Vec3 a = written_as_float(m.vertices_mm[t[0]], &fl[3]),
               b = written_as_float(m.vertices_mm[t[1]], &fl[6]),
               c = written_as_float(m.vertices_mm[t[2]], &fl[9]);
    Vec3 n = (b - a).cross(c - a);
    const double len = n.norm();
    if (len > 0) n /= len;
    for (std::size_t k = 0; k < 3; ++k) fl[k] = static_cast<float>(n[static_cast<Eigen::Index>(k)]);
    std::memcpy(dest, fl.data(), sizeof(fl));
    dest[48] = dest[49] = 0;
  });
  return f.finish();
}

Status write_ply(const DepositMesh& dm, std::span<const float> deviation,
                 const std::filesystem::path& path) {
  const Mesh& m = dm.mesh;
  const bool quality = !deviation.empty();
  StreamedFile f(path);
  if (auto st = f.open(); !st) return st;
  std::string& out = f.buffer();
  out += "ply\nformat binary_little_endian 1.0\ncomment printtwin as-printed deposit mesh\n";
  out += "comment voxel " + format_number(dm.voxel_mm) + " mm, cells of " +
         std::to_string(dm.cell_voxels) + " voxels, within " + format_number(dm.error_bound_mm) +
         " mm of the voxel surface\n";
  if (quality)
    out +=
        "comment quality and scalar_deviation: signed deviation from the design in mm (positive: "
        "excess)\n";
  out += "element vertex " + std::to_string(m.vertices_mm.size()) +
         "\nproperty float x\nproperty float y\nproperty float z\n";
  // The same value twice: MeshLab colours by `quality`, CloudCompare reads `scalar_*`.
  if (quality) out += "property float quality\nproperty float scalar_deviation\n";
  out += "element face " + std::to_string(m.triangles.size()) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
  f.records(m.vertices_mm.size(), quality ? 20 : 12, [&](std::size_t i, char* dest) {
    std::array<float, 5> fl{};
    for (int k = 0; k < 3; ++k)
      fl[static_cast<std::size_t>(k)] = static_cast<float>(m.vertices_mm[i][k]);
    if (quality) fl[3] = fl[4] = deviation[i];
    std::memcpy(dest, fl.data(), quality ? 20 : 12);
  });
  f.records(m.triangles.size(), 13, [&](std::size_t i, char* dest) {
    dest[0] = 3;
    std::array<std::int32_t, 3> ids{};
    for (std::size_t k = 0; k < 3; ++k) ids[k] = static_cast<std::int32_t>(m.triangles[i][k]);
    std::memcpy(dest + 1, ids.data(), sizeof(ids));
  });
  return f.finish();
}

void append_float(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), static_cast<float>(v));
  out.append(buf, r.ptr);
}

std::string model_xml(const Mesh& m) {
  std::string x =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<model unit=\"millimeter\" xml:lang=\"en-US\" "
      "xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\">\n"
      " <metadata name=\"Application\">printtwin</metadata>\n"
      " <metadata name=\"Title\">as-printed deposit</metadata>\n";
  if (m.triangles.empty()) return x + " <resources/>\n <build/>\n</model>\n";
  x += " <resources>\n  <object id=\"1\" type=\"model\" name=\"deposit\">\n   <mesh>\n    "
       "<vertices>\n";
  x.reserve(x.size() + m.vertices_mm.size() * 56 + m.triangles.size() * 52);
  for (const Vec3& p : m.vertices_mm) {
    x += "     <vertex x=\"";
    append_float(x, p.x());
    x += "\" y=\"";
    append_float(x, p.y());
    x += "\" z=\"";
    append_float(x, p.z());
    x += "\"/>\n";
  }
  x += "    </vertices>\n    <triangles>\n";
  for (const auto& t : m.triangles) {
    x += "     <triangle v1=\"" + std::to_string(t[0]) + "\" v2=\"" + std::to_string(t[1]) +
         "\" v3=\"" + std::to_string(t[2]) + "\"/>\n";
  }
  x += "    </triangles>\n   </mesh>\n  </object>\n </resources>\n <build>\n  <item "
       "objectid=\"1\"/>\n </build>\n</model>\n";
  return x;
}

/// Raw deflate of `data` (zip method 8).
Result<std::string> deflate_raw(std::string_view data) {
  z_stream z{};
  if (deflateInit2(&z, 6, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    return internal_error("zlib: deflateInit2 failed");
  std::string out(deflateBound(&z, static_cast<uLong>(data.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  const std::size_t n = z.total_out;
  deflateEnd(&z);
  if (rc != Z_STREAM_END) return internal_error("zlib: deflate did not finish");
  out.resize(n);
  return out;
}

struct ZipEntry {
  std::string name;
  std::string data;
};

/// A zip archive (deflated entries, fixed 1980-01-01 time stamps so the bytes depend on the
/// content only). No Zip64: entries and the archive stay under 4 GiB.
Result<std::string> zip_archive(const std::vector<ZipEntry>& entries) {
  std::string out, central;
  constexpr std::uint16_t kDate = (0 << 9) | (1 << 5) | 1;  // 1980-01-01
  for (const ZipEntry& e : entries) {
    if (e.data.size() >= 0xFFFFFFFFull)
      return usage_error("3MF: " + e.name +
                         " exceeds 4 GiB (no Zip64); use --deposit-mesh-max-triangles");
    auto packed = deflate_raw(e.data);
    if (!packed) return packed.error();
    const auto crc = static_cast<std::uint32_t>(::crc32(
        0L, reinterpret_cast<const Bytef*>(e.data.data()), static_cast<uInt>(e.data.size())));
    const auto offset = static_cast<std::uint32_t>(out.size());
    auto header = [&](std::string& s, bool central_entry) {
      put(s, central_entry ? std::uint32_t{0x02014b50} : std::uint32_t{0x04034b50});
      if (central_entry) put(s, std::uint16_t{20});  // made by
      put(s, std::uint16_t{20});                     // needed to extract
      put(s, std::uint16_t{0});                      // flags
      put(s, std::uint16_t{8});                      // deflate
      put(s, std::uint16_t{0});                      // time
      put(s, kDate);
      put(s, crc);
      put(s, static_cast<std::uint32_t>(packed->size()));
      put(s, static_cast<std::uint32_t>(e.data.size()));
      put(s, static_cast<std::uint16_t>(e.name.size()));
      put(s, std::uint16_t{0});  // extra
      if (central_entry) {
        put(s, std::uint16_t{0});  // comment
        put(s, std::uint16_t{0});  // disk
        put(s, std::uint16_t{0});  // internal attributes
        put(s, std::uint32_t{0});  // external attributes
        put(s, offset);
      }
      s += e.name;
    };
    header(out, false);
    out += *packed;
    header(central, true);
    if (out.size() >= 0xFFFFFFFFull)
      return usage_error(
          "3MF: the archive exceeds 4 GiB (no Zip64); use --deposit-mesh-max-triangles");
  }
  const auto central_offset = static_cast<std::uint32_t>(out.size());
  out += central;
  put(out, std::uint32_t{0x06054b50});
  put(out, std::uint16_t{0});
  put(out, std::uint16_t{0});
  put(out, static_cast<std::uint16_t>(entries.size()));
  put(out, static_cast<std::uint16_t>(entries.size()));
  put(out, static_cast<std::uint32_t>(central.size()));
  put(out, central_offset);
  put(out, std::uint16_t{0});
  return out;
}

Result<std::string> threemf_bytes(const Mesh& m) {
  std::vector<ZipEntry> entries;
  entries.push_back(
      {"[Content_Types].xml",
       "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">"
       "<Default Extension=\"rels\" "
       "ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>"
       "<Default Extension=\"model\" "
       "ContentType=\"application/vnd.ms-package.3dmanufacturing-3dmodel+xml\"/>"
       "</Types>\n"});
  entries.push_back(
      {"_rels/.rels",
       "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">"
       "<Relationship Target=\"/3D/3dmodel.model\" Id=\"rel0\" "
       "Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel\"/></"
       "Relationships>\n"});
  entries.push_back({"3D/3dmodel.model", model_xml(m)});
  return zip_archive(entries);
}

}  // namespace

Status check_deposit_mesh_path(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".stl" || ext == ".3mf" || ext == ".ply") return Ok{};
  return usage_error("--deposit-mesh " + path.string() + ": unknown mesh format '" + ext +
                     "', expected a file name ending in .stl, .3mf or .ply");
}

Status write_deposit_mesh(const DepositMesh& dm, const std::filesystem::path& path,
                          std::span<const float> deviation_mm) {
  if (auto st = check_deposit_mesh_path(path); !st) return st;
  const std::string ext = lower_extension(path);
  if (!deviation_mm.empty() && deviation_mm.size() != dm.mesh.vertices_mm.size())
    return internal_error("deposit mesh: " + std::to_string(deviation_mm.size()) +
                          " deviation values for " + std::to_string(dm.mesh.vertices_mm.size()) +
                          " vertices");
  if (ext == ".stl") return write_stl(dm.mesh, path);
  if (ext == ".ply") return write_ply(dm, deviation_mm, path);
  auto bytes = threemf_bytes(dm.mesh);
  if (!bytes) return bytes.error();
  return write_file_atomic(path, *bytes);
}

std::string deposit_mesh_summary(const DepositMesh& dm, const std::filesystem::path& path) {
  if (dm.mesh.triangles.empty())
    return "deposit mesh: the deposit has no part voxels; wrote an empty mesh to " + path.string() +
           "\n";
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  std::string s =
      "deposit mesh: " + path.string() + ", " + std::to_string(dm.mesh.triangles.size()) +
      " triangles, " + std::to_string(dm.mesh.vertices_mm.size()) + " vertices" +
      (ec ? std::string() : ", " + format_fixed(static_cast<double>(bytes) / 1e6, 1) + " MB") +
      ", " + format_fixed(dm.seconds, 2) + " s\n";
  s += "  closed and oriented outward; volume " + format_fixed(dm.volume_mm3, 1) +
       " mm3 (filled voxels " + format_fixed(dm.filled_volume_mm3, 1) + " mm3); ";
  if (dm.surface == DepositMeshSurface::layers)
    s += std::to_string(dm.layers) + " slabs, " + std::to_string(dm.outlines) +
         " outlines simplified within " + format_fixed(dm.outline_tolerance_mm, 4) +
         " mm, sides on the beads' round profile" +
         (dm.straight_outlines > 0 ? " (" + std::to_string(dm.straight_outlines) +
                                         " small outlines with flatter or straight sides)"
                                   : std::string()) +
         "; within " + format_fixed(dm.error_bound_mm, 3) + " mm of the voxel outlines\n";
  else if (dm.cell_voxels > 1)
    s += "decimated to cells of " + std::to_string(dm.cell_voxels) + " voxels from " +
         std::to_string(dm.full_res_triangles) + " triangles: within " +
         format_fixed(dm.error_bound_mm, 3) + " mm of the voxel surface, enclosing it\n";
  else if (dm.smoothed_vertices > 0)
    s += "smoothed: " + std::to_string(dm.smoothed_vertices) + " of " +
         std::to_string(dm.mesh.vertices_mm.size()) +
         " vertices on the bead surfaces (each within " + format_fixed(dm.error_bound_mm, 3) +
         " mm of the voxel surface), the rest on the voxel faces\n";
  else if (dm.error_bound_mm > 0)
    s += "on the voxel faces, within " + format_fixed(dm.error_bound_mm, 3) + " mm where " +
         std::to_string(dm.repaired_cells) + " voxels were filled to make it a manifold\n";
  else
    s += "exactly on the voxel faces\n";
  if (!dm.layers_fallback.empty())
    s += "  voxel surface instead of the layered one: " + dm.layers_fallback + "\n";
  if (dm.smoothing_skipped)
    s += "  not smoothed onto the beads: " + std::to_string(dm.mesh.triangles.size()) +
         " triangles, more than --deposit-mesh-smooth-max-triangles (2000000 by default; "
         "smoothing costs about 3.5 s of CPU per million triangles; 0 smooths any size)\n";
  if (dm.merged_pieces > 0 || dm.filled_cavities > 0)
    s += "  " + std::to_string(dm.merged_pieces) +
         " one-slab piece(s) touching the next slab joined to it, " +
         std::to_string(dm.filled_cavities) + " cavity(ies) closed by the slabs filled\n";
  if (dm.dropped_components > 0)
    s += "  left out " + std::to_string(dm.dropped_components) +
         " piece(s) without part voxels (skirt, purge line); --deposit-mesh-include adds auxiliary "
         "features\n";
  return s;
}

std::string deposit_mesh_json(const DepositMesh& dm, const std::filesystem::path& path) {
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  nlohmann::json j;
  j["path"] = path.string();
  j["triangles"] = dm.mesh.triangles.size();
  j["vertices"] = dm.mesh.vertices_mm.size();
  j["bytes"] = ec ? 0 : bytes;
  j["surface"] = dm.surface == DepositMeshSurface::layers ? "layers" : "voxel";
  if (!dm.layers_fallback.empty()) j["layers_fallback"] = dm.layers_fallback;
  j["cell_voxels"] = dm.cell_voxels;
  j["error_bound_mm"] = dm.error_bound_mm;
  j["volume_mm3"] = dm.volume_mm3;
  j["filled_volume_mm3"] = dm.filled_volume_mm3;
  j["repaired_voxels"] = dm.repaired_cells;
  j["smoothed_vertices"] = dm.smoothed_vertices;
  j["components"] = dm.components;
  j["dropped_components"] = dm.dropped_components;
  j["merged_pieces"] = dm.merged_pieces;
  j["filled_cavities"] = dm.filled_cavities;
  return j.dump();
}

Status parse_deposit_mesh_include(const std::string& list, DepositMeshOptions& o) {
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    std::string item = list.substr(start, comma - start);
    item.erase(std::remove(item.begin(), item.end(), ' '), item.end());
    std::transform(item.begin(), item.end(), item.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (item == "skirt" || item == "brim")
      o.include_skirt = true;
    else if (item == "support" || item == "supports")
      o.include_support = true;
    else if (item == "custom" || item == "purge" || item == "wipe_tower" || item == "wipe-tower")
      o.include_custom = true;
    else if (item == "all")
      o.include_skirt = o.include_support = o.include_custom = true;
    else if (!item.empty() || list.empty())
      return usage_error("--deposit-mesh-include: unknown feature '" + item +
                         "', expected a comma list of skirt, support, purge (start code, purge "
                         "lines, wipe tower) or all");
    start = comma + 1;
  }
  return Ok{};
}

}  // namespace printtwin
