// Exports of the deposit: outer surface, OctoMap .bt/.ot read back with OctoMap's API (via
// count_octomap_voxels), PLY point cloud, JSON fragment.
#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "deposit/deposit_test_support.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {

using detail::VoxelBlocks;
namespace {

/// Fills the box [lo, hi) of voxels.
void fill_box(VoxelGrid& g, const Eigen::Vector3i& lo, const Eigen::Vector3i& hi,
              std::uint32_t tag) {
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y) VoxelBlocks::fill_row(g, y, z, lo.x(), hi.x(), tag);
}

TEST(DepositOuterSurface, SolidBoxShowsItsShell) {
  VoxelGrid g(0.1, Vec3::Zero(), Eigen::Vector3i(40, 40, 40));
  fill_box(g, {5, 6, 7}, {25, 21, 30}, VoxelBlocks::add_tag(g, {1, 0, Feature::perimeter}));
  const auto s = outer_surface(g);
  const long nx = 20, ny = 15, nz = 23;
  EXPECT_EQ(static_cast<long>(s.size()), nx * ny * nz - (nx - 2) * (ny - 2) * (nz - 2));
  int corners = 0;
  for (const auto& v : s)
    if (std::popcount(static_cast<unsigned>(v.exposed_faces)) == 3) ++corners;
  EXPECT_EQ(corners, 8);
}

TEST(DepositOuterSurface, EnclosedCavityIsNotOutsideButAnOpenCupIs) {
  VoxelGrid g(0.1, Vec3::Zero(), Eigen::Vector3i(60, 60, 60));
  const auto t = VoxelBlocks::add_tag(g, {1, 0, Feature::perimeter});
  // Hollow closed box: 30^3 outside, 2-voxel walls, a 26^3 cavity (spans several blocks).
  fill_box(g, {10, 10, 10}, {40, 40, 40}, t);
  for (int z = 12; z < 38; ++z)
    for (int y = 12; y < 38; ++y)
      for (int x = 12; x < 38; ++x) g.clear({x, y, z});
  const std::size_t shell = 30L * 30 * 30 - 28L * 28 * 28;
  EXPECT_EQ(outer_surface(g).size(), shell);
  // Open the lid: the cavity's walls become outer surface too.
  for (int z = 38; z < 40; ++z)
    for (int y = 12; y < 38; ++y)
      for (int x = 12; x < 38; ++x) g.clear({x, y, z});
  const std::size_t cup = outer_surface(g).size();
  EXPECT_GT(cup, shell + 4 * 26 * 24);
}

DepositResult small_deposit() {
  const auto profile = ender3_marlin2();
  test::BeadWriter w(profile);
  for (int layer = 0; layer < 5; ++layer) {
    w.layer = layer;
    const double z = 0.2 * (layer + 1);
    w.feature = Feature::outer_perimeter;
    w.travel({40, 40, z});
    w.extrude({46, 40, z}, 0.45, 0.2);
    w.extrude({46, 44, z}, 0.45, 0.2);
    w.feature = Feature::sparse_infill;
    w.extrude({40, 44, z}, 0.45, 0.2);
    w.extrude({40, 40, z}, 0.45, 0.2);
  }
  auto r = deposit_moves(w.moves, profile, DepositSettings{});
  EXPECT_TRUE(r.ok());
  return std::move(r).value();
}

TEST(DepositExport, OctomapFilesReadBackWithTheSameVoxelCount) {
  const DepositResult d = small_deposit();
  ASSERT_GT(d.voxels, 10000u);
  const auto dir = test::temp_dir("deposit_octomap");
  ASSERT_TRUE(write_octomap(d.grid, dir / "part.bt").ok());
  ASSERT_TRUE(write_octomap(d.grid, dir / "part.ot", VoxelColoring::layer).ok());
  ASSERT_TRUE(write_octomap(d.grid, dir / "feature.ot", VoxelColoring::feature).ok());
  for (const char* name : {"part.bt", "part.ot", "feature.ot"}) {
    auto n = count_octomap_voxels(dir / name);
    ASSERT_TRUE(n.ok()) << n.error().describe();
    EXPECT_EQ(*n, d.voxels) << name;
  }
  EXPECT_FALSE(write_octomap(d.grid, dir / "part.vox").ok());
  EXPECT_FALSE(count_octomap_voxels(dir / "missing.bt").ok());
}

// The .bt encoder builds the pruned tree itself: full 8^3 cubes become single leaves, and
// the grid's blocks need not line up with OctoMap's cubes. Read back with OctoMap's API.
TEST(DepositExport, BinaryOctomapOfFullAndPartialCubesReadsBack) {
  const auto dir = test::temp_dir("deposit_bt");
  for (const double origin : {0.0, 0.3, -1.15}) {  // key offsets 0, 3, -23 voxels (mod 8: 0, 3, 1)
    VoxelGrid g(0.05, Vec3(origin, origin + 0.1, 0), Eigen::Vector3i(70, 50, 40));
    const auto t = VoxelBlocks::add_tag(g, {1, 0, Feature::perimeter});
    fill_box(g, {3, 5, 0}, {60, 45, 33}, t);                      // spans many whole cubes
    for (int z = 10; z < 20; ++z) g.clear({30, 20, z});           // holes inside
    g.set({69, 49, 39}, VoxelTag{2, 1, Feature::sparse_infill});  // a lone voxel in a corner
    const auto file = dir / "grid.bt";
    ASSERT_TRUE(write_octomap(g, file).ok());
    auto n = count_octomap_voxels(file);
    ASSERT_TRUE(n.ok()) << n.error().describe();
    EXPECT_EQ(*n, g.count()) << origin;
    EXPECT_EQ(g.count(), std::size_t{57} * 40 * 33 - 10 + 1);
  }
  VoxelGrid empty(0.05, Vec3::Zero(), Eigen::Vector3i(8, 8, 8));
  ASSERT_TRUE(write_octomap(empty, dir / "empty.bt").ok());
  auto n = count_octomap_voxels(dir / "empty.bt");
  ASSERT_TRUE(n.ok()) << n.error().describe();
  EXPECT_EQ(*n, 0u);
}

TEST(DepositExport, PlyHoldsTheOuterSurfaceWithLayerAndFeature) {
  const DepositResult d = small_deposit();
  const auto dir = test::temp_dir("deposit_ply");
  ASSERT_TRUE(write_deposit_ply(d.grid, dir / "surface.ply").ok());
  auto text = read_file(dir / "surface.ply");
  ASSERT_TRUE(text.ok());
  const std::string& s = *text;
  const auto end = s.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  const std::string header = s.substr(0, end);
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(header.find("property int layer"), std::string::npos);
  EXPECT_NE(header.find("property uchar feature"), std::string::npos);
  const auto surface = outer_surface(d.grid);
  EXPECT_NE(header.find("element vertex " + std::to_string(surface.size()) + "\n"),
            std::string::npos);
  EXPECT_LT(surface.size(), d.voxels);
  constexpr std::size_t kRecord = 6 * 4 + 3 + 4 + 1 + 4;
  const std::size_t body = end + std::strlen("end_header\n");
  ASSERT_EQ(s.size() - body, surface.size() * kRecord);
  // Every point lies on the deposit's bounding box or inside it, with a valid layer/feature.
  int layers_seen = 0, infill = 0;
  for (std::size_t i = 0; i < surface.size(); ++i) {
    const char* rec = s.data() + body + i * kRecord;
    float xyz[3];
    std::int32_t layer;
    std::uint8_t feature;
    std::memcpy(xyz, rec, sizeof xyz);
    std::memcpy(&layer, rec + 27, 4);
    feature = static_cast<std::uint8_t>(rec[31]);
    EXPECT_TRUE(d.bbox_mm.contains(Vec3(xyz[0], xyz[1], xyz[2]), 1e-3));
    EXPECT_GE(layer, 0);
    EXPECT_LE(layer, 4);
    layers_seen |= 1 << layer;
    infill += feature == static_cast<std::uint8_t>(Feature::sparse_infill);
  }
  EXPECT_EQ(layers_seen, 0x1F);
  EXPECT_GT(infill, 0);
}

TEST(DepositExport, JsonFragmentHasTheSummary) {
  const DepositResult d = small_deposit();
  const auto j = nlohmann::json::parse(deposit_json(d));
  EXPECT_DOUBLE_EQ(j.at("voxel_mm").get<double>(), 0.05);
  EXPECT_EQ(j.at("voxels").get<std::size_t>(), d.voxels);
  EXPECT_NEAR(j.at("volume_mm3").get<double>(), d.volume_mm3, 1e-4);
  // The loops close on their own start (no seam gap): each end cap lies on the loop's start,
  // overlap that is lost without the squeeze.
  EXPECT_NEAR(j.at("extruded_mm3").get<double>() / j.at("volume_mm3").get<double>(), 1.0, 0.03);
  EXPECT_GE(j.at("overlap_mm3").get<double>(), 0.0);
  EXPECT_NEAR(j.at("bbox_mm").at("max")[2].get<double>(), 1.0, 1e-9);
  // The first bead's round start: the first layer's (elephant's foot 0.1 mm on both sides)
  // reaches (0.45 + 0.2) / 2 behind x = 40.
  EXPECT_NEAR(j.at("bbox_mm").at("min")[0].get<double>(), 39.675, 0.06);
  EXPECT_EQ(j.at("beads").get<int>(), 20);
}

}  // namespace
}  // namespace printtwin
