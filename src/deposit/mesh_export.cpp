// The as-printed part as a closed triangle mesh (see mesh_export.hpp for the model).
//
// Steps: the filled volume from the outer-surface routine (filled_volume_of, the one place
// that calls it) -> a blocked bit solid -> manifold repair -> exposed faces, sorted by plane
// -> rectangles -> vertices and T-junction splits -> triangles -> components (skirt and
// purge pieces dropped) -> optionally the same on coarser cells until the size fits.
#include "deposit/mesh_export.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <unordered_map>
#include <vector>

#include "core/plain_path.hpp"
#include "deposit/mesh_export_internal.hpp"
#include "deposit/voxel_blocks.hpp"
#include "deviation/outer_surface.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {

using Mask = std::array<std::uint64_t, 8>;
constexpr std::uint64_t kColX0 = 0x0101010101010101ull;
constexpr std::uint64_t kColX7 = 0x8080808080808080ull;
constexpr int kMaxCoord = 65535;  // lattice coordinates are packed in 16 bits

// ---------------------------------------------------------------- the solid

/// A set of cells on a blocked grid: cell (x, y, z) covers grid keys origin + s * (x, y, z)
/// .. + s - 1 on each axis. Blocks of 8^3 cells: code 0 empty, 1 full, k + 2 masks[k].
struct Solid {
  VoxelKey origin{};
  int cell = 1;
  Eigen::Vector3i nb = Eigen::Vector3i::Zero();  // blocks per axis
  std::vector<std::uint32_t> code;
  std::vector<Mask> masks;

  static constexpr std::uint32_t kEmpty = 0, kFull = 1;

  [[nodiscard]] Eigen::Vector3i dims() const { return nb * 8; }
  [[nodiscard]] bool block_in(int bx, int by, int bz) const {
    return bx >= 0 && by >= 0 && bz >= 0 && bx < nb.x() && by < nb.y() && bz < nb.z();
  }
  [[nodiscard]] std::size_t index(int bx, int by, int bz) const {
    return (static_cast<std::size_t>(bz) * static_cast<std::size_t>(nb.y()) +
            static_cast<std::size_t>(by)) *
               static_cast<std::size_t>(nb.x()) +
           static_cast<std::size_t>(bx);
  }
  [[nodiscard]] std::uint32_t code_at(int bx, int by, int bz) const {
    return block_in(bx, by, bz) ? code[index(bx, by, bz)] : kEmpty;
  }
  /// Slice z (0..7) of block (bx, by, bz): bit y * 8 + x.
  [[nodiscard]] std::uint64_t word(int bx, int by, int bz, int z) const {
    const std::uint32_t c = code_at(bx, by, bz);
    if (c == kEmpty) return 0;
    if (c == kFull) return ~0ull;
    return masks[c - 2][static_cast<std::size_t>(z)];
  }
  [[nodiscard]] bool get(int x, int y, int z) const {
    if (x < 0 || y < 0 || z < 0) return false;
    return ((word(x >> 3, y >> 3, z >> 3, z & 7) >> ((y & 7) * 8 + (x & 7))) & 1U) != 0;
  }
  Mask& mask_for_write(int bx, int by, int bz) {
    std::uint32_t& c = code[index(bx, by, bz)];
    if (c < 2) {
      Mask m;
      m.fill(c == kFull ? ~0ull : 0ull);
      masks.push_back(m);
      c = static_cast<std::uint32_t>(masks.size() + 1);
    }
    return masks[c - 2];
  }
  void set(int x, int y, int z, bool on) {
    if (x < 0 || y < 0 || z < 0 || !block_in(x >> 3, y >> 3, z >> 3)) return;
    Mask& m = mask_for_write(x >> 3, y >> 3, z >> 3);
    const std::uint64_t bit = 1ull << ((y & 7) * 8 + (x & 7));
    if (on)
      m[static_cast<std::size_t>(z & 7)] |= bit;
    else
      m[static_cast<std::size_t>(z & 7)] &= ~bit;
  }
  [[nodiscard]] std::size_t count() const {
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, code.size(), std::size_t{1} << 14), std::size_t{0},
        [this](const tbb::blocked_range<std::size_t>& r, std::size_t n) {
          for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const std::uint32_t c = code[i];
            if (c == kFull)
              n += 512;
            else if (c >= 2)
              for (const std::uint64_t w : masks[c - 2])
                n += static_cast<std::size_t>(std::popcount(w));
          }
          return n;
        },
        std::plus<>());
  }
  /// Grid key of the min corner of cell (x, y, z).
  [[nodiscard]] VoxelKey key_of_cell(int x, int y, int z) const {
    return {origin.x + cell * x, origin.y + cell * y, origin.z + cell * z};
  }
};

Solid empty_solid(const VoxelKey& origin, int cell, const Eigen::Vector3i& cells) {
  Solid s;
  s.origin = origin;
  s.cell = cell;
  s.nb = Eigen::Vector3i((cells.x() + 7) / 8, (cells.y() + 7) / 8, (cells.z() + 7) / 8);
  s.code.assign(static_cast<std::size_t>(s.nb.x()) * static_cast<std::size_t>(s.nb.y()) *
                    static_cast<std::size_t>(s.nb.z()),
                Solid::kEmpty);
  return s;
}

/// The grid with the auxiliary voxels the options include relabelled as unknown, so that the
/// outer-surface routine keeps them (it treats auxiliary features as air).
VoxelGrid with_included_features(const VoxelGrid& grid, const DepositMeshOptions& o) {
  VoxelGrid copy = grid;
  const auto& table = detail::VoxelBlocks::tag_table(grid);
  std::vector<std::int64_t> relabel(table.size(), -1);
  for (std::size_t i = 0; i < table.size(); ++i) {
    const Feature f = table[i].feature;
    const bool inc =
        (o.include_skirt && f == Feature::skirt) ||
        (o.include_support && (f == Feature::support || f == Feature::support_interface)) ||
        (o.include_custom && (f == Feature::custom || f == Feature::wipe_tower));
    if (!inc) continue;
    VoxelTag t = table[i];
    t.feature = Feature::unknown;
    relabel[i] = detail::VoxelBlocks::add_tag(copy, t);
  }
  std::vector<std::pair<VoxelKey, std::uint32_t>> changes;
  detail::VoxelBlocks::visit_blocks(grid, [&](const detail::VoxelBlocks::BlockView& b) {
    for (int z = 0; z < 8; ++z)
      for (std::uint64_t bits = b.occupancy[z]; bits != 0; bits &= bits - 1) {
        const int bit = std::countr_zero(bits);
        const std::uint32_t ti = b.tag_index(z * 64 + bit);
        if (relabel[ti] >= 0)
          changes.push_back({{b.base.x + (bit & 7), b.base.y + (bit >> 3), b.base.z + z},
                             static_cast<std::uint32_t>(relabel[ti])});
      }
  });
  for (const auto& [k, ti] : changes) detail::VoxelBlocks::set_index(copy, k, ti);
  return copy;
}

/// The filled volume of an outer surface as a Solid of single voxels whose origin is
/// block-aligned with the grid and padded by one empty block on every side.
Result<Solid> solid_of(const DepositSurface& surf) {
  if (surf.filled_blocks_dims.minCoeff() <= 0) return Solid{};
  const Eigen::Vector3i lo = surf.filled_blocks_lo - Eigen::Vector3i::Ones();
  const Eigen::Vector3i cells = (surf.filled_blocks_dims + Eigen::Vector3i(2, 2, 2)) * 8;
  if (cells.maxCoeff() > kMaxCoord)
    return usage_error("--deposit-mesh: the deposit spans " + std::to_string(cells.maxCoeff()) +
                       " voxels on one axis; at most " + std::to_string(kMaxCoord) +
                       " are supported (use a larger --voxel)");
  Solid s = empty_solid({lo.x() * 8, lo.y() * 8, lo.z() * 8}, 1, cells);
  // Region voxels only (the codes speak for the region's voxels of each block).
  const VoxelKey rlo = surf.origin_key;
  const VoxelKey rhi{rlo.x + surf.dims.x(), rlo.y + surf.dims.y(), rlo.z + surf.dims.z()};
  const Eigen::Vector3i& fd = surf.filled_blocks_dims;
  for (int by = 0; by < fd.y(); ++by)
    for (int bx = 0; bx < fd.x(); ++bx)
      for (int bz = 0; bz < fd.z(); ++bz) {
        const std::size_t i =
            (static_cast<std::size_t>(by) * fd.x() + static_cast<std::size_t>(bx)) * fd.z() +
            static_cast<std::size_t>(bz);
        const std::uint32_t c = surf.filled_block_code[i];
        if (c == DepositSurface::kNoneFilled) continue;
        const int gx = bx + surf.filled_blocks_lo.x(), gy = by + surf.filled_blocks_lo.y(),
                  gz = bz + surf.filled_blocks_lo.z();
        Mask m{};
        for (int z = 0; z < 8; ++z)
          m[static_cast<std::size_t>(z)] =
              c == DepositSurface::kAllFilled
                  ? ~0ull
                  : surf.filled_masks[c - DepositSurface::kFirstMask][static_cast<std::size_t>(z)];
        const bool inside = gx * 8 >= rlo.x && gy * 8 >= rlo.y && gz * 8 >= rlo.z &&
                            gx * 8 + 8 <= rhi.x && gy * 8 + 8 <= rhi.y && gz * 8 + 8 <= rhi.z;
        if (!inside)  // a block on the region's border: its voxels outside the region are air
          for (int slot = 0; slot < 512; ++slot) {
            const int kx = gx * 8 + (slot & 7), ky = gy * 8 + ((slot >> 3) & 7),
                      kz = gz * 8 + (slot >> 6);
            if (kx < rlo.x || ky < rlo.y || kz < rlo.z || kx >= rhi.x || ky >= rhi.y || kz >= rhi.z)
              m[static_cast<std::size_t>(slot >> 6)] &= ~(1ull << (slot & 63));
          }
        const int sbx = gx - lo.x(), sby = gy - lo.y(), sbz = gz - lo.z();
        std::uint32_t& dst = s.code[s.index(sbx, sby, sbz)];
        if (std::all_of(m.begin(), m.end(), [](std::uint64_t w) { return w == ~0ull; })) {
          dst = Solid::kFull;
        } else if (std::any_of(m.begin(), m.end(), [](std::uint64_t w) { return w != 0; })) {
          s.masks.push_back(m);
          dst = static_cast<std::uint32_t>(s.masks.size() + 1);
        }
      }
  return s;
}

/// True when the block holds a voxel of a feature the outer-surface routine keeps (not
/// auxiliary); `aux[t]`: tag index t is auxiliary.
bool has_part_voxel(const detail::VoxelBlocks::BlockView& b, const std::vector<char>& aux) {
  // Tag indices past the table (none expected) count as auxiliary.
  const auto is_aux = [&](std::uint32_t t) { return t >= aux.size() || aux[t] != 0; };
  bool any_aux = b.wide != nullptr;
  for (int e = 0; e < b.palette_size && !any_aux; ++e) any_aux = is_aux(b.palette[e]);
  for (int z = 0; z < 8; ++z)
    for (std::uint64_t bits = b.occupancy[z]; bits != 0; bits &= bits - 1)
      if (!any_aux || !is_aux(b.tag_index(z * 64 + std::countr_zero(bits)))) return true;
  return false;
}

/// The region the filled volume is extracted over: the grid's blocks, cut to `margin` voxels
/// (rounded up to whole blocks) around the blocks holding part voxels. Auxiliary voxels are
/// air to the outer-surface routine, and beyond the seal radius plus a voxel from the part the
/// region's border changes no filled voxel, so this gives the same voxels as the whole grid
/// without flooding the empty bed around a far skirt or purge line. The blocks are read in
/// their memory order (one pass over the grid's storage) and bounded in keys; a voxel's centre
/// grows with its key, so the box is that of the extreme keys' centres.
Box3 filled_region(const VoxelGrid& g, int margin) {
  const auto& table = detail::VoxelBlocks::tag_table(g);
  std::vector<char> aux(table.size());
  for (std::size_t i = 0; i < table.size(); ++i)
    aux[i] = is_auxiliary_feature(table[i].feature) ? 1 : 0;
  constexpr int kE = detail::VoxelBlocks::kBlockEdge;
  const int m = (margin + kE - 1) / kE * kE;
  constexpr int kBig = std::numeric_limits<int>::max();
  VoxelKey all_lo{kBig, kBig, kBig}, all_hi{-kBig, -kBig, -kBig};
  VoxelKey part_lo = all_lo, part_hi = all_hi;
  const auto extend = [](VoxelKey& lo, VoxelKey& hi, const VoxelKey& a, const VoxelKey& b) {
    lo = {std::min(lo.x, a.x), std::min(lo.y, a.y), std::min(lo.z, a.z)};
    hi = {std::max(hi.x, b.x), std::max(hi.y, b.y), std::max(hi.z, b.z)};
  };
  detail::VoxelBlocks::visit_blocks_as_allocated(g, [&](const detail::VoxelBlocks::BlockView& b) {
    const VoxelKey last{b.base.x + kE - 1, b.base.y + kE - 1, b.base.z + kE - 1};
    extend(all_lo, all_hi, b.base, last);
    if (!has_part_voxel(b, aux)) return;
    extend(part_lo, part_hi, {b.base.x - m, b.base.y - m, b.base.z - m},
           {last.x + m, last.y + m, last.z + m});
  });
  Box3 all, part;
  if (all_lo.x <= all_hi.x) {
    all.extend(g.center_mm(all_lo));
    all.extend(g.center_mm(all_hi));
  }
  if (part_lo.x > part_hi.x) return all;
  part.extend(g.center_mm(part_lo));
  part.extend(g.center_mm(part_hi));
  Box3 cut;
  cut.min = all.min.cwiseMax(part.min);
  cut.max = all.max.cwiseMin(part.max);
  return cut;
}

/// Adapter to the deposit's outer-surface routine (the lead re-points it when the routines
/// are unified): the filled volume (occupied voxels plus the cavities the outside air does
/// not reach) of the non-auxiliary voxels, as solid_of gives it; `given` (may be null): the
/// deviation stage's, used unless auxiliary features are included.
Result<Solid> filled_volume_of(const VoxelGrid& grid, const DepositMeshOptions& o,
                               const DepositSurface* given) {
  const bool relabel = o.include_skirt || o.include_support || o.include_custom;
  if (given != nullptr && !relabel) return solid_of(*given);
  std::optional<VoxelGrid> relabelled;
  if (relabel) relabelled.emplace(with_included_features(grid, o));
  const VoxelGrid& g = relabelled ? *relabelled : grid;
  // Sealed as the deviation stage seals it: pinholes between beads do not let the outside
  // into the infill, layer grooves stay surface.
  const DeviationSettings sealed;
  const int seal_r = static_cast<int>(std::floor(sealed.seal_gap_mm / (2 * g.voxel_mm()) + 1e-9));
  const Box3 box = filled_region(g, seal_r + 2);
  if (box.empty()) return Solid{};
  const DepositSurface surf =
      extract_filled_volume(g, box, sealed.seal_gap_mm, sealed.groove_depth_mm);
  return solid_of(surf);
}

/// Runs fn(bz, out) for every block layer bz in parallel, each appending to its own vector,
/// and returns the vectors joined in layer order (the same result on any thread count).
template <class T, class Fn>
std::vector<T> per_block_layer(int layers, Fn&& fn) {
  std::vector<std::vector<T>> parts(static_cast<std::size_t>(std::max(layers, 0)));
  tbb::parallel_for(0, layers, [&](int bz) { fn(bz, parts[static_cast<std::size_t>(bz)]); });
  std::size_t total = 0;
  for (const auto& p : parts) total += p.size();
  std::vector<T> out;
  out.reserve(total);
  for (auto& p : parts) {
    out.insert(out.end(), p.begin(), p.end());
    p = {};
  }
  return out;
}

// ---------------------------------------------------------------- slices of neighbours

/// Voxel (x + 1, y) in lane y * 8 + x, from a slice and the slice of the +x block.
std::uint64_t next_x(std::uint64_t w, std::uint64_t wx) {
  return ((w >> 1) & ~kColX7) | ((wx & kColX0) << 7);
}
/// Voxel (x - 1, y), from a slice and the slice of the -x block.
std::uint64_t prev_x(std::uint64_t w, std::uint64_t wx) {
  return ((w << 1) & ~kColX0) | ((wx & kColX7) >> 7);
}
std::uint64_t next_y(std::uint64_t w, std::uint64_t wy) { return (w >> 8) | (wy << 56); }
std::uint64_t prev_y(std::uint64_t w, std::uint64_t wy) { return (w << 8) | (wy >> 56); }

/// The four cells (x, y), (x+1, y), (x, y+1), (x+1, y+1) of slice z of block (bx, by, bz), one
/// lane per (x, y).
std::array<std::uint64_t, 4> quad(const Solid& s, int bx, int by, int bz, int z) {
  const int zb = bz + (z >> 3), zz = z & 7;
  const std::uint64_t w = s.word(bx, by, zb, zz), wx = s.word(bx + 1, by, zb, zz);
  const std::uint64_t wy = s.word(bx, by + 1, zb, zz), wxy = s.word(bx + 1, by + 1, zb, zz);
  const std::uint64_t b = next_x(w, wx);
  return {w, b, next_y(w, wy), next_y(b, next_x(wy, wxy))};
}

// ---------------------------------------------------------------- manifold repair

// Cell i of a 2x2x2 cube: (i & 1, i >> 1 & 1, i >> 2).
constexpr std::array<std::array<int, 4>, 6> kSquares = {
    {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 4, 5}, {2, 3, 6, 7}, {0, 2, 4, 6}, {1, 3, 5, 7}}};

/// The cell to fill for a cube configuration (bit i: cell i filled), or -1 when the
/// configuration is well-composed.
std::array<std::int16_t, 256> make_fill_table() {
  std::array<std::int16_t, 256> t{};
  for (int cfg = 0; cfg < 256; ++cfg) {
    auto in = [&](int i) { return ((cfg >> i) & 1) != 0; };
    int fill = -1;
    for (const auto& q : kSquares) {  // p q / r s with p-s and q-r diagonal
      const int p = q[0], a = q[1], b = q[2], d = q[3];
      if (in(p) && in(d) && !in(a) && !in(b))
        fill = std::min(a, b);
      else if (in(a) && in(b) && !in(p) && !in(d))
        fill = std::min(p, d);
      if (fill >= 0) break;
    }
    if (fill < 0)
      for (int i = 0; i < 4; ++i) {
        const int pair = (1 << i) | (1 << (7 - i));
        if (cfg == pair)
          fill = i ^ 1;  // two opposite corners alone: join them
        else if (cfg == (255 & ~pair))
          fill = i;  // two opposite corners empty: fill one
        if (fill >= 0) break;
      }
    t[static_cast<std::size_t>(cfg)] = static_cast<std::int16_t>(fill);
  }
  return t;
}

/// Fills cells until no critical configuration is left; returns how many were filled.
std::size_t make_well_composed(Solid& s) {
  static const std::array<std::int16_t, 256> kFill = make_fill_table();
  using Cell = std::array<int, 3>;
  auto work = per_block_layer<Cell>(s.nb.z(), [&](int bz, std::vector<Cell>& found) {
    for (int by = 0; by < s.nb.y(); ++by)
      for (int bx = 0; bx < s.nb.x(); ++bx) {
        // Cubes with their min cell in this block touch the blocks b + {0,1}^3 only.
        const std::uint32_t c0 = s.code[s.index(bx, by, bz)];
        bool uniform = c0 < 2;
        for (int d = 1; d < 8 && uniform; ++d)
          uniform = s.code_at(bx + (d & 1), by + ((d >> 1) & 1), bz + (d >> 2)) == c0;
        if (uniform) continue;
        for (int z = 0; z < 8; ++z) {
          const auto lo = quad(s, bx, by, bz, z), hi = quad(s, bx, by, bz, z + 1);
          const std::array<std::uint64_t, 8> v = {lo[0], lo[1], lo[2], lo[3],
                                                  hi[0], hi[1], hi[2], hi[3]};
          std::uint64_t bad = 0;
          for (const auto& q : kSquares) {
            const std::uint64_t p = v[q[0]], a = v[q[1]], b = v[q[2]], d = v[q[3]];
            bad |= (p & d & ~a & ~b) | (a & b & ~p & ~d);
          }
          for (int i = 0; i < 4; ++i) {
            std::uint64_t others_in = ~0ull, others_out = ~0ull;
            for (int j = 0; j < 8; ++j)
              if (j != i && j != 7 - i) {
                others_in &= v[j];
                others_out &= ~v[j];
              }
            bad |= (v[i] & v[7 - i] & others_out) | (~v[i] & ~v[7 - i] & others_in);
          }
          for (; bad != 0; bad &= bad - 1) {
            const int bit = std::countr_zero(bad);
            found.push_back({bx * 8 + (bit & 7), by * 8 + (bit >> 3), bz * 8 + z});
          }
        }
      }
  });
  std::size_t filled = 0;
  while (!work.empty()) {
    const auto c = work.back();
    work.pop_back();
    int cfg = 0;
    for (int i = 0; i < 8; ++i)
      if (s.get(c[0] + (i & 1), c[1] + ((i >> 1) & 1), c[2] + (i >> 2))) cfg |= 1 << i;
    const int f = kFill[static_cast<std::size_t>(cfg)];
    if (f < 0) continue;
    const int x = c[0] + (f & 1), y = c[1] + ((f >> 1) & 1), z = c[2] + (f >> 2);
    s.set(x, y, z, true);
    ++filled;
    for (int i = 0; i < 8; ++i) work.push_back({x - (i & 1), y - ((i >> 1) & 1), z - (i >> 2)});
    work.push_back(c);
  }
  return filled;
}

// ---------------------------------------------------------------- faces and rectangles

/// Exposed face key: axis (2 bits) | side (1) | plane coordinate c (16) | v (16) | u (16),
/// (u, v) the two other axes in cyclic order (a + 1, a + 2), so e_u x e_v = e_a.
std::uint64_t face_key(int axis, int side, int c, int u, int v) {
  return (static_cast<std::uint64_t>(axis) << 49) | (static_cast<std::uint64_t>(side) << 48) |
         (static_cast<std::uint64_t>(c) << 32) | (static_cast<std::uint64_t>(v) << 16) |
         static_cast<std::uint64_t>(u);
}

std::vector<std::uint64_t> exposed_faces(const Solid& s) {
  auto keys = per_block_layer<std::uint64_t>(s.nb.z(), [&](int bz,
                                                           std::vector<std::uint64_t>& out) {
    auto emit = [&](std::uint64_t bits, int axis, int side, int bx, int by, int z) {
      for (; bits != 0; bits &= bits - 1) {
        const int bit = std::countr_zero(bits);
        const int x = bx * 8 + (bit & 7), y = by * 8 + (bit >> 3), zz = bz * 8 + z;
        const std::array<int, 3> p = {x, y, zz};
        const int u = p[static_cast<std::size_t>((axis + 1) % 3)],
                  v = p[static_cast<std::size_t>((axis + 2) % 3)];
        out.push_back(face_key(axis, side, p[static_cast<std::size_t>(axis)] + side, u, v));
      }
    };
    for (int by = 0; by < s.nb.y(); ++by)
      for (int bx = 0; bx < s.nb.x(); ++bx) {
        const std::uint32_t c = s.code[s.index(bx, by, bz)];
        if (c == Solid::kEmpty) continue;
        if (c == Solid::kFull && s.code_at(bx - 1, by, bz) == Solid::kFull &&
            s.code_at(bx + 1, by, bz) == Solid::kFull &&
            s.code_at(bx, by - 1, bz) == Solid::kFull &&
            s.code_at(bx, by + 1, bz) == Solid::kFull &&
            s.code_at(bx, by, bz - 1) == Solid::kFull && s.code_at(bx, by, bz + 1) == Solid::kFull)
          continue;
        for (int z = 0; z < 8; ++z) {
          const std::uint64_t w = s.word(bx, by, bz, z);
          if (w == 0) continue;
          emit(w & ~prev_x(w, s.word(bx - 1, by, bz, z)), 0, 0, bx, by, z);
          emit(w & ~next_x(w, s.word(bx + 1, by, bz, z)), 0, 1, bx, by, z);
          emit(w & ~prev_y(w, s.word(bx, by - 1, bz, z)), 1, 0, bx, by, z);
          emit(w & ~next_y(w, s.word(bx, by + 1, bz, z)), 1, 1, bx, by, z);
          const std::uint64_t below = z > 0 ? s.word(bx, by, bz, z - 1) : s.word(bx, by, bz - 1, 7);
          const std::uint64_t above = z < 7 ? s.word(bx, by, bz, z + 1) : s.word(bx, by, bz + 1, 0);
          emit(w & ~below, 2, 0, bx, by, z);
          emit(w & ~above, 2, 1, bx, by, z);
        }
      }
  });
  detail::radix_sort(keys, nullptr);
  return keys;
}

struct Rect {
  std::uint8_t axis = 0, side = 0;
  int c = 0, u0 = 0, u1 = 0, v0 = 0, v1 = 0;  // lattice: [u0, u1] x [v0, v1] at coordinate c
};

/// Runs of faces along u, stacked along v while their extent is equal.
std::vector<Rect> merge_faces(const std::vector<std::uint64_t>& keys) {
  std::vector<Rect> rects;
  std::vector<std::size_t> open, next_open;  // rectangles ending at the previous row, by u0
  std::uint64_t plane = ~0ull;
  int row = -2;
  std::size_t oi = 0;
  for (std::size_t i = 0; i < keys.size();) {
    const std::uint64_t k = keys[i];
    const std::uint64_t pl = k >> 32;
    const int v = static_cast<int>((k >> 16) & 0xFFFF), u0 = static_cast<int>(k & 0xFFFF);
    std::size_t j = i + 1;
    while (j < keys.size() && (keys[j] >> 16) == (k >> 16) &&
           static_cast<int>(keys[j] & 0xFFFF) == u0 + static_cast<int>(j - i))
      ++j;
    const int u1 = u0 + static_cast<int>(j - i);
    if (pl != plane || v != row) {  // a new row: the rectangles of the row before may grow
      if (pl == plane && v == row + 1)
        open.swap(next_open);
      else
        open.clear();
      next_open.clear();
      oi = 0;
      plane = pl;
      row = v;
    }
    while (oi < open.size() && rects[open[oi]].u0 < u0) ++oi;
    if (oi < open.size() && rects[open[oi]].u0 == u0 && rects[open[oi]].u1 == u1) {
      rects[open[oi]].v1 = v + 1;
      next_open.push_back(open[oi]);
      ++oi;
    } else {
      Rect r;
      r.axis = static_cast<std::uint8_t>(pl >> 17);
      r.side = static_cast<std::uint8_t>((pl >> 16) & 1);
      r.c = static_cast<int>(pl & 0xFFFF);
      r.u0 = u0;
      r.u1 = u1;
      r.v0 = v;
      r.v1 = v + 1;
      next_open.push_back(rects.size());
      rects.push_back(r);
    }
    i = j;
  }
  return rects;
}

// ---------------------------------------------------------------- triangles

std::array<int, 3> lattice_point(int axis, int c, int u, int v) {
  std::array<int, 3> p{};
  p[static_cast<std::size_t>(axis)] = c;
  p[static_cast<std::size_t>((axis + 1) % 3)] = u;
  p[static_cast<std::size_t>((axis + 2) % 3)] = v;
  return p;
}

std::uint32_t find_root(std::vector<std::uint32_t>& parent, std::uint32_t i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

struct Triangulated {
  Mesh mesh;
  std::vector<std::uint32_t> rect_of_triangle;
  std::vector<std::uint32_t> rect_vertex;  ///< a corner vertex of each rectangle
  /// Union-find forest over the vertices: joined when they bound one rectangle.
  std::vector<std::uint32_t> parent;
};

/// The mesh's vertices as bits on the solid's lattice: point p in the block p >> 3 (the
/// solid's empty padding keeps every surface point inside its blocks), bit
/// (z & 7) * 64 + (y & 7) * 8 + (x & 7); vertex ids follow the blocks' order, then the bits.
class VertexLattice {
 public:
  VertexLattice(const Solid& s, const std::vector<Rect>& rects) : s_(s) {
    slot_.assign(s.code.size(), kNone);
    for (const Rect& r : rects)
      for (int k = 0; k < 4; ++k) slot_[block_of(corner_point(r, k))] = 0;
    std::uint32_t n = 0;
    for (std::size_t b = 0; b < slot_.size(); ++b)
      if (slot_[b] == 0) {
        slot_[b] = n++;
        block_.push_back(static_cast<std::uint32_t>(b));
      }
    masks_.assign(n, Mask{});
    for (const Rect& r : rects)
      for (int k = 0; k < 4; ++k) {
        const auto p = corner_point(r, k);
        masks_[slot_[block_of(p)]][static_cast<std::size_t>(p[2] & 7)] |= bit_of(p);
      }
    // First id of each slice (slot k, slice z): base_[8 k + z]; base_[8 n] = the count.
    base_.resize(8 * static_cast<std::size_t>(n) + 1);
    std::uint32_t sum = 0;
    for (std::uint32_t k = 0; k < n; ++k)
      for (std::size_t z = 0; z < 8; ++z) {
        base_[8 * static_cast<std::size_t>(k) + z] = sum;
        sum += static_cast<std::uint32_t>(std::popcount(masks_[k][z]));
      }
    base_.back() = sum;
  }

  [[nodiscard]] std::uint32_t size() const { return base_.back(); }

  /// Id of a vertex point.
  [[nodiscard]] std::uint32_t id(const std::array<int, 3>& p) const {
    const std::uint32_t k = slot_[block_of(p)];
    const auto z = static_cast<std::size_t>(p[2] & 7);
    return base_[8 * static_cast<std::size_t>(k) + z] +
           static_cast<std::uint32_t>(std::popcount(masks_[k][z] & (bit_of(p) - 1)));
  }

  /// Appends the ids of the vertices strictly between the corners k and k + 1 of r, from
  /// corner k's end (the loop's direction); returns how many.
  int side_points(const Rect& r, int k, std::vector<std::uint32_t>& out) const {
    const int t = k % 2 == 0 ? (r.axis + 1) % 3 : (r.axis + 2) % 3;
    const int lo = k % 2 == 0 ? r.u0 : r.v0, hi = k % 2 == 0 ? r.u1 : r.v1;
    if (hi - lo < 2) return 0;
    auto p = corner_point(r, k);
    const std::size_t at = out.size();
    std::uint32_t k_slot = kNone;
    int block = -1;
    for (int q = lo + 1; q < hi; ++q) {
      p[static_cast<std::size_t>(t)] = q;
      if ((q >> 3) != block) {
        block = q >> 3;
        k_slot = slot_[block_of(p)];
      }
      if (k_slot == kNone) {  // no vertex in this block: skip to the next one
        q = (block << 3) + 7;
        continue;
      }
      if ((masks_[k_slot][static_cast<std::size_t>(p[2] & 7)] & bit_of(p)) != 0)
        out.push_back(id(p));
    }
    if (k >= 2) std::reverse(out.begin() + static_cast<std::ptrdiff_t>(at), out.end());
    return static_cast<int>(out.size() - at);
  }

  /// Lattice point of every vertex, in id order.
  template <class Fn>
  void each_vertex(Fn&& fn) const {
    for (std::size_t k = 0; k < block_.size(); ++k) {
      const std::uint32_t b = block_[k];
      const auto nx = static_cast<std::uint32_t>(s_.nb.x()),
                 ny = static_cast<std::uint32_t>(s_.nb.y());
      const int bx = static_cast<int>(b % nx), by = static_cast<int>((b / nx) % ny),
                bz = static_cast<int>(b / nx / ny);
      for (int z = 0; z < 8; ++z)
        for (std::uint64_t w = masks_[k][static_cast<std::size_t>(z)]; w != 0; w &= w - 1) {
          const int bit = std::countr_zero(w);
          fn(std::array<int, 3>{bx * 8 + (bit & 7), by * 8 + (bit >> 3), bz * 8 + z});
        }
    }
  }

  static std::array<int, 3> corner_point(const Rect& r, int k) {
    return lattice_point(r.axis, r.c, (k == 1 || k == 2) ? r.u1 : r.u0, k >= 2 ? r.v1 : r.v0);
  }

 private:
  static constexpr std::uint32_t kNone = ~0U;
  [[nodiscard]] std::size_t block_of(const std::array<int, 3>& p) const {
    return s_.index(p[0] >> 3, p[1] >> 3, p[2] >> 3);
  }
  static std::uint64_t bit_of(const std::array<int, 3>& p) {
    return 1ull << ((p[1] & 7) * 8 + (p[0] & 7));
  }
  const Solid& s_;
  std::vector<std::uint32_t> slot_;   // per block of the solid
  std::vector<std::uint32_t> block_;  // per slot
  std::vector<Mask> masks_;
  std::vector<std::uint32_t> base_;
};

/// The boundary loop of a rectangle (counter-clockwise seen from +axis): its corners with
/// the vertices lying on its sides; `count[k]` points on side k, `start[k]` corner k's index.
struct RectLoop {
  std::vector<std::uint32_t> ids;
  std::array<int, 4> start{}, count{};
  void build(const VertexLattice& lattice, const Rect& r) {
    ids.clear();
    for (int k = 0; k < 4; ++k) {
      start[static_cast<std::size_t>(k)] = static_cast<int>(ids.size());
      ids.push_back(lattice.id(VertexLattice::corner_point(r, k)));
      count[static_cast<std::size_t>(k)] = lattice.side_points(r, k, ids);
    }
  }
  /// A corner whose two sides carry no inserted point (a fan from it has no degenerate
  /// triangle), or -1: then a fan from the rectangle's centre.
  [[nodiscard]] int apex() const {
    for (int k = 0; k < 4; ++k)
      if (count[static_cast<std::size_t>(k)] == 0 &&
          count[static_cast<std::size_t>((k + 3) % 4)] == 0)
        return start[static_cast<std::size_t>(k)];
    return -1;
  }
};

/// The boundary loops of a run of rectangles, built once: loop k is
/// ids[begin[k] .. begin[k + 1]), with its fan apex (-1: a fan from the centre).
struct LoopChunk {
  std::vector<std::uint32_t> ids;
  std::vector<std::uint32_t> begin{0};
  std::vector<std::int32_t> apex;
};

/// Triangles of the rectangles, with every rectangle corner that lies on another
/// rectangle's side inserted into that side (no T-junctions). Vertices are found on a bit
/// lattice; the rectangles' loops are built in parallel chunks, counted, then the triangles
/// written at their offsets (the result does not depend on the threads).
Triangulated triangulate(const Solid& s, const std::vector<Rect>& rects, double voxel_mm,
                         const Vec3& grid_origin_mm) {
  const std::size_t nr = rects.size();
  const VertexLattice lattice(s, rects);
  Triangulated out;
  Mesh& m = out.mesh;
  const double step = voxel_mm * s.cell;
  const Vec3 base = grid_origin_mm + voxel_mm * Vec3(s.origin.x, s.origin.y, s.origin.z);
  const std::uint32_t nv = lattice.size();
  m.vertices_mm.reserve(nv + nr / 8);
  lattice.each_vertex([&](const std::array<int, 3>& p) {
    m.vertices_mm.push_back(base + step * Vec3(p[0], p[1], p[2]));
  });
  // Pass 1: each rectangle's loop, and its triangles (n - 2 for a corner fan, n from the
  // centre).
  constexpr std::size_t kChunk = 4096;
  const std::size_t chunks = (nr + kChunk - 1) / kChunk;
  std::vector<LoopChunk> loops(chunks);
  std::vector<std::uint32_t> tri_begin(nr + 1, 0);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    RectLoop loop;
    LoopChunk& lc = loops[c];
    const std::size_t r0 = c * kChunk, r1 = std::min(nr, (c + 1) * kChunk);
    lc.ids.reserve(8 * (r1 - r0));
    lc.apex.reserve(r1 - r0);
    for (std::size_t ri = r0; ri < r1; ++ri) {
      loop.build(lattice, rects[ri]);
      const auto n = static_cast<std::uint32_t>(loop.ids.size());
      const int apex = loop.apex();
      lc.ids.insert(lc.ids.end(), loop.ids.begin(), loop.ids.end());
      lc.begin.push_back(static_cast<std::uint32_t>(lc.ids.size()));
      lc.apex.push_back(apex);
      tri_begin[ri + 1] = apex < 0 ? n : n - 2;
    }
  });
  for (std::size_t i = 0; i < nr; ++i) tri_begin[i + 1] += tri_begin[i];
  std::vector<std::uint32_t> centre_id(nr, 0);
  for (std::size_t ri = 0; ri < nr; ++ri) {
    if (loops[ri / kChunk].apex[ri % kChunk] >= 0) continue;
    const Rect& r = rects[ri];
    centre_id[ri] = static_cast<std::uint32_t>(m.vertices_mm.size());
    const auto p = lattice_point(r.axis, r.c, 0, 0);
    Vec3 cp = base + step * Vec3(p[0], p[1], p[2]);
    cp[(r.axis + 1) % 3] += step * 0.5 * (r.u0 + r.u1);
    cp[(r.axis + 2) % 3] += step * 0.5 * (r.v0 + r.v1);
    m.vertices_mm.push_back(cp);
  }
  m.triangles.resize(tri_begin[nr]);
  out.rect_of_triangle.resize(tri_begin[nr]);
  out.rect_vertex.resize(nr);
  // Pass 2: the triangles at their offsets.
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    const LoopChunk& lc = loops[c];
    for (std::size_t ri = c * kChunk; ri < std::min(nr, (c + 1) * kChunk); ++ri) {
      const std::size_t k = ri - c * kChunk;
      const std::uint32_t* l = lc.ids.data() + lc.begin[k];
      const std::size_t n = lc.begin[k + 1] - lc.begin[k];
      out.rect_vertex[ri] = l[0];
      const bool flip = rects[ri].side == 0;  // the loop runs counter-clockwise seen from +axis
      std::size_t at = tri_begin[ri];
      auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t d) {
        m.triangles[at] =
            flip ? std::array<std::uint32_t, 3>{a, d, b} : std::array<std::uint32_t, 3>{a, b, d};
        out.rect_of_triangle[at++] = static_cast<std::uint32_t>(ri);
      };
      const int apex = lc.apex[k];
      if (apex >= 0) {
        const auto a0 = static_cast<std::size_t>(apex);
        for (std::size_t i = 1; i + 1 < n; ++i) add(l[a0], l[(a0 + i) % n], l[(a0 + i + 1) % n]);
      } else {
        for (std::size_t i = 0; i < n; ++i) add(centre_id[ri], l[i], l[(i + 1) % n]);
      }
    }
  });
  // Components: the vertices of each rectangle's loop (its triangles fan over them) joined.
  out.parent.resize(m.vertices_mm.size());
  std::iota(out.parent.begin(), out.parent.end(), 0U);
  for (std::size_t c = 0; c < chunks; ++c) {
    const LoopChunk& lc = loops[c];
    for (std::size_t k = 0; k < lc.apex.size(); ++k) {
      const std::uint32_t root = find_root(out.parent, lc.ids[lc.begin[k]]);
      for (std::uint32_t i = lc.begin[k] + 1; i < lc.begin[k + 1]; ++i) {
        const std::uint32_t r = find_root(out.parent, lc.ids[i]);
        if (r != root) out.parent[r] = root;
      }
      if (lc.apex[k] < 0) out.parent[centre_id[c * kChunk + k]] = root;  // a root of its own
    }
  }
  return out;
}

// ---------------------------------------------------------------- components

bool is_part_feature(Feature f) {
  switch (f) {
    case Feature::outer_perimeter:
    case Feature::perimeter:
    case Feature::overhang_perimeter:
    case Feature::sparse_infill:
    case Feature::solid_infill:
    case Feature::top_solid_infill:
    case Feature::bridge_infill:
    case Feature::gap_fill:
      return true;
    default:
      return false;
  }
}

bool kept_feature(Feature f, const DepositMeshOptions& o) {
  return is_part_feature(f) || (o.include_skirt && f == Feature::skirt) ||
         (o.include_support && (f == Feature::support || f == Feature::support_interface)) ||
         (o.include_custom && (f == Feature::custom || f == Feature::wipe_tower));
}

/// The cell inside the solid behind a rectangle's first face.
std::array<int, 3> inner_cell(const Rect& r) {
  return lattice_point(r.axis, r.side == 1 ? r.c - 1 : r.c, r.u0, r.v0);
}

struct Pieces {
  std::vector<std::uint32_t> component_of_rect;
  std::vector<bool> keep;  // per component
};

/// Connected pieces of the surface and which of them are part (see mesh_export.hpp).
Pieces classify(const Solid& s, const std::vector<Rect>& rects, Triangulated& t,
                const VoxelGrid& grid, const DepositMeshOptions& o) {
  std::vector<std::uint32_t> parent = std::move(t.parent);
  Pieces p;
  p.component_of_rect.assign(rects.size(), 0);
  std::vector<std::uint32_t> id(parent.size(), ~0U);
  std::uint32_t n = 0;
  for (std::size_t ri = 0; ri < rects.size(); ++ri) {
    const std::uint32_t root = find_root(parent, t.rect_vertex[ri]);
    if (id[root] == ~0U) id[root] = n++;
    p.component_of_rect[ri] = id[root];
  }
  bool tagged = false;
  for (const auto& tag : detail::VoxelBlocks::tag_table(grid))
    tagged |= kept_feature(tag.feature, o);
  std::vector<char> has_part(n, 0);
  std::vector<int> layer_min(n, 1 << 30), layer_max(n, -1);
  for (std::size_t ri = 0; ri < rects.size(); ++ri) {
    const std::uint32_t c = p.component_of_rect[ri];
    if (tagged && has_part[c]) continue;
    const auto cell = inner_cell(rects[ri]);
    const VoxelKey k0 = s.key_of_cell(cell[0], cell[1], cell[2]);
    for (int i = 0; i < s.cell * s.cell * s.cell; ++i) {
      const VoxelKey k{k0.x + i % s.cell, k0.y + (i / s.cell) % s.cell,
                       k0.z + i / (s.cell * s.cell)};
      const auto tag = grid.tag(k);
      if (!tag) continue;
      if (kept_feature(tag->feature, o)) has_part[c] = 1;
      layer_min[c] = std::min(layer_min[c], tag->layer);
      layer_max[c] = std::max(layer_max[c], tag->layer);
    }
  }
  p.keep.assign(n, false);
  bool any = false;
  for (std::uint32_t c = 0; c < n; ++c) {
    p.keep[c] = tagged ? has_part[c] != 0 : layer_max[c] > layer_min[c];
    any |= p.keep[c];
  }
  if (!tagged && !any) p.keep.assign(n, true);  // every piece one layer tall: keep them all
  return p;
}

/// Clears the 6-connected piece of the solid holding `seed`; returns the cells cleared.
std::size_t clear_piece(Solid& s, const std::array<int, 3>& seed) {
  std::size_t cleared = 0;
  std::vector<std::array<int, 3>> stack{seed};
  while (!stack.empty()) {
    const auto c = stack.back();
    stack.pop_back();
    if (!s.get(c[0], c[1], c[2])) continue;
    s.set(c[0], c[1], c[2], false);
    ++cleared;
    for (int a = 0; a < 3; ++a)
      for (int d = -1; d <= 1; d += 2) {
        auto n = c;
        n[static_cast<std::size_t>(a)] += d;
        stack.push_back(n);
      }
  }
  return cleared;
}

/// The solid on cells of `factor` of its own cells (a cell is filled when any is).
Solid coarsen(const Solid& fine, int factor) {
  // One empty block of padding below: coarse cell X covers fine cells (X - 8) * f ...
  const VoxelKey origin{fine.origin.x - 8 * factor * fine.cell,
                        fine.origin.y - 8 * factor * fine.cell,
                        fine.origin.z - 8 * factor * fine.cell};
  const Eigen::Vector3i cells = (fine.dims().array() + factor - 1) / factor + 16;
  Solid c = empty_solid(origin, fine.cell * factor, cells);
  for (int bz = 0; bz < fine.nb.z(); ++bz)
    for (int by = 0; by < fine.nb.y(); ++by)
      for (int bx = 0; bx < fine.nb.x(); ++bx) {
        const std::uint32_t code = fine.code[fine.index(bx, by, bz)];
        if (code == Solid::kEmpty) continue;
        for (int z = 0; z < 8; ++z) {
          const std::uint64_t w = fine.word(bx, by, bz, z);
          const int cz = (bz * 8 + z) / factor + 8;
          std::uint64_t done = 0;  // lanes whose coarse cell was set already in this slice
          for (std::uint64_t bits = w; bits != 0; bits &= bits - 1) {
            const int bit = std::countr_zero(bits);
            if ((done >> bit) & 1U) continue;
            const int cx = (bx * 8 + (bit & 7)) / factor + 8,
                      cy = (by * 8 + (bit >> 3)) / factor + 8;
            c.set(cx, cy, cz, true);
            // Lanes of the same coarse cell in this slice need no second set.
            for (int y = 0; y < 8; ++y)
              if ((by * 8 + y) / factor + 8 == cy)
                for (int x = 0; x < 8; ++x)
                  if ((bx * 8 + x) / factor + 8 == cx) done |= 1ull << (y * 8 + x);
          }
        }
      }
  return c;
}

struct Built {
  Triangulated tris;
  std::vector<Rect> rects;
  std::size_t repaired = 0;
};

Built mesh_solid(Solid& s, double voxel_mm, const Vec3& origin_mm) {
  Built b;
  b.repaired = make_well_composed(s);
  b.rects = merge_faces(exposed_faces(s));
  b.tris = triangulate(s, b.rects, voxel_mm, origin_mm);
  return b;
}

/// The volume the closed mesh encloses (signed tetrahedra against a point near the mesh),
/// summed in fixed chunks in parallel and added in chunk order (the same on any thread count).
double enclosed_volume_mm3(const Mesh& m) {
  if (m.triangles.empty()) return 0.0;
  const Vec3 ref = m.vertices_mm[m.triangles[0][0]];
  constexpr std::size_t kChunk = std::size_t{1} << 16;
  const std::size_t n = m.triangles.size(), chunks = (n + kChunk - 1) / kChunk;
  std::vector<double> part(chunks, 0.0);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    double six_v = 0;
    for (std::size_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i) {
      const auto& t = m.triangles[i];
      const Vec3 a = m.vertices_mm[t[0]] - ref, b = m.vertices_mm[t[1]] - ref,
                 d = m.vertices_mm[t[2]] - ref;
      six_v += a.dot(b.cross(d));
    }
    part[c] = six_v;
  });
  return std::accumulate(part.begin(), part.end(), 0.0) / 6.0;
}

/// Keeps the triangles of the kept components, with their vertices renumbered.
Mesh kept_part(const Triangulated& t, const Pieces& p) {
  Mesh out;
  std::vector<std::uint32_t> remap(t.mesh.vertices_mm.size(), ~0U);
  for (std::size_t ti = 0; ti < t.mesh.triangles.size(); ++ti) {
    if (!p.keep[p.component_of_rect[t.rect_of_triangle[ti]]]) continue;
    std::array<std::uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& r = remap[t.mesh.triangles[ti][static_cast<std::size_t>(k)]];
      if (r == ~0U) {
        r = static_cast<std::uint32_t>(out.vertices_mm.size());
        out.vertices_mm.push_back(
            t.mesh.vertices_mm[t.mesh.triangles[ti][static_cast<std::size_t>(k)]]);
      }
      tri[static_cast<std::size_t>(k)] = r;
    }
    out.triangles.push_back(tri);
  }
  return out;
}

}  // namespace

namespace detail {

/// Sorts `keys` ascending, LSD radix on 11-bit digits (2048 buckets stay in cache; digits
/// above the largest key, or shared by all keys, are skipped); `vals` (optional, same
/// length) move along with their keys (stable, so the result does not depend on the
/// threads). Large inputs are counted and scattered in fixed chunks in parallel.
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>* vals) {
  constexpr int kBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  const std::size_t n = keys.size();
  const std::size_t chunks = n < (std::size_t{1} << 16) ? 1 : 16;
  const std::size_t per = (n + chunks - 1) / chunks;
  std::uint64_t all_bits = 0;
  for (const std::uint64_t k : keys) all_bits |= k;
  std::vector<std::uint64_t> tmp(n);
  std::vector<std::uint32_t> tmp_vals(vals != nullptr ? vals->size() : 0);
  std::vector<std::size_t> count(chunks * kBuckets);
  for (int shift = 0; shift < 64 && (all_bits >> shift) != 0; shift += kBits) {
    auto each_chunk = [&](auto&& fn) {
      tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
        fn(c, c * per, std::min(n, (c + 1) * per), &count[c * kBuckets]);
      });
    };
    each_chunk([&](std::size_t, std::size_t lo, std::size_t hi, std::size_t* cnt) {
      std::fill(cnt, cnt + kBuckets, 0);
      for (std::size_t i = lo; i < hi; ++i) ++cnt[(keys[i] >> shift) & (kBuckets - 1)];
    });
    std::size_t sum = 0;
    bool one_digit = false;
    for (std::size_t b = 0; b < kBuckets; ++b) {
      std::size_t total = 0;
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::size_t m = count[c * kBuckets + b];
        count[c * kBuckets + b] = sum;
        sum += m;
        total += m;
      }
      one_digit |= total == n;
    }
    if (one_digit) continue;  // one digit: already in order
    each_chunk([&](std::size_t, std::size_t lo, std::size_t hi, std::size_t* at) {
      for (std::size_t i = lo; i < hi; ++i) {
        const std::size_t to = at[(keys[i] >> shift) & (kBuckets - 1)]++;
        tmp[to] = keys[i];
        if (vals != nullptr) tmp_vals[to] = (*vals)[i];
      }
    });
    keys.swap(tmp);
    if (vals != nullptr) vals->swap(tmp_vals);
  }
}

}  // namespace detail

namespace {

// ---------------------------------------------------------------- layered surface

/// Joins cells of a slab's projection that touch only at a corner (a 2x2 square holding two
/// diagonal cells and two empty ones) by filling one of the empty two, the one in the lower
/// row: the outlines then trace one region where the deposit is connected, not a one-cell
/// piece beside it. Repeats until no such square is left (a filled cell can make a new one).
/// `rows`: bit x of row y at rows[y * words + x / 64]; the border cells are empty.
void join_diagonal_cells(std::vector<std::uint64_t>& rows, int words) {
  const auto w = static_cast<std::size_t>(words);
  const std::size_t height = rows.size() / w;
  // Bit x of the result: bit x + 1 of the row (the neighbour on +x).
  const auto next = [w](const std::uint64_t* r, std::size_t i) {
    return (r[i] >> 1) | (i + 1 < w ? r[i + 1] << 63 : 0);
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t y = 0; y + 1 < height; ++y) {
      std::uint64_t* a = rows.data() + y * w;
      const std::uint64_t* b = a + w;
      std::uint64_t carry = 0;  // fills at bit 0 of word i from bit 63 of word i - 1
      for (std::size_t i = 0; i < w; ++i) {
        const std::uint64_t an = next(a, i), bn = next(b, i);
        const std::uint64_t rising = a[i] & bn & ~an & ~b[i];   // (x, y) and (x+1, y+1)
        const std::uint64_t falling = an & b[i] & ~a[i] & ~bn;  // (x+1, y) and (x, y+1)
        const std::uint64_t fill = (rising << 1) | carry | falling;
        carry = rising >> 63;
        if ((fill & ~a[i]) != 0) {
          a[i] |= fill;
          changed = true;
        }
      }
    }
  }
}

/// The solid's slabs: one per printed layer (boundaries at the beads' tops, at least two
/// cells apart), from its lowest to its highest filled cell. Cells above the last layer's
/// top (a solid top layer's overflow, lifted by the squeeze) are a slab of their own, even
/// one cell thin, so the last layer's top cap stays at its top.
detail::LayerSlabs slabs_of(const Solid& s, const VoxelGrid& grid,
                            std::span<const SurfaceBead> beads) {
  detail::LayerSlabs in;
  in.width = s.dims().x();
  in.height = s.dims().y();
  in.cell_mm = grid.voxel_mm() * s.cell;
  in.base_mm = grid.origin_mm() + grid.voxel_mm() * Vec3(s.origin.x, s.origin.y, s.origin.z);
  // The lowest and the highest filled cell: the block layers from the bottom up to the first
  // that holds one, and from the top down.
  int zmin = s.dims().z(), zmax = -1;
  const auto scan_layer = [&s, &zmin, &zmax](int bz) {
    bool found = false;
    for (int by = 0; by < s.nb.y(); ++by)
      for (int bx = 0; bx < s.nb.x(); ++bx)
        if (s.code[s.index(bx, by, bz)] != Solid::kEmpty)
          for (int z = 0; z < 8; ++z)
            if (s.word(bx, by, bz, z) != 0) {
              zmin = std::min(zmin, bz * 8 + z);
              zmax = std::max(zmax, bz * 8 + z + 1);
              found = true;
            }
    return found;
  };
  int lowest = 0;
  while (lowest < s.nb.z() && !scan_layer(lowest)) ++lowest;
  if (zmax < 0) return in;
  for (int bz = s.nb.z() - 1; bz > lowest && !scan_layer(bz); --bz) {}
  std::vector<int> tops;
  for (const SurfaceBead& b : beads) {
    const auto k = static_cast<int>(std::lround((b.end_mm.z() - in.base_mm.z()) / in.cell_mm));
    if (k > zmin && k < zmax) tops.push_back(k);
  }
  std::sort(tops.begin(), tops.end());
  in.bounds.push_back(zmin);
  for (const int k : tops)
    if (k - in.bounds.back() >= 2) in.bounds.push_back(k);
  if (zmax > in.bounds.back()) in.bounds.push_back(zmax);
  const int words = (in.width + 63) / 64;
  in.project = [&s, words](int z0, int z1, std::vector<std::uint64_t>& rows) {
    for (int bz = z0 >> 3; bz <= (z1 - 1) >> 3; ++bz)
      for (int by = 0; by < s.nb.y(); ++by)
        for (int bx = 0; bx < s.nb.x(); ++bx) {
          if (s.code[s.index(bx, by, bz)] == Solid::kEmpty) continue;
          std::uint64_t w = 0;
          for (int z = std::max(z0, bz * 8); z < std::min(z1, bz * 8 + 8); ++z)
            w |= s.word(bx, by, bz, z & 7);
          for (int y = 0; w != 0 && y < 8; ++y) {
            const std::uint64_t row = (w >> (y * 8)) & 0xFFU;
            rows[static_cast<std::size_t>(by * 8 + y) * static_cast<std::size_t>(words) +
                 static_cast<std::size_t>(bx >> 3)] |= row << ((bx & 7) * 8);
          }
        }
    join_diagonal_cells(rows, words);
  };
  return in;
}

/// The connected pieces of a mesh (over shared vertices) and the signed volume each encloses
/// (negative: an inner shell; a lone piece is taken as an outer one without summing it).
struct MeshPieces {
  std::vector<std::uint32_t> root;  ///< per vertex: the smallest vertex of its piece
  std::vector<double> volume;       ///< per root vertex
  std::size_t count = 0;
};

MeshPieces mesh_pieces(const Mesh& m) {
  MeshPieces p;
  std::vector<std::uint32_t>& parent = p.root;
  parent.resize(m.vertices_mm.size());
  std::iota(parent.begin(), parent.end(), 0U);
  for (const auto& t : m.triangles)
    for (int k = 1; k < 3; ++k) {
      const std::uint32_t a = find_root(parent, t[0]),
                          b = find_root(parent, t[static_cast<std::size_t>(k)]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  for (std::uint32_t v = 0; v < parent.size(); ++v) {  // roots are smaller: one pass
    parent[v] = parent[parent[v]];
    p.count += parent[v] == v ? 1 : 0;
  }
  p.volume.assign(parent.size(), 0.0);
  if (p.count == 1) {  // one piece of a closed surface oriented outward: an outer shell
    if (!parent.empty()) p.volume[0] = 1.0;
    return p;
  }
  for (const auto& t : m.triangles) {
    const Vec3 &a = m.vertices_mm[t[0]], &b = m.vertices_mm[t[1]], &c = m.vertices_mm[t[2]];
    p.volume[parent[t[0]]] += a.dot(b.cross(c)) / 6.0;
  }
  return p;
}

/// The cells of slab `slab`'s cross-section 4-connected to the seeds' cells (`rows`: the
/// projection, as LayerSlabs::project fills it; corner contacts are joined there).
std::vector<std::array<int, 2>> cross_section_cells(const detail::LayerSlabs& in,
                                                    const std::vector<std::uint64_t>& rows,
                                                    const std::vector<std::array<int, 2>>& seeds) {
  const auto words = static_cast<std::size_t>((in.width + 63) / 64);
  const auto filled = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < in.width && y < in.height &&
           ((rows[static_cast<std::size_t>(y) * words + static_cast<std::size_t>(x >> 6)] >>
             (x & 63)) &
            1U) != 0;
  };
  std::vector<char> seen(static_cast<std::size_t>(in.width) * static_cast<std::size_t>(in.height));
  std::vector<std::array<int, 2>> cells, stack;
  for (const auto& seed : seeds) stack.push_back(seed);
  while (!stack.empty()) {
    const auto [x, y] = stack.back();
    stack.pop_back();
    if (!filled(x, y)) continue;
    char& done = seen[static_cast<std::size_t>(y) * static_cast<std::size_t>(in.width) +
                      static_cast<std::size_t>(x)];
    if (done != 0) continue;
    done = 1;
    cells.push_back({x, y});
    stack.push_back({x + 1, y});
    stack.push_back({x - 1, y});
    stack.push_back({x, y + 1});
    stack.push_back({x, y - 1});
  }
  return cells;
}

/// The seeds' cells of each slab, per piece of the layered mesh (by root).
using PieceSeeds =
    std::unordered_map<std::uint32_t, std::map<int, std::vector<std::array<int, 2>>>>;
PieceSeeds seeds_by_piece(const detail::LayerSurface& surf, const MeshPieces& pieces) {
  PieceSeeds by;
  for (const auto& seed : surf.seeds)
    by[pieces.root[surf.mesh.triangles[seed.triangle][0]]][seed.slab].push_back({seed.x, seed.y});
  return by;
}

/// Cells moved from a slab's cross-section to a neighbour's, by slab (its cell range in z),
/// and the slab boundaries once the slabs left empty are gone.
struct MovedCells {
  std::map<std::pair<int, int>, std::vector<std::array<int, 2>>> add, remove;
  std::vector<int> bounds;
  std::size_t pieces = 0;
};

/// Pieces of the layered mesh that lie in one slab while their voxels touch a voxel of the
/// next slab up or down (face to face, along an edge or at a corner): the bead's round side
/// and the neighbour's take the contact away (a cell lifted onto a top layer, the sagging
/// underside of the next layer's bead). Their cells move to the cross-section of the slab
/// they touch (the one with more touching cells; down on a tie), so the mesh stays one piece
/// where the deposit is one. A slab left without cells joins the slab its cells moved to.
MovedCells split_pieces(const detail::LayerSurface& surf, const MeshPieces& pieces,
                        const detail::LayerSlabs& in, const Solid& s) {
  MovedCells moved;
  if (pieces.count < 2) return moved;
  const int ns = static_cast<int>(in.bounds.size()) - 1;
  const PieceSeeds by = seeds_by_piece(surf, pieces);
  std::vector<std::size_t> outlines(static_cast<std::size_t>(ns), 0), moving = outlines,
                                                                      incoming = outlines;
  for (const auto& seed : surf.seeds) ++outlines[static_cast<std::size_t>(seed.slab)];
  std::vector<int> target(static_cast<std::size_t>(ns), -1);  // where an emptied slab goes
  std::vector<std::uint64_t> rows;
  for (const auto& [root, slabs] : by) {
    const int slab = slabs.begin()->first;
    // One direction per slab and round: a slab cells move into keeps its own.
    if (slabs.size() != 1 || pieces.volume[root] <= 0 ||
        target[static_cast<std::size_t>(slab)] >= 0 || incoming[static_cast<std::size_t>(slab)] > 0)
      continue;
    const int z0 = in.bounds[static_cast<std::size_t>(slab)],
              z1 = in.bounds[static_cast<std::size_t>(slab) + 1];
    rows.assign(
        static_cast<std::size_t>(in.height) * static_cast<std::size_t>((in.width + 63) / 64), 0);
    in.project(z0, z1, rows);
    const auto cells = cross_section_cells(in, rows, slabs.begin()->second);
    // A voxel of the piece at the slab's top (bottom) and one of the next slab's above
    // (below) it, face to face, along an edge or at a corner.
    const auto touches = [&s](int x, int y, int z, int next) {
      if (!s.get(x, y, z)) return false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (s.get(x + dx, y + dy, next)) return true;
      return false;
    };
    std::size_t up = 0, down = 0;
    for (const auto& c : cells) {
      up += slab + 1 < ns && touches(c[0], c[1], z1 - 1, z1) ? 1 : 0;
      down += slab > 0 && touches(c[0], c[1], z0, z0 - 1) ? 1 : 0;
    }
    if (up == 0 && down == 0) continue;  // separate plastic: keep_part_pieces judges it
    const int to = up > down ? slab + 1 : slab - 1;
    if (moving[static_cast<std::size_t>(to)] > 0) continue;  // that slab may empty: next round
    const std::pair<int, int> from_range{z0, z1},
        to_range{in.bounds[static_cast<std::size_t>(to)],
                 in.bounds[static_cast<std::size_t>(to) + 1]};
    auto& add = moved.add[to_range];
    add.insert(add.end(), cells.begin(), cells.end());
    auto& rm = moved.remove[from_range];
    rm.insert(rm.end(), cells.begin(), cells.end());
    ++moved.pieces;
    ++incoming[static_cast<std::size_t>(to)];
    moving[static_cast<std::size_t>(slab)] += slabs.begin()->second.size();
    if (moving[static_cast<std::size_t>(slab)] == outlines[static_cast<std::size_t>(slab)])
      target[static_cast<std::size_t>(slab)] = to;
  }
  // Emptied slabs: the first and the last are dropped; one between joins its target (its
  // voxels are then in that slab's own cells). The moves follow the slabs they fall in.
  std::vector<char> keep_bound(in.bounds.size(), 1);
  for (int k = 0; k < ns; ++k) {
    const int to = target[static_cast<std::size_t>(k)];
    if (to >= 0)
      keep_bound[static_cast<std::size_t>(k == 0 ? 0 : k == ns - 1 ? ns : to > k ? k + 1 : k)] = 0;
  }
  for (std::size_t i = 0; i < in.bounds.size(); ++i)
    if (keep_bound[i] != 0) moved.bounds.push_back(in.bounds[i]);
  decltype(moved.add) add, remove;
  for (auto& [range, cells] : moved.add) {
    const auto hi = std::lower_bound(moved.bounds.begin(), moved.bounds.end(), range.second);
    if (hi == moved.bounds.begin() || hi == moved.bounds.end() || *(hi - 1) > range.first) continue;
    auto& to = add[{*(hi - 1), *hi}];
    to.insert(to.end(), cells.begin(), cells.end());
  }
  for (auto& [range, cells] : moved.remove) {
    const auto lo = std::lower_bound(moved.bounds.begin(), moved.bounds.end(), range.first);
    if (lo != moved.bounds.end() && *lo == range.first && lo + 1 != moved.bounds.end() &&
        *(lo + 1) == range.second)
      remove[range] = std::move(cells);
  }
  moved.add = std::move(add);
  moved.remove = std::move(remove);
  return moved;
}

/// `in` with `moved` applied to its slabs and cross-sections.
detail::LayerSlabs with_moved_cells(const detail::LayerSlabs& in, MovedCells moved) {
  detail::LayerSlabs out = in;
  out.bounds = moved.bounds;
  const int words = (in.width + 63) / 64;
  out.project = [base = in.project, moved = std::move(moved), words](
                    int z0, int z1, std::vector<std::uint64_t>& rows) {
    base(z0, z1, rows);
    const auto bit = [&rows, words](const std::array<int, 2>& c) -> std::uint64_t& {
      return rows[static_cast<std::size_t>(c[1]) * static_cast<std::size_t>(words) +
                  static_cast<std::size_t>(c[0] >> 6)];
    };
    if (const auto it = moved.remove.find({z0, z1}); it != moved.remove.end())
      for (const auto& c : it->second) bit(c) &= ~(1ULL << (c[0] & 63));
    if (const auto it = moved.add.find({z0, z1}); it != moved.add.end()) {
      for (const auto& c : it->second) bit(c) |= 1ULL << (c[0] & 63);
      join_diagonal_cells(rows, words);
    }
  };
  return out;
}

/// Connected pieces of the layered mesh and which are part (as classify does for the voxel
/// surface); drops the others from the mesh and their cells from the solid, and the inner
/// shells (cavities the slabs close: a hole of one slab's cross-section covered by the slabs
/// above and below, which the voxels reach from outside through cells the cross-sections
/// fill), as the filled volume fills every cavity the outside cannot reach. Returns the
/// kept count.
std::size_t keep_part_pieces(detail::LayerSurface& surf, const MeshPieces& pieces,
                             const detail::LayerSlabs& in, Solid& s, const VoxelGrid& grid,
                             const DepositMeshOptions& o, DepositMesh& out) {
  Mesh& m = surf.mesh;
  const auto& volume = pieces.volume;
  const auto& parent = pieces.root;
  bool tagged = false;
  for (const auto& tag : detail::VoxelBlocks::tag_table(grid))
    tagged |= kept_feature(tag.feature, o);
  std::unordered_map<std::uint32_t, std::array<int, 3>> piece;  // root: has part, layer range
  for (const auto& seed : surf.seeds) {
    const std::uint32_t root = parent[m.triangles[seed.triangle][0]];
    if (volume[root] < 0) continue;
    auto [it, fresh] = piece.try_emplace(root, std::array<int, 3>{0, 1 << 30, -1});
    if (tagged && it->second[0] != 0) continue;
    for (int z = in.bounds[static_cast<std::size_t>(seed.slab)];
         z < in.bounds[static_cast<std::size_t>(seed.slab) + 1]; ++z) {
      const auto tag = grid.tag(s.key_of_cell(seed.x, seed.y, z));
      if (!tag) continue;
      if (kept_feature(tag->feature, o)) it->second[0] = 1;
      it->second[1] = std::min(it->second[1], tag->layer);
      it->second[2] = std::max(it->second[2], tag->layer);
    }
  }
  const auto kept_root = [&](std::uint32_t root) {
    if (volume[root] < 0) return false;
    const auto& p = piece.at(root);
    return tagged ? p[0] != 0 : p[2] > p[1];
  };
  std::size_t n_kept = 0;
  for (const auto& [root, p] : piece) n_kept += kept_root(root) ? 1 : 0;
  if (!tagged && n_kept == 0) {  // every piece one layer tall: keep all
    n_kept = piece.size();
    for (auto& [root, p] : piece) p = {1, 0, 1};
  }
  out.dropped_components = piece.size() - n_kept;
  out.filled_cavities = pieces.count - piece.size();
  if (out.dropped_components == 0 && out.filled_cavities == 0) return n_kept;
  // The dropped pieces' cells, slab by slab, leave the solid.
  std::vector<std::uint64_t> rows;
  for (const auto& [root, slabs] : seeds_by_piece(surf, pieces)) {
    if (volume[root] < 0 || kept_root(root)) continue;
    for (const auto& [slab, seeds] : slabs) {
      const int z0 = in.bounds[static_cast<std::size_t>(slab)],
                z1 = in.bounds[static_cast<std::size_t>(slab) + 1];
      rows.assign(
          static_cast<std::size_t>(in.height) * static_cast<std::size_t>((in.width + 63) / 64), 0);
      in.project(z0, z1, rows);
      for (const auto& c : cross_section_cells(in, rows, seeds))
        for (int z = z0; z < z1; ++z) s.set(c[0], c[1], z, false);
    }
  }
  std::vector<std::uint32_t> remap(m.vertices_mm.size(), ~0U);
  Mesh k;
  for (const auto& t : m.triangles) {
    if (kept_root(parent[t[0]])) {
      std::array<std::uint32_t, 3> tri{};
      for (std::size_t c = 0; c < 3; ++c) {
        std::uint32_t& r = remap[t[c]];
        if (r == ~0U) {
          r = static_cast<std::uint32_t>(k.vertices_mm.size());
          k.vertices_mm.push_back(m.vertices_mm[t[c]]);
        }
        tri[c] = r;
      }
      k.triangles.push_back(tri);
    }
  }
  m = std::move(k);
  return n_kept;
}

/// The layered surface into `out` (true), or false with out.layers_fallback saying why.
bool layered_surface(Solid& fine, const VoxelGrid& grid, std::span<const SurfaceBead> beads,
                     const DepositMeshOptions& options, DepositMesh& out) {
  detail::LayerSlabs in = slabs_of(fine, grid, beads);
  detail::LayerSurfaceOptions lo;
  lo.tolerance_mm = options.outline_tolerance_mm;
  lo.profile_steps = options.profile_steps;
  detail::LayerSurface surf;
  MeshPieces pieces;
  int merge_rounds = 0;
  // After a join only the slabs whose cross-section changed are traced again, only the caps
  // beside them built again (PRINTTWIN_PLAIN=mesh_rebuild: the whole surface each time).
  std::optional<detail::LayerSurfaceMemo> memo;
  if (!detail::plain_path("mesh_rebuild")) memo.emplace();
  for (;;) {
    surf = detail::build_layer_surface(in, lo, memo ? &*memo : nullptr);
    const bool closed = !surf.mesh.triangles.empty() && detail::is_closed_oriented(surf.mesh);
    if (!closed && !lo.exact) {
      lo.exact = true;  // an intersection the inexact constructions snapped aside
      continue;
    }
    if (!closed) {
      out.layers_fallback = "the layered surface did not close (outlines that cross)";
      return false;
    }
    // One-slab pieces cut from the deposit they touch: into the next slab, and again (a
    // moved piece can leave another alone), a few rounds at most.
    pieces = mesh_pieces(surf.mesh);
    if (MovedCells moved = split_pieces(surf, pieces, in, fine);
        moved.pieces > 0 && merge_rounds < 3) {
      ++merge_rounds;
      out.merged_pieces += moved.pieces;
      if (memo)
        for (const auto* changed : {&moved.add, &moved.remove})
          for (const auto& [range, cells] : *changed) memo->forget(range.first, range.second);
      in = with_moved_cells(in, std::move(moved));
      continue;
    }
    if (options.max_triangles == 0 || surf.mesh.triangles.size() <= options.max_triangles) break;
    lo.tolerance_mm *= 2;
    if (lo.tolerance_mm > 2.0) {
      out.layers_fallback = "no layered surface within --deposit-mesh-max-triangles";
      return false;
    }
  }
  out.surface = DepositMeshSurface::layers;
  out.layers = in.bounds.size() - 1;
  out.outlines = surf.outlines;
  out.straight_outlines = surf.straight_outlines;
  out.outline_tolerance_mm = lo.tolerance_mm;
  out.components = keep_part_pieces(surf, pieces, in, fine, grid, options, out);
  out.filled_volume_mm3 = static_cast<double>(fine.count()) * std::pow(grid.voxel_mm(), 3);
  out.full_res_triangles = surf.mesh.triangles.size();
  // Outlines within the tolerance of the marching-squares outline, itself within half a
  // cell's diagonal of the voxel faces.
  out.error_bound_mm = lo.tolerance_mm + 0.5 * std::sqrt(2.0) * in.cell_mm;
  out.mesh = std::move(surf.mesh);
  return true;
}

/// The voxel surface of the filled solid (mesh_export.hpp: faces, components, smoothing,
/// decimation) into `out`.
Status voxel_surface(Solid& fine, const VoxelGrid& grid, const DepositMeshOptions& options,
                     std::span<const SurfaceBead> beads, DepositMesh& out) {
  out.surface = DepositMeshSurface::voxel;
  Built full = mesh_solid(fine, grid.voxel_mm(), grid.origin_mm());
  const Pieces pieces = classify(fine, full.rects, full.tris, grid, options);
  std::vector<bool> cleared(pieces.keep.size(), false);
  for (std::size_t ri = 0; ri < full.rects.size(); ++ri) {
    const std::uint32_t c = pieces.component_of_rect[ri];
    if (pieces.keep[c] || cleared[c]) continue;
    cleared[c] = true;
    clear_piece(fine, inner_cell(full.rects[ri]));
  }
  for (const bool k : pieces.keep) (k ? out.components : out.dropped_components) += 1;
  out.repaired_cells = full.repaired;
  out.filled_volume_mm3 = static_cast<double>(fine.count()) * std::pow(grid.voxel_mm(), 3);
  if (out.dropped_components == 0)
    out.mesh = std::move(full.tris.mesh);
  else
    out.mesh = kept_part(full.tris, pieces);
  out.full_res_triangles = out.mesh.triangles.size();
  std::size_t kept_rects = 0;
  for (std::size_t ri = 0; ri < full.rects.size(); ++ri)
    kept_rects += pieces.keep[pieces.component_of_rect[ri]] ? 1 : 0;
  out.rectangles = kept_rects;
  out.error_bound_mm = full.repaired > 0 ? std::sqrt(6.0) * grid.voxel_mm() : 0.0;
  // The plane of each kept triangle's rectangle (the smoothing's intersection check skips
  // pairs in one plane).
  std::vector<std::uint32_t> plane_of_triangle;
  const auto too_many_to_smooth = [&](std::size_t n) {
    return options.smooth_max_triangles > 0 && n > options.smooth_max_triangles;
  };
  if (options.smooth && !beads.empty() && !too_many_to_smooth(out.mesh.triangles.size())) {
    plane_of_triangle.reserve(out.mesh.triangles.size());
    for (const std::uint32_t ri : full.tris.rect_of_triangle) {
      if (out.dropped_components > 0 && !pieces.keep[pieces.component_of_rect[ri]]) continue;
      const Rect& r = full.rects[ri];
      plane_of_triangle.push_back((static_cast<std::uint32_t>(r.axis) << 17) |
                                  (static_cast<std::uint32_t>(r.side) << 16) |
                                  static_cast<std::uint32_t>(r.c));
    }
  }
  full = {};

  const std::size_t n_max = options.max_triangles;
  if (n_max > 0 && out.mesh.triangles.size() > n_max) {
    const int max_factor = std::max(2, fine.dims().maxCoeff());
    int factor = std::max(2, static_cast<int>(std::floor(std::sqrt(
                                 static_cast<double>(out.mesh.triangles.size()) / n_max))));
    for (;;) {
      Solid coarse = coarsen(fine, factor);
      Built b = mesh_solid(coarse, grid.voxel_mm(), grid.origin_mm());
      const std::size_t n = b.tris.mesh.triangles.size();
      if (n <= n_max) {
        out.mesh = std::move(b.tris.mesh);
        out.cell_voxels = factor;
        out.rectangles = b.rects.size();
        out.repaired_cells = b.repaired;
        out.error_bound_mm =
            (b.repaired > 0 ? std::sqrt(6.0) : std::sqrt(3.0)) * factor * grid.voxel_mm();
        break;
      }
      if (factor >= max_factor)
        return usage_error("--deposit-mesh-max-triangles " + std::to_string(n_max) +
                           " is below the smallest mesh of the part (" + std::to_string(n) +
                           " triangles on cells of " + std::to_string(factor) + " voxels)");
      const int grown =
          static_cast<int>(std::ceil(factor * std::sqrt(static_cast<double>(n) / n_max)));
      factor = std::min(max_factor, std::max(factor + 1, grown));
    }
  }
  if (out.cell_voxels == 1 && options.smooth && !beads.empty()) {
    out.smoothing_skipped = too_many_to_smooth(out.mesh.triangles.size());
    double max_shift = 0;
    if (!out.smoothing_skipped)
      out.smoothed_vertices =
          detail::smooth_onto_beads(out.mesh, plane_of_triangle, grid, beads, &max_shift);
    out.error_bound_mm = std::max(out.error_bound_mm, max_shift);
  }
  return Ok{};
}

}  // namespace

Result<DepositMesh> build_deposit_mesh(const VoxelGrid& grid, const DepositMeshOptions& options,
                                       std::span<const SurfaceBead> beads,
                                       const DepositSurface* filled) {
  const auto t0 = std::chrono::steady_clock::now();
  DepositMesh out;
  out.voxel_mm = grid.voxel_mm();
  auto solid = filled_volume_of(grid, options, filled);
  if (!solid) return solid.error();
  Solid& fine = *solid;
  if (!fine.code.empty()) {
    bool layered = false;
    if (options.surface == DepositMeshSurface::layers) {
      if (beads.empty())
        out.layers_fallback = "no beads (the G-code's layers are not known)";
      else
        layered = layered_surface(fine, grid, beads, options, out);
    }
    if (!layered)
      if (auto st = voxel_surface(fine, grid, options, beads, out); !st) return st.error();
    out.volume_mm3 = enclosed_volume_mm3(out.mesh);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace printtwin
