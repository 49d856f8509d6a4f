#!/usr/bin/env bash
# The lowest ATE any estimator could reach on each flight of a family (`wins bound`, a
# Cramér–Rao bound from the flight's geometry, IMU and bearings; docs/ESTIMATOR.md).
#
#   scripts/family_bound.sh FAMILY FIRST LAST OUT.csv [DURATION_S] [-- wins bound options...]
#   scripts/family_bound.sh room 1 200 room-bound.csv 60 -- --bearing-sigma-deg 2 --bearing-correlation-s 0.3
#
# Each flight is drawn as `wins sweep --family FAMILY --seeds FIRST..LAST --duration-s DURATION_S`
# draws it (`wins simulate --family`), written to a temporary folder, bounded and deleted. Rows
# as `wins bound --csv`, with the seed in place of the (temporary) folder. Uses `wins` from PATH, or target/release/wins.
set -euo pipefail
if [ $# -lt 4 ]; then
    sed -n '2,10p' "$0" >&2
    exit 2
fi
family=$1 first=$2 last=$3 out=$4
shift 4
duration=60
if [ $# -gt 0 ] && [ "$1" != "--" ]; then duration=$1; shift; fi
if [ $# -gt 0 ] && [ "$1" = "--" ]; then shift; fi
wins=$(command -v wins || echo "$(dirname "$0")/../target/release/wins")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "seed,ate_bound_m,last_sigma_m,worst_ap_sigma_m,bearings" > "$tmp/all.csv"
for seed in $(seq "$first" "$last"); do
    "$wins" simulate --family "$family" --seed "$seed" --duration "$duration" --out "$tmp/ds" >/dev/null
    "$wins" bound "$tmp/ds" --csv "$tmp/row.csv" "$@" >/dev/null
    tail -n +2 "$tmp/row.csv" | cut -d, -f2- | sed "s/^/$seed,/" >> "$tmp/all.csv"
    rm -rf "$tmp/ds"
done
mv "$tmp/all.csv" "$out"
echo "wrote $out"
