// VoxelGrid: a dense directory of 8x8x8-voxel blocks; a block is allocated on its first
// write and holds 512 occupancy bits (one 64-bit word per z-slice, bit y*8+x), a palette of
// up to 16 tag indices (into a table of distinct tags, one entry per depositing move) and a
// 4-bit palette index per voxel, so a voxel costs ~0.75 bytes where its block is allocated.
// A block's voxels are laid by a few beads of a couple of layers (on the benchmark part 2 in
// half of the blocks, more than 16 in 0.04 %); when a 17th tag arrives the palette first
// drops the entries no occupied voxel refers to any more (overwritten), and a block that still
// needs more becomes wide: a 32-bit tag index per voxel, kept beside the chunks. Blocks live in
// fixed-size chunks, so growing never moves or copies them. A chunk is one anonymous mapping:
// the kernel hands its pages out zeroed, so reserving chunks costs no time and no resident
// memory; pages fault in as blocks are written (from the second chunk on as transparent huge
// pages where the kernel has them: VoxelBlocks::advise_huge_pages).
#include "printtwin/voxel_grid.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "core/bits.hpp"
#include "core/plain_path.hpp"
#include "core/zeroed_array.hpp"
#include "deposit/nibbles.hpp"
#include "deposit/voxel_blocks.hpp"

namespace printtwin {

namespace detail {
namespace {
/// 4-bit lanes of a row's 8 voxels: bit x of m -> nibble x of the result.
constexpr std::array<std::uint32_t, 256> make_nibble_masks() {
  std::array<std::uint32_t, 256> t{};
  for (unsigned m = 0; m < 256; ++m)
    for (unsigned x = 0; x < 8; ++x)
      if ((m >> x) & 1U) t[m] |= 0xFU << (4 * x);
  return t;
}
constexpr std::array<std::uint32_t, 256> kNibbleMask = make_nibble_masks();
}  // namespace

void store_nibbles(std::uint8_t* row, std::uint64_t mask, unsigned e) {
  const std::uint32_t fill = 0x11111111U * e;
  for (int y = 0; y < 8; ++y, row += 4, mask >>= 8) {
    const std::uint32_t m = kNibbleMask[mask & 0xFFU];
    if (m == 0) continue;
    std::uint32_t w;
    std::memcpy(&w, row, 4);
    w = (w & ~m) | (fill & m);
    std::memcpy(row, &w, 4);
  }
}

}  // namespace detail

namespace {
using detail::VoxelBlocks;
constexpr int kEdge = VoxelBlocks::kBlockEdge;
constexpr int kPalette = VoxelBlocks::kPaletteSize;
constexpr std::size_t kBlockBytes = VoxelBlocks::kBlockBytes;
constexpr std::size_t kChunkBlocks = 16384;    // blocks per allocation chunk (6 MiB)
constexpr std::uint32_t kNoBlock = 0;          // directory value of an unallocated block
constexpr std::size_t kNibbleBytes = 512 / 2;  // per block
constexpr std::size_t kOccBytes = kChunkBlocks * kEdge * sizeof(std::uint64_t);
constexpr std::size_t kNibblesBytes = kChunkBlocks * kNibbleBytes;
constexpr std::size_t kPaletteBytes = kChunkBlocks * kPalette * sizeof(std::uint32_t);
constexpr std::size_t kChunkBytes = kOccBytes + kNibblesBytes + kPaletteBytes;
constexpr std::uint8_t kWide = 0xFF;  // palette length of a wide block

/// Zero-filled memory for one chunk (ZeroedArray: an anonymous mapping on Linux).
class ChunkMemory {
 public:
  /// `huge`: backed by transparent huge pages (VoxelBlocks::advise_huge_pages).
  explicit ChunkMemory(bool huge) : memory_(kChunkBytes) {
    if (huge) VoxelBlocks::advise_huge_pages(memory_.data(), kChunkBytes);
  }
  [[nodiscard]] std::uint64_t* occupancy() {
    return reinterpret_cast<std::uint64_t*>(memory_.data());
  }
  [[nodiscard]] std::uint8_t* nibbles() { return memory_.data() + kOccBytes; }
  [[nodiscard]] std::uint32_t* palettes() {
    return reinterpret_cast<std::uint32_t*>(memory_.data() + kOccBytes + kNibblesBytes);
  }

 private:
  ZeroedArray<std::uint8_t> memory_;
};
}  // namespace

struct VoxelGrid::Impl {
  double voxel_mm = 0.05;
  double inv_voxel = 20.0;
  Vec3 origin_mm = Vec3::Zero();
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();
  Eigen::Vector3i block_dims = Eigen::Vector3i::Zero();
  ZeroedArray<std::uint32_t> directory;  // block index + 1, or kNoBlock
  std::vector<std::unique_ptr<ChunkMemory>> chunks;
  std::size_t blocks = 0;
  std::size_t occupied = 0;
  std::vector<VoxelTag> tags;
  std::vector<std::uint8_t> palette_size;  // per block: palette entries in use, or kWide
  std::vector<std::array<std::int32_t, 3>> block_coord;  // per block: (bx, by, bz)
  // Wide blocks: 512 tag indices each; a wide block's palette[0] holds its index here.
  std::vector<std::unique_ptr<std::uint32_t[]>> wide;

  [[nodiscard]] std::size_t dir_index(int bx, int by, int bz) const {
    return (static_cast<std::size_t>(bz) * static_cast<std::size_t>(block_dims.y()) +
            static_cast<std::size_t>(by)) *
               static_cast<std::size_t>(block_dims.x()) +
           static_cast<std::size_t>(bx);
  }
  [[nodiscard]] std::uint64_t* occ(std::size_t b) const {
    return chunks[b / kChunkBlocks]->occupancy() + (b % kChunkBlocks) * kEdge;
  }
  [[nodiscard]] std::uint8_t* nibbles(std::size_t b) const {
    return chunks[b / kChunkBlocks]->nibbles() + (b % kChunkBlocks) * kNibbleBytes;
  }
  [[nodiscard]] std::uint32_t* palette(std::size_t b) const {
    return chunks[b / kChunkBlocks]->palettes() + (b % kChunkBlocks) * kPalette;
  }
  [[nodiscard]] std::uint32_t* wide_slots(std::size_t b) const {
    return palette_size[b] == kWide ? wide[palette(b)[0]].get() : nullptr;
  }
  // The first chunk keeps 4 KiB pages: a small grid stays small.
  void add_chunk() { chunks.push_back(std::make_unique<ChunkMemory>(!chunks.empty())); }
  std::size_t allocate_block(std::size_t di, int bx, int by, int bz) {
    if (blocks == chunks.size() * kChunkBlocks) add_chunk();
    const std::size_t b = blocks++;
    directory[di] = static_cast<std::uint32_t>(b + 1);
    palette_size.push_back(0);
    block_coord.push_back({bx, by, bz});
    return b;
  }
  [[nodiscard]] static unsigned nibble_at(const std::uint8_t* nib, int s) {
    return (nib[s >> 1] >> ((s & 1) * 4)) & 0xFU;
  }
  /// Drops the palette entries of block b that no occupied voxel refers to (keeping the
  /// order of the rest). Returns the new length.
  int compact_palette(std::size_t b) {
    const std::uint64_t* o = occ(b);
    std::uint8_t* nib = nibbles(b);
    unsigned used = 0;
    for (int z = 0; z < kEdge; ++z)
      for (std::uint64_t m = o[z]; m != 0; m &= m - 1)
        used |= 1U << nibble_at(nib, z * 64 + std::countr_zero(m));
    std::uint32_t* pal = palette(b);
    std::array<std::uint8_t, kPalette> moved{};
    int n = 0;
    for (int i = 0; i < palette_size[b]; ++i)
      if ((used >> i) & 1U) {
        moved[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(n);
        pal[n++] = pal[i];
      }
    for (int s = 0; s < 512; s += 2) {
      const unsigned lo = moved[nib[s >> 1] & 0xFU], hi = moved[nib[s >> 1] >> 4];
      nib[s >> 1] = static_cast<std::uint8_t>(lo | (hi << 4));
    }
    palette_size[b] = static_cast<std::uint8_t>(n);
    return n;
  }
  /// Makes block b wide: every slot gets its tag index.
  void widen(std::size_t b) {
    auto slots = std::make_unique<std::uint32_t[]>(512);
    const std::uint8_t* nib = nibbles(b);
    const std::uint32_t* pal = palette(b);
    for (int s = 0; s < 512; ++s) slots[static_cast<std::size_t>(s)] = pal[nibble_at(nib, s)];
    palette(b)[0] = static_cast<std::uint32_t>(wide.size());
    wide.push_back(std::move(slots));
    palette_size[b] = kWide;
  }
  /// Palette entry of tag index t in block b, adding it (and compacting the palette or
  /// widening the block when it is full); -1 when the block is wide.
  int palette_entry(std::size_t b, std::uint32_t t) {
    int n = palette_size[b];
    if (n == kWide) return -1;
    std::uint32_t* pal = palette(b);
    for (int i = n - 1; i >= 0; --i)  // the newest entries are the likeliest
      if (pal[i] == t) return i;
    if (n == kPalette) n = compact_palette(b);
    if (n == kPalette) {
      widen(b);
      return -1;
    }
    pal[n] = t;
    palette_size[b] = static_cast<std::uint8_t>(n + 1);
    return n;
  }
  /// Gives the voxels of `mask` (bit y * 8 + x) in z-slice z of block b tag index t.
  void store_tags(std::size_t b, int z, std::uint64_t mask, std::uint32_t t) {
    const int e = palette_entry(b, t);
    if (e < 0) {
      std::uint32_t* slots = wide_slots(b) + z * 64;
      for (; mask != 0; mask &= mask - 1) slots[std::countr_zero(mask)] = t;
      return;
    }
    detail::store_nibbles(nibbles(b) + z * 32, mask, static_cast<unsigned>(e));
  }
  [[nodiscard]] std::uint32_t load_tag(std::size_t b, int s) const {
    if (const std::uint32_t* w = wide_slots(b)) return w[s];
    return palette(b)[nibble_at(nibbles(b), s)];
  }
  /// Block of (bx,by,bz), allocating it if needed.
  std::size_t block_for_write(int bx, int by, int bz) {
    const std::size_t di = dir_index(bx, by, bz);
    const std::uint32_t d = directory[di];
    return d != kNoBlock ? d - 1 : allocate_block(di, bx, by, bz);
  }
  [[nodiscard]] bool in_range(const VoxelKey& k) const {
    return k.x >= 0 && k.y >= 0 && k.z >= 0 && k.x < dims.x() && k.y < dims.y() && k.z < dims.z();
  }
  /// Block index of an in-range key, or -1 when unallocated.
  [[nodiscard]] long block_of(const VoxelKey& k) const {
    const std::uint32_t d = directory[dir_index(k.x >> 3, k.y >> 3, k.z >> 3)];
    return d == kNoBlock ? -1 : static_cast<long>(d - 1);
  }
  void copy_from(const Impl& o) {
    voxel_mm = o.voxel_mm;
    inv_voxel = o.inv_voxel;
    origin_mm = o.origin_mm;
    dims = o.dims;
    block_dims = o.block_dims;
    directory = o.directory;
    blocks = o.blocks;
    occupied = o.occupied;
    tags = o.tags;
    palette_size = o.palette_size;
    block_coord = o.block_coord;
    wide.clear();
    for (const auto& w : o.wide) {
      wide.push_back(std::make_unique<std::uint32_t[]>(512));
      std::memcpy(wide.back().get(), w.get(), 512 * sizeof(std::uint32_t));
    }
    chunks.clear();
    for (std::size_t c = 0; c < o.chunks.size(); ++c) {
      add_chunk();
      const std::size_t used =
          std::min(kChunkBlocks, o.blocks - std::min(o.blocks, c * kChunkBlocks));
      std::memcpy(chunks.back()->occupancy(), o.chunks[c]->occupancy(),
                  used * kEdge * sizeof(std::uint64_t));
      std::memcpy(chunks.back()->nibbles(), o.chunks[c]->nibbles(), used * kNibbleBytes);
      std::memcpy(chunks.back()->palettes(), o.chunks[c]->palettes(),
                  used * kPalette * sizeof(std::uint32_t));
    }
  }
};

VoxelGrid::VoxelGrid(double voxel_mm, const Vec3& origin_mm, const Eigen::Vector3i& dims)
    : impl_(std::make_unique<Impl>()) {
  impl_->voxel_mm = voxel_mm > 0 ? voxel_mm : 0.05;
  impl_->inv_voxel = 1.0 / impl_->voxel_mm;
  impl_->origin_mm = origin_mm;
  impl_->dims = dims.cwiseMax(0);
  impl_->block_dims = (impl_->dims.array() + (kEdge - 1)) / kEdge;
  static_assert(kNoBlock == 0);  // the directory starts as zeros
  impl_->directory = ZeroedArray<std::uint32_t>(static_cast<std::size_t>(impl_->block_dims.x()) *
                                                static_cast<std::size_t>(impl_->block_dims.y()) *
                                                static_cast<std::size_t>(impl_->block_dims.z()));
}

VoxelGrid::VoxelGrid(VoxelGrid&&) noexcept = default;
VoxelGrid& VoxelGrid::operator=(VoxelGrid&&) noexcept = default;
VoxelGrid::VoxelGrid(const VoxelGrid& o) : impl_(std::make_unique<Impl>()) {
  impl_->copy_from(*o.impl_);
}
VoxelGrid& VoxelGrid::operator=(const VoxelGrid& o) {
  if (this != &o) {
    auto fresh = std::make_unique<Impl>();
    fresh->copy_from(*o.impl_);
    impl_ = std::move(fresh);
  }
  return *this;
}
VoxelGrid::~VoxelGrid() = default;

double VoxelGrid::voxel_mm() const { return impl_->voxel_mm; }
const Vec3& VoxelGrid::origin_mm() const { return impl_->origin_mm; }
const Eigen::Vector3i& VoxelGrid::dims() const { return impl_->dims; }

bool VoxelGrid::in_range(const VoxelKey& k) const { return impl_->in_range(k); }

VoxelKey VoxelGrid::key_of(const Vec3& p_mm) const {
  const Vec3 q = (p_mm - impl_->origin_mm) * impl_->inv_voxel;
  return {static_cast<std::int32_t>(std::floor(q.x())),
          static_cast<std::int32_t>(std::floor(q.y())),
          static_cast<std::int32_t>(std::floor(q.z()))};
}

Vec3 VoxelGrid::center_mm(const VoxelKey& k) const {
  return impl_->origin_mm + impl_->voxel_mm * Vec3(k.x + 0.5, k.y + 0.5, k.z + 0.5);
}

bool VoxelGrid::occupied(const VoxelKey& k) const {
  if (!impl_->in_range(k)) return false;
  const long b = impl_->block_of(k);
  if (b < 0) return false;
  const std::uint64_t bit = std::uint64_t{1} << ((k.y & 7) * 8 + (k.x & 7));
  return (impl_->occ(static_cast<std::size_t>(b))[k.z & 7] & bit) != 0;
}

std::optional<std::uint32_t> VoxelBlocks::tag_index(const VoxelGrid& grid, const VoxelKey& k) {
  if (!grid.occupied(k)) return std::nullopt;
  const auto b = static_cast<std::size_t>(grid.impl_->block_of(k));
  return grid.impl_->load_tag(b, (k.z & 7) * 64 + (k.y & 7) * 8 + (k.x & 7));
}

std::optional<VoxelTag> VoxelGrid::tag(const VoxelKey& k) const {
  const auto i = VoxelBlocks::tag_index(*this, k);
  if (!i) return std::nullopt;
  return impl_->tags[*i];
}

std::uint32_t VoxelBlocks::add_tag(VoxelGrid& grid, const VoxelTag& tag) {
  auto& t = grid.impl_->tags;
  if (t.empty() || !(t.back() == tag)) t.push_back(tag);
  return static_cast<std::uint32_t>(t.size() - 1);
}

const std::vector<VoxelTag>& VoxelBlocks::tag_table(const VoxelGrid& grid) {
  return grid.impl_->tags;
}

bool VoxelGrid::set(const VoxelKey& k, const VoxelTag& tag) {
  if (!impl_->in_range(k)) return false;
  return VoxelBlocks::set_index(*this, k, VoxelBlocks::add_tag(*this, tag));
}

bool VoxelBlocks::set_index(VoxelGrid& grid, const VoxelKey& k, std::uint32_t tag_index) {
  VoxelGrid::Impl& g = *grid.impl_;
  if (!g.in_range(k)) return false;
  const std::size_t b = g.block_for_write(k.x >> 3, k.y >> 3, k.z >> 3);
  const int slot = (k.y & 7) * 8 + (k.x & 7);
  std::uint64_t& word = g.occ(b)[k.z & 7];
  const std::uint64_t bit = std::uint64_t{1} << slot;
  const bool was_empty = (word & bit) == 0;
  word |= bit;
  g.store_tags(b, k.z & 7, bit, tag_index);
  g.occupied += was_empty ? 1 : 0;
  return was_empty;
}

std::size_t VoxelBlocks::fill_row(VoxelGrid& grid, std::int32_t y, std::int32_t z, std::int32_t x0,
                                  std::int32_t x1, std::uint32_t tag_index) {
  VoxelGrid::Impl& g = *grid.impl_;
  if (y < 0 || z < 0 || y >= g.dims.y() || z >= g.dims.z()) return 0;
  x0 = std::max(x0, 0);
  x1 = std::min(x1, g.dims.x());
  if (x0 >= x1) return 0;
  const int by = y >> 3;
  const int bz = z >> 3;
  const int row_shift = (y & 7) * 8;
  std::size_t fresh = 0;
  for (int bx = x0 >> 3; bx <= (x1 - 1) >> 3; ++bx) {
    const int lo = std::max(x0 - bx * kEdge, 0);
    const int hi = std::min(x1 - bx * kEdge, kEdge);
    const std::size_t b = g.block_for_write(bx, by, bz);
    const std::uint64_t mask = ((std::uint64_t{1} << (hi - lo)) - 1) << (row_shift + lo);
    std::uint64_t& word = g.occ(b)[z & 7];
    fresh += static_cast<std::size_t>(popcount64(mask & ~word));
    word |= mask;
    g.store_tags(b, z & 7, mask, tag_index);
  }
  g.occupied += fresh;
  return fresh;
}

std::uint64_t VoxelBlocks::write_tile_before(VoxelGrid& grid, int bx, int by, std::int32_t z,
                                             std::uint64_t mask, std::uint32_t tag_index) {
  VoxelGrid::Impl& g = *grid.impl_;
  const std::size_t b = g.block_for_write(bx, by, z >> 3);
  std::uint64_t& word = g.occ(b)[z & 7];
  const std::uint64_t before = word;
  word |= mask;
  g.store_tags(b, z & 7, mask, tag_index);
  g.occupied += static_cast<std::size_t>(popcount64(mask & ~before));
  return before;
}

std::size_t VoxelBlocks::write_tile(VoxelGrid& grid, int bx, int by, std::int32_t z,
                                    std::uint64_t mask, std::uint32_t tag_index) {
  return static_cast<std::size_t>(
      popcount64(mask & ~write_tile_before(grid, bx, by, z, mask, tag_index)));
}

void VoxelGrid::clear(const VoxelKey& k) {
  if (!impl_->in_range(k)) return;
  const long b = impl_->block_of(k);
  if (b < 0) return;
  std::uint64_t& word = impl_->occ(static_cast<std::size_t>(b))[k.z & 7];
  const std::uint64_t bit = std::uint64_t{1} << ((k.y & 7) * 8 + (k.x & 7));
  if ((word & bit) != 0) {
    word &= ~bit;
    --impl_->occupied;
  }
}

std::size_t VoxelGrid::count() const { return impl_->occupied; }

void VoxelBlocks::advise_huge_pages([[maybe_unused]] void* p, [[maybe_unused]] std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  static const bool plain = plain_path("deposit_huge_pages");
  if (plain) return;
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = reinterpret_cast<std::uintptr_t>(p);
  const std::uintptr_t lo = (begin + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t hi = (begin + bytes) & ~(kHuge - 1);
  // NOLINTNEXTLINE(performance-no-int-to-ptr): the page range of a mapping we own
  if (hi > lo) madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#endif
}

void VoxelBlocks::reserve_blocks(VoxelGrid& grid, std::size_t blocks) {
  while (grid.impl_->chunks.size() * kChunkBlocks < blocks) grid.impl_->add_chunk();
}

std::size_t VoxelBlocks::block_count(const VoxelGrid& grid) { return grid.impl_->blocks; }

std::size_t VoxelBlocks::wide_block_count(const VoxelGrid& grid) { return grid.impl_->wide.size(); }

std::size_t VoxelGrid::memory_bytes() const {
  return impl_->directory.size() * sizeof(std::uint32_t) +
         impl_->blocks * kBlockBytes +  // pages of a chunk are touched only as its blocks are used
         impl_->wide.size() * 512 * sizeof(std::uint32_t) +
         impl_->tags.capacity() * sizeof(VoxelTag);
}

std::size_t VoxelGrid::estimate_bytes(const Eigen::Vector3i& dims, std::size_t occupied_voxels) {
  const Eigen::Vector3i bd = (dims.cwiseMax(0).array() + (kEdge - 1)) / kEdge;
  const std::size_t directory = static_cast<std::size_t>(bd.x()) *
                                static_cast<std::size_t>(bd.y()) *
                                static_cast<std::size_t>(bd.z()) * sizeof(std::uint32_t);
  // Deposits fill their blocks about half on average (thin walls, surfaces).
  const std::size_t blocks = (2 * occupied_voxels + 511) / 512;
  return directory + blocks * kBlockBytes;
}

Eigen::Vector3i VoxelBlocks::block_dims(const VoxelGrid& grid) { return grid.impl_->block_dims; }

const std::uint64_t* VoxelBlocks::block_occupancy(const VoxelGrid& grid, int bx, int by, int bz) {
  const VoxelGrid::Impl& g = *grid.impl_;
  if (bx < 0 || by < 0 || bz < 0 || bx >= g.block_dims.x() || by >= g.block_dims.y() ||
      bz >= g.block_dims.z())
    return nullptr;
  const std::uint32_t d = g.directory[g.dir_index(bx, by, bz)];
  return d == kNoBlock ? nullptr : g.occ(d - 1);
}

VoxelBlocks::BlockView VoxelBlocks::view_of_block(const VoxelGrid& grid, std::size_t b, int bx,
                                                  int by, int bz) {
  const VoxelGrid::Impl& g = *grid.impl_;
  const bool wide = g.palette_size[b] == kWide;
  return BlockView{VoxelKey{bx * kEdge, by * kEdge, bz * kEdge},
                   g.occ(b),
                   g.nibbles(b),
                   g.palette(b),
                   wide ? 0 : g.palette_size[b],
                   wide ? g.wide_slots(b) : nullptr,
                   static_cast<std::uint32_t>(b)};
}

std::optional<VoxelBlocks::BlockView> VoxelBlocks::block_view(const VoxelGrid& grid, int bx, int by,
                                                              int bz) {
  const VoxelGrid::Impl& g = *grid.impl_;
  if (bx < 0 || by < 0 || bz < 0 || bx >= g.block_dims.x() || by >= g.block_dims.y() ||
      bz >= g.block_dims.z())
    return std::nullopt;
  const std::uint32_t d = g.directory[g.dir_index(bx, by, bz)];
  if (d == kNoBlock) return std::nullopt;
  return view_of_block(grid, d - 1, bx, by, bz);
}

void VoxelBlocks::visit_blocks(const VoxelGrid& grid,
                               const std::function<void(const BlockView&)>& fn) {
  const VoxelGrid::Impl& g = *grid.impl_;
  for (int bz = 0; bz < g.block_dims.z(); ++bz)
    for (int by = 0; by < g.block_dims.y(); ++by)
      for (int bx = 0; bx < g.block_dims.x(); ++bx) {
        const std::uint32_t d = g.directory[g.dir_index(bx, by, bz)];
        if (d != kNoBlock) fn(view_of_block(grid, d - 1, bx, by, bz));
      }
}

void VoxelBlocks::visit_blocks_as_allocated(const VoxelGrid& grid,
                                            const std::function<void(const BlockView&)>& fn) {
  const VoxelGrid::Impl& g = *grid.impl_;
  for (std::size_t b = 0; b < g.blocks; ++b) {
    const auto& c = g.block_coord[b];
    fn(view_of_block(grid, b, c[0], c[1], c[2]));
  }
}

void VoxelGrid::for_each(const std::function<void(const VoxelKey&, const VoxelTag&)>& fn) const {
  const auto& table = impl_->tags;
  VoxelBlocks::visit_blocks(*this, [&](const VoxelBlocks::BlockView& b) {
    for (int z = 0; z < kEdge; ++z) {
      std::uint64_t bits = b.occupancy[z];
      while (bits != 0) {
        const int bit = std::countr_zero(bits);
        bits &= bits - 1;
        const VoxelKey k{b.base.x + (bit & 7), b.base.y + (bit >> 3), b.base.z + z};
        fn(k, table[b.tag_index(z * 64 + bit)]);
      }
    }
  });
}

std::vector<VoxelKey> VoxelGrid::occupied_keys() const {
  std::vector<VoxelKey> keys;
  keys.reserve(impl_->occupied);
  for_each([&](const VoxelKey& k, const VoxelTag&) { keys.push_back(k); });
  return keys;
}

}  // namespace printtwin
