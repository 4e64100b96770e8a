#pragma once
// The outer surface's block toolkit (private to src/deviation/): the grid's 8^3 blocks as 8
// words (word z = z-slice z, bit y * 8 + x = voxel (x, y)), their cube dilations, the flood
// within a block, and the region's block box. Used by each step of the outer surface
// (surface_steps.hpp).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/bits.hpp"
#include "core/zeroed_array.hpp"
#include "deposit/voxel_blocks.hpp"
#include "deviation/outer_surface.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin::surface_blocks {

constexpr int kE = detail::VoxelBlocks::kBlockEdge;
static_assert(kE == 8, "a block's z-slice is one 64-bit word");

/// An 8^3 block of voxel bits laid out as the grid's occupancy: word z is z-slice z, bit
/// y * 8 + x is voxel (x, y).
using Cube = DepositSurface::BlockBits;

constexpr std::uint64_t kX0 = 0x0101010101010101ULL;  ///< x = 0 in every row
constexpr std::uint64_t kX7 = kX0 << 7;
constexpr std::uint64_t kY0 = 0xFFULL;  ///< the row y = 0
constexpr std::uint64_t kY7 = kY0 << 56;

/// Bits x in [lo, hi) of every row (0 <= lo <= hi <= 8).
constexpr std::uint64_t x_bits(int lo, int hi) {
  const unsigned row = (hi >= 8 ? 0xFFU : ((1U << hi) - 1U)) & ~((1U << lo) - 1U) & 0xFFU;
  return static_cast<std::uint64_t>(row) * kX0;
}
/// Rows y in [lo, hi) (0 <= lo <= hi <= 8).
constexpr std::uint64_t y_bits(int lo, int hi) {
  const std::uint64_t below_hi = hi >= 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * hi)) - 1;
  const std::uint64_t below_lo = (std::uint64_t{1} << (8 * lo)) - 1;
  return below_hi & ~below_lo;
}

inline bool any(const Cube& c) {
  std::uint64_t m = 0;
  for (const std::uint64_t w : c) m |= w;
  return m != 0;
}
inline int count(const Cube& c) {
  int n = 0;
  for (const std::uint64_t w : c) n += popcount64(w);
  return n;
}

/// The voxels of the block at `base` inside the key box [lo, hi] (inclusive).
inline Cube box_cube(const VoxelKey& base, const VoxelKey& lo, const VoxelKey& hi) {
  Cube c{};
  const int x0 = std::max(lo.x - base.x, 0), x1 = std::min(hi.x - base.x, kE - 1);
  const int y0 = std::max(lo.y - base.y, 0), y1 = std::min(hi.y - base.y, kE - 1);
  const int z0 = std::max(lo.z - base.z, 0), z1 = std::min(hi.z - base.z, kE - 1);
  if (x0 > x1 || y0 > y1 || z0 > z1) return c;
  const std::uint64_t slice = x_bits(x0, x1 + 1) & y_bits(y0, y1 + 1);
  for (int z = z0; z <= z1; ++z) c[static_cast<std::size_t>(z)] = slice;
  return c;
}

inline constexpr Cube kNoCube{};
inline const Cube& or_empty(const Cube* c) { return c != nullptr ? *c : kNoCube; }

/// One axis of a cube dilation by r (1 <= r <= 8) of block `m` between its neighbours `lo`
/// (at -1 along the axis) and `hi` (+1); null = empty.
inline Cube dilate_z(const Cube* lo_p, const Cube* m_p, const Cube* hi_p, int r) {
  std::array<std::uint64_t, 3 * kE> s;
  const Cube &lo = or_empty(lo_p), &m = or_empty(m_p), &hi = or_empty(hi_p);
  std::copy(lo.begin(), lo.end(), s.begin());
  std::copy(m.begin(), m.end(), s.begin() + kE);
  std::copy(hi.begin(), hi.end(), s.begin() + 2 * kE);
  Cube out;
  for (int z = 0; z < kE; ++z) {
    std::uint64_t v = 0;
    for (int k = -r; k <= r; ++k) {
      const int at = kE + z + k;
      v |= s[static_cast<std::size_t>(at)];
    }
    out[static_cast<std::size_t>(z)] = v;
  }
  return out;
}
/// Slices moved by k voxels both ways along y: rows move by k, the neighbours' rows enter (a
/// whole block at k = 8). A functor, so dilate_in_slices inlines it.
struct StepY {
  std::uint64_t operator()(std::uint64_t lo, std::uint64_t m, std::uint64_t hi, int k) const {
    if (k == kE) return lo | hi;
    return (m << (8 * k)) | (lo >> (64 - 8 * k)) | (m >> (8 * k)) | (hi << (64 - 8 * k));
  }
};
/// One in-slice axis (StepY) of a cube dilation by r (1 <= r <= 8).
template <class Step>
Cube dilate_in_slices(const Cube* lo_p, const Cube* m_p, const Cube* hi_p, int r, Step step) {
  const Cube &lo = or_empty(lo_p), &m = or_empty(m_p), &hi = or_empty(hi_p);
  Cube out;
  for (std::size_t z = 0; z < kE; ++z) {
    std::uint64_t v = m[z];
    for (int k = 1; k <= r; ++k) v |= step(lo[z], m[z], hi[z], k);
    out[z] = v;
  }
  return out;
}
/// The x axis of a cube dilation by r (1 <= r <= 8): slices moved by k voxels both ways
/// along x, with the neighbours' bits that wrap in (towards +x, bit x -> x + k and bits
/// 8 - k.. of the -x neighbour's row enter; towards -x likewise from the +x neighbour), bits
/// crossing into another row masked; each shift's four masks made once for the 8 slices.
inline Cube dilate_x(const Cube* lo_p, const Cube* m_p, const Cube* hi_p, int r) {
  const Cube &lo = or_empty(lo_p), &m = or_empty(m_p), &hi = or_empty(hi_p);
  Cube out = m;
  for (int k = 1; k <= r; ++k) {
    const std::uint64_t up = x_bits(k, 8), from_lo = x_bits(0, k), down = x_bits(0, 8 - k),
                        from_hi = x_bits(8 - k, 8);
    for (std::size_t z = 0; z < kE; ++z)
      out[z] |= ((m[z] << k) & up) | ((lo[z] >> (8 - k)) & from_lo) | ((m[z] >> k) & down) |
                ((hi[z] << (8 - k)) & from_hi);
  }
  return out;
}

/// Within one block, the voxels of `open` 6-connected to `seed` (seed inside open).
/// Up the slices, then down, until a pass down changes nothing: each slice it visited was
/// then grown to a fixed point against its neighbours' final state, so the flood is complete.
inline Cube flood_cube(const Cube& open, Cube o) {
  for (bool changed = true; changed;) {
    // Up the slices, then down: each pass carries a front through the whole block in z.
    for (int pass = 0; pass < 2; ++pass) {
      changed = false;
      for (int i = 0; i < kE; ++i) {
        const auto z = static_cast<std::size_t>(pass == 0 ? i : kE - 1 - i);
        std::uint64_t w = o[z];
        // Within the slice: grow along x and y until it stops.
        for (;;) {
          std::uint64_t g = w | ((w << 1) & ~kX0) | ((w >> 1) & ~kX7) | (w << 8) | (w >> 8);
          if (z > 0) g |= o[z - 1];
          if (z + 1 < kE) g |= o[z + 1];
          g &= open[z];
          if (g == w) break;
          w = g;
        }
        if (w != o[z]) {
          o[z] = w;
          changed = true;
        }
      }
    }
  }
  return o;
}

/// The face bits of c that touch the neighbour in direction `dir` (0 -x, 1 +x, 2 -y, 3 +y,
/// 4 -z, 5 +z), moved to where they land in that neighbour.
inline Cube transfer(const Cube& c, int dir) {
  Cube t{};
  switch (dir) {
    case 0:
      for (int z = 0; z < kE; ++z) t[z] = (c[z] & kX0) << 7;
      break;
    case 1:
      for (int z = 0; z < kE; ++z) t[z] = (c[z] & kX7) >> 7;
      break;
    case 2:
      for (int z = 0; z < kE; ++z) t[z] = (c[z] & kY0) << 56;
      break;
    case 3:
      for (int z = 0; z < kE; ++z) t[z] = (c[z] & kY7) >> 56;
      break;
    case 4:
      t[kE - 1] = c[0];
      break;
    default:
      t[0] = c[kE - 1];
      break;
  }
  return t;
}
inline constexpr std::array<std::array<int, 3>, 6> kDirs{
    {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}};

/// The grid blocks covering the region: lo .. lo + n - 1, indexed y, then x, then z.
struct BlockBox {
  Eigen::Vector3i lo = Eigen::Vector3i::Zero(), n = Eigen::Vector3i::Zero();
  [[nodiscard]] std::size_t size() const { return static_cast<std::size_t>(n.x()) * n.y() * n.z(); }
  [[nodiscard]] bool contains(int bx, int by, int bz) const {
    return bx >= lo.x() && by >= lo.y() && bz >= lo.z() && bx < lo.x() + n.x() &&
           by < lo.y() + n.y() && bz < lo.z() + n.z();
  }
  [[nodiscard]] std::size_t index(int bx, int by, int bz) const {
    return (static_cast<std::size_t>(by - lo.y()) * n.x() + static_cast<std::size_t>(bx - lo.x())) *
               n.z() +
           static_cast<std::size_t>(bz - lo.z());
  }
  [[nodiscard]] Eigen::Vector3i coords(std::size_t i) const {
    const auto nz = static_cast<std::size_t>(n.z()), nx = static_cast<std::size_t>(n.x());
    return {lo.x() + static_cast<int>((i / nz) % nx), lo.y() + static_cast<int>(i / (nz * nx)),
            lo.z() + static_cast<int>(i % nz)};
  }
};

/// A per-block flag set dilated by `reach` blocks (Chebyshev), in place: one pass per axis,
/// each an OR of shifted runs (z within a column, whole columns along x, whole rows along y).
inline void dilate_flags(std::vector<std::uint8_t>& f, const BlockBox& box, int reach) {
  if (reach <= 0) return;
  const auto nx = static_cast<std::size_t>(box.n.x()), ny = static_cast<std::size_t>(box.n.y()),
             nz = static_cast<std::size_t>(box.n.z());
  std::vector<std::uint8_t> g(f.size());
  // Along an axis of `len` entries `stride` apart, in runs of `run` contiguous entries.
  const auto pass = [&](std::size_t len, std::size_t stride, std::size_t run, std::size_t outer,
                        std::size_t outer_stride) {
    g = f;
    tbb::parallel_for(std::size_t{0}, outer, [&](std::size_t o) {
      const std::size_t base = o * outer_stride;
      for (std::size_t k = 1; k <= static_cast<std::size_t>(reach) && k < len; ++k)
        for (std::size_t j = 0; j + k < len; ++j) {
          std::uint8_t* lo = g.data() + base + j * stride;
          std::uint8_t* hi = g.data() + base + (j + k) * stride;
          const std::uint8_t* flo = f.data() + base + j * stride;
          const std::uint8_t* fhi = f.data() + base + (j + k) * stride;
          for (std::size_t e = 0; e < run; ++e) {
            lo[e] |= fhi[e];
            hi[e] |= flo[e];
          }
        }
    });
    f.swap(g);
  };
  // z: within each column, an entry at a time.
  g.resize(f.size());
  tbb::parallel_for(std::size_t{0}, nx * ny, [&](std::size_t o) {
    const std::uint8_t* col = f.data() + o * nz;
    std::uint8_t* out = g.data() + o * nz;
    const auto k = static_cast<std::size_t>(reach);
    for (std::size_t j = 0; j < nz; ++j) {
      std::uint8_t v = 0;
      for (std::size_t e = j >= k ? j - k : 0; e <= j + k && e < nz; ++e) v |= col[e];
      out[j] = v;
    }
  });
  f.swap(g);
  pass(nx, nz, nz, ny, nx * nz);     // x: columns of a row
  pass(ny, nx * nz, nx * nz, 1, 0);  // y: rows
}

/// Cubes appended in chunks (no copies as it grows), addressed by index. Chunk c holds
/// kFirst << c cubes: a small pool stays small, and a large one is made of few large blocks
/// (which the command line's operator new backs with huge pages: one page fault per 2 MiB
/// rather than per 4 KiB).
class CubePool {
 public:
  std::uint32_t push(const Cube& c) {
    if (size_ == capacity_) add_chunk();
    (*this)[size_] = c;
    return static_cast<std::uint32_t>(size_++);
  }
  Cube& operator[](std::size_t i) {
    const std::size_t c = chunk_of(i);
    return chunks_[c][i - first_of(c)];
  }
  const Cube& operator[](std::size_t i) const {
    const std::size_t c = chunk_of(i);
    return chunks_[c][i - first_of(c)];
  }
  [[nodiscard]] std::size_t size() const { return size_; }
  /// Room for n more cubes (uninitialised), at indices from the returned one on.
  std::size_t grow(std::size_t n) {
    const std::size_t first = size_;
    size_ += n;
    while (capacity_ < size_) add_chunk();
    return first;
  }

 private:
  static constexpr std::size_t kFirst = 4096;
  /// The chunk holding cube i: chunks 0..c hold kFirst * (2^(c + 1) - 1) cubes.
  static std::size_t chunk_of(std::size_t i) {
    return static_cast<std::size_t>(std::bit_width(i / kFirst + 1)) - 1;
  }
  static std::size_t first_of(std::size_t c) { return kFirst * ((std::size_t{1} << c) - 1); }
  void add_chunk() {
    const std::size_t n = kFirst << chunks_.size();
    chunks_.push_back(std::make_unique_for_overwrite<Cube[]>(n));
    capacity_ += n;
  }
  std::vector<std::unique_ptr<Cube[]>> chunks_;
  std::size_t size_ = 0, capacity_ = 0;
};

/// A field of block cubes dilated by r voxels (a cube of 2r + 1) and clipped to a box,
/// for the blocks asked for. The cube is the product of its three axis segments, and
/// dilations by a and b compose to a + b, so it runs as steps of at most 8 voxels (one
/// block), each along z, then x, then y (each reading the two neighbours along its axis),
/// the result of each step clipped. The base gives stable pointers (null = empty). prepare()
/// computes the stages below the top that given blocks read (each block's stage once, kept
/// for later calls), then top_of() gives the top stage of those blocks from any thread.
template <class Base, class Clip>
class DilatedField {
 public:
  DilatedField(const BlockBox& box, int r, Base base, Clip clip)
      : box_(box), base_(std::move(base)), clip_(std::move(clip)) {
    for (int left = r; left > 0; left -= kE) steps_.push_back(std::min(left, kE));
    top_ = 3 * static_cast<int>(steps_.size());
    memo_.resize(static_cast<std::size_t>(std::max(top_, 1)));
    for (int st = 1; st < top_; ++st)
      memo_[static_cast<std::size_t>(st)] = ZeroedArray<std::uint32_t>(box_.size());
  }
  /// Computes every stage below the top that the blocks `targets` (box indices) read, a
  /// stage at a time, its blocks in parallel; then top_of may run on several threads.
  void prepare(const std::vector<std::uint32_t>& targets) {
    std::vector<std::vector<std::uint32_t>> lists(static_cast<std::size_t>(std::max(top_, 1)));
    if (mark_.size() != box_.size()) mark_ = ZeroedArray<std::uint8_t>(box_.size());
    const std::vector<std::uint32_t>* cur = &targets;
    for (int st = top_ - 1; st >= 1; --st) {
      // Stage st + 1 reads stage st of a block and its two neighbours along its axis.
      const int axis = st % 3;
      auto& next = lists[static_cast<std::size_t>(st)];
      // Along the axis: the index step and the blocks on it; a block's place on the axis is
      // (index / step) % blocks (indices run y, then x, then z).
      const auto nz = static_cast<std::size_t>(box_.n.z()),
                 nx = static_cast<std::size_t>(box_.n.x());
      const std::size_t stride = axis == 0 ? 1 : axis == 1 ? nz : nz * nx;
      const auto len = static_cast<std::size_t>(axis == 0   ? box_.n.z()
                                                : axis == 1 ? box_.n.x()
                                                            : box_.n.y());
      const auto& memo = memo_[static_cast<std::size_t>(st)];
      const auto list = [&](std::size_t j) {
        // Computed by an earlier call: neither it nor what it reads is needed again.
        if (mark_[j] == 0 && memo[j] == 0) {
          mark_[j] = 1;
          next.push_back(static_cast<std::uint32_t>(j));
        }
      };
      for (const std::uint32_t i : *cur) {
        const std::size_t at = (i / stride) % len;
        if (at > 0) list(i - stride);
        list(i);
        if (at + 1 < len) list(i + stride);
      }
      for (const std::uint32_t j : next) mark_[j] = 0;
      cur = &next;
    }
    for (int st = 1; st < top_; ++st) {
      const auto& list = lists[static_cast<std::size_t>(st)];
      const std::size_t first = pool_.grow(list.size());
      tbb::parallel_for(std::size_t{0}, list.size(), [&](std::size_t k) {
        const Eigen::Vector3i b = box_.coords(list[k]);
        Cube out;
        std::uint32_t& memo = memo_[static_cast<std::size_t>(st)][list[k]];
        if (!compute(
                st, b.x(), b.y(), b.z(), [&](int x, int y, int z) { return read(st - 1, x, y, z); },
                out)) {
          memo = 1;
          return;
        }
        pool_[first + k] = out;
        memo = static_cast<std::uint32_t>(first + k + 2);
      });
    }
  }
  /// The top stage of a block whose stages below are prepared (false = empty).
  [[nodiscard]] bool top_of(int bx, int by, int bz, Cube& out) const {
    if (top_ == 0) {
      const Cube* c = base_(bx, by, bz);
      out = or_empty(c);
      return c != nullptr;
    }
    return compute(
        top_, bx, by, bz, [&](int x, int y, int z) { return read(top_ - 1, x, y, z); }, out);
  }

 private:
  /// Stage st (> 0) of a block from stage st - 1 (`below`) of it and its two neighbours along
  /// the stage's axis; false when empty.
  template <class Below>
  bool compute(int st, int bx, int by, int bz, const Below& below, Cube& out) const {
    const int axis = (st - 1) % 3;
    const int r = steps_[static_cast<std::size_t>((st - 1) / 3)];
    const int dx = axis == 1 ? 1 : 0, dy = axis == 2 ? 1 : 0, dz = axis == 0 ? 1 : 0;
    const Cube* lo = below(bx - dx, by - dy, bz - dz);
    const Cube* m = below(bx, by, bz);
    const Cube* hi = below(bx + dx, by + dy, bz + dz);
    if (lo == nullptr && m == nullptr && hi == nullptr) return false;
    out = axis == 0   ? dilate_z(lo, m, hi, r)
          : axis == 1 ? dilate_x(lo, m, hi, r)
                      : dilate_in_slices(lo, m, hi, r, StepY{});
    if (axis == 2) {
      const Cube c = clip_(bx, by, bz);
      for (std::size_t z = 0; z < kE; ++z) out[z] &= c[z];
    }
    return any(out);
  }
  /// A computed stage (st < top), or the base.
  const Cube* read(int st, int bx, int by, int bz) const {
    if (!box_.contains(bx, by, bz)) return nullptr;
    if (st == 0) return base_(bx, by, bz);
    const std::uint32_t k = memo_[static_cast<std::size_t>(st)][box_.index(bx, by, bz)];
    return k > 1 ? &pool_[k - 2] : nullptr;
  }
  const BlockBox& box_;
  Base base_;
  Clip clip_;
  std::vector<int> steps_;
  int top_ = 0;
  std::vector<ZeroedArray<std::uint32_t>> memo_;
  CubePool pool_;
  ZeroedArray<std::uint8_t> mark_;  ///< prepare's scratch: blocks already listed
};

}  // namespace printtwin::surface_blocks
