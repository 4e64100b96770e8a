// OctoMap adapter: the only file that includes OctoMap. Exports the deposit as .bt (binary
// occupancy OcTree, pruned; encoded here straight from the grid, byte for byte what OctoMap's
// writeBinary produces) or .ot (ColorOcTree built with OctoMap, every voxel a leaf with its
// layer or feature colour), and reads such files back. Coordinates and resolution are in millimetres (octovis
// shows any unit); voxel centres map to OctoMap keys one to one since the resolution equals
// the voxel size.
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>
#include <cctype>
#include <memory>
#include <sstream>

#include "deposit/palette.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

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
  const Vec3 lo = grid.origin_mm();
  const Vec3 hi = lo + grid.voxel_mm() * grid.dims().cast<double>();
  if (lo.cwiseAbs().maxCoeff() >= limit || hi.cwiseAbs().maxCoeff() >= limit)
    return usage_error("the deposit does not fit OctoMap's key range (+-" + format_number(limit) +
                       " mm at voxel " + format_number(grid.voxel_mm()) + " mm)");
  return Ok{};
}

/// Inserts every voxel as a leaf (the .ot path: ColorOcTree keeps every voxel for its colour).
template <class Tree>
void insert_voxels(const VoxelGrid& grid, Tree& tree, const std::function<void(typename Tree::NodeType*, const VoxelTag&)>& paint) {
  const float occupied = tree.getClampingThresMaxLog();
  grid.for_each([&](const VoxelKey& k, const VoxelTag& tag) {
    const Vec3 c = grid.center_mm(k);
    const octomap::OcTreeKey key =
        tree.coordToKey(octomap::point3d(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                         static_cast<float>(c.z())));
    auto* node = tree.setNodeValue(key, occupied, /*lazy_eval=*/true);
    if (paint && node != nullptr) paint(node, tag);
  });
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
  std::uint64_t morton = 0;  // interleaved cube key bits (z y x per level, most significant level first)
  std::array<std::uint64_t, 8> bits{};  // per z-slice, bit y * 8 + x
  [[nodiscard]] bool full() const {
    return std::all_of(bits.begin(), bits.end(), [](std::uint64_t w) { return w == ~std::uint64_t{0}; });
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
    for (std::size_t i = 0; i < cubes_.size(); ++i) full_prefix_[i + 1] = full_prefix_[i] + (cubes_[i].full() ? 1 : 0);
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
      code |= static_cast<std::uint16_t>((range_full(split[c], split[c + 1], depth + 1) ? 2u : 3u) << (2 * c));
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
    for (int z = z0; z < z0 + n; ++z) total += std::popcount(bits[static_cast<std::size_t>(z)] & rows);
    return total;
  }
  void encode_cube(const std::array<std::uint64_t, 8>& bits, int x0, int y0, int z0, int n) {
    const int h = n / 2;
    std::uint16_t code = 0;
    for (unsigned c = 0; c < 8; ++c) {
      const int cx = x0 + ((c & 1u) ? h : 0), cy = y0 + ((c & 2u) ? h : 0), cz = z0 + ((c & 4u) ? h : 0);
      const int occupied = count(bits, cx, cy, cz, h);
      if (occupied == 0) continue;
      ++nodes_;
      code |= static_cast<std::uint16_t>((occupied == h * h * h ? 2u : 3u) << (2 * c));
    }
    put(code);
    for (unsigned c = 0; c < 8; ++c)
      if (((code >> (2 * c)) & 3u) == 3u)
        encode_cube(bits, x0 + ((c & 1u) ? h : 0), y0 + ((c & 2u) ? h : 0), z0 + ((c & 4u) ? h : 0), h);
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

/// The voxels of the grid as 8^3 cubes aligned on OctoMap keys, in tree order.
std::vector<Cube> cubes_of(const VoxelGrid& grid) {
  // OctoMap key of voxel k: k + offset (its centre's coordinate / resolution, floored, + 2^15).
  Eigen::Vector3i offset;
  for (int a = 0; a < 3; ++a)
    offset[a] = static_cast<int>(std::llround(grid.origin_mm()[a] / grid.voxel_mm())) + 32768;
  std::vector<Cube> cubes;
  auto cube_at = [&](std::uint32_t cx, std::uint32_t cy, std::uint32_t cz) -> Cube& {
    const std::uint64_t m = morton3(cx, cy, cz);
    if (cubes.empty() || cubes.back().morton != m) {
      cubes.emplace_back();
      cubes.back().morton = m;
    }
    return cubes.back();
  };
  const bool aligned = offset.x() % 8 == 0 && offset.y() % 8 == 0 && offset.z() % 8 == 0;
  grid.visit_blocks([&](const VoxelGrid::BlockView& b) {
    const auto kx = static_cast<std::uint32_t>(b.base.x + offset.x());
    const auto ky = static_cast<std::uint32_t>(b.base.y + offset.y());
    const auto kz = static_cast<std::uint32_t>(b.base.z + offset.z());
    if (aligned) {
      Cube& c = cube_at(kx >> 3, ky >> 3, kz >> 3);
      for (int z = 0; z < 8; ++z) c.bits[static_cast<std::size_t>(z)] |= b.occupancy[z];
      return;
    }
    // A block straddles up to 2 x 2 x 2 cubes: bin its voxels into them, keep the non-empty.
    std::array<Cube, 8> local{};
    for (int z = 0; z < 8; ++z) {
      std::uint64_t w = b.occupancy[z];
      while (w != 0) {
        const int bit = std::countr_zero(w);
        w &= w - 1;
        const std::uint32_t x = (kx & 7u) + static_cast<std::uint32_t>(bit & 7);
        const std::uint32_t y = (ky & 7u) + static_cast<std::uint32_t>(bit >> 3);
        const std::uint32_t zz = (kz & 7u) + static_cast<std::uint32_t>(z);
        local[(x >> 3) | ((y >> 3) << 1) | ((zz >> 3) << 2)].bits[zz & 7u] |= std::uint64_t{1} << ((y & 7u) * 8 + (x & 7u));
      }
    }
    for (std::uint32_t c = 0; c < 8; ++c) {
      if (std::all_of(local[c].bits.begin(), local[c].bits.end(), [](std::uint64_t v) { return v == 0; })) continue;
      Cube& out = cube_at((kx >> 3) + (c & 1u), (ky >> 3) + ((c >> 1) & 1u), (kz >> 3) + (c >> 2));
      for (std::size_t z = 0; z < 8; ++z) out.bits[z] |= local[c].bits[z];
    }
  });
  std::sort(cubes.begin(), cubes.end(), [](const Cube& a, const Cube& b) { return a.morton < b.morton; });
  // Unaligned grids (and blocks visited out of Morton order) leave several pieces per cube.
  std::vector<Cube> merged;
  merged.reserve(cubes.size());
  for (const auto& c : cubes) {
    if (!merged.empty() && merged.back().morton == c.morton) {
      for (std::size_t z = 0; z < 8; ++z) merged.back().bits[z] |= c.bits[z];
    } else {
      merged.push_back(c);
    }
  }
  return merged;
}

std::string encode_bt(const VoxelGrid& grid) {
  BtEncoder encoder(cubes_of(grid));
  std::string data;
  const std::size_t nodes = encoder.encode(data);
  std::ostringstream head;
  head << "# Octomap OcTree binary file\n# (feel free to add / change comments, but leave the first line as it is!)\n#\n";
  head << "id OcTree\n";
  head << "size " << nodes << "\n";
  head << "res " << grid.voxel_mm() << "\n";
  head << "data\n";
  return head.str() + data;
}

}  // namespace

Status write_octomap(const VoxelGrid& grid, const std::filesystem::path& path, VoxelColoring coloring) {
  const std::string ext = lower_extension(path);
  if (ext != ".bt" && ext != ".ot")
    return usage_error("OctoMap output must end in .bt or .ot: " + path.string());
  if (auto st = check_key_range(grid); !st) return st.error();
  std::ostringstream bytes(std::ios::binary);
  if (ext == ".bt") return write_file_atomic(path, encode_bt(grid));
  {
    octomap::ColorOcTree tree(grid.voxel_mm());
    insert_voxels<octomap::ColorOcTree>(
        grid, tree, [coloring](octomap::ColorOcTreeNode* node, const VoxelTag& tag) {
          const auto c = coloring == VoxelColoring::layer ? deposit_detail::layer_color(tag.layer)
                                                          : deposit_detail::feature_color(tag.feature);
          node->setColor(c.r, c.g, c.b);
        });
    // ColorOcTree's pruning ignores colours: keep every voxel a leaf so colours survive.
    // An empty deposit leaves the tree without a root, which updateInnerOccupancy does not
    // expect; written as it is, it is a valid empty tree.
    if (tree.size() > 0) tree.updateInnerOccupancy();
    if (!tree.write(bytes)) return internal_error("OctoMap could not serialise " + path.string());
  }
  return write_file_atomic(path, bytes.str());
}

Result<std::size_t> count_octomap_voxels(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  std::unique_ptr<octomap::AbstractOcTree> owned;
  std::unique_ptr<octomap::OcTree> bt;
  if (ext == ".bt") {
    bt = std::make_unique<octomap::OcTree>(0.1);
    if (!bt->readBinary(path.string())) return bad_input("not a readable OctoMap .bt file", path.string());
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
