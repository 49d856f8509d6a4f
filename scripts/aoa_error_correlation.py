#!/usr/bin/env python3
"""How independent are a run's bearings? The per-packet AoA error of a simulated flight and how
much of it persists from packet to packet.

    wins simulate --family room --seed 26 --duration-s 60 -o ds
    wins run ds -o out
    python3 scripts/aoa_error_correlation.py ds out

For each AP, over the packets the run fed to the estimator (`out/aoa.csv`, status `fed`), matched
to the simulator's truth (`ds/truth/packets_apN.csv`, nearest packet within 1 ms):

- the median error and a robust σ (1.4826 × MAD); the errors within 4 robust σ of the median are
  the inliers, their standard deviation `sd`;
- for blocks of B seconds, the long-run variance ratio `n · Var(block means) / sd²` (n the mean
  packets per block): 1 when the errors are independent from packet to packet, n when every
  block's errors are one and the same. A ratio r means a block of n packets carries the
  information of n / r independent ones;
- `indep/s`: packets per second divided by the ratio of the 2 s blocks, the independent
  bearings per second the errors are worth.

Standard library only.
"""

import bisect
import csv
import glob
import os
import statistics as st
import sys

BLOCKS_S = (0.5, 1.0, 2.0, 5.0)
MATCH_NS = 1_000_000


def truth_by_ap(dataset):
    out = {}
    for path in glob.glob(os.path.join(dataset, "truth", "packets_ap*.csv")):
        ap = int(os.path.basename(path)[len("packets_ap"):-len(".csv")])
        rows = [(int(r["t_ns"]), float(r["aoa_deg"])) for r in csv.DictReader(open(path))]
        rows.sort()
        out[ap] = rows
    return out


def nearest(rows, t_ns):
    i = bisect.bisect_left(rows, (t_ns, float("-inf")))
    best = None
    for j in (i - 1, i):
        if 0 <= j < len(rows) and abs(rows[j][0] - t_ns) <= MATCH_NS:
            if best is None or abs(rows[j][0] - t_ns) < abs(best[0] - t_ns):
                best = rows[j]
    return best


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__.strip().splitlines()[0] + "\nusage: aoa_error_correlation.py DATASET RUN_OUT")
    dataset, run_out = sys.argv[1], sys.argv[2]
    truth = truth_by_ap(dataset)
    errors = {}
    unmatched = 0
    for r in csv.DictReader(open(os.path.join(run_out, "aoa.csv"))):
        if r["status"] != "fed":
            continue
        ap, t_ns = int(r["ap"]), int(r["t_ns"])
        match = nearest(truth.get(ap, []), t_ns)
        if match is None:
            unmatched += 1
            continue
        e = (float(r["aoa_deg"]) - match[1] + 180.0) % 360.0 - 180.0
        errors.setdefault(ap, []).append((t_ns / 1e9, e))
    print(f"fed packets without a truth packet within 1 ms: {unmatched}")
    header = "ap  packets  median  robust σ  inlier sd  " + "  ".join(
        f"ratio {b:g} s" for b in BLOCKS_S) + "  indep/s"
    print(header)
    for ap, xs in sorted(errors.items()):
        es = [e for _, e in xs]
        med = st.median(es)
        mad = 1.4826 * st.median([abs(e - med) for e in es])
        inliers = [(t, e) for t, e in xs if abs(e - med) <= 4.0 * mad]
        if len(inliers) < 10:
            print(f"{ap:>2}  {len(es):>7}  too few inliers")
            continue
        sd = st.pstdev([e for _, e in inliers])
        span = inliers[-1][0] - inliers[0][0]
        rate = len(inliers) / span if span > 0 else float("nan")
        ratios = []
        for b in BLOCKS_S:
            blocks = {}
            for t, e in inliers:
                blocks.setdefault(int(t // b), []).append(e)
            full = [v for v in blocks.values() if len(v) >= 3]
            if len(full) < 4 or sd == 0.0:
                ratios.append(float("nan"))
                continue
            n = st.mean(len(v) for v in full)
            ratios.append(n * st.pvariance([st.mean(v) for v in full]) / sd**2)
        cells = "  ".join(f"{r:>{len(f'ratio {b:g} s')}.1f}" for r, b in zip(ratios, BLOCKS_S))
        indep = rate / max(ratios[2], 1.0) if ratios[2] == ratios[2] else float("nan")
        print(f"{ap:>2}  {len(es):>7}  {med:>6.2f}  {mad:>8.2f}  {sd:>9.2f}  {cells}  {indep:>7.1f}")


if __name__ == "__main__":
    main()
