// Reads an OctoMap .ot (ColorOcTree) or .bt (OcTree) with OctoMap's own reader and prints
// its node count, its occupied voxels (a leaf above the bottom level counts for every voxel
// it covers) and an order-independent sum over (voxel key, colour): two files with the same
// voxels and colours print the same sum, however they are pruned. Used to compare the .ot
// printtwin writes with the one OctoMap's insert path writes (docs/deposit.md).
// Usage: octomap_voxel_sum FILE...
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

namespace {

std::uint64_t mix(std::uint64_t v) {
  v ^= v >> 33;
  v *= 0xff51afd7ed558ccdULL;
  v ^= v >> 33;
  v *= 0xc4ceb9fe1a85ec53ULL;
  return v ^ (v >> 33);
}

template <class Tree, class ColourOf>
void summarise(const char* name, const Tree& tree, ColourOf colour_of) {
  std::uint64_t voxels = 0, sum = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const int edge = 1 << (tree.getTreeDepth() - it.getDepth());
    const auto k = it.getIndexKey();
    const std::uint64_t colour = colour_of(*it);
    for (int z = 0; z < edge; ++z)
      for (int y = 0; y < edge; ++y)
        for (int x = 0; x < edge; ++x) {
          const std::uint64_t key = (std::uint64_t{k[0]} + static_cast<std::uint64_t>(x)) << 32 |
                                    (std::uint64_t{k[1]} + static_cast<std::uint64_t>(y)) << 16 |
                                    (std::uint64_t{k[2]} + static_cast<std::uint64_t>(z));
          sum += mix(key ^ (colour << 48));
          ++voxels;
        }
  }
  std::printf("%s: %zu nodes, %llu occupied voxels, voxel sum %016llx\n", name, tree.size(),
              static_cast<unsigned long long>(voxels), static_cast<unsigned long long>(sum));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: octomap_voxel_sum FILE.ot|FILE.bt...\n");
    return 2;
  }
  for (int i = 1; i < argc; ++i) {
    const std::string name = argv[i];
    if (name.size() > 3 && name.compare(name.size() - 3, 3, ".bt") == 0) {
      octomap::OcTree tree(0.1);
      if (!tree.readBinary(name))
        return std::fprintf(stderr, "%s: not a readable .bt\n", argv[i]), 1;
      summarise(argv[i], tree, [](const octomap::OcTreeNode&) { return std::uint64_t{0}; });
      continue;
    }
    std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(name));
    const auto* colour = dynamic_cast<const octomap::ColorOcTree*>(any.get());
    if (colour == nullptr)
      return std::fprintf(stderr, "%s: not a readable ColorOcTree .ot\n", argv[i]), 1;
    summarise(argv[i], *colour, [](const octomap::ColorOcTreeNode& n) {
      const auto c = n.getColor();
      return std::uint64_t{c.r} << 16 | std::uint64_t{c.g} << 8 | c.b;
    });
  }
  return 0;
}
