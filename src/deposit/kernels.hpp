#pragma once
// The deposit's kernels: the sample-point tests of a bead, 64 voxels at a time (the inner
// loop of the deposit), and the support count across a bead. The tile test has an AVX-512
// kernel, chosen at run time (use_avx512() in kernels.cpp), and a portable twin that gives
// the same bits; PRINTTWIN_PLAIN=bead_avx512 (core/plain_path.hpp) takes the twin. It is
// kept because it saves at least 10 % of the deposit's time (bench/RESULTS.md).
//
// A voxel (i, j, k) is occupied by a bead when its sample point lies inside the bead. The
// sample point is fixed per voxel: (i + jx, j + jy, k + jz) in voxel units, the jitter
// (jx, jy, jz) in (0, 1)^3 taken from an integer hash of the key (10 bits per axis). The
// test is evaluated in single precision on coordinates relative to the bead's start, in a
// fixed order of operations, so the portable and AVX-512 kernels give the same voxels bit
// for bit.
#include <cstddef>
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
  std::uint32_t h = static_cast<std::uint32_t>(i) * 0x8da6b343u ^
                    static_cast<std::uint32_t>(j) * 0xd8163841u ^
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
/// the bead; `lanes` (bits 0..7) masks the x that may be set. Dispatches to the AVX-512
/// kernel (two rows per instruction) when the CPU has it; both kernels give the same bits.
std::uint64_t test_tile(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                        int row_lo, int row_hi, unsigned lanes);

/// test_tile for the layers ks[0..nk) of one tile: masks[n] for layer ks[n]. The AVX-512
/// kernel sets its constants up once for all the layers; the same bits as test_tile.
void test_tile_layers(const BeadFrame& f, std::int32_t i0, std::int32_t j0, const std::int32_t* ks,
                      int nk, int row_lo, int row_hi, unsigned lanes, std::uint64_t* masks);

/// Where the sample point of voxel (i, j, k) lies in the bead's section, as the kernels
/// compute it: `l`, its lateral distance beyond the flat part of the section (|n . r| - flat,
/// negative over the flat part), and `dz`, its height above the section's centre line.
void section_offset(const BeadFrame& f, std::int32_t i, std::int32_t j, std::int32_t k, float& l,
                    float& dz);

/// A round join: the section of `f` revolved about the vertical line through the start (the
/// disc the nozzle's footprint leaves where a path turns), between the cuts of `f`. Inside:
/// the cuts hold, |dz| is within the section's half-height, and the horizontal distance rho
/// from the line has rho <= flat or (rho - flat)^2 + dz^2 <= r^2; the direction and slope of
/// `f` are not used. Same arguments and bits as test_tile, but only the x in `lanes` are
/// tested; portable code only (joins are few).
std::uint64_t test_tile_disc(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                             int row_lo, int row_hi, unsigned lanes);

/// The portable kernel (what test_tile runs without AVX-512), for the tests.
std::uint64_t test_tile_scalar(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                               int row_lo, int row_hi, unsigned lanes);

/// The deposit's height map, stored in 8 x 8 tiles (column (i, j) at
/// ((j / 8) * tiles_x + i / 8) * 64 + (j % 8) * 8 + i % 8).
struct HeightMapView {
  const std::uint16_t* top = nullptr;
  std::size_t tiles_x = 0;
  int nx = 0, ny = 0;

  /// Index into `top` of column (i, j) (inside the map).
  [[nodiscard]] std::size_t index(int i, int j) const {
    return ((static_cast<std::size_t>(j >> 3) * tiles_x + static_cast<std::size_t>(i >> 3)) << 6) +
           static_cast<std::size_t>(((j & 7) << 3) | (i & 7));
  }
  /// Rows held by the column under (u, v) (voxel units), 0 outside the map.
  [[nodiscard]] int rows_at(double u, double v) const {
    // floor without a library call (baseline x86-64 has no rounding instruction)
    const int iu = static_cast<int>(u), iv = static_cast<int>(v);
    const int i = iu - (u < static_cast<double>(iu) ? 1 : 0);
    const int j = iv - (v < static_cast<double>(iv) ? 1 : 0);
    return i >= 0 && j >= 0 && i < nx && j < ny ? top[index(i, j)] : 0;
  }
};

/// How many of the points (u + s[t] * du, v + s[t] * dv), t < n (voxel units from the grid
/// origin), stand on a column (floor of each coordinate, inside the map) holding at least
/// `need` rows. Points outside the map hold nothing.
int count_held(const HeightMapView& map, double u, double v, double du, double dv, const double* s,
               int n, int need);

/// Whether at least `enough` of count_held's points stand on a column holding `need` rows:
/// count_held(...) >= enough, reading the map only until the answer is known.
bool held_at_least(const HeightMapView& map, double u, double v, double du, double dv,
                   const double* s, int n, int need, int enough);

/// True when test_tile uses the AVX-512 kernel on this CPU.
bool bead_raster_uses_avx512();

}  // namespace printtwin::detail
