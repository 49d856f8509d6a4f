#!/usr/bin/env python3
"""A family's bounds (scripts/family_bound.sh) against the targets and, when a sweep's runs.csv of
the same flights is given, against what the estimator reached on each.

    python3 scripts/bound_outcomes.py "white 1°=room-white.csv" "persistent 2°, 0.3 s=room-tau.csv" \
        --runs room/runs.csv

Prints a Markdown table, one row per LABEL=BOUND_CSV: the bound's median and 90th percentile, how
many flights' bounds are above 0.3, 0.6 and 2 m (no estimator can do better than its bound, in
expectation), and with --runs, per flight that sent poses, the estimator's sent ATE over the bound
(median) and how many flights' sent ATE is within twice the bound. Standard library only.
"""
import csv
import sys


def quantile(values, p):
    v = sorted(values)
    return v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))] if v else None


def read(path):
    try:
        with open(path, newline="") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"{path}: {e.strerror}")


def main(argv):
    runs_path = None
    if "--runs" in argv:
        i = argv.index("--runs")
        runs_path = argv[i + 1]
        argv = argv[:i] + argv[i + 2:]
    if not argv:
        sys.exit(__doc__)
    sent = {}
    if runs_path:
        for r in read(runs_path):
            if r.get("sent.ate_rmse_m"):
                sent[int(r["seed"])] = float(r["sent.ate_rmse_m"])
    head = "| | flights | bound median / p90 (m) | above 0.3 m | above 0.6 m | above 2 m |"
    line = "|---|---|---|---|---|---|"
    if runs_path:
        head += " sent / bound, median | sent within 2× bound |"
        line += "---|---|"
    print(head)
    print(line)
    for arg in argv:
        label, _, path = arg.partition("=")
        rows = read(path)
        bound = {int(r["seed"]): float(r["ate_bound_m"]) for r in rows}
        b = list(bound.values())
        n = len(b)
        pct = lambda k: f"{k} ({100 * k / n:.0f} %)"
        out = (f"| {label} | {n} | {quantile(b, 0.5):.3f} / {quantile(b, 0.9):.3f} | "
               f"{pct(sum(x > 0.3 for x in b))} | {pct(sum(x > 0.6 for x in b))} | "
               f"{pct(sum(x > 2 for x in b))} |")
        if runs_path:
            both = [(sent[s], bound[s]) for s in bound if s in sent]
            ratio = quantile([e / max(x, 1e-9) for e, x in both], 0.5)
            within = sum(e <= 2 * x for e, x in both)
            out += f" {ratio:.1f} | {within} of {len(both)} |"
        print(out)


if __name__ == "__main__":
    main(sys.argv[1:])
