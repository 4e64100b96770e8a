// The mesh query's kernels (see kernels.hpp): the candidate scan of a ball query, plain and
// AVX2.
#include "mesh/kernels.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <array>
#include <bit>

#include "core/bits.hpp"
#include "core/plain_path.hpp"

namespace printtwin::detail {

namespace {

/// Offers every candidate whose box may win; the box test 4 at a time (same arithmetic as
/// box_distance2, so the same candidates pass).
void scan_candidates_plain(PointQueryState& st, const BallScratch& c) {
  for (std::size_t k = 0; k < c.ids.size(); ++k) {
    double box2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double e = std::max({0.0, c.lo[a][k] - st.p[a], st.p[a] - c.hi[a][k]});
      box2 += e * e;
    }
    if (box_may_win(box2, st.best_d2) && offer_unboxed(st, c.ids[k])) st.best_slot = k;
  }
}
#if defined(__x86_64__) && defined(__GNUC__)
[[gnu::target("avx2")]] inline __m256d dot3_avx2(__m256d ux, __m256d uy, __m256d uz, __m256d vx,
                                                 __m256d vy, __m256d vz) {
  // (x x' + y y') + z z': the association of Eigen's 3-vector dot product.
  return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ux, vx), _mm256_mul_pd(uy, vy)),
                       _mm256_mul_pd(uz, vz));
}
[[gnu::target("avx2")]] inline __m256d both_avx2(__m256d u, __m256d v) {
  return _mm256_and_pd(u, v);
}
[[gnu::target("avx2")]] inline __m256d le_avx2(__m256d u, __m256d v) {
  return _mm256_cmp_pd(u, v, _CMP_LE_OQ);
}
[[gnu::target("avx2")]] inline __m256d ge_avx2(__m256d u, __m256d v) {
  return _mm256_cmp_pd(u, v, _CMP_GE_OQ);
}
/// Four points (x, y, z columns).
struct Points4 {
  __m256d x, y, z;
};
/// u + t v per lane (a point on an edge), as the scalar `u + t * v`.
[[gnu::target("avx2")]] inline Points4 along_avx2(const Points4& u, __m256d t, const Points4& v) {
  return {_mm256_add_pd(u.x, _mm256_mul_pd(t, v.x)), _mm256_add_pd(u.y, _mm256_mul_pd(t, v.y)),
          _mm256_add_pd(u.z, _mm256_mul_pd(t, v.z))};
}
/// r = v in the lanes of `mask`.
[[gnu::target("avx2")]] inline void pick_avx2(Points4& r, const Points4& v, __m256d mask) {
  r.x = _mm256_blendv_pd(r.x, v.x, mask);
  r.y = _mm256_blendv_pd(r.y, v.y, mask);
  r.z = _mm256_blendv_pd(r.z, v.z, mask);
}

/// closest_point_on_triangle for 4 candidates at once (columns k..k+3 of c.corner): every
/// Voronoi region's answer is computed with the scalar code's operations in its order (no
/// FMA in this target), then the region the scalar walk would take is selected, so each lane
/// holds the scalar answer bit for bit. Writes q (x, y, z) and |q - p|^2 per lane.
[[gnu::target("avx2")]] void closest_points_4(const BallScratch& c, std::size_t k, const Vec3& p,
                                              double qx[4], double qy[4], double qz[4],
                                              double d2[4]) {
  std::array<const double*, 9> col{};
  for (std::size_t i = 0; i < 9; ++i) col[i] = c.corner[i].data() + k;
  const __m256d ax = _mm256_loadu_pd(col[0]), ay = _mm256_loadu_pd(col[1]),
                az = _mm256_loadu_pd(col[2]);
  const __m256d bx = _mm256_loadu_pd(col[3]), by = _mm256_loadu_pd(col[4]),
                bz = _mm256_loadu_pd(col[5]);
  const __m256d cx = _mm256_loadu_pd(col[6]), cy = _mm256_loadu_pd(col[7]),
                cz = _mm256_loadu_pd(col[8]);
  const __m256d px = _mm256_set1_pd(p.x()), py = _mm256_set1_pd(p.y()), pz = _mm256_set1_pd(p.z());
  const __m256d zero = _mm256_setzero_pd();
  const __m256d abx = _mm256_sub_pd(bx, ax), aby = _mm256_sub_pd(by, ay),
                abz = _mm256_sub_pd(bz, az);
  const __m256d acx = _mm256_sub_pd(cx, ax), acy = _mm256_sub_pd(cy, ay),
                acz = _mm256_sub_pd(cz, az);
  const __m256d apx = _mm256_sub_pd(px, ax), apy = _mm256_sub_pd(py, ay),
                apz = _mm256_sub_pd(pz, az);
  const __m256d d1 = dot3_avx2(abx, aby, abz, apx, apy, apz),
                e2 = dot3_avx2(acx, acy, acz, apx, apy, apz);
  const __m256d bpx = _mm256_sub_pd(px, bx), bpy = _mm256_sub_pd(py, by),
                bpz = _mm256_sub_pd(pz, bz);
  const __m256d d3 = dot3_avx2(abx, aby, abz, bpx, bpy, bpz),
                d4 = dot3_avx2(acx, acy, acz, bpx, bpy, bpz);
  const __m256d vc = _mm256_sub_pd(_mm256_mul_pd(d1, d4), _mm256_mul_pd(d3, e2));
  const __m256d cpx = _mm256_sub_pd(px, cx), cpy = _mm256_sub_pd(py, cy),
                cpz = _mm256_sub_pd(pz, cz);
  const __m256d d5 = dot3_avx2(abx, aby, abz, cpx, cpy, cpz),
                d6 = dot3_avx2(acx, acy, acz, cpx, cpy, cpz);
  const __m256d vb = _mm256_sub_pd(_mm256_mul_pd(d5, e2), _mm256_mul_pd(d1, d6));
  const __m256d va = _mm256_sub_pd(_mm256_mul_pd(d3, d6), _mm256_mul_pd(d5, d4));
  const __m256d d43 = _mm256_sub_pd(d4, d3), d56 = _mm256_sub_pd(d5, d6);
  // The regions, in the scalar walk's order (the first that holds decides).
  const __m256d r1 = both_avx2(le_avx2(d1, zero), le_avx2(e2, zero));
  const __m256d r2 = both_avx2(ge_avx2(d3, zero), le_avx2(d4, d3));
  const __m256d r3 = both_avx2(both_avx2(le_avx2(vc, zero), ge_avx2(d1, zero)), le_avx2(d3, zero));
  const __m256d r4 = both_avx2(ge_avx2(d6, zero), le_avx2(d5, d6));
  const __m256d r5 = both_avx2(both_avx2(le_avx2(vb, zero), ge_avx2(e2, zero)), le_avx2(d6, zero));
  const __m256d r6 =
      both_avx2(both_avx2(le_avx2(va, zero), ge_avx2(d43, zero)), ge_avx2(d56, zero));
  // Interior: a + ab (vb / s) + ac (vc / s), s = va + vb + vc, as 1 / s then products.
  const __m256d denom =
      _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_add_pd(_mm256_add_pd(va, vb), vc));
  const __m256d v = _mm256_mul_pd(vb, denom), w = _mm256_mul_pd(vc, denom);
  Points4 r{_mm256_add_pd(_mm256_add_pd(ax, _mm256_mul_pd(abx, v)), _mm256_mul_pd(acx, w)),
            _mm256_add_pd(_mm256_add_pd(ay, _mm256_mul_pd(aby, v)), _mm256_mul_pd(acy, w)),
            _mm256_add_pd(_mm256_add_pd(az, _mm256_mul_pd(abz, v)), _mm256_mul_pd(acz, w))};
  // Then the other regions, last-checked first, so the earliest that holds is kept.
  const Points4 a{ax, ay, az}, b{bx, by, bz}, c3{cx, cy, cz};
  const Points4 ab{abx, aby, abz}, ac{acx, acy, acz};
  const Points4 bc{_mm256_sub_pd(cx, bx), _mm256_sub_pd(cy, by), _mm256_sub_pd(cz, bz)};
  // edge bc: b + t (c - b), t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
  pick_avx2(r, along_avx2(b, _mm256_div_pd(d43, _mm256_add_pd(d43, d56)), bc), r6);
  pick_avx2(r, along_avx2(a, _mm256_div_pd(e2, _mm256_sub_pd(e2, d6)), ac), r5);  // edge ac
  pick_avx2(r, c3, r4);
  pick_avx2(r, along_avx2(a, _mm256_div_pd(d1, _mm256_sub_pd(d1, d3)), ab), r3);  // edge ab
  pick_avx2(r, b, r2);
  pick_avx2(r, a, r1);
  const __m256d ex = _mm256_sub_pd(r.x, px), ey = _mm256_sub_pd(r.y, py),
                ez = _mm256_sub_pd(r.z, pz);
  _mm256_storeu_pd(qx, r.x);
  _mm256_storeu_pd(qy, r.y);
  _mm256_storeu_pd(qz, r.z);
  _mm256_storeu_pd(d2, dot3_avx2(ex, ey, ez, ex, ey, ez));
}

/// Every candidate whose box may win, 4 at a time: the box test, then (when a lane passes)
/// the exact test of all 4 lanes at once. The best is the least (distance, triangle) over
/// the candidates, as offer() finds it: a lane whose box could not win cannot be it.
[[gnu::target("avx2")]] void scan_candidates_avx2(PointQueryState& st, const BallScratch& c) {
  const std::size_t n = c.ids.size();
  const __m256d zero = _mm256_setzero_pd();
  const __m256d px = _mm256_set1_pd(st.p.x()), py = _mm256_set1_pd(st.p.y()),
                pz = _mm256_set1_pd(st.p.z());
  for (std::size_t k = 0; k < n; k += 4) {
    // max(0, lo - p, p - hi) per axis; NaN never arises (padding boxes are at +inf).
    const __m256d ex =
        _mm256_max_pd(_mm256_max_pd(zero, _mm256_sub_pd(_mm256_loadu_pd(c.lo[0].data() + k), px)),
                      _mm256_sub_pd(px, _mm256_loadu_pd(c.hi[0].data() + k)));
    const __m256d ey =
        _mm256_max_pd(_mm256_max_pd(zero, _mm256_sub_pd(_mm256_loadu_pd(c.lo[1].data() + k), py)),
                      _mm256_sub_pd(py, _mm256_loadu_pd(c.hi[1].data() + k)));
    const __m256d ez =
        _mm256_max_pd(_mm256_max_pd(zero, _mm256_sub_pd(_mm256_loadu_pd(c.lo[2].data() + k), pz)),
                      _mm256_sub_pd(pz, _mm256_loadu_pd(c.hi[2].data() + k)));
    const __m256d box2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ex, ex), _mm256_mul_pd(ey, ey)),
                                       _mm256_mul_pd(ez, ez));
    const __m256d limit = _mm256_set1_pd(st.best_d2 * (1 + 1e-9));
    auto m = static_cast<unsigned>(_mm256_movemask_pd(_mm256_cmp_pd(box2, limit, _CMP_NGT_UQ)));
    if (n - k < 4) m &= (1U << (n - k)) - 1;
    if (m == 0) continue;
    alignas(32) double qx[4], qy[4], qz[4], d2[4];
    closest_points_4(c, k, st.p, qx, qy, qz, d2);
    for (; m != 0; m &= m - 1) {
      const auto j = static_cast<std::size_t>(std::countr_zero(m));
      const std::uint32_t t = c.ids[k + j];
      if (d2[j] < st.best_d2 || (d2[j] == st.best_d2 && t < st.best_triangle)) {
        st.best_d2 = d2[j];
        st.best_point = Vec3(qx[j], qy[j], qz[j]);
        st.best_triangle = t;
        st.best_slot = k + j;
      }
    }
  }
}
#endif

}  // namespace

CandidateKernel candidate_kernel() {
#if defined(__x86_64__) && defined(__GNUC__)
  if (cpu_has_avx2() && !plain_path("mesh_query_avx2")) return {scan_candidates_avx2, true};
#endif
  return {scan_candidates_plain, false};
}

}  // namespace printtwin::detail
