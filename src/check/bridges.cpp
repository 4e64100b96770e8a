// Bridges among the overhang regions: a flat ceiling held at both ends along one direction
// prints without support, the way a slicer lays bridge infill across it.
//
// Model (docs/check.md, "Bridges"):
// - A region is a bridge candidate when it rises at most kMaxRiseMm from its lowest to its
//   highest point: a flat ceiling, or the top of a horizontal hole or of a low vault (an
//   arch: its sides step in layer by layer, its top is bridged). Its outline in the plane is
//   what the ray test below reads.
// - Each edge on the region's border is anchored when the face beyond it runs down from it
//   (a wall below holds the bridge's end there), free otherwise (a wall rising from the edge,
//   an open edge, an edge of more than two faces).
// - Points spread over the region cast rays both ways along a direction; the direction
//   bridges the region when every point's two rays leave it through anchored edges. The
//   span along it is the longest such line. Of the directions (every kDirectionStepDeg) the
//   one with the shortest span is the bridge's, as a slicer turns bridge infill across the
//   shortest gap.
// - The mid-span sag comes from the printer's sag model (bridge_sag_mm at
//   bridge_sag_span_mm, sag ~ span^2), the one the deposit uses.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"

namespace printtwin::detail {

namespace {

constexpr double kPi = 3.14159265358979323846;
/// Faces of a flat ceiling lean at least this far from vertical (90 = horizontal).
constexpr double kFlatDeg = 85.0;
/// A bridge region rises at most this much from its lowest to its highest point.
constexpr double kMaxRiseMm = 3.0;
/// The face beyond an anchored edge reaches at least this far below it.
constexpr double kAnchorDropMm = 0.01;
/// Directions tried, in [0, 180) degrees.
constexpr int kDirectionStepDeg = 5;
/// Sample points spread over a region: at most this many.
constexpr std::size_t kMaxPoints = 1500;
/// And no closer than this.
constexpr double kMinSpacingMm = 0.25;
/// Regions with more border edges than this are sculpted surfaces, not ceilings: not tried.
constexpr std::size_t kMaxBorderEdges = 4000;

struct Edge2 {
  std::array<double, 2> a{}, b{};
  bool anchored = false;
};

struct Hit {
  double t = std::numeric_limits<double>::infinity();
  bool anchored = false;
};

/// The region's border edges in the plane, each anchored or free.
std::vector<Edge2> border_edges(const Mesh& m, std::span<const std::uint32_t> region_of,
                                std::uint32_t region, const EdgeTable& edges) {
  std::vector<Edge2> out;
  for (const auto& [b, e] : edges.groups) {
    std::size_t inside = 0;
    std::uint32_t outside_face = UINT32_MAX;
    for (std::size_t i = b; i < e; ++i) {
      const std::uint32_t f = edges.half_edges[i].face;
      if (region_of[f] == region)
        ++inside;
      else
        outside_face = f;
    }
    if (inside != 1) continue;  // inside the region (2) or not on it (0)
    const HalfEdge& h = edges.half_edges[b];
    const Vec3& pa = m.vertices_mm[h.lo];
    const Vec3& pb = m.vertices_mm[h.hi];
    Edge2 edge{{pa.x(), pa.y()}, {pb.x(), pb.y()}, false};
    if (e - b == 2 && outside_face != UINT32_MAX) {
      double low = std::numeric_limits<double>::infinity();
      for (const std::uint32_t v : m.triangles[outside_face])
        if (v != h.lo && v != h.hi) low = std::min(low, m.vertices_mm[v].z());
      edge.anchored = low < std::min(pa.z(), pb.z()) - kAnchorDropMm;
    }
    out.push_back(edge);
  }
  return out;
}

/// Points spread over the region in the plane: a square grid of the given spacing where it
/// falls on the region's faces, and the centroid of every face (of every k-th face when there
/// are more than kMaxPoints), so that a sliver the grid misses is still tried.
std::vector<std::array<double, 2>> spread_points(const Mesh& m,
                                                 std::span<const std::uint32_t> faces,
                                                 double spacing) {
  std::vector<std::array<double, 2>> out;
  const std::size_t stride = faces.size() / kMaxPoints + 1;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const auto& t = m.triangles[faces[i]];
    const Vec3& p0 = m.vertices_mm[t[0]];
    const Vec3& p1 = m.vertices_mm[t[1]];
    const Vec3& p2 = m.vertices_mm[t[2]];
    if (i % stride == 0) {
      const Vec3 c = (p0 + p1 + p2) / 3.0;
      out.push_back({c.x(), c.y()});
    }
    // Grid points inside the face's outline (barycentric test in the plane).
    const double det =
        (p1.x() - p0.x()) * (p2.y() - p0.y()) - (p2.x() - p0.x()) * (p1.y() - p0.y());
    if (std::abs(det) < 1e-12) continue;
    const double x0 = std::min({p0.x(), p1.x(), p2.x()});
    const double x1 = std::max({p0.x(), p1.x(), p2.x()});
    const double y0 = std::min({p0.y(), p1.y(), p2.y()});
    const double y1 = std::max({p0.y(), p1.y(), p2.y()});
    for (double y = std::ceil(y0 / spacing) * spacing; y < y1; y += spacing)
      for (double x = std::ceil(x0 / spacing) * spacing; x < x1; x += spacing) {
        const double a = ((p1.x() - x) * (p2.y() - y) - (p2.x() - x) * (p1.y() - y)) / det;
        const double b = ((p2.x() - x) * (p0.y() - y) - (p0.x() - x) * (p2.y() - y)) / det;
        if (a >= 0 && b >= 0 && a + b <= 1) out.push_back({x, y});
      }
  }
  return out;
}

/// Distance in the plane from p to the segment a-b.
double segment_distance(const std::array<double, 2>& p, const Edge2& e) {
  const double dx = e.b[0] - e.a[0];
  const double dy = e.b[1] - e.a[1];
  const double len2 = dx * dx + dy * dy;
  double t = len2 > 0 ? ((p[0] - e.a[0]) * dx + (p[1] - e.a[1]) * dy) / len2 : 0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p[0] - (e.a[0] + t * dx), p[1] - (e.a[1] + t * dy));
}

/// The region's outline area in the plane (its faces projected).
double plane_area(const Mesh& m, std::span<const std::uint32_t> faces) {
  double a = 0;
  for (const std::uint32_t f : faces) a += std::abs(triangle_normal(m, f).z()) * 0.5;
  return a;
}

/// The nearest border crossings of the line through p along +u and -u.
std::pair<Hit, Hit> cast(const std::array<double, 2>& p, const std::array<double, 2>& u,
                         const std::vector<Edge2>& border) {
  constexpr double kEps = 1e-9;
  Hit ahead, behind;
  const auto offer = [](Hit& h, double t, bool anchored) {
    // At equal distance (a ray through a shared corner) a free edge wins: no false anchor.
    if (t < h.t - kEps) {
      h = {t, anchored};
    } else if (t <= h.t + kEps) {
      h.anchored = h.anchored && anchored;
    }
  };
  for (const Edge2& e : border) {
    const double dx = e.b[0] - e.a[0];
    const double dy = e.b[1] - e.a[1];
    const double den = u[0] * dy - u[1] * dx;  // cross(u, b - a)
    if (std::abs(den) < 1e-12) continue;       // parallel to the ray
    const double wx = e.a[0] - p[0];
    const double wy = e.a[1] - p[1];
    const double t = (wx * dy - wy * dx) / den;  // along the ray
    const double s = (wx * u[1] - wy * u[0]) / den;
    if (s < -kEps || s > 1 + kEps) continue;
    if (t > kEps)
      offer(ahead, t, e.anchored);
    else if (t < -kEps)
      offer(behind, -t, e.anchored);
  }
  return {ahead, behind};
}

}  // namespace

std::vector<std::optional<BridgeSpan>> find_bridges(const Mesh& placed,
                                                    std::span<const std::uint32_t> region_of,
                                                    std::span<const OverhangRegion> regions,
                                                    double min_area_mm2, double cantilever_mm,
                                                    double sag_mm, double sag_span_mm) {
  std::vector<std::optional<BridgeSpan>> out(regions.size());
  const double flat = std::sin(kFlatDeg * kPi / 180.0);
  // Candidates: flat regions (each face near horizontal, the region within a thin slab).
  std::vector<char> candidate(regions.size(), 0);
  std::vector<std::vector<std::uint32_t>> faces(regions.size());
  for (std::size_t r = 0; r < regions.size(); ++r)
    candidate[r] = regions[r].area_mm2 >= min_area_mm2 &&
                   regions[r].bbox_mm.max.z() - regions[r].bbox_mm.min.z() <= kMaxRiseMm;
  std::vector<char> flat_faces(regions.size(), 1);
  for (std::uint32_t f = 0; f < region_of.size(); ++f) {
    const std::uint32_t r = region_of[f];
    if (r == UINT32_MAX || candidate[r] == 0) continue;
    const Vec3 n = triangle_normal(placed, f);
    const double len = n.norm();
    if (!(len > 0) || -n.z() / len < flat) flat_faces[r] = 0;
    faces[r].push_back(f);
  }
  if (std::none_of(candidate.begin(), candidate.end(), [](char c) { return c != 0; })) return out;
  const EdgeTable edges = build_edge_table(placed, {});
  const double max_span = 2.0 * sag_span_mm;  // the deposit's anchor search reaches no further
  for (std::size_t r = 0; r < regions.size(); ++r) {
    if (candidate[r] == 0) continue;
    const std::vector<Edge2> border =
        border_edges(placed, region_of, static_cast<std::uint32_t>(r), edges);
    if (std::none_of(border.begin(), border.end(), [](const Edge2& e) { return e.anchored; }))
      continue;
    if (border.size() > kMaxBorderEdges) continue;  // a sculpted surface, not a ceiling
    const double spacing = std::max(
        kMinSpacingMm, std::sqrt(plane_area(placed, faces[r]) / static_cast<double>(kMaxPoints)));
    // Points within reach of an anchored edge are held from it (a ledge that narrow prints);
    // the others must be bridged.
    std::vector<std::array<double, 2>> points;
    double ledge = 0;  // the farthest held point's distance to its anchor
    for (const auto& p : spread_points(placed, faces[r], spacing)) {
      double d = std::numeric_limits<double>::infinity();
      for (const Edge2& e : border)
        if (e.anchored) d = std::min(d, segment_distance(p, e));
      if (d <= cantilever_mm)
        ledge = std::max(ledge, d);
      else
        points.push_back(p);
    }
    std::optional<BridgeSpan> best;
    if (points.empty()) {  // a ledge: how far its corners reach beyond what holds it
      for (const std::uint32_t f : faces[r])
        for (const std::uint32_t v : placed.triangles[f]) {
          const std::array<double, 2> p{placed.vertices_mm[v].x(), placed.vertices_mm[v].y()};
          double d = std::numeric_limits<double>::infinity();
          for (const Edge2& e : border)
            if (e.anchored) d = std::min(d, segment_distance(p, e));
          ledge = std::max(ledge, d);
        }
      best = BridgeSpan{ledge, 0, 0, flat_faces[r] != 0, true};
    }
    for (int deg = 0; deg < 180 && !points.empty(); deg += kDirectionStepDeg) {
      const double a = deg * kPi / 180.0;
      const std::array<double, 2> u{std::cos(a), std::sin(a)};
      double span = 0;
      bool held = true;
      for (const auto& p : points) {
        const auto [ahead, behind] = cast(p, u, border);
        if (!ahead.anchored || !behind.anchored) {
          held = false;
          break;
        }
        span = std::max(span, ahead.t + behind.t);
        if (best && span >= best->span_mm) break;  // no shorter than the best direction
      }
      if (!held || span > max_span || (best && span >= best->span_mm)) continue;
      best = BridgeSpan{span, static_cast<double>(deg), 0, flat_faces[r] != 0, false};
    }
    if (!best) continue;
    best->sag_mm = sag_span_mm > 0 ? sag_mm * std::pow(best->span_mm / sag_span_mm, 2) : 0;
    out[r] = best;
  }
  return out;
}

}  // namespace printtwin::detail
