// The deviation stage's kernels (see kernels.hpp): the face-square distance scan, plain and
// AVX2.
#include "deviation/kernels.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "core/bits.hpp"
#include "core/plain_path.hpp"

namespace printtwin::detail {

namespace {

inline double face_dist2(const FaceArrays& f, std::size_t k, const Vec3& p, double half) {
  const int ax = f.axis[k];
  const Vec3& c = f.center[k];
  const double ex = std::max(0.0, std::abs(p.x() - c.x()) - (ax == 0 ? 0.0 : half));
  const double ey = std::max(0.0, std::abs(p.y() - c.y()) - (ax == 1 ? 0.0 : half));
  const double ez = std::max(0.0, std::abs(p.z() - c.z()) - (ax == 2 ? 0.0 : half));
  return ex * ex + ey * ey + ez * ez;
}

void scan_faces_plain(const FaceArrays& f, std::uint32_t lo, std::uint32_t hi, const Vec3& p,
                      double half, NearestFace& best) {
  for (std::uint32_t k = lo; k < hi; ++k) best.offer(face_dist2(f, k, p, half), k);
}

#if defined(__x86_64__) && defined(__GNUC__)
/// The same, 4 faces at a time (same operations in the same order: the same bits). Lanes
/// whose distance is not above the best go through the scalar rule, in index order.
[[gnu::target("avx2")]] void scan_faces_avx2(const FaceArrays& f, std::uint32_t lo,
                                             std::uint32_t hi, const Vec3& p, double half,
                                             NearestFace& best) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "face centres are read as rows of doubles");
  const __m256d px = _mm256_set1_pd(p.x()), py = _mm256_set1_pd(p.y()), pz = _mm256_set1_pd(p.z());
  const __m256d hv = _mm256_set1_pd(half), zero = _mm256_setzero_pd();
  const __m256d sign = _mm256_set1_pd(-0.0);
  const __m256i ax0 = _mm256_setzero_si256(), ax1 = _mm256_set1_epi64x(1),
                ax2 = _mm256_set1_epi64x(2);
  // 4 centres (x y z x | y z x y | z x y z) read as 3 rows and transposed to x, y, z
  // columns; the last few faces of the surface (no 4 centres left to read) one at a time.
  const std::uint32_t wide_end =
      std::min<std::uint32_t>(hi, static_cast<std::uint32_t>(f.n >= 4 ? f.n - 3 : 0));
  std::uint32_t k = lo;
  for (; k < wide_end; k += 4) {
    std::uint32_t a4 = 0;
    std::memcpy(&a4, f.axis + k, 4);
    const __m256i a = _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(static_cast<int>(a4)));
    // Per axis: max(0, |p - c| - h), h = 0 along the face's normal, else half.
    const __m256d hx = _mm256_andnot_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a, ax0)), hv);
    const __m256d hy = _mm256_andnot_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a, ax1)), hv);
    const __m256d hz = _mm256_andnot_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a, ax2)), hv);
    const double* row = f.center[k].data();
    const __m256d r0 = _mm256_loadu_pd(row), r1 = _mm256_loadu_pd(row + 4),
                  r2 = _mm256_loadu_pd(row + 8);
    const __m256d m1 = _mm256_permute2f128_pd(r0, r1, 0x30);  // x0 y0 | x2 y2
    const __m256d m2 = _mm256_permute2f128_pd(r0, r2, 0x21);  // z0 x1 | z2 x3
    const __m256d m3 = _mm256_permute2f128_pd(r1, r2, 0x30);  // y1 z1 | y3 z3
    const __m256d cx = _mm256_shuffle_pd(m1, m2, 0xA), cy = _mm256_shuffle_pd(m1, m3, 0x5),
                  cz = _mm256_shuffle_pd(m2, m3, 0xA);
    const __m256d dx = _mm256_andnot_pd(sign, _mm256_sub_pd(px, cx));
    const __m256d dy = _mm256_andnot_pd(sign, _mm256_sub_pd(py, cy));
    const __m256d dz = _mm256_andnot_pd(sign, _mm256_sub_pd(pz, cz));
    const __m256d ex = _mm256_max_pd(zero, _mm256_sub_pd(dx, hx));
    const __m256d ey = _mm256_max_pd(zero, _mm256_sub_pd(dy, hy));
    const __m256d ez = _mm256_max_pd(zero, _mm256_sub_pd(dz, hz));
    const __m256d d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ex, ex), _mm256_mul_pd(ey, ey)),
                                     _mm256_mul_pd(ez, ez));
    unsigned m = static_cast<unsigned>(
        _mm256_movemask_pd(_mm256_cmp_pd(d2, _mm256_set1_pd(best.d2), _CMP_LE_OQ)));
    if (hi - k < 4) m &= (1U << (hi - k)) - 1;
    if (m == 0) continue;
    alignas(32) double lane[4];
    _mm256_store_pd(lane, d2);
    for (; m != 0; m &= m - 1) {
      const int j = std::countr_zero(m);
      best.offer(lane[j], k + static_cast<std::uint32_t>(j));
    }
  }
  for (; k < hi; ++k) best.offer(face_dist2(f, k, p, half), k);
}
#endif

}  // namespace

FaceScan face_scan_kernel(bool portable) {
#if defined(__x86_64__) && defined(__GNUC__)
  if (!portable && cpu_has_avx2() && !plain_path("face_avx2")) return scan_faces_avx2;
#endif
  (void)portable;
  return scan_faces_plain;
}

}  // namespace printtwin::detail
