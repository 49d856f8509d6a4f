"""A researcher's first hour with wins from Python: a real capture, its AoA, a simulated flight
and its run, with matplotlib. Run from the repository root:

    pip install ./crates/wins-py matplotlib
    python crates/wins-py/examples/first_hour.py        # figures go to target/python-example/
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import wins

out = Path("target/python-example")
out.mkdir(parents=True, exist_ok=True)

# 1. A real Intel 5300 capture, as csiread would give it.
log = wins.read_csi("data/intel5300/csikit_example.dat")
print(log.count, "packets, CSI", log.csi.shape, log.csi.dtype)
amplitude_db = 20 * np.log10(np.abs(log.csi[:, :, :, 0]) + 1e-9)  # stream 0
print("mean amplitude per antenna (dB):", amplitude_db.mean(axis=(0, 1)).round(1))

# 2. Its per-packet AoA with the shipped settings (a λ/2 array on channel 64 by default).
angles = wins.aoa("data/intel5300/csikit_example.dat")
print(angles.summary["packets"], "packets,", angles.summary["with_aoa"], "with an AoA")
print("median AoA (deg):", np.nanmedian(angles.rows["aoa_deg"]).round(1))

# 3. A simulated flight, run as `wins run` runs it.
wins.simulate(out / "flight", "paper-circle", seed=2)
run = wins.run(out / "flight", out / "run")
print("ATE RMSE (m):", round(run.metrics["ate_rmse_m"], 3),
      "| converged at (s):", run.stats["converged_at_s"])
sigma = np.sqrt(np.diagonal(run.covariance[:, :3, :3], axis1=1, axis2=2))
print("median position sigma x, y, z (m):", np.median(sigma, axis=0).round(3))

fig, (top, side) = plt.subplots(1, 2, figsize=(10, 4))
top.plot(run.p_b_in_w[:, 0], run.p_b_in_w[:, 1], lw=1)
for name, (p, c) in run.aps.items():
    top.plot(p[0], p[1], "rx")
    top.annotate(name, (p[0], p[1]))
top.set_aspect("equal")
top.set_title("track from above (estimate's frame)")
side.plot(run.t, sigma)
side.set_title("position sigma (m)")
side.legend(["x", "y", "z"])
fig.savefig(out / "flight.png", dpi=80)
print("wrote", out / "flight.png")
