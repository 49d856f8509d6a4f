#!/usr/bin/env python3
"""Simulated CSI against real: each statistic of `wins csi stats` on the real static captures
(their range) beside the simulated static capture's (docs/VALIDATION.md, "Simulated CSI against
real"). Standard library only.

    python3 scripts/csi_realism.py [SHARED_DATA] [--seeds 3] [--before]

SHARED_DATA defaults to ../shared/data; the lgtm captures of `intel5300/lgtm` are used except
`0-degrees test-5` (something moved during it). The simulated capture is the built-in
`static-capture` (the same set-up: 0.1 m spacing, channel 64, the AP 1 m away at 20°), one per
seed; `--before` simulates it as the simulator did before its impairments were measured
(`[radio] receiver_response = "flat"`, `sto_max_s` = 100 ns). Exits 1 when a simulated value
falls outside the real range. Uses `wins` from PATH, or target/release/wins.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

# How far outside the real range a simulated value may fall and still count: the sampling error
# of the statistic over one capture of about 1000 packets (the timing offsets' IQR of a uniform
# draw scatters by about ±0.4 ns); 0 for the rest.
TOLERANCE = {"timing_offset_iqr_ns": 0.5}

ROWS = [
    ("phase between chains A, B: IQR over packets (deg)", "chain_phase_iqr_deg", 1),
    ("chains' curvature: agreement over packets", "curvature_agreement", 2),
    ("smoothed covariance: λ2/λ1 (dB)", ("eigenvalue_db", 0), 1),
    ("smoothed covariance: λ3/λ1 (dB)", ("eigenvalue_db", 1), 1),
    ("smoothed covariance: λ4/λ1 (dB)", ("eigenvalue_db", 2), 1),
    ("amplitude ripple over the subcarriers, chain A (dB)", "amplitude_ripple_db", 2),
    ("ripple of the amplitude ratio of neighbouring chains (dB)", "chain_amplitude_ripple_db", 2),
    ("ripple of the phase between neighbouring chains (deg)", "chain_phase_ripple_deg", 1),
    ("timing offset: IQR over packets (ns)", "timing_offset_iqr_ns", 1),
    ("AGC changes per 100 packets", "agc_changes_per_100", 1),
    ("credible MUSIC peaks per packet", "peaks_per_packet", 2),
    ("packets with a credible peak in another direction (%)", "other_direction_pct", 1),
]


def wins():
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "target", "release", "wins")
    return shutil.which("wins") or here


def stats(files):
    out = subprocess.run(
        [wins(), "csi", "stats", "--spacing-m", "0.1", "--json", *files],
        check=True, capture_output=True, text=True,
    ).stdout
    return [json.loads(line)["stats"] for line in out.splitlines() if line.strip()]


def value(s, key):
    return s[key[0]][key[1]] if isinstance(key, tuple) else s[key]


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    seeds = int(argv[argv.index("--seeds") + 1]) if "--seeds" in argv else 3
    if "--seeds" in argv:
        args.remove(str(seeds))
    shared = args[0] if args else os.path.join("..", "shared", "data")
    lgtm = os.path.join(shared, "intel5300", "lgtm")
    real = sorted(
        os.path.join(lgtm, f) for f in os.listdir(lgtm) if f.endswith(".dat") and "test-5" not in f
    )
    tmp = tempfile.mkdtemp()
    try:
        scenario = os.path.join(tmp, "static.toml")
        text = subprocess.run(
            [wins(), "simulate", "--print-scenario", "static-capture"],
            check=True, capture_output=True, text=True,
        ).stdout
        if "--before" in argv:
            text = text.replace('receiver_response = "intel5300"', 'receiver_response = "flat"')
            text = "\n".join(
                "sto_max_s = 1e-7" if line.startswith("sto_max_s") else line
                for line in text.splitlines()
            )
        with open(scenario, "w") as f:
            f.write(text)
        sims = []
        for seed in range(1, seeds + 1):
            out = os.path.join(tmp, f"s{seed}")
            subprocess.run(
                [wins(), "simulate", "--scenario-file", scenario, "--seed", str(seed), "--out", out],
                check=True, capture_output=True,
            )
            sims.append(os.path.join(out, "ap0.dat"))
        r, s = stats(real), stats(sims)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"| statistic | real: {len(r)} static lgtm captures (min – max) | simulated `static-capture`, {len(s)} seeds | within |")
    print("|---|---|---|---|")
    inside_all = True
    for label, key, digits in ROWS:
        rv = [value(x, key) for x in r]
        sv = [value(x, key) for x in s]
        lo, hi = min(rv), max(rv)
        tol = TOLERANCE.get(key if isinstance(key, str) else key[0], 0.0)
        inside = all(lo - tol <= v <= hi + tol for v in sv)
        inside_all &= inside
        fmt = f"{{:.{digits}f}}"
        sims_text = ", ".join(fmt.format(v) for v in sv)
        print(f"| {label} | {fmt.format(lo)} – {fmt.format(hi)} | {sims_text} | {'yes' if inside else 'no'} |")
    return 0 if inside_all else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
