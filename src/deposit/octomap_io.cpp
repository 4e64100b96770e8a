// OctoMap adapter: the only file that includes OctoMap. Exports the deposit as .bt (binary
// occupancy OcTree, pruned) or .ot (ColorOcTree, every voxel coloured by layer or feature),
// both encoded here straight from the grid's blocks in OctoMap's file formats (the same
// bytes as OctoMap's writeBinary for .bt; for .ot the tree OctoMap's insert path builds,
// with uniform-colour subtrees pruned), and reads such files back with OctoMap.
// Coordinates and resolution are in millimetres (octovis shows any unit); voxel centres map
// to OctoMap keys one to one since the resolution equals the voxel size.
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "core/atomic_write.hpp"
#include "core/bits.hpp"
#include "core/plain_path.hpp"
#include "deposit/palette.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

using detail::VoxelBlocks;

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
  const Vec3& lo = grid.origin_mm();
  const Vec3 hi = lo + grid.voxel_mm() * grid.dims().cast<double>();
  if (lo.cwiseAbs().maxCoeff() >= limit || hi.cwiseAbs().maxCoeff() >= limit)
    return usage_error("the deposit does not fit OctoMap's key range (+-" + format_number(limit) +
                       " mm at voxel " + format_number(grid.voxel_mm()) + " mm)");
  return Ok{};
}

// --- The cubes and the subtrees ---------------------------------------------------------
// OctoMap's own path (a node per voxel, then prune) needs tens of bytes and ~0.4 us per
// voxel: ~5 GB and ~40 s for the 85 M voxels of the benchmark part. Both trees are produced
// here directly instead: voxels are binned into 8^3 cubes aligned on OctoMap keys, the cubes
// put in the tree's depth-first child order (Morton order of the cube key, x lowest), and
// the tree encoded in OctoMap's format. The cubes are grouped into subtrees of 8^3 cubes
// (64^3 voxels, the nodes at depth kSubtreeDepth): the subtrees are encoded on all cores
// into separate pieces, and the levels above them are written around the pieces in tree
// order, as the pieces come (a bounded number in flight).

constexpr int kTreeDepth = 16;
constexpr int kCubeLevels = kTreeDepth - 3;                  // depth of the 8^3 cubes
constexpr int kSubtreeLevels = 3;                            // a subtree: 8^3 cubes
constexpr int kSubtreeDepth = kCubeLevels - kSubtreeLevels;  // depth of the subtrees' roots
constexpr std::size_t kPiecesInFlight = 16;

struct Cube {
  std::uint64_t morton =
      0;  // interleaved cube key bits (z y x per level, most significant level first)
  std::array<std::uint64_t, 8> bits{};  // per z-slice, bit y * 8 + x
  [[nodiscard]] bool full() const {
    return std::all_of(bits.begin(), bits.end(),
                       [](std::uint64_t w) { return w == ~std::uint64_t{0}; });
  }
};

std::uint64_t morton3(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  std::uint64_t m = 0;
  for (int b = kCubeLevels - 1; b >= 0; --b)
    m = (m << 3) | (((z >> b) & 1u) << 2) | (((y >> b) & 1u) << 1) | ((x >> b) & 1u);
  return m;
}

/// The cubes under one node at kSubtreeDepth, in tree order.
struct Subtree {
  std::uint64_t key = 0;  // the cubes' morton >> (3 * kSubtreeLevels)
  const Cube* begin = nullptr;
  const Cube* end = nullptr;
};

/// The grid's voxels as cubes, grouped by subtree; the subtrees in tree order.
struct CubeSet {
  std::vector<std::vector<Cube>> slabs;  // per slab of subtrees (64 voxels in z)
  std::vector<Subtree> subtrees;
};

/// Runs `fn` on all cores, or on one with PRINTTWIN_PLAIN=octomap_threads (the plain twin:
/// the same work in the same pieces, one after the other).
template <class Fn>
void on_export_threads(const Fn& fn) {
  if (!detail::plain_path("octomap_threads")) {
    fn();
    return;
  }
  tbb::task_arena one(1);
  one.execute(fn);
}

/// Bins the grid's blocks into cubes aligned on OctoMap keys. The blocks are offset from the
/// cubes by the same (sx, sy, sz) voxels: block (bx, by, bz) feeds cubes (bx, by, bz) +
/// (0|1, 0|1, 0|1) (relative to the cube of block 0). A slab (the cube layers of one layer of
/// subtrees) is assembled two cube layers at a time, so memory is the finished cubes plus
/// two layers per thread.
class CubeBinner {
 public:
  using Bits = std::array<std::uint64_t, 8>;
  struct Layer {
    std::vector<Bits> bits;              // per cell (cy * ncx + cx)
    std::vector<std::uint32_t> touched;  // cells with bits set, in first-touch order
    Bits& at(std::size_t cell) {
      Bits& b = bits[cell];
      if (std::all_of(b.begin(), b.end(), [](std::uint64_t v) { return v == 0; }))
        touched.push_back(static_cast<std::uint32_t>(cell));
      return b;
    }
  };
  using Scratch = std::array<Layer, 2>;

  explicit CubeBinner(const VoxelGrid& grid) : nb_(VoxelBlocks::block_dims(grid)) {
    // OctoMap key of voxel k: k + offset (its centre's coordinate / resolution, floored,
    // + 2^15).
    for (int a = 0; a < 3; ++a) {
      const int offset =
          static_cast<int>(std::llround(grid.origin_mm()[a] / grid.voxel_mm())) + 32768;
      s_[a] = static_cast<unsigned>(offset & 7);
      q_[a] = static_cast<std::uint32_t>(offset >> 3);
    }
    ncx_ = nb_.x() + 1;
    ncy_ = nb_.y() + 1;
    // Each allocated block goes to the slabs of the cube layers it feeds (bz, and bz + 1
    // when shifted); a slab's blocks in the grid's (z, y, x) order.
    blocks_.resize(static_cast<std::size_t>(slabs()));
    VoxelBlocks::visit_blocks_as_allocated(grid, [&](const VoxelBlocks::BlockView& b) {
      const BlockRef ref{b.occupancy, b.base.x / VoxelBlocks::kBlockEdge,
                         b.base.y / VoxelBlocks::kBlockEdge, b.base.z / VoxelBlocks::kBlockEdge};
      const int low = slab_of(ref.bz), high = slab_of(ref.bz + 1);
      blocks_[static_cast<std::size_t>(low)].push_back(ref);
      if (s_[2] != 0 && high != low) blocks_[static_cast<std::size_t>(high)].push_back(ref);
    });
    for (auto& slab : blocks_)
      std::sort(slab.begin(), slab.end(), [](const BlockRef& a, const BlockRef& b) {
        return std::tie(a.bz, a.by, a.bx) < std::tie(b.bz, b.by, b.bx);
      });
  }
  /// Slabs: cube layers 0 .. nb.z (relative to the cube of block 0) grouped by their
  /// subtree layer.
  [[nodiscard]] int slabs() const { return slab_of(nb_.z()) + 1; }
  /// The slab of cube layer cz.
  [[nodiscard]] int slab_of(int cz) const {
    return static_cast<int>(((q_[2] + static_cast<std::uint32_t>(cz)) >> 3) - (q_[2] >> 3));
  }
  /// The cubes of slab `s`, in tree order.
  std::vector<Cube> slab(int s, Scratch& layers) const {
    const int first = static_cast<int>(((q_[2] >> 3) + static_cast<std::uint32_t>(s)) * 8) -
                      static_cast<int>(q_[2]);
    const int c0 = std::max(first, 0), c1 = std::min(first + 8, nb_.z() + 1);
    for (auto& l : layers)
      if (l.bits.empty())
        l.bits.assign(static_cast<std::size_t>(ncx_) * static_cast<std::size_t>(ncy_), Bits{});
    std::vector<Cube> cubes;
    auto flush = [&](int cz) {  // cube layer cz is complete
      auto& layer = layers[static_cast<std::size_t>(cz & 1)];
      for (const std::uint32_t cell : layer.touched) {
        Bits& bits = layer.bits[cell];
        const auto cx = static_cast<std::uint32_t>(cell % static_cast<std::uint32_t>(ncx_)),
                   cy = static_cast<std::uint32_t>(cell / static_cast<std::uint32_t>(ncx_));
        Cube c;
        c.morton = morton3(q_[0] + cx, q_[1] + cy, q_[2] + static_cast<std::uint32_t>(cz));
        c.bits = bits;
        cubes.push_back(c);
        bits = Bits{};
      }
      layer.touched.clear();
    };
    // Cube layer cz takes the low slices of block layer cz and the high ones of cz - 1: it is
    // complete once block layer cz + 1 comes.
    int flushed = c0;
    for (const BlockRef& b : blocks_[static_cast<std::size_t>(s)]) {
      for (; flushed < b.bz; ++flushed) flush(flushed);
      bin_block(b.occupancy, b.bx, b.by, b.bz, c0, c1, layers);
    }
    for (; flushed < c1; ++flushed) flush(flushed);
    std::sort(cubes.begin(), cubes.end(),
              [](const Cube& a, const Cube& b) { return a.morton < b.morton; });
    return cubes;
  }

 private:
  /// ORs the slices of a block that fall in cube layers [c0, c1) into their cubes. Each
  /// z-slice's columns and rows are shifted into the up to 2 x 2 cubes it straddles (bit
  /// y * 8 + x).
  void bin_block(const std::uint64_t* occupancy, int bx, int by, int bz, int c0, int c1,
                 Scratch& layers) const {
    const unsigned sx = s_[0], sy = s_[1], sz = s_[2];
    const std::uint64_t low_columns = 0x0101010101010101ull * (0xFFu >> sx);  // x < 8 - sx
    for (unsigned z = 0; z < 8; ++z) {
      const std::uint64_t w = occupancy[z];
      if (w == 0) continue;
      const unsigned zz = z + sz;
      const int cz = bz + static_cast<int>(zz >> 3);
      if (cz < c0 || cz >= c1) continue;
      auto& layer = layers[static_cast<std::size_t>(cz & 1)];
      const std::uint64_t x_parts[2] = {(w & low_columns) << sx,
                                        sx == 0 ? 0 : (w & ~low_columns) >> (8 - sx)};
      for (int dx = 0; dx < 2; ++dx) {
        const std::uint64_t p = x_parts[dx];
        if (p == 0) continue;
        const auto cell = static_cast<std::size_t>(by) * static_cast<std::size_t>(ncx_) +
                          static_cast<std::size_t>(bx + dx);
        if (const std::uint64_t rows = p << (8 * sy); rows != 0)  // rows y < 8 - sy
          layer.at(cell)[zz & 7u] |= rows;
        if (sy != 0)
          if (const std::uint64_t rows = p >> (8 * (8 - sy)); rows != 0)
            layer.at(cell + static_cast<std::size_t>(ncx_))[zz & 7u] |= rows;
      }
    }
  }

  struct BlockRef {
    const std::uint64_t* occupancy;
    int bx, by, bz;
  };

  Eigen::Vector3i nb_;
  unsigned s_[3] = {0, 0, 0};
  std::uint32_t q_[3] = {0, 0, 0};
  int ncx_ = 0, ncy_ = 0;
  std::vector<std::vector<BlockRef>> blocks_;  // per slab
};

/// The voxels of the grid as cubes, grouped by subtree in tree order (the slabs are binned on
/// all cores).
CubeSet cubes_of(const VoxelGrid& grid) {
  const CubeBinner binner(grid);
  CubeSet set;
  set.slabs.resize(static_cast<std::size_t>(binner.slabs()));
  tbb::enumerable_thread_specific<CubeBinner::Scratch> scratch;
  tbb::parallel_for(std::size_t{0}, set.slabs.size(), [&](std::size_t s) {
    set.slabs[s] = binner.slab(static_cast<int>(s), scratch.local());
  });
  for (const auto& slab : set.slabs)
    for (std::size_t i = 0; i < slab.size();) {
      Subtree t;
      t.key = slab[i].morton >> (3 * kSubtreeLevels);
      t.begin = slab.data() + i;
      while (i < slab.size() && slab[i].morton >> (3 * kSubtreeLevels) == t.key) ++i;
      t.end = slab.data() + i;
      set.subtrees.push_back(t);
    }
  std::sort(set.subtrees.begin(), set.subtrees.end(),
            [](const Subtree& a, const Subtree& b) { return a.key < b.key; });
  return set;
}

/// One subtree encoded: its bytes, its node count (its root included) and its root (the
/// format's node word).
struct Piece {
  std::unique_ptr<char[]> bytes;
  std::size_t size = 0;  // bytes used
  std::size_t nodes = 0;
  std::uint32_t root = 0;
  /// Room for `n` bytes (left uninitialised).
  void allocate(std::size_t n) { bytes.reset(new char[n]); }
};

/// Voxels of a cube (its popcount).
std::size_t voxels_of(const Cube& c) {
  std::size_t n = 0;
  for (const auto w : c.bits) n += static_cast<std::size_t>(popcount64(w));
  return n;
}

/// Encodes the subtrees on all cores (`encode(const Subtree&)` returns a Piece) and hands
/// the pieces to `consume(Piece&)` one by one in tree order, at most kPiecesInFlight of them
/// held at once.
template <class Encode, class Consume>
void encode_in_order(const std::vector<Subtree>& subtrees, const Encode& encode,
                     const Consume& consume) {
  std::size_t next = 0;
  tbb::parallel_pipeline(
      kPiecesInFlight,
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& fc) -> std::size_t {
                                            if (next == subtrees.size()) {
                                              fc.stop();
                                              return 0;
                                            }
                                            return next++;
                                          }) &
          tbb::make_filter<std::size_t, Piece>(tbb::filter_mode::parallel,
                                               [&](std::size_t i) { return encode(subtrees[i]); }) &
          tbb::make_filter<Piece, void>(tbb::filter_mode::serial_in_order,
                                        [&](Piece p) { consume(p); }));
}

/// The levels of the tree above the subtrees (depths 0 .. kSubtreeDepth - 1), written around
/// the subtrees' pieces, which come one by one in tree order. A node is opened (written with
/// its child bits and a placeholder where its value depends on its children) when its first
/// subtree comes, and closed (its value patched in, or the node replaced by a leaf) when its
/// last has passed. `Format` writes the nodes:
///   std::uint64_t open(std::uint8_t child_bits): writes a node, returns its offset;
///   void append(const Piece&): appends a subtree;
///   std::uint32_t close(std::uint64_t at, const std::array<std::uint32_t, 8>& children,
///                       bool root, bool& leaf): finishes the node at `at`, returns it.
template <class Format>
class TopLevels {
 public:
  TopLevels(Format& format, const std::vector<Subtree>& subtrees)
      : format_(format), subtrees_(subtrees) {}
  void add(const Piece& piece) {
    const std::uint64_t key = subtrees_[next_].key;
    int from = 0;  // the shallowest level to open
    if (next_ > 0) {
      from = kSubtreeDepth;
      for (int t = 1; t < kSubtreeDepth; ++t)
        if (ancestor(key, t) != ancestor(last_, t)) {
          from = t;
          break;
        }
      close_from(from);
    }
    for (int t = from; t < kSubtreeDepth; ++t) {
      Level& l = levels_[static_cast<std::size_t>(t)];
      l = Level{};
      l.at = format_.open(child_bits(t));
    }
    Level& parent = levels_[kSubtreeDepth - 1];
    parent.children[key & 7u] = piece.root;
    parent.nodes += piece.nodes;
    format_.append(piece);
    last_ = key;
    ++next_;
  }
  /// Closes the open nodes; returns the tree's node count (0 when there were no subtrees).
  std::size_t finish() {
    if (next_ == 0) return 0;
    close_from(0);
    return nodes_;
  }

 private:
  struct Level {
    std::uint64_t at = 0;
    std::size_t nodes = 0;  // of the children's subtrees
    std::array<std::uint32_t, 8> children{};
  };
  /// The node at depth t above subtree `key`.
  static std::uint64_t ancestor(std::uint64_t key, int t) {
    return key >> (3 * (kSubtreeDepth - t));
  }
  /// Child bits of the node at depth t above the next subtree: the children that the
  /// subtrees under it, from the next on, lie in.
  [[nodiscard]] std::uint8_t child_bits(int t) const {
    const std::uint64_t node = ancestor(subtrees_[next_].key, t);
    unsigned bits = 0;
    for (std::size_t i = next_; i < subtrees_.size() && ancestor(subtrees_[i].key, t) == node; ++i)
      bits |= 1u << (ancestor(subtrees_[i].key, t + 1) & 7u);
    return static_cast<std::uint8_t>(bits);
  }
  /// Closes the open nodes at depths kSubtreeDepth - 1 down to `from`.
  void close_from(int from) {
    for (int t = kSubtreeDepth - 1; t >= from; --t) {
      Level& l = levels_[static_cast<std::size_t>(t)];
      bool leaf = false;
      const std::uint32_t node = format_.close(l.at, l.children, t == 0, leaf);
      const std::size_t nodes = leaf ? 1 : l.nodes + 1;
      if (t == 0) {
        nodes_ = nodes;
      } else {
        Level& parent = levels_[static_cast<std::size_t>(t - 1)];
        parent.children[ancestor(last_, t) & 7u] = node;
        parent.nodes += nodes;
      }
    }
  }

  Format& format_;
  const std::vector<Subtree>& subtrees_;
  std::array<Level, kSubtreeDepth> levels_{};
  std::size_t next_ = 0;    // index of the next subtree
  std::uint64_t last_ = 0;  // key of the last subtree
  std::size_t nodes_ = 0;
};

/// Child index (0..7) under a node at `depth` (< kCubeLevels) of the cube with this Morton
/// code.
unsigned child_of(std::uint64_t morton, int depth) {
  return static_cast<unsigned>((morton >> (3 * (kCubeLevels - 1 - depth))) & 7u);
}

/// Splits cubes [b, e) under a node at `depth` by child: child c holds [split[c],
/// split[c + 1]).
std::array<std::size_t, 9> split_by_child(const Cube* cubes, std::size_t b, std::size_t e,
                                          int depth) {
  std::array<std::size_t, 9> split{};
  split[0] = b;
  std::size_t i = b;
  for (unsigned c = 0; c < 8; ++c) {
    while (i < e && child_of(cubes[i].morton, depth) == c) ++i;
    split[c + 1] = i;
  }
  return split;
}

// --- .bt --------------------------------------------------------------------------------
// OcTree::writeBinaryData's format: per inner node two bytes, two bits per child (00
// absent, 01 occupied leaf, 11 inner node); then the inner children, in child order. A node
// whose whole cube is occupied is a leaf, as OctoMap's prune() makes it. Node words: 2 for
// an occupied leaf, 3 for an inner node (0: absent).

constexpr std::uint32_t kBtLeaf = 2, kBtInner = 3;

/// The two bytes of a node whose children have these words (two bits per child, child i at
/// bits 2i (low) and 2i+1 (high) of its byte: OctoMap's bitset order; occupied leaf = (0, 1),
/// inner = (1, 1)).
std::array<char, 2> bt_code(const std::array<std::uint32_t, 8>& children) {
  unsigned code = 0;
  for (unsigned c = 0; c < 8; ++c) {
    if (children[c] == kBtLeaf) code |= 2u << (2 * c);
    if (children[c] == kBtInner) code |= 3u << (2 * c);
  }
  return {static_cast<char>(code & 0xFFu), static_cast<char>(code >> 8)};
}

/// The sub-cubes of one 8^3 cube that hold a voxel (`any`) and that are full (`all`): of
/// edge 2 (4 x 4 x 4 of them, bit z * 16 + y * 4 + x) and of edge 4 (2 x 2 x 2, bit z * 4 +
/// y * 2 + x). Pairs of slices, rows and columns are folded with | and &.
struct SubCubes {
  std::uint64_t any2 = 0, all2 = 0;
  unsigned any4 = 0, all4 = 0;
  explicit SubCubes(const std::array<std::uint64_t, 8>& bits) {
    for (unsigned p = 0; p < 4; ++p) {
      any2 |= fold8(bits[2 * p] | bits[2 * p + 1], true) << (16 * p);
      all2 |= fold8(bits[2 * p] & bits[2 * p + 1], false) << (16 * p);
    }
    for (unsigned p = 0; p < 2; ++p) {
      any4 |= fold4(((any2 >> (32 * p)) | (any2 >> (32 * p + 16))) & 0xFFFFu, true) << (4 * p);
      all4 |= fold4(((all2 >> (32 * p)) & (all2 >> (32 * p + 16))) & 0xFFFFu, false) << (4 * p);
    }
  }
  /// An 8 x 8 slice (bit y * 8 + x) folded to 4 x 4 (bit y * 4 + x): | or & of each 2 x 2.
  static std::uint64_t fold8(std::uint64_t w, bool any) {
    w = any ? (w | (w >> 8)) : (w & (w >> 8));
    w = any ? (w | (w >> 1)) : (w & (w >> 1));
    w &= 0x0055005500550055ull;  // even rows and columns
    w = (w | (w >> 1)) & 0x0033003300330033ull;
    w = (w | (w >> 2)) & 0x000F000F000F000Full;
    w = (w | (w >> 12)) & 0x000000FF000000FFull;
    return (w | (w >> 24)) & 0xFFFFull;
  }
  /// A 4 x 4 slice (bit y * 4 + x) folded to 2 x 2 (bit y * 2 + x).
  static unsigned fold4(std::uint64_t w, bool any) {
    w = any ? (w | (w >> 4)) : (w & (w >> 4));
    w = any ? (w | (w >> 1)) : (w & (w >> 1));
    return static_cast<unsigned>((w & 1u) | ((w >> 1) & 2u) | ((w >> 6) & 4u) | ((w >> 7) & 8u));
  }
};

/// Encodes one subtree of the .bt.
class BtEncoder {
 public:
  Piece encode(const Subtree& s) {
    cubes_ = s.begin;
    const auto n = static_cast<std::size_t>(s.end - s.begin);
    full_prefix_.assign(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i)
      full_prefix_[i + 1] = full_prefix_[i] + (cubes_[i].full() ? 1 : 0);
    Piece piece;
    piece.nodes = 1;
    if (range_full(0, n, kSubtreeDepth)) {
      piece.root = kBtLeaf;
      return piece;
    }
    piece.root = kBtInner;
    // Inner nodes: at most 1 + 8 + 64 above the cubes and 1 + 8 + 64 in each.
    piece.allocate(2 * (73 + 73 * n));
    out_ = piece.bytes.get();
    size_ = 0;
    nodes_ = 1;
    encode_range(0, n, kSubtreeDepth);
    piece.size = size_;
    piece.nodes = nodes_;
    return piece;
  }

 private:
  /// Cubes [b, e) all lie under one node at `depth`: is that node entirely occupied?
  [[nodiscard]] bool range_full(std::size_t b, std::size_t e, int depth) const {
    const std::size_t need = std::size_t{1} << (3 * (kCubeLevels - depth));
    return e - b == need && full_prefix_[e] - full_prefix_[b] == need;
  }
  /// Writes the node above cubes [b, e) at `depth` (an inner node: not full, not empty).
  void encode_range(std::size_t b, std::size_t e, int depth) {
    if (depth == kCubeLevels) {
      const SubCubes sub(cubes_[b].bits);
      encode_cube(cubes_[b].bits, sub, 8, 0, 0, 0);
      return;
    }
    const auto split = split_by_child(cubes_, b, e, depth);
    std::array<std::uint32_t, 8> kinds{};
    for (unsigned c = 0; c < 8; ++c) {
      if (split[c] == split[c + 1]) continue;
      ++nodes_;
      kinds[c] = range_full(split[c], split[c + 1], depth + 1) ? kBtLeaf : kBtInner;
    }
    put(kinds);
    for (unsigned c = 0; c < 8; ++c)
      if (kinds[c] == kBtInner) encode_range(split[c], split[c + 1], depth + 1);
  }
  /// Writes the node of edge n at (x, y, z) (in units of n) inside one 8^3 cube: an inner
  /// node.
  void encode_cube(const std::array<std::uint64_t, 8>& bits, const SubCubes& sub, int n, int x,
                   int y, int z) {
    std::array<std::uint32_t, 8> kinds{};
    for (unsigned c = 0; c < 8; ++c) {
      const int cx = 2 * x + static_cast<int>(c & 1u), cy = 2 * y + static_cast<int>((c >> 1) & 1u),
                cz = 2 * z + static_cast<int>(c >> 2);
      bool any = false, all = false;
      if (n == 8) {
        any = ((sub.any4 >> c) & 1u) != 0, all = ((sub.all4 >> c) & 1u) != 0;
      } else if (n == 4) {
        const int bit = cz * 16 + cy * 4 + cx;
        any = ((sub.any2 >> bit) & 1u) != 0, all = ((sub.all2 >> bit) & 1u) != 0;
      } else {
        any = all = ((bits[static_cast<std::size_t>(cz)] >> (cy * 8 + cx)) & 1u) != 0;
      }
      if (!any) continue;
      ++nodes_;
      kinds[c] = all ? kBtLeaf : kBtInner;
    }
    put(kinds);
    for (unsigned c = 0; c < 8; ++c)
      if (kinds[c] == kBtInner)
        encode_cube(bits, sub, n / 2, 2 * x + static_cast<int>(c & 1u),
                    2 * y + static_cast<int>((c >> 1) & 1u), 2 * z + static_cast<int>(c >> 2));
  }
  void put(const std::array<std::uint32_t, 8>& kinds) {
    const auto code = bt_code(kinds);
    out_[size_] = code[0];
    out_[size_ + 1] = code[1];
    size_ += 2;
  }

  const Cube* cubes_ = nullptr;
  std::vector<std::size_t> full_prefix_;
  char* out_ = nullptr;
  std::size_t size_ = 0;
  std::size_t nodes_ = 0;
};

/// The levels above the .bt's subtrees, in memory.
struct BtFormat {
  std::string& out;
  std::uint64_t open(std::uint8_t /*child_bits*/) {
    out.append(2, '\0');  // the child codes, known when the node closes
    return out.size() - 2;
  }
  void append(const Piece& piece) { out.append(piece.bytes.get(), piece.size); }
  std::uint32_t close(std::uint64_t at, const std::array<std::uint32_t, 8>& children, bool root,
                      bool& leaf) {
    leaf = !root && std::all_of(children.begin(), children.end(),
                                [](std::uint32_t c) { return c == kBtLeaf; });
    if (leaf) {
      out.resize(at);
      return kBtLeaf;
    }
    const auto code = bt_code(children);
    out[at] = code[0];
    out[at + 1] = code[1];
    return kBtInner;
  }
};

/// The text header OctoMap writes before the nodes (`binary`: .bt, else .ot). `pad` spaces
/// end its empty comment line (OctoMap's reader skips a comment to its line's end): a
/// header written after its records fills the room left for it exactly.
std::string octomap_header(bool binary, const char* tree_type, std::size_t nodes, double resolution,
                           std::size_t pad = 0) {
  std::ostringstream head;
  head << (binary ? "# Octomap OcTree binary file\n" : "# Octomap OcTree file\n")
       << "# (feel free to add / change comments, but leave the first line as it is!)\n#"
       << std::string(pad, ' ') << "\nid " << tree_type << "\nsize " << nodes << "\nres "
       << resolution << "\ndata\n";
  return head.str();
}

std::string encode_bt(const VoxelGrid& grid) {
  std::string data;
  std::size_t nodes = 0;
  on_export_threads([&] {
    const CubeSet cubes = cubes_of(grid);
    BtFormat format{data};
    TopLevels<BtFormat> top(format, cubes.subtrees);
    encode_in_order(
        cubes.subtrees, [](const Subtree& s) { return BtEncoder().encode(s); },
        [&](const Piece& p) { top.add(p); });
    nodes = top.finish();
  });
  return octomap_header(true, "OcTree", nodes, grid.voxel_mm()) + data;
}

// --- .ot --------------------------------------------------------------------------------
// The ColorOcTree file (AbstractOcTree::write): a text header, then the nodes depth-first
// (OcTreeBaseImpl::writeNodesRecurs): per node its log-odds occupancy (float), its colour
// (r, g, b bytes), a byte with one bit per existing child, then the existing children in
// child order. Every voxel is occupied at the clamping maximum, so every inner node holds
// the same value (OctoMap's updateInnerOccupancy sets the maximum of the children); an inner
// node's colour is ColorOcTreeNode::getAverageChildColor of its children (the integer mean
// of the children whose colour is not pure white; white when none is). A node whose eight
// children are leaves of one colour is written as one leaf of that colour (lossless: unlike
// OctoMap's own ColorOcTree pruning, which ignores colour), so full 8^3 cubes of one layer or
// feature cost one node. A voxel's colour is looked up in its grid block when its cube is
// written.

// A node as one word: colour 0xRRGGBB in the low 24 bits, its kind above (0: absent).
using OtNode = std::uint32_t;
constexpr OtNode kLeaf = 1u << 24, kInner = 2u << 24, kWhite = 0xFFFFFFu;
constexpr std::size_t kRecord = 8;  // bytes of a node record

OtNode pack(const deposit_detail::Rgb& c) {
  return kLeaf | (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | c.b;
}

/// The parent of eight nodes (at least one present): a leaf when the eight are leaves of
/// one colour, else an inner node with OctoMap's average child colour.
OtNode parent_of(const OtNode* c) {
  const OtNode first = c[0];
  if ((first & ~kWhite) == kLeaf && c[1] == first && c[2] == first && c[3] == first &&
      c[4] == first && c[5] == first && c[6] == first && c[7] == first)
    return first;
  std::uint32_t r = 0, g = 0, b = 0, n = 0;
  for (int i = 0; i < 8; ++i) {
    if (c[i] == 0 || (c[i] & kWhite) == kWhite) continue;
    r += (c[i] >> 16) & 0xFFu, g += (c[i] >> 8) & 0xFFu, b += c[i] & 0xFFu, ++n;
  }
  if (n == 0) return kInner | kWhite;
  return kInner | ((r / n) << 16) | ((g / n) << 8) | (b / n);
}

/// Writes `n` bytes at file offset `at` (pwrite, retried until done); false on an error.
bool write_at(int fd, const char* bytes, std::size_t n, std::uint64_t at) {
  while (n > 0) {
    const ssize_t w = ::pwrite(fd, bytes, n, static_cast<off_t>(at));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    bytes += w, n -= static_cast<std::size_t>(w), at += static_cast<std::uint64_t>(w);
  }
  return true;
}

/// The .ot node records, streamed to the file through a buffer of the latest ones (memory
/// stays small however large the tree). Offsets count from the first record, which lies at
/// `start` in the file. A node's colour is known only after its subtree, and eight leaves of
/// one colour are taken back for one leaf, so writes may go back to records already flushed.
class RecordSink {
 public:
  RecordSink(int fd, std::uint64_t start) : fd_(fd), start_(start), buffer_(new char[kBytes]) {}
  /// Appends `n` bytes (whole records); returns their offset.
  std::uint64_t put(const char* bytes, std::size_t n) {
    if (size_ - base_ + n > kBytes) [[unlikely]] {
      flush();
      if (n > kBytes) {
        ok_ = ok_ && write_at(fd_, bytes, n, start_ + size_);
        size_ += n;
        base_ = size_;
        return size_ - n;
      }
    }
    std::memcpy(buffer_.get() + (size_ - base_), bytes, n);
    size_ += n;
    return size_ - n;
  }
  /// Overwrites `n` bytes of the records put, from offset `at` on.
  void patch(std::uint64_t at, const char* bytes, std::size_t n) {
    if (at >= base_)
      std::memcpy(buffer_.get() + (at - base_), bytes, n);
    else
      ok_ = ok_ && write_at(fd_, bytes, n, start_ + at);
  }
  /// Drops the records from offset `at` on (the file's stale bytes are overwritten or cut).
  void truncate(std::uint64_t at) {
    size_ = at;
    base_ = std::min(base_, at);
  }
  /// Writes the buffered records out.
  __attribute__((noinline)) void flush() {
    ok_ = ok_ && write_at(fd_, buffer_.get(), size_ - base_, start_ + base_);
    base_ = size_;
  }
  [[nodiscard]] std::uint64_t size() const { return size_; }
  [[nodiscard]] bool ok() const { return ok_; }

 private:
  static constexpr std::size_t kBytes = std::size_t{1} << 20;
  int fd_;
  std::uint64_t start_;
  std::unique_ptr<char[]> buffer_;
  std::uint64_t base_ = 0;  // offset of buffer_[0]
  std::uint64_t size_ = 0;  // offset of the next record
  bool ok_ = true;
};

/// What every .ot subtree encoder reads: the colour of every tag and where a cube's voxels
/// lie in the grid's blocks.
struct OtTables {
  OtTables(const VoxelGrid& grid, VoxelColoring coloring, float occupied_log_odds) {
    const auto& table = VoxelBlocks::tag_table(grid);
    colours.reserve(table.size());
    for (const auto& tag : table)
      colours.push_back(pack(coloring == VoxelColoring::layer
                                 ? deposit_detail::layer_color(tag.layer)
                                 : deposit_detail::feature_color(tag.feature)));
    for (int a = 0; a < 3; ++a)
      offset[a] = static_cast<int>(std::llround(grid.origin_mm()[a] / grid.voxel_mm())) + 32768;
    std::uint32_t value = 0;
    std::memcpy(&value, &occupied_log_odds, 4);
    value_word = value;
    // Every cube starts at the same place inside its grid block (offsets below 8): where
    // each of its voxels lies among the up to 2 x 2 x 2 blocks it overlaps.
    int shift[3];
    for (int a = 0; a < 3; ++a) shift[a] = (-offset[a]) & 7;
    for (int bit = 0; bit < 64; ++bit) {
      const int lx = shift[0] + (bit & 7), ly = shift[1] + (bit >> 3);
      xy_block[static_cast<std::size_t>(bit)] =
          static_cast<std::uint8_t>((lx >> 3) | ((ly >> 3) << 1));
      xy_slot[static_cast<std::size_t>(bit)] = static_cast<std::uint8_t>((ly & 7) * 8 + (lx & 7));
      xy_mask[xy_block[static_cast<std::size_t>(bit)]] |= std::uint64_t{1} << bit;
    }
    for (int z = 0; z < 8; ++z) {
      const int lz = shift[2] + z;
      z_block[static_cast<std::size_t>(z)] = static_cast<std::uint8_t>((lz >> 3) << 2);
      z_slot[static_cast<std::size_t>(z)] = static_cast<std::uint16_t>((lz & 7) * 64);
    }
    std::array<std::uint16_t, 8> spread{};  // bits 0, 1, 2 of i at bits 0, 3, 6
    for (unsigned i = 0; i < 8; ++i)
      for (unsigned level = 0; level < 3; ++level)
        spread[i] = static_cast<std::uint16_t>(spread[i] | ((i >> level) & 1u) << (3 * level));
    for (unsigned i = 0; i < 8; ++i) z_morton[i] = static_cast<std::uint16_t>(spread[i] << 2);
    for (unsigned bit = 0; bit < 64; ++bit)
      xy_morton[bit] = static_cast<std::uint16_t>(spread[bit & 7u] | (spread[bit >> 3] << 1));
  }
  /// The record of `node` with these child bits.
  void record(OtNode node, std::uint8_t children, char* out) const {
    const std::uint64_t word = record_word(node, children);
    std::memcpy(out, &word, kRecord);
  }
  /// The record of `node` as it lies in memory: the value, r, g, b, the child bits.
  [[nodiscard]] std::uint64_t record_word(OtNode node, std::uint8_t children) const {
    static_assert(std::endian::native == std::endian::little);
    return value_word | (std::uint64_t{__builtin_bswap32(node << 8)} << 32) |
           (std::uint64_t{children} << 56);
  }

  std::vector<OtNode> colours;  // per tag index, packed as a leaf
  int offset[3] = {0, 0, 0};
  std::uint64_t value_word = 0;             // the occupied log-odds, as written
  std::array<std::uint8_t, 64> xy_block{};  // per bit y * 8 + x of a cube slice: its block
  std::array<std::uint8_t, 64> xy_slot{};   // ... and its slot's y * 8 + x there
  std::array<std::uint64_t, 4> xy_mask{};   // per block (x bit, y bit): the bits in it
  std::array<std::uint8_t, 8> z_block{};    // per cube slice z: its block (z bit)
  std::array<std::uint16_t, 8> z_slot{};    // ... and its slot's z * 64 there
  // A voxel's place in the cube's depth-first (Morton) order: x bits at 0, 3, 6; y at 1, 4,
  // 7; z at 2, 5, 8.
  std::array<std::uint16_t, 64> xy_morton{};  // per bit y * 8 + x of a cube slice
  std::array<std::uint16_t, 8> z_morton{};    // per slice z
};

/// Nodes of the encoded .ot at most: per cube its voxels and at most min(voxels, 64) +
/// min(voxels, 8) + 1 nodes above them inside the cube, plus a chain of kCubeLevels
/// ancestors.
std::size_t max_ot_nodes(const CubeSet& cubes) {
  std::size_t nodes = 0;
  for (const auto& slab : cubes.slabs)
    for (const auto& c : slab) {
      const std::size_t n = voxels_of(c);
      nodes += n + std::min<std::size_t>(n, 64) + std::min<std::size_t>(n, 8) + 1 + kCubeLevels;
    }
  return nodes;
}

/// Encodes one subtree of the .ot into records in memory.
class OtEncoder {
 public:
  OtEncoder(const VoxelGrid& grid, const OtTables& tables) : grid_(grid), t_(tables) {}
  Piece encode(const Subtree& s) {
    Piece piece;
    // Records: at most 1 + 8 + 64 above the cubes, and per cube its voxels plus
    // min(voxels, 64) + min(voxels, 8) + 1 nodes above them.
    std::size_t records = 73 + 1;  // + 1: a voxel record is written before it is known to stay
    for (const Cube* c = s.begin; c != s.end; ++c) {
      const std::size_t n = voxels_of(*c);
      records += n + std::min<std::size_t>(n, 64) + std::min<std::size_t>(n, 8) + 1;
    }
    piece.allocate(records * kRecord);
    cubes_ = s.begin;
    out_ = piece.bytes.get();
    size_ = 0;
    piece.root = encode_range(0, static_cast<std::size_t>(s.end - s.begin), kSubtreeDepth);
    piece.size = size_;
    piece.nodes = size_ / kRecord;  // a record per node
    return piece;
  }

 private:
  /// Appends a node record (value, colour, child bits); returns its offset.
  std::size_t put_node(OtNode node, std::uint8_t children) {
    const std::uint64_t word = t_.record_word(node, children);
    std::memcpy(out_ + size_, &word, kRecord);
    size_ += kRecord;
    return size_ - kRecord;
  }
  OtNode encode_range(std::size_t b, std::size_t e, int depth) {
    if (depth == kCubeLevels) return encode_cube(cubes_[b]);
    const auto split = split_by_child(cubes_, b, e, depth);
    std::uint8_t mask = 0;
    for (unsigned c = 0; c < 8; ++c)
      if (split[c] != split[c + 1]) mask = static_cast<std::uint8_t>(mask | (1u << c));
    const std::size_t at = put_node(kInner | kWhite, mask);
    std::array<OtNode, 8> children{};
    for (unsigned c = 0; c < 8; ++c)
      if (split[c] != split[c + 1]) children[c] = encode_range(split[c], split[c + 1], depth + 1);
    const OtNode node = parent_of(children.data());
    if (node & kLeaf) {  // eight leaves of one colour: one leaf instead
      size_ = at;
      put_node(node, 0);
    } else {
      out_[at + 4] = static_cast<char>(node >> 16);
      out_[at + 5] = static_cast<char>(node >> 8);
      out_[at + 6] = static_cast<char>(node);
    }
    return node;
  }
  /// A grid block as the cube reads it: the colour of each palette entry, or of each slot
  /// when the block is wide.
  struct BlockColours {
    const std::uint8_t* nibbles = nullptr;
    const std::uint32_t* wide = nullptr;
    OtNode uniform = 0;  // the colour of all its tags, 0 when they differ
    std::array<OtNode, VoxelBlocks::kPaletteSize> palette{};
  };
  /// The packed leaf of every voxel of the cube, in the cube's depth-first order (slot
  /// xy_morton[y * 8 + x] | z_morton[z]); the slots of the other voxels of its 2^3 groups
  /// that hold a voxel are 0 (the rest are 0 from the cube before).
  /// Returns the colour all of them share when every grid block they come from has one
  /// colour for all its tags (then the voxels are filled without a per-voxel look-up),
  /// else 0.
  OtNode gather(const Cube& cube) {
    std::uint32_t k[3] = {0, 0, 0};
    for (int level = 0; level < kCubeLevels; ++level)
      for (int a = 0; a < 3; ++a)
        k[a] |= static_cast<std::uint32_t>((cube.morton >> (3 * level + a)) & 1u) << level;
    int b0[3], spans[3];
    for (int a = 0; a < 3; ++a) {
      const int g0 = static_cast<int>(k[a] * 8) - t_.offset[a];
      b0[a] = g0 >> 3;
      spans[a] = ((g0 + 7) >> 3) - b0[a] + 1;  // 1 when aligned, else 2
    }
    // The blocks the cube overlaps, and the one colour they share (0 when their tags differ).
    OtNode shared = ~OtNode{0};  // not yet known
    for (int dz = 0; dz < spans[2]; ++dz)
      for (int dy = 0; dy < spans[1]; ++dy)
        for (int dx = 0; dx < spans[0]; ++dx) {
          const auto view = VoxelBlocks::block_view(grid_, b0[0] + dx, b0[1] + dy, b0[2] + dz);
          if (!view) continue;
          BlockColours& b = blocks_[static_cast<std::size_t>(dx | (dy << 1) | (dz << 2))];
          b.nibbles = view->nibbles;
          b.wide = view->wide;
          OtNode c = b.wide == nullptr && view->palette_size > 0 ? t_.colours[view->palette[0]] : 0;
          for (int i = 0; i < view->palette_size; ++i) {
            b.palette[static_cast<std::size_t>(i)] = t_.colours[view->palette[i]];
            if (b.palette[static_cast<std::size_t>(i)] != c) c = 0;
          }
          b.uniform = c;
          shared = shared == ~OtNode{0} ? c : (shared == c ? c : 0);
        }
    if (shared != 0 && cube.full()) return shared;  // the caller writes one leaf
    for (std::size_t z = 0; z < 8; ++z) {
      std::uint64_t w = cube.bits[z];
      OtNode* slice = voxel_.data() + t_.z_morton[z];
      const auto& place = t_.xy_morton;
      if (shared != 0) {
        for (; w != 0; w &= w - 1) slice[place[std::countr_zero(w)]] = shared;
        continue;
      }
      // The slice's voxels block by block (up to 2 x 2 blocks): one colour, a palette
      // index or a wide tag per voxel.
      const unsigned z_slot = t_.z_slot[z];
      for (unsigned q = 0; q < 4; ++q) {
        std::uint64_t m = w & t_.xy_mask[q];
        if (m == 0) continue;
        const BlockColours& b = blocks_[t_.z_block[z] | q];
        if (b.uniform != 0) {
          for (; m != 0; m &= m - 1) slice[place[std::countr_zero(m)]] = b.uniform;
        } else if (b.wide != nullptr) {
          for (; m != 0; m &= m - 1) {
            const auto bit = static_cast<std::size_t>(std::countr_zero(m));
            slice[place[bit]] = t_.colours[b.wide[z_slot + t_.xy_slot[bit]]];
          }
        } else {
          for (; m != 0; m &= m - 1) {
            const auto bit = static_cast<std::size_t>(std::countr_zero(m));
            const unsigned slot = z_slot + t_.xy_slot[bit];
            slice[place[bit]] = b.palette[(b.nibbles[slot >> 1] >> ((slot & 1u) * 4)) & 15u];
          }
        }
      }
    }
    return shared;
  }
  OtNode encode_cube(const Cube& cube) {
    const OtNode shared = gather(cube);
    if (shared != 0 && cube.full()) {
      put_node(shared, 0);
      return shared;
    }
    // Levels inside the cube, bottom-up: 8^3 voxels -> 4^3 -> 2^3 -> the cube's node; in
    // depth-first order a node's eight children lie side by side.
    std::uint64_t groups = 0;  // the 2^3 groups of voxels that hold one
    for (unsigned g = 0; g < 64; ++g) {
      const OtNode* v = voxel_.data() + 8 * g;
      const bool any = (v[0] | v[1] | v[2] | v[3] | v[4] | v[5] | v[6] | v[7]) != 0;
      l1_[g] = any ? parent_of(v) : 0;
      groups |= std::uint64_t{any} << g;
    }
    for (unsigned g = 0; g < 8; ++g) {
      const OtNode* v = l1_.data() + 8 * g;
      const bool any = (v[0] | v[1] | v[2] | v[3] | v[4] | v[5] | v[6] | v[7]) != 0;
      l2_[g] = any ? parent_of(v) : 0;
    }
    const OtNode root = parent_of(l2_.data());
    write_cube_node(root, l2_.data(), 3);
    for (; groups != 0; groups &= groups - 1)  // the next cube starts from empty slots
      std::fill_n(voxel_.data() + 8 * std::countr_zero(groups), 8, OtNode{0});
    return root;
  }
  /// The child bits of eight nodes.
  static std::uint8_t child_mask(const OtNode* children) {
    unsigned mask = 0;
    for (unsigned c = 0; c < 8; ++c) mask |= unsigned{children[c] != 0} << c;
    return static_cast<std::uint8_t>(mask);
  }
  /// Writes a node of cube level `level` (1: above voxels, 3: the cube) and its subtree;
  /// `children` are its eight children.
  void write_cube_node(OtNode node, const OtNode* children, int level) {
    if (node & kLeaf) {
      put_node(node, 0);
      return;
    }
    put_node(node, child_mask(children));
    if (level == 1) {  // the children are voxels: leaves, written without a branch each
      char* out = out_ + size_;
      for (unsigned c = 0; c < 8; ++c) {
        const std::uint64_t word = t_.record_word(children[c], 0);
        std::memcpy(out, &word, kRecord);
        out += children[c] != 0 ? kRecord : 0;
      }
      size_ = static_cast<std::size_t>(out - out_);
      return;
    }
    const OtNode* below = level == 3 ? l1_.data() : voxel_.data();
    const auto first = static_cast<std::size_t>(children - (level == 3 ? l2_.data() : l1_.data()));
    for (unsigned c = 0; c < 8; ++c)
      if (children[c] != 0) write_cube_node(children[c], below + 8 * (first + c), level - 1);
  }

  const VoxelGrid& grid_;
  const OtTables& t_;
  const Cube* cubes_ = nullptr;
  std::array<BlockColours, 8> blocks_{};
  std::array<OtNode, 512> voxel_{};
  std::array<OtNode, 64> l1_{};
  std::array<OtNode, 8> l2_{};
  char* out_ = nullptr;
  std::size_t size_ = 0;
};

/// The levels above the .ot's subtrees, streamed to the file with the pieces.
struct OtFormat {
  RecordSink& sink;
  const OtTables& tables;
  std::uint64_t open(std::uint8_t child_bits) {
    char record[kRecord];
    tables.record(kInner | kWhite, child_bits, record);  // the colour comes when it closes
    return sink.put(record, kRecord);
  }
  void append(const Piece& piece) { sink.put(piece.bytes.get(), piece.size); }
  OtNode close(std::uint64_t at, const std::array<OtNode, 8>& children, bool /*root*/, bool& leaf) {
    const OtNode node = parent_of(children.data());
    leaf = (node & kLeaf) != 0;
    if (leaf) {  // eight leaves of one colour: one leaf instead
      sink.truncate(at);
      char record[kRecord];
      tables.record(node, 0, record);
      sink.put(record, kRecord);
    } else {
      const char colour[3] = {static_cast<char>(node >> 16), static_cast<char>(node >> 8),
                              static_cast<char>(node)};
      sink.patch(at + 4, colour, 3);
    }
    return node;
  }
};

/// Writes the .ot file into `fd`: the node records first, streamed from where the longest
/// header their count could need ends, then the header, padded to that length. False when a
/// write fails.
bool write_ot(int fd, const VoxelGrid& grid, VoxelColoring coloring) {
  const octomap::ColorOcTree reference(grid.voxel_mm());  // empty: for its occupancy constants
  const OtTables tables(grid, coloring, reference.getClampingThresMaxLog());
  std::uint64_t start = 0, size = 0;
  std::size_t nodes = 0;
  bool ok = false;
  on_export_threads([&] {
    const CubeSet cubes = cubes_of(grid);
    start = octomap_header(false, "ColorOcTree", max_ot_nodes(cubes), grid.voxel_mm()).size();
    RecordSink sink(fd, start);
    OtFormat format{sink, tables};
    TopLevels<OtFormat> top(format, cubes.subtrees);
    encode_in_order(
        cubes.subtrees, [&](const Subtree& s) { return OtEncoder(grid, tables).encode(s); },
        [&](const Piece& p) { top.add(p); });
    nodes = top.finish();
    sink.flush();
    ok = sink.ok();
    size = sink.size();
  });
  std::string header = octomap_header(false, "ColorOcTree", nodes, grid.voxel_mm());
  if (!ok || header.size() > start) return false;
  // The count has fewer digits than the room left for it: the comment line takes the rest
  // (moving the records up instead would copy the whole file once more).
  if (header.size() < start)
    header = octomap_header(false, "ColorOcTree", nodes, grid.voxel_mm(), start - header.size());
  return write_at(fd, header.data(), header.size(), 0) &&
         ::ftruncate(fd, static_cast<off_t>(header.size() + size)) == 0;
}

}  // namespace

Status write_octomap(const VoxelGrid& grid, const std::filesystem::path& path,
                     VoxelColoring coloring) {
  const std::string ext = lower_extension(path);
  if (ext != ".bt" && ext != ".ot")
    return usage_error("OctoMap output must end in .bt or .ot: " + path.string());
  if (auto st = check_key_range(grid); !st) return st.error();
  if (ext == ".bt") return write_file_atomic(path, encode_bt(grid));
  return detail::write_file_atomic_with(path, [&](int fd) { return write_ot(fd, grid, coloring); });
}

Result<std::size_t> count_octomap_voxels(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  std::unique_ptr<octomap::AbstractOcTree> owned;
  std::unique_ptr<octomap::OcTree> bt;
  if (ext == ".bt") {
    bt = std::make_unique<octomap::OcTree>(0.1);
    if (!bt->readBinary(path.string()))
      return bad_input("not a readable OctoMap .bt file", path.string());
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
