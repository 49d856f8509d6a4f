#!/usr/bin/env python3
"""Were a simulated run's receive-chain offsets resolved right, and what would the run give with
the right ones? Standard library only (Python 3.11+ for tomllib).

    wins simulate --family room --seed 28 --duration-s 60 -o ds28 && wins run ds28 -o out28
    python3 scripts/chain_decisions.py report ds28 out28 [DATASET RUN ...]

prints, per run, the offsets the run flew with (`stats.json` `chain_offsets.phase_offsets_rad`)
against the simulator's (`truth/truth.toml` `chain_phase_offsets_rad`), both relative to chain 0:
each chain's error in degrees, "wrong" when one exceeds 45° (a restart step, π at 5 GHz, resolved
wrong puts every bearing at an alias), the hypotheses' scores and when the run decided, the
median AoA error and the sent ATE.

    python3 scripts/chain_decisions.py truth-calibration ds28 ds28-truth
    printf '[pipeline.chains]\\nresolve = false\\n' > as-given.toml
    wins run ds28-truth -o out28-truth --config as-given.toml

copies the dataset with a `calibration.toml` holding the simulator's own chain offsets, to fly
the estimator with the offsets known (what the run would give had it resolved them right).
"""
import json
import math
import os
import re
import shutil
import sys
import tomllib


def wrap(x):
    return (x + math.pi) % (2 * math.pi) - math.pi


def truth_offsets(dataset):
    with open(os.path.join(dataset, "truth", "truth.toml"), "rb") as f:
        t = tomllib.load(f)["chain_phase_offsets_rad"]
    return [wrap(x - t[0]) for x in t]


def report(pairs):
    print("dataset | calibration | chain errors (°) | resolved | hypotheses (step°/curvature°: score) "
          "| decided at (s) | AoA error median (°) | sent ATE (m)")
    print("|".join(["---"] * 8))
    for dataset, run in pairs:
        try:
            with open(os.path.join(run, "stats.json")) as f:
                stats = json.load(f)
        except OSError as e:
            print(f"{dataset} | {run}: no stats.json ({e.strerror}) | | | | | |")
            continue
        metrics = {}
        if os.path.exists(os.path.join(run, "metrics.json")):
            with open(os.path.join(run, "metrics.json")) as f:
                metrics = json.load(f)
        drawn = ""
        if os.path.exists(os.path.join(dataset, "drawn.toml")):
            with open(os.path.join(dataset, "drawn.toml"), "rb") as f:
                drawn = tomllib.load(f).get("calibration", "")
        chains = stats.get("chain_offsets") or {}
        truth = truth_offsets(dataset)
        flown = chains.get("phase_offsets_rad")
        if flown:
            errors = [math.degrees(wrap(flown[i] - flown[0] - truth[i])) for i in range(1, len(truth))]
            verdict = "wrong" if max(abs(e) for e in errors) > 45 else "right"
            errors = " ".join(f"{e:.0f}" for e in errors)
        else:
            errors, verdict = "–", "–"
        scores = chains.get("scores") or []
        hyps = zip(chains.get("hypotheses_deg") or [], chains.get("hypotheses_curvature_deg") or [],
                   scores + [None] * len(chains.get("hypotheses_deg") or []))
        hyps = ", ".join(f"{s:.0f}/{c:.0f}: {'–' if v is None else f'{v:.2f}'}" for s, c, v in hyps)
        decided = chains.get("decided_at_s")
        aoa = metrics.get("aoa_error_median_deg")
        sent = (metrics.get("sent") or {}).get("ate_rmse_m")
        fmt = lambda x, d: "–" if x is None else f"{x:.{d}f}"
        print(f"{dataset} | {drawn} | {errors} | {verdict} | {hyps} | {fmt(decided, 1)} "
              f"| {fmt(aoa, 1)} | {fmt(sent, 2)}")


def truth_calibration(dataset, out):
    if os.path.exists(out):
        sys.exit(f"{out} exists: give a new folder")
    shutil.copytree(dataset, out)
    offsets = truth_offsets(dataset)
    with open(os.path.join(out, "calibration.toml"), "w") as f:
        f.write(f"phase_offsets_rad = {offsets}\n"
                f'source = "the simulator\'s own chain offsets ({dataset}/truth/truth.toml)"\n')
    path = os.path.join(out, "dataset.toml")
    with open(path) as f:
        text = f.read()
    if not re.search(r"^calibration\s*=", text, re.M):
        text, n = re.subn(r"^\[array\]\n", '[array]\ncalibration = "calibration.toml"\n', text,
                          count=1, flags=re.M)
        if n != 1:
            sys.exit(f"{path}: no [array] table")
        with open(path, "w") as f:
            f.write(text)
    print(f"wrote {out} (chain offsets {[round(x, 4) for x in offsets]} rad)")


def main():
    args = sys.argv[1:]
    if len(args) >= 3 and args[0] == "report" and len(args) % 2 == 1:
        report(list(zip(args[1::2], args[2::2])))
    elif len(args) == 3 and args[0] == "truth-calibration":
        truth_calibration(args[1], args[2])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
