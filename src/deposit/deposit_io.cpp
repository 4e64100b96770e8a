// Deposit exports that need no third-party format library: the PLY point cloud of the outer
// surface voxels and the `deposit` JSON fragment of the simulate report.
#include <bit>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>

#include "deposit/palette.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

using detail::VoxelBlocks;

namespace {

static_assert(std::endian::native == std::endian::little,
              "the PLY writer emits the host's byte order as binary_little_endian");

template <class T>
void put(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

/// v rounded to `decimals` digits; dividing by the power of ten keeps 118.6 printing as 118.6.
double rounded(double v, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(v * scale) / scale;
}

nlohmann::json box_json(const Box3& b) {
  if (b.empty()) return nullptr;
  auto arr = [](const Vec3& v) {
    return nlohmann::json::array({rounded(v.x(), 4), rounded(v.y(), 4), rounded(v.z(), 4)});
  };
  return {{"min", arr(b.min)}, {"max", arr(b.max)}};
}

}  // namespace

Status write_deposit_ply(const VoxelGrid& grid, const std::filesystem::path& path) {
  const std::vector<SurfaceVoxel> surface = outer_surface(grid);
  const auto& tags = VoxelBlocks::tag_table(grid);
  std::string out;
  out += "ply\nformat binary_little_endian 1.0\n";
  out += "comment printtwin deposit: outer surface voxels (centres, mm), voxel_mm " +
         format_number(grid.voxel_mm()) + "\n";
  out +=
      "comment feature: 0 unknown 1 outer_perimeter 2 perimeter 3 overhang_perimeter "
      "4 sparse_infill 5 solid_infill 6 top_solid_infill 7 bridge_infill 8 gap_fill 9 skirt "
      "10 support 11 support_interface 12 wipe_tower 13 custom\n";
  out += "element vertex " + std::to_string(surface.size()) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  out += "property float nx\nproperty float ny\nproperty float nz\n";
  out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out += "property int layer\nproperty uchar feature\nproperty uint line\n";
  out += "end_header\n";
  out.reserve(out.size() + surface.size() * 35);
  for (const auto& s : surface) {
    const Vec3 c = grid.center_mm(s.key);
    // Normal: the sum of the exposed faces' outward directions.
    Vec3 n((s.exposed_faces >> 1 & 1) - (s.exposed_faces & 1),
           (s.exposed_faces >> 3 & 1) - (s.exposed_faces >> 2 & 1),
           (s.exposed_faces >> 5 & 1) - (s.exposed_faces >> 4 & 1));
    if (n.squaredNorm() > 0) n.normalize();
    const auto ti = VoxelBlocks::tag_index(grid, s.key);
    const VoxelTag tag = ti ? tags[*ti] : VoxelTag{};
    const auto rgb = deposit_detail::layer_color(tag.layer);
    put(out, static_cast<float>(c.x()));
    put(out, static_cast<float>(c.y()));
    put(out, static_cast<float>(c.z()));
    put(out, static_cast<float>(n.x()));
    put(out, static_cast<float>(n.y()));
    put(out, static_cast<float>(n.z()));
    put(out, rgb.r);
    put(out, rgb.g);
    put(out, rgb.b);
    put(out, static_cast<std::int32_t>(tag.layer));
    put(out, static_cast<std::uint8_t>(tag.feature));
    put(out, static_cast<std::uint32_t>(tag.line));
  }
  return write_file_atomic(path, out);
}

std::string deposit_json(const DepositResult& d) {
  nlohmann::json j;
  j["voxel_mm"] = d.voxel_mm;
  j["voxels"] = d.voxels;
  j["volume_mm3"] = rounded(d.volume_mm3, 4);
  j["extruded_mm3"] = rounded(d.extruded_mm3, 4);
  j["overlap_mm3"] = rounded(d.overlap_mm3, 4);
  j["squeezed_mm3"] = rounded(d.squeezed_mm3, 4);
  j["bbox_mm"] = box_json(d.bbox_mm);
  j["beads"] = d.beads;
  j["unsupported_mm"] = rounded(d.unsupported_mm, 3);
  j["memory_bytes"] = d.memory_bytes;
  std::size_t bridges = 0, cantilevers = 0;
  for (const auto& s : d.unsupported) (s.bridge ? bridges : cantilevers) += 1;
  j["unsupported_stretches"] = {{"bridge", bridges}, {"cantilever", cantilevers}};
  return j.dump();
}

}  // namespace printtwin
