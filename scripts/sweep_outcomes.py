#!/usr/bin/env python3
"""Every flight of one or more sweeps counted, the failed ones included: how many converged, how
many sent a flight controller any pose, how many the poses sent were within 0.5, 1 and 2 m of
the truth (ATE RMSE after alignment, as `wins eval`), and the medians (of the sent ATE, the sent
attitude RMSE, the first pose's time and each run's mean NEES) over the runs that sent any. `wins sweep`'s own table
gives its statistics over the converged runs; this one divides by every flight.

    python3 scripts/sweep_outcomes.py "room, default=room/runs.csv" "room, paper=room-paper/runs.csv"

Prints a Markdown table, one row per LABEL=RUNS_CSV. Standard library only.
"""
import csv
import sys


def quantile(values, p):
    v = sorted(values)
    return v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))] if v else None


def fmt(x, digits):
    return "–" if x is None else f"{x:.{digits}f}"


def row(label, path):
    try:
        with open(path, newline="") as f:
            runs = list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"{path}: {e.strerror}")
    n = len(runs)
    if n == 0:
        sys.exit(f"{path}: no runs")

    def values(column):
        return [float(r[column]) for r in runs if r.get(column)]

    sent = values("sent.ate_rmse_m")
    first = values("sent.time_to_first_s")
    nees = values("sent.position_nees_mean")
    attitude = values("sent.attitude_error_rmse_deg")
    converged = sum(r["converged"] == "true" for r in runs)

    def share(k):
        return f"{k} ({100 * k / n:.0f} %)"

    within = [share(sum(v < limit for v in sent)) for limit in (0.5, 1.0, 2.0)]
    return (
        f"| {label} | {n} | {share(converged)} | {share(len(sent))} | "
        + " | ".join(within)
        + f" | {fmt(quantile(sent, 0.5), 2)} / {fmt(quantile(sent, 0.9), 1)}"
        + f" | {fmt(quantile(attitude, 0.5), 1)}"
        + f" | {fmt(quantile(first, 0.5), 1)} | {fmt(quantile(nees, 0.5), 1)} |"
    )


def main():
    if len(sys.argv) < 2 or any("=" not in a for a in sys.argv[1:]):
        sys.exit(__doc__)
    rows = [row(*arg.split("=", 1)) for arg in sys.argv[1:]]
    print(
        "| | flights | converged | a pose sent | sent ATE < 0.5 m | < 1 m | < 2 m "
        "| sent ATE median / p90 (m) | sent attitude, median (°) | first sent, median (s) "
        "| NEES, median run |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(r)

if __name__ == "__main__":
    main()
