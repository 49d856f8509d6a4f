#!/usr/bin/env python3
"""`wins live` seen from the flight controller's side, with pymavlink (the reference MAVLink
implementation): decodes what `wins live` sends, and plays a flight controller for it.

Install (once):
    python3 -m venv v && v/bin/pip install pymavlink==2.4.50

Used by the Rust test crates/wins-cli/tests/cli_live.rs (Python from $WINS_PYTHON) and by hand
(docs/LIVE.md):

    fc_pymavlink.py decode CAPTURE
        reads a raw capture of MAVLink datagrams (`wins replay --capture CAPTURE`) and prints JSON:
        every ODOMETRY and VISION_POSITION_ESTIMATE decoded, the count of each message type and of
        the bytes pymavlink could not take (bad CRC, bad prefix).

    fc_pymavlink.py fc DATASET --connect udpout:HOST:PORT [--start-at UNIX_TIME] [--speed S]
                       [--linger SECONDS] [--out FILE] [--key KEYFILE [--inject N]]
        plays the flight controller: DATASET/imu.csv (and the barometer file when dataset.toml has
        one) goes out as HIGHRES_IMU at the pace of its times (from UNIX_TIME, when given, so that
        `wins replay DATASET --realtime --only csi --start-at UNIX_TIME` plays the CSI from the same
        instant), on ONE pymavlink connection, which also receives what `wins live` sends back
        (its udpin answers the sender). At the end (the dataset played, then --linger seconds,
        0.5 by default) prints JSON (or writes it to FILE): what was sent, every ODOMETRY /
        VISION_POSITION_ESTIMATE received with its local receive time, the counts.
        With --key (a file of 64 hex digits, `wins live --mavlink-key`'s), MAVLink 2 signing is on
        as pymavlink's mavutil sets it up: every message sent is signed, and a message received
        without a valid signature is refused (`bad_signature`; `signing` has pymavlink's counts).
        --inject N then sends, a third of the way through the flight, N HIGHRES_IMU unsigned, N
        signed with another key and N copies of the last one sent (replays), all with absurd
        values (`injected` counts them): `wins live` must refuse every one.

The messages are those `wins replay` sends (crates/wins/src/live/player.rs): HIGHRES_IMU with
`time_usec` the dataset's IMU clock (ns / 1000, rounded down), the accelerometer (specific force,
m/s²) and gyroscope (rad/s) of imu.csv as they are (the dataset's IMU frame is the flight
controller's FRD body frame), `fields_updated` = the six accel and gyro bits; the barometer as
HIGHRES_IMU with only `abs_pressure` (hPa: the standard atmosphere's pressure at the altitude),
`fields_updated` = its bit. Both from system 1, component 1 (the autopilot). At equal times the
barometer goes first, as in `wins run`'s merge.

Decoded messages are JSON objects with every field pymavlink gives (NaN as null) plus `type`,
`src_system`, `src_component` and `seq`; in `fc` mode also `recv_unix_s` (the local Unix time it
arrived) and `recv_dataset_s` (the dataset time being played then: `recv_dataset_s - time_usec/1e6`
is the pose's age on arrival).
"""

import argparse
import csv
import hashlib
import json
import math
import os
import select
import sys
import time
import tomllib

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402

# Beside this script: the decoding and HIGHRES_IMU.fields_updated bits the cross-check uses.
from pymavlink_check import ACCEL_GYRO_BITS, PRESSURE_BIT, message_fields  # noqa: E402

# The standard atmosphere (crates/wins/src/live/mavlink/inbound.rs).
STANDARD_SEA_LEVEL_PA = 101_325.0
STANDARD_SEA_LEVEL_K = 288.15
LAPSE_RATE_K_M = 0.0065
BAROMETRIC_EXPONENT = 0.190_263

POSE_TYPES = ("ODOMETRY", "VISION_POSITION_ESTIMATE")


def pressure_at_altitude_pa(altitude_m, sea_level_pa=STANDARD_SEA_LEVEL_PA):
    """The inverse of h = T0/L (1 - (p/p0)^0.190263)."""
    h0 = STANDARD_SEA_LEVEL_K / LAPSE_RATE_K_M
    return sea_level_pa * (1.0 - altitude_m / h0) ** (1.0 / BAROMETRIC_EXPONENT)


class Tally:
    """Counts of what came in, and the poses decoded."""

    def __init__(self):
        self.counts = {}
        self.bad_data = {}
        self.poses = []

    def add(self, message, extra=None):
        kind = message.get_type()
        if kind == "BAD_DATA":
            reason = str(getattr(message, "reason", ""))
            if "CRC" in reason:
                key = "bad_crc"
            elif "signature" in reason:
                key = "bad_signature"
            else:
                key = "other"
            self.bad_data[key] = self.bad_data.get(key, 0) + 1
            return
        self.counts[kind] = self.counts.get(kind, 0) + 1
        if kind in POSE_TYPES:
            decoded = message_fields(message)
            decoded.update(extra or {})
            self.poses.append(decoded)

    def report(self):
        return {
            "messages": self.counts,
            "bad_crc": self.bad_data.get("bad_crc", 0),
            "bad_signature": self.bad_data.get("bad_signature", 0),
            "bad_data_other": self.bad_data.get("other", 0),
            "odometry": [p for p in self.poses if p["type"] == "ODOMETRY"],
            "vision_position_estimate": [
                p for p in self.poses if p["type"] == "VISION_POSITION_ESTIMATE"
            ],
        }


def decode(path):
    with open(path, "rb") as f:
        data = f.read()
    mav = mavlink2.MAVLink(None)
    mav.robust_parsing = True
    tally = Tally()
    for message in mav.parse_buffer(data) or []:
        tally.add(message)
    out = tally.report()
    out["bytes"] = len(data)
    print(json.dumps(out, indent=1))


def read_dataset(folder):
    """The dataset's IMU samples and barometer readings as (t_ns, order, values), in play order
    (time, then barometer before IMU)."""
    with open(os.path.join(folder, "dataset.toml"), "rb") as f:
        manifest = tomllib.load(f)
    events = []
    with open(os.path.join(folder, manifest["imu"]["file"]), newline="") as f:
        for row in csv.reader(f):
            if not row or row[0].lstrip().startswith("#"):
                continue
            t_ns = int(row[0])
            gyro = [float(v) for v in row[1:4]]
            accel = [float(v) for v in row[4:7]]
            events.append((t_ns, 1, (accel, gyro)))
    baro = manifest.get("baro")
    if baro and baro.get("file"):
        with open(os.path.join(folder, baro["file"]), newline="") as f:
            for row in csv.reader(f):
                if not row or row[0].startswith("#") or not row[0].strip().lstrip("-").isdigit():
                    continue  # the header and comments
                events.append((int(row[0]), 0, float(row[1])))
    events.sort(key=lambda e: (e[0], e[1]))
    if not any(e[1] == 1 for e in events):
        sys.exit(f"{folder}: no IMU sample")
    return events


def micros(t_ns):
    return max(t_ns // 1000, 0)


def fc(args):
    if not args.connect.startswith("udpout:"):
        sys.exit("--connect: udpout:HOST:PORT (wins live's udpin address)")
    if not (args.speed > 0 and math.isfinite(args.speed)):
        sys.exit("--speed must be positive")
    events = read_dataset(args.dataset)
    t0 = next(e[0] for e in events if e[1] == 1)  # the first IMU sample, as wins replay
    conn = mavutil.mavlink_connection(
        args.connect, source_system=1, source_component=1, dialect="common"
    )
    conn.mav.robust_parsing = True
    key = None
    if args.key:
        with open(args.key) as f:
            key = bytes.fromhex(f.read().strip())
        if len(key) != 32:
            sys.exit(f"--key {args.key}: not 64 hex digits")
        conn.setup_signing(key, sign_outgoing=True, allow_unsigned_callback=None, link_id=1)
    elif args.inject:
        sys.exit("--inject needs --key")
    tally = Tally()
    # The dataset time t plays at monotonic start + (t - t0) / speed.
    now_unix, now_mono = time.time(), time.monotonic()
    start = now_mono
    if args.start_at is not None and args.start_at > now_unix:
        start = now_mono + min(args.start_at - now_unix, 3600.0)

    def dataset_time_s(mono):
        return (t0 + (mono - start) * args.speed * 1e9) / 1e9

    def drain():
        while True:
            message = conn.recv_msg()
            if message is None:
                return
            mono = time.monotonic()
            tally.add(
                message,
                {"recv_unix_s": time.time(), "recv_dataset_s": dataset_time_s(mono)},
            )

    def wait_until(due):
        """Receives until the monotonic time `due`."""
        while True:
            drain()
            left = due - time.monotonic()
            if left <= 0:
                return
            select.select([conn.port], [], [], left)

    sent = {"imu": 0, "baro": 0}
    injected = {"unsigned": 0, "wrong_key": 0, "replayed": 0}
    inject_at = events[len(events) // 3][0] if args.inject else None
    last = None  # the bytes of the last signed HIGHRES_IMU sent
    max_lag = 0.0
    for t_ns, kind, values in events:
        due = start + (t_ns - t0) / 1e9 / args.speed
        wait_until(due)
        max_lag = max(max_lag, time.monotonic() - due)
        if inject_at is not None and t_ns >= inject_at and last is not None:
            inject(conn, key, last, micros(t_ns), args.inject, injected)
            inject_at = None
        if kind == 1:
            accel, gyro = values
            message = conn.mav.highres_imu_encode(
                micros(t_ns), *accel, *gyro, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ACCEL_GYRO_BITS
            )
            conn.mav.send(message)
            last = bytes(message.get_msgbuf())
            sent["imu"] += 1
        else:
            hpa = pressure_at_altitude_pa(values) / 100.0
            conn.mav.highres_imu_send(
                micros(t_ns), 0, 0, 0, 0, 0, 0, 0, 0, 0, hpa, 0, 0, 0, PRESSURE_BIT
            )
            sent["baro"] += 1
    wait_until(time.monotonic() + args.linger)
    out = tally.report()
    out["sent"] = sent
    if key is not None:
        s = conn.mav.signing
        out["signing"] = {"goodsig": s.goodsig_count, "badsig": s.badsig_count,
                          "unsigned_taken": s.unsigned_count}
        out["injected"] = injected
    out["played_s"] = (events[-1][0] - t0) / 1e9
    out["max_lag_s"] = max_lag
    out["start_unix_s"] = now_unix + (start - now_mono)
    text = json.dumps(out, indent=1)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")
    else:
        print(text)


def inject(conn, key, last, time_usec, n, injected):
    """Sends n HIGHRES_IMU unsigned, n signed with another key (both with absurd values) and n
    copies of `last` (a signed message already sent), counting them in `injected`."""
    signing = conn.mav.signing
    absurd = (time_usec, 50.0, -50.0, 50.0, 20.0, -20.0, 20.0,
              0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ACCEL_GYRO_BITS)
    signing.sign_outgoing = False
    for _ in range(n):
        conn.mav.highres_imu_send(*absurd)
        injected["unsigned"] += 1
    signing.sign_outgoing = True
    signing.secret_key = hashlib.sha256(key).digest()
    for _ in range(n):
        conn.mav.highres_imu_send(*absurd)
        injected["wrong_key"] += 1
    signing.secret_key = key
    for _ in range(n):
        conn.write(last)
        injected["replayed"] += 1


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="mode", required=True)
    d = sub.add_parser("decode", help="decode a capture of `wins replay --capture`")
    d.add_argument("capture")
    f = sub.add_parser("fc", help="play the flight controller to `wins live`")
    f.add_argument("dataset")
    f.add_argument("--connect", required=True, help="udpout:HOST:PORT, wins live's udpin")
    f.add_argument("--start-at", type=float, help="Unix time of the dataset's first IMU sample")
    f.add_argument("--speed", type=float, default=1.0, help="play speed (1: real time)")
    f.add_argument("--linger", type=float, default=0.5,
                   help="seconds to keep receiving after the last sample (default 0.5)")
    f.add_argument("--out", help="write the JSON here instead of printing it")
    f.add_argument("--key", help="sign with the key in this file (64 hex digits) and check "
                   "what comes back")
    f.add_argument("--inject", type=int, default=0,
                   help="with --key: N unsigned, N wrongly signed and N replayed HIGHRES_IMU")
    args = parser.parse_args(argv[1:])
    if args.mode == "decode":
        decode(args.capture)
    else:
        fc(args)


if __name__ == "__main__":
    main(sys.argv)
