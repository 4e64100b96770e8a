// Orientation advice: which side of the part to stand on the bed (least overhang, most contact).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kMaxFlatFaces = 20;

/// Rotation that turns `down` to -Z: a quarter or half turn about an axis for the axis
/// directions, the shortest turn otherwise.
Vec3 rotation_for(const Vec3& down) {
  const Vec3 target(0, 0, -1);
  Eigen::Matrix3d r;
  if (down.dot(target) < -1 + 1e-12) {
    r = Eigen::AngleAxisd(kPi, Vec3::UnitX()).toRotationMatrix();  // upside down: half turn about X
  } else {
    r = Eigen::Quaterniond::FromTwoVectors(down, target).toRotationMatrix();
  }
  Vec3 deg = xyz_deg_of(r);
  for (int i = 0; i < 3; ++i) {
    deg[i] = std::round(deg[i] * 1e6) / 1e6;
    if (deg[i] == 0) deg[i] = 0;  // no -0
  }
  return deg;
}

void score(const Mesh& mesh, const std::vector<Vec3>& normals, const std::vector<double>& areas,
           const CheckSettings& s, OrientationCandidate& c) {
  const Vec3 up = -c.down;
  double zmin = std::numeric_limits<double>::infinity(), zmax = -zmin;
  std::vector<double> z(mesh.vertices_mm.size());
  for (std::size_t v = 0; v < z.size(); ++v) {
    z[v] = mesh.vertices_mm[v].dot(up);
    zmin = std::min(zmin, z[v]);
    zmax = std::max(zmax, z[v]);
  }
  const double limit = std::sin((s.overhang_angle_deg + 0.01) * kPi / 180.0);
  c.overhang_mm2 = c.contact_mm2 = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!(areas[f] > 0)) continue;
    const double down = normals[f].dot(c.down);
    if (down <= 0) continue;
    bool on_bed = true;
    for (auto v : mesh.triangles[f]) on_bed = on_bed && z[v] - zmin <= s.bed_contact_mm;
    if (on_bed)
      c.contact_mm2 += areas[f];
    else if (down > limit)
      c.overhang_mm2 += areas[f];
  }
  c.height_mm = zmax - zmin;
  c.score = c.overhang_mm2 - c.contact_mm2;
}

/// The six axis directions down (-Z, +Z, +X, -X, +Y, -Y), scored in one pass over the faces:
/// along an axis a vertex's height is its coordinate (or its negation), so a face rests on
/// the bed when its box's far side along the axis lies within the contact band of the
/// mesh's extreme, and leans down by its normal's coordinate. The same figures as `score`
/// for each direction, summed in the same face order.
void score_axes(const Mesh& mesh, const std::vector<Vec3>& normals,
                const std::vector<double>& areas, const CheckSettings& s,
                std::array<OrientationCandidate, 6>& c) {
  constexpr std::array<int, 6> kAxis{2, 2, 0, 0, 1, 1};
  constexpr std::array<double, 6> kSign{-1, 1, 1, -1, 1, -1};  // the down direction's sign
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Vec3& v : mesh.vertices_mm) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double limit = std::sin((s.overhang_angle_deg + 0.01) * kPi / 180.0);
  for (std::size_t k = 0; k < 6; ++k) {
    c[k].down = Vec3::Zero();
    c[k].down[kAxis[k]] = kSign[k];
    c[k].overhang_mm2 = c[k].contact_mm2 = 0;
    c[k].height_mm = hi[kAxis[k]] - lo[kAxis[k]];
  }
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!(areas[f] > 0)) continue;
    const auto& t = mesh.triangles[f];
    const Vec3 &p = mesh.vertices_mm[t[0]], &q = mesh.vertices_mm[t[1]],
               &r = mesh.vertices_mm[t[2]];
    const Vec3 fmin = p.cwiseMin(q).cwiseMin(r), fmax = p.cwiseMax(q).cwiseMax(r);
    for (std::size_t k = 0; k < 6; ++k) {
      const int a = kAxis[k];
      const double down = kSign[k] * normals[f][a];
      if (down <= 0) continue;
      // Up is -down: heights are -sign x the coordinate, lowest at the extreme on the down side.
      const bool on_bed =
          kSign[k] < 0 ? fmax[a] - lo[a] <= s.bed_contact_mm : hi[a] - fmin[a] <= s.bed_contact_mm;
      if (on_bed)
        c[k].contact_mm2 += areas[f];
      else if (down > limit)
        c[k].overhang_mm2 += areas[f];
    }
  }
  for (auto& x : c) x.score = x.overhang_mm2 - x.contact_mm2;
}

}  // namespace

Mesh rotated_mesh(const Mesh& mesh, const Vec3& rotation_xyz_deg) {
  const Eigen::Matrix3d r = rotation_from_xyz_deg(rotation_xyz_deg);
  Mesh out = mesh;
  for (auto& v : out.vertices_mm) v = r * v;
  return out;
}

OrientationAdvice advise_orientation(const Mesh& mesh, const CheckSettings& s) {
  OrientationAdvice adv;
  const std::size_t nf = mesh.triangles.size();
  std::vector<Vec3> normals(nf);
  std::vector<double> areas(nf);
  double total = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const Vec3 n = triangle_normal(mesh, f);
    areas[f] = 0.5 * n.norm();
    normals[f] = areas[f] > 0 ? Vec3(n.normalized()) : Vec3::Zero();
    total += areas[f];
  }
  std::vector<OrientationCandidate> cands;
  auto add = [&](const Vec3& down, std::string label) {
    for (const auto& c : cands)
      if (c.down.dot(down) > std::cos(1.0 * kPi / 180.0)) return;
    OrientationCandidate c;
    c.down = down;
    c.label = std::move(label);
    c.rotation_xyz_deg = rotation_for(down);
    score(mesh, normals, areas, s, c);
    cands.push_back(std::move(c));
  };
  std::array<OrientationCandidate, 6> axes;
  score_axes(mesh, normals, areas, s, axes);
  const std::array<const char*, 6> axis_labels{"as modelled",  "upside down (+Z down)",
                                               "+X side down", "-X side down",
                                               "+Y side down", "-Y side down"};
  for (std::size_t k = 0; k < 6; ++k) {
    axes[k].label = axis_labels[k];
    axes[k].rotation_xyz_deg = rotation_for(axes[k].down);
    cands.push_back(std::move(axes[k]));
  }
  // Flat faces: normals equal within ~0.6 degrees, by area. Faces are grouped by their
  // normal rounded to 0.01 per axis (in [-100, 100]: 8 bits each), groups in key order and
  // each group summed in face order.
  std::vector<std::uint64_t> keyed;
  keyed.reserve(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    if (!(areas[f] > 0)) continue;
    const Vec3& n = normals[f];
    std::uint64_t key = 0;
    for (int a = 0; a < 3; ++a)
      key = (key << 8) | static_cast<std::uint64_t>(std::lround(n[a] * 100) + 100);
    keyed.push_back((key << 32) | f);
  }
  // Sorted by key, faces ascending within a key (pushed in face order; the sort is stable).
  detail::radix_sort_stable(
      keyed, [](std::uint64_t k) { return k >> 32; }, 24);
  std::vector<std::pair<double, Vec3>> flat;
  for (std::size_t i = 0; i < keyed.size();) {
    std::size_t j = i;
    double area = 0;
    Vec3 weighted = Vec3::Zero();
    for (; j < keyed.size() && keyed[j] >> 32 == keyed[i] >> 32; ++j) {
      const std::size_t f = keyed[j] & 0xFFFFFFFFU;
      area += areas[f];
      weighted += areas[f] * normals[f];
    }
    if (area >= 0.01 * total && weighted.norm() > 0) flat.push_back({area, weighted.normalized()});
    i = j;
  }
  std::stable_sort(flat.begin(), flat.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (std::size_t i = 0; i < flat.size() && i < kMaxFlatFaces; ++i)
    add(flat[i].second, "its flat face of " + format_fixed(flat[i].first, 1) + " mm2");
  adv.candidates = cands.size();
  adv.current = cands.front();
  adv.best = cands.front();
  for (const auto& c : cands)
    if (c.score < adv.best.score - 1e-9 ||
        (std::abs(c.score - adv.best.score) <= 1e-9 && c.height_mm < adv.best.height_mm - 1e-9))
      adv.best = c;
  const double saved = adv.current.overhang_mm2 - adv.best.overhang_mm2;
  adv.better = (saved >= 1.0 && saved >= 0.1 * adv.current.overhang_mm2) ||
               (saved >= 0 && adv.best.contact_mm2 > adv.current.contact_mm2 + 1.0 &&
                adv.best.score < adv.current.score - 1.0);
  return adv;
}

}  // namespace printtwin
