// The grid's writes on a writer thread (deposit/grid_writer.hpp) give the same deposit as the
// sweep writing them itself: every voxel and its tag, the counts and the findings, on parts
// built in code and on the real slicers' files (when ../shared/realworld is there).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "deposit/deposit_run.hpp"
#include "deposit/deposit_test_support.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/simulate.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

using test::BeadWriter;
using Writes = detail::DepositRunSettings::Writes;

using Voxel =
    std::tuple<std::int32_t, std::int32_t, std::int32_t, std::uint32_t, std::int32_t, Feature>;

std::vector<Voxel> voxels_of(const VoxelGrid& g) {
  std::vector<Voxel> out;
  out.reserve(g.count());
  g.for_each([&](const VoxelKey& k, const VoxelTag& t) {
    out.emplace_back(k.x, k.y, k.z, t.line, t.layer, t.feature);
  });
  return out;
}

DepositResult deposit_with(std::span<const Move> moves, const PrinterProfile& profile,
                           Writes writes, bool squeeze, double voxel_mm = 0.05) {
  detail::DepositRunSettings s;
  s.voxel_mm = voxel_mm;
  s.writes = writes;
  s.conserve_volume = squeeze;
  auto r = detail::DepositRun::moves(moves, profile, s);
  EXPECT_TRUE(r.ok()) << r.error().describe();
  return r.ok() ? std::move(*r) : DepositResult{};
}

/// Every voxel with its tag, the counts, the box, the memory and the findings agree.
void expect_same(const DepositResult& a, const DepositResult& b, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(a.voxels, b.voxels);
  EXPECT_EQ(a.overlap_mm3, b.overlap_mm3);
  EXPECT_EQ(a.squeezed_mm3, b.squeezed_mm3);
  EXPECT_EQ(a.beads, b.beads);
  EXPECT_EQ(a.unsupported_mm, b.unsupported_mm);
  EXPECT_EQ(a.unsupported.size(), b.unsupported.size());
  EXPECT_EQ(a.findings.size(), b.findings.size());
  EXPECT_TRUE(a.bbox_mm == b.bbox_mm);
  EXPECT_EQ(a.memory_bytes, b.memory_bytes);
  EXPECT_EQ(detail::VoxelBlocks::block_count(a.grid), detail::VoxelBlocks::block_count(b.grid));
  EXPECT_EQ(detail::VoxelBlocks::tag_table(a.grid), detail::VoxelBlocks::tag_table(b.grid));
  EXPECT_TRUE(voxels_of(a.grid) == voxels_of(b.grid));
}

/// A small part like the benchmark's: perimeters with sharp corners (round joins), zig-zag
/// infill, a bridge over a gap and an overhang (sag and droop), support, short beads and
/// path starts and stops (end caps), over enough layers that beads fall on earlier ones.
std::vector<Move> benchmark_like_part(const PrinterProfile& profile) {
  BeadWriter w(profile);
  const double h = 0.2;
  for (int layer = 0; layer < 12; ++layer) {
    const double z = h * (layer + 1);
    w.layer = layer;
    // Support under the bridge, for the first layers.
    if (layer < 6) {
      w.feature = Feature::support;
      for (int i = 0; i < 5; ++i) {
        w.travel({47.0 + 1.5 * i, 41, z});
        w.extrude({47.0 + 1.5 * i, 49, z}, 0.4, h);
      }
    }
    // Two towers, then a bridge between them from layer 8 on.
    for (const double x0 : {40.0, 56.0}) {
      w.feature = Feature::outer_perimeter;
      w.travel({x0, 40, z});
      w.extrude({x0 + 6, 40, z}, 0.45, h);
      w.extrude({x0 + 6, 50, z}, 0.45, h);
      w.extrude({x0 + 3, 53, z}, 0.45, h);  // a 45-degree corner, then sharper ones
      w.extrude({x0, 50, z}, 0.45, h);
      w.extrude({x0, 40, z}, 0.45, h);
      w.feature = layer % 4 == 0 ? Feature::solid_infill : Feature::sparse_infill;
      w.travel({x0 + 0.5, 40.5, z});
      for (int i = 0; i < 10; ++i) {  // zig-zag: turns of about 160 degrees
        const double y = 40.5 + 0.9 * i;
        w.extrude({x0 + 5.5, y + 0.45, z}, 0.45, h);
        w.extrude({x0 + 0.5, y + 0.9, z}, 0.45, h);
      }
      w.feature = Feature::gap_fill;
      w.extrude({x0 + 0.6, 49.6, z}, 0.3, h);  // a short bead
    }
    if (layer >= 8) {
      w.feature = Feature::bridge_infill;
      for (int i = 0; i < 4; ++i) {
        w.travel({45, 42.0 + 2 * i, z});
        w.extrude({57, 42.0 + 2 * i, z}, 0.45, h);
      }
      w.feature = Feature::overhang_perimeter;  // off the towers' side into air
      w.travel({62, 50, z});
      w.extrude({62, 55.0 + 0.3 * layer, z}, 0.45, h);
    }
  }
  w.layer = 12;
  w.feature = Feature::outer_perimeter;
  w.travel({43, 45, 2.6});
  for (int i = 1; i <= 150; ++i) {  // a vase-mode spiral: every move climbs
    const double t = 0.06 * i;
    w.extrude({43 + 2 * std::cos(t), 45 + 2 * std::sin(t), 2.6 + 0.001 * i}, 0.45, 0.2);
  }
  return std::move(w.moves);
}

// Without the squeeze the writer counts the overlap; with it the sweep reads its own copy of
// the occupancy (BeadSweep::mirror_writes).
TEST(DepositWrites, WriterThreadLaysTheSameVoxelsAndTags) {
  const auto profile = ender3_marlin2();
  const auto moves = benchmark_like_part(profile);
  for (const bool squeeze : {false, true}) {
    SCOPED_TRACE(squeeze ? "squeeze" : "no squeeze");
    const DepositResult direct = deposit_with(moves, profile, Writes::direct, squeeze);
    EXPECT_GT(direct.voxels, 100000u);
    EXPECT_GT(direct.overlap_mm3, 0.0);
    EXPECT_GT(direct.squeezed_mm3, 0.0);  // round joins (and the squeeze) took the overlap
    EXPECT_FALSE(direct.unsupported.empty());
    expect_same(direct, deposit_with(moves, profile, Writes::at_once, squeeze), "at once");
    expect_same(direct, deposit_with(moves, profile, Writes::thread, squeeze), "thread");
    expect_same(direct, deposit_with(moves, profile, Writes::automatic, squeeze), "automatic");
  }
}

/// The streamed builder's deposit, with the writes on a writer thread or not.
DepositResult streamed(std::span<const Move> moves, const PrinterProfile& profile, bool thread) {
  Box3 extent;
  for (const auto& m : moves) extent.extend(m.start_mm), extent.extend(m.end_mm);
  if (!thread) setenv("PRINTTWIN_PLAIN", "deposit_writer", 1);
  auto builder = DepositBuilder::create(extent, profile, DepositSettings{}, 100.0);
  if (!thread) unsetenv("PRINTTWIN_PLAIN");
  EXPECT_TRUE(builder.ok());
  if (!builder.ok()) return {};
  for (const auto& m : moves) builder->add(m);
  return builder->finish();
}

TEST(DepositWrites, StreamedBuilderWithWriterThreadMatches) {
  const auto profile = ender3_marlin2();
  const auto moves = benchmark_like_part(profile);
  expect_same(streamed(moves, profile, false), streamed(moves, profile, true), "streamed");
}

TEST(DepositWrites, RealSlicerFilesGiveTheSameDeposit) {
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no realworld folder";
  const auto profile = ender3_marlin2();
  int tested = 0;
  for (const auto& entry : std::filesystem::directory_iterator(*dir / "gcode")) {
    if (entry.path().extension() != ".gcode") continue;
    auto moves = interpret_gcode_file(entry.path(), profile, SimulateOptions{});
    if (!moves.ok() || moves->empty()) continue;  // the interpreter's tests cover its errors
    // A coarser voxel keeps the test short; the writes follow the same paths.
    for (const bool squeeze : {false, true}) {
      const DepositResult direct = deposit_with(*moves, profile, Writes::direct, squeeze, 0.2);
      expect_same(direct, deposit_with(*moves, profile, Writes::thread, squeeze, 0.2),
                  entry.path().filename().string() + (squeeze ? " squeeze" : ""));
    }
    ++tested;
  }
  if (tested == 0) GTEST_SKIP() << "no G-code the interpreter reads";
}

}  // namespace
}  // namespace printtwin
