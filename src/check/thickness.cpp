// Wall thickness and gap width by ray casting along face normals (MeshQuery / Embree).
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "check/check_internal.hpp"
#include "core/plain_path.hpp"
#include "mesh/mesh_query_rays.hpp"
#include "printtwin/check.hpp"
#include "printtwin/mesh_query.hpp"

namespace printtwin {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// A gap counts only between surfaces that face each other within 30 degrees: a concave
/// corner between two faces at an angle is not a gap.
const double kFacingCos = std::cos(30.0 * 3.14159265358979323846 / 180.0);

const double kWallCos = std::cos(60.0 * 3.14159265358979323846 / 180.0);

bool shares_vertex(const Mesh& mesh, std::size_t f, std::size_t g) {
  for (auto a : mesh.triangles[f])
    for (auto b : mesh.triangles[g])
      if (a == b) return true;
  return false;
}

struct FaceSample {
  double thickness_mm = kInf;
  double gap_mm = kInf;
};

/// Faces inside the solid (a shell overlapping or touching another): the point just off
/// the face, outside its own shell, is still inside the part when the surfaces crossed along
/// its normal, exits minus entries, number more than zero. Such a face is no surface of the
/// print: it casts no ray and rays pass through it.
std::vector<char> internal_faces(const Mesh& mesh, const MeshQuery& query, const Vec3& shift,
                                 double t_min) {
  const std::size_t nf = mesh.triangles.size();
  std::vector<char> internal(nf, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 1024),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        Vec3 n = triangle_normal(mesh, f);
                        const double len = n.norm();
                        if (!(len > 0)) continue;
                        n /= len;
                        const Vec3 c = detail::face_centroid(mesh, f) - shift;
                        int winding = 0;
                        double t = t_min;
                        for (int i = 0; i < 256; ++i) {
                          auto hit = query.first_hit(c, n, t);
                          if (!hit) break;
                          if (hit->triangle != f) winding += hit->normal.dot(n) > 0 ? 1 : -1;
                          t = hit->t_mm + t_min;
                        }
                        internal[f] = winding > 0 ? 1 : 0;
                      }
                    });
  return internal;
}

/// The thinnest wall, the narrowest gap, and the faces under each limit.
ThicknessResult summarise(const Mesh& mesh, const std::vector<FaceSample>& samples,
                          double min_thickness_mm, double line_width_mm) {
  ThicknessResult out;
  out.min_thickness_mm = kInf;
  out.min_gap_mm = kInf;
  for (std::size_t f = 0; f < samples.size(); ++f) {
    const FaceSample& s = samples[f];
    if (s.thickness_mm == kInf && s.gap_mm == kInf) continue;
    const double area = 0.5 * triangle_normal(mesh, f).norm();
    const Vec3 c = detail::face_centroid(mesh, f);
    // The least value and where; the faces under the limit (1 um of slack: a 0.4 mm wall
    // stored in float STL coordinates measures 0.39999 mm), their area and extent.
    const auto tally = [&](double value, double limit, double& least, Vec3& at, std::size_t& faces,
                           double& faces_area, Box3& box) {
      if (value < least) {
        least = value;
        at = c;
      }
      if (value < limit - 1e-3) {
        ++faces;
        faces_area += area;
        for (auto v : mesh.triangles[f]) box.extend(mesh.vertices_mm[v]);
      }
    };
    tally(s.thickness_mm, min_thickness_mm, out.min_thickness_mm, out.min_thickness_at_mm,
          out.thin_faces, out.thin_area_mm2, out.thin_bbox_mm);
    tally(s.gap_mm, line_width_mm, out.min_gap_mm, out.min_gap_at_mm, out.narrow_gap_faces,
          out.narrow_gap_area_mm2, out.narrow_gap_bbox_mm);
  }
  return out;
}

}  // namespace

Result<ThicknessResult> measure_thickness(const Mesh& mesh, double min_thickness_mm,
                                          double line_width_mm, const MeshQuery* prebuilt,
                                          const Vec3& query_offset_mm, bool beyond_limit,
                                          bool skip_internal_faces) {
  std::optional<MeshQuery> own;
  if (prebuilt == nullptr) {
    // One pass of rays: the BVH for rays only builds about four times faster than the full
    // one and traces a little slower (PRINTTWIN_PLAIN=check_bvh_rays builds the full one).
    auto built = detail::plain_path("check_bvh_rays") ? MeshQuery::build(mesh)
                                                      : MeshQuery::build_for_rays(mesh);
    if (!built) return built.error();
    own.emplace(std::move(*built));
  }
  const MeshQuery& query = prebuilt != nullptr ? *prebuilt : *own;
  const Vec3 shift = prebuilt != nullptr ? query_offset_mm : Vec3::Zero();
  const std::size_t nf = mesh.triangles.size();
  // Start rays a little off the surface: Embree works in float on coordinates centred on
  // the mesh, so hits closer than ~1e-4 mm of the origin are the face itself or a neighbour.
  const double t_min = 1e-4 + 1e-7 * bounding_box(mesh).size().norm();

  // Faces inside the solid cast no ray, and rays pass through them.
  const std::vector<char> internal =
      skip_internal_faces ? internal_faces(mesh, query, shift, t_min) : std::vector<char>(nf, 0);
  std::vector<FaceSample> samples(nf);
  // First hit along the ray that is not an internal face or f itself, given the first hit
  // from t0 on (`hit`): at most 64 hits are looked at.
  auto first_surface = [&](std::optional<RayHit> hit, const Vec3& c, const Vec3& dir, double t1,
                           std::size_t f) -> std::optional<RayHit> {
    for (int i = 1;; ++i) {
      if (!hit || (hit->triangle != f && !internal[hit->triangle])) return hit;
      if (i == 64) return std::nullopt;
      hit = query.first_hit(c, dir, hit->t_mm + t_min, t1);
    }
  };

  // The rays of a group of faces; inward ones end at `inward_max`. Neighbouring faces' rays
  // are traced as one stream (detail::first_hits: the same hits as one by one, faster;
  // PRINTTWIN_PLAIN=check_ray_stream traces them one by one).
  const bool stream = !detail::plain_path("check_ray_stream");
  struct Scratch {
    std::vector<std::uint32_t> faces;
    std::vector<Vec3> normal;
    std::vector<detail::RayRequest> rays;
    std::vector<std::optional<RayHit>> hits;
  };
  auto sample_faces = [&](std::span<const std::uint32_t> group, double inward_max, Scratch& sc) {
    sc.faces.clear();
    sc.normal.clear();
    sc.rays.clear();
    for (const std::uint32_t f : group) {
      Vec3 n = triangle_normal(mesh, f);
      const double len = n.norm();
      if (!(len > 0) || detail::is_degenerate_face(mesh, f) || internal[f]) {
        samples[f] = FaceSample{};
        continue;
      }
      n /= len;
      sc.faces.push_back(f);
      sc.normal.push_back(n);
      sc.rays.push_back({detail::face_centroid(mesh, f) - shift, -n, t_min, inward_max});
    }
    const std::size_t m = sc.faces.size();
    // Outward: the same origins, up to four line widths.
    for (std::size_t i = 0; i < m; ++i)
      sc.rays.push_back({sc.rays[i].origin, sc.normal[i], t_min, line_width_mm * 4});
    sc.hits.resize(sc.rays.size());
    if (stream) {
      detail::first_hits(query, sc.rays, sc.hits);
    } else {
      for (std::size_t i = 0; i < sc.rays.size(); ++i)
        sc.hits[i] =
            query.first_hit(sc.rays[i].origin, sc.rays[i].dir, sc.rays[i].t_min, sc.rays[i].t_max);
    }
    for (std::size_t i = 0; i < m; ++i) {
      const std::uint32_t f = sc.faces[i];
      const Vec3& n = sc.normal[i];
      const Vec3& c = sc.rays[i].origin;
      FaceSample sample;
      // Inward: the first surface hit from behind is the far side of the wall.
      if (auto hit = first_surface(sc.hits[i], c, -n, inward_max, f)) {
        // The far side of a wall faces back within 60 degrees and is no neighbour of f: a
        // ray leaving through a face beside f (a corner or a chamfer) measures no wall.
        if (hit->normal.dot(-n) > kWallCos && !shares_vertex(mesh, f, hit->triangle))
          sample.thickness_mm = hit->t_mm;
      }
      // Outward: the first surface hit head-on, facing back at us, bounds the gap.
      if (auto hit = first_surface(sc.hits[m + i], c, n, line_width_mm * 4, f)) {
        if (hit->normal.dot(n) < -kFacingCos && !shares_vertex(mesh, f, hit->triangle))
          sample.gap_mm = hit->t_mm;
      }
      samples[f] = sample;
    }
  };
  // Groups of neighbouring faces (by index) for one stream of rays.
  constexpr std::size_t kGroup = 16;
  tbb::enumerable_thread_specific<Scratch> scratch;
  tbb::enumerable_thread_specific<std::vector<std::uint32_t>> group_of;
  auto sample_range = [&](std::size_t begin, std::size_t end, std::size_t step, double inward_max,
                          auto&& keep) {
    auto& sc = scratch.local();
    auto& group = group_of.local();
    group.clear();
    for (std::size_t f = begin; f < end; f += step) {
      if (!keep(f)) continue;
      group.push_back(static_cast<std::uint32_t>(f));
      if (group.size() == kGroup) {
        sample_faces(group, inward_max, sc);
        group.clear();
      }
    }
    if (!group.empty()) sample_faces(group, inward_max, sc);
    group.clear();
  };

  // Within the limit, an inward ray's first hit is the unbounded ray's whenever that one is
  // thin. Beyond it, only the thinnest wall is reported, so an inward ray need not look
  // farther than a wall already measured: every kStride-th face is cast without limit
  // first, and the others stop just past the thinnest of those (the thinnest wall and every
  // thin face come out the same; PRINTTWIN_PLAIN=check_ray_bound casts them all unbounded).
  constexpr std::size_t kStride = 16;
  const bool bound = beyond_limit && !detail::plain_path("check_ray_bound");
  double inward_max = beyond_limit ? kInf : min_thickness_mm;
  const auto all = [](std::size_t) { return true; };
  if (bound) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (nf + kStride - 1) / kStride, 64),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        sample_range(r.begin() * kStride, std::min(nf, r.end() * kStride), kStride,
                                     kInf, all);
                      });
    double thinnest = kInf;
    for (std::size_t f = 0; f < nf; f += kStride)
      thinnest = std::min(thinnest, samples[f].thickness_mm);
    if (thinnest < kInf) inward_max = std::max(thinnest, min_thickness_mm) * (1 + 1e-6);
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 1024),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      sample_range(r.begin(), r.end(), 1, inward_max,
                                   [&](std::size_t f) { return !bound || f % kStride != 0; });
                    });

  return summarise(mesh, samples, min_thickness_mm, line_width_mm);
}

}  // namespace printtwin
