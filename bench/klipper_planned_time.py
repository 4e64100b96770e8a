#!/usr/bin/env python3
"""Klipper's own planned motion time for a G-code file, to compare with printtwin's.

Runs the klippy of an existing, already built Klipper checkout in batch mode (its
docs/Debugging.md, "Translating gcode files to micro-controller commands") and sums
accel_t + cruise_t + decel_t of every move its look-ahead queue releases (extrude-only
moves included, dwells apart). This script builds nothing: the checkout's
klippy/chelper/c_helper.so and the micro-controller data dictionary must exist.

  bench/klipper_planned_time.py --klipper ~/klipper --dict ~/klipper/out/klipper.dict \\
      printer.cfg part.gcode
  -> {"move_s": 332.659372, "moves": 2231, "dwell_s": 0.2}

printer.cfg needs an [mcu] whose pins the dictionary knows, [homing_override] (batch mode
cannot home: e.g. SET_KINEMATIC_POSITION X=0 Y=0 Z=0 with [force_move]
enable_force_move: True) and dummy [gcode_macro] entries for START_PRINT / END_PRINT style
macros of the slicer. Compare "move_s" with `printtwin simulate part.gcode --printer P
--json out.json` -> motion_time_s, P having the same [printer] and [extruder] numbers.
Batch mode does not wait for heaters, so M109/M190 do not stop the toolhead there while
a printer (and printtwin) stops at them: add M400 after them for an exact comparison.
"""
import argparse
import json
import os
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--klipper", required=True, help="path of a built Klipper checkout")
    ap.add_argument("--dict", required=True, help="micro-controller data dictionary (out/klipper.dict)")
    ap.add_argument("config", help="printer.cfg")
    ap.add_argument("gcode", help="G-code file")
    args = ap.parse_args()
    klippy = os.path.join(os.path.abspath(args.klipper), "klippy")
    if not os.path.isfile(os.path.join(klippy, "chelper", "c_helper.so")):
        sys.exit("error: %s has no built chelper (c_helper.so); build Klipper first" % klippy)
    if not os.path.isfile(args.dict):
        sys.exit("error: no data dictionary at %s" % args.dict)
    sys.path.insert(0, klippy)
    import toolhead  # noqa: E402  (Klipper's module)

    stats = {"move_s": 0.0, "moves": 0, "dwell_s": 0.0}
    flush = toolhead.LookAheadQueue.flush

    def counting_flush(self, lazy=False):
        moves = flush(self, lazy)
        for m in moves:
            stats["move_s"] += m.accel_t + m.cruise_t + m.decel_t
            stats["moves"] += 1
        return moves

    dwell = toolhead.ToolHead.dwell

    def counting_dwell(self, delay):
        stats["dwell_s"] += max(0.0, delay)
        return dwell(self, delay)

    toolhead.LookAheadQueue.flush = counting_flush
    toolhead.ToolHead.dwell = counting_dwell
    import atexit
    atexit.register(lambda: print(json.dumps(stats), flush=True))
    import klippy as klippy_main  # noqa: E402
    sys.argv = ["klippy.py", args.config, "-i", args.gcode, "-o", os.devnull, "-d", args.dict,
                "-l", os.devnull]
    klippy_main.main()


if __name__ == "__main__":
    main()
