// `printtwin simulate part.gcode`: run any slicer's G-code on the simulated printer.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "cli/deposit_options.hpp"
#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/simulate.hpp"

namespace printtwin::cli {

namespace {
struct SimulateCliOptions {
  std::string input;
  std::string printer = "auto";
  std::string json_path;
  std::string trace_path;
  double trace_hz = 10;
  bool strict = false;
  bool limits_from_gcode = false;
  bool quiet = false;
  DepositCliOptions deposit;  // --deposit, --deposit-ply, --voxel, ... (deposit_options.hpp)
};

/// Samples the twin's state at a fixed rate: nozzle on the bed, the seed's three joints
/// (Joint_X head on the beam, Joint_Y bed = -y, Joint_Z gantry), filament, speed, line.
class TraceWriter final : public MoveSink {
 public:
  explicit TraceWriter(double hz) : dt_(1.0 / hz) {
    csv_ = "t_s,x_mm,y_mm,z_mm,joint_x_mm,joint_y_mm,joint_z_mm,e_mm,speed_mm_s,line\n";
  }
  void on_segment(const MotionSegment& s) override {
    const double end = s.end_time_s();
    while (next_t_ < end) {
      const double t = next_t_ - s.start_time_s;
      const double f = s.length_mm > 0 ? s.distance_at(t) / s.length_mm : 1.0;
      write(next_t_, s.position_at(t), s.e_start_mm + f * s.e_mm, s.speed_at(t), s.line);
      next_t_ += dt_;
    }
    pos_ = s.end_mm;
    e_ = s.e_start_mm + s.e_mm;
    line_ = s.line;
  }
  void on_wait(double start_s, double duration_s, bool, long line) override {
    const double end = start_s + duration_s;
    while (next_t_ < end) {
      write(next_t_, pos_, e_, 0.0, line);
      next_t_ += dt_;
    }
    line_ = line;
  }
  const std::string& csv() const { return csv_; }

 private:
  void write(double t, const Vec3& p, double e, double v, long line) {
    csv_ += format_fixed(t, 4) + ',' + format_fixed(p.x(), 4) + ',' + format_fixed(p.y(), 4) + ',' +
            format_fixed(p.z(), 4) + ',' + format_fixed(p.x(), 4) + ',' + format_fixed(-p.y(), 4) +
            ',' + format_fixed(p.z(), 4) + ',' + format_fixed(e, 5) + ',' + format_fixed(v, 3) +
            ',' + std::to_string(line) + '\n';
  }
  double dt_;
  double next_t_ = 0;
  Vec3 pos_ = Vec3::Zero();
  double e_ = 0;
  long line_ = 0;
  std::string csv_;
};
}  // namespace

void add_simulate_command(CLI::App& app, CommandRunner& runner) {
  auto o = std::make_shared<SimulateCliOptions>();
  auto* cmd = app.add_subcommand(
      "simulate", "Run G-code on the simulated printer (timing, filament, layers, findings)");
  cmd->add_option("gcode", o->input, "G-code file from any slicer")->required();
  cmd->add_option(
         "--printer", o->printer,
         "auto (the printer the file's settings name), a library printer (printtwin printers), "
         "ender3, ender3-marlin1, ender3-klipper, a profile .json or a Klipper printer.cfg")
      ->capture_default_str();
  cmd->add_option("--json", o->json_path, "Write the result as JSON (schema printtwin.simulate/1)");
  cmd->add_option("--trace", o->trace_path, "Write the twin's state over time as CSV");
  cmd->add_option("--trace-hz", o->trace_hz, "Trace sampling rate (Hz)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 10000.0));
  cmd->add_flag("--strict", o->strict,
                "Warnings about the input are errors; warning findings fail the run");
  cmd->add_flag("--limits-from-gcode", o->limits_from_gcode,
                "Use the machine limits in PrusaSlicer's config block at the end of the file "
                "(and its estimator's classic-jerk model)");
  cmd->add_flag("-q,--quiet", o->quiet, "No summary on stdout");
  add_deposit_options(*cmd, o->deposit);
  cmd->callback([o, &runner] {
    runner.run = [o]() -> int {
      if (auto st =
              check_output_paths({{o->json_path, "--json", OutputKind::file},
                                  {o->trace_path, "--trace", OutputKind::file},
                                  {o->deposit.octomap_path, "--deposit", OutputKind::file},
                                  {o->deposit.ply_path, "--deposit-ply", OutputKind::file},
                                  {o->deposit.mesh.path, "--deposit-mesh", OutputKind::file}});
          !st)
        return report_error(st.error());
      if (auto mesh = deposit_mesh_options(o->deposit.mesh); !mesh)
        return report_error(mesh.error());
      // Missing, a directory, a symbolic link loop: said in those words, before any work.
      if (auto size = input_file_size(o->input); !size) return report_error(size.error());
      auto resolved = resolve_printer(o->printer, o->input);
      if (!resolved) return report_error(resolved.error());
      auto profile = std::optional<PrinterProfile>(std::move(resolved->profile));
      SimulateOptions options;
      options.interpreter.strict = o->strict;
      options.limits_from_gcode = o->limits_from_gcode;
      std::unique_ptr<TraceWriter> trace;
      if (!o->trace_path.empty()) trace = std::make_unique<TraceWriter>(o->trace_hz);
      DepositStage deposit(o->deposit, trace.get());
      auto sim = simulate_gcode_file(o->input, *profile, options, deposit.sink());
      if (!sim) return report_error(sim.error());
      // Nothing moved: whatever the file is, it was not understood as a print.
      if (sim->moves == 0)
        return report_error(bad_input(
            "no moves: " + std::to_string(sim->lines) + (sim->lines == 1 ? " line" : " lines") +
                " but not one G0/G1/G2/G3 move, expected a print's G-code",
            o->input));
      if (auto st = deposit.run(*profile, *sim); !st) return report_error(st.error());
      if (!o->json_path.empty()) {
        if (auto st = write_file_atomic(o->json_path,
                                        deposit.patch_json(simulation_to_json(*sim, o->input)));
            !st)
          return report_error(st.error());
      }
      if (trace) {
        if (auto st = write_file_atomic(o->trace_path, trace->csv()); !st)
          return report_error(st.error());
      }
      if (!o->quiet)
        std::fputs((o->input + "\n" + simulation_summary(*sim) + deposit.summary()).c_str(),
                   stdout);
      bool fail = has_errors(sim->findings);
      if (o->strict)
        for (const auto& f : sim->findings)
          if (f.severity == Severity::warning) fail = true;
      return fail ? kFail : kPass;
    };
  });
}

}  // namespace printtwin::cli
