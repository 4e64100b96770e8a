// The deviation stage's kernels (see kernels.hpp): the face-square distance scan.
#include "deviation/kernels.hpp"

#include <algorithm>
#include <cmath>

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

}  // namespace

FaceScan face_scan_kernel() { return scan_faces_plain; }

}  // namespace printtwin::detail
