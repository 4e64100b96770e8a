#!/usr/bin/env python3
"""Writes bench/bench_model.scad's part as an ASCII STL without OpenSCAD: the same lobed
polygon (500 points), extruded 40 mm in 200 slices with a 60 degree twist (clockwise going
up, as OpenSCAD's linear_extrude), side quads split in two, caps fanned from the axis (the
polygon is star-shaped around it): 201,000 triangles, 4 more than OpenSCAD's caps give.
Usage: bench/bench_model_stl.py OUT.stl"""
import math
import sys

N, SLICES, HEIGHT, TWIST = 500, 200, 40.0, 60.0


def radius(a):
    return 15.6 + 2.2 * math.sin(math.radians(7 * a)) + 0.6 * math.sin(math.radians(31 * a))


def ring(k):
    z = HEIGHT * k / SLICES
    rot = -math.radians(TWIST * k / SLICES)
    out = []
    for i in range(N):
        a = 360.0 * i / N
        r = radius(a)
        x, y = r * math.cos(math.radians(a)), r * math.sin(math.radians(a))
        out.append((x * math.cos(rot) - y * math.sin(rot), x * math.sin(rot) + y * math.cos(rot), z))
    return out


def facet(f, p, q, r):
    u = [q[i] - p[i] for i in range(3)]
    v = [r[i] - p[i] for i in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    length = math.sqrt(sum(c * c for c in n)) or 1.0
    f.write("facet normal %g %g %g\n outer loop\n" % tuple(c / length for c in n))
    for pt in (p, q, r):
        f.write("  vertex %.6f %.6f %.6f\n" % pt)
    f.write(" endloop\nendfacet\n")


def main():
    rings = [ring(k) for k in range(SLICES + 1)]
    with open(sys.argv[1], "w") as f:
        f.write("solid bench_model\n")
        for k in range(SLICES):
            lo, hi = rings[k], rings[k + 1]
            for i in range(N):
                j = (i + 1) % N
                facet(f, lo[i], lo[j], hi[j])
                facet(f, lo[i], hi[j], hi[i])
        bottom, top = rings[0], rings[SLICES]
        for i in range(N):
            j = (i + 1) % N
            facet(f, (0.0, 0.0, 0.0), bottom[j], bottom[i])
            facet(f, (0.0, 0.0, HEIGHT), top[i], top[j])
        f.write("endsolid bench_model\n")


main()
