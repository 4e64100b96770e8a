// The mesh query's candidate scan (see kernels.hpp).
#include "mesh/kernels.hpp"

#include <algorithm>

namespace printtwin::detail {

void scan_candidates(PointQueryState& st, const BallScratch& c) {
  for (std::size_t k = 0; k < c.ids.size(); ++k) {
    double box2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double e = std::max({0.0, c.lo[a][k] - st.p[a], st.p[a] - c.hi[a][k]});
      box2 += e * e;
    }
    if (box_may_win(box2, st.best_d2) && offer_unboxed(st, c.ids[k])) st.best_slot = k;
  }
}

}  // namespace printtwin::detail
