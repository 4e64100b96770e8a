// Step 4 of the outer surface: the faces between a filled part voxel and a voxel that is not
// filled (a part voxel is in I, so its neighbours are in R). Only blocks with part voxels that
// are, or touch, a block not wholly filled can have one. Per row of blocks (in parallel):
// each such block's six exposure cubes (-x, +x, -y, +y, -z, +z) as z-columns; faces counted
// per cell, then written in the fixed order: the blocks y, then x, then z, a block's cells by
// their y, x and z halves, voxel rows by y, then x, then z, a voxel's faces by direction.
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <array>
#include <bit>
#include <cstdint>
#include <optional>
#include <vector>

#include "deviation/surface_steps.hpp"

namespace printtwin::surface_blocks {

using detail::VoxelBlocks;

namespace {

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

/// A block's exposed faces: per direction and voxel row y, the z-columns (byte x = z bits).
struct Exposed {
  int bx = 0, bz = 0;
  std::array<std::array<std::uint64_t, kE>, 6> cols{};  // [direction][y]: byte x = z bits
  std::array<std::uint32_t, 8> cell_faces{};            // faces per cell (local y, x, z halves)
};

/// Bits of a cell's voxels in a z-column row word (byte x = z bits): bytes x in the cell's
/// x half, bits z in its z half.
constexpr std::uint64_t cell_columns(int cx, int cz) {
  const std::uint64_t nibble = cz != 0 ? 0xF0ULL : 0x0FULL;
  return (cx != 0 ? 0xFFFFFFFF00000000ULL : 0x00000000FFFFFFFFULL) & (nibble * kX0);
}

/// The filled voxels of a block. A part voxel is in I, so whether a voxel outside R counts as
/// filled never matters here: a block "all filled" reads as a full cube.
const Cube& filled_cube(const DepositSurface& s, const BlockBox& box, int bx, int by, int bz) {
  static const Cube full = full_cube();
  if (!box.contains(bx, by, bz)) return kNoCube;
  const std::uint32_t code = s.filled_block_code[box.index(bx, by, bz)];
  if (code == DepositSurface::kAllFilled) return full;
  if (code == DepositSurface::kNoneFilled) return kNoCube;
  return s.filled_masks[code - DepositSurface::kFirstMask];
}

/// Whether a part block can have faces: it, or a neighbour, is not wholly filled.
bool candidate(const DepositSurface& s, const BlockBox& box, int bx, int by, int bz) {
  bool c = s.filled_block_code[box.index(bx, by, bz)] != DepositSurface::kAllFilled;
  for (int d = 0; d < 6 && !c; ++d) {
    const int x = bx + kDirs[d][0], y = by + kDirs[d][1], z = bz + kDirs[d][2];
    c = box.contains(x, y, z) &&
        s.filled_block_code[box.index(x, y, z)] != DepositSurface::kAllFilled;
  }
  return c;
}

/// The exposed faces of part block (bx, by, bz) into e; false when it has none.
bool expose_block(const DepositSurface& s, const BlockBox& box, const PartBlocks& part, int bx,
                  int by, int bz, Exposed& e) {
  const Cube &f = filled_cube(s, box, bx, by, bz), &own = *part.of[box.index(bx, by, bz)];
  std::array<Cube, 6> nf;  // per direction: whether that neighbour of each voxel is filled
  {
    const Cube &fl = filled_cube(s, box, bx - 1, by, bz), &fr = filled_cube(s, box, bx + 1, by, bz);
    const Cube &fd = filled_cube(s, box, bx, by - 1, bz), &fu = filled_cube(s, box, bx, by + 1, bz);
    const Cube &fb = filled_cube(s, box, bx, by, bz - 1), &ft = filled_cube(s, box, bx, by, bz + 1);
    for (std::size_t z = 0; z < kE; ++z) {
      nf[0][z] = ((f[z] << 1) & ~kX0) | ((fl[z] & kX7) >> 7);
      nf[1][z] = ((f[z] >> 1) & ~kX7) | ((fr[z] & kX0) << 7);
      nf[2][z] = (f[z] << 8) | ((fd[z] & kY7) >> 56);
      nf[3][z] = (f[z] >> 8) | ((fu[z] & kY0) << 56);
      nf[4][z] = z > 0 ? f[z - 1] : fb[kE - 1];
      nf[5][z] = z + 1 < kE ? f[z + 1] : ft[0];
    }
  }
  e.bx = bx;
  e.bz = bz;
  bool some = false;
  for (std::size_t d = 0; d < 6; ++d) {
    Cube x;
    for (std::size_t z = 0; z < kE; ++z) x[z] = f[z] & own[z] & ~nf[d][z];
    if (!any(x)) continue;
    some = true;
    for (int y = 0; y < kE; ++y) e.cols[d][static_cast<std::size_t>(y)] = columns_of_row(x, y);
  }
  if (!some) return false;
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
  return true;
}

/// Per row of blocks (y), its blocks with faces in x, then z order.
std::vector<std::vector<Exposed>> exposed_rows(const DepositSurface& s, const BlockBox& box,
                                               const PartBlocks& part) {
  std::vector<std::vector<Exposed>> exposed(static_cast<std::size_t>(box.n.y()));
  tbb::parallel_for(0, box.n.y(), [&](int r) {
    const int by = box.lo.y() + r;
    auto& list = exposed[static_cast<std::size_t>(r)];
    for (int bx = box.lo.x(); bx < box.lo.x() + box.n.x(); ++bx)
      for (int bz = box.lo.z(); bz < box.lo.z() + box.n.z(); ++bz) {
        if (part.of[box.index(bx, by, bz)] == nullptr || !candidate(s, box, bx, by, bz)) continue;
        Exposed e;
        if (expose_block(s, box, part, bx, by, bz, e)) list.push_back(e);
      }
  });
  return exposed;
}

/// The face blocks in box order (y, then x, then z) and the start of each of their cells;
/// the first face block of each row in row_blocks. Returns the number of faces.
std::size_t lay_out(DepositSurface& s, const BlockBox& box,
                    const std::vector<std::vector<Exposed>>& exposed,
                    std::vector<std::size_t>& row_blocks) {
  row_blocks.assign(static_cast<std::size_t>(box.n.y()) + 1, 0);
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
  return n_faces;
}

/// Writes the faces of one exposed block from index `next` on.
void write_block(DepositSurface& s, const Exposed& e, int by, const VoxelBlocks::BlockView& view,
                 const std::vector<VoxelTag>& table, std::size_t next) {
  const VoxelKey kmin = s.origin_key;
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
            s.face_tags[next++] = tag;
          }
        }
      }
    }
  }
}

}  // namespace

void extract_faces(DepositSurface& s, const VoxelGrid& grid, const SurfaceRegion& region,
                   const PartBlocks& part) {
  const BlockBox& box = region.box;
  const std::vector<std::vector<Exposed>> exposed = exposed_rows(s, box, part);
  std::vector<std::size_t> row_blocks;
  const std::size_t n_faces = lay_out(s, box, exposed, row_blocks);
  // The face arrays sized side by side (resize writes each element's initial value). A
  // face's centre is not stored: DepositSurface::face_center computes it.
  tbb::parallel_invoke([&] { s.faces.resize(n_faces); }, [&] { s.face_tags.resize(n_faces); });
  const auto& table = VoxelBlocks::tag_table(grid);
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
      const VoxelBlocks::BlockView view = *next_view;
      if (c + 1 < list.size()) {
        next_view = VoxelBlocks::block_view(grid, list[c + 1].bx, by, list[c + 1].bz);
        fetch_tags(*next_view);
      }
      write_block(s, list[c], by, view, table,
                  s.face_cell_begin[8 * (row_blocks[static_cast<std::size_t>(r)] + c)]);
    }
  });
}

}  // namespace printtwin::surface_blocks
