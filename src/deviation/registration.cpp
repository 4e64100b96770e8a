// Registration, first half: find the part (or the objects) among the extrusions and sample
// them for the pose search (registration_search.cpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include "core/plain_path.hpp"
#include "deviation/disjoint_sets.hpp"
#include "deviation/registration_internal.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {

using detail::DisjointSets;

/// Points every `spacing` mm along the moves (half a spacing in from the first start), in
/// move order.
void sample_along(const std::vector<const Move*>& moves, double spacing, std::size_t max_points,
                  std::vector<Vec3>& out) {
  double carry = 0.5 * spacing;  // distance to the next point
  for (const Move* m : moves) {
    const double len = m->length_mm();
    double at = carry;
    for (; at <= len && out.size() < max_points; at += spacing)
      out.push_back(m->start_mm + (m->end_mm - m->start_mm) * (at / len));
    carry = at - len;
  }
}

/// Evenly spaced points along the moves, at most `max_points`.
std::vector<Vec3> sample_evenly(const std::vector<const Move*>& moves, std::size_t max_points) {
  double total = 0;
  for (const Move* m : moves) total += m->length_mm();
  std::vector<Vec3> out;
  if (total <= 0) return out;
  const double spacing = std::max(0.2, total / static_cast<double>(max_points));
  out.reserve(std::min(max_points, static_cast<std::size_t>(total / spacing) + 2));
  sample_along(moves, spacing, max_points, out);
  return out;
}

bool is_outer_wall(Feature f) {
  return f == Feature::outer_perimeter || f == Feature::overhang_perimeter;
}

PrintedObject make_object(int id, std::string name, const std::vector<const Move*>& moves) {
  PrintedObject o;
  o.id = id;
  o.name = std::move(name);
  std::vector<const Move*> walls;
  double length = 0;
  for (const Move* m : moves) {
    o.bbox_mm.extend(m->start_mm);
    o.bbox_mm.extend(m->end_mm);
    o.extruded_mm += m->xy_length_mm();
    length += m->length_mm();
    if (is_outer_wall(m->feature)) walls.push_back(m);
  }
  o.moves = moves.size();
  const std::vector<const Move*>& outline = walls.empty() ? moves : walls;
  o.wall_points_mm = sample_evenly(outline, PrintedObject::kMaxWallSamples);
  std::vector<Vec2> ends;
  ends.reserve(2 * outline.size());
  for (const Move* m : outline) {
    ends.push_back(m->start_mm.head<2>());
    ends.push_back(m->end_mm.head<2>());
  }
  o.hull_xy_mm = detail::convex_hull(std::move(ends));
  // Occupancy: cells of at least 1 mm, at most about 4 million in the box.
  const Vec3 size = o.bbox_mm.size() + Vec3::Constant(1.0);
  o.cell_mm = std::max(1.0, std::cbrt(size.prod() / 4e6));
  o.cell_origin_mm = o.bbox_mm.min - Vec3::Constant(o.cell_mm);
  const double step = 0.5 * o.cell_mm;
  o.cells.reserve(static_cast<std::size_t>(length / step) + moves.size());
  for (const Move* m : moves) {
    const int n = std::max(1, static_cast<int>(std::ceil(m->length_mm() / step)));
    for (int i = 0; i <= n; ++i) {
      const Vec3 c = (m->start_mm + (m->end_mm - m->start_mm) * (static_cast<double>(i) / n) -
                      o.cell_origin_mm) /
                     o.cell_mm;
      o.cells.push_back(detail::cell_key(static_cast<int>(c.x()), static_cast<int>(c.y()),
                                         static_cast<int>(c.z())));
    }
  }
  std::sort(o.cells.begin(), o.cells.end());
  o.cells.erase(std::unique(o.cells.begin(), o.cells.end()), o.cells.end());
  o.cells.shrink_to_fit();
  return o;
}

/// Median Z step between the distinct heights of the extrusions (0 with fewer than 2).
double median_layer_step(const std::vector<const Move*>& moves) {
  std::vector<double> z;
  z.reserve(moves.size());
  for (const Move* m : moves) z.push_back(std::round(m->end_mm.z() * 1e3) / 1e3);
  std::sort(z.begin(), z.end());
  z.erase(std::unique(z.begin(), z.end()), z.end());
  std::vector<double> steps;
  for (std::size_t i = 1; i < z.size(); ++i) steps.push_back(z[i] - z[i - 1]);
  if (steps.empty()) return 0;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2),
                   steps.end());
  return steps[steps.size() / 2];
}

/// Groups of connected extrusions in XY (raster of kCell mm, 8-connected): per group its
/// moves, in move order, groups by first move.
std::vector<std::vector<const Move*>> footprint_groups(const std::vector<const Move*>& candidates,
                                                       std::vector<double>& group_weight) {
  constexpr double kCell = 0.5;
  Box3 all;
  for (const Move* m : candidates) {
    all.extend(m->start_mm);
    all.extend(m->end_mm);
  }
  const int nx = static_cast<int>(std::floor(all.size().x() / kCell)) + 1;
  const int ny = static_cast<int>(std::floor(all.size().y() / kCell)) + 1;
  const auto cell_of = [&](const Vec3& p) {
    const int x =
        std::clamp(static_cast<int>(std::floor((p.x() - all.min.x()) / kCell)), 0, nx - 1);
    const int y =
        std::clamp(static_cast<int>(std::floor((p.y() - all.min.y()) / kCell)), 0, ny - 1);
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(x);
  };
  std::vector<double> weight(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny), 0.0);
  std::vector<std::uint32_t> move_cell(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const Move& m = *candidates[i];
    const double len = m.xy_length_mm();
    const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.5 * kCell))));
    for (int s = 0; s <= steps; ++s) {
      const Vec3 p = m.start_mm + (m.end_mm - m.start_mm) * (static_cast<double>(s) / steps);
      weight[cell_of(p)] += len / (steps + 1);
    }
    move_cell[i] = static_cast<std::uint32_t>(cell_of(m.start_mm));
  }
  DisjointSets sets(weight.size());
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) {
      const std::size_t c = static_cast<std::size_t>(y) * nx + x;
      if (weight[c] == 0) continue;
      for (int dy = 0; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (dy == 0 && dx <= 0) continue;
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || xx >= nx || yy >= ny) continue;
          const std::size_t n = static_cast<std::size_t>(yy) * nx + xx;
          if (weight[n] > 0)
            sets.unite(static_cast<std::uint32_t>(c), static_cast<std::uint32_t>(n));
        }
    }
  std::map<std::uint32_t, std::size_t> group_of_root;  // in order of first move
  std::vector<std::vector<const Move*>> groups;
  group_weight.clear();
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const std::uint32_t root = sets.find(move_cell[i]);
    auto [it, inserted] = group_of_root.try_emplace(root, groups.size());
    if (inserted) {
      groups.emplace_back();
      group_weight.push_back(0);
    }
    groups[it->second].push_back(candidates[i]);
    group_weight[it->second] += candidates[i]->xy_length_mm();
  }
  return groups;
}

}  // namespace

namespace detail {

namespace {

/// Drops the points strictly inside the octagon of the extreme points in 8 directions
/// (Akl-Toussaint): they cannot be hull vertices. A margin far above rounding keeps every
/// point that could be one, so the hull is the same; the sort then has few points left.
void drop_inner_points(std::vector<Vec2>& p) {
  if (p.size() < 64) return;
  static constexpr std::array<std::array<double, 2>, 8> kDirections = {
      {{1, 0}, {1, 1}, {0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}}};
  std::array<std::size_t, 8> extreme{};
  std::array<double, 8> best;
  best.fill(-std::numeric_limits<double>::infinity());
  double reach = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    reach = std::max(reach, p[i].cwiseAbs().maxCoeff());
    for (std::size_t k = 0; k < kDirections.size(); ++k) {
      const double s = kDirections[k][0] * p[i].x() + kDirections[k][1] * p[i].y();
      if (s > best[k]) {
        best[k] = s;
        extreme[k] = i;
      }
    }
  }
  if (!std::isfinite(reach)) return;
  std::vector<Vec2> corners;  // counter-clockwise (support points by direction angle)
  for (const std::size_t i : extreme)
    if (corners.empty() || (p[i] != corners.back() && p[i] != corners.front()))
      corners.push_back(p[i]);
  if (corners.size() < 3) return;
  const double margin = 1e-9 * (1 + reach) * (1 + reach);
  std::erase_if(p, [&](const Vec2& q) {
    for (std::size_t k = 0; k < corners.size(); ++k) {
      const Vec2& a = corners[k];
      const Vec2& b = corners[(k + 1) % corners.size()];
      if ((b.x() - a.x()) * (q.y() - a.y()) - (b.y() - a.y()) * (q.x() - a.x()) <= margin)
        return false;
    }
    return true;
  });
}

}  // namespace

std::vector<Vec2> convex_hull(std::vector<Vec2> p) {
  if (!detail::plain_path("hull_filter")) drop_inner_points(p);
  std::sort(p.begin(), p.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  const auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Vec2> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);
  return h;
}

}  // namespace detail

PartExtent find_part_extent(std::span<const Move> moves, const std::map<int, std::string>& names) {
  PartExtent part;
  // Extrusions that may belong to the part.
  std::vector<const Move*> candidates;
  bool tagged = false, labelled = false;
  for (const Move& m : moves) {
    if (m.kind != MoveKind::extrude || m.xy_length_mm() <= 0) continue;
    if (m.feature != Feature::unknown) tagged = true;
    if (is_auxiliary_feature(m.feature)) continue;
    labelled = labelled || m.object_id >= 0;
    candidates.push_back(&m);
  }
  if (candidates.empty()) return part;
  part.layer_height_mm = median_layer_step(candidates);
  part.walls_tagged = std::any_of(candidates.begin(), candidates.end(),
                                  [](const Move* m) { return is_outer_wall(m->feature); });

  if (labelled) {
    // The slicer named its objects: each is a candidate (moves outside any object dropped).
    part.method = "objects";
    std::map<int, std::vector<const Move*>> by_id;
    for (const Move* m : candidates)
      if (m->object_id >= 0) by_id[m->object_id].push_back(m);
    for (const auto& [id, list] : by_id) {
      const auto name = names.find(id);
      part.objects.push_back(
          make_object(id, name != names.end() ? name->second : "#" + std::to_string(id), list));
    }
  } else {
    part.method = tagged ? "tags" : "connectivity";
    std::vector<double> weight;
    auto groups = footprint_groups(candidates, weight);
    const double heaviest = *std::max_element(weight.begin(), weight.end());
    std::vector<std::size_t> kept;
    for (std::size_t g = 0; g < groups.size(); ++g)
      if (weight[g] >= 0.02 * heaviest) kept.push_back(g);
    if (!tagged) {
      // Untagged skirts and purge lines are one layer; drop such groups when others are taller.
      const auto z_extent = [&](std::size_t g) {
        double lo = 1e300, hi = -1e300;
        for (const Move* m : groups[g]) {
          lo = std::min(lo, m->end_mm.z());
          hi = std::max(hi, m->end_mm.z());
        }
        return hi - lo;
      };
      const double flat = std::max(2.5 * part.layer_height_mm, 0.5);
      double tallest = 0;
      for (const std::size_t g : kept) tallest = std::max(tallest, z_extent(g));
      if (tallest > flat) std::erase_if(kept, [&](std::size_t g) { return z_extent(g) <= flat; });
    }
    std::vector<const Move*> all;
    for (const std::size_t g : kept) all.insert(all.end(), groups[g].begin(), groups[g].end());
    std::sort(all.begin(), all.end());  // move order
    part.objects.push_back(make_object(-1, "part", all));
    // Several islands: each alone is a candidate too (several parts on one unlabelled bed).
    if (kept.size() > 1) {
      int n = 0;
      for (const std::size_t g : kept)
        if (weight[g] >= 0.1 * heaviest)
          part.objects.push_back(make_object(-1, "footprint " + std::to_string(++n), groups[g]));
    }
  }
  for (const auto& o : part.objects) {
    if (o.id >= 0 || &o == &part.objects.front()) {
      part.bbox_mm.extend(o.bbox_mm);
      part.moves += o.moves;
    }
  }
  return part;
}

Vec3 registration_offset(const Mesh& mesh, const PartExtent& part) {
  const Box3 mb = bounding_box(mesh);
  if (mb.empty()) return Vec3::Zero();
  if (part.bbox_mm.empty()) return Vec3(0, 0, -mb.min.z());
  const Vec3 pc = part.bbox_mm.center();
  const Vec3 mc = mb.center();
  return Vec3(pc.x() - mc.x(), pc.y() - mc.y(), -mb.min.z());
}

Eigen::Matrix3d rotation_from_xyz_deg(const Vec3& xyz_deg) {
  const double k = M_PI / 180.0;
  return (Eigen::AngleAxisd(xyz_deg.z() * k, Vec3::UnitZ()) *
          Eigen::AngleAxisd(xyz_deg.y() * k, Vec3::UnitY()) *
          Eigen::AngleAxisd(xyz_deg.x() * k, Vec3::UnitX()))
      .toRotationMatrix();
}

Vec3 xyz_deg_of(const Eigen::Matrix3d& r) {
  const double k = 180.0 / M_PI;
  // R = Rz(c) Ry(b) Rx(a): r20 = -sin b, r21 = cos b sin a, r22 = cos b cos a,
  // r10 = sin c cos b, r00 = cos c cos b.
  const double b = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  double a = 0, c = 0;
  if (std::abs(r(2, 0)) < 1 - 1e-12) {
    a = std::atan2(r(2, 1), r(2, 2));
    c = std::atan2(r(1, 0), r(0, 0));
  } else {  // gimbal lock: put everything in c
    c = std::atan2(-r(0, 1), r(1, 1));
  }
  const auto clean = [](double deg) { return std::abs(deg) < 1e-9 ? 0.0 : deg; };
  return Vec3(clean(a * k), clean(b * k), clean(c * k));
}

Mesh transformed(Mesh mesh, const RigidTransform& transform) {
  for (auto& v : mesh.vertices_mm) v = transform.apply(v);
  return mesh;
}

}  // namespace printtwin
