// Marlin 2.1's and Klipper's look-ahead planners in millimetres and seconds.
// Marlin: module/planner.cpp (_populate_block, reverse_pass_kernel, forward_pass_kernel,
// recalculate_trapezoids) and, for `prusaslicer_compat`, PrusaSlicer's
// GCodeProcessor::TimeProcessor (classic jerk with its safe-speed rule). Klipper:
// klippy/toolhead.py (Move, LookAheadQueue), kinematics/cartesian.py and extruder.py
// (check_move, calc_junction). Written from the published algorithms, not copied.
#include <algorithm>
#include <cmath>

#include "printtwin/planner.hpp"

namespace printtwin {

namespace {
constexpr double kVmin = kMinimumPlannerSpeed_mm_s;
// Klipper's toolhead.py: LOOKAHEAD_FLUSH_TIME and BUFFER_TIME_HIGH (the queued move time
// before a lazy flush, right after a full flush).
constexpr double kLookaheadFlushTime_s = 0.150;
constexpr double kBufferTimeHigh_s = 1.0;

/// The segment's description of the Move it times (where, what, which line).
void copy_move_fields(MotionSegment& s, const Move& m, double e_start_mm, long index) {
  s.start_mm = m.start_mm;
  s.end_mm = m.end_mm;
  s.e_start_mm = e_start_mm;
  s.e_mm = m.e_mm;
  s.line = m.line;
  s.layer = m.layer;
  s.feature = m.feature;
  s.kind = m.kind;
  s.object_id = m.object_id;
  s.index = index;
}

/// Highest speed at the start of a distance `s` from which `accel` reaches `v_end`.
double max_allowable_speed(double accel, double v_end, double s) {
  return std::sqrt(v_end * v_end + 2.0 * accel * s);
}
/// Marlin's SLOWDOWN: while the buffer drains, a block shorter in time than
/// `min_segment_time_s` is stretched towards it.
double slowdown_speed(const MotionLimits& L, double length_mm, double v, std::size_t queued) {
  const double t = length_mm / v;
  if (t < L.min_segment_time_s) {
    const double stretched = t + 2.0 * (L.min_segment_time_s - t) / static_cast<double>(queued);
    v = length_mm / stretched;
  }
  return v;
}

/// Orca's estimator: a gentle XY bend (< 29 degrees) caps the speed at sqrt(a r), r the
/// radius of the circle through this move's chord and the bend.
double orca_bend_speed(double accel, const Eigen::Vector2d& dir,
                       const Eigen::Vector2d& previous_dir, double xy_len, double v) {
  const double diff = (dir - previous_dir).norm();
  if (diff < 0.5 && diff > 1e-5) {
    const double cos_a = std::clamp(dir.dot(previous_dir), -1.0, 1.0);
    const double sin_half = std::sqrt(0.5 * (1.0 - cos_a));
    if (sin_half > 0) v = std::min(v, std::sqrt(accel * xy_len * 0.5 / sin_half));
  }
  return v;
}

/// The requested speed scaled down by the per-axis feedrate limits (M203), E included.
double axis_limited_speed(const MotionLimits& L, const Eigen::Vector4d& unit, double v) {
  double factor = 1.0;
  for (int i = 0; i < 4; ++i) {
    const double axis_speed = std::fabs(unit[i]) * v * factor;
    if (axis_speed > L.max_feedrate_mm_s[i]) factor *= L.max_feedrate_mm_s[i] / axis_speed;
  }
  return v * factor;
}

/// Scales `accel` down until no axis of `unit` exceeds its M201 limit. Divides only for the
/// axes that limit (most moves are limited by none or one).
double axis_limited_accel(const MotionLimits& L, const Eigen::Vector4d& unit, double accel) {
  for (int i = 0; i < 4; ++i)
    if (accel * std::fabs(unit[i]) > L.max_accel_mm_s2[i])
      accel = L.max_accel_mm_s2[i] / std::fabs(unit[i]);
  return accel;
}

/// A block's acceleration: M204 R for E-only moves, T for moves without E, P otherwise, then
/// per axis; the estimators clamp each by machine_max_acceleration_*.
/// The estimators' acceleration of a move type before the per-axis limits: PrusaSlicer's
/// move types (retracting while moving, a wipe, counts as travel; for Orca an extrusion
/// with Z and no XY too), each clamped by machine_max_acceleration_* whoever set it (M204,
/// SET_VELOCITY_LIMIT).
double estimator_type_accel(const MotionLimits& L, double e_mm, bool e_only, double xy_len) {
  const bool extrude = e_mm > 0 && !(L.orca_compat && xy_len == 0);
  const int type = e_only ? 1 : (extrude ? 0 : 2);
  return std::min(
      type == 1 ? L.retract_accel_mm_s2 : (type == 0 ? L.print_accel_mm_s2 : L.travel_accel_mm_s2),
      L.accel_cap_mm_s2[type]);
}

double block_accel(const MotionLimits& L, const Eigen::Vector4d& unit, double e_mm, bool e_only,
                   double xy_len) {
  double accel;
  if (L.prusaslicer_compat) {
    accel = axis_limited_accel(L, unit, estimator_type_accel(L, e_mm, e_only, xy_len));
  } else if (e_only) {
    accel = L.retract_accel_mm_s2;
  } else {
    accel = axis_limited_accel(L, unit, e_mm != 0 ? L.print_accel_mm_s2 : L.travel_accel_mm_s2);
  }
  return std::max(accel, 1e-6);
}

/// Marlin's junction deviation: the highest speed at the corner between the previous block
/// (`previous_unit`) and this one, with JD_HANDLE_SMALL_SEGMENTS when enabled.
double deviation_junction_speed(const MotionLimits& L, const Eigen::Vector4d& previous_unit,
                                const Eigen::Vector4d& unit, double accel, double length_mm,
                                double nominal, double previous_nominal) {
  double vmax_junction;
  double cos_theta = -previous_unit.dot(unit);
  if (cos_theta > 0.999999) {
    vmax_junction = kVmin;  // full reversal
  } else {
    cos_theta = std::max(cos_theta, -0.999999);
    Eigen::Vector4d ju = unit - previous_unit;
    const double jn = ju.norm();
    double junction_accel = accel;
    if (jn > 0) {
      ju /= jn;
      junction_accel = axis_limited_accel(L, ju, junction_accel);
    }
    const double sin_theta_d2 = std::sqrt(0.5 * (1.0 - cos_theta));
    double vsq = junction_accel * L.junction_deviation_mm * sin_theta_d2 / (1.0 - sin_theta_d2);
    if (L.jd_small_segments && length_mm < 1.0 && cos_theta < -0.7071067812) {
      // JD_HANDLE_SMALL_SEGMENTS: short segments of a curve share the speed of the
      // arc they approximate: v^2 = a * length / theta.
      const double theta = std::acos(-cos_theta);
      if (theta > 1e-6) vsq = std::min(vsq, length_mm * junction_accel / theta);
    }
    vmax_junction = std::sqrt(vsq);
  }
  return std::min({vmax_junction, nominal, previous_nominal});
}

/// Classic jerk: the speed from which a block may start (or end) at once.
double jerk_safe_speed(const MotionLimits& L, const Eigen::Vector4d& axis_speed, double nominal) {
  double safe = nominal;
  if (L.prusaslicer_compat) {
    Eigen::Vector4d jerk = L.jerk_mm_s;
    if (L.orca_compat) jerk[0] = jerk[1] = L.square_corner_velocity_mm_s;
    for (int i = 0; i < 4; ++i)
      if (std::fabs(axis_speed[i]) > jerk[i]) safe = std::min(safe, jerk[i]);
    return safe;
  }
  bool limited = false;
  for (int i = 0; i < 4; ++i) {
    const double jerk = std::fabs(axis_speed[i]), maxj = L.jerk_mm_s[i];
    if (jerk > maxj) {
      if (limited) {
        const double mjerk = nominal * maxj;
        if (mjerk < jerk * safe) safe = mjerk / jerk;
      } else {
        safe *= maxj / jerk;
        limited = true;
      }
    }
  }
  return safe;
}

/// The two blocks of a classic-jerk junction (this one and the previous).
struct JerkJunction {
  Eigen::Vector4d unit;
  Eigen::Vector4d previous_unit;
  Eigen::Vector4d axis_speed;
  Eigen::Vector4d previous_axis_speed;
  double nominal;
  double previous_nominal;
  double safe;
  double previous_safe;
};

/// Classic jerk: the highest junction speed at which no axis changes its speed by more than
/// its jerk (Marlin's rule; Orca's X, Y, Z vector rule for its estimator). `same_arc`: the
/// blocks are segments of one G2/G3, which Orca joins without a jerk limit.
/// Bambu Studio's estimator: v * |change of the XYZ unit direction| <= jerk per axis, the
/// junction not capped by the blocks' speeds; then the coasting rule.
double bambu_junction_speed(const MotionLimits& L, const JerkJunction& j) {
  const Eigen::Vector3d jerk_xyz(L.square_corner_velocity_mm_s, L.square_corner_velocity_mm_s,
                                 L.jerk_mm_s[2]);
  const Eigen::Vector3d du = (j.unit.head<3>() - j.previous_unit.head<3>()).cwiseAbs();
  double vmax_junction = std::min(j.nominal, j.previous_nominal);
  double k_min = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i)
    if (du[i] > 0) k_min = std::min(k_min, jerk_xyz[i] / du[i]);
  if (std::isfinite(k_min)) vmax_junction = k_min;
  const double threshold = vmax_junction * 0.99;
  if (j.previous_safe > threshold && j.safe > threshold) vmax_junction = j.safe;
  return vmax_junction;
}

double jerk_junction_speed(const MotionLimits& L, const JerkJunction& j, bool same_arc) {
  if (L.bambu_junction && !same_arc) return bambu_junction_speed(L, j);
  const bool prev_larger = j.previous_nominal > j.nominal;
  double vmax_junction = prev_larger ? j.nominal : j.previous_nominal;
  const double smaller_factor = vmax_junction / j.previous_nominal;
  double v_factor = 1.0;
  bool limited = false;
  int first_axis = 0;
  if (L.orca_compat) {
    // X, Y, Z together: the jerk is |entry velocity - exit velocity| per axis, and
    // each limit found scales what is left (Bambu's rule, kept as it is).
    const Eigen::Vector3d jerk_xyz(L.square_corner_velocity_mm_s, L.square_corner_velocity_mm_s,
                                   L.jerk_mm_s[2]);
    Eigen::Vector3d jv =
        (j.axis_speed.head<3>() - j.previous_axis_speed.head<3>() * smaller_factor).cwiseAbs();
    for (int i = 0; i < 3; ++i) {
      if (jv[i] > jerk_xyz[i]) {
        v_factor *= jerk_xyz[i] / jv[i];
        jv *= v_factor;
        limited = true;
      }
    }
    first_axis = 3;
  }
  for (int i = first_axis; i < 4; ++i) {
    double v_exit = j.previous_axis_speed[i] * smaller_factor;
    double v_entry = j.axis_speed[i];
    if (limited) {
      v_exit *= v_factor;
      v_entry *= v_factor;
    }
    const double jerk =
        (v_exit > v_entry)
            ? ((v_entry > 0 || v_exit < 0) ? (v_exit - v_entry) : std::max(v_exit, -v_entry))
            : ((v_entry < 0 || v_exit > 0) ? (v_entry - v_exit) : std::max(-v_exit, v_entry));
    if (jerk > L.jerk_mm_s[i]) {
      v_factor *= L.jerk_mm_s[i] / jerk;
      limited = true;
    }
  }
  if (same_arc) limited = false;
  if (limited) vmax_junction *= v_factor;
  const double threshold = vmax_junction * 0.99;
  if (j.previous_safe > threshold && j.safe > threshold) vmax_junction = j.safe;
  return vmax_junction;
}
}  // namespace

double klipper_junction_deviation_mm(double scv, double accel) {
  return accel > 0 ? scv * scv * (std::sqrt(2.0) - 1.0) / accel : 0.0;
}

double klipper_default_extrude_ratio(double nozzle_diameter_mm, double filament_diameter_mm) {
  const double area = 0.25 * 3.14159265358979323846 * filament_diameter_mm * filament_diameter_mm;
  return area > 0 ? 4.0 * nozzle_diameter_mm * nozzle_diameter_mm / area : 0.0;
}

MotionLimits motion_limits_from_profile(const PrinterProfile& p) {
  MotionLimits l;
  l.max_feedrate_mm_s = p.max_feedrate_mm_s;
  l.max_accel_mm_s2 = p.max_accel_mm_s2;
  l.print_accel_mm_s2 = p.print_accel_mm_s2;
  l.retract_accel_mm_s2 = p.retract_accel_mm_s2;
  l.travel_accel_mm_s2 = p.travel_accel_mm_s2;
  l.junction = p.junction;
  l.junction_deviation_mm = p.junction_deviation_mm;
  l.jerk_mm_s = p.jerk_mm_s;
  l.min_feedrate_mm_s = p.min_feedrate_mm_s;
  l.min_travel_feedrate_mm_s = p.min_travel_feedrate_mm_s;
  l.min_segment_time_s = p.min_segment_time_s;
  l.square_corner_velocity_mm_s = p.square_corner_velocity_mm_s;
  l.minimum_cruise_ratio = p.minimum_cruise_ratio;
  l.max_extrude_only_velocity_mm_s = p.max_extrude_only_velocity_mm_s;
  l.max_extrude_only_accel_mm_s2 = p.max_extrude_only_accel_mm_s2;
  if (p.firmware == "klipper") {
    l.klipper = true;
    // [extruder] defaults: derived from the config's max_velocity and max_accel once, at
    // start-up (SET_VELOCITY_LIMIT later does not change them).
    const double ratio =
        klipper_default_extrude_ratio(p.nozzle_diameter_mm, p.filament_diameter_mm);
    if (!(l.max_extrude_only_velocity_mm_s > 0))
      l.max_extrude_only_velocity_mm_s = p.max_feedrate_mm_s[0] * ratio;
    if (!(l.max_extrude_only_accel_mm_s2 > 0))
      l.max_extrude_only_accel_mm_s2 = p.print_accel_mm_s2 * ratio;
  }
  return l;
}

double MotionSegment::distance_at(double t) const {
  if (t <= 0) return 0;
  const double a = accel_mm_s2;
  if (t < accel_time_s) return start_speed_mm_s * t + 0.5 * a * t * t;
  double d = start_speed_mm_s * accel_time_s + 0.5 * a * accel_time_s * accel_time_s;
  t -= accel_time_s;
  if (t < cruise_time_s) return d + cruise_speed_mm_s * t;
  d += cruise_speed_mm_s * cruise_time_s;
  t = std::min(t - cruise_time_s, decel_time_s);
  return std::min(length_mm, d + cruise_speed_mm_s * t - 0.5 * a * t * t);
}

double MotionSegment::speed_at(double t) const {
  if (t <= 0) return start_speed_mm_s;
  if (t < accel_time_s) return start_speed_mm_s + accel_mm_s2 * t;
  t -= accel_time_s;
  if (t < cruise_time_s) return cruise_speed_mm_s;
  t = std::min(t - cruise_time_s, decel_time_s);
  return std::max(0.0, cruise_speed_mm_s - accel_mm_s2 * t);
}

Vec3 MotionSegment::position_at(double t) const {
  const double xyz = (end_mm - start_mm).norm();
  if (xyz <= 0 || length_mm <= 0) return start_mm;
  const double f = std::clamp(distance_at(t) / length_mm, 0.0, 1.0);
  return start_mm + f * (end_mm - start_mm);
}

Planner::Planner(const MotionLimits& limits, int block_buffer_size)
    : limits_(limits), capacity_(static_cast<std::size_t>(std::max(2, block_buffer_size))) {}

void Planner::set_limits(const MotionLimits& limits) { limits_ = limits; }

void Planner::add(const Move& move, MoveSink& sink) {
  if (limits_.klipper) {
    klipper_add(move, sink);
    return;
  }
  Block b;
  b.delta_mm.head<3>() = move.end_mm - move.start_mm;
  b.delta_mm[3] = move.e_mm;
  const double xyz = b.delta_mm.head<3>().norm();
  const double e_abs = std::fabs(move.e_mm);
  if (xyz < 1e-9 && e_abs < 1e-9) return;
  const bool e_only = xyz < 1e-9;
  b.length_mm = e_only ? e_abs : xyz;
  if (e_only) b.delta_mm.head<3>().setZero();
  b.unit = b.delta_mm / b.length_mm;
  b.move = move;
  b.e_start_mm = e_total_mm_;
  e_total_mm_ += move.e_mm;
  b.index = next_index_++;

  const MotionLimits& L = limits_;
  // Requested speed with Marlin's floors (M205 S / T).
  double v = move.feedrate_mm_s > 0 ? move.feedrate_mm_s : kVmin;
  v = std::max(v, move.e_mm != 0 ? L.min_feedrate_mm_s : L.min_travel_feedrate_mm_s);
  // SLOWDOWN: while the buffer is draining (2..N/2-1 queued), stretch short blocks.
  const std::size_t queued = window_.size();
  if (!L.prusaslicer_compat && L.min_segment_time_s > 0 && queued >= 2 &&
      queued <= capacity_ / 2 - 1)
    v = slowdown_speed(L, b.length_mm, v, queued);
  const double xy_len = b.delta_mm.head<2>().norm();
  if (L.orca_compat) {
    if (xy_len > 0 && previous_xy_len_ > 0 && !e_only) {
      const Eigen::Vector2d dir = b.delta_mm.head<2>() / xy_len;
      v = orca_bend_speed(estimator_type_accel(L, move.e_mm, e_only, xy_len), dir, previous_xy_dir_,
                          xy_len, v);
    }
    previous_xy_len_ = xy_len;
    if (xy_len > 0) previous_xy_dir_ = b.delta_mm.head<2>() / xy_len;
  }
  b.nominal_speed_mm_s = axis_limited_speed(L, b.unit, v);
  b.accel_mm_s2 = block_accel(L, b.unit, move.e_mm, e_only, xy_len);

  // Maximum junction speed with the previous block.
  const Eigen::Vector4d axis_speed = b.unit * b.nominal_speed_mm_s;
  double vmax_junction = 0;
  if (L.junction == JunctionModel::junction_deviation) {
    if (have_previous_ && previous_nominal_speed_mm_s_ > 1e-9)
      vmax_junction =
          deviation_junction_speed(L, previous_unit_, b.unit, b.accel_mm_s2, b.length_mm,
                                   b.nominal_speed_mm_s, previous_nominal_speed_mm_s_);
    b.safe_speed_mm_s = kVmin;
  } else {
    const double safe = jerk_safe_speed(L, axis_speed, b.nominal_speed_mm_s);
    b.safe_speed_mm_s = safe;
    vmax_junction = safe;
    if (have_previous_ && previous_nominal_speed_mm_s_ > 1e-4) {
      // Orca plans an arc (G2/G3) as one block: its segments join without a jerk limit.
      const bool same_arc =
          L.orca_compat && move.line == previous_line_ && move.line > 0 && xy_len > 0;
      JerkJunction j{b.unit,
                     previous_unit_,
                     axis_speed,
                     previous_axis_speed_mm_s_,
                     b.nominal_speed_mm_s,
                     previous_nominal_speed_mm_s_,
                     safe,
                     previous_safe_speed_mm_s_};
      vmax_junction = jerk_junction_speed(L, j, same_arc);
    }
  }
  b.max_entry_speed_mm_s = std::max(vmax_junction, kVmin);
  // Marlin: a block must be able to stop (MINIMUM_PLANNER_SPEED) within itself. PrusaSlicer's
  // estimator only asks it to reach its safe speed, which lets more blocks be "nominal".
  const double v_allowable = max_allowable_speed(
      b.accel_mm_s2, L.prusaslicer_compat ? b.safe_speed_mm_s : kVmin, b.length_mm);
  b.nominal_length = b.nominal_speed_mm_s <= v_allowable;
  b.entry_speed_mm_s = std::min(b.max_entry_speed_mm_s, v_allowable);

  have_previous_ = true;
  previous_unit_ = b.unit;
  previous_axis_speed_mm_s_ = axis_speed;
  previous_nominal_speed_mm_s_ = b.nominal_speed_mm_s;
  previous_safe_speed_mm_s_ = b.safe_speed_mm_s;
  previous_line_ = move.line;

  window_.push_back(std::move(b));
  ++queued_since_sync_;
  recalculate();
  while (window_.size() >= capacity_) emit_front(sink, window_[1].entry_speed_mm_s);
}

void Planner::recalculate() {
  const std::size_t n = window_.size();
  if (n == 0) return;
  // Reverse pass: every block must be able to slow down to the next block's entry, and the
  // last block to a stop (JD) or to its safe speed (classic jerk).
  const Block& last = window_.back();
  double next_entry =
      limits_.junction == JunctionModel::classic_jerk ? last.safe_speed_mm_s : kVmin;
  std::size_t first_changed = n;
  for (std::size_t k = n; k-- > 0;) {
    Block& b = window_[k];
    if (b.entry_fixed) break;
    const double e = b.nominal_length
                         ? b.max_entry_speed_mm_s
                         : std::min(b.max_entry_speed_mm_s,
                                    max_allowable_speed(b.accel_mm_s2, next_entry, b.length_mm));
    // Marlin's "planned" pointer: once a block's reverse-planned entry is unchanged (and it
    // is not one of the last two, whose exit just changed), nothing before it changes.
    if (k + 2 < n && e == b.reverse_entry_mm_s) break;
    b.reverse_entry_mm_s = e;
    b.entry_speed_mm_s = e;
    first_changed = k;
    next_entry = e;
  }
  // Forward pass: acceleration limits from the fixed start.
  const std::size_t from = first_changed > 0 ? first_changed - 1 : 0;
  for (std::size_t k = from + 1; k < n; ++k) {
    const Block& prev = window_[k - 1];
    Block& cur = window_[k];
    if (!prev.nominal_length && prev.entry_speed_mm_s < cur.entry_speed_mm_s) {
      const double v = max_allowable_speed(prev.accel_mm_s2, prev.entry_speed_mm_s, prev.length_mm);
      if (v < cur.entry_speed_mm_s) cur.entry_speed_mm_s = v;
    }
  }
}

void Planner::emit_front(MoveSink& sink, double exit_speed) {
  Block& b = window_.front();
  const double a = b.accel_mm_s2, L = b.length_mm;
  const double v0 = std::min(b.entry_speed_mm_s, b.nominal_speed_mm_s);
  double v1 = std::min(exit_speed, b.nominal_speed_mm_s);
  // Keep the profile feasible within the block's acceleration (classic jerk can ask for an
  // exit the fixed entry cannot reach; the difference is then a jerk at the junction).
  if (v0 * v0 - 2 * a * L > v1 * v1) v1 = std::sqrt(v0 * v0 - 2 * a * L);
  if (v1 * v1 > v0 * v0 + 2 * a * L) v1 = std::sqrt(v0 * v0 + 2 * a * L);
  const double vn = b.nominal_speed_mm_s;
  double accel_d = (vn * vn - v0 * v0) / (2 * a);
  double decel_d = (vn * vn - v1 * v1) / (2 * a);
  double cruise_d = L - accel_d - decel_d;
  double vpeak = vn;
  if (cruise_d < 0) {
    // Not enough room to reach the nominal speed: accelerate, then brake at once.
    accel_d = std::clamp((2 * a * L + v1 * v1 - v0 * v0) / (4 * a), 0.0, L);
    decel_d = L - accel_d;
    cruise_d = 0;
    vpeak = std::sqrt(std::max(v0 * v0 + 2 * a * accel_d, 0.0));
  }
  MotionSegment s;
  s.start_time_s = clock_s_;
  s.start_speed_mm_s = v0;
  s.end_speed_mm_s = std::min(v1, vpeak);
  s.cruise_speed_mm_s = std::max(vpeak, std::max(v0, s.end_speed_mm_s));
  s.nominal_speed_mm_s = vn;
  s.accel_mm_s2 = a;
  s.accel_time_s = std::max(0.0, (s.cruise_speed_mm_s - v0) / a);
  s.decel_time_s = std::max(0.0, (s.cruise_speed_mm_s - s.end_speed_mm_s) / a);
  s.cruise_time_s = cruise_d > 0 ? cruise_d / vn : 0.0;
  // Rounding: make the distance of the profile equal the length (a cruise at the peak).
  const double profile_d = (v0 + s.cruise_speed_mm_s) * 0.5 * s.accel_time_s +
                           (s.cruise_speed_mm_s + s.end_speed_mm_s) * 0.5 * s.decel_time_s;
  if (cruise_d <= 0 && L - profile_d > 1e-12 && s.cruise_speed_mm_s > 0)
    s.cruise_time_s = (L - profile_d) / s.cruise_speed_mm_s;
  s.length_mm = L;
  copy_move_fields(s, b.move, b.e_start_mm, b.index);
  clock_s_ += s.duration_s();
  window_.pop_front();
  if (!window_.empty()) {
    window_.front().entry_speed_mm_s = s.end_speed_mm_s;
    window_.front().entry_fixed = true;
  }
  sink.on_segment(s);
}

void Planner::flush(MoveSink& sink) {
  if (limits_.klipper || !kqueue_.empty()) {
    klipper_flush(sink, false);
    junction_flush_s_ = kBufferTimeHigh_s;
  }
  while (!window_.empty()) {
    const double exit = window_.size() > 1 ? window_[1].entry_speed_mm_s
                                           : (limits_.junction == JunctionModel::classic_jerk
                                                  ? window_.front().safe_speed_mm_s
                                                  : kVmin);
    emit_front(sink, exit);
  }
  have_previous_ = false;
  queued_since_sync_ = 0;
}

// ---------------------------------------------------------------------------------------
// Klipper

void Planner::klipper_add(const Move& move, MoveSink& sink) {
  const MotionLimits& L = limits_;
  KlipperMove m;
  Eigen::Vector4d d;
  d.head<3>() = move.end_mm - move.start_mm;
  d[3] = move.e_mm;
  // Limits that are not positive (an incomplete profile) limit nothing, as an absent one.
  constexpr double kNone = std::numeric_limits<double>::infinity();
  const double max_velocity = L.max_feedrate_mm_s[0] > 0 ? L.max_feedrate_mm_s[0] : kNone;
  const double max_accel = std::max(L.print_accel_mm_s2, 1e-6);
  const double speed = move.feedrate_mm_s > 0 ? move.feedrate_mm_s : kVmin;
  double velocity = std::min(speed, max_velocity);
  m.move_d = d.head<3>().norm();
  m.accel = max_accel;
  if (m.move_d < 1e-9) {
    // Extrude-only move: its own speed, no toolhead acceleration (the extruder limits it).
    d.head<3>().setZero();
    m.move_d = std::fabs(d[3]);
    if (m.move_d <= 0) return;
    m.kinematic = false;
    m.accel = 99999999.9;
    velocity = speed;
  }
  m.axes_r = d / m.move_d;
  m.junction_deviation = klipper_junction_deviation_mm(L.square_corner_velocity_mm_s, max_accel);
  m.min_move_t = m.move_d / velocity;
  m.max_cruise_v2 = velocity * velocity;
  m.delta_v2 = 2.0 * m.move_d * m.accel;
  m.mcr_delta_v2 = 2.0 * m.move_d * max_accel * (1.0 - L.minimum_cruise_ratio);
  auto limit_speed = [&m](double v, double a) {
    if (!(v > 0) || !(a > 0)) return;
    if (v * v < m.max_cruise_v2) {
      m.max_cruise_v2 = v * v;
      m.min_move_t = m.move_d / v;
    }
    m.accel = std::min(m.accel, a);
    m.delta_v2 = 2.0 * m.move_d * m.accel;
    m.mcr_delta_v2 = std::min(m.mcr_delta_v2, m.delta_v2);
  };
  // Kinematics: a move with Z is limited by max_z_velocity and max_z_accel along Z.
  if (m.kinematic && d[2] != 0) {
    const double z_ratio = m.move_d / std::fabs(d[2]);
    limit_speed(L.max_feedrate_mm_s[2] * z_ratio, L.max_accel_mm_s2[2] * z_ratio);
  }
  // Extruder: extrude-only moves, moves without XY (Z hop with E) and every retraction are
  // limited by max_extrude_only_velocity / _accel along E.
  if (d[3] != 0 && ((d[0] == 0 && d[1] == 0) || m.axes_r[3] < 0)) {
    double ev = L.max_extrude_only_velocity_mm_s, ea = L.max_extrude_only_accel_mm_s2;
    const double ratio = klipper_default_extrude_ratio(0.4, 1.75);
    if (!(ev > 0)) ev = std::min(max_velocity, 1e9) * ratio;
    if (!(ea > 0)) ea = max_accel * ratio;
    const double inv = 1.0 / std::fabs(m.axes_r[3]);
    limit_speed(ev * inv, ea * inv);
  }
  m.move = move;
  m.e_start_mm = e_total_mm_;
  e_total_mm_ += move.e_mm;
  m.index = next_index_++;

  if (kqueue_.empty()) {
    kqueue_.push_back(std::move(m));
    return;
  }
  const KlipperMove& prev = kqueue_.back();
  if (m.kinematic && prev.kinematic) {
    // Junction: never above either cruise speed or what the previous move can reach
    // (smoothed by its own start limit), nor the extruder's instantaneous corner velocity.
    double max_start_v2 =
        std::min({m.max_cruise_v2, prev.max_cruise_v2, prev.max_start_v2 + prev.delta_v2});
    const double diff_r = m.axes_r[3] - prev.axes_r[3];
    if (diff_r != 0) {
      const double v = L.extruder_corner_velocity_mm_s / std::fabs(diff_r);
      max_start_v2 = std::min(max_start_v2, v * v);
    }
    // Approximated centripetal velocity, corner angle from XYZ only.
    const double cos_theta = -m.axes_r.head<3>().dot(prev.axes_r.head<3>());
    const double sin_d2 = std::sqrt(std::max(0.5 * (1.0 - cos_theta), 0.0));
    const double cos_d2 = std::sqrt(std::max(0.5 * (1.0 + cos_theta), 0.0));
    const double one_minus_sin_d2 = 1.0 - sin_d2;
    if (one_minus_sin_d2 > 0 && cos_d2 > 0) {
      const double r_jd = sin_d2 / one_minus_sin_d2;
      // The approximated circle must touch both moves no further than their middles.
      const double quarter_tan_d2 = 0.25 * sin_d2 / cos_d2;
      max_start_v2 = std::min({max_start_v2, r_jd * m.junction_deviation * m.accel,
                               r_jd * prev.junction_deviation * prev.accel,
                               m.delta_v2 * quarter_tan_d2, prev.delta_v2 * quarter_tan_d2});
    }
    m.max_start_v2 = max_start_v2;
    m.max_mcr_start_v2 = std::min(max_start_v2, prev.max_mcr_start_v2 + prev.mcr_delta_v2);
  }
  junction_flush_s_ -= m.min_move_t;
  kqueue_.push_back(std::move(m));
  if (junction_flush_s_ <= 0) klipper_flush(sink, true);
}

void Planner::klipper_flush(MoveSink& sink, bool lazy) {
  junction_flush_s_ = kLookaheadFlushTime_s;
  bool update_flush_count = lazy;
  const std::size_t n = kqueue_.size();
  std::size_t flush_count = n;
  // Backward: the highest start speed of each move, given a stop after the last one, and
  // the cruise speed of the moves that can accelerate (limited by minimum_cruise_ratio).
  double next_start_v2 = 0, next_mcr_start_v2 = 0, peak_cruise_v2 = 0;
  std::size_t pending = 0;
  for (std::size_t i = n; i-- > 0;) {
    KlipperMove& m = kqueue_[i];
    const double reachable_start_v2 = next_start_v2 + m.delta_v2;
    const double start_v2 = std::min(m.max_start_v2, reachable_start_v2);
    double cruise_v2 = -1;
    ++pending;
    const double reach_mcr_start_v2 = next_mcr_start_v2 + m.mcr_delta_v2;
    const double mcr_start_v2 = std::min(m.max_mcr_start_v2, reach_mcr_start_v2);
    if (mcr_start_v2 < reach_mcr_start_v2) {
      // This move can accelerate.
      if (mcr_start_v2 + m.mcr_delta_v2 > next_mcr_start_v2 || pending > 1) {
        // It can both accelerate and decelerate, or a full acceleration is followed by a
        // full deceleration: the moves before it no longer depend on what comes later.
        if (update_flush_count && peak_cruise_v2 > 0) {
          flush_count = i + pending;
          update_flush_count = false;
        }
        peak_cruise_v2 = 0.5 * (mcr_start_v2 + reach_mcr_start_v2);
      }
      cruise_v2 =
          std::min({0.5 * (start_v2 + reachable_start_v2), m.max_cruise_v2, peak_cruise_v2});
      pending = 0;
    }
    m.start_v2 = start_v2;
    m.cruise_v2 = cruise_v2;
    m.end_v2 = next_start_v2;
    next_start_v2 = start_v2;
    next_mcr_start_v2 = mcr_start_v2;
  }
  if (update_flush_count || flush_count == 0) return;
  // Forward: moves that cannot accelerate keep the cruise speed of the one before.
  double prev_cruise_v2 = 0;
  for (std::size_t i = 0; i < flush_count; ++i) {
    KlipperMove& m = kqueue_[i];
    if (m.cruise_v2 < 0) m.cruise_v2 = std::min(prev_cruise_v2, m.start_v2);
    m.start_v2 = std::min(m.start_v2, m.cruise_v2);
    m.end_v2 = std::min(m.end_v2, m.cruise_v2);
    prev_cruise_v2 = m.cruise_v2;
    klipper_emit(m, sink);
  }
  kqueue_.erase(kqueue_.begin(), kqueue_.begin() + static_cast<std::ptrdiff_t>(flush_count));
}

void Planner::klipper_emit(const KlipperMove& m, MoveSink& sink) {
  const double half_inv_accel = 0.5 / m.accel;
  const double accel_d = std::max(0.0, (m.cruise_v2 - m.start_v2) * half_inv_accel);
  const double decel_d = std::max(0.0, (m.cruise_v2 - m.end_v2) * half_inv_accel);
  const double cruise_d = std::max(0.0, m.move_d - accel_d - decel_d);
  MotionSegment s;
  s.start_time_s = clock_s_;
  s.start_speed_mm_s = std::sqrt(m.start_v2);
  s.cruise_speed_mm_s = std::sqrt(m.cruise_v2);
  s.end_speed_mm_s = std::sqrt(m.end_v2);
  // Time of each phase: its distance over its average speed (as Klipper's set_junction).
  if (accel_d > 0) s.accel_time_s = accel_d / (0.5 * (s.start_speed_mm_s + s.cruise_speed_mm_s));
  if (s.cruise_speed_mm_s > 0) s.cruise_time_s = cruise_d / s.cruise_speed_mm_s;
  if (decel_d > 0) s.decel_time_s = decel_d / (0.5 * (s.end_speed_mm_s + s.cruise_speed_mm_s));
  s.nominal_speed_mm_s = std::sqrt(m.max_cruise_v2);
  s.accel_mm_s2 = m.accel;
  s.length_mm = m.move_d;
  copy_move_fields(s, m.move, m.e_start_mm, m.index);
  if (!m.kinematic) s.end_mm = s.start_mm;
  clock_s_ += s.duration_s();
  sink.on_segment(s);
}

void Planner::wait(double duration_s, bool heating, long line, MoveSink& sink) {
  flush(sink);
  if (duration_s <= 0) return;
  sink.on_wait(clock_s_, duration_s, heating, line);
  clock_s_ += duration_s;
}

}  // namespace printtwin
