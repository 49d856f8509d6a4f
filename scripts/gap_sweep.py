#!/usr/bin/env python3
"""Measures the estimator across IMU gaps over many simulated flights.

    python3 scripts/gap_sweep.py WINS WORKDIR [--scenario S] [--seeds A..B] [--at S] [--gaps 2,5]
                                 [--config FILE]

For every seed: simulates the scenario (`wins simulate`), cuts each gap out of imu.csv at --at
seconds (scripts/cut_flight.py), runs the undamaged and every damaged copy (`wins run`), and
scores each with `wins eval --from F` (F = the cut plus 15 s): the position error RMS after F
under one alignment of the whole trajectory, so that a restart's placement is scored and not
only its shape. Also the height error after F, mean |z_est + dz - z_true| with dz the mean
height offset over the poses before the cut (a turn about the vertical leaves heights alone).

Prints one row per seed (each run's RMS and height error), then per gap: how many flights come
back to within twice the undamaged error, the ratio's median, 90th percentile and worst, the
lost runs (no pose after F), and the height error's median, 90th percentile and worst beside
the undamaged flights'. A last line per gap scores each run after F under that segment's own
turn about the vertical and shift (the four directions one AP leaves free), against the
undamaged run's scored the same way: the shape after the restart, its placement against the
flight before set aside. When this line passes where the first does not, what is left is the
heading and position carried across the gap, not the new window.

--config is passed to every `wins run` (to measure a setting). WINS is the wins binary
(target/release/wins); WORKDIR must not exist (it is created and kept). Needs only the Python
standard library (3.11+).
"""
import argparse
import bisect
import math
import os
import re
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def run(cmd):
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


def tum(path):
    """(t, x, y, z) of each pose of a TUM file."""
    rows = []
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                v = [float(x) for x in line.split()]
                rows.append((v[0], v[1], v[2], v[3]))
    return rows


def height_error(est_path, truth_path, cut_s, from_s):
    """Mean |z| error after from_s, the heights offset by their mean difference before cut_s."""
    truth = tum(truth_path)
    times = [r[0] for r in truth]

    def z_true(t):
        i = min(bisect.bisect_left(times, t), len(truth) - 1)
        return truth[i][3]

    est = [(r[0], r[3]) for r in tum(est_path)]
    before = [z_true(t) - z for t, z in est if t < cut_s]
    after = [(t, z) for t, z in est if t >= from_s]
    if not before or not after:
        return None
    dz = statistics.fmean(before)
    return statistics.fmean(abs(z + dz - z_true(t)) for t, z in after)


def own_rms(est_path, truth_path, from_s):
    """The RMS after from_s under that segment's own best turn about the vertical and shift
    (the four directions one AP leaves free): the shape of the estimate after a restart, its
    placement against the flight before set aside. None without poses then."""
    truth = tum(truth_path)
    times = [r[0] for r in truth]
    pairs = []
    for t, x, y, z in tum(est_path):
        if t >= from_s:
            i = min(bisect.bisect_left(times, t), len(truth) - 1)
            pairs.append(((x, y, z), truth[i][1:]))
    if len(pairs) < 3:
        return None
    n = len(pairs)
    me = [sum(e[k] for e, _ in pairs) / n for k in range(3)]
    mt = [sum(q[k] for _, q in pairs) / n for k in range(3)]
    s_cross = s_dot = 0.0
    for e, q in pairs:
        ex, ey, tx, ty = e[0] - me[0], e[1] - me[1], q[0] - mt[0], q[1] - mt[1]
        s_cross += ex * ty - ey * tx
        s_dot += ex * tx + ey * ty
    yaw = math.atan2(s_cross, s_dot)
    c, s = math.cos(yaw), math.sin(yaw)
    total = 0.0
    for e, q in pairs:
        ex, ey, ez = e[0] - me[0], e[1] - me[1], e[2] - me[2]
        d = (c * ex - s * ey - (q[0] - mt[0]), s * ex + c * ey - (q[1] - mt[1]),
             ez - (q[2] - mt[2]))
        total += d[0] ** 2 + d[1] ** 2 + d[2] ** 2
    return math.sqrt(total / n)


def rms_from(wins, est, base, from_s):
    """The RMS after from_s, None when the run gave no pose then (wins eval refuses an empty
    trajectory)."""
    done = subprocess.run([wins, "eval", est, base, "--from", str(from_s)],
                          capture_output=True, text=True)
    m = re.search(r"position error from [0-9.]+ s on: ([0-9.]+) m RMS", done.stdout)
    return float(m.group(1)) if done.returncode == 0 and m else None


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q * (len(xs) - 1))))]


def spread(xs, unit=""):
    """Median, 90th percentile (nearest rank) and worst of xs, or "-" without any."""
    if not xs:
        return "-"
    return (f"median {statistics.median(xs):.2f}{unit}, 90th percentile {pct(xs, 0.9):.2f}, "
            f"worst {max(xs):.2f}")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("wins")
    p.add_argument("workdir")
    p.add_argument("--scenario", default="paper-circle")
    p.add_argument("--seeds", default="1..32")
    p.add_argument("--at", type=float, default=30.0)
    p.add_argument("--gaps", default="2,5")
    p.add_argument("--config", help="a configuration for every `wins run`")
    a = p.parse_args()
    config = ["--config", os.path.abspath(a.config)] if a.config else []
    lo, hi = (int(x) for x in a.seeds.split(".."))
    gaps = [float(g) for g in a.gaps.split(",")]
    from_s = a.at + 15.0
    os.makedirs(a.workdir)
    rows = []
    for seed in range(lo, hi + 1):
        d = os.path.join(a.workdir, f"seed{seed}")
        base = d + "-base"
        run([a.wins, "simulate", "--scenario", a.scenario, "--seed", str(seed), "-o", base])
        truth = os.path.join(base, "truth", "poses.tum")
        row = {"seed": seed}
        for gap in [0.0] + gaps:
            src = base
            if gap > 0:
                src = f"{d}-gap{gap:g}"
                run([sys.executable, os.path.join(HERE, "cut_flight.py"), base, src,
                     str(a.at), str(gap), "imu"])
            out = f"{src}-run"
            run([a.wins, "run", src, "--out", out, "--no-plots"] + config)
            est = os.path.join(out, "trajectory.tum")
            row[gap] = (rms_from(a.wins, est, base, from_s),
                        height_error(est, truth, a.at, from_s),
                        own_rms(est, truth, from_s))
        rows.append(row)
        cells = ", ".join(
            f"{'undamaged' if g == 0 else f'{g:g} s gap'} "
            + ("no pose" if row[g][0] is None else f"{row[g][0]:.3f} m")
            + ("" if row[g][1] is None else f" (height {row[g][1]:.2f} m)")
            for g in [0.0] + gaps)
        print(f"seed {seed:3}: {cells}", flush=True)
    und_rms = [r[0.0][0] for r in rows if r[0.0][0] is not None]
    und_heights = [r[0.0][1] for r in rows if r[0.0][1] is not None]
    rms = f"{statistics.median(und_rms):.3f} m" if und_rms else "-"
    print(f"undamaged: RMS after {from_s:g} s median {rms}; "
          f"height error {spread(und_heights, ' m')}")
    for gap in gaps:
        ratios, own, heights, lost = [], [], [], 0
        for r in rows:
            u, g = r[0.0][0], r[gap][0]
            if g is None or u is None:
                lost += 1
                continue
            ratios.append(g / u)
            if r[gap][1] is not None:
                heights.append(r[gap][1])
            if r[gap][2] is not None and r[0.0][2]:
                own.append(r[gap][2] / r[0.0][2])
        within = sum(q <= 2.0 for q in ratios)
        print(f"{gap:g} s IMU gap: {within} of {len(rows)} within twice the undamaged; ratio "
              f"{spread(ratios)}; lost {lost}; height error {spread(heights, ' m')}")
        print(f"{gap:g} s IMU gap, each run after {from_s:g} s under its own turn and shift: "
              f"{sum(q <= 2.0 for q in own)} of {len(rows)} within twice the undamaged; ratio "
              f"{spread(own)}")

if __name__ == "__main__":
    main()
