// The deposit's outer surface (flood fill from outside over z-runs) and exact distances from
// points to it (a bucket grid of face squares).
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <atomic>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

#include "core/bits.hpp"
#include "deviation/deposit_surface_internal.hpp"
#include "deviation/point_groups.hpp"
#include "printtwin/default_init_allocator.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

bool is_auxiliary_feature(Feature f) {
  switch (f) {
    case Feature::skirt:
    case Feature::support:
    case Feature::support_interface:
    case Feature::wipe_tower:
    case Feature::custom: return true;
    default: return false;
  }
}

namespace {

/// A maximal z-interval [z0, z1] of empty voxels in one column.
struct Run {
  std::int32_t z0 = 0, z1 = 0;
};

/// First z >= from (below `nz`) whose bit equals `want`, or nz. Word at a time.
inline int next_bit(const std::uint64_t* col, int words, int nz, int from, bool want) {
  if (from >= nz) return nz;
  int w = from >> 6;
  std::uint64_t bits = (want ? col[w] : ~col[w]) & (~std::uint64_t{0} << (from & 63));
  while (bits == 0) {
    if (++w >= words) return nz;
    bits = want ? col[w] : ~col[w];
  }
  return std::min(nz, w * 64 + std::countr_zero(bits));
}

/// Sets bits z0..z1-1 of a bit column.
inline void set_bits(std::uint64_t* col, int z0, int z1) {
  while (z0 < z1) {
    const int w = z0 >> 6;
    const int lo = z0 & 63;
    const int hi = std::min(64, lo + (z1 - z0));
    const std::uint64_t mask = (hi == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << hi) - 1) & (~std::uint64_t{0} << lo);
    col[w] |= mask;
    z0 += hi - lo;
  }
}

/// Bit i set when voxel i of z-slice z of block b has an auxiliary tag (`auxiliary[t]` is 1
/// for an auxiliary tag index t; indices clamped to `last`; tags of empty voxels mean nothing).
std::uint64_t aux_mask(const VoxelGrid::BlockView& b, int z, const std::uint8_t* auxiliary, std::uint32_t last) {
  std::uint64_t m = 0;
  if (b.wide != nullptr) {
    for (int i = 0; i < 64; ++i)
      m |= static_cast<std::uint64_t>(auxiliary[std::min(b.wide[z * 64 + i], last)] & 1U) << i;
    return m;
  }
  unsigned on = 0;  // bit e: palette entry e is auxiliary
  for (int e = 0; e < b.palette_size; ++e) on |= (auxiliary[std::min(b.palette[e], last)] & 1U) << e;
  const std::uint8_t* nib = b.nibbles + z * 32;
  for (int i = 0; i < 64; i += 2) {
    const unsigned v = nib[i >> 1];
    m |= static_cast<std::uint64_t>((on >> (v & 0xFU)) & 1U) << i;
    m |= static_cast<std::uint64_t>((on >> (v >> 4)) & 1U) << (i + 1);
  }
  return m;
}

/// Transposes an 8x8 bit matrix held in a word (byte r = row r, bit c = column c).
inline std::uint64_t transpose8(std::uint64_t x) {
  // Hacker's Delight 7-3.
  std::uint64_t t = (x ^ (x >> 7)) & 0x00AA00AA00AA00AAULL;
  x = x ^ t ^ (t << 7);
  t = (x ^ (x >> 14)) & 0x0000CCCC0000CCCCULL;
  x = x ^ t ^ (t << 14);
  t = (x ^ (x >> 28)) & 0x00000000F0F0F0F0ULL;
  return x ^ t ^ (t << 28);
}

/// Bit columns of `in` (nx * ny columns of `words` words, z bits) dilated by r voxels (a
/// cube of 2r + 1) into `out`, which may be `in` itself. Rows in blocks of S, blocks in
/// parallel; within a block each row dilated along z (word shifts) and x (OR of neighbouring
/// columns) goes into a ring of 2r + 1 rows and row y is the OR of the ring's rows y - r ..
/// y + r, so an input row is dilated once per block (plus r halo rows on each side) and the
/// ring stays in cache. In place, the r rows on each side of a block that belong to its
/// neighbours are copied before any block writes, and within a block row y + r is read
/// before row y is written. The result does not depend on the blocking.
void dilate(const std::uint64_t* in, std::uint64_t* out, int nx, int ny, int words, int r) {
  const auto row_words = static_cast<std::size_t>(nx) * static_cast<std::size_t>(words);
  const int span = 2 * r + 1;
  // About four blocks per thread (each block redoes 2r rows of its neighbours).
  const int threads = std::max(1, tbb::this_task_arena::max_concurrency());
  const int rows_per_block = std::max({32, 4 * span, (ny + 4 * threads - 1) / (4 * threads)});
  const int blocks = (ny + rows_per_block - 1) / rows_per_block;
  const bool in_place = in == out;
  // In place: per block, its neighbours' rows [y0 - r, y0) then [y1, y1 + r) as they were.
  std::vector<std::uint64_t> halo;
  const auto halo_row = [&](int block, int k) {  // k in 0 .. 2r - 1
    return halo.data() + (static_cast<std::size_t>(block) * 2 * r + k) * row_words;
  };
  const auto block_rows = [&](int block, int& y0, int& y1) {
    y0 = block * rows_per_block;
    y1 = std::min(ny, y0 + rows_per_block);
  };
  if (in_place && r > 0) {
    halo.resize(static_cast<std::size_t>(blocks) * 2 * r * row_words);
    tbb::parallel_for(0, blocks, [&](int block) {
      int y0 = 0, y1 = 0;
      block_rows(block, y0, y1);
      for (int k = 0; k < r; ++k) {
        if (y0 - r + k >= 0) std::copy_n(in + static_cast<std::size_t>(y0 - r + k) * row_words, row_words, halo_row(block, k));
        if (y1 + k < ny) std::copy_n(in + static_cast<std::size_t>(y1 + k) * row_words, row_words, halo_row(block, r + k));
      }
    });
  }
  tbb::parallel_for(0, blocks, [&](int block) {
    int y0 = 0, y1 = 0;
    block_rows(block, y0, y1);
    // Row y of the input as it was before any block wrote.
    const auto input_row = [&](int y) -> const std::uint64_t* {
      if (in_place && y < y0) return halo_row(block, y - (y0 - r));
      if (in_place && y >= y1) return halo_row(block, r + (y - y1));
      return in + static_cast<std::size_t>(y) * row_words;
    };
    std::vector<std::uint64_t> ring(row_words * static_cast<std::size_t>(span));
    std::vector<std::uint64_t> zrow(row_words);
    const auto slot = [&](int y) { return ring.data() + static_cast<std::size_t>(y % span) * row_words; };
    // Row y of `in` dilated along z then x, into `dst`.
    const auto zx_row = [&](int y, std::uint64_t* dst_row) {
      const std::uint64_t* row = input_row(y);
      for (int x = 0; x < nx; ++x) {
        const std::uint64_t* src = row + static_cast<std::size_t>(x) * words;
        std::uint64_t* dst = zrow.data() + static_cast<std::size_t>(x) * words;
        for (int w = 0; w < words; ++w) {
          std::uint64_t v = src[w];
          for (int k = 1; k <= r; ++k) {
            // Up by k (bit z -> z + k) and down by k, with the bits crossing word borders.
            v |= src[w] << k;
            if (w > 0) v |= src[w - 1] >> (64 - k);
            v |= src[w] >> k;
            if (w + 1 < words) v |= src[w + 1] << (64 - k);
          }
          dst[w] = v;
        }
      }
      for (int x = 0; x < nx; ++x) {
        std::uint64_t* d = dst_row + static_cast<std::size_t>(x) * words;
        std::copy_n(zrow.data() + static_cast<std::size_t>(x) * words, words, d);
        for (int t = std::max(0, x - r); t <= std::min(nx - 1, x + r); ++t) {
          if (t == x) continue;
          const std::uint64_t* q = zrow.data() + static_cast<std::size_t>(t) * words;
          for (int w = 0; w < words; ++w) d[w] |= q[w];
        }
      }
    };
    int next = std::max(0, y0 - r);  // the next row to go into the ring
    for (int y = y0; y < y1; ++y) {
      for (; next < ny && next <= y + r; ++next) zx_row(next, slot(next));
      std::uint64_t* dst = out + static_cast<std::size_t>(y) * row_words;
      const int t0 = std::max(0, y - r), t1 = std::min(ny - 1, y + r);
      std::copy_n(slot(t0), row_words, dst);
      for (int t = t0 + 1; t <= t1; ++t) {
        const std::uint64_t* q = slot(t);
        for (std::size_t i = 0; i < row_words; ++i) dst[i] |= q[i];
      }
    }
  });
}

/// Runs fn(y0, y1) over chunks of the rows 0..ny-1 in parallel.
template <class Fn>
void for_rows(int ny, const Fn& fn) {
  tbb::parallel_for(tbb::blocked_range<int>(0, ny, 16),
                    [&](const tbb::blocked_range<int>& rows) { fn(rows.begin(), rows.end()); });
}

/// `bits` sized to n words, zero, its pages first touched in parallel.
void parallel_zeroed(UninitWords& bits, std::size_t n, std::size_t row_words, int ny) {
  bits.resize(n);
  for_rows(ny, [&](int y0, int y1) {
    std::fill(bits.data() + static_cast<std::size_t>(y0) * row_words,
              bits.data() + static_cast<std::size_t>(y1) * row_words, std::uint64_t{0});
  });
}

}  // namespace

namespace {
/// The word of s.filled_bits holding p's voxel and the voxel's bit in it; nullptr when p is
/// outside the region.
const std::uint64_t* filled_word(const DepositSurface& s, const Vec3& p_mm, int& bit) {
  if (s.voxel_mm <= 0) return nullptr;
  const Vec3 q = (p_mm - s.origin_mm) / s.voxel_mm;
  const auto x = static_cast<long>(std::floor(q.x()));
  const auto y = static_cast<long>(std::floor(q.y()));
  const auto z = static_cast<long>(std::floor(q.z()));
  if (x < 0 || y < 0 || z < 0 || x >= s.dims.x() || y >= s.dims.y() || z >= s.dims.z()) return nullptr;
  const long words = (s.dims.z() + 63) / 64;
  bit = static_cast<int>(z & 63);
  return s.filled_bits.data() + (y * s.dims.x() + x) * words + (z >> 6);
}
}  // namespace

bool DepositSurface::filled(const Vec3& p_mm) const {
  int bit = 0;
  const std::uint64_t* w = filled_word(*this, p_mm, bit);
  return w != nullptr && ((*w >> bit) & 1U) != 0;
}

DepositSurface extract_outer_surface(const VoxelGrid& grid, const Box3& region_mm, double seal_gap_mm) {
  DepositSurface s;
  s.voxel_mm = grid.voxel_mm();
  if (region_mm.empty()) return s;
  // Region in grid keys, padded by one voxel: the padding is forced empty, so the outside
  // is connected all around the part.
  const VoxelKey kmin0 = grid.key_of(region_mm.min);
  const VoxelKey kmax0 = grid.key_of(region_mm.max);
  const VoxelKey kmin{kmin0.x - 1, kmin0.y - 1, kmin0.z - 1};
  const int nx = kmax0.x - kmin0.x + 3, ny = kmax0.y - kmin0.y + 3, nz = kmax0.z - kmin0.z + 3;
  s.dims = Eigen::Vector3i(nx, ny, nz);
  s.origin_mm = grid.origin_mm() + s.voxel_mm * Vec3(kmin.x, kmin.y, kmin.z);
  s.origin_key = kmin;
  const int words = (nz + 63) / 64;
  const std::size_t columns = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
  const std::size_t row_words = static_cast<std::size_t>(nx) * static_cast<std::size_t>(words);
  const std::size_t region_words = columns * static_cast<std::size_t>(words);
  // Every pass below works on whole rows (fixed y) of the region's bit columns, rows in
  // parallel chunks; the region-sized arrays are first touched by those passes.

  // 1. Occupancy of part voxels, one bit column per (x, y); the padding stays empty. Read
  // block by block (only allocated blocks cost anything).
  UninitWords occ;
  parallel_zeroed(occ, region_words, row_words, ny);
  const auto& table = grid.tag_table();
  std::vector<std::uint8_t> auxiliary(table.size());
  for (std::size_t i = 0; i < table.size(); ++i) auxiliary[i] = is_auxiliary_feature(table[i].feature) ? 1 : 0;
  bool any_auxiliary = false;
  for (const std::uint8_t a : auxiliary) any_auxiliary = any_auxiliary || a != 0;
  const auto last_tag = static_cast<std::uint32_t>(auxiliary.empty() ? 0 : auxiliary.size() - 1);
  // A block none of whose palette entries is auxiliary needs no per-voxel test, and its
  // palette indices are not read at all.
  const auto block_may_have_aux = [&](const VoxelGrid::BlockView& b) {
    if (b.wide != nullptr) return true;
    for (int e = 0; e < b.palette_size; ++e)
      if (auxiliary[std::min(b.palette[e], last_tag)] != 0) return true;
    return false;
  };
  // The region's blocks, column by column (the z-blocks of a column in a row), so the 64
  // bit columns a block writes stay in cache.
  constexpr int kE = VoxelGrid::kBlockEdge;
  std::vector<VoxelGrid::BlockView> in_region;
  std::vector<std::size_t> block_row_begin;  // into in_region, per row of blocks (by)
  {
    // Blocks meeting the region's interior (keys kmin + 1 .. kmin + n - 2 per axis); keys
    // may be negative, so >> 3 (floor) gives the block. Counted, then listed, rows in
    // parallel.
    static_assert(kE == 8);
    const Eigen::Vector3i lo((kmin.x + 1) >> 3, (kmin.y + 1) >> 3, (kmin.z + 1) >> 3);
    const Eigen::Vector3i hi((kmin.x + nx - 2) >> 3, (kmin.y + ny - 2) >> 3, (kmin.z + nz - 2) >> 3);
    const Eigen::Vector3i dims = grid.block_dims();
    const int by0 = std::max(0, lo.y()), by1 = std::min(dims.y() - 1, hi.y());
    const int bx0 = std::max(0, lo.x()), bx1 = std::min(dims.x() - 1, hi.x());
    const int bz0 = std::max(0, lo.z()), bz1 = std::min(dims.z() - 1, hi.z());
    const std::size_t rows = by1 >= by0 ? static_cast<std::size_t>(by1 - by0 + 1) : 0;
    block_row_begin.assign(rows + 1, 0);
    const auto for_row_blocks = [&](std::size_t r, const auto& fn) {
      const int by = by0 + static_cast<int>(r);
      for (int bx = bx0; bx <= bx1; ++bx)
        for (int bz = bz0; bz <= bz1; ++bz) fn(bx, by, bz);
    };
    tbb::parallel_for(std::size_t{0}, rows, [&](std::size_t r) {
      std::size_t n = 0;
      for_row_blocks(r, [&](int bx, int by, int bz) { n += grid.block_occupancy(bx, by, bz) != nullptr ? 1 : 0; });
      block_row_begin[r + 1] = n;
    });
    for (std::size_t r = 0; r < rows; ++r) block_row_begin[r + 1] += block_row_begin[r];
    in_region.resize(block_row_begin[rows]);
    tbb::parallel_for(std::size_t{0}, rows, [&](std::size_t r) {
      std::size_t at = block_row_begin[r];
      for_row_blocks(r, [&](int bx, int by, int bz) {
        if (const auto b = grid.block_view(bx, by, bz)) in_region[at++] = *b;
      });
    });
  }
  // A row of blocks writes 8 rows of bit columns that no other row of blocks writes.
  const std::size_t block_rows = block_row_begin.size() - 1;
  std::vector<std::size_t> occupied_per_row(block_rows, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, block_rows), [&](const tbb::blocked_range<std::size_t>& rr) {
    for (std::size_t row = rr.begin(); row != rr.end(); ++row) {
      std::size_t occupied = 0;
      for (std::size_t i = block_row_begin[row]; i < block_row_begin[row + 1]; ++i) {
        const VoxelGrid::BlockView& b = in_region[i];
        const int bx = b.base.x - kmin.x, by = b.base.y - kmin.y, bz = b.base.z - kmin.z;
        // The block's 8 z-slices of 64 (x, y) bits, without auxiliary voxels and z outside
        // the region, then transposed to one byte of 8 z bits per (x, y) column.
        std::array<std::uint64_t, kE> slice{};
        const bool test_aux = any_auxiliary && block_may_have_aux(b);
        for (int z = 0; z < kE; ++z) {
          const int gz = bz + z;
          if (gz < 1 || gz >= nz - 1) continue;
          std::uint64_t bits = b.occupancy[z];
          if (test_aux && bits != 0) bits &= ~aux_mask(b, z, auxiliary.data(), last_tag);
          slice[static_cast<std::size_t>(z)] = bits;
        }
        for (int y = 0; y < kE; ++y) {
          const int gy = by + y;
          if (gy < 1 || gy >= ny - 1) continue;
          // Row y of every slice: byte z = 8 x bits; transposed: byte x = 8 z bits.
          std::uint64_t m = 0;
          for (int z = 0; z < kE; ++z) m |= ((slice[static_cast<std::size_t>(z)] >> (8 * y)) & 0xFFU) << (8 * z);
          if (m == 0) continue;
          m = transpose8(m);
          for (int x = 0; x < kE; ++x) {
            const std::uint64_t zbits = (m >> (8 * x)) & 0xFFU;
            const int gx = bx + x;
            if (zbits == 0 || gx < 1 || gx >= nx - 1) continue;
            std::uint64_t* col = occ.data() + (static_cast<std::size_t>(gy) * nx + gx) * words;
            occupied += static_cast<std::size_t>(popcount64(zbits));
            // z bits bz..bz+7 (bz may be negative: the clipped low bits are zero).
            if (bz >= 0) {
              col[bz >> 6] |= zbits << (bz & 63);
              if ((bz & 63) > 56 && (bz >> 6) + 1 < words) col[(bz >> 6) + 1] |= zbits >> (64 - (bz & 63));
            } else {
              col[0] |= zbits >> (-bz);
            }
          }
        }
      }
      occupied_per_row[row] = occupied;
    }
  });
  for (const std::size_t n : occupied_per_row) s.occupied_voxels += n;

  // Gaps narrower than seal_gap_mm must not let the outside in (pinholes between beads are
  // voxelisation artefacts): the flood runs on the occupancy dilated by r voxels, and the
  // outside it reaches is dilated back by r (a morphological opening of the empty space).
  const int seal_r = seal_gap_mm > 0 ? static_cast<int>(std::floor(seal_gap_mm / (2 * s.voxel_mm) + 1e-9)) : 0;
  UninitWords blocked_storage;
  if (seal_r > 0) {
    blocked_storage.resize(region_words);
    dilate(occ.data(), blocked_storage.data(), nx, ny, words, seal_r);
    // The padding stays empty so that the outside surrounds everything.
    for_rows(ny, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y)
        for (int x = 0; x < nx; ++x) {
          std::uint64_t* col = blocked_storage.data() + (static_cast<std::size_t>(y) * nx + x) * words;
          if (x == 0 || y == 0 || x == nx - 1 || y == ny - 1) {
            std::fill(col, col + words, 0);
            continue;
          }
          col[0] &= ~std::uint64_t{1};
          col[(nz - 1) >> 6] &= ~(std::uint64_t{1} << ((nz - 1) & 63));
          if (nz % 64 != 0) col[words - 1] &= (std::uint64_t{1} << (nz % 64)) - 1;
        }
    });
  }
  const UninitWords& blocked = seal_r > 0 ? blocked_storage : occ;

  // 2. Empty runs per column (CSR: counted per column in parallel, then written in place),
  // then a breadth-first flood over runs. Two runs of face-adjacent columns touch when their
  // z-intervals overlap.
  const auto for_each_run = [&](std::size_t c, const auto& fn) {
    const std::uint64_t* col = blocked.data() + c * static_cast<std::size_t>(words);
    int z = next_bit(col, words, nz, 0, false);
    while (z < nz) {
      const int z1 = next_bit(col, words, nz, z, true);
      fn(z, z1 - 1);
      z = next_bit(col, words, nz, z1, false);
    }
  };
  std::vector<std::uint32_t> run_begin(columns + 1, 0);
  for_rows(ny, [&](int y0, int y1) {
    for (std::size_t c = static_cast<std::size_t>(y0) * nx; c < static_cast<std::size_t>(y1) * nx; ++c) {
      std::uint32_t n = 0;
      for_each_run(c, [&](int, int) { ++n; });
      run_begin[c + 1] = n;
    }
  });
  for (std::size_t c = 0; c < columns; ++c) run_begin[c + 1] += run_begin[c];
  std::vector<Run> runs(run_begin[columns]);
  std::vector<std::uint32_t> run_column(runs.size());
  for_rows(ny, [&](int y0, int y1) {
    for (std::size_t c = static_cast<std::size_t>(y0) * nx; c < static_cast<std::size_t>(y1) * nx; ++c) {
      std::uint32_t r = run_begin[c];
      for_each_run(c, [&](int z0, int z1) {
        runs[r] = {z0, z1};
        run_column[r++] = static_cast<std::uint32_t>(c);
      });
    }
  });
  std::vector<std::uint8_t> outside(runs.size(), 0);
  // Seeds: every run touching the padding (z = 0 or z = nz - 1, or a border column).
  std::vector<std::uint32_t> frontier;
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) {
      const std::size_t c = static_cast<std::size_t>(y) * nx + x;
      const bool border = x == 0 || y == 0 || x == nx - 1 || y == ny - 1;
      for (std::uint32_t r = run_begin[c]; r < run_begin[c + 1]; ++r)
        if (border || runs[r].z0 == 0 || runs[r].z1 == nz - 1) {
          outside[r] = 1;
          frontier.push_back(r);
        }
    }
  // Breadth first, a level at a time, the levels' runs in parallel: a run joins the next
  // level when this thread is the one that marks it. The set of outside runs does not
  // depend on the order they are reached in.
  const auto expand = [&](std::uint32_t r, const auto& reached) {
    const std::size_t c = run_column[r];
    const int x = static_cast<int>(c % static_cast<std::size_t>(nx));
    const int y = static_cast<int>(c / static_cast<std::size_t>(nx));
    const std::array<std::array<int, 2>, 4> nbs{{{x - 1, y}, {x + 1, y}, {x, y - 1}, {x, y + 1}}};
    for (const auto& nb : nbs) {
      if (nb[0] < 0 || nb[1] < 0 || nb[0] >= nx || nb[1] >= ny) continue;
      const std::size_t nc = static_cast<std::size_t>(nb[1]) * nx + nb[0];
      // Runs are sorted by z: skip those ending below r, stop at the first starting above.
      auto first = std::lower_bound(runs.begin() + run_begin[nc], runs.begin() + run_begin[nc + 1],
                                    runs[r].z0, [](const Run& a, int z) { return a.z1 < z; });
      for (auto it = first; it != runs.begin() + run_begin[nc + 1] && it->z0 <= runs[r].z1; ++it)
        reached(static_cast<std::uint32_t>(it - runs.begin()));
    }
  };
  std::vector<std::uint32_t> level;
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> found;
  while (!frontier.empty()) {
    level.clear();
    constexpr std::size_t kParallelLevel = 4096;  // smaller levels: one thread, no atomics
    if (frontier.size() < kParallelLevel) {
      for (const std::uint32_t r : frontier)
        expand(r, [&](std::uint32_t nr) {
          if (outside[nr] == 0) {
            outside[nr] = 1;
            level.push_back(nr);
          }
        });
    } else {
      for (auto& f : found) f.clear();
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, frontier.size(), 1024),
                        [&](const tbb::blocked_range<std::size_t>& rr) {
                          auto& mine = found.local();
                          for (std::size_t i = rr.begin(); i != rr.end(); ++i)
                            expand(frontier[i], [&](std::uint32_t nr) {
                              std::atomic_ref<std::uint8_t> flag(outside[nr]);
                              if (flag.load(std::memory_order_relaxed) == 0 &&
                                  flag.exchange(1, std::memory_order_relaxed) == 0)
                                mine.push_back(nr);
                            });
                        });
      for (const auto& f : found) level.insert(level.end(), f.begin(), f.end());
    }
    frontier.swap(level);
  }

  // 3. Filled bits = not outside (occupied voxels, enclosed voids, sealed gaps). The outside
  // bits take the storage of `blocked`, which the flood no longer needs.
  UninitWords out_bits = std::move(blocked_storage);
  out_bits.resize(region_words);
  for_rows(ny, [&](int y0, int y1) {
    for (std::size_t c = static_cast<std::size_t>(y0) * nx; c < static_cast<std::size_t>(y1) * nx; ++c) {
      std::uint64_t* o = out_bits.data() + c * static_cast<std::size_t>(words);
      std::fill(o, o + words, std::uint64_t{0});
      for (std::uint32_t r = run_begin[c]; r < run_begin[c + 1]; ++r)
        if (outside[r]) set_bits(o, runs[r].z0, runs[r].z1 + 1);
    }
  });
  // The outside dilated back (when sealing), then filled = not (outside and not occupied).
  if (seal_r > 0) dilate(out_bits.data(), out_bits.data(), nx, ny, words, seal_r);
  s.filled_bits = std::move(out_bits);
  std::vector<std::size_t> filled_per_row(static_cast<std::size_t>(ny), 0);
  for_rows(ny, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      std::size_t filled = 0;
      for (std::size_t c = static_cast<std::size_t>(y) * nx; c < static_cast<std::size_t>(y + 1) * nx; ++c) {
        std::uint64_t* f = s.filled_bits.data() + c * static_cast<std::size_t>(words);
        const std::uint64_t* oc = occ.data() + c * static_cast<std::size_t>(words);
        if (seal_r > 0) {
          for (int w = 0; w < words; ++w) f[w] = ~(f[w] & ~oc[w]);
        } else {
          for (int w = 0; w < words; ++w) f[w] = ~f[w];
        }
        if (nz % 64 != 0) f[words - 1] &= (std::uint64_t{1} << (nz % 64)) - 1;
        for (int w = 0; w < words; ++w) filled += static_cast<std::size_t>(popcount64(f[w]));
      }
      filled_per_row[static_cast<std::size_t>(y)] = filled;
    }
  });
  for (const std::size_t n : filled_per_row) s.filled_voxels += n;

  // 4. Faces between a filled voxel and an outside voxel (= not filled), column by column:
  // counted per row, then each row's faces written at its offset.
  // Column (x, y): its filled and occupied words and its four neighbours' filled words
  // (-x, +x, -y, +y), found once per column. `exposed` gives the faces of one 64-voxel
  // word of it, one mask per direction: -x, +x, -y, +y, -z, +z. Faces belong to occupied
  // voxels only (a sealed gap shows as a hole in the surface points, never as a leak).
  struct Column {
    const std::uint64_t* f;
    const std::uint64_t* oc;
    std::array<const std::uint64_t*, 4> n;
  };
  const auto column = [&](int x, int y) {
    const std::size_t c = (static_cast<std::size_t>(y) * nx + x) * static_cast<std::size_t>(words);
    const std::uint64_t* f = s.filled_bits.data() + c;
    return Column{f, occ.data() + c, {f - words, f + words, f - row_words, f + row_words}};
  };
  const auto exposed = [&](const Column& col, int w, std::array<std::uint64_t, 6>& m) {
    const std::uint64_t* f = col.f;
    const std::uint64_t fo = f[w] & col.oc[w];
    if (fo == 0) return false;
    const std::uint64_t up = (w + 1 < words) ? (f[w + 1] & 1U) : 0;
    const std::uint64_t down = (w > 0) ? (f[w - 1] >> 63) : 0;
    const std::uint64_t above = (f[w] >> 1) | (up << 63);
    const std::uint64_t below = (f[w] << 1) | down;
    m = {fo & ~col.n[0][w], fo & ~col.n[1][w], fo & ~col.n[2][w], fo & ~col.n[3][w], fo & ~below, fo & ~above};
    return true;
  };
  std::vector<std::size_t> row_faces(static_cast<std::size_t>(ny) + 1, 0);
  for_rows(ny, [&](int y0, int y1) {
    std::array<std::uint64_t, 6> m{};
    for (int y = std::max(y0, 1); y < std::min(y1, ny - 1); ++y) {
      std::size_t n = 0;
      for (int x = 1; x < nx - 1; ++x) {
        const Column col = column(x, y);
        for (int w = 0; w < words; ++w)
          if (exposed(col, w, m))
            for (const std::uint64_t bits : m) n += static_cast<std::size_t>(popcount64(bits));
      }
      row_faces[static_cast<std::size_t>(y) + 1] = n;
    }
  });
  for (int y = 0; y < ny; ++y) row_faces[static_cast<std::size_t>(y) + 1] += row_faces[static_cast<std::size_t>(y)];
  // The face arrays sized side by side (resize writes each element's initial value).
  const std::size_t n_faces = row_faces[static_cast<std::size_t>(ny)];
  tbb::parallel_invoke([&] { s.faces.resize(n_faces); }, [&] { s.face_tags.resize(n_faces); },
                       [&] { s.face_centers_mm.resize(n_faces); });
  const double v = s.voxel_mm;
  // Each face carries its voxel's tag (a voxel's faces share one lookup): a dense directory
  // of the region's blocks, so a tag is two array reads instead of a grid lookup.
  const int dbx = (nx + 2 * kE) / kE + 2, dby = (ny + 2 * kE) / kE + 2, dbz = (nz + 2 * kE) / kE + 2;
  const auto dir_index = [&](const VoxelKey& base) {
    return (static_cast<std::size_t>((base.z - kmin.z + kE) / kE) * static_cast<std::size_t>(dby) +
            static_cast<std::size_t>((base.y - kmin.y + kE) / kE)) * static_cast<std::size_t>(dbx) +
           static_cast<std::size_t>((base.x - kmin.x + kE) / kE);
  };
  std::vector<const VoxelGrid::BlockView*> directory(static_cast<std::size_t>(dbx) * dby * dbz, nullptr);
  for (const auto& b : in_region) directory[dir_index(b.base)] = &b;
  const auto tag_of = [&](const VoxelKey& k) {
    const VoxelKey base{k.x - (k.x & (kE - 1)), k.y - (k.y & (kE - 1)), k.z - (k.z & (kE - 1))};
    const VoxelGrid::BlockView* b = directory[dir_index(base)];
    if (b == nullptr || !(b->base == base)) return grid.tag(k).value_or(VoxelTag{});  // not expected
    return table[b->tag_index((k.z - base.z) * 64 + (k.y - base.y) * 8 + (k.x - base.x))];
  };
  for_rows(ny, [&](int y0, int y1) {
    std::array<std::uint64_t, 6> m{};
    for (int y = std::max(y0, 1); y < std::min(y1, ny - 1); ++y) {
      std::size_t next = row_faces[static_cast<std::size_t>(y)];
      const auto add_face = [&](int x, int z, int axis, int side, const VoxelTag& tag) {
        SurfaceFace& f = s.faces[next];
        f.voxel = VoxelKey{kmin.x + x, kmin.y + y, kmin.z + z};
        f.axis = static_cast<std::uint8_t>(axis);
        f.side = static_cast<std::int8_t>(side);
        Vec3 c = s.origin_mm + v * Vec3(x + 0.5, y + 0.5, z + 0.5);
        c[axis] += 0.5 * v * side;
        s.face_centers_mm[next] = c;
        s.face_tags[next++] = tag;
      };
      for (int x = 1; x < nx - 1; ++x) {
        const Column col = column(x, y);
        for (int w = 0; w < words; ++w) {
          if (!exposed(col, w, m)) continue;
          std::uint64_t any = m[0] | m[1] | m[2] | m[3] | m[4] | m[5];
          while (any != 0) {
            const int b = std::countr_zero(any);
            any &= any - 1;
            const std::uint64_t bit = std::uint64_t{1} << b;
            const int z = w * 64 + b;
            const VoxelTag tag = tag_of(VoxelKey{kmin.x + x, kmin.y + y, kmin.z + z});
            for (int k = 0; k < 6; ++k)
              if (m[static_cast<std::size_t>(k)] & bit) add_face(x, z, k >> 1, (k & 1) != 0 ? +1 : -1, tag);
          }
        }
      }
    }
  });
  return s;
}

// ---------------------------------------------------------------- distances to the faces

namespace {

/// Faces bucketed by the cell of their centre (cells of kCell voxels), CSR layout, stored
/// as columns (centre x, y, z, normal axis, face index) so the search tests 4 at a time.
struct FaceBuckets {
  static constexpr int kCell = 4;
  static constexpr std::size_t kPad = 4;  ///< entries past the end, so 4-wide loads stay inside
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();
  std::vector<std::uint32_t> begin;  ///< per cell, into the columns
  /// Faces sorted by cell (by index within a cell); every entry is written once, so the
  /// columns are not zeroed first.
  std::unique_ptr<double[]> cx, cy, cz;
  std::unique_ptr<std::uint8_t[]> axis;
  std::unique_ptr<std::uint32_t[]> face;
  double cell_mm = 0;
  Vec3 origin_mm = Vec3::Zero();

  explicit FaceBuckets(const DepositSurface& s) {
    cell_mm = s.voxel_mm * kCell;
    origin_mm = s.origin_mm;
    cells = (s.dims.array() + kCell - 1) / kCell;
    const std::size_t n = static_cast<std::size_t>(cells.x()) * cells.y() * cells.z();
    // A face goes to the cell of its voxel (its square lies in the voxel's box, so in the
    // cell's): integer arithmetic, and a column's faces fill neighbouring cells.
    const auto cell_of = [&](std::size_t i) {
      const VoxelKey& k = s.faces[i].voxel;
      return static_cast<std::uint32_t>(cell_index(Eigen::Vector3i((k.x - s.origin_key.x) / kCell,
                                                                   (k.y - s.origin_key.y) / kCell,
                                                                   (k.z - s.origin_key.z) / kCell)));
    };
    begin.assign(n + 1, 0);
    for (std::size_t i = 0; i < s.faces.size(); ++i) ++begin[cell_of(i) + 1];
    for (std::size_t c = 0; c < n; ++c) begin[c + 1] += begin[c];
    const std::size_t m = s.faces.size() + kPad;
    cx = std::make_unique_for_overwrite<double[]>(m);
    cy = std::make_unique_for_overwrite<double[]>(m);
    cz = std::make_unique_for_overwrite<double[]>(m);
    axis = std::make_unique_for_overwrite<std::uint8_t[]>(m);
    face = std::make_unique_for_overwrite<std::uint32_t[]>(m);
    for (std::size_t k = s.faces.size(); k < m; ++k) {
      cx[k] = cy[k] = cz[k] = 0;
      axis[k] = 0;
      face[k] = 0;
    }
    // begin[c] serves as cell c's write cursor, which leaves it at the start of cell c + 1:
    // shifted back by one cell afterwards.
    for (std::size_t i = 0; i < s.faces.size(); ++i) {
      const std::uint32_t k = begin[cell_of(i)]++;
      cx[k] = s.face_centers_mm[i].x();
      cy[k] = s.face_centers_mm[i].y();
      cz[k] = s.face_centers_mm[i].z();
      axis[k] = s.faces[i].axis;
      face[k] = static_cast<std::uint32_t>(i);
    }
    std::copy_backward(begin.begin(), begin.end() - 1, begin.end());
    begin[0] = 0;
  }
  [[nodiscard]] Eigen::Vector3i cell_coord(const Vec3& p) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp(static_cast<int>(std::floor((p[a] - origin_mm[a]) / cell_mm)), 0, cells[a] - 1);
    return c;
  }
  /// Cells column by column (z fastest): a column's faces go to consecutive cells.
  [[nodiscard]] std::size_t cell_index(const Eigen::Vector3i& c) const {
    return (static_cast<std::size_t>(c.y()) * cells.x() + c.x()) * cells.z() + c.z();
  }
};

/// The nearest so far: squared distance and face index (ties: the lowest index).
struct Nearest {
  double d2 = std::numeric_limits<double>::infinity();
  std::uint32_t face = 0;
  void offer(double x2, std::uint32_t f) {
    if (x2 < d2 || (x2 == d2 && f < face)) {
      d2 = x2;
      face = f;
    }
  }
};

/// Squared distance from p to the face square k (axis-aligned, edge 2 * half): per axis
/// max(0, |p - c| - h), h = half in the face's plane and 0 along its normal.
inline double face_dist2(const FaceBuckets& b, std::size_t k, const Vec3& p, double half) {
  const int ax = b.axis[k];
  const double ex = std::max(0.0, std::abs(p.x() - b.cx[k]) - (ax == 0 ? 0.0 : half));
  const double ey = std::max(0.0, std::abs(p.y() - b.cy[k]) - (ax == 1 ? 0.0 : half));
  const double ez = std::max(0.0, std::abs(p.z() - b.cz[k]) - (ax == 2 ? 0.0 : half));
  return ex * ex + ey * ey + ez * ez;
}

void scan_faces_default(const FaceBuckets& b, std::uint32_t lo, std::uint32_t hi, const Vec3& p,
                        double half, Nearest& best) {
  for (std::uint32_t k = lo; k < hi; ++k) best.offer(face_dist2(b, k, p, half), b.face[k]);
}

#if defined(__x86_64__) && defined(__GNUC__)
/// The same, 4 faces at a time (same operations in the same order: the same bits). Lanes
/// whose distance is not above the best go through the scalar rule, in index order.
[[gnu::target("avx2")]] void scan_faces_avx2(const FaceBuckets& b, std::uint32_t lo, std::uint32_t hi,
                                             const Vec3& p, double half, Nearest& best) {
  const __m256d px = _mm256_set1_pd(p.x()), py = _mm256_set1_pd(p.y()), pz = _mm256_set1_pd(p.z());
  const __m256d hv = _mm256_set1_pd(half), zero = _mm256_setzero_pd();
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256i ax0 = _mm256_setzero_si256(), ax1 = _mm256_set1_epi64x(1), ax2 = _mm256_set1_epi64x(2);
  for (std::uint32_t k = lo; k < hi; k += 4) {
    std::uint32_t a4 = 0;
    std::memcpy(&a4, b.axis.get() + k, 4);
    const __m256i a = _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(static_cast<int>(a4)));
    // Per axis: max(0, |p - c| - h), h = 0 along the face's normal, else half.
    const __m256d hx = _mm256_andnot_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a, ax0)), hv);
    const __m256d hy = _mm256_andnot_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a, ax1)), hv);
    const __m256d hz = _mm256_andnot_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a, ax2)), hv);
    const __m256d dx = _mm256_andnot_pd(sign, _mm256_sub_pd(px, _mm256_loadu_pd(b.cx.get() + k)));
    const __m256d dy = _mm256_andnot_pd(sign, _mm256_sub_pd(py, _mm256_loadu_pd(b.cy.get() + k)));
    const __m256d dz = _mm256_andnot_pd(sign, _mm256_sub_pd(pz, _mm256_loadu_pd(b.cz.get() + k)));
    const __m256d ex = _mm256_max_pd(zero, _mm256_sub_pd(dx, hx));
    const __m256d ey = _mm256_max_pd(zero, _mm256_sub_pd(dy, hy));
    const __m256d ez = _mm256_max_pd(zero, _mm256_sub_pd(dz, hz));
    const __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ex, ex), _mm256_mul_pd(ey, ey)), _mm256_mul_pd(ez, ez));
    unsigned m = static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(d2, _mm256_set1_pd(best.d2), _CMP_LE_OQ)));
    if (hi - k < 4) m &= (1U << (hi - k)) - 1;
    if (m == 0) continue;
    alignas(32) double lane[4];
    _mm256_store_pd(lane, d2);
    for (; m != 0; m &= m - 1) {
      const int j = std::countr_zero(m);
      best.offer(lane[j], b.face[k + static_cast<std::uint32_t>(j)]);
    }
  }
}
#else
void scan_faces_avx2(const FaceBuckets& b, std::uint32_t lo, std::uint32_t hi, const Vec3& p, double half,
                     Nearest& best) {
  scan_faces_default(b, lo, hi, p, half, best);
}
#endif

}  // namespace

namespace detail {

bool deposit_distance_uses_avx2() { return cpu_has_avx2(); }

void distances_to_deposit_with(const DepositSurface& s, std::span<const Vec3> points,
                               std::vector<double>& signed_mm, std::vector<std::uint32_t>* nearest_face,
                               bool portable) {
  signed_mm.assign(points.size(), 0.0);
  if (nearest_face != nullptr) nearest_face->assign(points.size(), 0);
  if (s.faces.empty()) {
    // No deposit at all: everything designed is missing; distance to the region's far side.
    const double far = (s.dims.cast<double>() * s.voxel_mm).norm();
    std::fill(signed_mm.begin(), signed_mm.end(), -far);
    return;
  }
  const FaceBuckets buckets(s);
  const double half = 0.5 * s.voxel_mm;
  const bool avx2 = !portable && cpu_has_avx2();
  // A coarse level (groups of kGroup^3 cells) flags where faces are, so that points far from
  // the deposit (a missing wall) skip empty space quickly; the search stays exact.
  constexpr int kGroup = 8;
  const Eigen::Vector3i groups = (buckets.cells.array() + kGroup - 1) / kGroup;
  std::vector<std::uint8_t> group_has(static_cast<std::size_t>(groups.x()) * groups.y() * groups.z(), 0);
  const auto group_index = [&](const Eigen::Vector3i& g) {
    return (static_cast<std::size_t>(g.z()) * groups.y() + g.y()) * groups.x() + g.x();
  };
  for (int y = 0; y < buckets.cells.y(); ++y)  // in the cells' memory order (z fastest)
    for (int x = 0; x < buckets.cells.x(); ++x)
      for (int z = 0; z < buckets.cells.z(); ++z) {
        const std::size_t ci = buckets.cell_index(Eigen::Vector3i(x, y, z));
        if (buckets.begin[ci] != buckets.begin[ci + 1])
          group_has[group_index(Eigen::Vector3i(x / kGroup, y / kGroup, z / kGroup))] = 1;
      }
  const double group_mm = buckets.cell_mm * kGroup;
  const int max_group_ring = groups.maxCoeff();
  constexpr int kFineRings = 2;
  // Queries in cells of the buckets' size, column by column: neighbouring queries read the
  // same cells and filled bits (the input, say mesh samples in triangle order, may jump).
  std::vector<std::uint32_t> order, group;
  group_by_cell(points, buckets.cell_mm, order, group);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 2048),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    // The previous point of this chunk and its distance: by the triangle inequality the
    // nearest face of p is at most prev_d + |p - prev_p| away, which bounds the search.
    Vec3 prev_p = Vec3::Zero();
    double prev_d = std::numeric_limits<double>::infinity();
    for (std::size_t j = range.begin(); j != range.end(); ++j) {
      // Points (say mesh samples in triangle order) and their result slots are scattered:
      // fetched a few points ahead.
      constexpr std::size_t kAhead = 8;
      if (j + kAhead < range.end()) {
        const std::size_t ahead = order[j + kAhead];
        __builtin_prefetch(&points[ahead]);
        __builtin_prefetch(&signed_mm[ahead], 1);
        if (nearest_face != nullptr) __builtin_prefetch(&(*nearest_face)[ahead], 1);
      }
      const std::size_t i = order[j];
      const Vec3& p = points[i];
      {  // p's filled bit, read after the search
        int bit = 0;
        if (const std::uint64_t* w = filled_word(s, p, bit)) __builtin_prefetch(w);
      }
      Nearest best;
      const double& best2 = best.d2;
      // Squared distance from p to a box of `size` at `lo`, widened by half a voxel (a face
      // centred in a cell reaches half a voxel beyond it).
      const auto box_dist2 = [&](const Vec3& lo, double size) {
        double b2 = 0;
        for (int a = 0; a < 3; ++a) {
          const double l = lo[a] - half, h = lo[a] + size + half;
          const double e = p[a] < l ? l - p[a] : (p[a] > h ? p[a] - h : 0.0);
          b2 += e * e;
        }
        return b2;
      };
      // Every face as close as the best so far is visited (strict pruning), and ties go to
      // the lowest face index: the result does not depend on the order cells are scanned.
      const auto scan_cell = [&](const Eigen::Vector3i& c) {
        if ((c.array() < 0).any() || (c.array() >= buckets.cells.array()).any()) return;
        const std::size_t ci = buckets.cell_index(c);
        if (buckets.begin[ci] == buckets.begin[ci + 1]) return;
        if (box_dist2(buckets.origin_mm + buckets.cell_mm * c.cast<double>(), buckets.cell_mm) > best2) return;
        if (avx2)
          scan_faces_avx2(buckets, buckets.begin[ci], buckets.begin[ci + 1], p, half, best);
        else
          scan_faces_default(buckets, buckets.begin[ci], buckets.begin[ci + 1], p, half, best);
      };
      // p's own cell first; then the bound (the previous point's, or the best face of p's
      // cell) limits the search to the cells its ball touches (at most 2 per axis): all
      // faces within the bound are in them, so the minimum over them is the global one.
      const Eigen::Vector3i c0 = buckets.cell_coord(p);
      scan_cell(c0);
      bool done = false;
      const double bound = std::min((prev_d + (p - prev_p).norm()) * (1 + 1e-9) + 1e-9,
                                    std::sqrt(best2) * (1 + 1e-9) + 1e-9);
      if (bound < buckets.cell_mm) {
        const double reach_mm = bound + half;
        Eigen::Vector3i lo, hi;
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::max(0, static_cast<int>(std::floor((p[a] - reach_mm - buckets.origin_mm[a]) / buckets.cell_mm)));
          hi[a] = std::min(buckets.cells[a] - 1,
                           static_cast<int>(std::floor((p[a] + reach_mm - buckets.origin_mm[a]) / buckets.cell_mm)));
        }
        for (int z = lo.z(); z <= hi.z(); ++z)
          for (int y = lo.y(); y <= hi.y(); ++y)
            for (int x = lo.x(); x <= hi.x(); ++x) {
              const Eigen::Vector3i c(x, y, z);
              if (c != c0) scan_cell(c);
            }
        done = best2 <= bound * bound;
      }
      // Fine rings around p's cell; every cell of ring + 1 is at least ring * cell - half away.
      for (int ring = 0; ring <= kFineRings && !done; ++ring) {
        for (int dz = -ring; dz <= ring; ++dz)
          for (int dy = -ring; dy <= ring; ++dy)
            for (int dx = -ring; dx <= ring; ++dx)
              if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) == ring)
                scan_cell(c0 + Eigen::Vector3i(dx, dy, dz));
        const double reach = ring * buckets.cell_mm - half;
        done = reach > 0 && best2 < reach * reach;
      }
      // Far points: rings of groups, descending only into groups that hold faces and may
      // beat the best so far (cells already scanned are simply scanned again).
      const Eigen::Vector3i g0 = c0 / kGroup;
      for (int ring = 0; ring <= max_group_ring && !done; ++ring) {
        for (int dz = -ring; dz <= ring; ++dz)
          for (int dy = -ring; dy <= ring; ++dy)
            for (int dx = -ring; dx <= ring; ++dx) {
              if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != ring) continue;
              const Eigen::Vector3i g = g0 + Eigen::Vector3i(dx, dy, dz);
              if ((g.array() < 0).any() || (g.array() >= groups.array()).any()) continue;
              if (group_has[group_index(g)] == 0) continue;
              if (box_dist2(buckets.origin_mm + group_mm * g.cast<double>(), group_mm) > best2) continue;
              for (int z = 0; z < kGroup; ++z)
                for (int y = 0; y < kGroup; ++y)
                  for (int x = 0; x < kGroup; ++x) scan_cell(g * kGroup + Eigen::Vector3i(x, y, z));
            }
        const double reach = ring * group_mm - half;
        done = reach > 0 && best2 < reach * reach;
      }
      const double d = std::sqrt(best2);
      prev_p = p;
      prev_d = d;
      signed_mm[i] = s.filled(p) ? d : -d;
      if (nearest_face != nullptr) (*nearest_face)[i] = best.face;
    }
  });
}

}  // namespace detail

void distances_to_deposit(const DepositSurface& surface, std::span<const Vec3> points,
                          std::vector<double>& signed_mm, std::vector<std::uint32_t>* nearest_face) {
  detail::distances_to_deposit_with(surface, points, signed_mm, nearest_face, false);
}

}  // namespace printtwin
