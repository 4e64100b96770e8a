// OctoMap adapter: the only file that includes OctoMap. Exports the deposit as .bt (binary
// occupancy OcTree, pruned) or .ot (ColorOcTree, every voxel a leaf with its layer or feature
// colour), and reads such files back. Coordinates and resolution are in millimetres (octovis
// shows any unit); voxel centres map to OctoMap keys one to one since the resolution equals
// the voxel size.
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cctype>
#include <memory>
#include <sstream>

#include "deposit/palette.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

namespace {

std::string lower_extension(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

/// OctoMap addresses +-32768 voxels around the origin on each axis.
Status check_key_range(const VoxelGrid& grid) {
  const double limit = 32767.0 * grid.voxel_mm();
  const Vec3 lo = grid.origin_mm();
  const Vec3 hi = lo + grid.voxel_mm() * grid.dims().cast<double>();
  if (lo.cwiseAbs().maxCoeff() >= limit || hi.cwiseAbs().maxCoeff() >= limit)
    return usage_error("the deposit does not fit OctoMap's key range (+-" + format_number(limit) +
                       " mm at voxel " + format_number(grid.voxel_mm()) + " mm)");
  return Ok{};
}

template <class Tree>
void insert_voxels(const VoxelGrid& grid, Tree& tree, const std::function<void(typename Tree::NodeType*, const VoxelTag&)>& paint) {
  const float occupied = tree.getClampingThresMaxLog();
  grid.for_each([&](const VoxelKey& k, const VoxelTag& tag) {
    const Vec3 c = grid.center_mm(k);
    const octomap::OcTreeKey key =
        tree.coordToKey(octomap::point3d(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                         static_cast<float>(c.z())));
    auto* node = tree.setNodeValue(key, occupied, /*lazy_eval=*/true);
    if (paint && node != nullptr) paint(node, tag);
  });
}

}  // namespace

Status write_octomap(const VoxelGrid& grid, const std::filesystem::path& path, VoxelColoring coloring) {
  const std::string ext = lower_extension(path);
  if (ext != ".bt" && ext != ".ot")
    return usage_error("OctoMap output must end in .bt or .ot: " + path.string());
  if (auto st = check_key_range(grid); !st) return st.error();
  std::ostringstream bytes(std::ios::binary);
  if (ext == ".bt") {
    octomap::OcTree tree(grid.voxel_mm());
    insert_voxels<octomap::OcTree>(grid, tree, {});
    tree.updateInnerOccupancy();
    tree.prune();
    if (!tree.writeBinary(bytes)) return internal_error("OctoMap could not serialise " + path.string());
  } else {
    octomap::ColorOcTree tree(grid.voxel_mm());
    insert_voxels<octomap::ColorOcTree>(
        grid, tree, [coloring](octomap::ColorOcTreeNode* node, const VoxelTag& tag) {
          const auto c = coloring == VoxelColoring::layer ? deposit_detail::layer_color(tag.layer)
                                                          : deposit_detail::feature_color(tag.feature);
          node->setColor(c.r, c.g, c.b);
        });
    // ColorOcTree's pruning ignores colours: keep every voxel a leaf so colours survive.
    tree.updateInnerOccupancy();
    if (!tree.write(bytes)) return internal_error("OctoMap could not serialise " + path.string());
  }
  return write_file_atomic(path, bytes.str());
}

Result<std::size_t> count_octomap_voxels(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  std::unique_ptr<octomap::AbstractOcTree> owned;
  std::unique_ptr<octomap::OcTree> bt;
  if (ext == ".bt") {
    bt = std::make_unique<octomap::OcTree>(0.1);
    if (!bt->readBinary(path.string())) return bad_input("not a readable OctoMap .bt file", path.string());
  } else if (ext == ".ot") {
    owned.reset(octomap::AbstractOcTree::read(path.string()));
    if (!owned) return bad_input("not a readable OctoMap .ot file", path.string());
  } else {
    return usage_error("OctoMap files end in .bt or .ot: " + path.string());
  }
  auto count = [](const auto& tree) {
    std::size_t n = 0;
    const unsigned max_depth = tree.getTreeDepth();
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it)
      if (tree.isNodeOccupied(*it)) n += std::size_t{1} << (3 * (max_depth - it.getDepth()));
    return n;
  };
  if (bt) return count(*bt);
  if (auto* color = dynamic_cast<octomap::ColorOcTree*>(owned.get())) return count(*color);
  if (auto* occ = dynamic_cast<octomap::OcTree*>(owned.get())) return count(*occ);
  return bad_input("unsupported OctoMap tree type " + owned->getTreeType(), path.string());
}

}  // namespace printtwin
