// The deposit's outer surface: a flood fill of the outside air over the blocked grid.
// Unallocated blocks are all air and are visited as single nodes; inside allocated blocks
// the reachable air is a 512-bit mask grown with bit-parallel dilation (one 64-bit word per
// z-slice, bit y*8+x). Air reached from the grid border is "outside"; occupied voxels with a
// face on it form the outer surface.
#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"

namespace printtwin {

using detail::VoxelBlocks;

namespace {

using Mask = std::array<std::uint64_t, 8>;
constexpr std::uint64_t kColX0 = 0x0101010101010101ull;  // x == 0 in every row
constexpr std::uint64_t kColX7 = 0x8080808080808080ull;  // x == 7
constexpr std::uint64_t kRowY0 = 0x00000000000000FFull;  // y == 0
constexpr std::uint64_t kRowY7 = 0xFF00000000000000ull;  // y == 7

/// Voxels that are 6-neighbours (inside the block) of a set voxel, and the set itself.
Mask dilate(const Mask& m) {
  Mask out{};
  for (int z = 0; z < 8; ++z) {
    const std::uint64_t w = m[z];
    std::uint64_t d = w | ((w << 1) & ~kColX0) | ((w >> 1) & ~kColX7) | (w << 8) | (w >> 8);
    if (z > 0) d |= m[z - 1];
    if (z < 7) d |= m[z + 1];
    out[z] = d;
  }
  return out;
}

/// Face `f` (0 -x, 1 +x, 2 -y, 3 +y, 4 -z, 5 +z) of a mask, moved to the opposite face (as
/// the neighbouring block across f sees it).
Mask face_to_neighbour(const Mask& m, int f) {
  Mask out{};
  switch (f) {
    case 0: for (int z = 0; z < 8; ++z) out[z] = (m[z] & kColX0) << 7; break;
    case 1: for (int z = 0; z < 8; ++z) out[z] = (m[z] & kColX7) >> 7; break;
    case 2: for (int z = 0; z < 8; ++z) out[z] = (m[z] & kRowY0) << 56; break;
    case 3: for (int z = 0; z < 8; ++z) out[z] = (m[z] & kRowY7) >> 56; break;
    case 4: out[7] = m[0]; break;
    case 5: out[0] = m[7]; break;
    default: break;
  }
  return out;
}

/// All voxels on face f of a block.
Mask full_face(int f) {
  Mask all;
  all.fill(~0ull);
  return face_to_neighbour(all, f ^ 1);  // the face f as reached from across it
}

const std::array<Eigen::Vector3i, 6> kStep = {Eigen::Vector3i(-1, 0, 0), Eigen::Vector3i(1, 0, 0),
                                              Eigen::Vector3i(0, -1, 0), Eigen::Vector3i(0, 1, 0),
                                              Eigen::Vector3i(0, 0, -1), Eigen::Vector3i(0, 0, 1)};

}  // namespace

std::vector<SurfaceVoxel> outer_surface(const VoxelGrid& grid) {
  const Eigen::Vector3i bd = VoxelBlocks::block_dims(grid);
  const std::size_t nblocks = static_cast<std::size_t>(bd.x()) * static_cast<std::size_t>(bd.y()) *
                              static_cast<std::size_t>(bd.z());
  std::vector<SurfaceVoxel> out;
  if (nblocks == 0) return out;
  auto index = [&](const Eigen::Vector3i& b) {
    return (static_cast<std::size_t>(b.z()) * static_cast<std::size_t>(bd.y()) +
            static_cast<std::size_t>(b.y())) * static_cast<std::size_t>(bd.x()) +
           static_cast<std::size_t>(b.x());
  };
  auto inside_dir = [&](const Eigen::Vector3i& b) {
    return (b.array() >= 0).all() && (b.array() < bd.array()).all();
  };
  // Outside air per allocated block (slot by directory index), and reached flags.
  std::vector<std::uint32_t> slot(nblocks, 0);  // 0: none yet
  std::vector<Mask> air;                        // air[slot - 1]
  std::vector<std::uint8_t> reached(nblocks, 0);
  std::vector<std::uint8_t> queued(nblocks, 0);
  std::deque<Eigen::Vector3i> work;

  auto seed = [&](const Eigen::Vector3i& b, const Mask& candidates) {
    const std::size_t i = index(b);
    const std::uint64_t* occ = VoxelBlocks::block_occupancy(grid, b.x(), b.y(), b.z());
    if (occ == nullptr) {
      if (!reached[i]) {
        reached[i] = 1;
        work.push_back(b);
      }
      return;
    }
    if (slot[i] == 0) {
      air.push_back(Mask{});
      slot[i] = static_cast<std::uint32_t>(air.size());
    }
    Mask& a = air[slot[i] - 1];
    bool grew = false;
    for (int z = 0; z < 8; ++z) {
      const std::uint64_t add = candidates[z] & ~occ[z] & ~a[z];
      if (add != 0) {
        a[z] |= add;
        grew = true;
      }
    }
    if (grew && !queued[i]) {
      queued[i] = 1;
      work.push_back(b);
    }
  };

  // Seeds: every block face on the border of the directory.
  for (int bz = 0; bz < bd.z(); ++bz)
    for (int by = 0; by < bd.y(); ++by) {
      const bool row_on_border = bz == 0 || bz == bd.z() - 1 || by == 0 || by == bd.y() - 1;
      for (int bx = 0; bx < bd.x(); ++bx) {
        if (!row_on_border && bx > 0 && bx < bd.x() - 1) {
          bx = bd.x() - 2;  // interior of the row: jump to its last block
          continue;
        }
        const Eigen::Vector3i b(bx, by, bz);
        for (int f = 0; f < 6; ++f)
          if (!inside_dir(b + kStep[f])) seed(b, full_face(f));
      }
    }

  while (!work.empty()) {
    const Eigen::Vector3i b = work.front();
    work.pop_front();
    const std::size_t i = index(b);
    const std::uint64_t* occ = VoxelBlocks::block_occupancy(grid, b.x(), b.y(), b.z());
    Mask reach;
    if (occ == nullptr) {
      reach.fill(~0ull);
    } else {
      queued[i] = 0;
      Mask& a = air[slot[i] - 1];
      for (;;) {  // grow through the empty voxels of this block
        Mask next = dilate(a);
        bool changed = false;
        for (int z = 0; z < 8; ++z) {
          next[z] &= ~occ[z];
          changed |= next[z] != a[z];
        }
        a = next;
        if (!changed) break;
      }
      reach = a;
    }
    for (int f = 0; f < 6; ++f) {
      const Eigen::Vector3i nb = b + kStep[f];
      if (!inside_dir(nb)) continue;
      const Mask across = face_to_neighbour(reach, f);
      bool any = false;
      for (auto w : across) any |= w != 0;
      if (any) seed(nb, across);
    }
  }

  // Surface: occupied voxels next to outside air (inside the block, or across a face).
  VoxelBlocks::visit_blocks(grid, [&](const VoxelBlocks::BlockView& blk) {
    const Eigen::Vector3i b(blk.base.x / 8, blk.base.y / 8, blk.base.z / 8);
    const std::size_t i = index(b);
    const Mask a = slot[i] ? air[slot[i] - 1] : Mask{};
    // Outside air of the neighbours, as seen on this block's faces.
    std::array<Mask, 6> beyond{};
    for (int f = 0; f < 6; ++f) {
      const Eigen::Vector3i nb = b + kStep[f];
      Mask nair;
      if (!inside_dir(nb)) {
        nair.fill(~0ull);
      } else {
        const std::size_t ni = index(nb);
        if (VoxelBlocks::block_occupancy(grid, nb.x(), nb.y(), nb.z()) == nullptr) {
          if (reached[ni]) nair.fill(~0ull); else nair = Mask{};
        } else {
          nair = slot[ni] ? air[slot[ni] - 1] : Mask{};
        }
      }
      beyond[f] = face_to_neighbour(nair, f ^ 1);  // their face opposite to f, moved onto ours
    }
    for (int z = 0; z < 8; ++z) {
      const std::uint64_t occ = blk.occupancy[z];
      if (occ == 0) continue;
      // Exposed faces per direction, as bit masks over this slice.
      std::array<std::uint64_t, 6> exp{};
      exp[0] = occ & (((a[z] << 1) & ~kColX0) | (beyond[0][z] & kColX0));  // -x neighbour
      exp[1] = occ & (((a[z] >> 1) & ~kColX7) | (beyond[1][z] & kColX7));  // +x
      exp[2] = occ & ((a[z] << 8) | (beyond[2][z] & kRowY0));               // -y
      exp[3] = occ & ((a[z] >> 8) | (beyond[3][z] & kRowY7));               // +y
      exp[4] = occ & (z > 0 ? a[z - 1] : beyond[4][0]);                      // -z
      exp[5] = occ & (z < 7 ? a[z + 1] : beyond[5][7]);                      // +z
      std::uint64_t any = exp[0] | exp[1] | exp[2] | exp[3] | exp[4] | exp[5];
      while (any != 0) {
        const int bit = std::countr_zero(any);
        any &= any - 1;
        SurfaceVoxel s;
        s.key = VoxelKey{blk.base.x + (bit & 7), blk.base.y + (bit >> 3), blk.base.z + z};
        for (int f = 0; f < 6; ++f)
          if ((exp[f] >> bit) & 1u) s.exposed_faces |= static_cast<std::uint8_t>(1u << f);
        out.push_back(s);
      }
    }
  });
  return out;
}

}  // namespace printtwin
