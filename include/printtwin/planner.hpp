#pragma once
// Motion planner of the simulated printer: Moves in, timed MotionSegments out.
//
// Two planning models. Marlin's (the default) follows Marlin 2.1's planner (planner.cpp):
// every Move becomes a block with a nominal speed
// limited per axis (X, Y, Z, E), an acceleration chosen from M204 P/R/T and limited per axis,
// and a maximum entry speed from the junction model (junction deviation with the small
// segment rule, or classic jerk). Blocks wait in a look-ahead window of
// `block_buffer_size` blocks; each new block triggers Marlin's reverse pass (decelerate to
// a stop at the end of the window) and forward pass (acceleration limits), and the oldest
// block leaves the window -- and is emitted as a MotionSegment with a trapezoidal speed
// profile -- when the window is full. Memory is bounded by the window, never by the file.
//
// The printer's clock is continuous: dwells and heating waits first drain the window (the
// printer stops, as Marlin's planner.synchronize()) and then advance the clock, so
// `MotionSegment::start_time_s` already includes every wait before it.
//
// Klipper's (MotionLimits::klipper, chosen for profiles whose firmware is "klipper") follows
// klippy/toolhead.py: one acceleration for every move, junction speeds from the junction
// deviation derived from square_corner_velocity, the approximated-centripetal and
// smoothed-reachability caps, minimum_cruise_ratio, the extruder's extrude-only and
// instantaneous-corner limits, and Klipper's look-ahead queue that is flushed lazily once
// 150 ms of moves are queued (docs/simulate.md, "Planning models").
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <deque>
#include <limits>
#include <vector>

#include "printtwin/machine.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin {

/// The motion settings the firmware holds at one moment; M201/M203/M204/M205/M220 change
/// them mid-file. Per-axis values are ordered X, Y, Z, E.
struct MotionLimits {
  Eigen::Vector4d max_feedrate_mm_s{500, 500, 5, 25};    ///< M203
  Eigen::Vector4d max_accel_mm_s2{500, 500, 100, 5000};  ///< M201
  double print_accel_mm_s2 = 500;                        ///< M204 P (and S)
  double retract_accel_mm_s2 = 500;                      ///< M204 R: E-only moves
  double travel_accel_mm_s2 = 500;                       ///< M204 T (and S): moves without E
  JunctionModel junction = JunctionModel::junction_deviation;
  double junction_deviation_mm = 0.08;        ///< M205 J
  bool jd_small_segments = true;              ///< Marlin JD_HANDLE_SMALL_SEGMENTS
  Eigen::Vector4d jerk_mm_s{10, 10, 0.3, 5};  ///< M205 X Y Z E (classic jerk)
  /// Plan like PrusaSlicer's time estimator (GCodeProcessor::TimeProcessor) instead of the
  /// firmware: classic jerk whose "safe speed" is min(nominal, jerk of each moving axis)
  /// (Marlin scales proportionally), moves that retract while moving (wipes) use the travel
  /// acceleration, and E-only moves are limited per axis like any other. Used by
  /// `--limits-from-gcode` to reproduce PrusaSlicer's estimate (docs/simulate.md).
  bool prusaslicer_compat = false;
  /// With prusaslicer_compat: plan like the estimator of OrcaSlicer, Bambu Studio and
  /// Creality Print (PrusaSlicer's GCodeProcessor with Bambu's changes): the X, Y, Z jerk of
  /// a junction is the difference of the velocity vectors (no coasting rule), XY bends of
  /// less than 29 degrees cap the speed at sqrt(print accel * r) of the circle through the
  /// move, moves with E > 0 and Z only count as travel, and the X/Y jerk is
  /// square_corner_velocity_mm_s (Orca reads SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY as
  /// X/Y jerk; limits_from_slicer_config sets it to machine_max_jerk_x).
  bool orca_compat = false;
  /// With orca_compat: Bambu Studio's junction rule instead of OrcaSlicer's. The junction
  /// speed is the largest v at which v times the per-axis change of the X, Y, Z unit
  /// directions stays within each axis's jerk (E is not checked), and it is not capped by
  /// the two blocks' speeds: a slow block followed by a fast one hands the fast one its
  /// junction speed (within what the slow block can reach). Set by
  /// limits_from_prusaslicer_config when the header names Bambu Studio.
  bool bambu_junction = false;
  /// M204 values are clamped to these (PrusaSlicer's machine_max_acceleration_extruding,
  /// _retracting, _travel); infinity = no clamp, as in Marlin.
  Eigen::Vector3d accel_cap_mm_s2 =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  double min_feedrate_mm_s = 0;         ///< M205 S: floor of the requested speed of printing moves
  double min_travel_feedrate_mm_s = 0;  ///< M205 T: floor for moves without E
  /// M205 B: Marlin's SLOWDOWN -- while the buffer holds 2..N/2-1 blocks (it is draining,
  /// e.g. right after a synchronize), blocks shorter than this are slowed down.
  double min_segment_time_s = 0.02;
  /// Ratio of the feedrate override M220 (1 = 100 %); applied by the interpreter.
  double feedrate_scale = 1.0;
  // Klipper's planner (used when the profile's firmware is "klipper"); SET_VELOCITY_LIMIT
  // changes them mid-file. Velocity and accel above are Klipper's max_velocity/max_accel.
  double square_corner_velocity_mm_s = 5.0;   ///< SQUARE_CORNER_VELOCITY
  double minimum_cruise_ratio = 0.5;          ///< MINIMUM_CRUISE_RATIO
  double max_extrude_only_velocity_mm_s = 0;  ///< [extruder]; 0 = derived as Klipper does
  double max_extrude_only_accel_mm_s2 = 0;    ///< [extruder]; 0 = derived as Klipper does
  /// Plan like Klipper's toolhead. Then max_velocity is max_feedrate_mm_s[0], max_accel is
  /// print_accel_mm_s2 (Klipper has one acceleration: M204 and SET_VELOCITY_LIMIT ACCEL set
  /// it), max_z_velocity / max_z_accel are max_feedrate_mm_s[2] / max_accel_mm_s2[2]; the
  /// other per-axis limits, jerk, junction deviation and M205 values are not used.
  bool klipper = false;
  /// [extruder] instantaneous_corner_velocity: caps a junction where the extrusion ratio
  /// (E per mm of XYZ) changes by d to (v / d)^2.
  double extruder_corner_velocity_mm_s = 1.0;
};

/// Klipper's junction deviation (mm) for a square corner velocity and an acceleration:
/// scv^2 (sqrt 2 - 1) / accel, so a 90-degree corner is taken at scv whatever the accel.
[[nodiscard]] double klipper_junction_deviation_mm(double square_corner_velocity_mm_s,
                                                   double accel_mm_s2);
/// Klipper's default max_extrude_only_velocity / _accel ratio: a 4 d_nozzle^2 cross
/// section over the filament's area (times max_velocity or max_accel of the config).
[[nodiscard]] double klipper_default_extrude_ratio(double nozzle_diameter_mm,
                                                   double filament_diameter_mm);

/// The limits of a printer profile at power-on.
[[nodiscard]] MotionLimits motion_limits_from_profile(const PrinterProfile& profile);

/// Marlin's MINIMUM_PLANNER_SPEED: a block never needs to slow below this (mm/s).
inline constexpr double kMinimumPlannerSpeed_mm_s = 0.05;

/// One planned block: a straight move with a trapezoidal speed profile along its path.
/// Like Klipper's `struct move` (trapq.h): start time, the three phases, start position and
/// direction. Speeds are along the path; for E-only moves the path is the filament (|E|).
struct MotionSegment {
  double start_time_s = 0;   ///< printer clock at the start (includes earlier waits)
  double accel_time_s = 0;   ///< accelerating from start_speed to cruise_speed
  double cruise_time_s = 0;  ///< at cruise_speed
  double decel_time_s = 0;   ///< decelerating from cruise_speed to end_speed
  double start_speed_mm_s = 0;
  double cruise_speed_mm_s = 0;  ///< highest speed reached (<= nominal_speed_mm_s)
  double end_speed_mm_s = 0;
  double nominal_speed_mm_s = 0;  ///< requested speed after per-axis feedrate limits
  double accel_mm_s2 = 0;         ///< acceleration along the path (after per-axis limits)
  double length_mm = 0;           ///< path length: XYZ distance, or |E| for E-only moves
  Vec3 start_mm = Vec3::Zero();   ///< nozzle at the start (machine frame)
  Vec3 end_mm = Vec3::Zero();     ///< nozzle at the end
  double e_start_mm = 0;          ///< cumulative filament (mm) pushed before this segment
  double e_mm = 0;                ///< filament of this segment (negative: retraction)
  long line = 0;                  ///< G-code line of the Move
  int layer = -1;
  Feature feature = Feature::unknown;
  MoveKind kind = MoveKind::travel;
  int object_id = -1;
  long index = 0;  ///< 0-based index of the Move in the stream

  [[nodiscard]] double duration_s() const { return accel_time_s + cruise_time_s + decel_time_s; }
  [[nodiscard]] double end_time_s() const { return start_time_s + duration_s(); }
  /// Distance travelled along the path `t_s` seconds after the start (clamped to the segment).
  [[nodiscard]] double distance_at(double t_s) const;
  /// Speed along the path `t_s` seconds after the start.
  [[nodiscard]] double speed_at(double t_s) const;
  /// Nozzle position `t_s` seconds after the start.
  [[nodiscard]] Vec3 position_at(double t_s) const;
};

/// Receives the simulation's output as a stream, in order. Override what you need; each
/// call gets a reference valid only during the call. Used by simulate_gcode (simulate.hpp),
/// the deposit and the trace writer.
class MoveSink {
 public:
  virtual ~MoveSink() = default;
  /// Each Move as the interpreter resolves it (arcs already segmented), in file order.
  virtual void on_move(const Move& move) { (void)move; }
  /// Each planned segment once its timing is final (it left the look-ahead window).
  virtual void on_segment(const MotionSegment& segment) { (void)segment; }
  /// The printer stands still from `start_time_s` for `duration_s` (G4 dwell, M109/M190
  /// heating wait); `heating` tells which. `line` is the G-code line.
  virtual void on_wait(double start_time_s, double duration_s, bool heating, long line) {
    (void)start_time_s, (void)duration_s, (void)heating, (void)line;
  }
};

/// Marlin's look-ahead planner over a window of `block_buffer_size` blocks, or Klipper's
/// look-ahead queue when `limits.klipper` (the window size is then unused).
///
///   Planner planner(motion_limits_from_profile(profile), profile.block_buffer_size);
///   planner.add(move, sink);  ...  planner.flush(sink);
///
/// Cost: O(window) per move. Not thread-safe; one planner per simulation.
class Planner {
 public:
  Planner(const MotionLimits& limits, int block_buffer_size);

  /// New limits for the moves added from now on (blocks already planned keep theirs, as in
  /// Marlin, where M201/M203/M204/M205 affect only blocks planned afterwards).
  void set_limits(const MotionLimits& limits);
  [[nodiscard]] const MotionLimits& limits() const { return limits_; }

  /// Plans a move; segments that leave the window are passed to `sink.on_segment`.
  /// Moves with no XYZ and no E motion are ignored.
  void add(const Move& move, MoveSink& sink);
  /// Runs every planned block to a stop (M400, G4, M109, G28, end of file).
  void flush(MoveSink& sink);
  /// Flushes, then stands still for `duration_s` (reported with sink.on_wait).
  void wait(double duration_s, bool heating, long line, MoveSink& sink);

  /// Printer clock: end of the last emitted segment or wait (s).
  [[nodiscard]] double clock_s() const { return clock_s_; }
  /// Number of blocks waiting in the look-ahead window.
  [[nodiscard]] int queued() const { return static_cast<int>(window_.size() + kqueue_.size()); }

 private:
  struct Block {
    Eigen::Vector4d delta_mm = Eigen::Vector4d::Zero();  ///< X Y Z E
    Eigen::Vector4d unit = Eigen::Vector4d::Zero();      ///< delta / length (junction vector)
    double length_mm = 0;
    double nominal_speed_mm_s = 0;
    double accel_mm_s2 = 0;
    double max_entry_speed_mm_s = 0;
    double entry_speed_mm_s = 0;
    double reverse_entry_mm_s = -1;  ///< entry from the last reverse pass (before the forward pass)
    double safe_speed_mm_s = 0;      ///< classic jerk: speed the block may start/stop at
    bool nominal_length = false;     ///< nominal speed reachable from a stop within the block
    bool entry_fixed = false;        ///< the block before it already left the window
    Move move;
    double e_start_mm = 0;
    long index = 0;
  };

  void emit_front(MoveSink& sink, double exit_speed_mm_s);
  void recalculate();

  // Klipper's planner (toolhead.py: Move, LookAheadQueue), squared speeds as Klipper keeps them.
  struct KlipperMove {
    Move move;
    double e_start_mm = 0;
    long index = 0;
    Eigen::Vector4d axes_r = Eigen::Vector4d::Zero();  ///< X Y Z E per mm of move_d
    double move_d = 0;      ///< XYZ length, or |E| for extrude-only moves
    bool kinematic = true;  ///< moves XYZ
    double accel = 0;
    double junction_deviation = 0;
    double min_move_t = 0;  ///< move_d at the cruise speed (for the flush timer)
    double max_cruise_v2 = 0;
    double delta_v2 = 0;  ///< 2 * move_d * accel
    double max_start_v2 = 0;
    double max_mcr_start_v2 = 0;  ///< minimum_cruise_ratio's start limit
    double mcr_delta_v2 = 0;      ///< 2 * move_d * accel * (1 - minimum_cruise_ratio)
    // Set by the flush.
    double start_v2 = 0, cruise_v2 = -1, end_v2 = 0;
  };
  void klipper_add(const Move& move, MoveSink& sink);
  /// LookAheadQueue.flush: plans the queue to a stop at its end; `lazy` emits only the moves
  /// whose speeds later moves can no longer change.
  void klipper_flush(MoveSink& sink, bool lazy);
  void klipper_emit(const KlipperMove& m, MoveSink& sink);
  std::vector<KlipperMove> kqueue_;
  double junction_flush_s_ = 1.0;  ///< queued move time left before a lazy flush

  MotionLimits limits_;
  std::size_t capacity_;
  std::deque<Block> window_;
  double clock_s_ = 0;
  double e_total_mm_ = 0;
  long next_index_ = 0;
  long queued_since_sync_ = 0;
  // State of the previous block for the junction (Marlin's previous_* variables).
  bool have_previous_ = false;
  Eigen::Vector4d previous_unit_ = Eigen::Vector4d::Zero();
  Eigen::Vector4d previous_axis_speed_mm_s_ = Eigen::Vector4d::Zero();
  double previous_nominal_speed_mm_s_ = 0;
  double previous_safe_speed_mm_s_ = 0;
  Eigen::Vector2d previous_xy_dir_ =
      Eigen::Vector2d::Zero();  ///< unit XY direction (Orca's centripetal cap)
  double previous_xy_len_ = 0;
  long previous_line_ = -1;  ///< G-code line of the previous move (segments of one arc share it)
};

}  // namespace printtwin
