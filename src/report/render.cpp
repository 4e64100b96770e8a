// Heatmap renders of the part: orthographic views rasterised (per pixel centre, the nearest
// triangle along the view direction), coloured by signed deviation and shaded with two
// Lambert lights.
//
// Colour comes from the mesh-surface samples (mesh -> deposit distances, dense: one per
// voxel-sized patch) splatted into the image and depth-tested against the ray-cast depth
// buffer, so details finer than the mesh's triangles (a dropped thin wall on a 12-triangle
// box) still show. Pixels no sample reaches fall back to the per-vertex deviation
// interpolated with barycentric coordinates.
//
// A render has two halves: trace_heatmap_view (camera fit, raster, lighting and outlines; the
// mesh and the view only) and shade_heatmap (colours from one deviation result). Reports of
// several results on the same placed mesh (compare's variants) trace once (HeatmapCache).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "printtwin/report.hpp"
#include "report/heatmap.hpp"

namespace printtwin {

namespace {

using Rgb = std::array<std::uint8_t, 3>;

struct ColorStop {
  double t;
  double r, g, b;
};

Rgb lerp_stops(const ColorStop* stops, int n, double t) {
  t = std::clamp(t, 0.0, 1.0);
  int i = 0;
  while (i + 2 < n && t > stops[i + 1].t) ++i;
  const ColorStop& a = stops[i];
  const ColorStop& b = stops[i + 1];
  const double s = (b.t > a.t) ? std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0) : 0.0;
  auto mix = [s](double x, double y) {
    return static_cast<std::uint8_t>(std::lround(x + (y - x) * s));
  };
  return {mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b)};
}

// Sequential ramps after ColorBrewer's Blues/Reds (light near the tolerance, dark at range).
constexpr ColorStop kExcess[] = {
    {0.0, 253, 174, 107}, {0.35, 241, 105, 19}, {0.7, 203, 24, 29}, {1.0, 127, 0, 13}};
constexpr ColorStop kDeficit[] = {
    {0.0, 140, 198, 230}, {0.35, 66, 146, 198}, {0.7, 33, 97, 172}, {1.0, 8, 48, 107}};
// Within tolerance: green, leaning teal on the deficit side and yellow-green on the excess
// side, so the sign reads even inside the band without competing with the shading.
constexpr ColorStop kWithin[] = {{0.0, 84, 178, 160}, {0.5, 65, 171, 93}, {1.0, 166, 206, 96}};

double nice_ceil(double v) {
  if (!(v > 0)) return 1.0;
  const double e = std::pow(10.0, std::floor(std::log10(v)));
  for (double m : {1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0})
    if (m * e >= v * (1 - 1e-12)) return m * e;
  return 10 * e;
}

}  // namespace

Rgb DeviationColorScale::color(double d_mm) const {
  const double tol = std::max(tolerance_mm, 1e-9);
  const double range = std::max(range_mm, tol * 1.0001);
  if (!std::isfinite(d_mm)) return {200, 200, 200};
  const double a = std::abs(d_mm);
  if (a <= tol) return lerp_stops(kWithin, 3, 0.5 + 0.5 * d_mm / tol);
  const double t = (a - tol) / (range - tol);
  return d_mm > 0 ? lerp_stops(kExcess, 4, t) : lerp_stops(kDeficit, 4, t);
}

DeviationColorScale make_color_scale(const DeviationResult& deviation) {
  DeviationColorScale s;
  s.tolerance_mm = deviation.tolerance_mm > 0 ? deviation.tolerance_mm : 0.2;
  double worst = 0;
  for (double d : deviation.vertex_deviation_mm)
    if (std::isfinite(d)) worst = std::max(worst, std::abs(d));
  for (const double d : deviation.mesh_samples.distances_mm)
    if (std::isfinite(d)) worst = std::max(worst, std::abs(d));
  worst = std::max({worst, std::abs(deviation.mesh_to_deposit.min_mm),
                    std::abs(deviation.mesh_to_deposit.max_mm)});
  s.range_mm = std::clamp(nice_ceil(worst), 2 * s.tolerance_mm, 10 * s.tolerance_mm);
  return s;
}

std::vector<ViewSpec> default_views() {
  const double s = 1.0 / std::sqrt(3.0);
  return {
      // Looking from the front-left-top corner down to the back-right: the classic iso.
      ViewSpec{"iso", "Isometric", Vec3(s, s, -s), Vec3(0, 0, 1), 720, 540},
      ViewSpec{"front", "Front (-Y)", Vec3(0, 1, 0), Vec3(0, 0, 1), 360, 300},
      ViewSpec{"right", "Right (+X)", Vec3(-1, 0, 0), Vec3(0, 0, 1), 360, 300},
      ViewSpec{"top", "Top (+Z)", Vec3(0, 0, -1), Vec3(0, 1, 0), 360, 300},
      ViewSpec{"back_iso", "Back isometric", Vec3(-s, -s, -s), Vec3(0, 0, 1), 360, 300},
  };
}

Vec2 Camera::project(const Vec3& p_mm) const {
  const Vec3 d = p_mm - center_mm;
  return Vec2(0.5 * width_px + d.dot(right) / mm_per_px, 0.5 * height_px - d.dot(up) / mm_per_px);
}

TracedView trace_heatmap_view(const Mesh& mesh, const ViewSpec& view) {
  TracedView out;
  out.view = view;
  Camera& cam = out.camera;
  cam.forward = view.direction.normalized();
  Vec3 up_hint = view.up;
  if (std::abs(up_hint.normalized().dot(cam.forward)) > 0.999) up_hint = Vec3(0, 1, 0);
  cam.right = cam.forward.cross(up_hint).normalized();
  cam.up = cam.right.cross(cam.forward).normalized();

  // Fit the part: extents along the image axes and depth.
  double min_x = 1e300, max_x = -1e300, min_y = 1e300, max_y = -1e300, min_z = 1e300,
         max_z = -1e300;
  for (const Vec3& v : mesh.vertices_mm) {
    const double x = v.dot(cam.right), y = v.dot(cam.up), z = v.dot(cam.forward);
    min_x = std::min(min_x, x), max_x = std::max(max_x, x);
    min_y = std::min(min_y, y), max_y = std::max(max_y, y);
    min_z = std::min(min_z, z), max_z = std::max(max_z, z);
  }
  const int margin_px = 10;
  const int max_w = std::max(view.width_px, 2 * margin_px + 8);
  const int max_h = std::max(view.height_px, 2 * margin_px + 8);
  const double ex = std::max(max_x - min_x, 1e-6), ey = std::max(max_y - min_y, 1e-6);
  cam.mm_per_px = std::max(ex / (max_w - 2 * margin_px), ey / (max_h - 2 * margin_px));
  cam.width_px = std::min(max_w, static_cast<int>(std::ceil(ex / cam.mm_per_px)) + 2 * margin_px);
  cam.height_px = std::min(max_h, static_cast<int>(std::ceil(ey / cam.mm_per_px)) + 2 * margin_px);
  cam.center_mm = cam.right * (0.5 * (min_x + max_x)) + cam.up * (0.5 * (min_y + max_y)) +
                  cam.forward * (0.5 * (min_z + max_z));
  const int w = cam.width_px, h = cam.height_px;
  const double depth = max_z - min_z;
  const double pad = 0.01 * depth + 1.0;
  out.near_offset_mm = 0.5 * depth + pad;

  // Per pixel: triangle, depth from the pixel's ray origin, unit normal. Each triangle is
  // projected (pixel (x, y)'s centre at (x, y)) and the pixel centres inside it take it when
  // it is nearer than what they hold; triangles go in index order and only a strictly nearer
  // one replaces, so equal depths keep the lowest index.
  constexpr std::uint32_t kNone = TracedView::kNoHit;
  std::vector<std::uint32_t>& tri = out.triangle;
  std::vector<float>& tdepth = out.depth_mm;
  std::vector<Vec3>& normal = out.normal;
  tri.assign(static_cast<std::size_t>(w) * h, kNone);
  tdepth.assign(tri.size(), 0.f);
  normal.assign(tri.size(), Vec3::Zero());
  {
    std::vector<Vec2> px(mesh.vertices_mm.size());
    std::vector<double> pz(mesh.vertices_mm.size());
    for (std::size_t v = 0; v < px.size(); ++v) {
      const Vec3 d = mesh.vertices_mm[v] - cam.center_mm;
      px[v] = Vec2(d.dot(cam.right) / cam.mm_per_px + 0.5 * w - 0.5,
                   0.5 * h - 0.5 - d.dot(cam.up) / cam.mm_per_px);
      pz[v] = d.dot(cam.forward) + out.near_offset_mm;
    }
    std::vector<double> nearest(tri.size(), std::numeric_limits<double>::infinity());
    const auto edge = [](const Vec2& a, const Vec2& b, const Vec2& p) {
      return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
    };
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      const auto& f = mesh.triangles[t];
      const Vec2 &a = px[f[0]], &b = px[f[1]], &c = px[f[2]];
      const double area = edge(a, b, c);
      if (!(std::abs(area) > 0) || !std::isfinite(area)) continue;  // edge-on: no pixel sees it
      const Vec2 lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
      const int x0 = std::max(0, static_cast<int>(std::ceil(lo.x()))),
                x1 = std::min(w - 1, static_cast<int>(std::floor(hi.x())));
      const int y0 = std::max(0, static_cast<int>(std::ceil(lo.y()))),
                y1 = std::min(h - 1, static_cast<int>(std::floor(hi.y())));
      if (x0 > x1 || y0 > y1) continue;
      const double inv = 1.0 / area;
      Vec3 n = triangle_normal(mesh, t);
      if (const double len = n.norm(); len > 0) n /= len;
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const Vec2 p(x, y);
          // Barycentric weights (either winding: both faces are seen).
          const double l0 = edge(b, c, p) * inv, l1 = edge(c, a, p) * inv, l2 = edge(a, b, p) * inv;
          if (l0 < 0 || l1 < 0 || l2 < 0) continue;
          const double z = l0 * pz[f[0]] + l1 * pz[f[1]] + l2 * pz[f[2]];
          const std::size_t i = static_cast<std::size_t>(y) * w + x;
          if (!(z < nearest[i])) continue;
          nearest[i] = z;
          tri[i] = static_cast<std::uint32_t>(t);
          tdepth[i] = static_cast<float>(z);
          normal[i] = n;
        }
    }
  }

  // Lighting: two Lambert lights, creases and depth steps outlined (darkened where a
  // neighbour differs a lot).
  const Vec3 key_light = (-cam.forward + 0.55 * cam.up - 0.45 * cam.right).normalized();
  const Vec3 fill_light = (-cam.forward - 0.2 * cam.up + 0.8 * cam.right).normalized();
  out.shade.assign(tri.size(), 0.0);
  const double edge_depth = 3.0 * cam.mm_per_px;
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        if (tri[i] == kNone) continue;
        const Vec3& n = normal[i];
        const Vec3 ns = n.dot(cam.forward) > 0 ? Vec3(-n) : n;
        double shade = 0.46 + 0.54 * std::max(0.0, ns.dot(key_light)) +
                       0.16 * std::max(0.0, ns.dot(fill_light));
        auto differs = [&](int xx, int yy) {
          if (xx < 0 || yy < 0 || xx >= w || yy >= h) return true;
          const std::size_t j = static_cast<std::size_t>(yy) * w + xx;
          if (tri[j] == kNone) return true;
          if (std::abs(tdepth[j] - tdepth[i]) > edge_depth) return true;
          return normal[j].dot(n) < 0.82;  // crease > ~35 degrees
        };
        if (differs(x + 1, y) || differs(x, y + 1) || differs(x - 1, y) || differs(x, y - 1))
          shade *= 0.72;
        out.shade[i] = std::min(shade, 1.12);
      }
  });
  out.hit_pixels = static_cast<std::size_t>(
      std::count_if(tri.begin(), tri.end(), [](std::uint32_t t) { return t != kNone; }));
  return out;
}

Vec3 TracedView::pixel_origin(int x, int y) const {
  const Camera& cam = camera;
  return cam.center_mm + cam.right * ((x + 0.5 - 0.5 * cam.width_px) * cam.mm_per_px) -
         cam.up * ((y + 0.5 - 0.5 * cam.height_px) * cam.mm_per_px) - cam.forward * near_offset_mm;
}

namespace {
/// Deviation per pixel: the sum and count of the samples that landed on it.
struct PixelDeviation {
  std::vector<float> sum;
  std::vector<std::uint16_t> count;
};

/// Everything the depth test and the accumulation touch per pixel, in one 24-byte record
/// (samples arrive in mesh order, not image order: one cache line per sample instead of
/// one per array). The per-pixel depth window is computed once, not per sample.
struct SplatPixel {
  double window = -1;  ///< largest accepted |sample depth - surface depth|; < 0: no surface
  float depth = 0;
  float sum = 0;
  std::uint16_t count = 0;
};

/// Projects mesh-surface samples into a traced view.
struct SampleProjector {
  const Camera& cam;
  std::span<const Vec3> positions;
  std::span<const double> values;
  int radius_px;
  double inv_px;
  /// Image position (fx, fy) of sample k and its offset d from the camera centre; false when
  /// it falls outside the image (plus the splat radius) or has no finite value.
  bool operator()(std::size_t k, double& fx, double& fy, Vec3& d) const {
    const int w = cam.width_px, h = cam.height_px;
    d = positions[k] - cam.center_mm;
    fx = 0.5 * w + d.dot(cam.right) * inv_px;
    fy = 0.5 * h - d.dot(cam.up) * inv_px;
    return fx >= -radius_px && fy >= -radius_px && fx < w + radius_px && fy < h + radius_px &&
           std::isfinite(values[k]);
  }
};

/// One pixel per sample: the samples are bucketed by bands of 16 rows first (a stable
/// counting sort, so each pixel still sums its samples in sample order), then splatted band
/// by band with the band's pixels in cache.
void splat_one_pixel_each(const SampleProjector& project, std::size_t stride, double near_offset,
                          std::vector<SplatPixel>& splat) {
  const Camera& cam = project.cam;
  const int w = cam.width_px, h = cam.height_px;
  const std::size_t n = project.positions.size();
  constexpr int kBandRows = 16;
  const std::size_t bands = static_cast<std::size_t>((h + kBandRows - 1) / kBandRows);
  struct Drop {
    double t;
    std::uint32_t pixel;
    float value;
  };
  std::vector<std::size_t> start(bands + 1, 0);
  double fx = 0, fy = 0;
  Vec3 d;
  for (std::size_t k = 0; k < n; k += stride)
    if (project(k, fx, fy, d)) ++start[static_cast<std::size_t>(fy) / kBandRows + 1];
  for (std::size_t b = 1; b <= bands; ++b) start[b] += start[b - 1];
  std::vector<Drop> drops(start[bands]);
  for (std::size_t k = 0; k < n; k += stride) {
    if (!project(k, fx, fy, d)) continue;
    const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
    drops[start[static_cast<std::size_t>(cy) / kBandRows]++] = {
        d.dot(cam.forward) + near_offset,
        static_cast<std::uint32_t>(static_cast<std::size_t>(cy) * w + cx),
        static_cast<float>(project.values[k])};
  }
  for (const Drop& drop : drops) {
    SplatPixel& p = splat[drop.pixel];
    if (!(std::abs(drop.t - p.depth) <= p.window)) continue;
    p.sum += drop.value;
    if (p.count < 65535) ++p.count;
  }
}

/// Samples larger than a pixel: each covers a square of radius_px around its pixel.
void splat_squares(const SampleProjector& project, std::size_t stride, double near_offset,
                   std::vector<SplatPixel>& splat) {
  const Camera& cam = project.cam;
  const int w = cam.width_px, h = cam.height_px;
  const int radius_px = project.radius_px;
  for (std::size_t k = 0; k < project.positions.size(); k += stride) {
    double fx = 0, fy = 0;
    Vec3 d;
    if (!project(k, fx, fy, d)) continue;
    const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
    const double sample_t = d.dot(cam.forward) + near_offset;
    const auto value = static_cast<float>(project.values[k]);
    for (int yy = std::max(cy - radius_px, 0); yy <= std::min(cy + radius_px, h - 1); ++yy) {
      for (int xx = std::max(cx - radius_px, 0); xx <= std::min(cx + radius_px, w - 1); ++xx) {
        SplatPixel& p = splat[static_cast<std::size_t>(yy) * w + xx];
        if (!(std::abs(sample_t - p.depth) <= p.window)) continue;
        p.sum += value;
        if (p.count < 65535) ++p.count;
      }
    }
  }
}

/// Hole fill: a surface pixel no sample reached takes the mean of the splatted neighbours
/// within 2 px at a similar depth.
void fill_holes(const TracedView& traced, double depth_tol, PixelDeviation& dev) {
  const int w = traced.camera.width_px, h = traced.camera.height_px;
  const std::vector<std::uint32_t>& tri = traced.triangle;
  const std::vector<float>& tdepth = traced.depth_mm;
  std::vector<float> fill_value(tri.size(), 0.f);
  std::vector<char> filled(tri.size(), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        if (tri[i] == TracedView::kNoHit || dev.count[i] > 0) continue;
        double sum = 0;
        std::size_t n = 0;
        for (int yy = std::max(y - 2, 0); yy <= std::min(y + 2, h - 1); ++yy)
          for (int xx = std::max(x - 2, 0); xx <= std::min(x + 2, w - 1); ++xx) {
            const std::size_t j = static_cast<std::size_t>(yy) * w + xx;
            if (dev.count[j] == 0 || std::abs(tdepth[j] - tdepth[i]) > 3 * depth_tol) continue;
            sum += dev.sum[j];
            n += dev.count[j];
          }
        if (n > 0) fill_value[i] = static_cast<float>(sum / static_cast<double>(n)), filled[i] = 1;
      }
  });
  for (std::size_t i = 0; i < tri.size(); ++i)
    if (filled[i]) dev.sum[i] = fill_value[i], dev.count[i] = 1;
}

/// Deviation per pixel from the mesh-surface samples, splatted and depth-tested. A sample
/// stands for a patch of ~spacing; when that is about a pixel or less, each sample lands on
/// one pixel and the few pixels no sample reached are filled from their neighbours.
PixelDeviation splat_samples(const TracedView& traced, const Mesh& mesh,
                             const SurfaceDeviationField& field) {
  const Camera& cam = traced.camera;
  const std::vector<std::uint32_t>& tri = traced.triangle;
  PixelDeviation dev{std::vector<float>(tri.size(), 0.f),
                     std::vector<std::uint16_t>(tri.size(), 0)};
  double spacing = field.sample_spacing_mm;
  if (!(spacing > 0) && !field.sample_positions_mm.empty())
    spacing =
        std::sqrt(surface_area_mm2(mesh) / static_cast<double>(field.sample_positions_mm.size()));
  if (field.sample_positions_mm.empty() || !(spacing > 0)) return dev;
  const int radius_px =
      spacing > 1.5 * cam.mm_per_px
          ? std::min(static_cast<int>(std::lround(0.5 * spacing / cam.mm_per_px)), 6)
          : 0;
  const double depth_tol = 1.5 * std::max(spacing, cam.mm_per_px) + 0.02;
  // Many samples per pixel (dense sampling, small image): a regular subset carries the same
  // picture; keep about 3 per pixel.
  const double per_px = (cam.mm_per_px / spacing) * (cam.mm_per_px / spacing);
  const std::size_t stride =
      radius_px == 0 ? std::max<std::size_t>(1, static_cast<std::size_t>(per_px / 3.0)) : 1;
  std::vector<SplatPixel> splat(tri.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tri.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        if (tri[i] == TracedView::kNoHit) continue;
                        // Slanted faces change depth across a pixel: widen the test where they are
                        // steep.
                        const double slope = std::abs(traced.normal[i].dot(cam.forward));
                        splat[i].window = depth_tol / std::max(slope, 0.25);
                        splat[i].depth = traced.depth_mm[i];
                      }
                    });
  const SampleProjector project{cam, field.sample_positions_mm, field.sample_distances_mm,
                                radius_px, 1.0 / cam.mm_per_px};
  if (radius_px == 0)
    splat_one_pixel_each(project, stride, traced.near_offset_mm, splat);
  else
    splat_squares(project, stride, traced.near_offset_mm, splat);
  for (std::size_t i = 0; i < tri.size(); ++i)
    dev.sum[i] = splat[i].sum, dev.count[i] = splat[i].count;
  fill_holes(traced, depth_tol, dev);
  return dev;
}

/// Where no sample reached a pixel: the per-vertex deviation interpolated at the hit point
/// with barycentric coordinates (double precision).
double vertex_deviation_at(const TracedView& traced, const Mesh& mesh,
                           const SurfaceDeviationField& field, int x, int y, std::size_t i) {
  const Camera& cam = traced.camera;
  const auto& t = mesh.triangles[traced.triangle[i]];
  const Vec3& a = mesh.vertices_mm[t[0]];
  const Vec3& b = mesh.vertices_mm[t[1]];
  const Vec3& c = mesh.vertices_mm[t[2]];
  const Vec3 v0 = b - a, v1 = c - a,
             v2 = traced.pixel_origin(x, y) + cam.forward * traced.depth_mm[i] - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1);
  const double d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double den = d00 * d11 - d01 * d01;
  double bv = 0, bw = 0;
  if (std::abs(den) > 0) {
    bv = std::clamp((d11 * d20 - d01 * d21) / den, 0.0, 1.0);
    bw = std::clamp((d00 * d21 - d01 * d20) / den, 0.0, 1.0 - bv);
  }
  return (1 - bv - bw) * field.vertex_deviation_mm[t[0]] + bv * field.vertex_deviation_mm[t[1]] +
         bw * field.vertex_deviation_mm[t[2]];
}
}  // namespace

HeatmapView shade_heatmap(const TracedView& traced, const Mesh& mesh,
                          const SurfaceDeviationField& field, const DeviationColorScale& scale) {
  HeatmapView out;
  out.view = traced.view;
  out.camera = traced.camera;
  out.hit_pixels = traced.hit_pixels;
  const Camera& cam = traced.camera;
  const int w = cam.width_px, h = cam.height_px;
  constexpr std::uint32_t kNone = TracedView::kNoHit;
  const std::vector<std::uint32_t>& tri = traced.triangle;
  const std::vector<Vec3>& normal = traced.normal;
  const PixelDeviation dev = splat_samples(traced, mesh, field);
  const bool have_vertex = !field.vertex_deviation_mm.empty() &&
                           field.vertex_deviation_mm.size() == mesh.vertices_mm.size();

  // Colour, times the traced lighting.
  out.image.width = w;
  out.image.height = h;
  out.image.rgba.assign(tri.size() * 4, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * w + x;
        std::uint8_t* px = &out.image.rgba[4 * i];
        if (tri[i] == kNone) continue;
        const bool back = normal[i].dot(cam.forward) > 0;
        Rgb base{176, 176, 176};
        if (!back) {
          if (dev.count[i] > 0)
            base = scale.color(static_cast<double>(dev.sum[i]) / dev.count[i]);
          else if (have_vertex)
            base = scale.color(vertex_deviation_at(traced, mesh, field, x, y, i));
          else
            base = {205, 205, 205};  // no deviation data here
        }
        const double shade = traced.shade[i];
        for (int k = 0; k < 3; ++k)
          px[k] = static_cast<std::uint8_t>(std::clamp(std::lround(base[k] * shade), 0L, 255L));
        px[3] = 255;
      }
  });
  return out;
}

HeatmapView render_heatmap(const Mesh& mesh, const SurfaceDeviationField& field,
                           const DeviationColorScale& scale, const ViewSpec& view) {
  return shade_heatmap(trace_heatmap_view(mesh, view), mesh, field, scale);
}

std::vector<RegionMarker> mark_regions(const TracedView& traced,
                                       std::span<const DeviationRegion> regions) {
  const Camera& camera = traced.camera;
  std::vector<RegionMarker> out;
  out.reserve(regions.size());
  for (const auto& r : regions) {
    RegionMarker m;
    m.worst_px = camera.project(r.worst_position_mm);
    m.bbox_min_px = Vec2::Constant(1e300);
    m.bbox_max_px = Vec2::Constant(-1e300);
    if (!r.bbox_mm.empty()) {
      for (int c = 0; c < 8; ++c) {
        const Vec3 corner((c & 1) ? r.bbox_mm.max.x() : r.bbox_mm.min.x(),
                          (c & 2) ? r.bbox_mm.max.y() : r.bbox_mm.min.y(),
                          (c & 4) ? r.bbox_mm.max.z() : r.bbox_mm.min.z());
        const Vec2 p = camera.project(corner);
        m.bbox_min_px = m.bbox_min_px.cwiseMin(p);
        m.bbox_max_px = m.bbox_max_px.cwiseMax(p);
      }
    } else {
      m.bbox_min_px = m.bbox_max_px = m.worst_px;
    }
    // Hidden when the surface seen at the point's pixel is clearly in front of the point.
    m.visible = true;
    const double fx = std::floor(m.worst_px.x()), fy = std::floor(m.worst_px.y());
    if (fx >= 0 && fy >= 0 && fx < camera.width_px && fy < camera.height_px) {
      const int x = static_cast<int>(fx), y = static_cast<int>(fy);
      const std::size_t i = static_cast<std::size_t>(y) * camera.width_px + x;
      if (traced.triangle[i] != TracedView::kNoHit) {
        const double point_depth =
            (r.worst_position_mm - traced.pixel_origin(x, y)).dot(camera.forward);
        m.visible = traced.depth_mm[i] >= point_depth - (3.0 * camera.mm_per_px + 0.1);
      }
    }
    out.push_back(m);
  }
  return out;
}

}  // namespace printtwin
