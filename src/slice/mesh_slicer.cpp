// Cutting a triangle mesh into layer outlines: one pass over the triangles drops a segment
// into every layer plane a triangle crosses, then each layer chains its segments over the
// shared mesh edges (exact integer keys, no coordinate matching) into closed loops.
// A vertex exactly on a plane counts as above it, so every crossing triangle yields exactly
// two crossed edges and no special cases remain.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include <tbb/parallel_for.h>

#include "printtwin/io.hpp"
#include "slice/slice_internal.hpp"

namespace printtwin {

using namespace slice_detail;

std::vector<double> layer_print_z(double object_height_mm, const SliceSettings& s) {
  std::vector<double> z;
  if (!(object_height_mm > 0)) return z;
  const double eps = 1e-6;
  double top = std::min(s.first_layer_height_mm, object_height_mm);
  z.push_back(top);
  // The n-th layer ends at first + n * layer_height, computed without accumulating error.
  for (long n = 1;; ++n) {
    const double prev = z.back();
    if (prev + eps >= object_height_mm) break;
    double next = s.first_layer_height_mm + static_cast<double>(n) * s.layer_height_mm;
    if (next > object_height_mm + eps) {
      const double rest = object_height_mm - prev;
      if (rest < 0.25 * s.layer_height_mm) break;  // too thin to print: dropped
      next = object_height_mm;
    }
    z.push_back(next);
  }
  return z;
}

namespace {

struct Segment {
  double ax, ay, bx, by;
  std::uint64_t from_edge;  // key of the crossed edge where the segment starts
  std::uint64_t to_edge;
};

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

// Chains one layer's segments into loops. Returns loops in microns; `open_end` gets the
// position of an unmatched end when the mesh is not closed at this height.
struct ChainStats {
  int closed_gaps = 0;             // open chains joined across a gap
  std::optional<Vec2> dropped_at;  // an open chain that could not be closed
};

// Largest gap between open chain ends that is bridged (PrusaSlicer closes such gaps too).
constexpr double kMaxGapUm = 2000.0;

std::vector<std::vector<Point2um>> chain(std::vector<Segment>& segs, ChainStats& stats) {
  struct Open {
    std::vector<Point2um> pts;
    Point2um end;
  };
  std::vector<Open> open;
  std::vector<std::vector<Point2um>> loops;
  const std::size_t n = segs.size();
  if (n == 0) return loops;
  // Sort by start key for binary search of the successor.
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return segs[a].from_edge < segs[b].from_edge;
  });
  std::vector<std::uint64_t> keys(n);
  for (std::size_t i = 0; i < n; ++i) keys[i] = segs[order[i]].from_edge;
  std::vector<char> used(n, 0);
  auto find_next = [&](std::uint64_t key) -> long {
    auto it = std::lower_bound(keys.begin(), keys.end(), key);
    while (it != keys.end() && *it == key) {
      const std::size_t pos = static_cast<std::size_t>(it - keys.begin());
      if (!used[pos]) return static_cast<long>(pos);
      ++it;
    }
    return -1;
  };
  for (std::size_t start = 0; start < n; ++start) {
    if (used[start]) continue;
    std::vector<Point2um> loop;
    std::size_t cur = start;
    used[cur] = 1;
    bool closed = false;
    for (;;) {
      const Segment& s = segs[order[cur]];
      loop.push_back(Point2um{std::llround(s.ax * 1000.0), std::llround(s.ay * 1000.0)});
      if (s.to_edge == segs[order[start]].from_edge) {
        closed = true;
        break;
      }
      const long nxt = find_next(s.to_edge);
      if (nxt < 0) break;
      cur = static_cast<std::size_t>(nxt);
      used[cur] = 1;
    }
    if (!closed) {
      const Segment& s = segs[order[cur]];
      open.push_back(Open{std::move(loop),
                          Point2um{std::llround(s.bx * 1000.0), std::llround(s.by * 1000.0)}});
      continue;
    }
    // Drop repeated points (edges cut at the same micron).
    std::vector<Point2um> clean;
    clean.reserve(loop.size());
    for (const auto& p : loop)
      if (clean.empty() || !(clean.back() == p)) clean.push_back(p);
    while (clean.size() > 1 && clean.front() == clean.back()) clean.pop_back();
    if (clean.size() >= 3) loops.push_back(std::move(clean));
  }
  // Open chains (a mesh that is not closed, or pieces of one loop started in its middle):
  // join each chain's end to the nearest chain start, or close it on itself, across gaps up
  // to kMaxGapUm. Pieces of one loop meet at distance 0 and do not count as gaps.
  auto d = [](const Point2um& a, const Point2um& b) {
    return std::hypot(double(a.x_um - b.x_um), double(a.y_um - b.y_um));
  };
  while (!open.empty()) {
    Open c = std::move(open.back());
    open.pop_back();
    for (;;) {
      const double self = d(c.end, c.pts.front());
      long best = -1;
      bool best_reversed = false;
      double bd = std::numeric_limits<double>::infinity();
      for (std::size_t k = 0; k < open.size(); ++k) {
        const double dk = d(c.end, open[k].pts.front());
        if (dk < bd) {
          bd = dk;
          best = static_cast<long>(k);
          best_reversed = false;
        }
        // A piece running the other way (misoriented faces) joins by its end.
        const double de = d(c.end, open[k].end);
        if (de < bd) {
          bd = de;
          best = static_cast<long>(k);
          best_reversed = true;
        }
      }
      if (std::min(self, bd) > kMaxGapUm) {
        if (!stats.dropped_at) stats.dropped_at = Vec2(c.end.x_um * 1e-3, c.end.y_um * 1e-3);
        break;
      }
      if (self <= bd) {
        if (self > 2.0) ++stats.closed_gaps;
        if (c.pts.size() >= 3) loops.push_back(std::move(c.pts));
        break;
      }
      if (bd > 2.0) ++stats.closed_gaps;
      Open& nx = open[static_cast<std::size_t>(best)];
      if (best_reversed) {
        nx.pts.push_back(nx.end);
        std::reverse(nx.pts.begin(), nx.pts.end());
        nx.end = nx.pts.back();
        nx.pts.pop_back();
      }
      c.pts.insert(c.pts.end(), nx.pts.begin(), nx.pts.end());
      c.end = nx.end;
      open.erase(open.begin() + best);
    }
  }
  return loops;
}

}  // namespace

Result<std::vector<LayerOutline>> slice_layers(const Mesh& mesh, const SliceSettings& s) {
  if (mesh.triangles.empty()) return bad_input("the mesh has no triangles");
  const Box3 box = bounding_box(mesh);
  const std::vector<double> print_z = layer_print_z(box.max.z(), s);
  if (print_z.empty())
    return bad_input(
        "the mesh has no height above the bed (top at z = " + format_number(box.max.z()) + " mm)");
  const std::size_t L = print_z.size();
  std::vector<LayerOutline> layers(L);
  std::vector<double> slice_z(L);
  for (std::size_t i = 0; i < L; ++i) {
    const double bottom = i == 0 ? 0.0 : print_z[i - 1];
    layers[i].index = static_cast<int>(i);
    layers[i].print_z_mm = print_z[i];
    layers[i].height_mm = print_z[i] - bottom;
    layers[i].slice_z_mm = 0.5 * (bottom + print_z[i]);
    slice_z[i] = layers[i].slice_z_mm;
  }
  // Inside-out meshes (negative volume) are sliced with reversed loops.
  const bool flip = signed_volume_mm3(mesh) < 0;

  // Edge keys use one index per distinct position, so meshes whose triangles do not share
  // vertex indices (STL soups) chain as well as indexed ones.
  const auto& V = mesh.vertices_mm;
  std::vector<std::uint32_t> canon(V.size());
  {
    std::vector<std::uint32_t> ord(V.size());
    std::iota(ord.begin(), ord.end(), 0u);
    auto less = [&](std::uint32_t a, std::uint32_t b) {
      const Vec3& p = V[a];
      const Vec3& q = V[b];
      if (p.x() != q.x()) return p.x() < q.x();
      if (p.y() != q.y()) return p.y() < q.y();
      if (p.z() != q.z()) return p.z() < q.z();
      return a < b;
    };
    std::sort(ord.begin(), ord.end(), less);
    for (std::size_t k = 0; k < ord.size(); ++k) {
      if (k > 0 && V[ord[k]] == V[ord[k - 1]])
        canon[ord[k]] = canon[ord[k - 1]];
      else
        canon[ord[k]] = ord[k];
    }
  }
  std::vector<std::vector<Segment>> per_layer(L);
  for (const auto& tri : mesh.triangles) {
    if (tri[0] >= V.size() || tri[1] >= V.size() || tri[2] >= V.size())
      return bad_input("a triangle refers to a vertex index past the end of the vertex list");
    const std::array<std::uint32_t, 3> t = {canon[tri[0]], canon[tri[1]], canon[tri[2]]};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;  // degenerate
    const Vec3& p0 = V[t[0]];
    const Vec3& p1 = V[t[1]];
    const Vec3& p2 = V[t[2]];
    const double zmin = std::min({p0.z(), p1.z(), p2.z()});
    const double zmax = std::max({p0.z(), p1.z(), p2.z()});
    // Layers with zmin <= z <= zmax. A vertex on the plane counts as above it, so a
    // triangle whose top corner lies on the plane is cut there too (a segment of zero
    // length): its neighbours' segments end on its edges, and the loop must run through it.
    auto lo = std::lower_bound(slice_z.begin(), slice_z.end(), zmin);
    auto hi = std::upper_bound(slice_z.begin(), slice_z.end(), zmax);
    for (auto it = lo; it != hi; ++it) {
      const double z = *it;
      const bool above[3] = {p0.z() >= z, p1.z() >= z, p2.z() >= z};
      const int n_above = int(above[0]) + int(above[1]) + int(above[2]);
      if (n_above == 0 || n_above == 3) continue;
      // The lone vertex a (alone on its side), then b, c in the triangle's cyclic order.
      int a = 0;
      if (n_above == 1) {
        for (int k = 0; k < 3; ++k)
          if (above[k]) a = k;
      } else {
        for (int k = 0; k < 3; ++k)
          if (!above[k]) a = k;
      }
      const std::uint32_t ia = t[a], ib = t[(a + 1) % 3], ic = t[(a + 2) % 3];
      auto cut = [&](std::uint32_t u, std::uint32_t v, double& x, double& y) {
        if (u > v) std::swap(u, v);  // same formula from both triangles of the edge
        const Vec3& pu = V[u];
        const Vec3& pv = V[v];
        const double tt = (z - pu.z()) / (pv.z() - pu.z());
        x = pu.x() + tt * (pv.x() - pu.x());
        y = pu.y() + tt * (pv.y() - pu.y());
      };
      Segment seg{};
      double x_ab, y_ab, x_ca, y_ca;
      cut(ia, ib, x_ab, y_ab);
      cut(ic, ia, x_ca, y_ca);
      // Outward normal on the right of the walking direction: outer loops run CCW.
      bool a_to_c = n_above == 1;  // lone vertex above: from edge (a,b) to edge (c,a)
      if (flip) a_to_c = !a_to_c;
      if (a_to_c) {
        seg = Segment{x_ab, y_ab, x_ca, y_ca, edge_key(ia, ib), edge_key(ic, ia)};
      } else {
        seg = Segment{x_ca, y_ca, x_ab, y_ab, edge_key(ic, ia), edge_key(ia, ib)};
      }
      per_layer[static_cast<std::size_t>(it - slice_z.begin())].push_back(seg);
    }
  }

  std::vector<ChainStats> chain_stats(L);
  tbb::parallel_for(std::size_t(0), L, [&](std::size_t i) {
    auto loops = chain(per_layer[i], chain_stats[i]);
    // Union: overlapping shells merge, orientation normalised (outer CCW, holes CW).
    CPaths paths = to_paths(loops);
    ClipperLib::Clipper c;
    c.AddPaths(paths, ClipperLib::ptSubject, true);
    CPaths out;
    c.Execute(ClipperLib::ctUnion, out, ClipperLib::pftPositive, ClipperLib::pftPositive);
    ClipperLib::CleanPolygons(out, 2.0);  // drop points closer than ~2 um (tessellation noise)
    layers[i].polygons.clear();
    for (const auto& p : out) {
      if (p.size() < 3) continue;
      std::vector<Point2um> poly;
      poly.reserve(p.size());
      for (const auto& q : p) poly.push_back(Point2um{q.X, q.Y});
      layers[i].polygons.push_back(std::move(poly));
    }
  });
  for (std::size_t i = 0; i < L; ++i) {
    layers[i].closed_gaps = chain_stats[i].closed_gaps;
    if (const auto& at = chain_stats[i].dropped_at) {
      return bad_input("the mesh is not closed: the outline of layer " + std::to_string(i) +
                       " (z = " + format_fixed(layers[i].slice_z_mm, 3) + " mm) ends open at x = " +
                       format_fixed(at->x(), 3) + ", y = " + format_fixed(at->y(), 3) +
                       " mm, more than 2 mm from any other open end");
    }
  }
  return layers;
}

}  // namespace printtwin
