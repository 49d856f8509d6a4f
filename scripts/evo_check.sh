#!/usr/bin/env bash
# evo_check.sh: checks that `wins eval` computes the ATE, attitude error and RPE exactly as evo.
#
# Set-up (once; evo writes its settings to ~/.evo on its first run):
#   python3 -m venv /tmp/evo-venv && /tmp/evo-venv/bin/pip install evo==1.38.1
#
# Usage, from the repository root:
#   scripts/evo_check.sh EST.tum TRUTH.tum [RPE_DELTA]
#       Runs on the same two files
#         evo_ape tum TRUTH EST -a                                 vs  ate_rmse_m
#         evo_ape tum TRUTH EST -a -r angle_deg                    vs  attitude_error_rmse_deg
#         evo_rpe tum TRUTH EST --delta N --delta_unit f           vs  rpe_trans_rmse_m
#         evo_rpe tum TRUTH EST --delta N --delta_unit f -r angle_deg  vs  rpe_rot_rmse_deg
#       and `wins eval EST TRUTH --rpe-delta N --align se3 --json` (N = RPE_DELTA, default 1; both with the
#       default 10 ms association tolerance), prints the pairs side by side, and exits 1 if any
#       pair differs by more than 1e-6 relative (plus 1e-12 absolute, for errors that are ~0).
#   scripts/evo_check.sh --perturb TRUTH.tum EST.tum [SEED]
#       Writes a test estimate: TRUTH from 2 s on, every 4th pose, moved by a random rigid
#       transform, with 5 cm / 1° Gaussian noise, ±2 ms time jitter and three poses after the
#       truth ends (unmatched in both tools).
#
# Environment: EVO_VENV (default /tmp/evo-venv); WINS, the wins command (default
# `cargo run -q --release -p wins-cli --`).
set -euo pipefail

EVO_VENV=${EVO_VENV:-/tmp/evo-venv}
PY="$EVO_VENV/bin/python"
export MPLBACKEND=Agg

if [[ ${1:-} == --perturb ]]; then
    [[ $# -ge 3 ]] || { echo "usage: $0 --perturb TRUTH.tum EST.tum [SEED]" >&2; exit 2; }
    "$PY" - "$2" "$3" "${4:-1}" <<'EOF'
import sys
import numpy as np
from scipy.spatial.transform import Rotation

truth_path, est_path, seed = sys.argv[1], sys.argv[2], int(sys.argv[3])
rng = np.random.default_rng(seed)
rows = np.loadtxt(truth_path, comments="#")
t0 = rows[0, 0]
rows = rows[rows[:, 0] >= t0 + 2.0][::4]
t_end = np.loadtxt(truth_path, comments="#")[-1, 0]
extra = rows[-1:].repeat(3, axis=0)
extra[:, 0] = t_end + np.array([0.05, 0.1, 0.15])
rows = np.vstack([rows, extra])
est_from_truth = Rotation.from_rotvec(rng.normal(size=3))
offset = rng.uniform(-5, 5, size=3)
p = est_from_truth.apply(rows[:, 1:4]) + offset + rng.normal(scale=0.05, size=(len(rows), 3))
att = Rotation.from_rotvec(np.deg2rad(1.0) * rng.normal(size=(len(rows), 3)))
q = (est_from_truth * Rotation.from_quat(rows[:, 4:8]) * att).as_quat()  # x y z w
t = rows[:, 0] + rng.uniform(-0.002, 0.002, size=len(rows))
with open(est_path, "w") as f:
    f.write("# timestamp tx ty tz qx qy qz qw\n")
    for i in range(len(rows)):
        f.write(f"{t[i]:.9f} " + " ".join(repr(float(x)) for x in (*p[i], *q[i])) + "\n")
print(f"{est_path}: {len(rows)} poses")
EOF
    exit 0
fi

[[ $# -ge 2 ]] || { echo "usage: $0 EST.tum TRUTH.tum [RPE_DELTA]" >&2; exit 2; }
EST=$1
TRUTH=$2
DELTA=${3:-1}
read -r -a WINS_CMD <<<"${WINS:-cargo run -q --release -p wins-cli --}"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

# Runs an evo tool with --save_results and prints the full-precision RMSE from its stats.json.
evo_rmse() {
    local tool=$1 zip
    shift
    zip="$WORK/$tool-$RANDOM.zip"
    "$EVO_VENV/bin/$tool" tum "$TRUTH" "$EST" "$@" --save_results "$zip" --no_warnings --silent
    "$PY" -c 'import json, sys, zipfile; print(repr(json.loads(zipfile.ZipFile(sys.argv[1]).read("stats.json"))["rmse"]))' "$zip"
}

evo_ate=$(evo_rmse evo_ape -a)
evo_att=$(evo_rmse evo_ape -a -r angle_deg)
evo_rpe_t=$(evo_rmse evo_rpe --delta "$DELTA" --delta_unit f)
evo_rpe_r=$(evo_rmse evo_rpe --delta "$DELTA" --delta_unit f -r angle_deg)
"${WINS_CMD[@]}" eval "$EST" "$TRUTH" --rpe-delta "$DELTA" --align se3 --json >"$WORK/wins.json"

"$PY" - "$WORK/wins.json" "$evo_ate" "$evo_att" "$evo_rpe_t" "$evo_rpe_r" "$DELTA" <<'EOF'
import json, sys

wins = json.load(open(sys.argv[1]))
evo = [float(x) for x in sys.argv[2:6]]
delta = sys.argv[6]
rows = [
    ("evo_ape -a", "ate_rmse_m"),
    ("evo_ape -a -r angle_deg", "attitude_error_rmse_deg"),
    (f"evo_rpe --delta {delta}", "rpe_trans_rmse_m"),
    (f"evo_rpe --delta {delta} -r angle_deg", "rpe_rot_rmse_deg"),
]
print(f"wins: {wins['poses_evaluated']} poses evaluated, {wins['poses_unmatched']} unmatched, "
      f"{wins['rpe_pairs']} RPE pairs")
print(f"{'evo':<34}{'evo RMSE':>24}  {'wins':<26}{'wins value':>24}  {'rel. diff':>9}")
failed = False
for (evo_name, key), e in zip(rows, evo):
    w = wins[key]
    diff = abs(w - e)
    rel = diff / max(abs(w), abs(e)) if max(abs(w), abs(e)) > 0 else 0.0
    ok = diff <= 1e-6 * max(abs(w), abs(e)) + 1e-12
    failed |= not ok
    print(f"{evo_name:<34}{e:>24.15g}  {key:<26}{w:>24.15g}  {rel:>9.1e}{'' if ok else '  MISMATCH'}")
sys.exit(1 if failed else 0)
EOF
