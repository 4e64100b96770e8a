#pragma once
// Small geometric value types shared by every stage. Units: millimetres, machine frame
// (x right, y towards the back of the bed, z up, origin at the bed's front-left corner).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <limits>

namespace printtwin {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;

/// Axis-aligned box. Empty while min > max (the default).
struct Box3 {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

  [[nodiscard]] bool empty() const { return (min.array() > max.array()).any(); }
  void extend(const Vec3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const Box3& b) {
    if (b.empty()) return;
    extend(b.min);
    extend(b.max);
  }
  [[nodiscard]] Vec3 size() const { return empty() ? Vec3::Zero() : Vec3(max - min); }
  [[nodiscard]] Vec3 center() const { return 0.5 * (min + max); }
  [[nodiscard]] bool contains(const Vec3& p, double eps = 0.0) const {
    return (p.array() >= min.array() - eps).all() && (p.array() <= max.array() + eps).all();
  }
  bool operator==(const Box3&) const = default;
};

}  // namespace printtwin
