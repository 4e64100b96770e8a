// The deviation stage's kernels (see kernels.hpp): the face-square distance scan.
#include "deviation/kernels.hpp"

namespace printtwin::detail {

namespace {

void scan_faces_plain(const std::uint16_t* code, std::uint32_t lo, std::uint32_t hi,
                      const double* x, const double* y, const double* z, NearestFace& best) {
  for (std::uint32_t k = lo; k < hi; ++k) {
    const unsigned c = code[k];
    best.offer(x[c & 15U] + y[(c >> 4) & 15U] + z[(c >> 8) & 15U], k);
  }
}

}  // namespace

FaceScan face_scan_kernel() { return scan_faces_plain; }

}  // namespace printtwin::detail
