// The layered surface of the as-printed mesh (mesh_export.hpp has the model).
//
// Steps, each slab (layer) in parallel: the cross-section (the slab's cells projected) ->
// marching-squares outlines (filled on the left, diagonal neighbours apart) -> simplified
// (Douglas-Peucker) -> one miter vector per vertex, the rounded side's inset checked so no
// edge turns back. Each boundary between slabs in parallel: the top rings of the slab below
// and the bottom rings of the slab above, crossings split exactly on both -> the faces inside
// exactly one of the two regions, up or down, by the planar walk of mesh_export_caps.cpp, or
// where it gives up by one constrained Delaunay triangulation with all rings as constraints.
// Each slab again: its side as strips between rings, the end rings taken from the caps with
// their split points (no T-junctions). Vertices and triangles are joined in slab order (the
// same on any thread count).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Constrained_triangulation_plus_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <numbers>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "core/plain_path.hpp"
#include "deposit/mesh_export_caps.hpp"
#include "deposit/mesh_export_internal.hpp"

namespace printtwin::detail {

/// The round side as a polyline (rings at -90 .. +90 degrees, `steps` per quarter) with its
/// inner rings at inset a r (1 - cos phi) and height b r sin phi: its mean and RMS inset
/// along the profile (lengths weighted), in units of r.
std::array<double, 2> profile_moments(int steps, double a, double b) {
  double len = 0, s1 = 0, s2 = 0, x0 = 0, z0 = 0;
  for (int j = 1; j <= steps; ++j) {
    const double phi = j * (0.5 * std::numbers::pi / steps);
    const double x1 = j == steps ? 1.0 : a * (1.0 - std::cos(phi));
    const double z1 = j == steps ? 1.0 : b * std::sin(phi);
    const double l = std::hypot(x1 - x0, z1 - z0);
    len += l;
    s1 += l * 0.5 * (x0 + x1);
    s2 += l * (x0 * x0 + x0 * x1 + x1 * x1) / 3.0;
    x0 = x1;
    z0 = z1;
  }
  return {s1 / len, std::sqrt(s2 / len)};
}

/// The scale of the inner rings' inset and height (a, b above) for which the polyline's
/// mean and RMS inset equal the round profile's (1 - 2 / pi and sqrt(3/2 - 4 / pi) of r):
/// rings on the circle would make a polygon inside it, the side too deep by 0.033 r on
/// average at two steps. Newton's method on a and b; {1, 1} for one step (no inner ring).
std::array<double, 2> profile_fit(int steps) {
  static const auto table = [] {
    std::array<std::array<double, 2>, 17> t{};
    const double mean = 1.0 - 2.0 / std::numbers::pi, rms = std::sqrt(1.5 - 4.0 / std::numbers::pi);
    for (int n = 0; n < static_cast<int>(t.size()); ++n) {
      double a = 1, b = 1;
      for (int it = 0; n >= 2 && it < 30; ++it) {
        const auto f = profile_moments(n, a, b);
        const double h = 1e-7;
        const auto fa = profile_moments(n, a + h, b), fb = profile_moments(n, a, b + h);
        const double j00 = (fa[0] - f[0]) / h, j01 = (fb[0] - f[0]) / h;
        const double j10 = (fa[1] - f[1]) / h, j11 = (fb[1] - f[1]) / h;
        const double det = j00 * j11 - j01 * j10;
        if (std::abs(det) < 1e-12) break;
        const double r0 = f[0] - mean, r1 = f[1] - rms;
        a -= (j11 * r0 - j01 * r1) / det;
        b -= (j00 * r1 - j10 * r0) / det;
      }
      const auto f = profile_moments(std::max(n, 1), a, b);
      const bool ok = n >= 2 && std::abs(f[0] - mean) < 1e-6 && std::abs(f[1] - rms) < 1e-6 &&
                      a > 0 && b > 0 && b <= 1;
      t[static_cast<std::size_t>(n)] =
          ok ? std::array<double, 2>{a, b} : std::array<double, 2>{1, 1};
    }
    return t;
  }();
  return steps >= 0 && steps < static_cast<int>(table.size())
             ? table[static_cast<std::size_t>(steps)]
             : std::array<double, 2>{1, 1};
}

namespace {

using P2 = Eigen::Vector2d;

/// The caps' triangulation on kernel K: inexact constructions (fast; an intersection may
/// snap to a nearby vertex) or exact ones (the fall-back when the fast one finds a ring that
/// does not bound its region).
template <class K, class Itag>
using CtOf = CGAL::Constrained_triangulation_plus_2<CGAL::Constrained_Delaunay_triangulation_2<
    K,
    CGAL::Triangulation_data_structure_2<
        CGAL::Triangulation_vertex_base_with_info_2<std::uint32_t, K>,
        CGAL::Constrained_triangulation_face_base_2<
            K, CGAL::Triangulation_face_base_with_info_2<unsigned char, K>>>,
    Itag>>;
using CtFast =
    CtOf<CGAL::Exact_predicates_inexact_constructions_kernel, CGAL::Exact_predicates_tag>;
using CtExact =
    CtOf<CGAL::Exact_predicates_exact_constructions_kernel, CGAL::Exact_intersections_tag>;

// ---------------------------------------------------------------- outlines

/// One closed outline of a slab's cross-section, filled on its left.
struct Outline {
  std::vector<P2> pts;    ///< mm
  std::vector<P2> miter;  ///< per vertex: the move of one mm of inset (toward the fill)
  /// Per vertex: the share of the rounded profile kept there (0: a straight side), so no
  /// inset edge turns back and no ring comes near another part of an outline (limit_insets).
  std::vector<double> share;
  double scale = 1;     ///< share of the rounded profile kept by the whole outline (fall-back)
  bool capped = false;  ///< miters limited by the edge lengths (after a crossing)
  std::vector<P2> raw;  ///< the marching-squares outline (simple; outlines never meet)
  int seed_x = 0, seed_y = 0;
};

struct Slab {
  std::vector<Outline> outlines;
  double z_lo = 0, z_hi = 0;
  /// Extra inset of the top and bottom rings (a fiftieth of a cell): where the slab below
  /// and the one above touch along an edge only (diagonal cells), their rings would share
  /// it in opposite directions (four triangles on one edge); this keeps them apart.
  double end_inset = 0;
  double cell_mm = 0;
  std::size_t points = 0;  ///< over its outlines
};

struct Segment {
  std::uint64_t from = 0, to = 0;  // edge-midpoint ids: (y * width + x) * 2 + vertical
  int seed_x = 0, seed_y = 0;      // the filled cell the segment cuts off
};

/// Marching-squares segments of a bit image: in each cell (x, y)..(x + 1, y + 1) of pixel
/// centres, from each "out" crossing (filled corner to empty, counter-clockwise) to the
/// previous "in" crossing, so the fill is on the left and diagonal pixels stay apart.
std::vector<Segment> march(const std::vector<std::uint64_t>& rows, int width, int height) {
  const int words = (width + 63) / 64;
  std::vector<Segment> segs;
  const auto h_id = [&](int x, int y) {
    return static_cast<std::uint64_t>(static_cast<std::int64_t>(y) * width + x) * 2;
  };
  for (int y = 0; y + 1 < height; ++y) {
    const std::uint64_t* ra = &rows[static_cast<std::size_t>(y) * words];
    const std::uint64_t* rb = ra + words;
    for (int w = 0; w < words; ++w) {
      const std::uint64_t a = ra[w], b = rb[w];
      const std::uint64_t a_next = w + 1 < words ? ra[w + 1] : 0,
                          b_next = w + 1 < words ? rb[w + 1] : 0;
      const std::uint64_t a1 = (a >> 1) | (a_next << 63), b1 = (b >> 1) | (b_next << 63);
      std::uint64_t mixed = (a | a1 | b | b1) & ~(a & a1 & b & b1);
      for (; mixed != 0; mixed &= mixed - 1) {
        const int bit = std::countr_zero(mixed);
        const int x = w * 64 + bit;
        if (x + 1 >= width) continue;
        const std::array<bool, 4> c{((a >> bit) & 1U) != 0, ((a1 >> bit) & 1U) != 0,
                                    ((b1 >> bit) & 1U) != 0, ((b >> bit) & 1U) != 0};
        const std::array<std::uint64_t, 4> e{h_id(x, y), h_id(x + 1, y) + 1, h_id(x, y + 1),
                                             h_id(x, y) + 1};
        const std::array<int, 4> cx{x, x + 1, x + 1, x}, cy{y, y, y + 1, y + 1};
        for (int k = 0; k < 4; ++k) {
          if (!c[static_cast<std::size_t>(k)] || c[static_cast<std::size_t>((k + 1) & 3)]) continue;
          for (int d = 1; d < 4; ++d) {
            const auto j = static_cast<std::size_t>((k + 4 - d) & 3);
            if (c[j] || !c[(j + 1) & 3]) continue;
            segs.push_back({e[static_cast<std::size_t>(k)], e[j], cx[static_cast<std::size_t>(k)],
                            cy[static_cast<std::size_t>(k)]});
            break;
          }
        }
      }
    }
  }
  return segs;
}

/// Closes the segments into loops of edge-midpoint ids (each midpoint starts one segment).
std::vector<std::vector<std::uint64_t>> close_loops(std::vector<Segment>& segs,
                                                    std::vector<std::array<int, 2>>& seeds) {
  std::sort(segs.begin(), segs.end(),
            [](const Segment& p, const Segment& q) { return p.from < q.from; });
  std::vector<char> used(segs.size(), 0);
  std::vector<std::vector<std::uint64_t>> loops;
  for (std::size_t s = 0; s < segs.size(); ++s) {
    if (used[s] != 0) continue;
    std::vector<std::uint64_t> loop;
    std::size_t cur = s;
    bool closed = false;
    for (;;) {
      used[cur] = 1;
      loop.push_back(segs[cur].from);
      const auto it =
          std::lower_bound(segs.begin(), segs.end(), segs[cur].to,
                           [](const Segment& p, std::uint64_t id) { return p.from < id; });
      if (it == segs.end() || it->from != segs[cur].to) break;
      cur = static_cast<std::size_t>(it - segs.begin());
      if (cur == s) {
        closed = true;
        break;
      }
      if (used[cur] != 0) break;
    }
    if (!closed || loop.size() < 3) continue;
    loops.push_back(std::move(loop));
    seeds.push_back({segs[s].seed_x, segs[s].seed_y});
  }
  return loops;
}

double segment_distance(const P2& p, const P2& a, const P2& b) {
  const P2 d = b - a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * d)).norm();
}

/// Douglas-Peucker on a closed polyline: the kept points, in order (at least three).
std::vector<P2> simplify_closed(const std::vector<P2>& pts, double tol) {
  const std::size_t n = pts.size();
  if (n <= 4 || tol <= 0) return pts;
  std::size_t far = 0;
  for (std::size_t i = 1; i < n; ++i)
    if ((pts[i] - pts[0]).squaredNorm() > (pts[far] - pts[0]).squaredNorm()) far = i;
  std::vector<char> keep(n, 0);
  keep[0] = keep[far] = 1;
  std::vector<std::array<std::size_t, 2>> stack{{0, far}, {far, n}};
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    const P2& a = pts[i];
    const P2& b = pts[j % n];
    double worst = -1;
    std::size_t at = i;
    for (std::size_t k = i + 1; k < j; ++k) {
      const double d = segment_distance(pts[k], a, b);
      if (d > worst) {
        worst = d;
        at = k;
      }
    }
    if (worst > tol) {
      keep[at] = 1;
      stack.push_back({i, at});
      stack.push_back({at, j});
    }
  }
  std::vector<P2> out;
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i] != 0) out.push_back(pts[i]);
  if (out.size() < 3) return pts;
  return out;
}

/// The miter vectors of a closed outline filled on its left: moving vertex k by d * miter[k]
/// moves both its edges d toward the fill. `r` > 0: a vertex between short edges moves less
/// (at most half its shorter edge at the full inset r), so the zigzags of a traced outline
/// do not fold into swallowtails.
std::vector<P2> miters(const std::vector<P2>& p, double r) {
  const std::size_t n = p.size();
  std::vector<P2> m(n);
  for (std::size_t k = 0; k < n; ++k) {
    const P2 ein = p[k] - p[(k + n - 1) % n], eout = p[(k + 1) % n] - p[k];
    const P2 din = ein.normalized(), dout = eout.normalized();
    const P2 nin(-din.y(), din.x()), nout(-dout.y(), dout.x());
    const double c = 1.0 + nin.dot(nout);
    m[k] = (nin + nout) / std::max(c, 0.5);
    const double reach = m[k].norm() * r, room = 0.5 * std::min(ein.norm(), eout.norm());
    if (r > 0 && reach > room) m[k] *= std::max(room / reach, 0.05);
  }
  return m;
}

/// The inset of outline vertex k at its widest ring (the top or bottom ring): its share of
/// the profile's depth r, plus the end rings' extra inset e.
double end_ring_inset(const Outline& o, std::size_t k, double r, double e) {
  return o.scale * o.share[k] * r + e;
}

/// True when the outline's widest rings (vertex k inset by end_ring_inset) turn no edge back.
bool inset_keeps_edges(const Outline& o, double r, double e) {
  const std::size_t n = o.pts.size();
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t k1 = (k + 1) % n;
    const P2 e0 = o.pts[k1] - o.pts[k];
    const P2 f = (o.pts[k1] + end_ring_inset(o, k1, r, e) * o.miter[k1]) -
                 (o.pts[k] + end_ring_inset(o, k, r, e) * o.miter[k]);
    if (e0.dot(f) <= 0.05 * e0.squaredNorm()) return false;
  }
  return true;
}

/// Shares are multiples of this: the same outline in two slabs gets the same rings (no cap
/// between them) unless a limit differs by a step, never by a few nanometres (a crossing a
/// hair from a vertex, a sliver in the cap).
constexpr double kShareStep = 1.0 / 64;

/// The share of the profile for which a vertex's widest inset is at most `inset`: 0 .. 1, a
/// multiple of kShareStep.
double share_for(double inset, double r, double e) {
  return r > 0 ? std::floor(std::clamp((inset - e) / r, 0.0, 1.0) / kShareStep) * kShareStep : 0.0;
}

/// Limits the shares so that no edge of the widest rings turns back or gets shorter than
/// max(5 %, min(half, kMinEdge)) of its length (no near-duplicate ring vertices): on each
/// edge that would, the insets of the vertices that shorten it are scaled down together,
/// repeated until every edge keeps its direction.
void limit_by_edges(Outline& o, double r, double e, double min_edge) {
  const std::size_t n = o.pts.size();
  std::vector<std::size_t> work(n);  // edges to check; an edge comes back when an end moves in
  std::vector<char> queued(n, 1);
  for (std::size_t k = 0; k < n; ++k) work[k] = k;
  for (std::size_t w = 0; w < work.size(); ++w) {
    const std::size_t k = work[w], k1 = (k + 1) % n;
    queued[k] = 0;
    const P2 d = o.pts[k1] - o.pts[k];
    const double len = d.norm();
    if (len <= 0) continue;
    const P2 u = d / len;
    const double da = end_ring_inset(o, k, r, e), db = end_ring_inset(o, k1, r, e);
    const double ua = da * o.miter[k].dot(u), ub = -db * o.miter[k1].dot(u);  // > 0: shortens
    const double room = len - std::max(0.05 * len, std::min(0.5 * len, min_edge));
    const double shorten = std::max(ua, 0.0) + std::max(ub, 0.0);
    const double lengthen = std::min(ua, 0.0) + std::min(ub, 0.0);
    if (shorten + lengthen <= room || shorten <= 0) continue;
    const double t = std::clamp((room - lengthen) / shorten, 0.0, 1.0) * 0.999;
    for (const auto& [v, part, inset] : {std::tuple{k, ua, da}, std::tuple{k1, ub, db}}) {
      if (part <= 0) continue;
      const double s = share_for(t * inset, r, e);
      if (s >= o.share[v]) continue;
      o.share[v] = s;
      for (const std::size_t edge : {(v + n - 1) % n, v})  // both edges of v again
        if (queued[edge] == 0) {
          queued[edge] = 1;
          work.push_back(edge);
        }
    }
  }
}

/// The edges of a slab's outlines binned on a grid of square cells (every cell an edge passes
/// through), to find the edges near a point without looking at all of them.
class EdgeGrid {
 public:
  EdgeGrid(const std::vector<Outline>& outlines, double cell) : outlines_(outlines), cell_(cell) {
    P2 lo(1e300, 1e300), hi(-1e300, -1e300);
    for (const Outline& o : outlines)
      for (const P2& p : o.pts) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
    lo_ = lo;
    cols_ = static_cast<std::int64_t>((hi.x() - lo.x()) / cell) + 1;
    rows_ = static_cast<std::int64_t>((hi.y() - lo.y()) / cell) + 1;
    start_.assign(static_cast<std::size_t>(cols_ * rows_) + 1, 0);
    // Two sweeps over every edge's cells: count, then fill (edges in order within a cell).
    for (int fill = 0; fill < 2; ++fill) {
      std::uint32_t id = 0;
      for (std::size_t i = 0; i < outlines.size(); ++i) {
        const auto& p = outlines[i].pts;
        for (std::size_t k = 0; k < p.size(); ++k, ++id) {
          if (fill == 0)
            edge_at_.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k)});
          const P2 a = p[k], b = p[(k + 1) % p.size()];
          const int steps = 1 + static_cast<int>(2.0 * (b - a).norm() / cell);
          std::int64_t last = -1;
          for (int t = 0; t <= steps; ++t) {
            const auto c = cell_of(a + (b - a) * (static_cast<double>(t) / steps));
            const std::int64_t at = c[1] * cols_ + c[0];
            if (at == last) continue;
            last = at;
            if (fill == 0)
              ++start_[static_cast<std::size_t>(at) + 1];
            else
              ids_[next_[static_cast<std::size_t>(at)]++] = id;
          }
        }
      }
      if (fill == 0) {
        seen_.assign(edge_at_.size(), 0);
        for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
        ids_.resize(start_.back());
        next_.assign(start_.begin(), start_.end() - 1);
      }
    }
  }

  /// Calls f(outline, edge, t, closest point) once for every edge that may pass within
  /// `radius` of p (an edge is listed in every cell it passes).
  template <class F>
  void near(const P2& p, double radius, F&& f) const {
    const auto c = cell_of(p);
    const auto reach = static_cast<std::int64_t>(std::ceil(radius / cell_));
    ++query_;
    for (std::int64_t cy = c[1] - reach; cy <= c[1] + reach; ++cy)
      for (std::int64_t cx = c[0] - reach; cx <= c[0] + reach; ++cx) {
        if (cx < 0 || cy < 0 || cx >= cols_ || cy >= rows_) continue;
        const auto cell = static_cast<std::size_t>(cy * cols_ + cx);
        for (std::uint32_t at = start_[cell]; at < start_[cell + 1]; ++at) {
          std::uint32_t& seen = seen_[ids_[at]];
          if (seen == query_) continue;
          seen = query_;
          const auto [oi, ek] = edge_at_[ids_[at]];
          const auto& q = outlines_[oi].pts;
          const P2 a = q[ek], d = q[(ek + 1) % q.size()] - a;
          const double len2 = d.squaredNorm();
          const double t = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
          f(static_cast<std::size_t>(oi), static_cast<std::size_t>(ek), t, P2(a + t * d));
        }
      }
  }

 private:
  std::array<std::int64_t, 2> cell_of(const P2& p) const {
    return {static_cast<std::int64_t>((p.x() - lo_.x()) / cell_),
            static_cast<std::int64_t>((p.y() - lo_.y()) / cell_)};
  }
  const std::vector<Outline>& outlines_;
  double cell_;
  P2 lo_ = P2::Zero();
  std::int64_t cols_ = 1, rows_ = 1;
  std::vector<std::uint32_t> start_, next_, ids_;      // per cell c: its edges, ids_[start_[c] ..]
  std::vector<std::array<std::uint32_t, 2>> edge_at_;  // per edge id: outline, first vertex
  // Per edge id: the last query that met it (near() calls f once per edge).
  mutable std::vector<std::uint32_t> seen_;
  mutable std::uint32_t query_ = 0;
};

/// The distance along a closed outline (cumulative edge lengths, n + 1 entries) between
/// vertex k and the point at t along edge ek, the shorter way round.
double along_outline(const std::vector<double>& arc, std::size_t k, std::size_t ek, double t) {
  const double s = arc[ek] + t * (arc[ek + 1] - arc[ek]);
  const double d = std::abs(s - arc[k]);
  return std::min(d, arc.back() - d);
}

std::vector<double> arc_lengths(const Outline& o) {
  const std::size_t n = o.pts.size();
  std::vector<double> arc(n + 1, 0.0);
  for (std::size_t k = 0; k < n; ++k) arc[k + 1] = arc[k] + (o.pts[(k + 1) % n] - o.pts[k]).norm();
  return arc;
}

/// True when edge ek of outline oi (its point x at t nearest vertex k of outline i) is a
/// feature that vertex's inset must stay clear of: in front of the vertex (along its miter),
/// the vertex on the edge's fill side, and not the vertex's own neighbourhood: another
/// outline, or a stretch of its own outline that faces it (the two fill sides turned toward
/// each other: the flanks of a neck or a fin) or lies more than twice as far along the
/// outline as across (a finely cut curve's next edges lie beside the vertex, not across).
bool faces(const std::vector<Outline>& outlines, std::size_t i, std::size_t k,
           const std::vector<double>& arc, std::size_t oi, std::size_t ek, double t, const P2& x) {
  const Outline& o = outlines[i];
  const auto& q = outlines[oi].pts;
  const std::size_t n = o.pts.size(), ek1 = (ek + 1) % q.size();
  if (oi == i && (ek == k || ek1 == k)) return false;
  const P2 d = q[ek1] - q[ek], to = x - o.pts[k];
  const P2 normal(-d.y(), d.x());  // toward the edge's fill (not unit)
  if (to.dot(o.miter[k]) < 0 || to.dot(normal) > 0) return false;
  if (oi != i) return true;
  return o.miter[k].dot(normal) < 0 || along_outline(arc, k, ek, t) >= 2.0 * to.norm() || n < 4;
}

/// A share of the widest inset reaches at most this much of the distance to the nearest
/// facing edge, so two rings facing each other keep a tenth of their gap.
constexpr double kReach = 0.45;

/// Limits each vertex's share of the profile by the local feature size: its widest inset
/// moves it at most kReach of its distance to the nearest edge of the slab's outlines that
/// lies on its fill side and is not its own neighbourhood (another outline, or a stretch of
/// its own outline more than twice that distance away along it: a neck, a thin wall).
void limit_vertices_by_feature_size(std::vector<Outline>& outlines, const EdgeGrid& grid, double r,
                                    double e) {
  for (std::size_t i = 0; i < outlines.size(); ++i) {
    Outline& o = outlines[i];
    const std::vector<double> arc = arc_lengths(o);
    for (std::size_t k = 0; k < o.pts.size(); ++k) {
      const double m = o.miter[k].norm();
      if (m <= 0) continue;
      double nearest = (r + e) * m / kReach;  // only nearer edges limit the inset
      grid.near(o.pts[k], nearest, [&](std::size_t oi, std::size_t ek, double t, const P2& x) {
        const double dist = (x - o.pts[k]).norm();
        if (dist >= nearest || !faces(outlines, i, k, arc, oi, ek, t, x)) return;
        nearest = dist;
      });
      o.share[k] = std::min(o.share[k], share_for(kReach * nearest / m, r, e));
    }
  }
}

/// Splits the edges whose inset would come nearer than kReach of the distance to a vertex
/// facing them (a long straight edge beside a pinhole or a neck: its ends are far from the
/// feature, its middle is not), at the point nearest that vertex, so the ring can be
/// limited there alone. `grid`: the outlines' edges. True when some edge was split.
bool split_edges_near_features(std::vector<Outline>& outlines, const EdgeGrid& grid, double r,
                               double e, double min_gap) {
  std::vector<std::tuple<std::size_t, std::size_t, double>> splits;  // outline, edge, t
  for (std::size_t i = 0; i < outlines.size(); ++i) {
    const Outline& o = outlines[i];
    const std::vector<double> arc = arc_lengths(o);
    for (std::size_t k = 0; k < o.pts.size(); ++k)
      grid.near(
          o.pts[k], (r + e) / kReach, [&](std::size_t oi, std::size_t ek, double t, const P2& x) {
            const Outline& q = outlines[oi];
            const std::size_t ek1 = (ek + 1) % q.pts.size();
            const P2 d = q.pts[ek1] - q.pts[ek];
            const double len = d.norm(), dist = (o.pts[k] - x).norm();
            if (len <= 0 || t * len < min_gap || (1 - t) * len < min_gap) return;  // near an end
            const P2 normal(-d.y() / len, d.x() / len);  // toward the edge's fill
            if (dist >= (r + e) / kReach || !faces(outlines, i, k, arc, oi, ek, t, x)) return;
            const double inset = (1 - t) * end_ring_inset(q, ek, r, e) * q.miter[ek].dot(normal) +
                                 t * end_ring_inset(q, ek1, r, e) * q.miter[ek1].dot(normal);
            if (inset > kReach * dist) splits.emplace_back(oi, ek, t);
          });
  }
  if (splits.empty()) return false;
  std::sort(splits.begin(), splits.end());
  std::size_t at = 0;
  for (std::size_t i = 0; i < outlines.size(); ++i) {
    Outline& o = outlines[i];
    std::vector<P2> pts;
    for (std::size_t k = 0; k < o.pts.size(); ++k) {
      pts.push_back(o.pts[k]);
      const P2 a = o.pts[k], b = o.pts[(k + 1) % o.pts.size()];
      for (double last = 0;
           at < splits.size() && std::get<0>(splits[at]) == i && std::get<1>(splits[at]) == k;
           ++at) {
        const double t = std::get<2>(splits[at]);
        if ((t - last) * (b - a).norm() < min_gap) continue;  // one split per gap
        pts.push_back(a + t * (b - a));
        last = t;
      }
    }
    if (pts.size() == o.pts.size()) continue;
    o.pts = std::move(pts);
    o.miter = miters(o.pts, 0);
  }
  return true;
}

/// Drops the rounded profile (share 0) at the ends of every two edges of the slab's rings
/// that cross or touch, at each inset level (`levels`: per level the share of the
/// profile's depth r and the extra inset: the widest rings, the inner ones). The rings' edges
/// are binned on a grid of `cell` squares and the pairs within each cell tested. True when
/// some share went down (the caller repeats until none does).
bool reduce_crossing_shares(std::vector<Outline>& outlines, double r,
                            const std::vector<std::array<double, 2>>& levels, double cell) {
  struct Seg {
    P2 a, b;
    std::uint32_t outline, k;
  };
  std::vector<Seg> segs;
  std::vector<std::uint64_t> bins;
  std::vector<std::array<std::uint32_t, 2>> hit;  // outline, vertex
  const auto orient = [](const P2& a, const P2& b, const P2& c) {
    return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  };
  for (const auto& level : levels) {
    const double depth = level[0], extra = level[1];  // named: the lambda below reads them
    segs.clear();
    bins.clear();
    P2 lo(1e300, 1e300);
    for (std::size_t i = 0; i < outlines.size(); ++i) {
      const Outline& o = outlines[i];
      const std::size_t n = o.pts.size();
      const auto at = [&](std::size_t k) {
        return P2(o.pts[k] + (o.scale * o.share[k] * r * depth + extra) * o.miter[k]);
      };
      for (std::size_t k = 0; k < n; ++k) {
        segs.push_back(
            {at(k), at((k + 1) % n), static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k)});
        lo = lo.cwiseMin(segs.back().a);
      }
    }
    for (std::size_t id = 0; id < segs.size(); ++id) {
      const P2 a = segs[id].a - lo, b = segs[id].b - lo;
      const int steps = 1 + static_cast<int>(2.0 * (b - a).norm() / cell);
      for (int t = 0; t < steps; ++t) {  // each piece's box: the cells it can pass through
        const P2 p = a + (b - a) * (static_cast<double>(t) / steps),
                 q = a + (b - a) * (static_cast<double>(t + 1) / steps);
        const auto x0 = static_cast<std::uint64_t>(std::min(p.x(), q.x()) / cell),
                   x1 = static_cast<std::uint64_t>(std::max(p.x(), q.x()) / cell),
                   y0 = static_cast<std::uint64_t>(std::min(p.y(), q.y()) / cell),
                   y1 = static_cast<std::uint64_t>(std::max(p.y(), q.y()) / cell);
        for (std::uint64_t y = y0; y <= y1; ++y)
          for (std::uint64_t x = x0; x <= x1; ++x)
            bins.push_back((((y << 16) | (x & 0xFFFFU)) << 32) | id);
      }
    }
    std::sort(bins.begin(), bins.end());
    bins.erase(std::unique(bins.begin(), bins.end()), bins.end());
    for (std::size_t g = 0; g < bins.size();) {
      std::size_t end = g;
      while (end < bins.size() && (bins[end] >> 32) == (bins[g] >> 32)) ++end;
      for (std::size_t u = g; u < end; ++u)
        for (std::size_t v = u + 1; v < end; ++v) {
          const Seg& s = segs[static_cast<std::uint32_t>(bins[u])];
          const Seg& t = segs[static_cast<std::uint32_t>(bins[v])];
          const std::size_t n = outlines[s.outline].pts.size();
          if (s.outline == t.outline && (t.k == (s.k + 1) % n || s.k == (t.k + 1) % n)) continue;
          const double o1 = orient(s.a, s.b, t.a), o2 = orient(s.a, s.b, t.b);
          if (o1 * o2 > 0 || orient(t.a, t.b, s.a) * orient(t.a, t.b, s.b) > 0) continue;
          if (o1 == 0 && o2 == 0) {  // on one line (an axis-parallel wall): only if they overlap
            const P2 dir = s.b - s.a;
            const double t0 = (t.a - s.a).dot(dir), t1 = (t.b - s.a).dot(dir);
            if (std::max(t0, t1) < 0 || std::min(t0, t1) > dir.squaredNorm()) continue;
          }
          for (const Seg* e : {&s, &t}) {
            const auto m = static_cast<std::uint32_t>(outlines[e->outline].pts.size());
            hit.push_back({e->outline, e->k});
            hit.push_back({e->outline, (e->k + 1) % m});
          }
        }
      g = end;
    }
  }
  bool changed = false;
  for (const auto& [i, k] : hit) {
    changed = changed || outlines[i].share[k] > 0;
    outlines[i].share[k] = 0;
  }
  return changed;
}

/// The shares of the slab's outlines: limited by the local feature size (after splitting the
/// edges that pass a feature), then so that no edge turns back (limit_by_edges).
void limit_insets(std::vector<Outline>& outlines, double r, double e, double cell_mm, int steps) {
  // Grid cells as wide as a straight edge's widest inset could matter (a corner's reaches a
  // few cells).
  const double reach = (r + e) / kReach;
  if (outlines.empty() || reach <= 0) return;
  bool split = false;
  {
    const EdgeGrid grid(outlines, reach);  // the split reads the outlines as the limit does
    limit_vertices_by_feature_size(outlines, grid, r, e);
    split = split_edges_near_features(outlines, grid, r, e, 0.5 * cell_mm);
  }
  if (split) {
    for (Outline& o : outlines) o.share.assign(o.pts.size(), 1.0);
    limit_vertices_by_feature_size(outlines, EdgeGrid(outlines, reach), r, e);
  }
  std::vector<std::array<double, 2>> levels{{1.0, e}};  // the widest rings, then inner ones
  for (int j = 1; j < steps; ++j)
    levels.push_back(
        {profile_fit(steps)[0] * (1.0 - std::cos(j * 0.5 * std::numbers::pi / steps)), 0.0});
  for (int round = 0; round < 16; ++round) {
    for (Outline& o : outlines) limit_by_edges(o, r, e, 0.1 * cell_mm);
    if (!reduce_crossing_shares(outlines, r, levels, reach)) break;
  }
}

/// The slab's outlines: its cells projected, marched, simplified, with miters and the
/// share of the rounded profile each can take.
Slab trace_slab(const LayerSlabs& in, int s, double tol, int steps,
                std::vector<std::uint64_t>& rows) {
  Slab slab;
  const int z0 = in.bounds[static_cast<std::size_t>(s)],
            z1 = in.bounds[static_cast<std::size_t>(s) + 1];
  slab.z_lo = in.base_mm.z() + in.cell_mm * z0;
  slab.z_hi = in.base_mm.z() + in.cell_mm * z1;
  const double r = 0.5 * (slab.z_hi - slab.z_lo);
  slab.end_inset = 0.02 * in.cell_mm;
  slab.cell_mm = in.cell_mm;
  rows.assign(static_cast<std::size_t>(in.height) * static_cast<std::size_t>((in.width + 63) / 64),
              0);
  in.project(z0, z1, rows);
  std::vector<Segment> segs = march(rows, in.width, in.height);
  std::vector<std::array<int, 2>> seeds;
  const auto loops = close_loops(segs, seeds);
  const double half = 0.5 * in.cell_mm;
  for (std::size_t l = 0; l < loops.size(); ++l) {
    std::vector<P2> pts;
    pts.reserve(loops[l].size());
    for (const std::uint64_t id : loops[l]) {
      const std::int64_t cell = static_cast<std::int64_t>(id >> 1);
      const std::int64_t row = cell / in.width;  // the cell's y
      const auto x = static_cast<double>(cell % in.width), y = static_cast<double>(row);
      const bool vertical = (id & 1U) != 0;
      pts.emplace_back(in.base_mm.x() + half * (2 * x + (vertical ? 1 : 2)),
                       in.base_mm.y() + half * (2 * y + (vertical ? 2 : 1)));
    }
    Outline o;
    o.pts = simplify_closed(pts, tol);
    o.raw = std::move(pts);
    o.miter = miters(o.pts, 0);
    o.share.assign(o.pts.size(), 1.0);
    o.seed_x = seeds[l][0];
    o.seed_y = seeds[l][1];
    slab.points += o.pts.size();
    slab.outlines.push_back(std::move(o));
  }
  limit_insets(slab.outlines, r, slab.end_inset, in.cell_mm, steps);
  slab.points = 0;
  for (Outline& o : slab.outlines) {
    slab.points += o.pts.size();
    o.scale = 0;
    for (const double share : {1.0, 0.5, 0.25})
      if (o.scale = share; inset_keeps_edges(o, r, slab.end_inset)) break;
    if (!inset_keeps_edges(o, r, slab.end_inset)) o.scale = 0;
  }
  return slab;
}

// ---------------------------------------------------------------- rings

/// Ring j (0 .. 2 steps) of a slab's side: the bead's round side at angle phi_j from
/// -90 to +90 degrees, inset r (1 - cos phi) toward the fill at height mid + r sin phi; the
/// inner rings scaled by profile_fit so the side is as deep on average as the round one.
double ring_inset(const Slab& s, const Outline& o, std::size_t k, int j, int steps) {
  const double r = 0.5 * (s.z_hi - s.z_lo);
  const double phi = (j - steps) * (0.5 * std::numbers::pi / steps);
  const bool end = j == 0 || j == 2 * steps;
  const double a = end ? 1.0 : profile_fit(steps)[0];
  return o.scale * o.share[k] * r * a * (1.0 - std::cos(phi)) + (end ? s.end_inset : 0.0);
}
double ring_z(const Slab& s, int j, int steps) {
  if (j == 0) return s.z_lo;
  if (j == 2 * steps) return s.z_hi;
  const double r = 0.5 * (s.z_hi - s.z_lo);
  return s.z_lo + r +
         r * profile_fit(steps)[1] * std::sin((j - steps) * (0.5 * std::numbers::pi / steps));
}
P2 ring_point(const Slab& s, const Outline& o, std::size_t k, int j, int steps) {
  return o.pts[k] + ring_inset(s, o, k, j, steps) * o.miter[k];
}

// ---------------------------------------------------------------- caps

/// Upper ring vertices this close to a lower ring vertex (in cells; 5 um at 0.05 mm) are
/// snapped onto it: well under the outline tolerance, above the rounding of the rings.
constexpr double kCapSnapCells = 0.1;

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

/// Vertices that coincide once written as float (as every mesh format stores them) become
/// one (a split point a hair from a ring's vertex); triangles that lose an edge go.
void weld_as_float(Boundary& b) {
  std::vector<std::uint32_t> rep(b.verts.size());
  std::unordered_map<std::uint64_t, std::uint32_t> at;
  at.reserve(b.verts.size());
  std::vector<P2> kept;
  kept.reserve(b.verts.size());
  for (std::size_t i = 0; i < b.verts.size(); ++i) {
    const std::uint64_t key = (static_cast<std::uint64_t>(
                                   std::bit_cast<std::uint32_t>(static_cast<float>(b.verts[i].x())))
                               << 32) |
                              std::bit_cast<std::uint32_t>(static_cast<float>(b.verts[i].y()));
    const auto [it, fresh] = at.try_emplace(key, static_cast<std::uint32_t>(kept.size()));
    if (fresh) kept.push_back(b.verts[i]);
    rep[i] = it->second;
  }
  if (kept.size() == b.verts.size()) return;
  b.verts = std::move(kept);
  for (std::uint32_t& v : b.seq) v = rep[v];
  std::size_t n = 0;
  for (const auto& t : b.tris) {
    const std::array<std::uint32_t, 3> r{rep[t[0]], rep[t[1]], rep[t[2]]};
    if (r[0] != r[1] && r[1] != r[2] && r[0] != r[2]) b.tris[n++] = r;
  }
  b.tris.resize(n);
}

/// Marks each face with the regions (bit 0: below's top, bit 1: above's bottom) it lies in,
/// crossing the rings' sub-segments from the infinite face.
template <class Ct>
void mark_faces(Ct& ct, const std::unordered_map<std::uint64_t, unsigned char>& toggles) {
  for (auto f : ct.all_face_handles()) f->info() = 0;
  std::vector<typename Ct::Face_handle> stack{ct.infinite_face()};
  ct.infinite_face()->info() = 0x80;
  while (!stack.empty()) {
    const typename Ct::Face_handle f = stack.back();
    stack.pop_back();
    const unsigned char state = f->info() & 3U;
    for (int i = 0; i < 3; ++i) {
      const typename Ct::Face_handle g = f->neighbor(i);
      if ((g->info() & 0x80U) != 0) continue;
      const auto va = f->vertex(Ct::cw(i)), vb = f->vertex(Ct::ccw(i));
      unsigned char t = 0;
      if (!ct.is_infinite(va) && !ct.is_infinite(vb))
        if (const auto it = toggles.find(edge_key(va->info(), vb->info())); it != toggles.end())
          t = it->second;
      g->info() = static_cast<unsigned char>(0x80U | (state ^ t));
      stack.push_back(g);
    }
  }
}

/// The cap on triangulation Ct (see cap) of `rings` (the first `n_below` are the lower
/// slab's top rings, region bit 1; the others the upper slab's bottom rings, bit 2), the
/// constraints inserted in ring order.
template <class Ct>
Boundary cap_on(const std::vector<CapRing>& in, std::size_t n_below, const CapExtras& extras) {
  using Point = typename Ct::Point;
  Boundary b;
  Ct ct;
  struct Ring {
    std::vector<Point> pts;
    std::vector<char> vertex;  // 0: a point from `extras`
    typename Ct::Constraint_id cid;
    unsigned char side;
  };
  std::vector<Ring> rings(in.size());
  for (std::size_t ri = 0; ri < in.size(); ++ri) {
    rings[ri].side = ri < n_below ? 1 : 2;
    rings[ri].pts.reserve(in[ri].size());
    auto extra = extras.empty() ? nullptr : extras[ri].data();
    const auto extra_end = extras.empty() ? nullptr : extra + extras[ri].size();
    for (std::size_t k = 0; k < in[ri].size(); ++k) {
      rings[ri].pts.emplace_back(in[ri][k].x(), in[ri][k].y());
      rings[ri].vertex.push_back(1);
      for (; extra != extra_end && extra->after == k; ++extra) {
        rings[ri].pts.emplace_back(extra->p.x(), extra->p.y());
        rings[ri].vertex.push_back(0);
      }
    }
  }
  for (Ring& r : rings) r.cid = ct.insert_constraint(r.pts.begin(), r.pts.end(), true);
  std::uint32_t n = 0;
  for (auto v : ct.finite_vertex_handles()) {
    v->info() = n++;
    b.verts.emplace_back(CGAL::to_double(v->point().x()), CGAL::to_double(v->point().y()));
  }
  std::unordered_map<std::uint64_t, unsigned char> toggles;
  for (const Ring& r : rings) {
    b.pos_base.push_back(static_cast<std::uint32_t>(b.pos.size()));
    const auto first = static_cast<std::uint32_t>(b.seq.size());
    std::size_t k = 0;
    if (r.cid == typename Ct::Constraint_id(nullptr)) {  // every point one (snapped)
      b.ok = false;
      return b;
    }
    for (auto it = ct.vertices_in_constraint_begin(r.cid);
         it != ct.vertices_in_constraint_end(r.cid); ++it) {
      const auto at = static_cast<std::uint32_t>(b.seq.size());
      // Ring points snapped onto one vertex share its place (a side edge of no length).
      for (; k < r.pts.size() && (*it)->point() == r.pts[k]; ++k)
        if (r.vertex[k] != 0) b.pos.push_back(at);
      if (at > first) {
        const std::uint32_t u = b.seq.back(), v = (*it)->info();
        if (u != v) toggles[edge_key(u, v)] ^= r.side;
      }
      b.seq.push_back((*it)->info());
    }
    // Closed: the first vertex again at the end.
    if (k != r.pts.size() || b.seq.size() - first < 2 || b.seq.back() != b.seq[first]) {
      b.ok = false;
      return b;
    }
    b.pos.push_back(static_cast<std::uint32_t>(b.seq.size() - 1));
  }
  mark_faces(ct, toggles);
  std::vector<typename Ct::Vertex_handle> handle(n);
  for (auto v : ct.finite_vertex_handles()) handle[v->info()] = v;
  for (std::size_t ri = 0; ri < rings.size(); ++ri) {
    const std::size_t begin = b.pos[b.pos_base[ri]];
    const std::size_t end = b.pos[b.pos_base[ri] + in[ri].size()];
    for (std::size_t i = begin; i < end; ++i) {
      typename Ct::Face_handle f;
      int opposite = 0;
      if (b.seq[i] == b.seq[i + 1] ||
          !ct.is_edge(handle[b.seq[i]], handle[b.seq[i + 1]], f, opposite))
        continue;
      const bool left = f->vertex(Ct::ccw(opposite)) == handle[b.seq[i]];
      const typename Ct::Face_handle inner = left ? f : f->neighbor(opposite);
      if ((inner->info() & rings[ri].side) == 0) {
        b.crossed.push_back(ri < n_below ? std::array<std::size_t, 2>{0, ri}
                                         : std::array<std::size_t, 2>{1, ri - n_below});
        break;
      }
    }
  }
  if (!b.crossed.empty()) return b;
  for (auto f : ct.finite_face_handles()) {
    const unsigned s = f->info() & 3U;
    if (s != 1 && s != 2) continue;
    const std::uint32_t a = f->vertex(0)->info(), c = f->vertex(1)->info(),
                        d = f->vertex(2)->info();
    b.tris.push_back(s == 1 ? std::array{a, c, d} : std::array{a, d, c});
  }
  weld_as_float(b);
  return b;
}

/// Ring vertices or edges (ring, index) by grid cell key, filled once and then read: a hash
/// table in flat arrays (buckets of entries in place, no allocation per entry). The order of
/// a cell's entries is free: every reader keeps the nearest, ties to the smallest item.
class CellIndex {
 public:
  using Item = std::array<std::uint32_t, 2>;
  void add(std::uint64_t key, std::uint32_t ring, std::uint32_t k) {
    entries_.push_back({key, {ring, k}});
  }
  /// Sorts the entries into their buckets; no add after it.
  void seal() {
    bits_ = std::max(1, static_cast<int>(std::bit_width(entries_.size())));
    start_.assign((std::size_t{1} << bits_) + 1, 0);
    for (const Entry& e : entries_) ++start_[bucket(e.key) + 1];
    for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
    std::vector<std::uint32_t> next(start_.begin(), start_.end() - 1);
    sorted_.resize(entries_.size());
    for (const Entry& e : entries_) sorted_[next[bucket(e.key)]++] = e;
    entries_ = {};
  }
  /// Calls f(item) for each entry of the cell `key`.
  template <class F>
  void each(std::uint64_t key, F&& f) const {
    const std::size_t b = bucket(key);
    for (std::uint32_t i = start_[b]; i < start_[b + 1]; ++i)
      if (sorted_[i].key == key) f(sorted_[i].item);
  }

 private:
  struct Entry {
    std::uint64_t key;
    Item item;
  };
  std::size_t bucket(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> (64 - bits_));
  }
  std::vector<Entry> entries_, sorted_;
  std::vector<std::uint32_t> start_;
  int bits_ = 1;
};

/// Per vertex of a set of rings: its index in one flat array (ring's first + k).
std::vector<std::size_t> ring_offsets(const std::vector<CapRing>& rings) {
  std::vector<std::size_t> first(rings.size() + 1, 0);
  for (std::size_t ri = 0; ri < rings.size(); ++ri) first[ri + 1] = first[ri] + rings[ri].size();
  return first;
}

/// The tangent of a closed ring at vertex k (previous to next vertex).
P2 ring_tangent(const CapRing& r, std::size_t k) {
  const std::size_t n = r.size();
  return r[(k + 1) % n] - r[(k + n - 1) % n];
}

/// Moves each upper ring vertex within `eps` of a lower ring vertex onto it (the nearest),
/// when both rings run the same way there (rings that meet head-on, as diagonal neighbours'
/// rings do, stay apart) and no other upper vertex took it, except the one just before on
/// the same ring. Rings a few micrometres apart then share vertices instead of crossing
/// near them, which leaves sliver triangles. A ring that would keep fewer than three points
/// is left as it is.
void snap_upper_to_lower(std::vector<CapRing>& rings, std::size_t n_below, double eps) {
  if (n_below == 0 || n_below == rings.size() || eps <= 0) return;
  const auto cell_of = [&](double v) { return static_cast<std::int64_t>(std::floor(v / eps)); };
  const auto key = [](std::int64_t x, std::int64_t y) {
    return (static_cast<std::uint64_t>(x) << 32) ^ static_cast<std::uint64_t>(y & 0xffffffff);
  };
  CellIndex grid;
  for (std::size_t ri = 0; ri < n_below; ++ri)
    for (std::size_t k = 0; k < rings[ri].size(); ++k)
      grid.add(key(cell_of(rings[ri][k].x()), cell_of(rings[ri][k].y())),
               static_cast<std::uint32_t>(ri), static_cast<std::uint32_t>(k));
  grid.seal();
  // Per lower vertex: the upper ring and vertex that took it.
  constexpr std::array<std::size_t, 2> kFree{~std::size_t{0}, ~std::size_t{0}};
  const std::vector<std::size_t> first = ring_offsets(rings);
  std::vector<std::array<std::size_t, 2>> taken(first[n_below], kFree);
  for (std::size_t ri = n_below; ri < rings.size(); ++ri) {
    CapRing moved = rings[ri];
    std::vector<std::size_t> took;
    for (std::size_t k = 0; k < moved.size(); ++k) {
      const P2 p = rings[ri][k];
      const P2 tangent = ring_tangent(rings[ri], k);
      double best = eps * eps;
      const CellIndex::Item* hit = nullptr;
      const std::int64_t cx = cell_of(p.x()), cy = cell_of(p.y());
      for (std::int64_t dx = -1; dx <= 1; ++dx)
        for (std::int64_t dy = -1; dy <= 1; ++dy)
          grid.each(key(cx + dx, cy + dy), [&](const CellIndex::Item& item) {
            const CapRing& lower = rings[item[0]];
            const double d2 = (lower[item[1]] - p).squaredNorm();
            const bool closer = d2 < best || (d2 == best && hit != nullptr && item < *hit);
            if (closer && ring_tangent(lower, item[1]).dot(tangent) > 0) {
              best = d2;
              hit = &item;
            }
          });
      if (hit == nullptr) continue;
      const std::size_t id = first[(*hit)[0]] + (*hit)[1];
      std::array<std::size_t, 2>& at = taken[id];
      if (at != kFree && !(at[0] == ri && at[1] + 1 == k)) continue;
      at = {ri, k};
      moved[k] = rings[(*hit)[0]][(*hit)[1]];
      took.push_back(id);
    }
    std::size_t distinct = 0;
    for (std::size_t k = 0; k < moved.size(); ++k)
      distinct += moved[k] != moved[(k + 1) % moved.size()] ? 1 : 0;
    if (distinct >= 3)
      rings[ri] = std::move(moved);
    else
      for (const std::size_t id : took) taken[id] = kFree;
  }
}

/// Puts each vertex of one set of rings that lies within `eps` of an edge of the other set
/// (not within `eps` of its ends, both rings running the same way) on that edge as a split
/// point, for both sets: the two rings then share the point instead of crossing next to it.
/// The shared points keep one order along both rings: where two rings cross at a steep angle
/// within `eps` of each other (short ring edges: per-vertex insets), a vertex u of one ring
/// lies just after vertex l on l's ring and l just after u on u's ring; taking both would
/// make the rings share the edge u-l head-on (four triangles on it). Then only the first
/// (the upper vertex onto the lower edge) is taken; likewise, of two vertices of one ring put
/// on one edge in the opposite order, only the first.
CapExtras snap_to_edges(const std::vector<CapRing>& rings, std::size_t n_below, double eps) {
  CapExtras extras(rings.size());
  if (n_below == 0 || n_below == rings.size() || eps <= 0) return extras;
  constexpr double kCell = 0.25;  // mm: the edge grid
  const auto cell_of = [](double v) { return static_cast<std::int64_t>(std::floor(v / kCell)); };
  const auto key = [](std::int64_t x, std::int64_t y) {
    return (static_cast<std::uint64_t>(x) << 32) ^ static_cast<std::uint64_t>(y & 0xffffffff);
  };
  const auto id = [](std::size_t ring, std::size_t k) {
    return (static_cast<std::uint64_t>(ring) << 32) | static_cast<std::uint64_t>(k);
  };
  // Per vertex (ring, k): the edge (ring, first vertex) it was put on (kNone: none).
  constexpr std::uint64_t kNone = ~std::uint64_t{0};
  const std::vector<std::size_t> first = ring_offsets(rings);
  std::vector<std::uint64_t> put_on(first.back(), kNone);
  for (int pass = 0; pass < 2; ++pass) {  // upper vertices onto lower edges, then the reverse
    const std::size_t t0 = pass == 0 ? 0 : n_below, t1 = pass == 0 ? n_below : rings.size();
    const std::size_t s0 = pass == 0 ? n_below : 0, s1 = pass == 0 ? rings.size() : n_below;
    CellIndex grid;
    for (std::size_t ri = t0; ri < t1; ++ri)
      for (std::size_t k = 0; k < rings[ri].size(); ++k) {
        const P2 a = rings[ri][k], b = rings[ri][(k + 1) % rings[ri].size()];
        for (std::int64_t x = cell_of(std::min(a.x(), b.x()) - eps);
             x <= cell_of(std::max(a.x(), b.x()) + eps); ++x)
          for (std::int64_t y = cell_of(std::min(a.y(), b.y()) - eps);
               y <= cell_of(std::max(a.y(), b.y()) + eps); ++y)
            grid.add(key(x, y), static_cast<std::uint32_t>(ri), static_cast<std::uint32_t>(k));
      }
    grid.seal();
    for (std::size_t si = s0; si < s1; ++si) {
      const std::size_t n = rings[si].size();
      for (std::size_t k = 0; k < n; ++k) {
        const P2 p = rings[si][k];
        const P2 tangent = ring_tangent(rings[si], k);
        double best = eps;
        std::array<std::uint32_t, 2> hit{~0U, ~0U};
        double hit_t = 0;
        grid.each(key(cell_of(p.x()), cell_of(p.y())), [&](const CellIndex::Item& item) {
          const CapRing& r = rings[item[0]];
          const std::size_t m = item[1], m1 = (m + 1) % r.size();
          const P2& a = r[m];
          const P2& b = r[m1];
          const P2 d = b - a;
          const double len = d.norm();
          if (len <= 2 * eps || d.dot(tangent) <= 0) return;
          const double t = (p - a).dot(d) / (len * len);
          if (t * len <= eps || (1 - t) * len <= eps) return;  // near an end: not an edge
          // The edge's start already on this ring's edge from p, or its end on the edge
          // into p: the two would share u-l head-on.
          if (put_on[first[item[0]] + m] == id(si, k) ||
              put_on[first[item[0]] + m1] == id(si, (k + n - 1) % n))
            return;
          const double dist = std::abs(d.x() * (p.y() - a.y()) - d.y() * (p.x() - a.x())) / len;
          if (dist < best || (dist == best && item < hit)) {
            best = dist;
            hit = item;
            hit_t = t;
          }
        });
        if (hit[0] == ~0U) continue;
        extras[hit[0]].push_back(
            {hit[1], hit_t, p, static_cast<std::uint32_t>(si), static_cast<std::uint32_t>(k)});
        put_on[first[si] + k] = id(hit[0], hit[1]);
      }
    }
  }
  for (auto& e : extras) {
    std::sort(e.begin(), e.end(), [](const CapExtra& a, const CapExtra& b) {
      return a.after != b.after ? a.after < b.after : a.t < b.t;
    });
    // Of the points of one ring on one edge, those in that ring's order (the first kept).
    std::size_t kept = 0;
    for (std::size_t i = 0; i < e.size(); ++i) {
      bool back = false;
      for (std::size_t j = 0; j < kept && !back; ++j) {
        const CapExtra& q = e[kept - 1 - j];
        if (q.after != e[i].after) break;
        if (q.ring != e[i].ring) continue;
        const auto nr = static_cast<std::uint32_t>(rings[q.ring].size());
        back = (q.vertex + nr - e[i].vertex) % nr < (e[i].vertex + nr - q.vertex) % nr;
      }
      if (!back) e[kept++] = e[i];
    }
    e.resize(kept);
  }
  return extras;
}

/// The cap of `rings` (the first `n_below` the lower slab's top rings): the fast
/// triangulation, or the exact one where the fast one finds a ring that does not bound its
/// region (a real crossing, or an intersection of nearly parallel edges rounded aside).
Boundary cap_of_rings(const std::vector<CapRing>& rings, std::size_t n_below, double eps,
                      bool exact) {
  const CapExtras extras = snap_to_edges(rings, n_below, eps);
  if (exact) return cap_on<CtExact>(rings, n_below, extras);
  if (!plain_path("caps")) {
    Boundary b;
    if (cap_by_walk(rings, n_below, extras, b)) {
      if (b.crossed.empty()) weld_as_float(b);
      return b;
    }
  }
  Boundary b = cap_on<CtFast>(rings, n_below, extras);
  if (!b.ok || !b.crossed.empty()) b = cap_on<CtExact>(rings, n_below, extras);
  return b;
}

/// The cap between `below`'s top rings and `above`'s bottom rings (either may be null),
/// upper vertices within a tenth of a cell of a lower one snapped onto it.
Boundary cap(const Slab* below, const Slab* above, int steps, bool exact) {
  std::vector<CapRing> rings;
  const auto add = [&](const Slab* s, int j) {
    if (s == nullptr) return;
    for (const Outline& o : s->outlines) {
      CapRing& r = rings.emplace_back();
      r.reserve(o.pts.size());
      for (std::size_t k = 0; k < o.pts.size(); ++k) r.push_back(ring_point(*s, o, k, j, steps));
    }
  };
  add(below, 2 * steps);
  add(above, 0);
  const std::size_t n_below = below != nullptr ? below->outlines.size() : 0;
  const double eps = kCapSnapCells * (below != nullptr ? below->cell_mm : above->cell_mm);
  snap_upper_to_lower(rings, n_below, eps);
  return cap_of_rings(rings, n_below, eps, exact);
}

// ---------------------------------------------------------------- sides

/// Triangles between two chains along one outline edge (lower and upper ring), advancing on
/// the chain whose next point comes first along the edge.
void zip(const std::vector<std::uint32_t>& lo, const std::vector<std::uint32_t>& up,
         const std::vector<Vec3>& v, std::vector<std::array<std::uint32_t, 3>>& out) {
  const auto params = [&](const std::vector<std::uint32_t>& c, std::vector<double>& t) {
    t.resize(c.size());
    const P2 a = v[c.front()].head<2>(), b = v[c.back()].head<2>();
    const P2 d = b - a;
    const double len2 = d.squaredNorm();
    for (std::size_t i = 0; i < c.size(); ++i)
      t[i] = len2 > 0 ? (v[c[i]].head<2>() - a).dot(d) / len2
                      : static_cast<double>(i) / static_cast<double>(c.size() - 1);
  };
  thread_local std::vector<double> tl, tu;
  params(lo, tl);
  params(up, tu);
  std::size_t i = 0, j = 0;
  while (i + 1 < lo.size() || j + 1 < up.size()) {
    const bool lower = j + 1 >= up.size() || (i + 1 < lo.size() && tl[i + 1] <= tu[j + 1]);
    const std::array<std::uint32_t, 3> t =
        lower ? std::array{lo[i], lo[i + 1], up[j]} : std::array{lo[i], up[j + 1], up[j]};
    if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) out.push_back(t);
    (lower ? i : j) += 1;
  }
}

/// The chain of outline edge k of ring `ring` of boundary `b`, as global vertex ids.
void boundary_chain(const Boundary& b, std::uint32_t base, std::size_t ring, std::size_t k,
                    std::vector<std::uint32_t>& out) {
  out.clear();
  const std::size_t p = b.pos_base[ring] + k;
  for (std::uint32_t i = b.pos[p]; i <= b.pos[p + 1]; ++i) out.push_back(base + b.seq[i]);
}

struct SideInput {
  const Slab* slab;
  const Boundary* bottom;  // boundary below: this slab's outlines are its "above" rings
  const Boundary* top;     // boundary above: this slab's outlines are its "below" rings
  std::uint32_t bottom_base, top_base, inner_base;
  std::size_t bottom_first_ring;  // rings of the slab below come first in `bottom`
};

/// The side strips of one slab; `seeds` gets each outline's first triangle (slab-local).
void side(const SideInput& in, int steps, const std::vector<Vec3>& v,
          std::vector<std::array<std::uint32_t, 3>>& out, std::vector<std::uint32_t>& seeds) {
  std::vector<std::uint32_t> lo, up;
  std::size_t offset = 0;
  for (std::size_t l = 0; l < in.slab->outlines.size(); ++l) {
    const Outline& o = in.slab->outlines[l];
    const std::size_t n = o.pts.size();
    seeds.push_back(static_cast<std::uint32_t>(out.size()));
    const auto inner = [&](int j, std::size_t k) {
      return in.inner_base +
             static_cast<std::uint32_t>(static_cast<std::size_t>(j - 1) * in.slab->points + offset +
                                        k % n);
    };
    for (std::size_t k = 0; k < n; ++k)
      for (int j = 0; j < 2 * steps; ++j) {
        if (j == 0)
          boundary_chain(*in.bottom, in.bottom_base, in.bottom_first_ring + l, k, lo);
        else
          lo = {inner(j, k), inner(j, k + 1)};
        if (j + 1 == 2 * steps)
          boundary_chain(*in.top, in.top_base, l, k, up);
        else
          up = {inner(j + 1, k), inner(j + 1, k + 1)};
        zip(lo, up, v, out);
      }
    offset += n;
  }
}

/// True when cap() gives the same boundary for `a` as for `b` (their rings are the same).
bool same_rings(const Slab& a, const Slab& b) {
  if (a.z_lo != b.z_lo || a.z_hi != b.z_hi || a.end_inset != b.end_inset ||
      a.cell_mm != b.cell_mm || a.outlines.size() != b.outlines.size())
    return false;
  for (std::size_t l = 0; l < a.outlines.size(); ++l) {
    const Outline &p = a.outlines[l], &q = b.outlines[l];
    if (p.scale != q.scale || p.pts != q.pts || p.miter != q.miter || p.share != q.share)
      return false;
  }
  return true;
}

/// The boundaries of a build that a later one may take (build_layer_surface's memo).
/// `reuse(b)`: boundary b as it was (null: build it); `traced[s]`: slab s as traced, kept
/// when the caps change it.
struct CapReuse {
  std::function<const Boundary*(std::size_t)> reuse;
  std::vector<std::optional<Slab>>* traced = nullptr;
};

/// Caps of every boundary; rings that cross (themselves, or another ring of their side)
/// get capped miters, then straight sides, then their unsimplified outline (simple, and
/// apart from the others).
/// False when some still cross.
bool make_caps(std::vector<Slab>& slabs, int steps, bool exact, std::vector<Boundary>& caps,
               const CapReuse& memo) {
  const std::size_t ns = slabs.size();
  caps.assign(ns + 1, Boundary{});
  std::vector<char> redo(ns + 1, 1);
  for (int round = 0; round < 4; ++round) {
    tbb::parallel_for(std::size_t{0}, ns + 1, [&](std::size_t b) {
      if (redo[b] == 0) return;
      if (const Boundary* kept = memo.reuse ? memo.reuse(b) : nullptr; kept != nullptr)
        caps[b] = *kept;
      else
        caps[b] = cap(b > 0 ? &slabs[b - 1] : nullptr, b < ns ? &slabs[b] : nullptr, steps, exact);
    });
    std::fill(redo.begin(), redo.end(), 0);
    bool any = false;
    for (std::size_t b = 0; b <= ns; ++b)
      for (const auto& [below_or_above, l] : caps[b].crossed) {
        const std::size_t s = below_or_above == 0 ? b - 1 : b;
        if (memo.traced != nullptr && !(*memo.traced)[s]) (*memo.traced)[s] = slabs[s];
        Outline& o = slabs[s].outlines[l];
        const double r = 0.5 * (slabs[s].z_hi - slabs[s].z_lo);
        if (o.scale > 0 && !o.capped) {
          o.capped = true;
          o.miter = miters(o.pts, r);
        } else if (o.scale > 0) {
          o.scale = 0;
        } else if (o.pts.size() != o.raw.size()) {
          slabs[s].points += o.raw.size() - o.pts.size();
          o.pts = o.raw;
          o.miter = miters(o.pts, 0);
          o.share.assign(o.pts.size(), 0.0);
        }
        redo[s] = redo[s + 1] = 1;
        any = true;
      }
    if (!any) break;
  }
  return std::all_of(caps.begin(), caps.end(),
                     [](const Boundary& b) { return b.ok && b.crossed.empty(); });
}

/// The share of the rounded profile an outline keeps, its edges' lengths weighted.
double kept_depth(const Outline& o) {
  double len = 0, kept = 0;
  for (std::size_t k = 0; k < o.pts.size(); ++k) {
    const std::size_t k1 = (k + 1) % o.pts.size();
    const double l = (o.pts[k1] - o.pts[k]).norm();
    len += l;
    kept += 0.5 * l * o.scale * (o.share[k] + o.share[k1]);
  }
  return len > 0 ? kept / len : 0.0;
}

}  // namespace

LayerCap layer_cap(const std::vector<std::vector<Eigen::Vector2d>>& lower,
                   const std::vector<std::vector<Eigen::Vector2d>>& upper, double snap_mm,
                   bool exact) {
  std::vector<CapRing> rings(lower.begin(), lower.end());
  rings.insert(rings.end(), upper.begin(), upper.end());
  snap_upper_to_lower(rings, lower.size(), snap_mm);
  Boundary b = cap_of_rings(rings, lower.size(), snap_mm, exact);
  LayerCap out;
  out.ok = b.ok && b.crossed.empty();
  if (!out.ok) return out;
  out.vertices = std::move(b.verts);
  out.triangles = std::move(b.tris);
  return out;
}

struct LayerSurfaceMemo::State {
  LayerSurfaceOptions options;
  int width = 0, height = 0;
  double cell_mm = 0;
  Vec3 base_mm = Vec3::Zero();
  /// One per slab of the build, in order: its cell range, its state after the caps, and
  /// its traced state when the caps changed it.
  struct Kept {
    int z0 = 0, z1 = 0;
    bool forgotten = false;
    Slab last;
    std::optional<Slab> traced;
  };
  std::vector<Kept> slabs;
  std::vector<Boundary> caps;  ///< boundary b: below slab b - 1, above slab b

  [[nodiscard]] bool fits(const LayerSlabs& in, const LayerSurfaceOptions& o) const {
    return o.tolerance_mm == options.tolerance_mm && o.profile_steps == options.profile_steps &&
           o.exact == options.exact && in.width == width && in.height == height &&
           in.cell_mm == cell_mm && in.base_mm == base_mm;
  }
  /// The kept slab of cells [z0, z1) (not forgotten), or -1.
  [[nodiscard]] std::ptrdiff_t find(int z0, int z1) const {
    const auto it = std::lower_bound(slabs.begin(), slabs.end(), z0,
                                     [](const Kept& k, int z) { return k.z0 < z; });
    return it != slabs.end() && it->z0 == z0 && it->z1 == z1 && !it->forgotten ? it - slabs.begin()
                                                                               : -1;
  }
  /// Boundary b of a build whose slab s is the kept slab from[s] (-1: none), now in the
  /// state `slabs`: the kept boundary when its slabs were its slabs here, next to each other
  /// (or both ends), and are in the state they had (null otherwise).
  [[nodiscard]] const Boundary* cap(std::size_t b, const std::vector<std::ptrdiff_t>& from,
                                    const std::vector<Slab>& now) const {
    const std::size_t ns = now.size();
    const std::ptrdiff_t lo = b > 0 ? from[b - 1] : -1, hi = b < ns ? from[b] : -1;
    const auto kept_ns = static_cast<std::ptrdiff_t>(slabs.size());
    const bool pair = b == 0 ? hi == 0 : b == ns ? lo == kept_ns - 1 : lo >= 0 && hi == lo + 1;
    if (!pair) return nullptr;
    const std::size_t kb = b == 0 ? 0 : static_cast<std::size_t>(lo) + 1;
    if (b > 0 && !same_rings(now[b - 1], slabs[kb - 1].last)) return nullptr;
    if (b < ns && !same_rings(now[b], slabs[kb].last)) return nullptr;
    return &caps[kb];
  }
  /// The state of a build of `in` (its slabs and caps moved in).
  static std::unique_ptr<State> of(const LayerSlabs& in, const LayerSurfaceOptions& options,
                                   std::vector<Slab>& slabs,
                                   std::vector<std::optional<Slab>>& traced,
                                   std::vector<Boundary>& caps) {
    auto st = std::make_unique<State>();
    st->options = options;
    st->width = in.width;
    st->height = in.height;
    st->cell_mm = in.cell_mm;
    st->base_mm = in.base_mm;
    st->slabs.resize(slabs.size());
    for (std::size_t s = 0; s < slabs.size(); ++s) {
      Kept& k = st->slabs[s];
      k.z0 = in.bounds[s];
      k.z1 = in.bounds[s + 1];
      k.last = std::move(slabs[s]);
      k.traced = std::move(traced[s]);
    }
    st->caps = std::move(caps);
    return st;
  }
};

LayerSurfaceMemo::LayerSurfaceMemo() = default;
LayerSurfaceMemo::~LayerSurfaceMemo() = default;
LayerSurfaceMemo::LayerSurfaceMemo(LayerSurfaceMemo&&) noexcept = default;
LayerSurfaceMemo& LayerSurfaceMemo::operator=(LayerSurfaceMemo&&) noexcept = default;

void LayerSurfaceMemo::forget(int z0, int z1) {
  if (!state_) return;
  for (auto& k : state_->slabs)
    if (k.z0 == z0 && k.z1 == z1) k.forgotten = true;
}

LayerSurface build_layer_surface(const LayerSlabs& in, const LayerSurfaceOptions& options,
                                 LayerSurfaceMemo* memo) {
  LayerSurface out;
  const int n_slabs = static_cast<int>(in.bounds.size()) - 1;
  if (n_slabs <= 0) return out;
  const int steps = std::max(1, options.profile_steps);
  const auto ns = static_cast<std::size_t>(n_slabs);
  // The memo's slab of each slab (-1: traced here).
  const LayerSurfaceMemo::State* old =
      memo != nullptr && memo->state_ && memo->state_->fits(in, options) ? memo->state_.get()
                                                                         : nullptr;
  std::vector<std::ptrdiff_t> from(ns, -1);
  if (old != nullptr)
    for (std::size_t s = 0; s < ns; ++s) from[s] = old->find(in.bounds[s], in.bounds[s + 1]);
  std::vector<Slab> slabs(ns);
  tbb::parallel_for(0, n_slabs, [&](int s) {
    const auto su = static_cast<std::size_t>(s);
    if (from[su] >= 0) {
      const auto& kept = old->slabs[static_cast<std::size_t>(from[su])];
      slabs[su] = kept.traced ? *kept.traced : kept.last;
      return;
    }
    thread_local std::vector<std::uint64_t> rows;
    slabs[su] = trace_slab(in, s, options.tolerance_mm, steps, rows);
  });
  std::vector<std::optional<Slab>> traced(memo != nullptr ? ns : 0);
  std::atomic<std::size_t> reused_caps{0};
  CapReuse reuse;
  if (memo != nullptr) reuse.traced = &traced;
  if (old != nullptr)
    reuse.reuse = [&](std::size_t b) {
      const Boundary* kept = old->cap(b, from, slabs);
      if (kept != nullptr) reused_caps.fetch_add(1, std::memory_order_relaxed);
      return kept;
    };
  std::vector<Boundary> caps;
  const bool closed = make_caps(slabs, steps, options.exact, caps, reuse);
  if (memo != nullptr) {
    memo->reused_slabs_ = static_cast<std::size_t>(
        std::count_if(from.begin(), from.end(), [](std::ptrdiff_t f) { return f >= 0; }));
    memo->reused_caps_ = reused_caps.load();
  }
  if (!closed) {  // rings kept crossing: no mesh
    if (memo != nullptr) memo->state_.reset();
    return out;
  }
  // Vertices: each boundary's, then each slab's inner rings.
  std::vector<std::uint32_t> cap_base(ns + 1), inner_base(ns);
  std::size_t nv = 0;
  for (std::size_t b = 0; b <= ns; ++b) {
    cap_base[b] = static_cast<std::uint32_t>(nv);
    nv += caps[b].verts.size();
  }
  for (std::size_t s = 0; s < ns; ++s) {
    inner_base[s] = static_cast<std::uint32_t>(nv);
    nv += static_cast<std::size_t>(2 * steps - 1) * slabs[s].points;
  }
  Mesh& mesh = out.mesh;
  mesh.vertices_mm.resize(nv);
  tbb::parallel_for(std::size_t{0}, ns + 1, [&](std::size_t b) {
    const double z = b < ns ? slabs[b].z_lo : slabs[b - 1].z_hi;
    for (std::size_t i = 0; i < caps[b].verts.size(); ++i)
      mesh.vertices_mm[cap_base[b] + i] = Vec3(caps[b].verts[i].x(), caps[b].verts[i].y(), z);
  });
  tbb::parallel_for(std::size_t{0}, ns, [&](std::size_t s) {
    std::size_t at = inner_base[s];
    for (int j = 1; j < 2 * steps; ++j)
      for (const Outline& o : slabs[s].outlines)
        for (std::size_t k = 0; k < o.pts.size(); ++k) {
          const P2 p = ring_point(slabs[s], o, k, j, steps);
          mesh.vertices_mm[at++] = Vec3(p.x(), p.y(), ring_z(slabs[s], j, steps));
        }
  });
  std::vector<std::vector<std::array<std::uint32_t, 3>>> sides(ns);
  std::vector<std::vector<std::uint32_t>> side_seeds(ns);
  tbb::parallel_for(std::size_t{0}, ns, [&](std::size_t s) {
    const SideInput si{&slabs[s],
                       &caps[s],
                       &caps[s + 1],
                       cap_base[s],
                       cap_base[s + 1],
                       inner_base[s],
                       s > 0 ? slabs[s - 1].outlines.size() : 0};
    side(si, steps, mesh.vertices_mm, sides[s], side_seeds[s]);
  });
  // Triangles: each boundary's cap, then each slab's side, copied in parallel to their
  // places in one array of the final size.
  std::vector<std::size_t> tri_base(2 * ns + 2, 0);
  for (std::size_t b = 0; b <= ns; ++b) tri_base[b + 1] = tri_base[b] + caps[b].tris.size();
  for (std::size_t s = 0; s < ns; ++s)
    tri_base[ns + 2 + s] = tri_base[ns + 1 + s] + sides[s].size();
  out.cap_triangles = tri_base[ns + 1];
  mesh.triangles.resize(tri_base[2 * ns + 1]);
  tbb::parallel_for(std::size_t{0}, 2 * ns + 1, [&](std::size_t i) {
    auto* at = mesh.triangles.data() + tri_base[i];
    if (i <= ns) {
      for (const auto& t : caps[i].tris)
        *at++ = {cap_base[i] + t[0], cap_base[i] + t[1], cap_base[i] + t[2]};
    } else {
      std::copy(sides[i - ns - 1].begin(), sides[i - ns - 1].end(), at);
    }
  });
  for (std::size_t s = 0; s < ns; ++s) {
    const auto first = static_cast<std::uint32_t>(tri_base[ns + 1 + s]);
    for (std::size_t l = 0; l < slabs[s].outlines.size(); ++l)
      out.seeds.push_back({slabs[s].outlines[l].seed_x, slabs[s].outlines[l].seed_y,
                           static_cast<int>(s), first + side_seeds[s][l]});
    out.outlines += slabs[s].outlines.size();
    for (const Outline& o : slabs[s].outlines) out.straight_outlines += kept_depth(o) < 0.5 ? 1 : 0;
  }
  if (memo != nullptr) memo->state_ = LayerSurfaceMemo::State::of(in, options, slabs, traced, caps);
  return out;
}

bool is_closed_oriented(const Mesh& mesh) {
  // Each edge a -> b of a triangle is listed at its lower end min(a, b), as the other end
  // and the direction ((other << 1) | (a > b)); sorted, a vertex's list must hold every
  // other end exactly twice, once each way: each edge once in each direction.
  const std::size_t nv = mesh.vertices_mm.size();
  if (nv >= (std::size_t{1} << 31)) return false;
  std::vector<std::uint32_t> begin(nv + 2, 0);
  for (const auto& t : mesh.triangles)
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      if (a >= nv || b >= nv || a == b) return false;
      ++begin[std::min(a, b) + 2];
    }
  for (std::size_t v = 2; v < begin.size(); ++v) begin[v] += begin[v - 1];
  std::vector<std::uint32_t> to(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      to[begin[std::min(a, b) + 1]++] = (std::max(a, b) << 1) | (a > b ? 1U : 0U);
    }
  // begin[v] .. begin[v + 1]: the edges listed at v.
  std::atomic<bool> ok{true};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t v = r.begin(); v != r.end() && ok.load(); ++v) {
                        const auto first = to.begin() + begin[v], last = to.begin() + begin[v + 1];
                        std::sort(first, last);
                        if ((last - first) % 2 != 0) ok = false;
                        for (auto e = first; e != last && e + 1 != last; e += 2)
                          if ((*e & 1U) != 0 || e[1] != *e + 1) ok = false;
                      }
                    });
  return ok.load();
}

}  // namespace printtwin::detail
