// Registration, second half: the pose of the mesh on the bed. Candidate orientations and
// unit scales by height, the Z angle from the minimum-area rectangles of both footprints,
// ICP of the outer-wall points against the mesh, a score of residual and coverage.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "deviation/registration_internal.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"
#include "printtwin/mesh_query.hpp"

namespace printtwin {

namespace {

using Mat3 = Eigen::Matrix3d;

constexpr double kQuarter = M_PI / 2;
/// Mesh units the search tries when they are not given: mm, inch, cm, m, and their inverses.
constexpr std::array<double, 7> kUnitScales = {1.0, 25.4, 10.0, 1000.0, 1.0 / 25.4, 0.1, 0.001};

/// The rotation that puts mesh axis `i / 2` (sign + for even i) up; i = 0 is the identity.
Mat3 up_rotation(int i) {
  static constexpr std::array<std::pair<int, double>, 6> kUp = {
      {{2, 1.0}, {2, -1.0}, {0, 1.0}, {0, -1.0}, {1, 1.0}, {1, -1.0}}};
  const auto [axis, sign] = kUp[static_cast<std::size_t>(i)];
  const Vec3 r2 = sign * Vec3::Unit(axis);
  const Vec3 r0 = Vec3::Unit(axis == 0 ? 1 : 0);
  const Vec3 r1 = r2.cross(r0);
  Mat3 u;
  u.row(0) = r0.transpose();
  u.row(1) = r1.transpose();
  u.row(2) = r2.transpose();
  return u;
}

Mat3 rz(double angle) { return Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix(); }

/// Rotation about Z by k quarter turns, with exact entries.
Mat3 rz_quarter(int k) {
  static constexpr std::array<std::array<double, 2>, 4> kCs = {{{1, 0}, {0, 1}, {-1, 0}, {0, -1}}};
  const auto [c, s] = kCs[static_cast<std::size_t>(((k % 4) + 4) % 4)];
  Mat3 r;
  r << c, -s, 0, s, c, 0, 0, 0, 1;
  return r;
}

/// Minimum-area enclosing rectangle of a convex polygon: the angle of side a in [0, pi/2),
/// its length and the other side's.
struct Rect {
  double angle = 0, a = 0, b = 0;
};

Rect min_area_rect(const std::vector<Vec2>& hull) {
  Rect best;
  if (hull.empty()) return best;
  if (hull.size() < 3) {
    const Vec2 d = hull.back() - hull.front();
    best.a = std::abs(d.x());
    best.b = std::abs(d.y());
    return best;
  }
  double best_area = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const Vec2 e = hull[(i + 1) % hull.size()] - hull[i];
    if (e.norm() <= 0) continue;
    const Vec2 u = e.normalized(), v(-u.y(), u.x());
    double lu = 1e300, hu = -1e300, lv = 1e300, hv = -1e300;
    for (const Vec2& p : hull) {
      lu = std::min(lu, p.dot(u));
      hu = std::max(hu, p.dot(u));
      lv = std::min(lv, p.dot(v));
      hv = std::max(hv, p.dot(v));
    }
    const double area = (hu - lu) * (hv - lv);
    if (area < best_area * (1 - 1e-9)) {
      best_area = area;
      double angle = std::atan2(u.y(), u.x());
      double a = hu - lu, b = hv - lv;
      const int quarters = static_cast<int>(std::floor(angle / kQuarter));
      angle -= quarters * kQuarter;
      if (quarters % 2 != 0) std::swap(a, b);
      best = {angle, a, b};
    }
  }
  return best;
}

/// One pose being tried: x' = s * rz(theta) * up * x + t.
struct Pose {
  const PrintedObject* object = nullptr;
  int up = 0;
  Mat3 up_matrix = Mat3::Identity();
  double scale = 1;
  double theta = 0;
  Vec3 t = Vec3::Zero();
  double size_error = 0;  ///< height/footprint mismatch in tolerances (<= 1: plausible)
  double rms = 0, p50 = 0, coverage = 0, score = 0;
  [[nodiscard]] Mat3 rotation() const { return rz(theta) * up_matrix; }
};

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

class Search {
 public:
  Search(const Mesh& mesh, const MeshQuery& query, const PartExtent& part)
      : mesh_(mesh),
        query_(query),
        layer_(part.layer_height_mm > 0 ? part.layer_height_mm : 0.2),
        walls_tagged_(part.walls_tagged) {
    const double area = surface_area_mm2(mesh);
    const double spacing = area > 0 ? std::sqrt(area / 1500.0) : 1.0;
    for (const auto& s : sample_surface(mesh, spacing, 7))
      coverage_samples_.push_back(s.position_mm);
    if (coverage_samples_.empty()) coverage_samples_ = mesh.vertices_mm;
  }

  /// Bounding box of the mesh under rotation r and scale s.
  [[nodiscard]] Box3 rotated_box(const Mat3& r, double s) const {
    Box3 b;
    for (const Vec3& v : mesh_.vertices_mm) b.extend(s * (r * v));
    return b;
  }

  /// Translation that centres the rotated mesh's box on the object's box in XY and puts the
  /// lowest point at z = 0 (the way slicers place parts).
  [[nodiscard]] Vec3 centred(const Mat3& r, double s, const PrintedObject& o) const {
    const Box3 b = rotated_box(r, s);
    const Vec3 oc = o.bbox_mm.center(), mc = b.center();
    return Vec3(oc.x() - mc.x(), oc.y() - mc.y(), -b.min.z());
  }

  /// Distances of `points` to the mesh under the pose (machine frame, mm).
  void distances(const Mat3& r, double s, const Vec3& t, std::span<const Vec3> points,
                 std::vector<double>& d, std::vector<Vec3>* closest_machine = nullptr) {
    q_.resize(points.size());
    const Mat3 rt = r.transpose();
    for (std::size_t i = 0; i < points.size(); ++i) q_[i] = rt * (points[i] - t) / s;
    // The closest triangles of the previous query of the same points (the last ICP step, or
    // the pose before) bound each search from the start; the answers are the same.
    if (hint_points_ != points.data() || hints_.size() != points.size()) hints_.clear();
    query_.closest_points(q_, cp_, hints_);
    hint_points_ = points.data();
    hints_.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) hints_[i] = cp_[i].triangle;
    d.resize(points.size());
    if (closest_machine != nullptr) closest_machine->resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Vec3 c = s * (r * cp_[i].point_mm) + t;
      d[i] = (points[i] - c).norm();
      if (closest_machine != nullptr) (*closest_machine)[i] = c;
    }
  }

  /// ICP about Z: rotation angle and XY translation of the pose, Z kept.
  void refine(Pose& pose, std::span<const Vec3> points, int iterations) {
    std::vector<double> d;
    std::vector<Vec3> c;
    for (int it = 0; it < iterations; ++it) {
      distances(pose.rotation(), pose.scale, pose.t, points, d, &c);
      const double keep = std::max(3.0 * median_of(d), 1.0);
      Vec2 mc = Vec2::Zero(), mp = Vec2::Zero();
      std::size_t n = 0;
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (d[i] > keep) continue;
        mc += c[i].head<2>();
        mp += points[i].head<2>();
        ++n;
      }
      if (n < 3) return;
      mc /= static_cast<double>(n);
      mp /= static_cast<double>(n);
      double sxx = 0, sxy = 0;  // cross-covariance terms of the 2-D Procrustes problem
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (d[i] > keep) continue;
        const Vec2 a = c[i].head<2>() - mc, b = points[i].head<2>() - mp;
        sxx += a.dot(b);
        sxy += a.x() * b.y() - a.y() * b.x();
      }
      const double delta = std::atan2(sxy, sxx);
      const Eigen::Rotation2Dd r2(delta);
      const Vec2 shift = mp - r2 * mc;
      pose.theta += delta;
      const Vec2 txy = r2 * pose.t.head<2>() + shift;
      const double moved = (txy - pose.t.head<2>()).norm();
      pose.t.head<2>() = txy;
      if (std::abs(delta) < 1e-6 && moved < 1e-4) break;  // 0.00006 degrees, 0.1 um
    }
  }

  /// Share of the mesh surface with printed extrusions in a neighbouring cell.
  [[nodiscard]] double coverage(const Mat3& r, double s, const Vec3& t,
                                const PrintedObject& o) const {
    if (coverage_samples_.empty() || o.cells.empty()) return 0;
    std::size_t covered = 0;
    for (const Vec3& p : coverage_samples_) {
      const Vec3 c = (s * (r * p) + t - o.cell_origin_mm) / o.cell_mm;
      const int x = static_cast<int>(std::floor(c.x())), y = static_cast<int>(std::floor(c.y())),
                z = static_cast<int>(std::floor(c.z()));
      bool hit = false;
      for (int dz = -1; dz <= 1 && !hit; ++dz)
        for (int dy = -1; dy <= 1 && !hit; ++dy)
          for (int dx = -1; dx <= 1 && !hit; ++dx) {
            if (x + dx < 0 || y + dy < 0 || z + dz < 0) continue;
            hit = std::binary_search(o.cells.begin(), o.cells.end(),
                                     detail::cell_key(x + dx, y + dy, z + dz));
          }
      covered += hit ? 1 : 0;
    }
    return static_cast<double>(covered) / static_cast<double>(coverage_samples_.size());
  }

  /// Residual, coverage and score of a pose on `points` (the object's walls or a subset).
  void evaluate(Pose& pose, std::span<const Vec3> points) {
    std::vector<double> d;
    distances(pose.rotation(), pose.scale, pose.t, points, d);
    double sum = 0;
    for (const double x : d) sum += x * x;
    pose.rms = d.empty() ? 0 : std::sqrt(sum / static_cast<double>(d.size()));
    pose.p50 = median_of(d);
    pose.coverage = coverage(pose.rotation(), pose.scale, pose.t, *pose.object);
    // Untagged G-code: the "walls" include infill inside the part, so the median is the
    // residual that tells; with wall tags the RMS.
    pose.score = residual(pose) + 5.0 * (1.0 - pose.coverage);
  }

  [[nodiscard]] double residual(const Pose& pose) const {
    return walls_tagged_ ? pose.rms : pose.p50;
  }
  [[nodiscard]] double layer() const { return layer_; }
  [[nodiscard]] bool walls_tagged() const { return walls_tagged_; }

 private:
  const Mesh& mesh_;
  const MeshQuery& query_;
  double layer_;
  bool walls_tagged_;
  std::vector<Vec3> coverage_samples_;
  std::vector<Vec3> q_;
  std::vector<ClosestPoint> cp_;
  const Vec3* hint_points_ = nullptr;  ///< the points `hints_` were found for
  std::vector<std::uint32_t> hints_;
};

/// Every `stride`-th point, at most `n`.
std::vector<Vec3> subset(const std::vector<Vec3>& points, std::size_t n) {
  if (points.size() <= n) return points;
  std::vector<Vec3> out;
  out.reserve(n);
  const double step = static_cast<double>(points.size()) / static_cast<double>(n);
  for (std::size_t i = 0; i < n; ++i)
    out.push_back(points[static_cast<std::size_t>(static_cast<double>(i) * step)]);
  return out;
}

bool names_object(const PrintedObject& o, const std::string& wanted) {
  return o.name == wanted ||
         (o.id >= 0 && (wanted == std::to_string(o.id) || wanted == "#" + std::to_string(o.id)));
}

/// The candidates `options.object` allows (those with wall points). Error: it names none.
Result<std::vector<const PrintedObject*>> objects_to_match(const PartExtent& part,
                                                           const RegistrationOptions& options) {
  std::vector<const PrintedObject*> objects;
  for (const auto& o : part.objects)
    if (options.object.empty() || names_object(o, options.object)) objects.push_back(&o);
  if (objects.empty() && !options.object.empty()) {
    std::string list;
    for (const auto& o : part.objects)
      if (o.id >= 0) list += (list.empty() ? "" : ", ") + ("'" + o.name + "'");
    return usage_error(
        "--object '" + options.object + "': the G-code has no such object" +
        (list.empty() ? std::string(" (it labels none)") : " (it has " + list + ")"));
  }
  std::erase_if(objects, [](const PrintedObject* o) { return o->wall_points_mm.empty(); });
  return objects;
}

std::string size_text(const Vec3& v) {
  return format_fixed(v.x(), 1) + " x " + format_fixed(v.y(), 1) + " x " + format_fixed(v.z(), 1) +
         " mm";
}

/// Fills the report fields of `reg` from the chosen pose, the mismatch verdict included.
void describe(Registration& reg, const Pose& pose, const Search& search, const Mesh& mesh) {
  const PrintedObject& o = *pose.object;
  reg.object = o.name;
  reg.object_id = o.id;
  reg.object_bbox_mm = o.bbox_mm;
  reg.residual_rms_mm = pose.rms;
  reg.residual_p50_mm = pose.p50;
  reg.coverage_pct = 100.0 * pose.coverage;
  reg.wall_points = o.wall_points_mm.size();
  reg.mesh_size_mm = bounding_box(transformed(mesh, reg.transform)).size();
  reg.printed_size_mm = o.bbox_mm.size();
  const double limit = std::max(1.0, 4.0 * search.layer());
  const double res = search.residual(pose);
  std::string why;
  if (pose.size_error > 1)
    why = "its size matches no orientation of the mesh";
  else if (res > limit)
    why = "its walls lie " + format_fixed(res, 2) + " mm from the mesh (" +
          (search.walls_tagged() ? "RMS" : "median") + "; a match gives about half a bead, limit " +
          format_fixed(limit, 2) + " mm)";
  else if (pose.coverage < 0.7)
    why = "it covers only " + format_fixed(100.0 * pose.coverage, 0) + " % of the mesh surface";
  if (!why.empty()) {
    reg.matches = false;
    reg.mismatch = "the G-code does not appear to be this part: " + why + "; printed " +
                   size_text(reg.printed_size_mm) + " (extrusion centre lines), mesh as placed " +
                   size_text(reg.mesh_size_mm);
  }
}

}  // namespace

/// The pose to report, from the best fit: the unrotated pose when it fits as well (a
/// symmetric part), then a quarter-turn angle taken exactly when it fits as well. Sets
/// `reg.transform.rotation`; true when the slicer's centring was kept exactly.
bool settle_pose(Search& search, Pose& best, Registration& reg) {
  // A symmetric part (a cube, a cylinder) fits several poses equally well: keep it as
  // designed when the unrotated pose fits as well as the best, so that the report does not
  // claim a turn the slicer never made.
  const auto fits_as_well = [&search](const Pose& p, const Pose& than) {
    return search.residual(p) <=
           search.residual(than) + std::max(0.01, 0.02 * search.residual(than));
  };
  if (!best.rotation().isIdentity(1e-9)) {
    Pose upright = best;
    upright.up_matrix = Mat3::Identity();
    upright.theta = 0;
    upright.t = search.centred(Mat3::Identity(), best.scale, *best.object);
    search.evaluate(upright, best.object->wall_points_mm);
    if (fits_as_well(upright, best)) best = upright;
  }

  // Slicers rotate by whole degrees and most parts not at all: a quarter-turn angle within
  // half a degree that fits as well (with the slicer's centring) is taken exactly.
  const double quarters = std::round(best.theta / kQuarter);
  bool exact = false;
  if (std::abs(best.theta - quarters * kQuarter) < 0.5 * M_PI / 180) {
    Pose snapped = best;
    const Mat3 r = rz_quarter(static_cast<int>(quarters)) * best.up_matrix;
    snapped.theta = quarters * kQuarter;
    snapped.t = search.centred(r, best.scale, *best.object);
    search.evaluate(snapped, best.object->wall_points_mm);
    if (fits_as_well(snapped, best)) {
      best = snapped;
      reg.transform.rotation = r;
      exact = true;
    }
  }
  if (!exact) reg.transform.rotation = best.rotation();
  return exact;
}

Result<Registration> register_mesh(const Mesh& mesh, const MeshQuery& query, const PartExtent& part,
                                   const RegistrationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto chosen = objects_to_match(part, options);
  if (!chosen) return chosen.error();
  const std::vector<const PrintedObject*>& objects = *chosen;
  if (objects.empty())
    return bad_input("the G-code has no extrusion of the part to register the mesh against");
  if (mesh.vertices_mm.empty()) return bad_input("registration: the mesh has no vertices");

  Search search(mesh, query, part);
  const double layer = search.layer();
  std::vector<double> scales;
  if (options.scale)
    scales.push_back(*options.scale);
  else
    scales.assign(kUnitScales.begin(), kUnitScales.end());
  const int ups = options.allow_rotation ? 6 : 1;

  // Candidate poses, each with its size error (height and footprint against the object's).
  std::vector<Pose> candidates;
  std::vector<Pose> fallback;  // when no candidate is plausible: the closest in size
  for (int u = 0; u < ups; ++u) {
    const Mat3 up = up_rotation(u);
    std::vector<Vec2> xy;
    xy.reserve(mesh.vertices_mm.size());
    double lo = 1e300, hi = -1e300;
    for (const Vec3& v : mesh.vertices_mm) {
      const Vec3 w = up * v;
      xy.push_back(w.head<2>());
      lo = std::min(lo, w.z());
      hi = std::max(hi, w.z());
    }
    const Rect mesh_rect = min_area_rect(detail::convex_hull(std::move(xy)));
    for (const PrintedObject* o : objects) {
      const Rect printed = min_area_rect(o->hull_xy_mm);
      const double height = o->bbox_mm.max.z();
      for (const double s : scales) {
        const double h_tol = std::max({2.5 * layer, 0.03 * height, 0.6});
        const double h_err = std::abs(s * (hi - lo) - height) / h_tol;
        const int quarters = options.allow_rotation ? 4 : 1;
        for (int k = 0; k < quarters; ++k) {
          const double ma = s * (k % 2 == 0 ? mesh_rect.a : mesh_rect.b);
          const double mb = s * (k % 2 == 0 ? mesh_rect.b : mesh_rect.a);
          const double f_tol = std::max(2.0, 0.08 * std::max(ma, mb));
          // Without feature tags the print may hold supports and brims beside the part: only
          // a print smaller than the mesh rules the pose out.
          const double f_err =
              part.walls_tagged
                  ? std::max(std::abs(ma - printed.a), std::abs(mb - printed.b)) / f_tol
                  : std::max({ma - printed.a, mb - printed.b, 0.0}) / f_tol;
          Pose p;
          p.object = o;
          p.up = u;
          p.up_matrix = up;
          p.scale = s;
          p.theta = options.allow_rotation ? printed.angle - mesh_rect.angle + k * kQuarter : 0.0;
          p.size_error = std::max(h_err, f_err);
          (p.size_error <= 1 ? candidates : fallback).push_back(p);
        }
      }
    }
  }
  const auto by_size = [](const Pose& a, const Pose& b) { return a.size_error < b.size_error; };
  if (candidates.empty()) {
    std::stable_sort(fallback.begin(), fallback.end(), by_size);
    fallback.resize(std::min<std::size_t>(fallback.size(), 4));
    candidates = std::move(fallback);
  }
  std::stable_sort(candidates.begin(), candidates.end(), by_size);
  if (candidates.size() > 32) candidates.resize(32);

  // Coarse ICP on a few hundred wall points for each candidate.
  int tried = 0;
  const auto coarse = [&](Pose& p) {
    const std::vector<Vec3> pts = subset(p.object->wall_points_mm, 300);
    p.t = search.centred(p.rotation(), p.scale, *p.object);
    if (options.allow_rotation)
      search.refine(p, pts, 12);
    else
      search.refine(p, pts, 0);
    search.evaluate(p, pts);
    ++tried;
  };
  for (Pose& p : candidates) coarse(p);
  const auto by_score = [](const Pose& a, const Pose& b) { return a.score < b.score; };
  std::stable_sort(candidates.begin(), candidates.end(), by_score);
  // A footprint whose rectangle says little (round, square-ish): sweep the Z angle.
  if (options.allow_rotation && search.residual(candidates.front()) > std::max(0.75, 3 * layer)) {
    std::vector<Pose> sweep;
    for (std::size_t i = 0; i < std::min<std::size_t>(candidates.size(), 2); ++i)
      for (int a = 0; a < 24; ++a) {
        Pose p = candidates[i];
        p.theta = a * (M_PI / 12);
        coarse(p);
        sweep.push_back(p);
      }
    candidates.insert(candidates.end(), sweep.begin(), sweep.end());
    std::stable_sort(candidates.begin(), candidates.end(), by_score);
  }
  // Fine ICP on up to 1500 wall points for the two best, scored on every wall point.
  const std::size_t finalists = std::min<std::size_t>(candidates.size(), 2);
  for (std::size_t i = 0; i < finalists; ++i) {
    Pose& p = candidates[i];
    if (options.allow_rotation) search.refine(p, subset(p.object->wall_points_mm, 1500), 20);
    search.evaluate(p, p.object->wall_points_mm);
  }
  std::stable_sort(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(finalists),
                   by_score);
  Pose best = candidates.front();
  Registration reg;
  const bool exact = settle_pose(search, best, reg);
  reg.transform.scale = best.scale;
  reg.transform.translation_mm = best.t;
  reg.candidates = tried;
  reg.method = std::string("auto (") + part.method + (exact ? ", slicer centring" : ", ICP") + ")";
  describe(reg, best, search, mesh);
  reg.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return reg;
}

Result<Registration> evaluate_registration(const Mesh& mesh, const MeshQuery& query,
                                           const PartExtent& part, const RigidTransform& transform,
                                           const RegistrationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto chosen = objects_to_match(part, options);
  if (!chosen) return chosen.error();
  Search search(mesh, query, part);
  std::optional<Pose> best;
  for (const PrintedObject* o : *chosen) {
    Pose p;
    p.object = o;
    p.up_matrix = transform.rotation;
    p.scale = transform.scale;
    p.t = transform.translation_mm;
    search.evaluate(p, o->wall_points_mm);
    if (!best || p.score < best->score) best = p;
  }
  Registration reg;
  reg.transform = transform;
  reg.method = "--place";
  if (best) describe(reg, *best, search, mesh);
  reg.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return reg;
}

}  // namespace printtwin
