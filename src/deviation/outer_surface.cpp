// The deposit's outer surface: a flood fill from outside over the grid's 8^3 blocks, where
// only the blocks the outside reaches (and their neighbours) are ever looked at voxel by
// voxel. The inside of a part (sparse infill, enclosed by its walls and solid layers) is
// never visited: it stays "filled" by default.
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <memory>
#include <optional>

#include "core/bits.hpp"
#include "core/zeroed_array.hpp"
#include "deviation/outer_surface.hpp"
#include "deviation/surface_blocks.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

using detail::VoxelBlocks;

bool is_auxiliary_feature(Feature f) {
  switch (f) {
    case Feature::skirt:
    case Feature::support:
    case Feature::support_interface:
    case Feature::wipe_tower:
    case Feature::custom:
      return true;
    default:
      return false;
  }
}

namespace {

using namespace surface_blocks;  // NOLINT(google-build-using-namespace): this stage's own toolkit

/// Bit i set when voxel i of z-slice z of block b has an auxiliary tag (`auxiliary[t]` is 1
/// for an auxiliary tag index t; indices clamped to `last`; tags of empty voxels mean nothing).
std::uint64_t aux_mask(const VoxelBlocks::BlockView& b, int z, const std::uint8_t* auxiliary,
                       std::uint32_t last) {
  std::uint64_t m = 0;
  if (b.wide != nullptr) {
    for (int i = 0; i < 64; ++i)
      m |= static_cast<std::uint64_t>(auxiliary[std::min(b.wide[z * 64 + i], last)] & 1U) << i;
    return m;
  }
  unsigned on = 0;  // bit e: palette entry e is auxiliary
  for (int e = 0; e < b.palette_size; ++e)
    on |= (auxiliary[std::min(b.palette[e], last)] & 1U) << e;
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

/// Row y of a cube's slices as z-columns: byte x of the result holds the 8 z bits of (x, y).
inline std::uint64_t columns_of_row(const Cube& c, int y) {
  std::uint64_t m = 0;
  for (int z = 0; z < kE; ++z)
    m |= ((c[static_cast<std::size_t>(z)] >> (8 * y)) & 0xFFU) << (8 * z);
  return transpose8(m);
}

}  // namespace

namespace {
/// The region voxel holding p: its grid key, or false when p is outside the region.
bool region_key(const DepositSurface& s, const Vec3& p_mm, VoxelKey& key) {
  if (s.voxel_mm <= 0) return false;
  const Vec3 q = (p_mm - s.origin_mm) / s.voxel_mm;
  const auto x = static_cast<long>(std::floor(q.x()));
  const auto y = static_cast<long>(std::floor(q.y()));
  const auto z = static_cast<long>(std::floor(q.z()));
  if (x < 0 || y < 0 || z < 0 || x >= s.dims.x() || y >= s.dims.y() || z >= s.dims.z())
    return false;
  key = VoxelKey{s.origin_key.x + static_cast<int>(x), s.origin_key.y + static_cast<int>(y),
                 s.origin_key.z + static_cast<int>(z)};
  return true;
}
}  // namespace

const std::uint32_t* DepositSurface::filled_code_of(const Vec3& p_mm, int& slot) const {
  VoxelKey k;
  if (!region_key(*this, p_mm, k)) return nullptr;
  const int bx = k.x >> 3, by = k.y >> 3, bz = k.z >> 3;
  slot = (k.z & 7) * 64 + (k.y & 7) * 8 + (k.x & 7);
  const std::size_t i =
      (static_cast<std::size_t>(by - filled_blocks_lo.y()) * filled_blocks_dims.x() +
       static_cast<std::size_t>(bx - filled_blocks_lo.x())) *
          filled_blocks_dims.z() +
      static_cast<std::size_t>(bz - filled_blocks_lo.z());
  return filled_block_code.data() + i;
}

bool DepositSurface::filled(const Vec3& p_mm) const {
  int slot = 0;
  const std::uint32_t* code = filled_code_of(p_mm, slot);
  if (code == nullptr) return false;
  if (*code == kAllFilled) return true;
  if (*code == kNoneFilled) return false;
  return ((filled_masks[*code - kFirstMask][static_cast<std::size_t>(slot >> 6)] >> (slot & 63)) &
          1U) != 0;
}

DepositSurface extract_outer_surface(const VoxelGrid& grid, const Box3& region_mm,
                                     double seal_gap_mm, double groove_depth_mm) {
  DepositSurface s;
  s.voxel_mm = grid.voxel_mm();
  if (region_mm.empty()) return s;
  // Region R in grid keys, padded by one voxel: the padding (R minus its interior I) is
  // forced empty, so the outside is connected all around the part.
  const VoxelKey kmin0 = grid.key_of(region_mm.min);
  const VoxelKey kmax0 = grid.key_of(region_mm.max);
  const VoxelKey kmin{kmin0.x - 1, kmin0.y - 1, kmin0.z - 1};
  const int nx = kmax0.x - kmin0.x + 3, ny = kmax0.y - kmin0.y + 3, nz = kmax0.z - kmin0.z + 3;
  s.dims = Eigen::Vector3i(nx, ny, nz);
  s.origin_mm = grid.origin_mm() + s.voxel_mm * Vec3(kmin.x, kmin.y, kmin.z);
  s.origin_key = kmin;
  const VoxelKey rlo = kmin, rhi{kmin.x + nx - 1, kmin.y + ny - 1, kmin.z + nz - 1};
  const VoxelKey ilo{rlo.x + 1, rlo.y + 1, rlo.z + 1}, ihi{rhi.x - 1, rhi.y - 1, rhi.z - 1};
  // Keys may be negative: >> 3 is the floor.
  BlockBox box;
  box.lo = Eigen::Vector3i(rlo.x >> 3, rlo.y >> 3, rlo.z >> 3);
  box.n = Eigen::Vector3i((rhi.x >> 3) - box.lo.x() + 1, (rhi.y >> 3) - box.lo.y() + 1,
                          (rhi.z >> 3) - box.lo.z() + 1);
  s.filled_blocks_lo = box.lo;
  s.filled_blocks_dims = box.n;
  const auto base_of = [](int bx, int by, int bz) { return VoxelKey{bx * kE, by * kE, bz * kE}; };
  const auto inside_box = [&](int bx, int by, int bz, const VoxelKey& lo, const VoxelKey& hi) {
    const VoxelKey b = base_of(bx, by, bz);
    return b.x >= lo.x && b.y >= lo.y && b.z >= lo.z && b.x + kE - 1 <= hi.x &&
           b.y + kE - 1 <= hi.y && b.z + kE - 1 <= hi.z;
  };
  Cube full;
  full.fill(~std::uint64_t{0});
  const auto region_cube = [&](int bx, int by, int bz) {
    return inside_box(bx, by, bz, rlo, rhi) ? full : box_cube(base_of(bx, by, bz), rlo, rhi);
  };
  const auto region_cube_of = [&](std::size_t i) {
    const Eigen::Vector3i b = box.coords(i);
    return region_cube(b.x(), b.y(), b.z());
  };
  const auto interior_cube = [&](int bx, int by, int bz) {
    return inside_box(bx, by, bz, ilo, ihi) ? full : box_cube(base_of(bx, by, bz), ilo, ihi);
  };

  // 1. Part voxels (occupied, not auxiliary, in I) per block of the box: a pointer to the
  // grid's occupancy, or to a filtered copy where auxiliary voxels or I's border cut it. The
  // allocated blocks are read in the order they were allocated (their memory order).
  const auto& table = VoxelBlocks::tag_table(grid);
  std::vector<std::uint8_t> auxiliary(table.size());
  for (std::size_t i = 0; i < table.size(); ++i)
    auxiliary[i] = is_auxiliary_feature(table[i].feature) ? 1 : 0;
  const auto last_tag = static_cast<std::uint32_t>(auxiliary.empty() ? 0 : auxiliary.size() - 1);
  const std::size_t n_blocks = box.size();
  ZeroedArray<const Cube*> part_of(n_blocks);
  CubePool filtered;
  VoxelBlocks::visit_blocks_as_allocated(grid, [&](const VoxelBlocks::BlockView& b) {
    const int bx = b.base.x >> 3, by = b.base.y >> 3, bz = b.base.z >> 3;
    if (!box.contains(bx, by, bz)) return;
    Cube c;
    std::copy(b.occupancy, b.occupancy + kE, c.begin());
    bool cut = false;
    // A block none of whose palette entries is auxiliary needs no per-voxel test.
    bool aux = b.wide != nullptr;
    for (int e = 0; e < b.palette_size && !aux; ++e)
      aux = auxiliary[std::min(b.palette[e], last_tag)] != 0;
    if (aux) {
      for (int z = 0; z < kE; ++z)
        if (c[static_cast<std::size_t>(z)] != 0)
          c[static_cast<std::size_t>(z)] &= ~aux_mask(b, z, auxiliary.data(), last_tag);
      cut = true;
    }
    if (!inside_box(bx, by, bz, ilo, ihi)) {
      const Cube in = box_cube(b.base, ilo, ihi);
      for (std::size_t z = 0; z < kE; ++z) c[z] &= in[z];
      cut = true;
    }
    const int n = count(c);
    if (n == 0) return;
    s.occupied_voxels += static_cast<std::size_t>(n);
    const std::size_t i = box.index(bx, by, bz);
    if (cut) {
      part_of[i] = &filtered[filtered.push(c)];
    } else {
      static_assert(sizeof(Cube) == kE * sizeof(std::uint64_t));
      part_of[i] = reinterpret_cast<const Cube*>(b.occupancy);
    }
  });
  const auto part_cube = [&](int bx, int by, int bz) -> const Cube* {
    return box.contains(bx, by, bz) ? part_of[box.index(bx, by, bz)] : nullptr;
  };
  // Gaps narrower than seal_gap_mm must not let the outside in (pinholes between beads are
  // voxelisation artefacts): the flood runs on the part dilated by r voxels, and the outside
  // it reaches is dilated back by r (a morphological opening of the empty space).
  const int seal_r =
      seal_gap_mm > 0 ? static_cast<int>(std::floor(seal_gap_mm / (2 * s.voxel_mm) + 1e-9)) : 0;
  const int reach = (seal_r + kE - 1) / kE;  // in blocks
  // What the seal closed is opened again to `reopen` voxels (6-connected steps through empty
  // voxels) from the sealed outside: grooves between layers and beads are surface again, a
  // pinhole lets the outside in no further than that.
  const int reopen =
      groove_depth_mm > 0 ? static_cast<int>(std::floor(groove_depth_mm / s.voxel_mm + 1e-9)) : 0;
  // A block no part voxel comes within r of is open all through (within R).
  std::vector<std::uint8_t> near_occ(n_blocks);
  for (std::size_t i = 0; i < n_blocks; ++i) near_occ[i] = part_of[i] != nullptr ? 1 : 0;
  dilate_flags(near_occ, box, reach);
  // 2. The flood, block by block from the padding, in waves: every block of a wave grows its
  // outside by a fill within the block, in parallel, and what reaches its faces seeds the
  // neighbours for the next_wave wave. An open block is wholly outside as soon as anything
  // reaches it (R within a block is a box, so connected). The outside found is the one
  // component of the open voxels that holds the padding, whatever the order blocks are
  // reached in.
  // Held only through the flood: its cubes' memory then serves the dilation of step 3.
  std::optional<DilatedField<decltype(part_cube), decltype(interior_cube)>> blocked;
  blocked.emplace(box, seal_r, part_cube, interior_cube);
  enum : std::uint8_t { kUntouched = 0, kWhole = 1, kPartial = 2 };
  std::vector<std::uint8_t> kind(n_blocks, kUntouched);
  std::vector<std::uint8_t> queued(n_blocks, 0);
  std::vector<std::uint32_t> slot(n_blocks, 0);  // partial blocks: into open/outside/pending
  CubePool open, outside, pending;
  std::vector<std::uint8_t> has_open;  // per slot: open (E) computed
  // Wave entries carry their block's coordinates (no divisions to recover them).
  struct Queued {
    std::uint32_t i;
    std::int32_t x, y, z;
  };
  struct Seed {
    Queued to;
    Cube bits;
  };
  std::vector<Queued> wave, next_wave;
  // Seeds for a block, between waves (one thread): an open block turns whole; another gets
  // its state (open voxels computed before the wave), the seed pending, and a place in the
  // next_wave wave.
  const auto add_seed = [&](const Queued& q, const Cube& seed) {
    const std::size_t i = q.i;
    if (kind[i] == kWhole) return;
    if (near_occ[i] == 0) {
      kind[i] = kWhole;
      next_wave.push_back(q);
      return;
    }
    if (kind[i] == kUntouched) {
      kind[i] = kPartial;
      slot[i] = open.push(Cube{});
      outside.push(Cube{});
      pending.push(Cube{});
      has_open.push_back(0);
    }
    Cube& p = pending[slot[i]];
    std::uint64_t any_bits = 0;
    for (std::size_t z = 0; z < kE; ++z) {
      p[z] |= seed[z];
      any_bits |= seed[z];
    }
    if (any_bits != 0 && queued[i] == 0) {
      queued[i] = 1;
      next_wave.push_back(q);
    }
  };
  // Seeds: the padding, in the blocks on the box's faces.
  for (int by = box.lo.y(); by < box.lo.y() + box.n.y(); ++by)
    for (int bx = box.lo.x(); bx < box.lo.x() + box.n.x(); ++bx)
      for (int bz = box.lo.z(); bz < box.lo.z() + box.n.z(); ++bz) {
        const bool face = bx == box.lo.x() || by == box.lo.y() || bz == box.lo.z() ||
                          bx == box.lo.x() + box.n.x() - 1 || by == box.lo.y() + box.n.y() - 1 ||
                          bz == box.lo.z() + box.n.z() - 1;
        if (!face) continue;
        const Cube r = region_cube(bx, by, bz), in = interior_cube(bx, by, bz);
        Cube pad;
        for (std::size_t z = 0; z < kE; ++z) pad[z] = r[z] & ~in[z];
        if (any(pad))
          add_seed({static_cast<std::uint32_t>(box.index(bx, by, bz)), bx, by, bz}, pad);
      }
  // Index steps to the six neighbours (blocks are indexed y, then x, then z).
  const std::array<std::ptrdiff_t, 6> step{-static_cast<std::ptrdiff_t>(box.n.z()),
                                           box.n.z(),
                                           -static_cast<std::ptrdiff_t>(box.n.z()) * box.n.x(),
                                           static_cast<std::ptrdiff_t>(box.n.z()) * box.n.x(),
                                           -1,
                                           1};
  tbb::enumerable_thread_specific<std::vector<Seed>> found;
  tbb::enumerable_thread_specific<std::vector<Queued>> turned_whole;
  std::vector<std::uint32_t> need_open;
  while (!next_wave.empty()) {
    wave.swap(next_wave);
    next_wave.clear();
    // The open voxels of the wave's new partial blocks: their dilation's stages prepared,
    // then each block's, in parallel.
    need_open.clear();
    for (const Queued& q : wave)
      if (kind[q.i] == kPartial && has_open[slot[q.i]] == 0) need_open.push_back(q.i);
    if (!need_open.empty()) {
      blocked->prepare(need_open);
      tbb::parallel_for(std::size_t{0}, need_open.size(), [&](std::size_t k) {
        const std::uint32_t i = need_open[k];
        const Eigen::Vector3i b = box.coords(i);
        Cube e = region_cube(b.x(), b.y(), b.z());
        Cube d;
        if (blocked->top_of(b.x(), b.y(), b.z(), d))
          for (std::size_t z = 0; z < kE; ++z) e[z] &= ~d[z];
        open[slot[i]] = e;
        has_open[slot[i]] = 1;
      });
    }
    for (auto& f : found) f.clear();
    for (auto& w : turned_whole) w.clear();
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, wave.size(), 256),
        [&](const tbb::blocked_range<std::size_t>& range) {
          auto& mine = found.local();
          auto& whole_now = turned_whole.local();
          for (std::size_t w = range.begin(); w != range.end(); ++w) {
            const Queued q = wave[w];
            const bool whole = kind[q.i] == kWhole;
            Cube grown;
            if (whole) {
              grown = region_cube(q.x, q.y, q.z);
            } else {
              queued[q.i] = 0;
              const std::uint32_t k = slot[q.i];
              Cube o = outside[k];
              bool news = false;
              for (std::size_t z = 0; z < kE; ++z) {
                const std::uint64_t add = pending[k][z] & open[k][z] & ~o[z];
                o[z] |= add;
                news = news || add != 0;
              }
              pending[k] = Cube{};
              if (!news) continue;
              o = flood_cube(open[k], o);
              for (std::size_t z = 0; z < kE; ++z) grown[z] = o[z] & ~outside[k][z];
              outside[k] = o;
            }
            for (int d = 0; d < 6; ++d) {
              const int nbx = q.x + kDirs[d][0], nby = q.y + kDirs[d][1], nbz = q.z + kDirs[d][2];
              if (!box.contains(nbx, nby, nbz)) continue;
              const auto n = static_cast<std::uint32_t>(static_cast<std::ptrdiff_t>(q.i) +
                                                        step[static_cast<std::size_t>(d)]);
              // An open block turns whole here (the one thread that claims it queues it); other
              // blocks change kind only between waves.
              std::atomic_ref<std::uint8_t> nk(kind[n]);
              if (nk.load(std::memory_order_relaxed) == kWhole) continue;
              const Cube t = transfer(grown, d);
              if (!any(t)) continue;
              if (near_occ[n] == 0) {
                std::uint8_t expected = kUntouched;
                if (nk.compare_exchange_strong(expected, kWhole, std::memory_order_relaxed))
                  whole_now.push_back({n, nbx, nby, nbz});
              } else {
                mine.push_back({{n, nbx, nby, nbz}, t});
              }
            }
          }
        });
    // The seeds, between waves (OR is commutative: the order they come in changes nothing).
    for (const auto& w : turned_whole) next_wave.insert(next_wave.end(), w.begin(), w.end());
    for (auto& f : found)
      for (const Seed& sd : f) add_seed(sd.to, sd.bits);
  }
  blocked.reset();
  // 3. Filled = R minus (the outside dilated back by r, where not part). Only blocks within
  // `reach` of a block the outside entered can differ from "all filled" (untouched) or "none
  // filled" (wholly outside, which holds no part voxel).
  std::vector<std::uint8_t> near_outside(n_blocks, 0);
  for (std::size_t i = 0; i < n_blocks; ++i)
    near_outside[i] = kind[i] == kWhole || (kind[i] == kPartial && any(outside[slot[i]])) ? 1 : 0;
  dilate_flags(near_outside, box, reach + (seal_r > 0 ? (reopen + kE - 1) / kE : 0));
  s.filled_block_code.assign(n_blocks, DepositSurface::kAllFilled);
  std::vector<std::uint32_t> mixed;
  for (std::size_t i = 0; i < n_blocks; ++i) {
    if (kind[i] == kWhole)
      s.filled_block_code[i] = DepositSurface::kNoneFilled;
    else if (near_outside[i] != 0)
      mixed.push_back(static_cast<std::uint32_t>(i));
  }
  const auto outside_cube = [&](int bx, int by, int bz) -> const Cube* {
    const std::size_t i = box.index(bx, by, bz);
    if (kind[i] == kWhole) return &full;  // R's part of it: the field clips to R
    if (kind[i] == kPartial) return &outside[slot[i]];
    return nullptr;
  };
  DilatedField outside_back(box, seal_r, outside_cube, region_cube);
  outside_back.prepare(mixed);
  s.filled_masks.resize(mixed.size());
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    const Eigen::Vector3i b = box.coords(mixed[m]);
    Cube o{};
    const bool some = outside_back.top_of(b.x(), b.y(), b.z(), o);
    const Cube& part = or_empty(part_of[mixed[m]]);
    const Cube region = region_cube(b.x(), b.y(), b.z());
    Cube& f = s.filled_masks[m];
    for (std::size_t z = 0; z < kE; ++z) f[z] = region[z] & ~((some ? o[z] : 0) & ~part[z]);
  });
  for (std::size_t m = 0; m < mixed.size(); ++m)
    s.filled_block_code[mixed[m]] = DepositSurface::kFirstMask + static_cast<std::uint32_t>(m);
  if (seal_r > 0 && reopen > 0)
    reopen_grooves(
        s, box, mixed, reopen, [&](std::size_t i) { return region_cube_of(i); },
        [&](std::size_t i) { return or_empty(part_of[i]); });
  std::size_t not_filled = 0;
  for (std::size_t m = 0; m < mixed.size(); ++m) {
    const Cube region = region_cube_of(mixed[m]);
    for (std::size_t z = 0; z < kE; ++z)
      not_filled += static_cast<std::size_t>(popcount64(region[z] & ~s.filled_masks[m][z]));
  }
  for (std::size_t i = 0; i < n_blocks; ++i)
    if (kind[i] == kWhole) {
      const Eigen::Vector3i b = box.coords(i);
      not_filled += inside_box(b.x(), b.y(), b.z(), rlo, rhi)
                        ? std::size_t{512}
                        : static_cast<std::size_t>(count(region_cube(b.x(), b.y(), b.z())));
    }
  s.filled_voxels =
      static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz) -
      not_filled;
  // 4. Faces between a filled part voxel and a voxel that is not filled (a part voxel is in
  // I, so its neighbours are in R). Only blocks with part voxels that are, or touch, a block
  // not wholly filled can have one. Per row of blocks (in parallel): each such block's six
  // exposure cubes (-x, +x, -y, +y, -z, +z) as z-columns; faces counted per row of voxels,
  // then written in the fixed order: voxel rows by y, then x, then z, a voxel's faces by
  // direction.
  // A part voxel is in I, so whether a voxel outside R counts as filled never matters here:
  // a block "all filled" reads as a full cube.
  const auto filled_cube = [&](int bx, int by, int bz) -> const Cube& {
    if (!box.contains(bx, by, bz)) return kNoCube;
    const std::uint32_t code = s.filled_block_code[box.index(bx, by, bz)];
    if (code == DepositSurface::kAllFilled) return full;
    if (code == DepositSurface::kNoneFilled) return kNoCube;
    return s.filled_masks[code - DepositSurface::kFirstMask];
  };
  struct Exposed {
    int bx = 0, bz = 0;
    std::array<std::array<std::uint64_t, kE>, 6> cols{};  // [direction][y]: byte x = z bits
    std::array<std::uint32_t, 8> cell_faces{};            // faces per cell (local y, x, z halves)
  };
  // Bits of a cell's voxels in a z-column row word (byte x = z bits): bytes x in the cell's
  // x half, bits z in its z half.
  const auto cell_columns = [](int cx, int cz) {
    const std::uint64_t nibble = cz != 0 ? 0xF0ULL : 0x0FULL;
    return (cx != 0 ? 0xFFFFFFFF00000000ULL : 0x00000000FFFFFFFFULL) & (nibble * kX0);
  };
  std::vector<std::vector<Exposed>> exposed(static_cast<std::size_t>(box.n.y()));
  tbb::parallel_for(0, box.n.y(), [&](int r) {
    const int by = box.lo.y() + r;
    auto& list = exposed[static_cast<std::size_t>(r)];
    for (int bx = box.lo.x(); bx < box.lo.x() + box.n.x(); ++bx)
      for (int bz = box.lo.z(); bz < box.lo.z() + box.n.z(); ++bz) {
        const std::size_t i = box.index(bx, by, bz);
        if (part_of[i] == nullptr) continue;
        bool candidate = s.filled_block_code[i] != DepositSurface::kAllFilled;
        for (int d = 0; d < 6 && !candidate; ++d) {
          const int x = bx + kDirs[d][0], y = by + kDirs[d][1], z = bz + kDirs[d][2];
          candidate = box.contains(x, y, z) &&
                      s.filled_block_code[box.index(x, y, z)] != DepositSurface::kAllFilled;
        }
        if (!candidate) continue;
        const Cube &f = filled_cube(bx, by, bz), &part = *part_of[i];
        std::array<Cube, 6> nf;  // per direction: whether that neighbour of each voxel is filled
        {
          const Cube &fl = filled_cube(bx - 1, by, bz), &fr = filled_cube(bx + 1, by, bz);
          const Cube &fd = filled_cube(bx, by - 1, bz), &fu = filled_cube(bx, by + 1, bz);
          const Cube &fb = filled_cube(bx, by, bz - 1), &ft = filled_cube(bx, by, bz + 1);
          for (std::size_t z = 0; z < kE; ++z) {
            nf[0][z] = ((f[z] << 1) & ~kX0) | ((fl[z] & kX7) >> 7);
            nf[1][z] = ((f[z] >> 1) & ~kX7) | ((fr[z] & kX0) << 7);
            nf[2][z] = (f[z] << 8) | ((fd[z] & kY7) >> 56);
            nf[3][z] = (f[z] >> 8) | ((fu[z] & kY0) << 56);
            nf[4][z] = z > 0 ? f[z - 1] : fb[kE - 1];
            nf[5][z] = z + 1 < kE ? f[z + 1] : ft[0];
          }
        }
        Exposed e;
        e.bx = bx;
        e.bz = bz;
        bool some = false;
        for (std::size_t d = 0; d < 6; ++d) {
          Cube x;
          for (std::size_t z = 0; z < kE; ++z) x[z] = f[z] & part[z] & ~nf[d][z];
          if (!any(x)) continue;
          some = true;
          for (int y = 0; y < kE; ++y)
            e.cols[d][static_cast<std::size_t>(y)] = columns_of_row(x, y);
        }
        if (!some) continue;
        for (int cell = 0; cell < 8; ++cell) {
          const std::uint64_t in_cell = cell_columns((cell >> 1) & 1, cell & 1);
          const int y0 = 4 * (cell >> 2);
          std::uint32_t n = 0;
          for (int y = y0; y < y0 + 4; ++y)
            for (std::size_t d = 0; d < 6; ++d)
              n += static_cast<std::uint32_t>(
                  popcount64(e.cols[d][static_cast<std::size_t>(y)] & in_cell));
          e.cell_faces[static_cast<std::size_t>(cell)] = n;
        }
        list.push_back(e);
      }
  });
  // The face blocks in box order (y, then x, then z) and the start of each of their cells.
  std::vector<std::size_t> row_blocks(static_cast<std::size_t>(box.n.y()) + 1, 0);
  for (int r = 0; r < box.n.y(); ++r)
    row_blocks[static_cast<std::size_t>(r) + 1] =
        row_blocks[static_cast<std::size_t>(r)] + exposed[static_cast<std::size_t>(r)].size();
  const std::size_t n_face_blocks = row_blocks.back();
  s.face_blocks.resize(n_face_blocks);
  s.face_cell_begin.resize(8 * n_face_blocks + 1);
  std::size_t n_faces = 0;
  for (int r = 0; r < box.n.y(); ++r) {
    const auto& list = exposed[static_cast<std::size_t>(r)];
    for (std::size_t c = 0; c < list.size(); ++c) {
      const std::size_t k = row_blocks[static_cast<std::size_t>(r)] + c;
      s.face_blocks[k] =
          static_cast<std::uint32_t>(box.index(list[c].bx, box.lo.y() + r, list[c].bz));
      for (std::size_t cell = 0; cell < 8; ++cell) {
        s.face_cell_begin[8 * k + cell] = static_cast<std::uint32_t>(n_faces);
        n_faces += list[c].cell_faces[cell];
      }
    }
  }
  s.face_cell_begin.back() = static_cast<std::uint32_t>(n_faces);
  // The face arrays sized side by side (resize writes each element's initial value).
  tbb::parallel_invoke([&] { s.faces.resize(n_faces); }, [&] { s.face_tags.resize(n_faces); },
                       [&] { s.face_centers_mm.resize(n_faces); });
  const double v = s.voxel_mm;
  tbb::parallel_for(0, box.n.y(), [&](int r) {
    const int by = box.lo.y() + r;
    const auto& list = exposed[static_cast<std::size_t>(r)];
    // A block's tag slots are read at random, a few per voxel row: the next block's are
    // fetched while this one is written (its view found one block ahead).
    const auto fetch_tags = [](const VoxelBlocks::BlockView& b) {
      if (b.wide != nullptr) return;
      for (int line = 0; line < 256; line += 64) __builtin_prefetch(b.nibbles + line);
      __builtin_prefetch(b.palette);
    };
    std::optional<VoxelBlocks::BlockView> next_view;
    if (!list.empty()) next_view = VoxelBlocks::block_view(grid, list[0].bx, by, list[0].bz);
    for (std::size_t c = 0; c < list.size(); ++c) {
      const Exposed& e = list[c];
      const VoxelBlocks::BlockView view = *next_view;
      if (c + 1 < list.size()) {
        next_view = VoxelBlocks::block_view(grid, list[c + 1].bx, by, list[c + 1].bz);
        fetch_tags(*next_view);
      }
      std::size_t next = s.face_cell_begin[8 * (row_blocks[static_cast<std::size_t>(r)] + c)];
      for (int cell = 0; cell < 8; ++cell) {
        const int y0 = 4 * (cell >> 2), x0 = 4 * ((cell >> 1) & 1), z0 = 4 * (cell & 1);
        for (int y = y0; y < y0 + 4; ++y) {
          const int ly = by * kE + y - kmin.y;
          for (int x = x0; x < x0 + 4; ++x) {
            const int lx = e.bx * kE + x - kmin.x;
            std::array<unsigned, 6> m{};
            unsigned all = 0;
            for (std::size_t d = 0; d < 6; ++d) {
              m[d] = static_cast<unsigned>((e.cols[d][static_cast<std::size_t>(y)] >> (8 * x)) &
                                           (0xFU << z0));
              all |= m[d];
            }
            while (all != 0) {
              const int z = std::countr_zero(all);
              all &= all - 1;
              const int lz = e.bz * kE + z - kmin.z;
              const VoxelTag tag = table[view.tag_index(z * 64 + y * 8 + x)];
              for (int d = 0; d < 6; ++d) {
                if (((m[static_cast<std::size_t>(d)] >> z) & 1U) == 0) continue;
                const int axis = d >> 1;
                const int side = (d & 1) != 0 ? +1 : -1;
                SurfaceFace& f = s.faces[next];
                f.voxel = VoxelKey{kmin.x + lx, kmin.y + ly, kmin.z + lz};
                f.axis = static_cast<std::uint8_t>(axis);
                f.side = static_cast<std::int8_t>(side);
                Vec3 ctr = s.origin_mm + v * Vec3(lx + 0.5, ly + 0.5, lz + 0.5);
                ctr[axis] += 0.5 * v * side;
                s.face_centers_mm[next] = ctr;
                s.face_tags[next++] = tag;
              }
            }
          }
        }
      }
    }
  });
  return s;
}

}  // namespace printtwin
