#pragma once
// The deviation stage's kernels: the one place with instruction-set specific code in
// deviation/, behind one dispatch point (face_scan_kernel). Each kernel keeps a plain twin
// that gives the same bits; bench/RESULTS.md measures the pairs.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "printtwin/geometry.hpp"

namespace printtwin::detail {

/// The nearest face so far: squared distance and face index (ties: the lowest index).
struct NearestFace {
  double d2 = std::numeric_limits<double>::infinity();
  std::uint32_t face = 0;
  void offer(double x2, std::uint32_t f) {
    if (x2 < d2 || (x2 == d2 && f < face)) {
      d2 = x2;
      face = f;
    }
  }
};

/// The faces of a deposit surface cell (4^3 voxels) are 2-byte codes: bits 4a..4a+3 the
/// index of the face centre's coordinate along axis a among the cell's 12 (three per voxel
/// row l = 0..3: 3 l the voxels' centre, 3 l + 1 their min side, 3 l + 2 their max side),
/// bits 12..13 the normal axis. A face square (edge 2 * half, axis-aligned) reaches `half`
/// either way from its centre in its plane, and not at all along its normal, which is the
/// axis whose coordinate is a side: so the squared distance from a point p to the face is
/// the sum over the axes of one term per coordinate index, max(0, |p_a - c| - h)^2 with
/// h = half for a centre and 0 for a side. AxisTerms holds those 12 terms of one axis of
/// one cell for one point (16 entries: any 4-bit index reads inside; the 4 unused ones are
/// infinite). Written only by fill (no initial values: a search makes several a point).
struct AxisTerms {
  std::array<double, 16> t;
  /// The reach h of each coordinate index: half for a centre, 0 for a side.
  static std::array<double, 12> reaches(double half) {
    std::array<double, 12> h{};
    for (std::size_t j = 0; j < 12; j += 3) h[j] = half;
    return h;
  }
  /// The terms of p_a against a cell's coordinates along axis a (`coord`, 12 of them), with
  /// the reaches `h` (reaches(half)): a loop without branches, which the compiler vectorises.
  void fill(const double* coord, const std::array<double, 12>& h, double p_a) {
    for (std::size_t j = 0; j < 12; ++j) {
      const double e = std::max(0.0, std::abs(p_a - coord[j]) - h[j]);
      t[j] = e * e;
    }
    for (std::size_t j = 12; j < 16; ++j) t[j] = std::numeric_limits<double>::infinity();
  }
};

/// Offers faces [lo, hi) of a cell (their codes at code[lo..hi)) to `best`: the squared
/// distance to each is x[i] + y[j] + z[k] for its coordinate indices i, j, k (the terms of
/// the point against the cell, AxisTerms).
using FaceScan = void (*)(const std::uint16_t* code, std::uint32_t lo, std::uint32_t hi,
                          const double* x, const double* y, const double* z, NearestFace& best);

/// The face scan to use.
FaceScan face_scan_kernel();

}  // namespace printtwin::detail
