#!/usr/bin/env python3
"""The same drawn flights with the bearings' multipath taken away: copies every scenario file of a
folder (as `wins sweep --family …` keeps them in OUT/scenarios/) with the room's reflections off
(`max_order = 0`) and its obstacles removed, everything else as drawn (IMU, vibration, chain
offsets, packet rate, trajectory). Flying both sets with the same seed tells what the estimator
loses to the AoA stage's multipath from what it loses on its own. Standard library only
(Python 3.11+ for tomllib).

    wins sweep --family room --seeds 1..80 --duration-s 60 -o room80
    python3 scripts/without_reflections.py room80/scenarios direct
    wins sweep --scenario $(ls room80/scenarios/*.toml | paste -sd,) --seeds 1 --duration-s 60 -o with
    wins sweep --scenario $(ls direct/*.toml | paste -sd,) --seeds 1 --duration-s 60 -o without
    python3 scripts/sweep_outcomes.py "as drawn=with/runs.csv" "direct path only=without/runs.csv"
"""
import os
import re
import sys
import tomllib

OBSTACLE_TABLE = re.compile(r"^\[\[obstacles\]\]\n(?:(?!\[)[^\n]*\n)*", re.MULTILINE)
MAX_ORDER = re.compile(r"^max_order = \d+$", re.MULTILINE)


def without_reflections(text):
    """The scenario's text with `max_order = 0` and no `[[obstacles]]` table."""
    if not MAX_ORDER.search(text):
        raise ValueError("no `max_order = N` line under [room]")
    text = MAX_ORDER.sub("max_order = 0", text)
    text = OBSTACLE_TABLE.sub("", text)
    parsed = tomllib.loads(text)
    if parsed.get("room", {}).get("max_order") != 0 or parsed.get("obstacles"):
        raise ValueError("the rewrite did not take")
    return text


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    source, target = argv[1], argv[2]
    os.makedirs(target, exist_ok=True)
    names = sorted(n for n in os.listdir(source) if n.endswith(".toml"))
    if not names:
        print(f"no scenario files (*.toml) in {source}", file=sys.stderr)
        return 1
    for name in names:
        out = os.path.join(target, name)
        if os.path.exists(out):
            print(f"{out} exists: choose an empty folder", file=sys.stderr)
            return 1
        with open(os.path.join(source, name), encoding="utf-8") as f:
            text = f.read()
        try:
            rewritten = without_reflections(text)
        except (ValueError, tomllib.TOMLDecodeError) as e:
            print(f"{name}: {e}", file=sys.stderr)
            return 1
        with open(out, "w", encoding="utf-8") as f:
            f.write(rewritten)
    print(f"wrote {len(names)} scenarios without reflections or obstacles to {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
