// Tests of the deposit's inner loop: the 64-voxel sample-point test of a bead (both kernels
// agree bit for bit, and the bits are the stadium geometry).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "deposit/height_map.hpp"
#include "deposit/kernels.hpp"
#include "deposit/nibbles.hpp"

namespace printtwin::detail {
namespace {

TEST(TagNibbles, WritesTheMaskedVoxelsOnly) {
  std::array<std::uint8_t, 32> row{};
  store_nibbles(row.data(),
                (std::uint64_t{1} << 0) | (std::uint64_t{1} << 9) | (std::uint64_t{1} << 63), 0xA);
  EXPECT_EQ(row[0], 0x0A);   // voxel (0, 0): low nibble of byte 0
  EXPECT_EQ(row[4], 0xA0);   // voxel (1, 1): row 1 starts at byte 4, x = 1 is the high nibble
  EXPECT_EQ(row[31], 0xA0);  // voxel (7, 7)
  // Against a voxel-at-a-time reference, whatever the mask, entry and previous bytes.
  std::mt19937_64 rng(7);
  std::array<std::uint8_t, 32> a{};
  for (auto& x : a) x = static_cast<std::uint8_t>(rng());
  for (int i = 0; i < 2000; ++i) {
    std::uint64_t mask = rng();
    if (i % 3 == 0) mask &= rng();  // sparser masks too
    if (i % 7 == 0) mask = i % 2 ? ~std::uint64_t{0} : 0;
    const auto e = static_cast<unsigned>(rng() % 16);
    std::array<std::uint8_t, 32> expected = a;
    for (int v = 0; v < 64; ++v)
      if ((mask >> v) & 1U) {
        std::uint8_t& byte = expected[static_cast<std::size_t>(v / 2)];
        byte = v % 2 ? static_cast<std::uint8_t>((byte & 0x0F) | (e << 4))
                     : static_cast<std::uint8_t>((byte & 0xF0) | e);
      }
    store_nibbles(a.data(), mask, e);
    ASSERT_EQ(a, expected) << "mask " << std::hex << mask << " entry " << e;
  }
}

/// A flat bead from (ax, ay) along direction angle t, length len, section of height 2r and
/// flat half-width flat, top at z_top (voxel units); square cuts.
BeadFrame bead(double ax, double ay, double z_top, double t, double len, double r, double flat) {
  BeadFrame f;
  f.ia = static_cast<std::int32_t>(std::floor(ax));
  f.ja = static_cast<std::int32_t>(std::floor(ay));
  f.ka = static_cast<std::int32_t>(std::floor(z_top));
  f.fa_x = static_cast<float>(ax - f.ia);
  f.fa_y = static_cast<float>(ay - f.ja);
  f.d_x = static_cast<float>(std::cos(t)), f.d_y = static_cast<float>(std::sin(t));
  f.n_x = -f.d_y, f.n_y = f.d_x;
  f.m0_x = f.d_x, f.m0_y = f.d_y;
  f.m1_x = f.d_x, f.m1_y = f.d_y;
  f.e1 = static_cast<float>(len);
  f.c0 = static_cast<float>(z_top - r - f.ka);
  f.r = static_cast<float>(r), f.r2 = static_cast<float>(r * r), f.flat = static_cast<float>(flat);
  return f;
}

// Both kernels (AVX-512 two rows at a time, portable a voxel at a time) give the same bits,
// over odd and even row ranges, one layer at a time or a tile's layers at once.
TEST(BeadRaster, DispatchedKernelMatchesThePortableOne) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int set_bits = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const double ax = 100 + 50 * u(rng), ay = 100 + 50 * u(rng), z_top = 4 + 20 * u(rng);
    BeadFrame f =
        bead(ax, ay, z_top, 2 * M_PI * u(rng), 1 + 40 * u(rng), 1 + 3 * u(rng), 4 * u(rng));
    f.slope = trial % 4 == 0 ? static_cast<float>(0.05 * u(rng)) : 0.0f;  // some spiral beads
    for (int tile = 0; tile < 12; ++tile) {
      const auto i0 = static_cast<std::int32_t>(8 * std::floor((ax - 12 + 24 * u(rng)) / 8));
      const auto j0 = static_cast<std::int32_t>(8 * std::floor((ay - 12 + 24 * u(rng)) / 8));
      const auto k = static_cast<std::int32_t>(std::floor(z_top - 6 + 7 * u(rng)));
      const int row_lo = static_cast<int>(8 * u(rng) * 0.5),
                row_hi = 4 + static_cast<int>(4 * u(rng) + 0.99);
      const unsigned lanes = trial % 3 == 0 ? 0x3Fu : 0xFFu;
      const std::uint64_t a = test_tile(f, i0, j0, k, row_lo, row_hi, lanes);
      const std::uint64_t b = test_tile_scalar(f, i0, j0, k, row_lo, row_hi, lanes);
      ASSERT_EQ(a, b) << "trial " << trial << " tile " << tile;
      // All of a bead's layers of the tile at once: each layer's bits as alone.
      const std::array<std::int32_t, 5> ks{k - 2, k - 1, k, k + 1, k + 3};
      std::array<std::uint64_t, 5> masks{};
      test_tile_layers(f, i0, j0, ks.data(), static_cast<int>(ks.size()), row_lo, row_hi, lanes,
                       masks.data());
      for (std::size_t n = 0; n < ks.size(); ++n)
        ASSERT_EQ(masks[n], test_tile_scalar(f, i0, j0, ks[n], row_lo, row_hi, lanes))
            << "trial " << trial << " layer " << n;
      set_bits += __builtin_popcountll(a);
    }
  }
  EXPECT_GT(set_bits, 10000);  // the tiles were not all empty
}

TEST(BeadRaster, BitsAreTheVoxelsWhoseSamplePointIsInTheStadium) {
  // A bead along x at y = 20.3, top at z = 8 (voxel units): section 4 high, 9 wide.
  const double ay = 20.3, z_top = 8.0, r = 2.0, flat = 2.5;
  const BeadFrame f = bead(3.2, ay, z_top, 0.0, 40.0, r, flat);
  int inside = 0, outside = 0;
  for (std::int32_t k = 4; k < 10; ++k)
    for (std::int32_t j0 = 8; j0 <= 24; j0 += 8)
      for (std::int32_t i0 = 0; i0 <= 48; i0 += 8) {
        const std::uint64_t bits = test_tile(f, i0, j0, k, 0, 8, 0xFFu);
        for (int y = 0; y < 8; ++y)
          for (int x = 0; x < 8; ++x) {
            const std::uint32_t h = voxel_jitter_bits(i0 + x, j0 + y, k);
            const double sx = i0 + x + ((h & 0x3FF) + 0.5) / 1024.0;
            const double sy = j0 + y + (((h >> 10) & 0x3FF) + 0.5) / 1024.0;
            const double sz = k + (((h >> 20) & 0x3FF) + 0.5) / 1024.0;
            const double dz = sz - (z_top - r);
            const double lateral = std::abs(sy - ay) - flat;
            const bool expect = sx >= 3.2 && sx < 43.2 && dz >= -r && dz < r &&
                                (lateral <= 0 || lateral * lateral + dz * dz <= r * r);
            // Sample points within 1e-4 voxel of the surface may go either way in single precision.
            const double margin =
                std::min({std::abs(sx - 3.2), std::abs(sx - 43.2), std::abs(dz + r),
                          std::abs(dz - r), std::abs(std::hypot(std::max(lateral, 0.0), dz) - r)});
            if (margin < 1e-4) continue;
            const bool got = ((bits >> (y * 8 + x)) & 1u) != 0;
            ASSERT_EQ(got, expect) << "voxel " << i0 + x << "," << j0 + y << "," << k;
            (got ? inside : outside) += 1;
          }
      }
  // The stadium's area is 4 x 5 + pi x 4 = 32.6 voxels per voxel of length: 40 voxels long.
  EXPECT_NEAR(inside / 40.0, 32.57, 1.0);
  EXPECT_GT(outside, 0);
}

TEST(BeadRaster, CountHeldMatchesAColumnByColumnCount) {
  const int nx = 37, ny = 29;
  const std::size_t tiles_x = (nx + 7) / 8, tiles_y = (ny + 7) / 8;
  std::vector<std::uint16_t> top(tiles_x * tiles_y * 64 + 1, 0);
  std::mt19937 rng(3);
  for (auto& t : top) t = static_cast<std::uint16_t>(rng() % 12);
  const HeightMapView map{top.data(), tiles_x, nx, ny};
  const auto column = [&](double u, double v) {
    const auto i = static_cast<int>(std::floor(u)), j = static_cast<int>(std::floor(v));
    if (i < 0 || j < 0 || i >= nx || j >= ny) return 0;
    return static_cast<int>(
        top[((static_cast<std::size_t>(j) / 8) * tiles_x + static_cast<std::size_t>(i) / 8) * 64 +
            static_cast<std::size_t>(j % 8) * 8 + static_cast<std::size_t>(i % 8)]);
  };
  std::uniform_real_distribution<double> u(-6.0, 44.0), unit(-1.0, 1.0);
  int total = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int n = 1 + trial % 13;
    std::vector<double> s(static_cast<std::size_t>(n));
    for (int t = 0; t < n; ++t) s[static_cast<std::size_t>(t)] = -0.5 * n + t + 0.5;
    const double x = u(rng), y = u(rng), dx = unit(rng), dy = unit(rng);
    const int need = static_cast<int>(rng() % 12);
    int expect = 0;
    for (const double st : s) expect += column(x + st * dx, y + st * dy) >= need ? 1 : 0;
    ASSERT_EQ(count_held(map, x, y, dx, dy, s.data(), n, need), expect) << "trial " << trial;
    for (int enough = 0; enough <= n + 1; ++enough)
      ASSERT_EQ(held_at_least(map, x, y, dx, dy, s.data(), n, need, enough), expect >= enough)
          << "trial " << trial << " enough " << enough;
    total += expect;
  }
  EXPECT_GT(total, 1000);
}

// The map keeps, per column, the rows the earlier layers left under the layer that holds its
// top: what the droop model reads under this layer's beads.
TEST(HeightMap, KeepsTheRowsBeforeTheTopLayer) {
  HeightMap map(0.05, Vec3::Zero(), 16, 16, 2, 2);
  const std::size_t tile = map.index(0, 0);
  const std::uint64_t col0 = 1, col1 = 2;  // columns (0, 0), (1, 0)
  const std::int32_t support0 = HeightMap::layer_code(0, true);
  const std::int32_t part1 = HeightMap::layer_code(1, false);
  map.raise_tile(tile, col0 | col1, 4, support0);  // layer 0's support: 4 rows
  map.raise_tile(tile, col0, 8, part1);            // layer 1 covers (0, 0)
  map.raise_tile(tile, col0, 9, part1);            // and again, higher
  map.raise_tile(tile, col1, 3, part1);            // below (1, 0)'s top
  EXPECT_EQ(map.rows(0.01, 0.01), 9);
  EXPECT_EQ(map.rows_before_top_layer(0.01, 0.01), 4);  // layer 0's rows
  EXPECT_EQ(*map.top_layer_at(0.01, 0.01), 1);
  EXPECT_FALSE(map.top_is_support(0.01, 0.01));
  EXPECT_EQ(map.rows(0.06, 0.01), 4);  // not reached: layer 0's
  EXPECT_EQ(*map.top_layer_at(0.06, 0.01), 0);
  EXPECT_TRUE(map.top_is_support(0.06, 0.01));
  EXPECT_FALSE(map.top_is_support(0.11, 0.01));  // empty
  // Support and part of one layer are one layer: the rows before stay the earlier layers'.
  const std::uint64_t col2 = 4;  // column (2, 0)
  map.raise_tile(tile, col2, 4, HeightMap::layer_code(0, false));
  map.raise_tile(tile, col2, 6, HeightMap::layer_code(1, true));
  EXPECT_TRUE(map.top_is_support(0.11, 0.01));
  map.raise_tile(tile, col2, 8, part1);
  EXPECT_FALSE(map.top_is_support(0.11, 0.01));
  EXPECT_EQ(*map.top_layer_at(0.11, 0.01), 1);
  EXPECT_EQ(map.rows_before_top_layer(0.11, 0.01), 4);
  EXPECT_EQ(map.rows_before_top_layer(0.06, 0.01), 0);
  EXPECT_EQ(map.rows_before_top_layer(-1.0, 0.01), 0);  // outside the map
}

// One call with rows per column (the sweep's, per tile) leaves the map as the calls per voxel
// layer did (top layer first, each column raised by its highest voxel), on random layers of
// random columns over a map that already holds other layers; tops_equal finds the tops.
TEST(HeightMap, ColumnsOfATileInOneCallAsLayerByLayer) {
  std::mt19937_64 rng(5);
  HeightMap by_layer(0.05, Vec3::Zero(), 8, 8, 1, 1), at_once(0.05, Vec3::Zero(), 8, 8, 1, 1);
  const std::size_t tile = by_layer.index(0, 0);
  for (int trial = 0; trial < 400; ++trial) {
    const std::int32_t layer = HeightMap::layer_code(trial / 20, trial % 3 == 0);
    const int top = 4 + trial / 4 + static_cast<int>(rng() % 4);
    std::uint64_t raised = 0;
    std::array<std::uint16_t, 64> rows{};
    for (int k = top; k > top - 5 && k >= 0; --k) {
      const std::uint64_t mask = rng() & rng();
      if ((mask & ~raised) != 0) {
        by_layer.raise_tile(tile, mask & ~raised, static_cast<std::uint16_t>(k + 1), layer);
        HeightMap::set_columns(rows.data(), mask & ~raised, static_cast<std::uint16_t>(k + 1));
      }
      raised |= mask;
    }
    if (raised != 0) at_once.raise_tile_columns(tile, raised, rows.data(), layer);
    for (int s = 0; s < 64; ++s) {
      const double x = 0.05 * (s % 8) + 0.01, y = 0.05 * (s / 8) + 0.01;
      ASSERT_EQ(by_layer.rows(x, y), at_once.rows(x, y)) << trial << " " << s;
      ASSERT_EQ(by_layer.top_layer_at(x, y), at_once.top_layer_at(x, y)) << trial << " " << s;
      ASSERT_EQ(by_layer.top_is_support(x, y), at_once.top_is_support(x, y));
      ASSERT_EQ(by_layer.rows_before_top_layer(x, y), at_once.rows_before_top_layer(x, y));
    }
    const auto r = static_cast<std::uint16_t>(top);
    std::uint64_t eq = 0;
    for (int s = 0; s < 64; ++s)
      if (by_layer.rows(0.05 * (s % 8) + 0.01, 0.05 * (s / 8) + 0.01) == r)
        eq |= std::uint64_t{1} << s;
    ASSERT_EQ(at_once.tops_equal(tile, r), eq);
  }
}

}  // namespace
}  // namespace printtwin::detail
