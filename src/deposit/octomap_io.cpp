// OctoMap adapter: the only file that includes OctoMap. Exports the deposit as .bt (binary
// occupancy OcTree, pruned) or .ot (ColorOcTree, every voxel coloured by layer or feature),
// both encoded here straight from the grid's blocks in OctoMap's file formats (the same
// bytes as OctoMap's writeBinary for .bt; for .ot the tree OctoMap's insert path builds,
// with uniform-colour subtrees pruned), and reads such files back with OctoMap.
// Coordinates and resolution are in millimetres (octovis shows any unit); voxel centres map
// to OctoMap keys one to one since the resolution equals the voxel size.
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

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
    for (int z = z0; z < z0 + n; ++z)
      total += std::popcount(bits[static_cast<std::size_t>(z)] & rows);
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
  std::array<std::vector<Bits>, 2> layers;
  for (auto& l : layers)
    l.assign(static_cast<std::size_t>(ncx) * static_cast<std::size_t>(ncy), Bits{});
  std::vector<Cube> cubes;
  auto flush = [&](int cz) {  // cube layer cz is complete
    auto& layer = layers[static_cast<std::size_t>(cz & 1)];
    for (int cy = 0; cy < ncy; ++cy)
      for (int cx = 0; cx < ncx; ++cx) {
        Bits& bits = layer[static_cast<std::size_t>(cy) * static_cast<std::size_t>(ncx) +
                           static_cast<std::size_t>(cx)];
        if (std::all_of(bits.begin(), bits.end(), [](std::uint64_t v) { return v == 0; })) continue;
        Cube c;
        c.morton = morton3(qx + static_cast<std::uint32_t>(cx), qy + static_cast<std::uint32_t>(cy),
                           qz + static_cast<std::uint32_t>(cz));
        c.bits = bits;
        cubes.push_back(c);
        bits = Bits{};
      }
  };
  // A block straddles up to 2 x 2 x 2 cubes: each z-slice's columns and rows are shifted
  // into them (bit y * 8 + x).
  const std::uint64_t low_columns = 0x0101010101010101ull * (0xFFu >> sx);  // x < 8 - sx
  for (int bz = 0; bz < nb.z(); ++bz) {
    for (int by = 0; by < nb.y(); ++by)
      for (int bx = 0; bx < nb.x(); ++bx) {
        const std::uint64_t* occupancy = VoxelBlocks::block_occupancy(grid, bx, by, bz);
        if (occupancy == nullptr) continue;
        for (unsigned z = 0; z < 8; ++z) {
          const std::uint64_t w = occupancy[z];
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
            layer[cell][zz & 7u] |= p << (8 * sy);  // rows y < 8 - sy
            if (sy != 0)
              layer[cell + static_cast<std::size_t>(ncx)][zz & 7u] |= p >> (8 * (8 - sy));
          }
        }
      }
    flush(bz);
  }
  flush(nb.z());
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
  }
  /// Bytes the encoded tree needs at most, 8 a node: per cube its voxels and at most
  /// min(voxels, 64) + min(voxels, 8) + 1 nodes above them inside the cube, plus a chain of
  /// kCubeLevels ancestors.
  [[nodiscard]] std::size_t max_bytes() const {
    std::size_t nodes = 0;
    for (const auto& c : cubes_) {
      std::size_t n = 0;
      for (const auto w : c.bits) n += static_cast<std::size_t>(std::popcount(w));
      nodes += n + std::min<std::size_t>(n, 64) + std::min<std::size_t>(n, 8) + 1 + kCubeLevels;
    }
    return 8 * nodes;
  }
  /// Encodes the tree into `out` (max_bytes() of room); returns the node count (OctoMap's
  /// size()); size() is then the bytes written.
  std::size_t encode(char* out) {
    out_ = out;
    size_ = 0;
    nodes_ = 0;
    if (!cubes_.empty()) encode_range(0, cubes_.size(), 0);
    return nodes_;
  }
  [[nodiscard]] std::size_t size() const { return size_; }

 private:
  [[nodiscard]] unsigned child_of(std::size_t i, int depth) const {
    return static_cast<unsigned>((cubes_[i].morton >> (3 * (kCubeLevels - 1 - depth))) & 7u);
  }
  /// Appends a node record (value, colour, child bits); returns its offset in the output.
  std::size_t put_node(OtNode node, std::uint8_t children) {
    const std::size_t at = size_;
    record_[4] = static_cast<char>(node >> 16), record_[5] = static_cast<char>(node >> 8);
    record_[6] = static_cast<char>(node), record_[7] = static_cast<char>(children);
    std::memcpy(out_ + at, record_, sizeof record_);
    size_ += sizeof record_;
    ++nodes_;
    return at;
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
    const std::size_t at = put_node(kInner | kWhite, mask);
    const std::size_t nodes_before = nodes_;
    std::array<OtNode, 8> children{};
    for (unsigned c = 0; c < 8; ++c)
      if (split[c] != split[c + 1]) children[c] = encode_range(split[c], split[c + 1], depth + 1);
    const OtNode node = parent_of(children.data());
    if (node & kLeaf) {  // eight leaves of one colour: one leaf instead
      size_ = at;
      nodes_ = nodes_before - 1;
      put_node(node, 0);
    } else {
      out_[at + 4] = static_cast<char>(node >> 16);
      out_[at + 5] = static_cast<char>(node >> 8);
      out_[at + 6] = static_cast<char>(node);
    }
    return node;
  }
  /// The packed leaf of every voxel of the cube (slot z * 64 + y * 8 + x; 0 where empty).
  /// Returns the colour all of them share when every grid block they come from has one
  /// colour for all its tags (then the voxels are filled without a per-voxel look-up),
  /// else 0.
  OtNode gather(const Cube& cube) {
    std::uint32_t k[3] = {0, 0, 0};
    for (int level = 0; level < kCubeLevels; ++level)
      for (int a = 0; a < 3; ++a)
        k[a] |= static_cast<std::uint32_t>((cube.morton >> (3 * level + a)) & 1u) << level;
    int g0[3], b0[3], spans[3];
    for (int a = 0; a < 3; ++a) {
      g0[a] = static_cast<int>(k[a] * 8) - offset_[a];
      b0[a] = g0[a] >> 3;
      spans[a] = ((g0[a] + 7) >> 3) - b0[a] + 1;  // 1 when aligned, else 2
    }
    // The blocks the cube overlaps, each with its one colour (0 when its tags differ).
    std::array<std::optional<VoxelBlocks::BlockView>, 8> blocks;
    std::array<OtNode, 8> block_colour{};
    OtNode shared = ~OtNode{0};  // not yet known
    for (int dz = 0; dz < spans[2]; ++dz)
      for (int dy = 0; dy < spans[1]; ++dy)
        for (int dx = 0; dx < spans[0]; ++dx) {
          const auto bi = static_cast<std::size_t>(dx | (dy << 1) | (dz << 2));
          blocks[bi] = VoxelBlocks::block_view(grid_, b0[0] + dx, b0[1] + dy, b0[2] + dz);
          if (!blocks[bi]) continue;
          const auto& v = *blocks[bi];
          OtNode c = v.wide == nullptr && v.palette_size > 0 ? colours_[v.palette[0]] : 0;
          for (int i = 1; i < v.palette_size && c != 0; ++i)
            if (colours_[v.palette[i]] != c) c = 0;
          block_colour[bi] = c;
          shared = shared == ~OtNode{0} ? c : (shared == c ? c : 0);
        }
    if (shared != 0 && cube.full()) return shared;  // the caller writes one leaf
    voxel_.fill(0);
    for (int z = 0; z < 8; ++z) {
      std::uint64_t w = cube.bits[static_cast<std::size_t>(z)];
      while (w != 0) {
        const int bit = std::countr_zero(w);
        w &= w - 1;
        if (shared != 0) {
          voxel_[static_cast<std::size_t>(z) * 64 + static_cast<std::size_t>(bit)] = shared;
          continue;
        }
        const int gx = g0[0] + (bit & 7), gy = g0[1] + (bit >> 3), gz = g0[2] + z;
        const int block_of_eight =
            ((gx >> 3) - b0[0]) | (((gy >> 3) - b0[1]) << 1) | (((gz >> 3) - b0[2]) << 2);
        const auto bi = static_cast<std::size_t>(block_of_eight);
        voxel_[static_cast<std::size_t>(z) * 64 + static_cast<std::size_t>(bit)] =
            block_colour[bi] != 0
                ? block_colour[bi]
                : colours_[blocks[bi]->tag_index((gz & 7) * 64 + (gy & 7) * 8 + (gx & 7))];
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
  char record_[8] = {};
  std::array<OtNode, 512> voxel_{};
  std::array<OtNode, 64> l1_{};
  std::array<OtNode, 8> l2_{};
  char* out_ = nullptr;
  std::size_t size_ = 0;
  std::size_t nodes_ = 0;
};

/// The .ot file's bytes: the header written just before the nodes, in one buffer whose
/// untouched tail costs address space only.
struct OtBytes {
  std::unique_ptr<char[]> buffer;
  std::string_view bytes;
};

OtBytes encode_ot(const VoxelGrid& grid, VoxelColoring coloring) {
  const octomap::ColorOcTree reference(grid.voxel_mm());  // empty: for its occupancy constants
  OtEncoder encoder(grid, cubes_of(grid), coloring, reference.getClampingThresMaxLog());
  constexpr std::size_t kHeadRoom = 512;
  OtBytes out;
  out.buffer.reset(new char[kHeadRoom + encoder.max_bytes()]);
  const std::size_t nodes = encoder.encode(out.buffer.get() + kHeadRoom);
  const std::string text = octomap_header(false, "ColorOcTree", nodes, grid.voxel_mm());
  char* start = out.buffer.get() + kHeadRoom - text.size();
  std::copy(text.begin(), text.end(), start);
  out.bytes = std::string_view(start, text.size() + encoder.size());
  return out;
}

}  // namespace

Status write_octomap(const VoxelGrid& grid, const std::filesystem::path& path,
                     VoxelColoring coloring) {
  const std::string ext = lower_extension(path);
  if (ext != ".bt" && ext != ".ot")
    return usage_error("OctoMap output must end in .bt or .ot: " + path.string());
  if (auto st = check_key_range(grid); !st) return st.error();
  if (ext == ".bt") return write_file_atomic(path, encode_bt(grid));
  const OtBytes ot = encode_ot(grid, coloring);
  return write_file_atomic(path, ot.bytes);
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
