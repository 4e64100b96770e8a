#!/usr/bin/env python3
"""Compares CloudCompare's C2M distances (ASC export: x y z d per line) with printtwin's
figures ("n N mean_abs A rms R max_abs M" from deviation_bench --c2m) and prints the
differences and the speed ratio. Used by bench/c2m_compare.sh."""
import math
import sys


def main():
    asc, ours_line, t_ours, t_cc = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
    n = 0
    s_abs = 0.0
    s2 = 0.0
    mx = 0.0
    with open(asc) as f:
        for line in f:
            parts = line.split()
            if len(parts) < 4:
                continue
            d = abs(float(parts[-1]))
            n += 1
            s_abs += d
            s2 += d * d
            mx = max(mx, d)
    cc = {"n": n, "mean_abs": s_abs / n, "rms": math.sqrt(s2 / n), "max_abs": mx}
    tok = ours_line.split()
    ours = {tok[i]: float(tok[i + 1]) for i in range(0, len(tok) - 1, 2)}
    print(f"points: ours {int(ours['n'])}, CloudCompare {n}")
    worst = 0.0
    for key in ("mean_abs", "rms", "max_abs"):
        diff = abs(ours[key] - cc[key])
        worst = max(worst, diff)
        print(f"{key:9s} ours {ours[key]:.9f}  CloudCompare {cc[key]:.9f}  |diff| {diff:.2e} mm")
    print(f"agreement: {'OK' if worst <= 1e-4 else 'NOT OK'} (largest |diff| {worst:.2e} mm, goal 1e-4)")
    print(f"whole process (median of 3): ours {t_ours:.3f} s, CloudCompare {t_cc:.3f} s, "
          f"ratio {t_cc / t_ours:.1f}x")


if __name__ == "__main__":
    main()
