#!/usr/bin/env python3
"""Copies a wins dataset folder with a stretch of its IMU or CSI cut out, to test the estimator
across an IMU gap or a CSI outage.

    python3 scripts/cut_flight.py BASE OUT START_S LENGTH_S imu|csi

imu: drops the imu.csv rows strictly inside (START_S, START_S + LENGTH_S) (IMU clock, s).
csi: drops every AP log's CSI records (code 0xBB) whose NIC time plus the manifest's
imu_minus_nic_ns falls strictly inside that span; other records are kept byte for byte.
Needs only the Python standard library (3.11+ for tomllib). OUT must not exist.
"""
import shutil
import struct
import sys
import tomllib


def main():
    if len(sys.argv) != 6 or sys.argv[5] not in ("imu", "csi"):
        sys.exit(__doc__)
    base, out, start_s, length_s, kind = sys.argv[1:]
    a_ns = int(float(start_s) * 1e9)
    b_ns = int((float(start_s) + float(length_s)) * 1e9)
    shutil.copytree(base, out)  # refuses an existing OUT
    manifest = tomllib.load(open(f"{base}/dataset.toml", "rb"))
    if kind == "imu":
        name = manifest["imu"]["file"]
        lines = open(f"{base}/{name}").read().splitlines(True)
        kept = [
            line
            for line in lines
            if line.startswith("#") or not a_ns < int(line.split(",")[0]) < b_ns
        ]
        open(f"{out}/{name}", "w").writelines(kept)
        print(f"{len(lines) - len(kept)} IMU rows removed")
        return
    for ap in manifest["aps"]:
        offset_ns = ap["imu_minus_nic_ns"]
        data = open(f"{base}/{ap['log']}", "rb").read()
        kept, i, removed = bytearray(), 0, 0
        while i + 3 <= len(data):
            (length,) = struct.unpack(">H", data[i : i + 2])
            record = data[i : i + 2 + length]
            if data[i + 2] == 0xBB:
                (nic_us,) = struct.unpack("<I", data[i + 3 : i + 7])
                if a_ns < nic_us * 1000 + offset_ns < b_ns:
                    removed += 1
                    i += 2 + length
                    continue
            kept += record
            i += 2 + length
        kept += data[i:]
        open(f"{out}/{ap['log']}", "wb").write(kept)
        print(f"{ap['name']}: {removed} CSI records removed")


if __name__ == "__main__":
    main()
