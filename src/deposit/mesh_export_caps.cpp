// The caps' planar walk (mesh_export_caps.hpp has the contract).
//
// The two sets of rings of a boundary are simplified outlines of nearly the same wall: they
// cross at shallow angles all along it and enclose thin slivers between the crossings. The
// walk finds every contact of two ring edges on a grid with exact orientation predicates,
// puts each crossing point on both rings, and walks the faces of the resulting planar graph
// (its order around each vertex taken from the rings' own points, never from a rounded
// crossing). Each face is labelled by the regions it lies in (from a ray cast per connected
// piece, then across its edges), and the faces in exactly one region are triangulated: ear
// clipping for the small simple ones (slivers), a constrained Delaunay triangulation of the
// face alone for the others. Everything it cannot prove makes it give up (false).
#include "deposit/mesh_export_caps.hpp"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

namespace printtwin::detail {
namespace {

using P2 = Eigen::Vector2d;
using Epick = CGAL::Exact_predicates_inexact_constructions_kernel;
using Tri = std::array<std::uint32_t, 3>;
constexpr std::uint32_t kNone = ~0U;

/// Faces with more points than this (or with holes) go to the face's own Delaunay
/// triangulation: ear clipping is quadratic in the worst case.
constexpr std::size_t kEarMax = 64;

/// Orientation of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear; exact (a
/// floating-point filter, then CGAL's exact predicate).
int orient(const P2& a, const P2& b, const P2& c) {
  const double l = (a.x() - c.x()) * (b.y() - c.y());
  const double r = (a.y() - c.y()) * (b.x() - c.x());
  const double det = l - r;
  const double bound = 3.3306690738754716e-16 * (std::abs(l) + std::abs(r));
  if (det > bound) return 1;
  if (-det > bound) return -1;
  return static_cast<int>(CGAL::orientation(
      Epick::Point_2(a.x(), a.y()), Epick::Point_2(b.x(), b.y()), Epick::Point_2(c.x(), c.y())));
}

/// Ids of points by their exact coordinates (open addressing).
class PointIds {
 public:
  void reset(std::size_t n) {
    std::size_t cap = 16;
    while (cap < 2 * n + 16) cap *= 2;
    keys_.assign(cap, {});
    ids_.assign(cap, kNone);
  }
  /// The id of `p`, or `fresh` (then stored) when it is new.
  std::uint32_t find_or_add(const P2& p, std::uint32_t fresh) {
    const std::array<std::uint64_t, 2> k{std::bit_cast<std::uint64_t>(p.x() + 0.0),
                                         std::bit_cast<std::uint64_t>(p.y() + 0.0)};
    std::uint64_t h =
        k[0] * 0x9E3779B97F4A7C15ULL ^ (k[1] + 0x632BE59BD9B4E019ULL) * 0xC2B2AE3D27D4EB4FULL;
    h ^= h >> 29;
    const std::size_t mask = ids_.size() - 1;
    for (std::size_t i = h & mask;; i = (i + 1) & mask) {
      if (ids_[i] == kNone) {
        keys_[i] = k;
        ids_[i] = fresh;
        return fresh;
      }
      if (keys_[i] == k) return ids_[i];
    }
  }

 private:
  std::vector<std::array<std::uint64_t, 2>> keys_;
  std::vector<std::uint32_t> ids_;
};

struct Crossing {
  std::uint32_t e = 0, f = 0;  // the two ring edges
  double te = 0, tf = 0;       // where along each
  std::uint32_t id = 0;        // its vertex
};

/// The state of one boundary's walk.
struct Walk {
  std::size_t n_below = 0;
  std::vector<P2> pt;                     // per vertex
  std::vector<char> is_crossing;          // per vertex
  std::vector<std::uint32_t> ids;         // each ring's points (extras in), consecutive repeats out
  std::vector<std::uint32_t> ring_begin;  // per ring, into ids (and edges); one more at end
  std::vector<std::uint32_t> vertex_slot;   // per input ring vertex: its place in ids
  std::vector<std::uint32_t> vertex_begin;  // per ring, into vertex_slot
  std::vector<std::uint32_t> edge_ring;     // per edge (edge i of ring r: ids[begin + i] ->)
  std::vector<std::array<std::uint32_t, 2>> coincident;  // edges with the same two ends
  std::vector<Crossing> crossings;
  std::vector<std::uint32_t> crossed_rings;  // rings crossing their own set

  [[nodiscard]] std::uint32_t ring_size(std::size_t r) const {
    return ring_begin[r + 1] - ring_begin[r];
  }
  [[nodiscard]] std::uint32_t edge_from(std::uint32_t e) const { return ids[e]; }
  [[nodiscard]] std::uint32_t edge_to(std::uint32_t e) const {
    const std::uint32_t r = edge_ring[e];
    return e + 1 < ring_begin[r + 1] ? ids[e + 1] : ids[ring_begin[r]];
  }
  [[nodiscard]] unsigned char side_of_ring(std::size_t r) const { return r < n_below ? 1 : 2; }
};

/// Each ring's points with its split points, as vertex ids; false when a ring keeps fewer
/// than three.
bool collect_rings(const std::vector<CapRing>& rings, const CapExtras& extras, Walk& w) {
  std::size_t total = 0;
  for (std::size_t r = 0; r < rings.size(); ++r)
    total += rings[r].size() + (extras.empty() ? 0 : extras[r].size());
  PointIds pids;
  pids.reset(total);
  w.ring_begin.assign(1, 0);
  w.vertex_begin.assign(1, 0);
  for (std::size_t r = 0; r < rings.size(); ++r) {
    const std::size_t first = w.ids.size();
    const CapExtra* extra = extras.empty() ? nullptr : extras[r].data();
    const CapExtra* const extra_end = extras.empty() ? nullptr : extra + extras[r].size();
    const auto add = [&](const P2& p) {
      const auto id = pids.find_or_add(p, static_cast<std::uint32_t>(w.pt.size()));
      if (id == w.pt.size()) w.pt.push_back(p);
      if (w.ids.size() == first || w.ids.back() != id) w.ids.push_back(id);
    };
    for (std::size_t k = 0; k < rings[r].size(); ++k) {
      add(rings[r][k]);
      w.vertex_slot.push_back(static_cast<std::uint32_t>(w.ids.size() - 1 - first));
      for (; extra != extra_end && extra->after == k; ++extra) add(extra->p);
    }
    // The ring's last points may be its first again: they take the closing place.
    std::size_t m = w.ids.size() - first;
    while (m > 1 && w.ids.back() == w.ids[first]) {
      w.ids.pop_back();
      --m;
    }
    for (std::size_t k = w.vertex_begin.back(); k < w.vertex_slot.size(); ++k)
      w.vertex_slot[k] = std::min(w.vertex_slot[k], static_cast<std::uint32_t>(m));
    if (m < 3) return false;
    w.ring_begin.push_back(static_cast<std::uint32_t>(w.ids.size()));
    w.vertex_begin.push_back(static_cast<std::uint32_t>(w.vertex_slot.size()));
    w.edge_ring.resize(w.ids.size(), static_cast<std::uint32_t>(r));
  }
  w.is_crossing.assign(w.pt.size(), 0);
  return true;
}

/// A uniform grid over the rings' edges: each edge in the cells its segment passes through.
class EdgeGrid {
 public:
  explicit EdgeGrid(const Walk& w) : w_(w) {
    const std::size_t n = w.ids.size();
    lo_ = P2(std::numeric_limits<double>::max(), std::numeric_limits<double>::max());
    P2 hi = -lo_;
    double length = 0;
    for (std::uint32_t e = 0; e < n; ++e) {
      const P2& a = w.pt[w.edge_from(e)];
      lo_ = lo_.cwiseMin(a);
      hi = hi.cwiseMax(a);
      length += (w.pt[w.edge_to(e)] - a).norm();
    }
    cell_ = std::max(2.0 * length / static_cast<double>(std::max<std::size_t>(n, 1)), 1e-9);
    for (;;) {
      cols_ = static_cast<std::int64_t>((hi.x() - lo_.x()) / cell_) + 1;
      rows_ = static_cast<std::int64_t>((hi.y() - lo_.y()) / cell_) + 1;
      if (cols_ * rows_ <= static_cast<std::int64_t>(4 * n + 64)) break;
      cell_ *= 1.5;
    }
    start_.assign(static_cast<std::size_t>(cols_ * rows_) + 1, 0);
    for (int pass = 0; pass < 2; ++pass) {
      for (std::uint32_t e = 0; e < n; ++e)
        for (std::int64_t r = row_of(e, 0); r <= row_of(e, 1); ++r) {
          const auto [c0, c1] = span(e, r);
          for (std::int64_t c = c0; c <= c1; ++c) {
            const auto cell = static_cast<std::size_t>(r * cols_ + c);
            if (pass == 0)
              ++start_[cell + 1];
            else
              items_[fill_[cell]++] = e;
          }
        }
      if (pass == 0) {
        std::partial_sum(start_.begin(), start_.end(), start_.begin());
        items_.resize(start_.back());
        fill_.assign(start_.begin(), start_.end() - 1);
      }
    }
  }

  /// Calls f(e, f) once for each pair of edges that share a cell (e < f).
  template <class F>
  bool for_each_pair(F&& f) const {
    for (std::int64_t r = 0; r < rows_; ++r)
      for (std::int64_t c = 0; c < cols_; ++c) {
        const auto cell = static_cast<std::size_t>(r * cols_ + c);
        for (std::size_t i = start_[cell]; i < start_[cell + 1]; ++i)
          for (std::size_t j = i + 1; j < start_[cell + 1]; ++j) {
            const std::uint32_t a = std::min(items_[i], items_[j]),
                                b = std::max(items_[i], items_[j]);
            if (!boxes_meet(a, b) || !first_shared(a, b, r, c)) continue;
            if (!f(a, b)) return false;
          }
      }
    return true;
  }

 private:
  [[nodiscard]] std::int64_t clamp_row(double y) const {
    return std::clamp(static_cast<std::int64_t>(std::floor((y - lo_.y()) / cell_)), std::int64_t{0},
                      rows_ - 1);
  }
  [[nodiscard]] std::int64_t clamp_col(double x) const {
    return std::clamp(static_cast<std::int64_t>(std::floor((x - lo_.x()) / cell_)), std::int64_t{0},
                      cols_ - 1);
  }
  [[nodiscard]] std::int64_t row_of(std::uint32_t e, int top) const {
    const double ya = w_.pt[w_.edge_from(e)].y(), yb = w_.pt[w_.edge_to(e)].y();
    const double m = 1e-7 * cell_;
    return top != 0 ? clamp_row(std::max(ya, yb) + m) : clamp_row(std::min(ya, yb) - m);
  }
  /// The columns edge e passes through in row r (a little wider: rounding).
  [[nodiscard]] std::pair<std::int64_t, std::int64_t> span(std::uint32_t e, std::int64_t r) const {
    const P2& a = w_.pt[w_.edge_from(e)];
    const P2& b = w_.pt[w_.edge_to(e)];
    const double m = 1e-7 * cell_;
    double x0 = std::min(a.x(), b.x()), x1 = std::max(a.x(), b.x());
    if (a.y() != b.y()) {
      const double y0 = std::max(std::min(a.y(), b.y()), lo_.y() + cell_ * static_cast<double>(r));
      const double y1 =
          std::min(std::max(a.y(), b.y()), lo_.y() + cell_ * static_cast<double>(r + 1));
      const double s = (b.x() - a.x()) / (b.y() - a.y());
      const double xa = a.x() + (y0 - a.y()) * s, xb = a.x() + (y1 - a.y()) * s;
      x0 = std::max(x0, std::min(xa, xb));
      x1 = std::min(x1, std::max(xa, xb));
    }
    return {clamp_col(x0 - m), clamp_col(x1 + m)};
  }
  [[nodiscard]] bool boxes_meet(std::uint32_t e, std::uint32_t f) const {
    const P2& a = w_.pt[w_.edge_from(e)];
    const P2& b = w_.pt[w_.edge_to(e)];
    const P2& c = w_.pt[w_.edge_from(f)];
    const P2& d = w_.pt[w_.edge_to(f)];
    return std::max(a.x(), b.x()) >= std::min(c.x(), d.x()) &&
           std::max(c.x(), d.x()) >= std::min(a.x(), b.x()) &&
           std::max(a.y(), b.y()) >= std::min(c.y(), d.y()) &&
           std::max(c.y(), d.y()) >= std::min(a.y(), b.y());
  }
  /// True when (r, c) is the first cell (by row, then column) holding both edges.
  [[nodiscard]] bool first_shared(std::uint32_t e, std::uint32_t f, std::int64_t r,
                                  std::int64_t c) const {
    for (std::int64_t rr = std::max(row_of(e, 0), row_of(f, 0)); rr <= r; ++rr) {
      const auto [a0, a1] = span(e, rr);
      const auto [b0, b1] = span(f, rr);
      const std::int64_t lo = std::max(a0, b0), hi = std::min(a1, b1);
      if (lo <= hi) return rr == r && lo == c;
    }
    return false;
  }

  const Walk& w_;
  P2 lo_;
  double cell_ = 1;
  std::int64_t cols_ = 1, rows_ = 1;
  std::vector<std::size_t> start_, fill_;
  std::vector<std::uint32_t> items_;
};

/// Classifies the contact of edges e < f: nothing, a crossing of the two sets (recorded),
/// two edges with the same ends (recorded); false for any other contact.
bool meet(Walk& w, std::uint32_t e, std::uint32_t f) {
  const std::uint32_t a = w.edge_from(e), b = w.edge_to(e), c = w.edge_from(f), d = w.edge_to(f);
  const bool same_set = w.side_of_ring(w.edge_ring[e]) == w.side_of_ring(w.edge_ring[f]);
  if ((a == c && b == d) || (a == d && b == c)) {
    if (same_set) return false;
    w.coincident.push_back({e, f});
    return true;
  }
  if (a == c || a == d || b == c || b == d) {  // one shared end: no overlap
    const std::uint32_t v = (a == c || a == d) ? a : b;
    const std::uint32_t p = v == a ? b : a, q = (v == c) ? d : c;
    const P2& pv = w.pt[v];
    if (orient(pv, w.pt[p], w.pt[q]) != 0) return true;
    return (w.pt[p] - pv).dot(w.pt[q] - pv) < 0;
  }
  const P2 &pa = w.pt[a], &pb = w.pt[b], &pc = w.pt[c], &pd = w.pt[d];
  const int o1 = orient(pa, pb, pc), o2 = orient(pa, pb, pd);
  if (o1 * o2 > 0) return true;
  const int o3 = orient(pc, pd, pa), o4 = orient(pc, pd, pb);
  if (o3 * o4 > 0) return true;
  if (o1 == 0 || o2 == 0 || o3 == 0 || o4 == 0) {
    if (o1 == 0 && o2 == 0) {  // collinear: apart unless their boxes overlap
      const auto within = [](const P2& p, const P2& s, const P2& t) {
        return std::min(s.x(), t.x()) <= p.x() && p.x() <= std::max(s.x(), t.x()) &&
               std::min(s.y(), t.y()) <= p.y() && p.y() <= std::max(s.y(), t.y());
      };
      return !(within(pc, pa, pb) || within(pd, pa, pb) || within(pa, pc, pd));
    }
    return false;  // an end on the other edge
  }
  if (same_set) {  // a ring crossing itself or another of its set: its region is not on its left
    w.crossed_rings.push_back(w.edge_ring[e]);
    w.crossed_rings.push_back(w.edge_ring[f]);
    return true;
  }
  const P2 u = pb - pa, v = pd - pc, s = pc - pa;
  const double den = u.x() * v.y() - u.y() * v.x();
  if (!std::isfinite(1.0 / den)) return false;
  const double te = std::clamp((s.x() * v.y() - s.y() * v.x()) / den, 0.0, 1.0);
  const double tf = std::clamp((s.x() * u.y() - s.y() * u.x()) / den, 0.0, 1.0);
  w.crossings.push_back({e, f, te, tf, 0});
  return true;
}

/// The planar graph: sub-edges (ring edges cut at the crossings) and their half-edges
/// (2 s: along sub-edge s, 2 s + 1: against it).
struct Graph {
  struct Sub {
    std::uint32_t u = 0, v = 0, edge = 0;  // ends and the ring edge it lies on
    unsigned char toggle = 0;              // the regions its crossing toggles
    bool alive = true;                     // false: the same as another ring's
  };
  std::vector<Sub> subs;
  std::vector<std::uint32_t> seq;                       // each ring's vertices, closed
  std::vector<std::uint32_t> seq_begin;                 // per ring
  std::vector<std::uint32_t> first_sub;                 // per ring edge
  std::vector<std::array<std::uint32_t, 2>> ring_half;  // (half-edge, side) per ring sub-edge
  std::vector<std::uint32_t> out_begin, out;            // half-edges out of each vertex, CCW
  std::vector<std::uint32_t> slot;                      // per half-edge: its place in out
  std::vector<std::uint32_t> next;                      // per half-edge: the next along its face
  std::vector<std::uint32_t> face;                      // per half-edge
  std::vector<std::uint32_t> face_begin, face_half;     // faces as half-edge lists
  std::vector<std::array<std::uint32_t, 4>> cross_out;  // per crossing: e fwd/back, f fwd/back

  [[nodiscard]] std::uint32_t origin(std::uint32_t h) const {
    return (h & 1U) != 0 ? subs[h >> 1].v : subs[h >> 1].u;
  }
  [[nodiscard]] std::uint32_t head(std::uint32_t h) const {
    return (h & 1U) != 0 ? subs[h >> 1].u : subs[h >> 1].v;
  }
};

/// Cuts the ring edges at the crossings (ordered along each edge); false on a tie.
bool build_subs(Walk& w, Graph& g) {
  // (edge, t, crossing) for both edges of each crossing, sorted along each edge.
  struct At {
    std::uint32_t edge;
    double t;
    std::uint32_t crossing;
    std::uint32_t which;  // 0: the crossing's e, 1: its f
  };
  std::vector<At> at;
  at.reserve(2 * w.crossings.size());
  PointIds pids;
  pids.reset(w.pt.size() + w.crossings.size());
  for (std::uint32_t i = 0; i < w.pt.size(); ++i) pids.find_or_add(w.pt[i], i);
  for (std::uint32_t i = 0; i < w.crossings.size(); ++i) {
    Crossing& x = w.crossings[i];
    const P2& a = w.pt[w.edge_from(x.e)];
    const P2 p = a + x.te * (w.pt[w.edge_to(x.e)] - a);
    x.id = static_cast<std::uint32_t>(w.pt.size());
    if (pids.find_or_add(p, x.id) != x.id) return false;  // rounded onto another point
    w.pt.push_back(p);
    w.is_crossing.push_back(1);
    at.push_back({x.e, x.te, i, 0});
    at.push_back({x.f, x.tf, i, 1});
  }
  std::sort(at.begin(), at.end(), [](const At& p, const At& q) {
    return p.edge != q.edge ? p.edge < q.edge : p.t < q.t;
  });
  for (std::size_t i = 1; i < at.size(); ++i)
    if (at[i].edge == at[i - 1].edge && !(at[i].t > at[i - 1].t)) return false;
  g.cross_out.assign(w.crossings.size(), {});
  std::vector<std::array<std::uint32_t, 2>> cross_in(w.crossings.size());
  g.first_sub.resize(w.ids.size());
  g.seq_begin.clear();
  std::size_t k = 0;
  for (std::size_t r = 0; r + 1 < w.ring_begin.size(); ++r) {
    g.seq_begin.push_back(static_cast<std::uint32_t>(g.seq.size()));
    for (std::uint32_t e = w.ring_begin[r]; e < w.ring_begin[r + 1]; ++e) {
      g.first_sub[e] = static_cast<std::uint32_t>(g.subs.size());
      std::uint32_t from = w.edge_from(e);
      g.seq.push_back(from);
      for (; k < at.size() && at[k].edge == e; ++k) {
        const std::uint32_t id = w.crossings[at[k].crossing].id;
        cross_in[at[k].crossing][at[k].which] = static_cast<std::uint32_t>(g.subs.size());
        g.subs.push_back({from, id, e, w.side_of_ring(r), true});
        g.cross_out[at[k].crossing][2 * at[k].which] = static_cast<std::uint32_t>(g.subs.size());
        g.seq.push_back(id);
        from = id;
      }
      g.subs.push_back({from, w.edge_to(e), e, w.side_of_ring(r), true});
    }
    g.seq.push_back(w.ids[w.ring_begin[r]]);
  }
  // Half-edges at each crossing: e forward, e backward, f forward, f backward.
  for (std::size_t i = 0; i < w.crossings.size(); ++i) {
    auto& o = g.cross_out[i];
    o = {2 * o[0], 2 * cross_in[i][0] + 1, 2 * o[2], 2 * cross_in[i][1] + 1};
  }
  for (const auto& [e, f] : w.coincident) {
    Graph::Sub& a = g.subs[g.first_sub[e]];
    Graph::Sub& b = g.subs[g.first_sub[f]];
    if (!a.alive || !b.alive || a.v != w.edge_to(e) || b.v != w.edge_to(f)) return false;
    a.toggle ^= b.toggle;
    b.alive = false;
  }
  // Each ring sub-edge as a half-edge of a live sub-edge, with its ring's side.
  std::vector<std::uint32_t> rep(g.subs.size());
  std::iota(rep.begin(), rep.end(), 0U);
  for (const auto& [e, f] : w.coincident) rep[g.first_sub[f]] = g.first_sub[e];
  for (std::uint32_t s = 0; s < g.subs.size(); ++s) {
    const Graph::Sub& sub = g.subs[s];
    const std::uint32_t t = rep[s];
    const std::uint32_t h = 2 * t + (g.subs[t].u == sub.u ? 0U : 1U);
    g.ring_half.push_back({h, w.side_of_ring(w.edge_ring[sub.edge])});
  }
  return true;
}

/// The point a half-edge heads for from a ring vertex: the far end of its ring edge (exact,
/// unlike a crossing point).
P2 direction_target(const Walk& w, const Graph& g, std::uint32_t h) {
  const std::uint32_t e = g.subs[h >> 1].edge;
  return w.pt[(h & 1U) != 0 ? w.edge_from(e) : w.edge_to(e)];
}

/// Half-edges out of each vertex in counter-clockwise order, and each half-edge's next;
/// false when two leave a vertex the same way.
bool order_vertices(const Walk& w, Graph& g) {
  const std::size_t nv = w.pt.size(), nh = 2 * g.subs.size();
  g.out_begin.assign(nv + 1, 0);
  for (const auto& s : g.subs)
    if (s.alive) {
      ++g.out_begin[s.u + 1];
      ++g.out_begin[s.v + 1];
    }
  std::partial_sum(g.out_begin.begin(), g.out_begin.end(), g.out_begin.begin());
  g.out.assign(g.out_begin.back(), 0);
  std::vector<std::uint32_t> fill(g.out_begin.begin(), g.out_begin.end() - 1);
  for (std::uint32_t s = 0; s < g.subs.size(); ++s)
    if (g.subs[s].alive) {
      g.out[fill[g.subs[s].u]++] = 2 * s;
      g.out[fill[g.subs[s].v]++] = 2 * s + 1;
    }
  for (std::size_t i = 0; i < w.crossings.size(); ++i) {
    const Crossing& x = w.crossings[i];
    const auto& o = g.cross_out[i];
    const bool from_right =
        orient(w.pt[w.edge_from(x.e)], w.pt[w.edge_to(x.e)], w.pt[w.edge_from(x.f)]) < 0;
    if (g.out_begin[x.id + 1] - g.out_begin[x.id] != 4) return false;
    const std::array<std::uint32_t, 4> ccw =
        from_right ? std::array{o[0], o[2], o[1], o[3]} : std::array{o[0], o[3], o[1], o[2]};
    std::copy(ccw.begin(), ccw.end(), g.out.begin() + g.out_begin[x.id]);
  }
  for (std::uint32_t v = 0; v < nv; ++v) {
    const std::uint32_t b = g.out_begin[v], e = g.out_begin[v + 1];
    if (e - b < 2) {
      if (e != b) return false;
      continue;
    }
    if (w.is_crossing[v] != 0 || e - b == 2) continue;
    const P2& c = w.pt[v];
    const auto upper = [&](const P2& t) {
      return t.y() > c.y() || (t.y() == c.y() && t.x() > c.x());
    };
    std::sort(g.out.begin() + b, g.out.begin() + e, [&](std::uint32_t p, std::uint32_t q) {
      const P2 tp = direction_target(w, g, p), tq = direction_target(w, g, q);
      const bool up = upper(tp), uq = upper(tq);
      if (up != uq) return up;
      return orient(c, tp, tq) > 0;
    });
    for (std::uint32_t i = b; i < e; ++i) {
      const P2 tp = direction_target(w, g, g.out[i]);
      const P2 tq = direction_target(w, g, g.out[i + 1 < e ? i + 1 : b]);
      if (upper(tp) == upper(tq) && orient(c, tp, tq) == 0) return false;
    }
  }
  g.slot.assign(nh, kNone);
  for (std::uint32_t v = 0; v < nv; ++v)
    for (std::uint32_t i = g.out_begin[v]; i < g.out_begin[v + 1]; ++i)
      g.slot[g.out[i]] = i - g.out_begin[v];
  g.next.assign(nh, kNone);
  for (std::uint32_t h = 0; h < nh; ++h) {
    if (!g.subs[h >> 1].alive) continue;
    const std::uint32_t v = g.head(h), b = g.out_begin[v], deg = g.out_begin[v + 1] - b;
    g.next[h] = g.out[b + (g.slot[h ^ 1U] + deg - 1) % deg];
  }
  return true;
}

/// The faces: the cycles of `next`.
bool walk_faces(Graph& g) {
  const std::size_t nh = g.next.size();
  g.face.assign(nh, kNone);
  g.face_begin.assign(1, 0);
  g.face_half.clear();
  for (std::uint32_t h0 = 0; h0 < nh; ++h0) {
    if (g.next[h0] == kNone || g.face[h0] != kNone) continue;
    const auto f = static_cast<std::uint32_t>(g.face_begin.size() - 1);
    std::uint32_t h = h0;
    do {
      if (g.face[h] != kNone || g.face_half.size() > nh) return false;
      g.face[h] = f;
      g.face_half.push_back(h);
      h = g.next[h];
    } while (h != h0);
    g.face_begin.push_back(static_cast<std::uint32_t>(g.face_half.size()));
  }
  return true;
}

std::uint32_t find_root(std::vector<std::uint32_t>& parent, std::uint32_t v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

/// Crossings of the ray from p toward -x with the rings of other pieces, per set (bit 0:
/// lower, bit 1: upper); false when p lies on one.
bool regions_at(const Walk& w, const std::vector<std::uint32_t>& ring_piece, std::uint32_t piece,
                const std::vector<std::array<double, 4>>& ring_box, const P2& p,
                unsigned char& label) {
  label = 0;
  for (std::size_t r = 0; r + 1 < w.ring_begin.size(); ++r) {
    const auto& box = ring_box[r];
    if (ring_piece[r] == piece || box[0] > p.x() || box[1] > p.y() || box[3] < p.y()) continue;
    bool inside = false;
    for (std::uint32_t e = w.ring_begin[r]; e < w.ring_begin[r + 1]; ++e) {
      const P2& a = w.pt[w.edge_from(e)];
      const P2& b = w.pt[w.edge_to(e)];
      if ((a.y() > p.y()) == (b.y() > p.y())) continue;
      const int o = orient(a, b, p);
      if (o == 0) return false;
      if ((b.y() > a.y()) == (o < 0)) inside = !inside;
    }
    if (inside) label ^= w.side_of_ring(r);
  }
  return true;
}

/// Ear clipping of a simple polygon (counter-clockwise, at least three points); false when
/// no ear is found (a polygon too thin for its rounded points).
bool ear_clip(const std::vector<std::uint32_t>& poly, const std::vector<P2>& pt,
              std::vector<Tri>& out) {
  const std::size_t n = poly.size();
  thread_local std::vector<std::uint32_t> prev, next;
  thread_local std::vector<char> convex;
  prev.resize(n);
  next.resize(n);
  convex.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    prev[i] = static_cast<std::uint32_t>((i + n - 1) % n);
    next[i] = static_cast<std::uint32_t>((i + 1) % n);
  }
  const auto p = [&](std::uint32_t i) -> const P2& { return pt[poly[i]]; };
  const auto update = [&](std::uint32_t i) {
    convex[i] = orient(p(prev[i]), p(i), p(next[i])) > 0 ? 1 : 0;
  };
  for (std::uint32_t i = 0; i < n; ++i) update(i);
  const auto is_ear = [&](std::uint32_t i) {
    if (convex[i] == 0) return false;
    const std::uint32_t a = prev[i], c = next[i];
    for (std::uint32_t j = next[c]; j != a; j = next[j])
      if (convex[j] == 0 && orient(p(a), p(i), p(j)) >= 0 && orient(p(i), p(c), p(j)) >= 0 &&
          orient(p(c), p(a), p(j)) >= 0)
        return false;
    return true;
  };
  std::size_t left = n, stall = 0;
  std::uint32_t i = 0;
  while (left > 3) {
    if (is_ear(i)) {
      const std::uint32_t a = prev[i], c = next[i];
      out.push_back({poly[a], poly[i], poly[c]});
      next[a] = c;
      prev[c] = a;
      update(a);
      update(c);
      --left;
      stall = 0;
      i = a;
    } else {
      i = next[i];
      if (++stall > left) return false;
    }
  }
  if (orient(p(prev[i]), p(i), p(next[i])) <= 0) return false;
  out.push_back({poly[prev[i]], poly[i], poly[next[i]]});
  return true;
}

using Cdt = CGAL::Constrained_Delaunay_triangulation_2<
    Epick,
    CGAL::Triangulation_data_structure_2<
        CGAL::Triangulation_vertex_base_with_info_2<std::uint32_t, Epick>,
        CGAL::Constrained_triangulation_face_base_2<
            Epick, CGAL::Triangulation_face_base_with_info_2<unsigned char, Epick>>>,
    CGAL::No_constraint_intersection_tag>;

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

/// A constrained Delaunay triangulation of one face given by its boundary cycles (the
/// face's own, then those of the pieces inside it), its triangles counter-clockwise; false
/// when a cycle's edge is not an edge of it.
bool cdt_face(const std::vector<std::vector<std::uint32_t>>& cycles, const std::vector<P2>& pt,
              std::vector<Tri>& out) {
  std::vector<std::uint32_t> ids;
  std::vector<std::uint64_t> keys;
  for (const auto& c : cycles)
    for (std::size_t i = 0; i < c.size(); ++i) {
      ids.push_back(c[i]);
      keys.push_back(edge_key(c[i], c[(i + 1) % c.size()]));
    }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::sort(keys.begin(), keys.end());
  Cdt ct;
  std::vector<Cdt::Vertex_handle> vh(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    vh[i] = ct.insert(Cdt::Point(pt[ids[i]].x(), pt[ids[i]].y()));
    if (ct.number_of_vertices() != i + 1) return false;
    vh[i]->info() = ids[i];
  }
  const auto handle = [&](std::uint32_t id) {
    return vh[static_cast<std::size_t>(std::lower_bound(ids.begin(), ids.end(), id) - ids.begin())];
  };
  try {
    for (const auto& c : cycles)
      for (std::size_t i = 0; i < c.size(); ++i)
        ct.insert_constraint(handle(c[i]), handle(c[(i + 1) % c.size()]));
  } catch (const std::exception&) {
    return false;
  }
  if (ct.number_of_vertices() != ids.size()) return false;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    Cdt::Face_handle f;
    int opposite = 0;
    if (!ct.is_edge(handle(static_cast<std::uint32_t>(keys[i] >> 32)),
                    handle(static_cast<std::uint32_t>(keys[i] & 0xffffffffU)), f, opposite))
      return false;
  }
  // Parity of the cycles' edges crossed from the infinite face.
  for (auto f : ct.all_face_handles()) f->info() = 0;
  std::vector<Cdt::Face_handle> stack{ct.infinite_face()};
  ct.infinite_face()->info() = 0x80;
  while (!stack.empty()) {
    const Cdt::Face_handle f = stack.back();
    stack.pop_back();
    for (int i = 0; i < 3; ++i) {
      const Cdt::Face_handle n = f->neighbor(i);
      if ((n->info() & 0x80U) != 0) continue;
      const auto va = f->vertex(Cdt::cw(i)), vb = f->vertex(Cdt::ccw(i));
      unsigned char t = 0;
      if (!ct.is_infinite(va) && !ct.is_infinite(vb)) {
        const std::uint64_t k = edge_key(va->info(), vb->info());
        const auto [lo, hi] = std::equal_range(keys.begin(), keys.end(), k);
        t = static_cast<unsigned char>((hi - lo) & 1);
      }
      n->info() = static_cast<unsigned char>(0x80U | ((f->info() ^ t) & 1U));
      stack.push_back(n);
    }
  }
  for (auto f : ct.finite_face_handles())
    if ((f->info() & 1U) != 0)
      out.push_back({f->vertex(0)->info(), f->vertex(1)->info(), f->vertex(2)->info()});
  return true;
}

/// Signed area of a cycle of vertices.
double cycle_area(const std::vector<std::uint32_t>& c, const std::vector<P2>& pt) {
  double a = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const P2& p = pt[c[i]];
    const P2& q = pt[c[(i + 1) % c.size()]];
    a += p.x() * q.y() - p.y() * q.x();
  }
  return 0.5 * a;
}

/// True when p lies inside the cycle (p on none of its edges).
bool inside_cycle(const std::vector<std::uint32_t>& c, const std::vector<P2>& pt, const P2& p) {
  bool inside = false;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const P2& a = pt[c[i]];
    const P2& b = pt[c[(i + 1) % c.size()]];
    if ((a.y() > p.y()) == (b.y() > p.y())) continue;
    if ((b.y() > a.y()) == (orient(a, b, p) < 0)) inside = !inside;
  }
  return inside;
}

/// Labels of the faces (bit 0: inside the lower rings, bit 1: inside the upper ones) and
/// each piece's outer face; false when a ring does not bound its region.
struct Labels {
  std::vector<int> label;            // per face
  std::vector<std::uint32_t> piece;  // per face
  std::vector<char> outer;           // per face: the outside of its piece
  std::vector<P2> piece_point;       // per piece: its leftmost ring point
};

bool label_faces(const Walk& w, const Graph& g, Labels& lab) {
  const std::size_t nv = w.pt.size(), nf = g.face_begin.size() - 1;
  std::vector<std::uint32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0U);
  for (const auto& s : g.subs)
    if (s.alive) parent[find_root(parent, s.u)] = find_root(parent, s.v);
  // Pieces, numbered by their first vertex; each one's leftmost ring point.
  std::vector<std::uint32_t> piece_of_root(nv, kNone), leftmost;
  std::vector<std::uint32_t> piece(nv);
  for (std::uint32_t v = 0; v < nv; ++v) {
    const std::uint32_t root = find_root(parent, v);
    if (piece_of_root[root] == kNone) {
      piece_of_root[root] = static_cast<std::uint32_t>(leftmost.size());
      leftmost.push_back(kNone);
    }
    const std::uint32_t pc = piece[v] = piece_of_root[root];
    if (w.is_crossing[v] != 0) continue;
    const P2& p = w.pt[v];
    if (leftmost[pc] == kNone || p.x() < w.pt[leftmost[pc]].x() ||
        (p.x() == w.pt[leftmost[pc]].x() && p.y() < w.pt[leftmost[pc]].y()))
      leftmost[pc] = v;
  }
  const std::size_t np = leftmost.size();
  std::vector<std::uint32_t> ring_piece(w.ring_begin.size() - 1);
  std::vector<std::array<double, 4>> ring_box(ring_piece.size());
  for (std::size_t r = 0; r < ring_piece.size(); ++r) {
    ring_piece[r] = piece[w.ids[w.ring_begin[r]]];
    auto& box = ring_box[r];
    box = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
           std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest()};
    for (std::uint32_t e = w.ring_begin[r]; e < w.ring_begin[r + 1]; ++e) {
      const P2& p = w.pt[w.ids[e]];
      box = {std::min(box[0], p.x()), std::min(box[1], p.y()), std::max(box[2], p.x()),
             std::max(box[3], p.y())};
    }
  }
  lab.label.assign(nf, -1);
  lab.piece.assign(nf, kNone);
  lab.outer.assign(nf, 0);
  lab.piece_point.resize(np);
  std::vector<std::uint32_t> stack;
  for (std::uint32_t pc = 0; pc < np; ++pc) {
    const std::uint32_t v = leftmost[pc];
    const P2& c = w.pt[v];
    lab.piece_point[pc] = c;
    // The outer face lies left of the half-edge out of v that turns farthest counter-clockwise.
    std::uint32_t best = g.out[g.out_begin[v]];
    for (std::uint32_t i = g.out_begin[v] + 1; i < g.out_begin[v + 1]; ++i)
      if (orient(c, direction_target(w, g, best), direction_target(w, g, g.out[i])) > 0)
        best = g.out[i];
    unsigned char outside = 0;
    if (!regions_at(w, ring_piece, pc, ring_box, c, outside)) return false;
    const std::uint32_t f0 = g.face[best];
    lab.label[f0] = outside;
    lab.outer[f0] = 1;
    stack.assign(1, f0);
    while (!stack.empty()) {
      const std::uint32_t f = stack.back();
      stack.pop_back();
      lab.piece[f] = pc;
      for (std::uint32_t i = g.face_begin[f]; i < g.face_begin[f + 1]; ++i) {
        const std::uint32_t h = g.face_half[i];
        const std::uint32_t other = g.face[h ^ 1U];
        const int l = lab.label[f] ^ g.subs[h >> 1].toggle;
        if (lab.label[other] == -1) {
          lab.label[other] = l;
          stack.push_back(other);
        } else if (lab.label[other] != l) {
          return false;
        }
      }
    }
  }
  for (const auto& [h, side] : g.ring_half)
    if ((lab.label[g.face[h]] & static_cast<int>(side)) == 0) return false;
  return true;
}

/// The cycle of vertices of face f.
void face_cycle(const Graph& g, std::uint32_t f, std::vector<std::uint32_t>& c) {
  c.clear();
  for (std::uint32_t i = g.face_begin[f]; i < g.face_begin[f + 1]; ++i)
    c.push_back(g.origin(g.face_half[i]));
}

/// The triangles of the faces inside exactly one region, up (lower only) or down.
bool triangulate(const Walk& w, const Graph& g, const Labels& lab, std::vector<Tri>& tris) {
  const std::size_t nf = lab.label.size();
  std::vector<std::vector<std::uint32_t>> holes(nf);
  std::vector<std::uint32_t> c;
  // A piece whose outside is a face of one region is a hole of the face around it: the
  // innermost face of another piece that holds its leftmost point.
  std::vector<std::uint32_t> bounded;
  std::vector<std::array<double, 4>> box;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (lab.outer[f] == 0 || (lab.label[f] != 1 && lab.label[f] != 2)) continue;
    if (bounded.empty())
      for (std::uint32_t b = 0; b < nf; ++b) {
        if (lab.outer[b] != 0) continue;
        bounded.push_back(b);
        auto& bb = box.emplace_back(std::array{
            std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
            std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest()});
        for (std::uint32_t i = g.face_begin[b]; i < g.face_begin[b + 1]; ++i) {
          const P2& q = w.pt[g.origin(g.face_half[i])];
          bb = {std::min(bb[0], q.x()), std::min(bb[1], q.y()), std::max(bb[2], q.x()),
                std::max(bb[3], q.y())};
        }
      }
    const P2& p = lab.piece_point[lab.piece[f]];
    std::uint32_t around = kNone;
    double around_area = 0;
    for (std::size_t j = 0; j < bounded.size(); ++j) {
      const std::uint32_t b = bounded[j];
      const auto& bb = box[j];
      if (lab.piece[b] == lab.piece[f] || p.x() < bb[0] || p.y() < bb[1] || p.x() > bb[2] ||
          p.y() > bb[3])
        continue;
      face_cycle(g, b, c);
      if (!inside_cycle(c, w.pt, p)) continue;
      const double a = cycle_area(c, w.pt);
      if (around == kNone || a < around_area) {
        around = b;
        around_area = a;
      }
    }
    if (around == kNone || lab.label[around] != lab.label[f]) return false;
    holes[around].push_back(f);
  }
  std::vector<std::uint32_t> mark(w.pt.size(), kNone);
  std::vector<std::vector<std::uint32_t>> cycles;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (lab.outer[f] != 0 || (lab.label[f] != 1 && lab.label[f] != 2)) continue;
    face_cycle(g, f, c);
    bool simple = c.size() <= kEarMax && holes[f].empty();
    for (const std::uint32_t v : c) {
      simple = simple && mark[v] != f;
      mark[v] = f;
    }
    const std::size_t first = tris.size();
    if (!simple || !ear_clip(c, w.pt, tris)) {
      tris.resize(first);
      cycles.assign(1, c);
      for (const std::uint32_t h : holes[f]) {
        face_cycle(g, h, c);
        cycles.push_back(c);
      }
      if (!cdt_face(cycles, w.pt, tris)) return false;
    }
    if (lab.label[f] == 2)
      for (std::size_t t = first; t < tris.size(); ++t) std::swap(tris[t][1], tris[t][2]);
  }
  return true;
}

}  // namespace

bool cap_by_walk(const std::vector<CapRing>& rings, std::size_t n_below, const CapExtras& extras,
                 Boundary& out) {
  Walk w;
  w.n_below = n_below;
  if (rings.empty() || !collect_rings(rings, extras, w)) return false;
  {
    const EdgeGrid grid(w);
    if (!grid.for_each_pair([&](std::uint32_t e, std::uint32_t f) { return meet(w, e, f); }))
      return false;
  }
  if (!w.crossed_rings.empty()) {
    out = Boundary{};
    std::sort(w.crossed_rings.begin(), w.crossed_rings.end());
    w.crossed_rings.erase(std::unique(w.crossed_rings.begin(), w.crossed_rings.end()),
                          w.crossed_rings.end());
    for (const std::uint32_t r : w.crossed_rings)
      out.crossed.push_back(r < n_below ? std::array<std::size_t, 2>{0, r}
                                        : std::array<std::size_t, 2>{1, r - n_below});
    return true;
  }
  Graph g;
  Labels lab;
  if (!build_subs(w, g) || !order_vertices(w, g) || !walk_faces(g) || !label_faces(w, g, lab))
    return false;
  out = Boundary{};
  if (!triangulate(w, g, lab, out.tris)) return false;
  out.verts = std::move(w.pt);
  // Each ring's vertices with its split points; each input vertex's place among them.
  out.seq = std::move(g.seq);
  for (std::size_t r = 0; r < rings.size(); ++r) {
    out.pos_base.push_back(static_cast<std::uint32_t>(out.pos.size()));
    const std::uint32_t base = g.seq_begin[r];
    // Place in seq of the ring's point i (i = m: the closing one).
    std::uint32_t i = 0, at = base;
    for (std::uint32_t k = w.vertex_begin[r]; k < w.vertex_begin[r + 1]; ++k) {
      for (; i < w.vertex_slot[k]; ++i) {
        ++at;
        while (w.is_crossing[out.seq[at]] != 0) ++at;
      }
      out.pos.push_back(at);
    }
    const std::uint32_t end =
        r + 1 < rings.size() ? g.seq_begin[r + 1] : static_cast<std::uint32_t>(out.seq.size());
    out.pos.push_back(end - 1);
  }
  return true;
}

}  // namespace printtwin::detail
