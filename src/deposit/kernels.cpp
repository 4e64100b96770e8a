// The deposit's kernels (see kernels.hpp). The tile kernels evaluate the same
// single-precision operations in the same order (no fused multiply-add: the AVX-512 kernel is
// compiled with contraction off, and the build does not contract), so they set the same bits.
#include "deposit/kernels.hpp"

#include "core/bits.hpp"
#include "core/plain_path.hpp"

#include <cmath>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define PRINTTWIN_HAVE_AVX512_KERNEL 1
#endif

namespace printtwin::detail {

namespace {

constexpr float kJitterScale = 1.0f / 1024.0f;
constexpr float kJitterHalf = 0.5f / 1024.0f;

/// The sample point of one voxel relative to the bead; X, Y, Z are its integer offsets from
/// (ia, ja, ka), h its jitter bits.
struct SamplePoint {
  float s0, s1;  // start cut (inside >= 0), end cut (inside < 0)
  float l, dz;   // beyond the flat part laterally, above the section centre
};
/// The jitter of jitter bits h along one axis (`shift`: 0 x, 10 y, 20 z).
inline float jitter(std::uint32_t h, int shift) {
  return static_cast<float>(static_cast<std::int32_t>((h >> shift) & 0x3FFu)) * kJitterScale +
         kJitterHalf;
}

inline SamplePoint sample_point(const BeadFrame& f, float X, float Y, float Z, std::uint32_t h) {
  const float rx = (X + jitter(h, 0)) - f.fa_x;
  const float ry = (Y + jitter(h, 10)) - f.fa_y;
  const float z = Z + jitter(h, 20);
  SamplePoint p;
  p.s0 = f.m0_x * rx + f.m0_y * ry;
  p.s1 = (f.m1_x * rx + f.m1_y * ry) - f.e1;
  const float u = f.d_x * rx + f.d_y * ry;
  p.dz = z - (f.c0 + f.slope * u);
  p.l = std::fabs(f.n_x * rx + f.n_y * ry) - f.flat;
  return p;
}

/// The sample-point test of one voxel (arguments as sample_point's).
inline bool inside(const BeadFrame& f, float X, float Y, float Z, std::uint32_t h) {
  const SamplePoint p = sample_point(f, X, Y, Z, h);
  const bool round_ok = (p.l <= 0.0f) | (p.l * p.l + p.dz * p.dz <= f.r2);
  return (p.s0 >= 0.0f) & (p.s1 < 0.0f) & (p.dz >= -f.r) & (p.dz < f.r) & round_ok;
}

#if PRINTTWIN_HAVE_AVX512_KERNEL
// GCC 12 flags the "undefined" source operands inside its own AVX-512 intrinsics.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
/// The portable kernel's operations on two rows at once (lanes 0-7 row y, lanes 8-15 row
/// y + 1), each an IEEE single-precision operation in the same order (no contraction into
/// fused multiply-adds, which AVX-512 would allow), so the same bits.
[[gnu::target("avx512f"), gnu::optimize("fp-contract=off")]] void test_tile_layers_avx512(
    const BeadFrame& f, std::int32_t i0, std::int32_t j0, const std::int32_t* ks, int nk,
    int row_lo, int row_hi, unsigned lanes, std::uint64_t* masks) {
  // Everything but the layer's height and hash is the same for all the tile's layers.
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7);
  const __m512i vi = _mm512_add_epi32(_mm512_set1_epi32(i0), lane);
  const __m512i ihash = _mm512_mullo_epi32(vi, _mm512_set1_epi32(static_cast<int>(0x8da6b343u)));
  const __m512 X = _mm512_cvtepi32_ps(_mm512_sub_epi32(vi, _mm512_set1_epi32(f.ia)));
  const __m512i c1 = _mm512_set1_epi32(0x7feb352d);
  const __m512i c2 = _mm512_set1_epi32(static_cast<int>(0x846ca68bu));
  const __m512i ten = _mm512_set1_epi32(0x3FF);
  const __m512 scale = _mm512_set1_ps(kJitterScale), half = _mm512_set1_ps(kJitterHalf);
  const __m512 fa_x = _mm512_set1_ps(f.fa_x), fa_y = _mm512_set1_ps(f.fa_y);
  const __m512 m0x = _mm512_set1_ps(f.m0_x), m0y = _mm512_set1_ps(f.m0_y);
  const __m512 m1x = _mm512_set1_ps(f.m1_x), m1y = _mm512_set1_ps(f.m1_y),
               e1 = _mm512_set1_ps(f.e1);
  const __m512 dx = _mm512_set1_ps(f.d_x), dy = _mm512_set1_ps(f.d_y);
  const __m512 nx = _mm512_set1_ps(f.n_x), ny = _mm512_set1_ps(f.n_y);
  const __m512 c0 = _mm512_set1_ps(f.c0), slope = _mm512_set1_ps(f.slope);
  const __m512 r = _mm512_set1_ps(f.r), neg_r = _mm512_set1_ps(-f.r), r2 = _mm512_set1_ps(f.r2);
  const __m512 flat = _mm512_set1_ps(f.flat), zero = _mm512_setzero_ps();
  const auto lanes16 = static_cast<__mmask16>(lanes | (lanes << 8));
  const __mmask16 low = 0x00FF;
  for (int n = 0; n < nk; ++n) {
    const std::int32_t k = ks[n];
    const __m512 Z = _mm512_set1_ps(static_cast<float>(k - f.ka));
    const std::uint32_t khash = static_cast<std::uint32_t>(k) * 0xcb1ab31fu;
    std::uint64_t out = 0;
    for (int y = row_lo; y < row_hi; y += 2) {
      const std::int32_t j = j0 + y;
      const auto row_hash = [&](std::int32_t jj) {
        return static_cast<int>(static_cast<std::uint32_t>(jj) * 0xd8163841u ^ khash);
      };
      // Lanes 8-15 hold row y + 1 (past row_hi they are computed and dropped).
      __m512i h =
          _mm512_xor_si512(ihash, _mm512_mask_blend_epi32(low, _mm512_set1_epi32(row_hash(j + 1)),
                                                          _mm512_set1_epi32(row_hash(j))));
      h = _mm512_xor_si512(h, _mm512_srli_epi32(h, 16));
      h = _mm512_mullo_epi32(h, c1);
      h = _mm512_xor_si512(h, _mm512_srli_epi32(h, 15));
      h = _mm512_mullo_epi32(h, c2);
      h = _mm512_xor_si512(h, _mm512_srli_epi32(h, 16));
      const __m512 jx =
          _mm512_add_ps(_mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_and_si512(h, ten)), scale), half);
      const __m512 jy = _mm512_add_ps(
          _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(h, 10), ten)), scale),
          half);
      const __m512 jz = _mm512_add_ps(
          _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(h, 20), ten)), scale),
          half);
      const __m512 Y = _mm512_mask_blend_ps(low, _mm512_set1_ps(static_cast<float>(j + 1 - f.ja)),
                                            _mm512_set1_ps(static_cast<float>(j - f.ja)));
      const __m512 rx = _mm512_sub_ps(_mm512_add_ps(X, jx), fa_x);
      const __m512 ry = _mm512_sub_ps(_mm512_add_ps(Y, jy), fa_y);
      const __m512 z = _mm512_add_ps(Z, jz);
      const __m512 s0 = _mm512_add_ps(_mm512_mul_ps(m0x, rx), _mm512_mul_ps(m0y, ry));
      const __m512 s1 =
          _mm512_sub_ps(_mm512_add_ps(_mm512_mul_ps(m1x, rx), _mm512_mul_ps(m1y, ry)), e1);
      const __m512 u = _mm512_add_ps(_mm512_mul_ps(dx, rx), _mm512_mul_ps(dy, ry));
      const __m512 dz = _mm512_sub_ps(z, _mm512_add_ps(c0, _mm512_mul_ps(slope, u)));
      const __m512 l = _mm512_sub_ps(
          _mm512_abs_ps(_mm512_add_ps(_mm512_mul_ps(nx, rx), _mm512_mul_ps(ny, ry))), flat);
      const __mmask16 round_ok =
          _mm512_cmp_ps_mask(l, zero, _CMP_LE_OQ) |
          _mm512_cmp_ps_mask(_mm512_add_ps(_mm512_mul_ps(l, l), _mm512_mul_ps(dz, dz)), r2,
                             _CMP_LE_OQ);
      __mmask16 ok =
          _mm512_cmp_ps_mask(s0, zero, _CMP_GE_OQ) & _mm512_cmp_ps_mask(s1, zero, _CMP_LT_OQ);
      ok &= _mm512_cmp_ps_mask(dz, neg_r, _CMP_GE_OQ) & _mm512_cmp_ps_mask(dz, r, _CMP_LT_OQ);
      ok &= round_ok & lanes16;
      unsigned bits = ok;
      if (y + 1 >= row_hi) bits &= 0xFFu;
      out |= static_cast<std::uint64_t>(bits) << (8 * y);
    }
    masks[n] = out;
  }
}
#pragma GCC diagnostic pop
#endif

/// Whether this run uses the AVX-512 tile kernel: the CPU has it and PRINTTWIN_PLAIN does not
/// name `bead_avx512` (core/plain_path.hpp).
bool use_avx512() {
  static const bool use = [] {
#if PRINTTWIN_HAVE_AVX512_KERNEL
    return cpu_has_avx512f() && !plain_path("bead_avx512");
#else
    return false;
#endif
  }();
  return use;
}

}  // namespace

int count_held(const HeightMapView& map, double u, double v, double du, double dv, const double* s,
               int n, int need) {
  int held = 0;
  for (int t = 0; t < n; ++t) held += map.rows_at(u + s[t] * du, v + s[t] * dv) >= need ? 1 : 0;
  return held;
}

bool held_at_least(const HeightMapView& map, double u, double v, double du, double dv,
                   const double* s, int n, int need, int enough) {
  int held = 0;
  for (int t = 0; t < n; ++t) {
    if (held >= enough) return true;
    if (held + (n - t) < enough) return false;  // the rest cannot make it
    held += map.rows_at(u + s[t] * du, v + s[t] * dv) >= need ? 1 : 0;
  }
  return held >= enough;
}

void section_offset(const BeadFrame& f, std::int32_t i, std::int32_t j, std::int32_t k, float& l,
                    float& dz) {
  const SamplePoint p = sample_point(f, static_cast<float>(i - f.ia), static_cast<float>(j - f.ja),
                                     static_cast<float>(k - f.ka), voxel_jitter_bits(i, j, k));
  l = p.l;
  dz = p.dz;
}

namespace {

/// The bits of a tile (as test_tile) whose voxel passes `in(X, Y, Z, jitter bits)` (integer
/// offsets from the frame's voxel); only the x in `lanes` are tested.
template <class Inside>
std::uint64_t scan_tile(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                        int row_lo, int row_hi, unsigned lanes, const Inside& in) {
  const float Z = static_cast<float>(k - f.ka);
  std::uint64_t out = 0;
  for (int y = row_lo; y < row_hi; ++y) {
    const std::int32_t j = j0 + y;
    const float Y = static_cast<float>(j - f.ja);
    unsigned bits = 0;
    for (int x = 0; x < 8; ++x) {
      if (((lanes >> x) & 1u) == 0) continue;
      const std::int32_t i = i0 + x;
      bits |=
          static_cast<unsigned>(in(static_cast<float>(i - f.ia), Y, Z, voxel_jitter_bits(i, j, k)))
          << x;
    }
    out |= static_cast<std::uint64_t>(bits) << (8 * y);
  }
  return out;
}

}  // namespace

std::uint64_t test_tile_scalar(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                               int row_lo, int row_hi, unsigned lanes) {
  return scan_tile(
      f, i0, j0, k, row_lo, row_hi, lanes,
      [&](float X, float Y, float Z, std::uint32_t h) { return inside(f, X, Y, Z, h); });
}

std::uint64_t test_tile_disc(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                             int row_lo, int row_hi, unsigned lanes) {
  return scan_tile(f, i0, j0, k, row_lo, row_hi, lanes,
                   [&](float X, float Y, float Z, std::uint32_t h) {
                     const float rx = (X + jitter(h, 0)) - f.fa_x;
                     const float ry = (Y + jitter(h, 10)) - f.fa_y;
                     const float dz = (Z + jitter(h, 20)) - f.c0;
                     const float s0 = f.m0_x * rx + f.m0_y * ry;
                     const float s1 = (f.m1_x * rx + f.m1_y * ry) - f.e1;
                     const float l = std::sqrt(rx * rx + ry * ry) - f.flat;
                     return (s0 >= 0.0f) & (s1 < 0.0f) & (dz >= -f.r) & (dz < f.r) &
                            ((l <= 0.0f) | (l * l + dz * dz <= f.r2));
                   });
}

void test_tile_layers(const BeadFrame& f, std::int32_t i0, std::int32_t j0, const std::int32_t* ks,
                      int nk, int row_lo, int row_hi, unsigned lanes, std::uint64_t* masks) {
#if PRINTTWIN_HAVE_AVX512_KERNEL
  if (use_avx512()) {
    test_tile_layers_avx512(f, i0, j0, ks, nk, row_lo, row_hi, lanes, masks);
    return;
  }
#endif
  for (int n = 0; n < nk; ++n) masks[n] = test_tile_scalar(f, i0, j0, ks[n], row_lo, row_hi, lanes);
}

std::uint64_t test_tile(const BeadFrame& f, std::int32_t i0, std::int32_t j0, std::int32_t k,
                        int row_lo, int row_hi, unsigned lanes) {
  std::uint64_t mask = 0;
  test_tile_layers(f, i0, j0, &k, 1, row_lo, row_hi, lanes, &mask);
  return mask;
}

bool bead_raster_uses_avx512() { return use_avx512(); }

}  // namespace printtwin::detail
