// measure_intersection_effect: what self-intersecting faces do to the layer outlines.
//
// Each sampled layer is cut across the whole mesh; the cut segments are oriented by the face
// normals (outer loops counter-clockwise) and chained into loops over shared edges. With the
// loops' signed area sum S (the integral of the winding number w), the area with w > 0 (P,
// what union slicers print) and with w < 0 (N), the area enclosed more than once is
// S + N - P (exact while w >= -1), and N is the area folded inside out.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <polyclipping/clipper.hpp>
#include <utility>
#include <vector>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"

namespace printtwin {

namespace {

constexpr double kUnitsPerMm = 1e4;  // Clipper integer coordinates: 0.1 um
constexpr std::size_t kMaxLayers = 400;
/// Areas below this per layer are float noise of slivers (a 0.03 mm square).
constexpr double kNoiseAreaMm2 = 1e-3;

struct LayerArea {
  double twice_mm2 = 0;
  double inverted_mm2 = 0;
};

double area_mm2(const ClipperLib::Paths& paths) {
  double a = 0;
  for (const auto& p : paths) a += ClipperLib::Area(p);
  return a / (kUnitsPerMm * kUnitsPerMm);
}

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

LayerArea cut_layer(const Mesh& mesh, const std::vector<std::uint32_t>& by_zmin,
                    const std::vector<double>& zmin, const std::vector<double>& zmax, double zp) {
  struct Segment {
    std::uint64_t from = 0, to = 0;  // down-crossing edge -> up-crossing edge
    ClipperLib::IntPoint start;
  };
  std::vector<Segment> segs;
  const auto end = std::upper_bound(by_zmin.begin(), by_zmin.end(), zp,
                                    [&](double z, std::uint32_t f) { return z < zmin[f]; });
  for (auto it = by_zmin.begin(); it != end; ++it) {
    const std::uint32_t f = *it;
    if (!(zmax[f] > zp)) continue;
    const auto& t = mesh.triangles[f];
    Segment s;
    int found = 0;
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t u = t[i], v = t[(i + 1) % 3];
      const Vec3& pu = mesh.vertices_mm[u];
      const Vec3& pv = mesh.vertices_mm[v];
      const bool au = pu.z() > zp, av = pv.z() > zp;
      if (au == av) continue;
      ++found;
      if (au) {  // above -> below: the segment starts here; the point from the canonical edge
        const Vec3& lo = u < v ? pu : pv;
        const Vec3& hi = u < v ? pv : pu;
        const double k = (zp - lo.z()) / (hi.z() - lo.z());
        const Vec3 p = lo + k * (hi - lo);
        s.from = edge_key(u, v);
        s.start =
            ClipperLib::IntPoint(static_cast<ClipperLib::cInt>(std::llround(p.x() * kUnitsPerMm)),
                                 static_cast<ClipperLib::cInt>(std::llround(p.y() * kUnitsPerMm)));
      } else {
        s.to = edge_key(u, v);
      }
    }
    if (found == 2) segs.push_back(s);
  }
  // Chain: the segment leaving edge e follows the one arriving at e.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> starts(segs.size());
  for (std::size_t i = 0; i < segs.size(); ++i)
    starts[i] = {segs[i].from, static_cast<std::uint32_t>(i)};
  std::sort(starts.begin(), starts.end());
  std::vector<char> used(segs.size(), 0);
  ClipperLib::Paths loops;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    if (used[i]) continue;
    ClipperLib::Path loop;
    std::size_t cur = i;
    while (true) {
      used[cur] = 1;
      loop.push_back(segs[cur].start);
      auto it = std::lower_bound(starts.begin(), starts.end(),
                                 std::make_pair(segs[cur].to, std::uint32_t{0}));
      while (it != starts.end() && it->first == segs[cur].to && used[it->second]) ++it;
      if (it == starts.end() || it->first != segs[cur].to) break;
      cur = it->second;
    }
    if (loop.size() >= 3) loops.push_back(std::move(loop));
  }
  LayerArea out;
  if (loops.empty()) return out;
  const double sum = area_mm2(loops);
  ClipperLib::Paths pos, neg;
  {
    ClipperLib::Clipper c;
    c.AddPaths(loops, ClipperLib::ptSubject, true);
    c.Execute(ClipperLib::ctUnion, pos, ClipperLib::pftPositive, ClipperLib::pftPositive);
  }
  {
    ClipperLib::Clipper c;
    c.AddPaths(loops, ClipperLib::ptSubject, true);
    c.Execute(ClipperLib::ctUnion, neg, ClipperLib::pftNegative, ClipperLib::pftNegative);
  }
  const double p = area_mm2(pos);
  const double n = std::abs(area_mm2(neg));
  out.inverted_mm2 = n;
  out.twice_mm2 = std::max(0.0, sum + n - p);
  return out;
}

}  // namespace

IntersectionEffect measure_intersection_effect(const Mesh& mesh,
                                               const std::vector<std::uint32_t>& faces,
                                               double layer_height_mm) {
  IntersectionEffect eff;
  eff.layer_height_mm = layer_height_mm;
  if (faces.empty() || !(layer_height_mm > 0)) return eff;
  const std::size_t nf = mesh.triangles.size();
  std::vector<double> zmin(nf), zmax(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = mesh.triangles[f];
    const double a = mesh.vertices_mm[t[0]].z(), b = mesh.vertices_mm[t[1]].z(),
                 c = mesh.vertices_mm[t[2]].z();
    zmin[f] = std::min({a, b, c});
    zmax[f] = std::max({a, b, c});
  }
  const double z0 = *std::min_element(zmin.begin(), zmin.end());
  // Layer k is cut at z0 + (k + 0.5) h: the layers the intersecting faces span.
  std::vector<long long> ks;
  Box3 faces_box;
  for (auto f : faces) {
    const long long lo = static_cast<long long>(std::ceil((zmin[f] - z0) / layer_height_mm - 0.5));
    const long long hi = static_cast<long long>(std::floor((zmax[f] - z0) / layer_height_mm - 0.5));
    for (long long k = std::max(lo, 0LL); k <= hi && k - lo < 100000; ++k) ks.push_back(k);
    for (auto v : mesh.triangles[f]) faces_box.extend(mesh.vertices_mm[v]);
  }
  std::sort(ks.begin(), ks.end());
  ks.erase(std::unique(ks.begin(), ks.end()), ks.end());
  eff.layers = ks.size();
  std::vector<long long> cut = ks;
  if (cut.size() > kMaxLayers) {
    cut.clear();
    for (std::size_t i = 0; i < kMaxLayers; ++i) cut.push_back(ks[i * ks.size() / kMaxLayers]);
  }
  std::vector<std::uint32_t> by_zmin(nf);
  for (std::size_t f = 0; f < nf; ++f) by_zmin[f] = static_cast<std::uint32_t>(f);
  std::sort(by_zmin.begin(), by_zmin.end(), [&](std::uint32_t a, std::uint32_t b) {
    return zmin[a] < zmin[b] || (zmin[a] == zmin[b] && a < b);
  });
  std::vector<LayerArea> areas(cut.size());
  tbb::parallel_for(std::size_t{0}, cut.size(), [&](std::size_t i) {
    areas[i] = cut_layer(mesh, by_zmin, zmin, zmax,
                         z0 + (static_cast<double>(cut[i]) + 0.5) * layer_height_mm);
  });
  // Each cut layer stands for ks.size() / cut.size() layers.
  const double weight =
      cut.empty() ? 0.0 : static_cast<double>(ks.size()) / static_cast<double>(cut.size());
  double changed = 0;
  double zlo = std::numeric_limits<double>::infinity(), zhi = -zlo;
  for (std::size_t i = 0; i < cut.size(); ++i) {
    const LayerArea& a = areas[i];
    const double twice = a.twice_mm2 > kNoiseAreaMm2 ? a.twice_mm2 : 0.0;
    const double inv = a.inverted_mm2 > kNoiseAreaMm2 ? a.inverted_mm2 : 0.0;
    if (twice == 0 && inv == 0) continue;
    changed += weight;
    eff.twice_volume_mm3 += weight * twice * layer_height_mm;
    eff.inverted_volume_mm3 += weight * inv * layer_height_mm;
    eff.max_twice_area_mm2 = std::max(eff.max_twice_area_mm2, twice);
    eff.max_inverted_area_mm2 = std::max(eff.max_inverted_area_mm2, inv);
    const double z = z0 + static_cast<double>(cut[i]) * layer_height_mm;
    zlo = std::min(zlo, z);
    zhi = std::max(zhi, z + layer_height_mm);
  }
  eff.layers_changed = static_cast<std::size_t>(std::llround(changed));
  if (eff.layers_changed > 0) {
    eff.changed_bbox_mm.extend(Vec3(faces_box.min.x(), faces_box.min.y(), zlo));
    eff.changed_bbox_mm.extend(Vec3(faces_box.max.x(), faces_box.max.y(), zhi));
  }
  eff.measured = true;
  return eff;
}

}  // namespace printtwin
