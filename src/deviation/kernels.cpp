// The deviation stage's kernels (see kernels.hpp): the face-square distance scan.
#include "deviation/kernels.hpp"

#include <algorithm>
#include <cmath>

namespace printtwin::detail {

namespace {

inline double face_dist2(const FaceCell& f, std::size_t k, const Vec3& p, double half) {
  const unsigned code = f.code[k], ax = code >> 12;
  const double cx = f.coord[0][code & 15U], cy = f.coord[1][(code >> 4) & 15U],
               cz = f.coord[2][(code >> 8) & 15U];
  const double ex = std::max(0.0, std::abs(p.x() - cx) - (ax == 0 ? 0.0 : half));
  const double ey = std::max(0.0, std::abs(p.y() - cy) - (ax == 1 ? 0.0 : half));
  const double ez = std::max(0.0, std::abs(p.z() - cz) - (ax == 2 ? 0.0 : half));
  return ex * ex + ey * ey + ez * ez;
}

void scan_faces_plain(const FaceCell& f, std::uint32_t lo, std::uint32_t hi, const Vec3& p,
                      double half, NearestFace& best) {
  for (std::uint32_t k = lo; k < hi; ++k) best.offer(face_dist2(f, k, p, half), k);
}

}  // namespace

FaceScan face_scan_kernel() { return scan_faces_plain; }

}  // namespace printtwin::detail
