// The mesh query's candidate scan (see kernels.hpp).
#include "mesh/kernels.hpp"

#include <algorithm>
#include <array>

namespace printtwin::detail {

namespace {
/// Candidates whose box distances are computed together (a loop without branches, which the
/// compiler vectorises) before the exact tests of those that may win.
constexpr std::size_t kBoxBlock = 64;
}  // namespace

void scan_candidates(PointQueryState& st, const BallScratch& c) {
  const std::size_t n = c.ids.size();
  const double px = st.p.x(), py = st.p.y(), pz = st.p.z();
  const double *lx = c.lo[0].data(), *ly = c.lo[1].data(), *lz = c.lo[2].data();
  const double *hx = c.hi[0].data(), *hy = c.hi[1].data(), *hz = c.hi[2].data();
  std::array<double, kBoxBlock> box2{};
  for (std::size_t k0 = 0; k0 < n; k0 += kBoxBlock) {
    const std::size_t m = std::min(kBoxBlock, n - k0);
    // max(0, lo - p, p - hi) per axis, squared and summed x, y, z (box_distance2's order).
    for (std::size_t j = 0; j < m; ++j) {
      const std::size_t k = k0 + j;
      const double ex = std::max(std::max(0.0, lx[k] - px), px - hx[k]);
      const double ey = std::max(std::max(0.0, ly[k] - py), py - hy[k]);
      const double ez = std::max(std::max(0.0, lz[k] - pz), pz - hz[k]);
      box2[j] = ex * ex + ey * ey + ez * ez;
    }
    for (std::size_t j = 0; j < m; ++j)
      if (box_may_win(box2[j], st.best_d2) && offer_unboxed(st, c.ids[k0 + j]))
        st.best_slot = k0 + j;
  }
}

}  // namespace printtwin::detail
