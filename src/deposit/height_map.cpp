// The deposit's height map (see height_map.hpp).
#include "deposit/height_map.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace printtwin::detail {

HeightMap::HeightMap(double voxel_mm, const Vec3& origin_mm, int nx, int ny, std::size_t tiles_x,
                     std::size_t tiles_y)
    : voxel_(voxel_mm),
      inv_voxel_(1.0 / voxel_mm),
      ox_(origin_mm.x()),
      oy_(origin_mm.y()),
      oz_(origin_mm.z()),
      nx_(nx),
      ny_(ny),
      tiles_x_(tiles_x),
      top_(tiles_x * tiles_y * 64),
      top_layer_(top_.size()),
      before_(top_.size()) {}

std::optional<std::int32_t> HeightMap::top_layer_at(double x_mm, double y_mm) const {
  const double u = (x_mm - ox_) * inv_voxel_, v = (y_mm - oy_) * inv_voxel_;
  const int i = floor_int(u), j = floor_int(v);
  if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return std::nullopt;
  const std::size_t at = index(i, j);
  if (top_[at] == 0) return std::nullopt;
  return top_layer_[at] >> 1;  // an arithmetic shift: layer_code's floor division by 2
}

bool HeightMap::top_is_support(double x_mm, double y_mm) const {
  const int i = floor_int(u(x_mm)), j = floor_int(v(y_mm));
  if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return false;
  const std::size_t at = index(i, j);
  return top_[at] != 0 && (top_layer_[at] & 1) != 0;
}

int HeightMap::rows_before_top_layer(double x_mm, double y_mm) const {
  const int i = floor_int(u(x_mm)), j = floor_int(v(y_mm));
  if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return 0;
  return before_[index(i, j)];
}

int HeightMap::rows_reaching(double z_mm) const {
  int r = static_cast<int>(std::ceil((z_mm - oz_) * inv_voxel_));
  while (r > 0 && oz_ + (r - 1) * voxel_ >= z_mm) --r;
  while (!(oz_ + r * voxel_ >= z_mm)) ++r;
  return std::max(r, 0);
}

std::uint64_t HeightMap::tops_equal(std::size_t at, std::uint16_t rows) const {
  const std::uint16_t* tile = top_.data() + at;
  std::uint64_t m = 0;
#if defined(__SSE2__)
  const __m128i value = _mm_set1_epi16(static_cast<short>(rows));
  for (int y = 0; y < 8; ++y) {
    const __m128i eq =
        _mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(tile + 8 * y)), value);
    const auto bits = static_cast<unsigned>(_mm_movemask_epi8(_mm_packs_epi16(eq, eq))) & 0xFFu;
    m |= static_cast<std::uint64_t>(bits) << (8 * y);
  }
#else
  for (int s = 0; s < 64; ++s)
    if (tile[s] == rows) m |= std::uint64_t{1} << s;
#endif
  return m;
}

void HeightMap::set_columns(std::uint16_t* rows, std::uint64_t mask, std::uint16_t value) {
#if defined(__SSE2__)
  const __m128i bit = _mm_setr_epi16(1, 2, 4, 8, 16, 32, 64, 128);
  const __m128i v = _mm_set1_epi16(static_cast<short>(value));
  for (int y = 0; y < 8; ++y, rows += 8) {
    const auto m = static_cast<short>((mask >> (8 * y)) & 0xFFu);
    if (m == 0) continue;
    const __m128i lanes = _mm_cmpeq_epi16(_mm_and_si128(_mm_set1_epi16(m), bit), bit);
    auto* p = reinterpret_cast<__m128i*>(rows);
    _mm_storeu_si128(
        p, _mm_or_si128(_mm_and_si128(lanes, v), _mm_andnot_si128(lanes, _mm_loadu_si128(p))));
  }
#else
  for (; mask != 0; mask &= mask - 1) rows[std::countr_zero(mask)] = value;
#endif
}

void HeightMap::raise_tops(std::uint16_t* tile, std::int32_t* layers, std::uint16_t* before,
                           std::uint64_t mask, const std::uint16_t* rows, bool per_column,
                           std::int32_t layer) {
#if defined(__SSE2__)
  const __m128i bit = _mm_setr_epi16(1, 2, 4, 8, 16, 32, 64, 128);
  const __m128i one_value = _mm_set1_epi16(static_cast<short>(rows[0]));
  const __m128i layer4 = _mm_set1_epi32(layer);
  for (int y = 0; y < 8; ++y, tile += 8, layers += 8, before += 8) {
    const auto m = static_cast<short>((mask >> (8 * y)) & 0xFFu);
    if (m == 0) continue;
    const __m128i value =
        per_column ? _mm_loadu_si128(reinterpret_cast<const __m128i*>(rows + 8 * y)) : one_value;
    const __m128i lanes = _mm_cmpeq_epi16(_mm_and_si128(_mm_set1_epi16(m), bit), bit);
    auto* p = reinterpret_cast<__m128i*>(tile);
    const __m128i old = _mm_loadu_si128(p);
    // Heights stay below 32768 rows (kMaxRows), so the signed compare and max are exact.
    const __m128i reach = _mm_andnot_si128(_mm_cmpgt_epi16(old, value), lanes);
    _mm_storeu_si128(p, _mm_max_epi16(old, _mm_and_si128(lanes, value)));
    auto* lp = reinterpret_cast<__m128i*>(layers);
    const __m128i l_lo = _mm_loadu_si128(lp), l_hi = _mm_loadu_si128(lp + 1);
    // Columns whose top passes to another layer keep the rows they held (the layer: the code
    // without its support bit).
    const __m128i layer_only = _mm_srai_epi32(layer4, 1);
    const __m128i same = _mm_packs_epi32(_mm_cmpeq_epi32(_mm_srai_epi32(l_lo, 1), layer_only),
                                         _mm_cmpeq_epi32(_mm_srai_epi32(l_hi, 1), layer_only));
    const __m128i handed = _mm_andnot_si128(same, reach);
    auto* bp = reinterpret_cast<__m128i*>(before);
    _mm_storeu_si128(bp, _mm_or_si128(_mm_and_si128(handed, old),
                                      _mm_andnot_si128(handed, _mm_loadu_si128(bp))));
    const __m128i r_lo = _mm_unpacklo_epi16(reach, reach), r_hi = _mm_unpackhi_epi16(reach, reach);
    _mm_storeu_si128(lp, _mm_or_si128(_mm_and_si128(r_lo, layer4), _mm_andnot_si128(r_lo, l_lo)));
    _mm_storeu_si128(lp + 1,
                     _mm_or_si128(_mm_and_si128(r_hi, layer4), _mm_andnot_si128(r_hi, l_hi)));
  }
#else
  for (int y = 0; y < 8; ++y, tile += 8, layers += 8, before += 8) {
    const auto m = static_cast<unsigned>(mask >> (8 * y)) & 0xFFu;
    for (int x = 0; x < 8; ++x) {
      if (((m >> x) & 1u) == 0) continue;
      const std::uint16_t r = rows[per_column ? 8 * y + x : 0];
      if (r >= tile[x]) {
        if ((layers[x] >> 1) != (layer >> 1)) before[x] = tile[x];
        layers[x] = layer;
      }
      tile[x] = std::max(tile[x], r);
    }
  }
#endif
}

}  // namespace printtwin::detail
