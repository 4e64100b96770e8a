#pragma once
// The deviation stage's kernels: the one place with instruction-set specific code in
// deviation/, behind one dispatch point (face_scan_kernel). Each kernel keeps a plain twin
// that gives the same bits; bench/RESULTS.md measures the pairs.
#include <array>
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

/// A cell of a deposit surface's faces (4^3 voxels) as the kernels read them: per face a
/// code, bits 4a..4a+3 the index of its centre's coordinate along axis a in coord[a], bits
/// 12..13 its normal axis (0, 1, 2); per axis the cell's coordinates, three per voxel row
/// l = 0..3 (index 3 l: the voxels' centre, 3 l + 1: their min side, 3 l + 2: their max
/// side), as DepositSurface::face_center computes them (the same bits).
struct FaceCell {
  const std::uint16_t* code = nullptr;
  std::array<const double*, 3> coord{};
};

/// Offers faces [lo, hi) of a cell to `best`: the squared distance from p to each face square
/// (edge 2 * half, axis-aligned), per axis max(0, |p - c| - h), h = half in the face's plane
/// and 0 along its normal.
using FaceScan = void (*)(const FaceCell& cell, std::uint32_t lo, std::uint32_t hi, const Vec3& p,
                          double half, NearestFace& best);

/// The face scan to use.
FaceScan face_scan_kernel();

}  // namespace printtwin::detail
