// Marlin 2.1's look-ahead planner in millimetres and seconds.
// Behaviour follows Marlin module/planner.cpp (_populate_block, reverse_pass_kernel,
// forward_pass_kernel, recalculate_trapezoids) and, for `prusaslicer_compat`, PrusaSlicer's
// GCodeProcessor::TimeProcessor (classic jerk with its safe-speed rule). Written from the
// published algorithms, not copied.
#include <algorithm>
#include <cmath>

#include "printtwin/planner.hpp"

namespace printtwin {

namespace {
constexpr double kVmin = kMinimumPlannerSpeed_mm_s;

/// Highest speed at the start of a distance `s` from which `accel` reaches `v_end`.
double max_allowable_speed(double accel, double v_end, double s) {
  return std::sqrt(v_end * v_end + 2.0 * accel * s);
}
}  // namespace

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
  if (!L.prusaslicer_compat && L.min_segment_time_s > 0 && queued >= 2 && queued <= capacity_ / 2 - 1) {
    const double t = b.length_mm / v;
    if (t < L.min_segment_time_s) {
      const double stretched = t + 2.0 * (L.min_segment_time_s - t) / static_cast<double>(queued);
      v = b.length_mm / stretched;
    }
  }
  // Per-axis feedrate limits (M203), E included.
  double factor = 1.0;
  for (int i = 0; i < 4; ++i) {
    const double axis_speed = std::fabs(b.unit[i]) * v * factor;
    if (axis_speed > L.max_feedrate_mm_s[i]) factor *= L.max_feedrate_mm_s[i] / axis_speed;
  }
  b.nominal_speed_mm_s = v * factor;

  // Acceleration: M204 R for E-only moves, T for moves without E, P otherwise, then per axis.
  double accel;
  if (L.prusaslicer_compat) {
    // PrusaSlicer's move types: retracting while moving (wipe) counts as travel.
    accel = e_only ? L.retract_accel_mm_s2
                   : (move.e_mm > 0 ? L.print_accel_mm_s2 : L.travel_accel_mm_s2);
    for (int i = 0; i < 4; ++i)
      if (accel * std::fabs(b.unit[i]) > L.max_accel_mm_s2[i]) accel = L.max_accel_mm_s2[i] / std::fabs(b.unit[i]);
  } else if (e_only) {
    accel = L.retract_accel_mm_s2;
  } else {
    accel = move.e_mm != 0 ? L.print_accel_mm_s2 : L.travel_accel_mm_s2;
    // Divide only for the axes that limit (most moves are limited by none or one).
    for (int i = 0; i < 4; ++i)
      if (accel * std::fabs(b.unit[i]) > L.max_accel_mm_s2[i]) accel = L.max_accel_mm_s2[i] / std::fabs(b.unit[i]);
  }
  b.accel_mm_s2 = std::max(accel, 1e-6);

  // Maximum junction speed with the previous block.
  const Eigen::Vector4d axis_speed = b.unit * b.nominal_speed_mm_s;
  double vmax_junction = 0;
  if (L.junction == JunctionModel::junction_deviation) {
    if (have_previous_ && previous_nominal_speed_mm_s_ > 1e-9) {
      double cos_theta = -previous_unit_.dot(b.unit);
      if (cos_theta > 0.999999) {
        vmax_junction = kVmin;  // full reversal
      } else {
        cos_theta = std::max(cos_theta, -0.999999);
        Eigen::Vector4d ju = b.unit - previous_unit_;
        const double jn = ju.norm();
        double junction_accel = b.accel_mm_s2;
        if (jn > 0) {
          ju /= jn;
          for (int i = 0; i < 4; ++i)
            if (junction_accel * std::fabs(ju[i]) > L.max_accel_mm_s2[i])
              junction_accel = L.max_accel_mm_s2[i] / std::fabs(ju[i]);
        }
        const double sin_theta_d2 = std::sqrt(0.5 * (1.0 - cos_theta));
        double vsq = junction_accel * L.junction_deviation_mm * sin_theta_d2 / (1.0 - sin_theta_d2);
        if (L.jd_small_segments && b.length_mm < 1.0 && cos_theta < -0.7071067812) {
          // JD_HANDLE_SMALL_SEGMENTS: short segments of a curve share the speed of the
          // arc they approximate: v^2 = a * length / theta.
          const double theta = std::acos(-cos_theta);
          if (theta > 1e-6) vsq = std::min(vsq, b.length_mm * junction_accel / theta);
        }
        vmax_junction = std::sqrt(vsq);
      }
      vmax_junction = std::min({vmax_junction, b.nominal_speed_mm_s, previous_nominal_speed_mm_s_});
    }
    b.safe_speed_mm_s = kVmin;
  } else {
    // Classic jerk: the speed from which the block may start (or end) at once.
    double safe = b.nominal_speed_mm_s;
    if (L.prusaslicer_compat) {
      for (int i = 0; i < 4; ++i)
        if (std::fabs(axis_speed[i]) > L.jerk_mm_s[i]) safe = std::min(safe, L.jerk_mm_s[i]);
    } else {
      bool limited = false;
      for (int i = 0; i < 4; ++i) {
        const double jerk = std::fabs(axis_speed[i]), maxj = L.jerk_mm_s[i];
        if (jerk > maxj) {
          if (limited) {
            const double mjerk = b.nominal_speed_mm_s * maxj;
            if (mjerk < jerk * safe) safe = mjerk / jerk;
          } else {
            safe *= maxj / jerk;
            limited = true;
          }
        }
      }
    }
    b.safe_speed_mm_s = safe;
    vmax_junction = safe;
    if (have_previous_ && previous_nominal_speed_mm_s_ > 1e-4) {
      const bool prev_larger = previous_nominal_speed_mm_s_ > b.nominal_speed_mm_s;
      vmax_junction = prev_larger ? b.nominal_speed_mm_s : previous_nominal_speed_mm_s_;
      const double smaller_factor = vmax_junction / previous_nominal_speed_mm_s_;
      double v_factor = 1.0;
      bool limited = false;
      for (int i = 0; i < 4; ++i) {
        double v_exit = previous_axis_speed_mm_s_[i] * smaller_factor;
        double v_entry = axis_speed[i];
        if (limited) {
          v_exit *= v_factor;
          v_entry *= v_factor;
        }
        const double jerk = (v_exit > v_entry)
                                ? ((v_entry > 0 || v_exit < 0) ? (v_exit - v_entry) : std::max(v_exit, -v_entry))
                                : ((v_entry < 0 || v_exit > 0) ? (v_entry - v_exit) : std::max(-v_exit, v_entry));
        if (jerk > L.jerk_mm_s[i]) {
          v_factor *= L.jerk_mm_s[i] / jerk;
          limited = true;
        }
      }
      if (limited) vmax_junction *= v_factor;
      const double threshold = vmax_junction * 0.99;
      if (previous_safe_speed_mm_s_ > threshold && safe > threshold) vmax_junction = safe;
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
  double next_entry = limits_.junction == JunctionModel::classic_jerk ? last.safe_speed_mm_s : kVmin;
  std::size_t first_changed = n;
  for (std::size_t k = n; k-- > 0;) {
    Block& b = window_[k];
    if (b.entry_fixed) break;
    const double e = b.nominal_length
                         ? b.max_entry_speed_mm_s
                         : std::min(b.max_entry_speed_mm_s, max_allowable_speed(b.accel_mm_s2, next_entry, b.length_mm));
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
  s.start_mm = b.move.start_mm;
  s.end_mm = b.move.end_mm;
  s.e_start_mm = b.e_start_mm;
  s.e_mm = b.move.e_mm;
  s.line = b.move.line;
  s.layer = b.move.layer;
  s.feature = b.move.feature;
  s.kind = b.move.kind;
  s.object_id = b.move.object_id;
  s.index = b.index;
  clock_s_ += s.duration_s();
  window_.pop_front();
  if (!window_.empty()) {
    window_.front().entry_speed_mm_s = s.end_speed_mm_s;
    window_.front().entry_fixed = true;
  }
  sink.on_segment(s);
}

void Planner::flush(MoveSink& sink) {
  while (!window_.empty()) {
    const double exit = window_.size() > 1
                            ? window_[1].entry_speed_mm_s
                            : (limits_.junction == JunctionModel::classic_jerk ? window_.front().safe_speed_mm_s : kVmin);
    emit_front(sink, exit);
  }
  have_previous_ = false;
  queued_since_sync_ = 0;
}

void Planner::wait(double duration_s, bool heating, long line, MoveSink& sink) {
  flush(sink);
  if (duration_s <= 0) return;
  sink.on_wait(clock_s_, duration_s, heating, line);
  clock_s_ += duration_s;
}

}  // namespace printtwin
