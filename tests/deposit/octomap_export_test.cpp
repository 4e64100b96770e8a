// The .ot export is written straight from the grid. These tests build the same tree the
// way OctoMap's API would (a ColorOcTree leaf per voxel, then updateInnerOccupancy) and
// compare, through OctoMap's own reader: the same occupied voxels with the same colours,
// and every node of the written tree has the colour OctoMap gives the node at that place.
#include <gtest/gtest.h>
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <tuple>

#include "deposit/deposit_test_support.hpp"
#include "deposit/palette.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {

using detail::VoxelBlocks;
namespace {

using Colour = std::tuple<int, int, int>;
using VoxelColours = std::map<std::tuple<int, int, int>, Colour>;

/// The .ot as OctoMap's insert path builds it (the export before it was written directly).
std::unique_ptr<octomap::ColorOcTree> tree_by_insertion(const VoxelGrid& grid,
                                                        VoxelColoring coloring) {
  auto tree = std::make_unique<octomap::ColorOcTree>(grid.voxel_mm());
  const float occupied = tree->getClampingThresMaxLog();
  grid.for_each([&](const VoxelKey& k, const VoxelTag& tag) {
    const Vec3 c = grid.center_mm(k);
    const auto key = tree->coordToKey(octomap::point3d(
        static_cast<float>(c.x()), static_cast<float>(c.y()), static_cast<float>(c.z())));
    auto* node = tree->setNodeValue(key, occupied, /*lazy_eval=*/true);
    const auto rgb = coloring == VoxelColoring::layer ? deposit_detail::layer_color(tag.layer)
                                                      : deposit_detail::feature_color(tag.feature);
    node->setColor(rgb.r, rgb.g, rgb.b);
  });
  if (tree->size() > 0) tree->updateInnerOccupancy();
  return tree;
}

std::unique_ptr<octomap::ColorOcTree> read_ot(const std::filesystem::path& file) {
  std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(file.string()));
  if (!any) return nullptr;
  if (dynamic_cast<octomap::ColorOcTree*>(any.get()) == nullptr) return nullptr;
  return std::unique_ptr<octomap::ColorOcTree>(static_cast<octomap::ColorOcTree*>(any.release()));
}

/// Every occupied voxel (OctoMap key) with its colour; a leaf above the bottom stands for
/// all the voxels it covers.
VoxelColours voxels_of(const octomap::ColorOcTree& tree) {
  VoxelColours out;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const int edge = 1 << (tree.getTreeDepth() - it.getDepth());
    const auto k = it.getIndexKey();  // the leaf's lowest key
    const auto c = it->getColor();
    for (int z = 0; z < edge; ++z)
      for (int y = 0; y < edge; ++y)
        for (int x = 0; x < edge; ++x) out[{k[0] + x, k[1] + y, k[2] + z}] = {c.r, c.g, c.b};
  }
  return out;
}

void expect_same_as_insertion(const VoxelGrid& grid, VoxelColoring coloring,
                              const std::string& what) {
  const auto dir = test::temp_dir("octomap_ot");
  const auto file = dir / "grid.ot";
  ASSERT_TRUE(write_octomap(grid, file, coloring).ok()) << what;
  const auto written = read_ot(file);
  ASSERT_NE(written, nullptr) << what;
  const auto reference = tree_by_insertion(grid, coloring);
  const auto voxels = voxels_of(*written);
  EXPECT_EQ(voxels.size(), grid.count()) << what;
  EXPECT_TRUE(voxels == voxels_of(*reference)) << what;
  auto n = count_octomap_voxels(file);
  ASSERT_TRUE(n.ok()) << n.error().describe();
  EXPECT_EQ(*n, grid.count()) << what;
  // Inner nodes: the same occupancy and colour as OctoMap's updateInnerOccupancy gives.
  std::size_t nodes = 0, mismatched = 0;
  for (auto it = written->begin_tree(), end = written->end_tree(); it != end; ++it, ++nodes) {
    // search() reads depth 0 as "the bottom": the root is compared as itself.
    const auto* ref =
        it.getDepth() == 0 ? reference->getRoot() : reference->search(it.getKey(), it.getDepth());
    if (ref == nullptr || ref->getLogOdds() != it->getLogOdds() ||
        !(ref->getColor() == it->getColor()))
      ++mismatched;
  }
  EXPECT_EQ(nodes, written->size()) << what;
  EXPECT_EQ(mismatched, 0u) << what;
  EXPECT_LE(written->size(), reference->size()) << what;
}

void fill_box(VoxelGrid& g, const Eigen::Vector3i& lo, const Eigen::Vector3i& hi,
              std::uint32_t tag) {
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y) VoxelBlocks::fill_row(g, y, z, lo.x(), hi.x(), tag);
}

// Boxes of several layers and features, holes, a lone voxel in the grid's far corner and
// one at its origin; the grid's blocks line up with OctoMap's cubes or not, by `origin`.
VoxelGrid boxes_and_holes(double origin) {
  VoxelGrid g(0.05, Vec3(origin, origin + 0.1, 0), Eigen::Vector3i(70, 50, 40));
  for (int layer = 0; layer < 8; ++layer) {
    const auto t =
        VoxelBlocks::add_tag(g, {static_cast<std::uint32_t>(layer + 1), layer,
                                 layer % 3 == 0 ? Feature::gap_fill : Feature::sparse_infill});
    fill_box(g, {3, 5, 4 * layer}, {60, 45, 4 * layer + 4}, t);
  }
  const auto outer = VoxelBlocks::add_tag(g, {100, 2, Feature::outer_perimeter});
  fill_box(g, {0, 0, 8}, {3, 50, 12}, outer);
  for (int z = 10; z < 20; ++z) g.clear({30, 20, z});
  g.set({69, 49, 39}, VoxelTag{200, 9, Feature::support});
  g.set({0, 0, 0}, VoxelTag{201, 0, Feature::skirt});
  return g;
}

TEST(OctomapOt, SameVoxelsAndColoursAsOctomapsInsertPath) {
  for (const double origin : {0.0, 0.3, -1.15}) {
    const VoxelGrid g = boxes_and_holes(origin);
    for (const auto coloring : {VoxelColoring::layer, VoxelColoring::feature})
      expect_same_as_insertion(g, coloring, "origin " + std::to_string(origin));
  }
}

// The .bt holds the bytes OctoMap's writeBinary writes for the same voxels inserted one by
// one (it prunes the tree first).
TEST(OctomapBt, SameBytesAsOctomapsWriteBinary) {
  for (const double origin : {0.0, 0.3, -1.15}) {
    const VoxelGrid g = boxes_and_holes(origin);
    const auto file = test::temp_dir("octomap_bt") / "grid.bt";
    ASSERT_TRUE(write_octomap(g, file).ok());
    octomap::OcTree tree(g.voxel_mm());
    g.for_each([&](const VoxelKey& k, const VoxelTag&) {
      const Vec3 c = g.center_mm(k);
      tree.updateNode(
          tree.coordToKey(octomap::point3d(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                           static_cast<float>(c.z()))),
          true, /*lazy_eval=*/true);
    });
    tree.updateInnerOccupancy();
    std::ostringstream reference;
    ASSERT_TRUE(tree.writeBinary(reference));
    const auto written = read_file(file);
    ASSERT_TRUE(written.ok());
    EXPECT_TRUE(*written == reference.str()) << "origin " << origin;
    EXPECT_GT(written->size(), 200u);
  }
}

TEST(OctomapOt, SimulatedBeadsAndASingleBead) {
  const auto profile = ender3_marlin2();
  test::BeadWriter w(profile);
  w.feature = Feature::outer_perimeter;
  w.travel({40, 40, 0.2});
  w.extrude({43, 41, 0.2}, 0.45, 0.2);
  auto one = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(one.ok());
  ASSERT_GT(one->voxels, 0u);
  expect_same_as_insertion(one->grid, VoxelColoring::layer, "single bead");
  for (int layer = 1; layer < 4; ++layer) {
    w.layer = layer;
    const double z = 0.2 * (layer + 1);
    w.feature = Feature::perimeter;
    w.travel({40, 40, z});
    w.extrude({44, 40, z}, 0.45, 0.2);
    w.feature = Feature::solid_infill;
    w.extrude({44, 43, z}, 0.45, 0.2);
  }
  auto several = deposit_moves(w.moves, profile, DepositSettings{});
  ASSERT_TRUE(several.ok());
  expect_same_as_insertion(several->grid, VoxelColoring::feature, "beads");
  expect_same_as_insertion(several->grid, VoxelColoring::layer, "beads");
}

// A whole cube of one colour is one node, and the tree is far smaller than a leaf per voxel.
TEST(OctomapOt, UniformCubesArePrunedWithoutLosingColour) {
  VoxelGrid g(0.05, Vec3::Zero(), Eigen::Vector3i(64, 64, 64));
  fill_box(g, {0, 0, 0}, {64, 64, 32}, VoxelBlocks::add_tag(g, {1, 0, Feature::sparse_infill}));
  fill_box(g, {0, 0, 32}, {64, 64, 64}, VoxelBlocks::add_tag(g, {2, 1, Feature::sparse_infill}));
  const auto dir = test::temp_dir("octomap_ot_uniform");
  ASSERT_TRUE(write_octomap(g, dir / "layer.ot", VoxelColoring::layer).ok());
  ASSERT_TRUE(write_octomap(g, dir / "feature.ot", VoxelColoring::feature).ok());
  const auto by_layer = read_ot(dir / "layer.ot");
  const auto by_feature = read_ot(dir / "feature.ot");
  ASSERT_NE(by_layer, nullptr);
  ASSERT_NE(by_feature, nullptr);
  EXPECT_EQ(by_feature->getNumLeafNodes(), 1u);  // the 64^3 block, one colour
  EXPECT_EQ(by_layer->getNumLeafNodes(), 8u);    // its two halves, 4 nodes of 32^3 each
  expect_same_as_insertion(g, VoxelColoring::layer, "two halves");
  // Far fewer nodes than the room the header kept for their count: the comment line takes
  // the difference (the records stay where they were written), and OctoMap reads the count.
  const auto bytes = read_file(dir / "feature.ot");
  ASSERT_TRUE(bytes.ok());
  std::istringstream lines(*bytes);
  std::string line;
  for (int i = 0; i < 3; ++i) std::getline(lines, line);
  EXPECT_EQ(line.substr(0, 2), "# ");
  EXPECT_EQ(line.find_first_not_of(' ', 1), std::string::npos);
  std::getline(lines, line);
  EXPECT_EQ(line, "id ColorOcTree");
  std::getline(lines, line);
  EXPECT_EQ(line, "size " + std::to_string(by_feature->size()));
}

// More records than the encoder buffers (1 MiB): the colours of nodes whose records were
// already written out are patched in the file. Every other voxel of a checkerboard (no two
// of a 2^3 cube alike) beside solid layers (merged into larger leaves).
TEST(OctomapOt, LargeTreeStreamedToTheFile) {
  VoxelGrid g(0.05, Vec3(0.3, 0.1, 0), Eigen::Vector3i(80, 72, 64));
  for (int z = 0; z < 64; ++z)
    for (int y = 0; y < 72; ++y)
      for (int x = 0; x < 80; ++x)
        if ((x + y + z) % 2 == 0 || x >= 64)
          g.set({x, y, z}, VoxelTag{static_cast<std::uint32_t>(z / 4 + 1), z / 4,
                                    x >= 64 ? Feature::solid_infill : Feature::sparse_infill});
  ASSERT_GT(g.count(), 150000u);
  expect_same_as_insertion(g, VoxelColoring::layer, "checkerboard");
}

// The subtrees (64^3 voxels) are encoded on all cores and the levels above them written
// around them: the same bytes as on one thread (PRINTTWIN_PLAIN=octomap_threads), and the
// nodes above the subtrees are merged like those inside them (a 128^3 cube of one colour,
// eight subtrees, is one leaf of the .ot and one occupied leaf of the .bt).
TEST(OctomapOt, SubtreesOnAllCoresGiveTheBytesOfOneThread) {
  VoxelGrid g(0.05, Vec3::Zero(), Eigen::Vector3i(136, 130, 129));
  fill_box(g, {0, 0, 0}, {128, 128, 128}, VoxelBlocks::add_tag(g, {1, 0, Feature::sparse_infill}));
  fill_box(g, {128, 0, 0}, {136, 130, 9}, VoxelBlocks::add_tag(g, {2, 1, Feature::perimeter}));
  g.set({3, 129, 128}, VoxelTag{3, 2, Feature::support});
  const auto dir = test::temp_dir("octomap_threads");
  std::map<std::string, std::string> threaded;
  for (const bool plain : {false, true}) {
    if (plain) {
      ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "octomap_threads", 1), 0);
    }
    for (const char* name : {"layer.ot", "feature.ot", "part.bt"}) {
      const auto file = dir / name;
      ASSERT_TRUE(
          write_octomap(g, file, name[0] == 'f' ? VoxelColoring::feature : VoxelColoring::layer)
              .ok())
          << name;
      const auto bytes = read_file(file);
      ASSERT_TRUE(bytes.ok()) << name;
      if (plain)
        EXPECT_TRUE(*bytes == threaded[name]) << name;
      else
        threaded[name] = *bytes;
    }
    if (plain) ::unsetenv("PRINTTWIN_PLAIN");
  }
  const auto ot = read_ot(dir / "feature.ot");
  ASSERT_NE(ot, nullptr);
  const octomap::OcTreeKey corner(32768, 32768, 32768);
  const auto* cube = ot->search(corner, ot->getTreeDepth() - 7);
  ASSERT_NE(cube, nullptr);
  EXPECT_FALSE(ot->nodeHasChildren(cube));
  EXPECT_EQ(ot->search(corner)->getColor(),
            ot->search(octomap::OcTreeKey(32895, 32895, 32895))->getColor());
  octomap::OcTree bt(0.05);
  ASSERT_TRUE(bt.readBinary((dir / "part.bt").string()));
  const auto* occupied = bt.search(corner, bt.getTreeDepth() - 7);
  ASSERT_NE(occupied, nullptr);
  EXPECT_FALSE(bt.nodeHasChildren(occupied));
  EXPECT_TRUE(bt.isNodeOccupied(occupied));
  auto n = count_octomap_voxels(dir / "part.bt");
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, g.count());
  expect_same_as_insertion(g, VoxelColoring::feature, "128^3 cube");
}

TEST(OctomapOt, EmptyDepositIsAValidEmptyTree) {
  const VoxelGrid empty(0.05, Vec3::Zero(), Eigen::Vector3i(8, 8, 8));
  const auto dir = test::temp_dir("octomap_ot_empty");
  for (const char* name : {"empty.ot", "empty.bt"}) {
    ASSERT_TRUE(write_octomap(empty, dir / name).ok()) << name;
    auto n = count_octomap_voxels(dir / name);
    ASSERT_TRUE(n.ok()) << n.error().describe();
    EXPECT_EQ(*n, 0u) << name;
  }
}

}  // namespace
}  // namespace printtwin
