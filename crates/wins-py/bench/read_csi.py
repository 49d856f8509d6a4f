"""Reading a ~100 MB Intel 5300 log to numpy: `wins.read_csi` against csiread, in one run.

    pip install ./crates/wins-py csiread
    python crates/wins-py/bench/read_csi.py [--mb 100] [--repeat 3]

The log is the repository's largest real capture repeated to the size asked (records are
self-framed, so the copies make one valid log). Each reader reads it `--repeat` times; the best
time of each is printed, and their ratio (wins over csiread: below 1 is faster).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import csiread
import numpy as np

import wins

REPO = Path(__file__).resolve().parents[3]


def best(f, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mb", type=float, default=100.0)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    source = max((REPO / "data" / "intel5300").glob("*.dat"), key=lambda p: p.stat().st_size)
    block = source.read_bytes()
    copies = max(1, round(args.mb * 1e6 / len(block)))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.dat"
        with open(path, "wb") as f:
            for _ in range(copies):
                f.write(block)
        size_mb = path.stat().st_size / 1e6
        ours = wins.read_csi(path, ntx=3)
        theirs = csiread.Intel(str(path), nrxnum=3, ntxnum=3, if_report=False)
        theirs.read()
        assert ours.count == theirs.count and np.array_equal(ours.csi, theirs.csi)

        def read_theirs() -> None:
            c = csiread.Intel(str(path), nrxnum=3, ntxnum=3, if_report=False)
            c.read()

        t_wins = best(lambda: wins.read_csi(path, ntx=3), args.repeat)
        t_csiread = best(read_theirs, args.repeat)
    print(f"log: {source.name} x {copies} = {size_mb:.1f} MB, {ours.count} packets")
    print(f"wins.read_csi   {t_wins:.3f} s")
    print(f"csiread.Intel   {t_csiread:.3f} s")
    print(f"ratio wins / csiread: {t_wins / t_csiread:.2f}")


if __name__ == "__main__":
    main()
