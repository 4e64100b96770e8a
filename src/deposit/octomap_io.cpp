// OctoMap adapter: the only file that includes OctoMap. Exports the deposit as .bt (binary
// occupancy OcTree, pruned) or .ot (ColorOcTree, every voxel coloured by layer or feature),
// both encoded here straight from the grid's blocks in OctoMap's file formats (the same
// bytes as OctoMap's writeBinary for .bt; for .ot the tree OctoMap's insert path builds,
// with uniform-colour subtrees pruned), and reads such files back with OctoMap.
// Coordinates and resolution are in millimetres (octovis shows any unit); voxel centres map
// to OctoMap keys one to one since the resolution equals the voxel size.
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>
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
#include <vector>

#include "core/atomic_write.hpp"
#include "core/bits.hpp"
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

// --- .bt written straight from the grid ------------------------------------------------
// OctoMap's own path (a node per voxel, then prune) needs tens of bytes and ~0.4 us per
// voxel: ~5 GB and ~40 s for the 85 M voxels of the benchmark part. The pruned occupancy
// tree it writes is a function of the occupied voxels alone, so it is produced here
// directly: voxels are binned into 8^3 cubes aligned on OctoMap keys, the cubes sorted in
// the tree's depth-first child order (Morton order of the cube key, x lowest), and the tree
// encoded in OcTree::writeBinaryData's format (per inner node two bytes, two bits per child:
// 00 absent, 01 occupied leaf, 11 inner node; then the inner children, in child order).
// A node whose whole cube is occupied is a leaf, as OctoMap's prune() makes it.

constexpr int kTreeDepth = 16;
constexpr int kCubeLevels = kTreeDepth - 3;  // depth of the 8^3 cubes

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

class BtEncoder {
 public:
  explicit BtEncoder(std::vector<Cube> cubes) : cubes_(std::move(cubes)) {
    full_prefix_.resize(cubes_.size() + 1, 0);
    for (std::size_t i = 0; i < cubes_.size(); ++i)
      full_prefix_[i + 1] = full_prefix_[i] + (cubes_[i].full() ? 1 : 0);
  }
  /// Encodes the tree; returns the node count (OctoMap's size()).
  std::size_t encode(std::string& out) {
    if (cubes_.empty()) return 0;  // no root: OctoMap writes no data either
    out_ = &out;
    nodes_ = 1;
    encode_range(0, cubes_.size(), 0);
    return nodes_;
  }

 private:
  /// Child index (0..7) of cube i under a node at `depth` (< kCubeLevels).
  [[nodiscard]] unsigned child_of(std::size_t i, int depth) const {
    return static_cast<unsigned>((cubes_[i].morton >> (3 * (kCubeLevels - 1 - depth))) & 7u);
  }
  /// Cubes [b, e) all lie under one node at `depth`: is that node entirely occupied?
  [[nodiscard]] bool range_full(std::size_t b, std::size_t e, int depth) const {
    const std::size_t need = std::size_t{1} << (3 * (kCubeLevels - depth));
    return e - b == need && full_prefix_[e] - full_prefix_[b] == need;
  }
  /// Writes the node above cubes [b, e) at `depth` (an inner node: not full, not empty).
  void encode_range(std::size_t b, std::size_t e, int depth) {
    if (depth == kCubeLevels) {
      encode_cube(cubes_[b].bits, 0, 0, 0, 8);
      return;
    }
    std::array<std::size_t, 9> split{};
    split[0] = b;
    std::size_t i = b;
    for (unsigned c = 0; c < 8; ++c) {
      while (i < e && child_of(i, depth) == c) ++i;
      split[c + 1] = i;
    }
    std::uint16_t code = 0;
    for (unsigned c = 0; c < 8; ++c) {
      if (split[c] == split[c + 1]) continue;
      ++nodes_;
      code |= static_cast<std::uint16_t>((range_full(split[c], split[c + 1], depth + 1) ? 2u : 3u)
                                         << (2 * c));
    }
    put(code);
    for (unsigned c = 0; c < 8; ++c)
      if (((code >> (2 * c)) & 3u) == 3u) encode_range(split[c], split[c + 1], depth + 1);
  }
  /// Occupied voxels of the sub-cube at (x0, y0, z0) of edge n inside one 8^3 cube.
  static int count(const std::array<std::uint64_t, 8>& bits, int x0, int y0, int z0, int n) {
    const std::uint64_t row = ((std::uint64_t{1} << n) - 1) << x0;
    std::uint64_t rows = 0;
    for (int y = y0; y < y0 + n; ++y) rows |= row << (8 * y);
    int total = 0;
    for (int z = z0; z < z0 + n; ++z) total += popcount64(bits[static_cast<std::size_t>(z)] & rows);
    return total;
  }
  void encode_cube(const std::array<std::uint64_t, 8>& bits, int x0, int y0, int z0, int n) {
    const int h = n / 2;
    std::uint16_t code = 0;
    for (unsigned c = 0; c < 8; ++c) {
      const int cx = x0 + ((c & 1u) ? h : 0), cy = y0 + ((c & 2u) ? h : 0),
                cz = z0 + ((c & 4u) ? h : 0);
      const int occupied = count(bits, cx, cy, cz, h);
      if (occupied == 0) continue;
      ++nodes_;
      code |= static_cast<std::uint16_t>((occupied == h * h * h ? 2u : 3u) << (2 * c));
    }
    put(code);
    for (unsigned c = 0; c < 8; ++c)
      if (((code >> (2 * c)) & 3u) == 3u)
        encode_cube(bits, x0 + ((c & 1u) ? h : 0), y0 + ((c & 2u) ? h : 0), z0 + ((c & 4u) ? h : 0),
                    h);
  }
  void put(std::uint16_t code) {
    // Two bits per child, child i at bits 2i (low) and 2i+1 (high) of its byte: OctoMap's
    // bitset order. Occupied leaf = (0, 1), inner = (1, 1).
    auto byte_of = [](unsigned quad) {
      unsigned out = 0;
      for (unsigned i = 0; i < 4; ++i) {
        const unsigned v = (quad >> (2 * i)) & 3u;  // 2: leaf, 3: inner
        if (v == 2u) out |= 1u << (2 * i + 1);
        if (v == 3u) out |= 3u << (2 * i);
      }
      return static_cast<char>(out);
    };
    out_->push_back(byte_of(code & 0xFFu));
    out_->push_back(byte_of(code >> 8));
  }

  std::vector<Cube> cubes_;
  std::vector<std::size_t> full_prefix_;
  std::string* out_ = nullptr;
  std::size_t nodes_ = 0;
};

/// The voxels of the grid as 8^3 cubes aligned on OctoMap keys, in tree order. The grid's
/// blocks are offset from the cubes by the same (sx, sy, sz) voxels: block (bx, by, bz)
/// feeds cubes (bx, by, bz) + (0|1, 0|1, 0|1) (relative to the cube of block 0). Cubes are
/// assembled two layers at a time, so memory is the finished cubes plus two layers.
std::vector<Cube> cubes_of(const VoxelGrid& grid) {
  // OctoMap key of voxel k: k + offset (its centre's coordinate / resolution, floored, + 2^15).
  Eigen::Vector3i offset;
  for (int a = 0; a < 3; ++a)
    offset[a] = static_cast<int>(std::llround(grid.origin_mm()[a] / grid.voxel_mm())) + 32768;
  const auto sx = static_cast<unsigned>(offset.x() & 7), sy = static_cast<unsigned>(offset.y() & 7),
             sz = static_cast<unsigned>(offset.z() & 7);
  const auto qx = static_cast<std::uint32_t>(offset.x() >> 3),
             qy = static_cast<std::uint32_t>(offset.y() >> 3),
             qz = static_cast<std::uint32_t>(offset.z() >> 3);
  const Eigen::Vector3i nb = VoxelBlocks::block_dims(grid);
  const int ncx = nb.x() + 1, ncy = nb.y() + 1;
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
  std::array<Layer, 2> layers;
  for (auto& l : layers)
    l.bits.assign(static_cast<std::size_t>(ncx) * static_cast<std::size_t>(ncy), Bits{});
  std::vector<Cube> cubes;
  cubes.reserve(VoxelBlocks::block_count(grid));
  auto flush = [&](int cz) {  // cube layer cz is complete
    auto& layer = layers[static_cast<std::size_t>(cz & 1)];
    for (const std::uint32_t cell : layer.touched) {
      Bits& bits = layer.bits[cell];
      const auto cx = static_cast<std::uint32_t>(cell % static_cast<std::uint32_t>(ncx)),
                 cy = static_cast<std::uint32_t>(cell / static_cast<std::uint32_t>(ncx));
      Cube c;
      c.morton = morton3(qx + cx, qy + cy, qz + static_cast<std::uint32_t>(cz));
      c.bits = bits;
      cubes.push_back(c);
      bits = Bits{};
    }
    layer.touched.clear();
  };
  // A block straddles up to 2 x 2 x 2 cubes: each z-slice's columns and rows are shifted
  // into them (bit y * 8 + x). Blocks come in z, y, x order: cube layer cz is complete once
  // a block of layer cz + 1 comes.
  const std::uint64_t low_columns = 0x0101010101010101ull * (0xFFu >> sx);  // x < 8 - sx
  int flushed = 0;                                                          // cube layers done
  VoxelBlocks::visit_blocks(grid, [&](const VoxelBlocks::BlockView& block) {
    const int bx = block.base.x / VoxelBlocks::kBlockEdge,
              by = block.base.y / VoxelBlocks::kBlockEdge,
              bz = block.base.z / VoxelBlocks::kBlockEdge;
    for (; flushed < bz; ++flushed) flush(flushed);
    for (unsigned z = 0; z < 8; ++z) {
      const std::uint64_t w = block.occupancy[z];
      if (w == 0) continue;
      const unsigned zz = z + sz;
      auto& layer = layers[static_cast<std::size_t>((bz + static_cast<int>(zz >> 3)) & 1)];
      const std::uint64_t x_parts[2] = {(w & low_columns) << sx,
                                        sx == 0 ? 0 : (w & ~low_columns) >> (8 - sx)};
      for (int dx = 0; dx < 2; ++dx) {
        const std::uint64_t p = x_parts[dx];
        if (p == 0) continue;
        const auto cell = static_cast<std::size_t>(by) * static_cast<std::size_t>(ncx) +
                          static_cast<std::size_t>(bx + dx);
        if (const std::uint64_t rows = p << (8 * sy); rows != 0)  // rows y < 8 - sy
          layer.at(cell)[zz & 7u] |= rows;
        if (sy != 0)
          if (const std::uint64_t rows = p >> (8 * (8 - sy)); rows != 0)
            layer.at(cell + static_cast<std::size_t>(ncx))[zz & 7u] |= rows;
      }
    }
  });
  for (; flushed <= nb.z(); ++flushed) flush(flushed);
  std::sort(cubes.begin(), cubes.end(),
            [](const Cube& a, const Cube& b) { return a.morton < b.morton; });
  return cubes;
}

/// The text header OctoMap writes before the nodes (`binary`: .bt, else .ot).
std::string octomap_header(bool binary, const char* tree_type, std::size_t nodes,
                           double resolution) {
  std::ostringstream head;
  head << (binary ? "# Octomap OcTree binary file\n" : "# Octomap OcTree file\n")
       << "# (feel free to add / change comments, but leave the first line as it is!)\n#\n"
       << "id " << tree_type << "\nsize " << nodes << "\nres " << resolution << "\ndata\n";
  return head.str();
}

std::string encode_bt(const VoxelGrid& grid) {
  BtEncoder encoder(cubes_of(grid));
  std::string data;
  const std::size_t nodes = encoder.encode(data);
  return octomap_header(true, "OcTree", nodes, grid.voxel_mm()) + data;
}

// --- .ot written straight from the grid ------------------------------------------------
// The ColorOcTree file (AbstractOcTree::write): a text header, then the nodes depth-first
// (OcTreeBaseImpl::writeNodesRecurs): per node its log-odds occupancy (float), its colour
// (r, g, b bytes), a byte with one bit per existing child, then the existing children in
// child order. Every voxel is occupied at the clamping maximum, so every inner node holds
// the same value (OctoMap's updateInnerOccupancy sets the maximum of the children); an inner
// node's colour is ColorOcTreeNode::getAverageChildColor of its children (the integer mean
// of the children whose colour is not pure white; white when none is). A node whose eight
// children are leaves of one colour is written as one leaf of that colour (lossless: unlike
// OctoMap's own ColorOcTree pruning, which ignores colour), so full 8^3 cubes of one layer or
// feature cost one node. The cubes are the .bt encoder's; a voxel's colour is looked up in
// its grid block when its cube is written.

// A node as one word: colour 0xRRGGBB in the low 24 bits, its kind above (0: absent).
using OtNode = std::uint32_t;
constexpr OtNode kLeaf = 1u << 24, kInner = 2u << 24, kWhite = 0xFFFFFFu;

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
  /// Appends a record; returns its offset.
  std::uint64_t put(const char* record) {
    if (size_ - base_ + kRecord > kBytes) [[unlikely]]
      flush();
    std::memcpy(buffer_.get() + (size_ - base_), record, kRecord);
    size_ += kRecord;
    return size_ - kRecord;
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

  static constexpr std::size_t kRecord = 8;

 private:
  static constexpr std::size_t kBytes = std::size_t{1} << 20;
  int fd_;
  std::uint64_t start_;
  std::unique_ptr<char[]> buffer_;
  std::uint64_t base_ = 0;  // offset of buffer_[0]
  std::uint64_t size_ = 0;  // offset of the next record
  bool ok_ = true;
};

class OtEncoder {
 public:
  OtEncoder(const VoxelGrid& grid, std::vector<Cube> cubes, VoxelColoring coloring,
            float occupied_log_odds)
      : grid_(grid), cubes_(std::move(cubes)) {
    const auto& table = VoxelBlocks::tag_table(grid);
    colours_.reserve(table.size());
    for (const auto& tag : table)
      colours_.push_back(pack(coloring == VoxelColoring::layer
                                  ? deposit_detail::layer_color(tag.layer)
                                  : deposit_detail::feature_color(tag.feature)));
    for (int a = 0; a < 3; ++a)
      offset_[a] = static_cast<int>(std::llround(grid.origin_mm()[a] / grid.voxel_mm())) + 32768;
    std::memcpy(record_, &occupied_log_odds, 4);
    // Every cube starts at the same place inside its grid block (offsets below 8): where
    // each of its voxels lies among the up to 2 x 2 x 2 blocks it overlaps.
    int shift[3];
    for (int a = 0; a < 3; ++a) shift[a] = (-offset_[a]) & 7;
    for (int bit = 0; bit < 64; ++bit) {
      const int lx = shift[0] + (bit & 7), ly = shift[1] + (bit >> 3);
      xy_block_[static_cast<std::size_t>(bit)] =
          static_cast<std::uint8_t>((lx >> 3) | ((ly >> 3) << 1));
      xy_slot_[static_cast<std::size_t>(bit)] = static_cast<std::uint8_t>((ly & 7) * 8 + (lx & 7));
    }
    for (int z = 0; z < 8; ++z) {
      const int lz = shift[2] + z;
      z_block_[static_cast<std::size_t>(z)] = static_cast<std::uint8_t>((lz >> 3) << 2);
      z_slot_[static_cast<std::size_t>(z)] = static_cast<std::uint16_t>((lz & 7) * 64);
    }
  }
  /// Nodes of the encoded tree at most: per cube its voxels and at most min(voxels, 64) +
  /// min(voxels, 8) + 1 nodes above them inside the cube, plus a chain of kCubeLevels
  /// ancestors.
  [[nodiscard]] std::size_t max_nodes() const {
    std::size_t nodes = 0;
    for (const auto& c : cubes_) {
      std::size_t n = 0;
      for (const auto w : c.bits) n += static_cast<std::size_t>(popcount64(w));
      nodes += n + std::min<std::size_t>(n, 64) + std::min<std::size_t>(n, 8) + 1 + kCubeLevels;
    }
    return nodes;
  }
  /// Encodes the tree into `out`; returns the node count (OctoMap's size()).
  std::size_t encode(RecordSink& out) {
    out_ = &out;
    nodes_ = 0;
    if (!cubes_.empty()) encode_range(0, cubes_.size(), 0);
    return nodes_;
  }

 private:
  [[nodiscard]] unsigned child_of(std::size_t i, int depth) const {
    return static_cast<unsigned>((cubes_[i].morton >> (3 * (kCubeLevels - 1 - depth))) & 7u);
  }
  /// Appends a node record (value, colour, child bits); returns its offset in the output.
  std::uint64_t put_node(OtNode node, std::uint8_t children) {
    record_[4] = static_cast<char>(node >> 16), record_[5] = static_cast<char>(node >> 8);
    record_[6] = static_cast<char>(node), record_[7] = static_cast<char>(children);
    ++nodes_;
    return out_->put(record_);
  }
  OtNode encode_range(std::size_t b, std::size_t e, int depth) {
    if (depth == kCubeLevels) return encode_cube(cubes_[b]);
    std::array<std::size_t, 9> split{};
    split[0] = b;
    std::size_t i = b;
    std::uint8_t mask = 0;
    for (unsigned c = 0; c < 8; ++c) {
      while (i < e && child_of(i, depth) == c) ++i;
      split[c + 1] = i;
      if (split[c] != split[c + 1]) mask = static_cast<std::uint8_t>(mask | (1u << c));
    }
    const std::uint64_t at = put_node(kInner | kWhite, mask);
    const std::size_t nodes_before = nodes_;
    std::array<OtNode, 8> children{};
    for (unsigned c = 0; c < 8; ++c)
      if (split[c] != split[c + 1]) children[c] = encode_range(split[c], split[c + 1], depth + 1);
    const OtNode node = parent_of(children.data());
    if (node & kLeaf) {  // eight leaves of one colour: one leaf instead
      out_->truncate(at);
      nodes_ = nodes_before - 1;
      put_node(node, 0);
    } else {
      const char colour[3] = {static_cast<char>(node >> 16), static_cast<char>(node >> 8),
                              static_cast<char>(node)};
      out_->patch(at + 4, colour, 3);
    }
    return node;
  }
  /// A grid block as the cube reads it: the colour of each palette entry, or of each slot
  /// when the block is wide.
  struct BlockColours {
    const std::uint8_t* nibbles = nullptr;
    const std::uint32_t* wide = nullptr;
    std::array<OtNode, VoxelBlocks::kPaletteSize> palette{};
  };
  /// The packed leaf of every voxel of the cube (slot z * 64 + y * 8 + x; 0 where empty).
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
      const int g0 = static_cast<int>(k[a] * 8) - offset_[a];
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
          OtNode c = b.wide == nullptr && view->palette_size > 0 ? colours_[view->palette[0]] : 0;
          for (int i = 0; i < view->palette_size; ++i) {
            b.palette[static_cast<std::size_t>(i)] = colours_[view->palette[i]];
            if (b.palette[static_cast<std::size_t>(i)] != c) c = 0;
          }
          shared = shared == ~OtNode{0} ? c : (shared == c ? c : 0);
        }
    if (shared != 0 && cube.full()) return shared;  // the caller writes one leaf
    voxel_.fill(0);
    for (std::size_t z = 0; z < 8; ++z) {
      std::uint64_t w = cube.bits[z];
      OtNode* slice = voxel_.data() + z * 64;
      if (shared != 0) {
        for (; w != 0; w &= w - 1) slice[std::countr_zero(w)] = shared;
        continue;
      }
      const unsigned z_block = z_block_[z], z_slot = z_slot_[z];
      for (; w != 0; w &= w - 1) {
        const auto bit = static_cast<std::size_t>(std::countr_zero(w));
        const BlockColours& b = blocks_[z_block | xy_block_[bit]];
        const unsigned slot = z_slot + xy_slot_[bit];
        slice[bit] = b.wide != nullptr
                         ? colours_[b.wide[slot]]
                         : b.palette[(b.nibbles[slot >> 1] >> ((slot & 1u) * 4)) & 15u];
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
    // Levels inside the cube, bottom-up: 8^3 voxels -> 4^3 -> 2^3 -> the cube's node.
    reduce(voxel_.data(), 8, l1_.data());
    reduce(l1_.data(), 4, l2_.data());
    OtNode root = 0;
    reduce(l2_.data(), 2, &root);
    write_cube_node(root, 3, 0, 0, 0);
    return root;
  }
  /// Parents (edge n / 2) of the nodes of one level (edge n, index z * n * n + y * n + x).
  static void reduce(const OtNode* level, int n, OtNode* parents) {
    const int h = n / 2;
    for (int z = 0; z < h; ++z)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < h; ++x) {
          const OtNode* c = level + (2 * z * n + 2 * y) * n + 2 * x;
          const OtNode children[8] = {c[0],     c[1],         c[n],         c[n + 1],
                                      c[n * n], c[n * n + 1], c[n * n + n], c[n * n + n + 1]};
          const bool any = (children[0] | children[1] | children[2] | children[3] | children[4] |
                            children[5] | children[6] | children[7]) != 0;
          parents[(z * h + y) * h + x] = any ? parent_of(children) : 0;
        }
  }
  /// Writes node (x, y, z) of cube level `level` (0: voxels, 3: the cube) and its subtree.
  void write_cube_node(OtNode node, int level, int x, int y, int z) {
    if (node & kLeaf) {
      put_node(node, 0);
      return;
    }
    const int n = 8 >> (level - 1);  // edge of the child level
    const OtNode* below = level == 1 ? voxel_.data() : level == 2 ? l1_.data() : l2_.data();
    OtNode children[8];
    std::uint8_t mask = 0;
    for (unsigned c = 0; c < 8; ++c) {
      const int cx = 2 * x + static_cast<int>(c & 1u), cy = 2 * y + static_cast<int>((c >> 1) & 1u),
                cz = 2 * z + static_cast<int>(c >> 2);
      children[c] = below[(cz * n + cy) * n + cx];
      if (children[c] != 0) mask = static_cast<std::uint8_t>(mask | (1u << c));
    }
    put_node(node, mask);
    if (level == 1) {  // the children are voxels: leaves
      for (const OtNode c : children)
        if (c != 0) put_node(c, 0);
      return;
    }
    for (unsigned c = 0; c < 8; ++c)
      if (children[c] != 0)
        write_cube_node(children[c], level - 1, 2 * x + static_cast<int>(c & 1u),
                        2 * y + static_cast<int>((c >> 1) & 1u), 2 * z + static_cast<int>(c >> 2));
  }

  const VoxelGrid& grid_;
  std::vector<Cube> cubes_;
  std::vector<OtNode> colours_;  // per tag index, packed as a leaf
  int offset_[3] = {0, 0, 0};
  char record_[RecordSink::kRecord] = {};
  std::array<std::uint8_t, 64> xy_block_{};  // per bit y * 8 + x of a cube slice: its block
  std::array<std::uint8_t, 64> xy_slot_{};   // ... and its slot's y * 8 + x there
  std::array<std::uint8_t, 8> z_block_{};    // per cube slice z: its block (z bit)
  std::array<std::uint16_t, 8> z_slot_{};    // ... and its slot's z * 64 there
  std::array<BlockColours, 8> blocks_{};
  std::array<OtNode, 512> voxel_{};
  std::array<OtNode, 64> l1_{};
  std::array<OtNode, 8> l2_{};
  RecordSink* out_ = nullptr;
  std::size_t nodes_ = 0;
};

/// Writes the .ot file into `fd`: the node records first, streamed from where the longest
/// header their count could need ends, then the header; when the header is shorter, the
/// records are moved up to it. False when a write fails.
bool write_ot(int fd, const VoxelGrid& grid, VoxelColoring coloring) {
  const octomap::ColorOcTree reference(grid.voxel_mm());  // empty: for its occupancy constants
  OtEncoder encoder(grid, cubes_of(grid), coloring, reference.getClampingThresMaxLog());
  const std::uint64_t start =
      octomap_header(false, "ColorOcTree", encoder.max_nodes(), grid.voxel_mm()).size();
  RecordSink sink(fd, start);
  const std::size_t nodes = encoder.encode(sink);
  sink.flush();
  const std::string header = octomap_header(false, "ColorOcTree", nodes, grid.voxel_mm());
  if (!sink.ok() || header.size() > start) return false;
  const std::uint64_t size = sink.size();
  if (header.size() < start) {  // move the records up, front to back
    std::vector<char> chunk(std::size_t{1} << 20);
    for (std::uint64_t done = 0; done < size;) {
      const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(chunk.size(), size - done));
      const ssize_t got = ::pread(fd, chunk.data(), n, static_cast<off_t>(start + done));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0 ||
          !write_at(fd, chunk.data(), static_cast<std::size_t>(got), header.size() + done))
        return false;
      done += static_cast<std::uint64_t>(got);
    }
  }
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
