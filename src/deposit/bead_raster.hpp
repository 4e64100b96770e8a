#pragma once
// Sample-point tests of a bead, 64 voxels at a time: the inner loop of the deposit.
//
// A voxel (i, j, k) is occupied by a bead when its sample point lies inside the bead. The
// sample point is fixed per voxel: (i + jx, j + jy, k + jz) in voxel units, the jitter
// (jx, jy, jz) in (0, 1)^3 taken from an integer hash of the key (10 bits per axis). The
// test is evaluated in single precision on coordinates relative to the bead's start, in a
// fixed order of operations, so the scalar kernel and the AVX2 kernel (chosen at run time)
// give the same voxels bit for bit.
#include <cstdint>

namespace printtwin::detail {

/// One bead in the frame of the tests: voxel units, relative to the voxel (ia, ja, ka) that
/// holds the start of the tip's path.
struct BeadFrame {
  std::int32_t ia = 0, ja = 0, ka = 0;  // integer part of the start
  float fa_x = 0, fa_y = 0;             // fractional part of the start (x, y)
  float d_x = 0, d_y = 0;               // unit direction of the move (xy)
  float n_x = 0, n_y = 0;               // unit lateral normal
  float m0_x = 0, m0_y = 0;             // start cut normal: inside where m0 . r >= 0
  float m1_x = 0, m1_y = 0, e1 = 0;     // end cut: inside where m1 . r - e1 < 0 (e1 = m1 . (b - a))
  float c0 = 0;                         // section centre height at the start, relative to ka
  float slope = 0;                      // section centre: c0 + slope * (d . r)
  float r = 0, r2 = 0, flat = 0;        // section: half-height, its square, flat half-width
};

/// Fixed jitter of voxel (i, j, k): bits 0-9 give x, 10-19 y, 20-29 z, each as
/// (bits + 0.5) / 1024 of a voxel.
inline std::uint32_t voxel_jitter_bits(std::int32_t i, std::int32_t j, std::int32_t k) {
  std::uint32_t h = static_cast<std::uint32_t>(i) * 0x8da6b343u ^ static_cast<std::uint32_t>(j) * 0xd8163841u ^
                    static_cast<std::uint32_t>(k) * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

/// Tests the 8 x 8 voxels (i0 + x, j0 + y, k) for x in 0..7 and y in row_lo..row_hi-1 (0 <= row_lo
/// < row_hi <= 8). Bit y * 8 + x of the result is set when the voxel's sample point is inside
/// the bead; `lanes` (bits 0..7) masks the x that may be set. Dispatches to the AVX2 kernel
/// when the CPU has it (same results).
std::uint64_t test_tile(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k, int row_lo,
                        int row_hi, unsigned lanes);

/// The portable kernel (what test_tile runs without AVX2), for the tests.
std::uint64_t test_tile_scalar(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                               int row_lo, int row_hi, unsigned lanes);

/// True when test_tile uses the AVX2 kernel on this CPU.
bool bead_raster_uses_avx2();

}  // namespace printtwin::detail
