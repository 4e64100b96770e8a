#!/usr/bin/env python3
"""Helper of bench/mesh_c2m_compare.sh (no third-party modules).

  mesh_c2m_stats.py vertices ASPRINTED.ply VERTICES.ply
      the vertices of printtwin's binary PLY mesh as a point cloud (binary PLY, float x y z)
  mesh_c2m_stats.py surface ASPRINTED.ply POINTS.ply [SPACING_MM]
      points spread uniformly over the mesh's surface (one per SPACING^2 of area on average,
      default 0.05 mm; fixed seed), as a point cloud: C2M from them is the mean over the
      surface, as verify's figure is, whatever the triangulation
  mesh_c2m_stats.py compare ASPRINTED.ply CC.asc REPORT.json [CC_SURFACE.asc]
      CloudCompare's C2M distances (ASC: x y z d per line, the vertices in file order):
      mean and RMS per vertex and weighted by vertex area (a third of the area of the
      triangles around each vertex), against verify's deposit -> mesh mean and RMS.
  mesh_c2m_stats.py regions ASPRINTED.ply CC_SURFACE.asc REPORT.json [SPACING_MM [BANDS]]
      where they differ: per band of layers (the first two and last two layers alone) and per
      kind of mesh surface (side, caps facing up, caps facing down), the C2M of the surface
      points (the same points as `surface` with the same spacing) against verify's
      per-layer figures
  mesh_c2m_stats.py kinds ASPRINTED.ply CC_SURFACE.asc CC_VERIFY.asc [SPACING_MM [STRIDE]]
      the same per kind of surface, on both sides: CloudCompare's C2M of verify's own deposit
      samples (CC_VERIFY.asc: `deviation_bench --export`'s points.ply, every STRIDE-th
      sample, unweighted) against that of the mesh's surface points, each verify sample
      given the kind of the nearest mesh surface point; the first layer (bottom to one layer
      up, without the bed plane) and the caps of the top two layers apart (a layer:
      PRINTTWIN_FIRST_LAYER_MM, default 0.2)
"""
import json
import math
import random
import struct
import sys
from array import array


def read_mesh(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    nv = nf = 0
    props = 0
    in_vertex = False
    for line in header:
        p = line.split()
        if p[:2] == ["element", "vertex"]:
            nv, in_vertex = int(p[2]), True
        elif p[:2] == ["element", "face"]:
            nf, in_vertex = int(p[2]), False
        elif p[:2] == ["property", "float"] and in_vertex:
            props += 1
    verts = array("f")
    verts.frombytes(data[end:end + nv * props * 4])
    xyz = array("d", [0.0]) * (3 * nv)
    for i in range(nv):
        xyz[3 * i:3 * i + 3] = array("d", verts[props * i:props * i + 3])
    faces = []
    off = end + nv * props * 4
    rec = struct.Struct("<B3i")
    for k in range(nf):
        faces.append(rec.unpack_from(data, off + 13 * k)[1:])
    return xyz, faces


def vertex_areas(xyz, faces):
    area = array("d", [0.0]) * (len(xyz) // 3)
    for a, b, c in faces:
        ax, ay, az = xyz[3 * a:3 * a + 3]
        ux, uy, uz = xyz[3 * b] - ax, xyz[3 * b + 1] - ay, xyz[3 * b + 2] - az
        vx, vy, vz = xyz[3 * c] - ax, xyz[3 * c + 1] - ay, xyz[3 * c + 2] - az
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        third = math.sqrt(cx * cx + cy * cy + cz * cz) / 6.0
        area[a] += third
        area[b] += third
        area[c] += third
    return area


def surface_points(xyz, faces, spacing, seed=1, normals=None):
    """The points (x y z floats); `normals` (a list, optional) gets each point's triangle's
    unit normal z."""
    rng = random.Random(seed)
    density = 1.0 / (spacing * spacing)
    out = array("f")
    for a, b, c in faces:
        ax, ay, az = xyz[3 * a:3 * a + 3]
        ux, uy, uz = xyz[3 * b] - ax, xyz[3 * b + 1] - ay, xyz[3 * b + 2] - az
        vx, vy, vz = xyz[3 * c] - ax, xyz[3 * c + 1] - ay, xyz[3 * c + 2] - az
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        expect = 0.5 * math.sqrt(cx * cx + cy * cy + cz * cz) * density
        k = int(expect)
        if rng.random() < expect - k:
            k += 1
        if normals is not None and k > 0:
            nz = cz / max(math.sqrt(cx * cx + cy * cy + cz * cz), 1e-30)
            normals.extend([nz] * k)
        for _ in range(k):
            s, t = rng.random(), rng.random()
            if s + t > 1.0:
                s, t = 1.0 - s, 1.0 - t
            out.extend((ax + s * ux + t * vx, ay + s * uy + t * vy, az + s * uz + t * vz))
    return out


def read_distances(path):
    d = array("d")
    with open(path) as f:
        for line in f:
            p = line.replace(",", " ").split()
            if len(p) >= 4:
                d.append(float(p[-1]))
    return d


def surface_with_distances(mesh_path, cc_surface, spacing):
    """The mesh's surface points (as `surface` spreads them), their normals' z and
    CloudCompare's C2M distance of each."""
    xyz, faces = read_mesh(mesh_path)
    nz = []
    pts = surface_points(xyz, faces, spacing, normals=nz)
    d = read_distances(cc_surface)
    if len(d) != len(nz):
        sys.exit("CloudCompare gave %d distances for %d surface points" % (len(d), len(nz)))
    return pts, nz, d


def regions(mesh_path, cc_surface, report_path, spacing, bands):
    """Per layer band and per kind of surface (side: |nz| < 0.99; up / down caps: flat): the C2M of
    the points spread over the mesh against verify's per-layer deposit -> mesh figures (its
    layers combined by sample count, all kinds of surface together)."""
    pts, nz, d = surface_with_distances(mesh_path, cc_surface, spacing)
    layers = json.load(open(report_path)).get("per_layer", [])
    tops = [l["z_mm"] for l in layers]
    if not tops:
        sys.exit("no per_layer in the report")
    n = len(tops)
    edges = [0, 1, 2] + [2 + (n - 4) * i // bands for i in range(1, bands)] + [n - 2, n - 1, n]
    edges = sorted(set(e for e in edges if 0 <= e <= n))
    band_of = [0] * n
    for b in range(len(edges) - 1):
        for k in range(edges[b], edges[b + 1]):
            band_of[k] = b
    acc = [[[0, 0.0, 0.0] for _ in range(3)] for _ in range(len(edges) - 1)]
    import bisect
    for i in range(len(d)):
        k = min(bisect.bisect_left(tops, pts[3 * i + 2] - 1e-6), n - 1)
        kind = 0 if abs(nz[i]) < 0.99 else (1 if nz[i] > 0 else 2)
        a = acc[band_of[k]][kind]
        a[0] += 1
        a[1] += d[i]
        a[2] += d[i] * d[i]
    area = spacing * spacing
    print("%-13s | %-22s | %-30s | %-30s | %-22s" %
          ("layers", "verify mean / RMS", "mesh all mean / RMS (mm2)", "mesh side mean / RMS (mm2)",
           "mesh caps up / down mean"))
    for b in range(len(edges) - 1):
        lo, hi = edges[b], edges[b + 1]
        cnt = sum(l["deposit_to_mesh"]["samples"] for l in layers[lo:hi])
        vm = vr = float("nan")
        if cnt:
            vm = sum(l["deposit_to_mesh"]["samples"] * l["deposit_to_mesh"]["mean_mm"]
                     for l in layers[lo:hi]) / cnt
            vr = math.sqrt(sum(l["deposit_to_mesh"]["samples"] * l["deposit_to_mesh"]["rms_mm"] ** 2
                               for l in layers[lo:hi]) / cnt)
        tot = [sum(acc[b][k][j] for k in range(3)) for j in range(3)]

        def fig(a):
            if a[0] == 0:
                return "      -"
            return "%+.4f %.4f (%6.0f)" % (a[1] / a[0], math.sqrt(a[2] / a[0]), a[0] * area)
        caps = " ".join("%+.4f" % (acc[b][k][1] / acc[b][k][0]) if acc[b][k][0] else "   -   "
                        for k in (1, 2))
        print("%4d-%-8d | %+.4f %.4f (%7d) | %-30s | %-30s | %s" %
              (lo, hi - 1, vm, vr, cnt, fig(tot), fig(acc[b][0]), caps))


def kinds(mesh_path, cc_surface, cc_verify, spacing, stride):
    """Verify's samples and the mesh's surface points per kind of surface (see the usage)."""
    pts, nz, d = surface_with_distances(mesh_path, cc_surface, spacing)
    zmin = min(pts[2::3])
    zmax = max(pts[2::3])
    cell = 4 * spacing
    grid = {}
    for i in range(len(nz)):
        key = (int(pts[3 * i] // cell), int(pts[3 * i + 1] // cell), int(pts[3 * i + 2] // cell))
        grid.setdefault(key, []).append(i)
    names = ["bed (z = bottom)", "first layer sides", "sides", "caps up, top 2 layers",
             "caps up, below", "caps down"]

    def kind(z, normal_z):
        if z < zmin + 0.01:
            return 0
        if abs(normal_z) < 0.99:
            return 1 if z < zmin + LAYER_MM else 2
        if normal_z < 0:
            return 5
        return 3 if z > zmax - 2 * LAYER_MM - 0.01 else 4
    mesh_acc = [[0, 0.0, 0.0] for _ in names]
    for i in range(len(nz)):
        a = mesh_acc[kind(pts[3 * i + 2], nz[i])]
        a[0] += 1
        a[1] += d[i]
        a[2] += d[i] * d[i]
    ver_acc = [[0, 0.0, 0.0] for _ in names]
    with open(cc_verify) as f:
        for n, line in enumerate(f):
            if n % stride:
                continue
            p = line.replace(",", " ").split()
            if len(p) < 4:
                continue
            x, y, z, dist = (float(v) for v in p[:4])
            cx, cy, cz = int(x // cell), int(y // cell), int(z // cell)
            best, bi = 1e18, -1
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for dz in (-1, 0, 1):
                        for i in grid.get((cx + dx, cy + dy, cz + dz), ()):
                            e = ((pts[3 * i] - x) ** 2 + (pts[3 * i + 1] - y) ** 2 +
                                 (pts[3 * i + 2] - z) ** 2)
                            if e < best:
                                best, bi = e, i
            if bi < 0:
                continue
            a = ver_acc[kind(z, nz[bi])]
            a[0] += 1
            a[1] += dist
            a[2] += dist * dist

    def fig(a):
        if a[0] == 0:
            return "%-24s" % "-"
        return "%+.4f %.4f (%7d)" % (a[1] / a[0], math.sqrt(a[2] / a[0]), a[0])
    print("%-19s | %-24s | %-24s" % ("kind (z %.3f-%.3f)" % (zmin, zmax),
                                     "verify samples mean/RMS", "mesh surface mean/RMS"))
    for k, name in enumerate(names):
        print("%-19s | %s | %s" % (name, fig(ver_acc[k]), fig(mesh_acc[k])))


LAYER_MM = 0.2  # the first layer's band above the bed (PRINTTWIN_FIRST_LAYER_MM)


def main():
    global LAYER_MM
    import os
    LAYER_MM = float(os.environ.get("PRINTTWIN_FIRST_LAYER_MM", LAYER_MM))
    if sys.argv[1] == "kinds":
        kinds(sys.argv[2], sys.argv[3], sys.argv[4],
              float(sys.argv[5]) if len(sys.argv) > 5 else 0.05,
              int(sys.argv[6]) if len(sys.argv) > 6 else 1)
        return
    if sys.argv[1] == "regions":
        regions(sys.argv[2], sys.argv[3], sys.argv[4],
                float(sys.argv[5]) if len(sys.argv) > 5 else 0.05,
                int(sys.argv[6]) if len(sys.argv) > 6 else 8)
        return
    if sys.argv[1] == "surface":
        xyz, faces = read_mesh(sys.argv[2])
        pts = surface_points(xyz, faces, float(sys.argv[4]) if len(sys.argv) > 4 else 0.05)
        with open(sys.argv[3], "wb") as f:
            f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n"
                     "property float y\nproperty float z\nend_header\n" % (len(pts) // 3)).encode())
            pts.tofile(f)
        return
    if sys.argv[1] == "vertices":
        xyz, _ = read_mesh(sys.argv[2])
        n = len(xyz) // 3
        with open(sys.argv[3], "wb") as f:
            f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n"
                     "property float y\nproperty float z\nend_header\n" % n).encode())
            array("f", xyz).tofile(f)
        return
    xyz, faces = read_mesh(sys.argv[2])
    d = array("d")
    with open(sys.argv[3]) as f:
        for line in f:
            p = line.replace(",", " ").split()
            if len(p) >= 4:
                d.append(float(p[-1]))
    n = len(xyz) // 3
    if len(d) != n:
        sys.exit("CloudCompare gave %d distances for %d vertices" % (len(d), n))
    w = vertex_areas(xyz, faces)
    sw = sum(w)
    plain_mean = sum(d) / n
    plain_rms = math.sqrt(sum(x * x for x in d) / n)
    w_mean = sum(wi * x for wi, x in zip(w, d)) / sw
    w_rms = math.sqrt(sum(wi * x * x for wi, x in zip(w, d)) / sw)
    ours = json.load(open(sys.argv[4]))["deviation"]["deposit_to_mesh"]
    print("verify deposit -> mesh (area-weighted): mean %+.4f mm, RMS %.4f mm (%d points)" %
          (ours["mean_mm"], ours["rms_mm"], ours["samples"]))
    print("mesh area %.1f mm2, %d vertices" % (sw, n))
    weighted_off = 0.0  # the larger relative difference of the area-weighted figures
    for name, m, r in (("CloudCompare C2M per vertex", plain_mean, plain_rms),
                       ("CloudCompare C2M area-weighted", w_mean, w_rms)):
        dm = abs(m - ours["mean_mm"]) / abs(ours["mean_mm"])
        dr = abs(r - ours["rms_mm"]) / ours["rms_mm"]
        print("%-31s mean %+.4f mm (%+.1f %%), RMS %.4f mm (%+.1f %%)" %
              (name, m, 100 * (m - ours["mean_mm"]) / abs(ours["mean_mm"]), r,
               100 * (r - ours["rms_mm"]) / ours["rms_mm"]))
        weighted_off = max(dm, dr)  # the last row is the area-weighted one
    print("agreement (area-weighted, goal within 5 %%): %s" %
          ("OK" if weighted_off <= 0.05 else "NOT OK"))
    if len(sys.argv) > 5:  # C2M from points spread over the mesh's surface
        ds = read_distances(sys.argv[5])
        m = sum(ds) / len(ds)
        r = math.sqrt(sum(x * x for x in ds) / len(ds))
        off = max(abs(m - ours["mean_mm"]) / abs(ours["mean_mm"]),
                  abs(r - ours["rms_mm"]) / ours["rms_mm"])
        print("%-31s mean %+.4f mm (%+.1f %%), RMS %.4f mm (%+.1f %%) (%d points)" %
              ("CloudCompare C2M surface points", m,
               100 * (m - ours["mean_mm"]) / abs(ours["mean_mm"]), r,
               100 * (r - ours["rms_mm"]) / ours["rms_mm"], len(ds)))
        print("agreement (surface points, goal within 5 %%): %s" %
              ("OK" if off <= 0.05 else "NOT OK"))
    # Where they differ: by layer (a vertex in the first layer whose top is at or above it;
    # verify's layer figures combined by their sample counts, an approximation).
    layers = json.load(open(sys.argv[4])).get("per_layer", [])
    if len(layers) >= 5:
        tops = [l["z_mm"] for l in layers]
        groups = (("first two layers", 0, 2), ("middle layers", 2, len(tops) - 2),
                  ("last two layers", len(tops) - 2, len(tops)))
        acc = [[0.0, 0.0, 0.0] for _ in groups]
        for i in range(n):
            z = xyz[3 * i + 2]
            k = next((j for j, t in enumerate(tops) if t >= z - 1e-6), len(tops) - 1)
            g = 0 if k < 2 else (2 if k >= len(tops) - 2 else 1)
            acc[g][0] += w[i]
            acc[g][1] += w[i] * d[i]
            acc[g][2] += w[i] * d[i] * d[i]
        for (name, lo, hi), (a, s1, s2) in zip(groups, acc):
            cnt = sum(l["deposit_to_mesh"]["samples"] for l in layers[lo:hi])
            if cnt == 0 or a == 0:
                continue
            vm = sum(l["deposit_to_mesh"]["samples"] * l["deposit_to_mesh"]["mean_mm"]
                     for l in layers[lo:hi]) / cnt
            vr = math.sqrt(sum(l["deposit_to_mesh"]["samples"] * l["deposit_to_mesh"]["rms_mm"] ** 2
                               for l in layers[lo:hi]) / cnt)
            print("  %-17s verify mean %+.4f RMS %.4f | C2M area-weighted mean %+.4f RMS %.4f"
                  " (%.0f mm2)" % (name, vm, vr, s1 / a, math.sqrt(s2 / a), a))


if __name__ == "__main__":
    main()
