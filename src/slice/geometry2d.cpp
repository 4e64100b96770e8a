// 2D helpers of the slicer over Clipper 6.4 (integer microns): offsets, booleans, polygons
// with holes, strip centre lines and infill line patterns.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "slice/slice_internal.hpp"

namespace printtwin::slice_detail {

using namespace ClipperLib;

const char* role_label(Role r) {
  switch (r) {
    case Role::external_perimeter:
      return "External perimeter";
    case Role::perimeter:
      return "Perimeter";
    case Role::sparse_infill:
      return "Internal infill";
    case Role::solid_infill:
      return "Solid infill";
    case Role::top_solid_infill:
      return "Top solid infill";
    case Role::bridge_infill:
      return "Bridge infill";
    case Role::gap_fill:
      return "Gap fill";
    case Role::skirt:
      return "Skirt/Brim";
  }
  return "Perimeter";
}

CPaths to_paths(const std::vector<std::vector<Point2um>>& polygons) {
  CPaths out;
  out.reserve(polygons.size());
  for (const auto& poly : polygons) {
    CPath p;
    p.reserve(poly.size());
    for (const auto& q : poly) p.emplace_back(q.x_um, q.y_um);
    out.push_back(std::move(p));
  }
  return out;
}

namespace {
void collect(const PolyNode& node, ExPolygons& out) {
  for (const PolyNode* outer : node.Childs) {
    ExPolygon ex;
    ex.contour = outer->Contour;
    for (const PolyNode* hole : outer->Childs) {
      ex.holes.push_back(hole->Contour);
      collect(*hole, out);  // islands inside holes
    }
    out.push_back(std::move(ex));
  }
}
}  // namespace

ExPolygons to_expolygons(const CPaths& paths) {
  Clipper c;
  c.AddPaths(paths, ptSubject, true);
  PolyTree tree;
  c.Execute(ctUnion, tree, pftNonZero, pftNonZero);
  ExPolygons out;
  collect(tree, out);
  return out;
}

CPaths to_paths(const ExPolygons& polys) {
  CPaths out;
  for (const auto& ex : polys) {
    out.push_back(ex.contour);
    for (const auto& h : ex.holes) out.push_back(h);
  }
  return out;
}

CPaths offset(const CPaths& paths, double delta_um, JoinType join) {
  if (paths.empty()) return {};
  ClipperOffset co(2.0, 5.0);  // miter limit 2 x delta; arcs within 5 um
  co.AddPaths(paths, join, etClosedPolygon);
  CPaths out;
  co.Execute(out, delta_um);
  return out;
}

CPaths offset(const ExPolygons& polys, double delta_um, JoinType join) {
  return offset(to_paths(polys), delta_um, join);
}

CPaths clip(const CPaths& subject, const CPaths& clip_paths, ClipType type) {
  if (subject.empty()) return type == ctUnion ? unite(clip_paths) : CPaths{};
  if (clip_paths.empty()) {
    if (type == ctIntersection) return {};
    return unite(subject);
  }
  Clipper c;
  c.AddPaths(subject, ptSubject, true);
  c.AddPaths(clip_paths, ptClip, true);
  CPaths out;
  c.Execute(type, out, pftNonZero, pftNonZero);
  return out;
}

CPaths unite(const CPaths& a) {
  if (a.empty()) return {};
  Clipper c;
  c.AddPaths(a, ptSubject, true);
  CPaths out;
  c.Execute(ctUnion, out, pftNonZero, pftNonZero);
  return out;
}

CPaths opening(const CPaths& a, double r_um) { return offset(offset(a, -r_um), r_um); }

double area_mm2(const CPaths& paths) {
  double a = 0;
  for (const auto& p : paths) a += Area(p);
  return a * 1e-6;
}

CPaths clip_lines(const CPaths& lines, const CPaths& region) {
  if (lines.empty() || region.empty()) return {};
  Clipper c;
  c.AddPaths(lines, ptSubject, false);
  c.AddPaths(region, ptClip, true);
  PolyTree tree;
  c.Execute(ctIntersection, tree, pftNonZero, pftNonZero);
  CPaths out;
  OpenPathsFromPolyTree(tree, out);
  return out;
}

namespace {

double path_length(const CPath& p, bool closed) {
  double len = 0;
  for (std::size_t i = 1; i < p.size(); ++i)
    len += std::hypot(double(p[i].X - p[i - 1].X), double(p[i].Y - p[i - 1].Y));
  if (closed && p.size() > 1)
    len += std::hypot(double(p.front().X - p.back().X), double(p.front().Y - p.back().Y));
  return len;
}

// Point at arc length s along polyline `p` with cumulative lengths `cum`.
std::pair<double, double> point_at(const CPath& p, const std::vector<double>& cum, double s) {
  auto it = std::upper_bound(cum.begin(), cum.end(), s);
  std::size_t i = it == cum.begin() ? 0 : static_cast<std::size_t>(it - cum.begin()) - 1;
  if (i + 1 >= p.size()) return {double(p.back().X), double(p.back().Y)};
  const double seg = cum[i + 1] - cum[i];
  const double t = seg > 0 ? (s - cum[i]) / seg : 0;
  return {p[i].X + t * double(p[i + 1].X - p[i].X), p[i].Y + t * double(p[i + 1].Y - p[i].Y)};
}

std::vector<double> cumulative(const CPath& p) {
  std::vector<double> cum(p.size(), 0.0);
  for (std::size_t i = 1; i < p.size(); ++i)
    cum[i] = cum[i - 1] + std::hypot(double(p[i].X - p[i - 1].X), double(p[i].Y - p[i - 1].Y));
  return cum;
}

// Shortens an open polyline by `d` at both ends (keeps it when too short).
CPath trim_ends(const CPath& p, double d) {
  const auto cum = cumulative(p);
  const double len = cum.back();
  if (len <= 2 * d + 1) return p;
  CPath out;
  auto a = point_at(p, cum, d);
  out.emplace_back(std::llround(a.first), std::llround(a.second));
  for (std::size_t i = 0; i < p.size(); ++i)
    if (cum[i] > d && cum[i] < len - d) out.push_back(p[i]);
  auto b = point_at(p, cum, len - d);
  out.emplace_back(std::llround(b.first), std::llround(b.second));
  return out;
}

// Douglas-Peucker simplification of an open polyline (tolerance in microns).
void dp(const CPath& p, std::size_t a, std::size_t b, double tol, std::vector<char>& keep) {
  if (b <= a + 1) return;
  const double ax = double(p[a].X), ay = double(p[a].Y);
  const double dx = double(p[b].X) - ax, dy = double(p[b].Y) - ay;
  const double len = std::hypot(dx, dy);
  double worst = -1;
  std::size_t wi = a;
  for (std::size_t k = a + 1; k < b; ++k) {
    const double px = double(p[k].X) - ax, py = double(p[k].Y) - ay;
    const double d = len > 0 ? std::abs(px * dy - py * dx) / len : std::hypot(px, py);
    if (d > worst) {
      worst = d;
      wi = k;
    }
  }
  if (worst > tol) {
    keep[wi] = 1;
    dp(p, a, wi, tol, keep);
    dp(p, wi, b, tol, keep);
  }
}

CPath simplify_open(const CPath& p, double tol) {
  if (p.size() < 3) return p;
  std::vector<char> keep(p.size(), 0);
  keep.front() = keep.back() = 1;
  dp(p, 0, p.size() - 1, tol, keep);
  CPath out;
  for (std::size_t k = 0; k < p.size(); ++k)
    if (keep[k]) out.push_back(p[k]);
  return out;
}

}  // namespace

Centerline centerline(const ExPolygon& strip) {
  Centerline c;
  double area = std::abs(Area(strip.contour));
  double perim = path_length(strip.contour, true);
  for (const auto& h : strip.holes) {
    area -= std::abs(Area(h));
    perim += path_length(h, true);
  }
  if (area <= 0 || perim <= 0) return c;
  // Rectangle L x d with area A and perimeter P: d = (P/2 - sqrt(P^2/4 - 4A)) / 2.
  const double half = 0.5 * perim;
  const double disc = half * half - 4.0 * area;
  const double d_um = disc >= 0 ? 0.5 * (half - std::sqrt(disc)) : 0.25 * perim;
  c.width_mm = d_um / kUmPerMm;
  if (!strip.holes.empty()) {
    // A ring: its centre line is the outer contour moved inwards by half the width.
    c.paths = offset(CPaths{strip.contour}, -0.5 * d_um);
    c.closed = true;
    return c;
  }
  const CPath& P = strip.contour;
  const std::size_t n = P.size();
  if (n < 3) return c;
  // Ends of the strip: the farthest pair by two farthest-point sweeps.
  auto farthest = [&](std::size_t from) {
    std::size_t best = from;
    double bd = -1;
    for (std::size_t k = 0; k < n; ++k) {
      const double dd = std::hypot(double(P[k].X - P[from].X), double(P[k].Y - P[from].Y));
      if (dd > bd) {
        bd = dd;
        best = k;
      }
    }
    return best;
  };
  const std::size_t i = farthest(farthest(0));
  const std::size_t j = farthest(i);
  if (i == j) return c;
  // The two sides from end i to end j, then their average by normalised arc length.
  CPath side_a, side_b;
  for (std::size_t k = i;; k = (k + 1) % n) {
    side_a.push_back(P[k]);
    if (k == j) break;
  }
  for (std::size_t k = i;; k = (k + n - 1) % n) {
    side_b.push_back(P[k]);
    if (k == j) break;
  }
  // Each end of a strip is a short cap that belongs to one side only: drop it from that
  // side so both sides run along the strip (otherwise the line ends skew across).
  auto edge_len = [](const CPath& p, std::size_t k) {
    return std::hypot(double(p[k + 1].X - p[k].X), double(p[k + 1].Y - p[k].Y));
  };
  for (int end = 0; end < 2; ++end) {
    if (side_a.size() < 3 || side_b.size() < 3) break;
    if (end == 1) {
      std::reverse(side_a.begin(), side_a.end());
      std::reverse(side_b.begin(), side_b.end());
    }
    const double la = edge_len(side_a, 0), lb = edge_len(side_b, 0);
    if (la <= 1.5 * d_um && lb > la)
      side_a.erase(side_a.begin());
    else if (lb <= 1.5 * d_um && la > lb)
      side_b.erase(side_b.begin());
    if (end == 1) {
      std::reverse(side_a.begin(), side_a.end());
      std::reverse(side_b.begin(), side_b.end());
    }
  }
  const auto ca = cumulative(side_a);
  const auto cb = cumulative(side_b);
  const std::size_t samples = std::max<std::size_t>(2, std::max(side_a.size(), side_b.size()) * 2);
  CPath mid;
  for (std::size_t k = 0; k < samples; ++k) {
    const double t = double(k) / double(samples - 1);
    auto pa = point_at(side_a, ca, t * ca.back());
    auto pb = point_at(side_b, cb, t * cb.back());
    IntPoint q(std::llround(0.5 * (pa.first + pb.first)),
               std::llround(0.5 * (pa.second + pb.second)));
    if (mid.empty() || mid.back() != q) mid.push_back(q);
  }
  mid = simplify_open(mid, 5.0);
  if (mid.size() < 2) return c;
  // The bead's round ends reach half a width beyond the end points.
  c.paths.push_back(trim_ends(mid, 0.5 * d_um));
  return c;
}

namespace {

// Parallel lines at `angle_deg` spaced `spacing_um` on a grid fixed to the origin (so the
// lines of consecutive layers line up), covering the bounding box of `region`.
CPaths line_field(const CPaths& region, double spacing_um, double angle_deg) {
  const double a = angle_deg * std::numbers::pi / 180.0;
  const double ca = std::cos(a), sa = std::sin(a);
  // Rotate by -a: lines become horizontal.
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto& p : region)
    for (const auto& q : p) {
      const double x = ca * double(q.X) + sa * double(q.Y);
      const double y = -sa * double(q.X) + ca * double(q.Y);
      xmin = std::min(xmin, x);
      xmax = std::max(xmax, x);
      ymin = std::min(ymin, y);
      ymax = std::max(ymax, y);
    }
  CPaths lines;
  if (xmin > xmax) return lines;
  const long k0 = static_cast<long>(std::ceil(ymin / spacing_um - 0.5));
  const long k1 = static_cast<long>(std::floor(ymax / spacing_um - 0.5));
  xmin -= 1000;
  xmax += 1000;
  for (long k = k0; k <= k1; ++k) {
    const double y = (double(k) + 0.5) * spacing_um;
    // Rotate back by +a.
    const IntPoint p0(std::llround(ca * xmin - sa * y), std::llround(sa * xmin + ca * y));
    const IntPoint p1(std::llround(ca * xmax - sa * y), std::llround(sa * xmax + ca * y));
    lines.push_back(CPath{p0, p1});
  }
  return lines;
}

}  // namespace

CPaths infill_lines(const CPaths& region, InfillPattern pattern, double spacing_um,
                    double angle_deg, int layer_index) {
  if (region.empty() || !(spacing_um > 0)) return {};
  switch (pattern) {
    case InfillPattern::rectilinear: {
      const double ang = angle_deg + ((layer_index % 2) != 0 ? 90.0 : 0.0);
      return clip_lines(line_field(region, spacing_um, ang), region);
    }
    case InfillPattern::grid: {
      CPaths lines = line_field(region, 2 * spacing_um, angle_deg);
      CPaths more = line_field(region, 2 * spacing_um, angle_deg + 90);
      lines.insert(lines.end(), more.begin(), more.end());
      return clip_lines(lines, region);
    }
    case InfillPattern::triangles: {
      CPaths lines;
      for (int k = 0; k < 3; ++k) {
        CPaths more = line_field(region, 3 * spacing_um, angle_deg + 60.0 * k);
        lines.insert(lines.end(), more.begin(), more.end());
      }
      return clip_lines(lines, region);
    }
    case InfillPattern::concentric: {
      CPaths out;
      CPaths cur = offset(region, -0.5 * spacing_um);
      for (int guard = 0; !cur.empty() && guard < 10000; ++guard) {
        for (auto p : cur) {
          if (p.size() < 3) continue;
          p.push_back(p.front());  // closed loop written as an open polyline
          out.push_back(std::move(p));
        }
        cur = offset(cur, -spacing_um);
      }
      return out;
    }
  }
  return {};
}

}  // namespace printtwin::slice_detail
