#pragma once
// The deviation stage's kernels: the one place with instruction-set specific code in
// deviation/, behind one dispatch point (face_scan_kernel). Each kernel keeps a plain twin
// that gives the same bits; bench/RESULTS.md measures the pair (PRINTTWIN_PLAIN=face_avx2).
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

/// A deposit surface's faces as the kernels read them: centres (rows of x y z) and the
/// normal axis of each face (0, 1, 2), with 4 readable bytes past the last.
struct FaceArrays {
  const Vec3* center = nullptr;
  const std::uint8_t* axis = nullptr;
  std::size_t n = 0;
};

/// Offers faces [lo, hi) to `best`: the squared distance from p to each face square (edge
/// 2 * half, axis-aligned), per axis max(0, |p - c| - h), h = half in the face's plane and 0
/// along its normal.
using FaceScan = void (*)(const FaceArrays& faces, std::uint32_t lo, std::uint32_t hi,
                          const Vec3& p, double half, NearestFace& best);

/// The face scan to use.
FaceScan face_scan_kernel();

}  // namespace printtwin::detail
