#!/usr/bin/env python3
"""How many beads of a G-code file could the deposit lay at once, at best?

The deposit's bead loop is serial: each bead reads the height map and the occupancy that the
beads before it left. Two beads can be laid side by side only when neither reaches the other's
columns. This script bounds the gain of any such schedule: it links each extrusion to the last
earlier extrusion that touched the same XY cell (cells of CELL mm, each bead widened by REACH
mm: half its width plus the squeeze's reach), weights each bead by its length plus a fixed
cost per bead (COST, in mm of bead), and prints the total work divided by the longest chain
of dependent beads: the speed-up no schedule of whole beads can beat, on any number of cores.

Usage: bench/bead_parallelism.py FILE.gcode [REACH_MM=1.0] [COST_MM=1.0] [CELL_MM=1.0]
(text G-code with G0/G1 moves, absolute or relative E; arcs are not read).
"""
import math
import sys


def extrusions(path):
    x = y = z = e = 0.0
    relative = False
    for raw in open(path, errors="replace"):
        words = raw.split(";", 1)[0].split()
        if not words:
            continue
        cmd = words[0].upper()
        if cmd == "M83":
            relative = True
        elif cmd == "M82":
            relative = False
        elif cmd == "G92":
            for w in words[1:]:
                if w[:1].upper() == "E":
                    e = float(w[1:] or 0)
        elif cmd in ("G0", "G1"):
            nx, ny, nz, ne = x, y, z, None
            for w in words[1:]:
                try:
                    v = float(w[1:])
                except ValueError:
                    continue
                c = w[:1].upper()
                if c == "X":
                    nx = v
                elif c == "Y":
                    ny = v
                elif c == "Z":
                    nz = v
                elif c == "E":
                    ne = v
            de = 0.0
            if ne is not None:
                de = ne if relative else ne - e
                if not relative:
                    e = ne
            if de > 0 and (nx != x or ny != y):
                yield (x, y, nx, ny)
            x, y, z = nx, ny, nz


def main():
    path = sys.argv[1]
    reach = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    cost = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
    cell = float(sys.argv[4]) if len(sys.argv) > 4 else 1.0
    last = {}
    finish = []
    total = 0.0
    for i, (x0, y0, x1, y1) in enumerate(extrusions(path)):
        length = math.hypot(x1 - x0, y1 - y0)
        work = length + cost
        total += work
        start = 0.0
        cells = []
        for cx in range(math.floor((min(x0, x1) - reach) / cell),
                        math.floor((max(x0, x1) + reach) / cell) + 1):
            for cy in range(math.floor((min(y0, y1) - reach) / cell),
                            math.floor((max(y0, y1) + reach) / cell) + 1):
                px, py = (cx + 0.5) * cell, (cy + 0.5) * cell
                dx, dy = x1 - x0, y1 - y0
                t = 0.0 if length == 0 else max(0.0, min(1.0, ((px - x0) * dx + (py - y0) * dy) / (length * length)))
                if math.hypot(px - (x0 + t * dx), py - (y0 + t * dy)) <= reach + cell * math.sqrt(0.5):
                    cells.append((cx, cy))
                    j = last.get((cx, cy))
                    if j is not None:
                        start = max(start, finish[j])
        finish.append(start + work)
        for c in cells:
            last[c] = i
    critical = max(finish) if finish else 0.0
    print(f"{len(finish)} beads, work {total:.0f}, longest chain {critical:.0f}, "
          f"best speed-up {total / critical if critical else 0:.2f}x")


if __name__ == "__main__":
    main()
