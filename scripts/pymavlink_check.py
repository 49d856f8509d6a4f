#!/usr/bin/env python3
"""Cross-check of wins' MAVLink messages against pymavlink, the reference implementation.

Install (once):
    python3 -m venv /work/venv-mav && /work/venv-mav/bin/pip install pymavlink==2.4.50

Used by the Rust test crates/wins/tests/it/pymavlink.rs (Python from $WINS_PYTHON):

    pymavlink_check.py encode-imu OUT.bin
        writes MAVLink 2 HIGHRES_IMU, SCALED_IMU and SCALED_PRESSURE messages with known values to
        OUT.bin, and those values as JSON to OUT.json (also printed).
    pymavlink_check.py decode IN.bin
        parses the ODOMETRY and VISION_POSITION_ESTIMATE messages in IN.bin (written by wins) and
        prints their fields as JSON (NaN as null), with the sender's ids and the MAVLink version.
    pymavlink_check.py sign-imu KEYFILE OUT.bin
        as encode-imu, every message signed (MAVLink 2 signing) with the key in KEYFILE (64 hex
        digits), link id 3, timestamps from the current time.
    pymavlink_check.py verify KEYFILE IN.bin
        parses IN.bin with signing on and the key in KEYFILE, unsigned messages refused (no
        allow_unsigned_callback), and prints JSON: the messages taken (as decode does, plus
        `signed`) and pymavlink's signing counts (goodsig, badsig, unsigned, refused).
"""

import json
import math
import os
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402

# HIGHRES_IMU.fields_updated bits.
ACCEL_GYRO_BITS = 0x3F
ACCEL_BITS = 0x07
PRESSURE_BIT = 0x200


def imu_messages():
    """The messages written by encode-imu, as (pymavlink message, values) pairs."""
    highres = dict(
        time_usec=1_234_567_890,
        xacc=0.5, yacc=-0.25, zacc=-9.75,
        xgyro=0.125, ygyro=-0.0625, zgyro=0.03125,
        xmag=0.2, ymag=0.0, zmag=0.4,
        abs_pressure=1001.5, diff_pressure=0.0, pressure_alt=110.0, temperature=25.0,
    )
    cases = [
        ("HIGHRES_IMU", dict(highres, fields_updated=ACCEL_GYRO_BITS | PRESSURE_BIT)),
        ("HIGHRES_IMU", dict(highres, time_usec=1_234_577_890, abs_pressure=1001.25,
                             fields_updated=PRESSURE_BIT)),
        ("HIGHRES_IMU", dict(highres, time_usec=1_234_587_890, fields_updated=ACCEL_BITS)),
        ("SCALED_IMU", dict(time_boot_ms=65_000, xacc=12, yacc=-34, zacc=-1002,
                            xgyro=15, ygyro=-7, zgyro=3, xmag=0, ymag=0, zmag=0)),
        ("SCALED_PRESSURE", dict(time_boot_ms=65_010, press_abs=998.75, press_diff=0.0,
                                 temperature=2500)),
    ]
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    out = []
    for kind, values in cases:
        encode = getattr(mav, kind.lower() + "_encode")
        out.append((mav, encode(**values), dict(values, type=kind)))
    return out


def read_key(path):
    """The 32-byte key of a file of 64 hex digits."""
    with open(path) as f:
        key = bytes.fromhex(f.read().strip())
    if len(key) != 32:
        sys.exit(f"{path}: not a 32-byte key")
    return key


def setup_signing(mav, key, link_id, sign_outgoing):
    """Signing as mavutil's setup_signing does it: the timestamp from the current time, in 10 us
    units since 2015-01-01."""
    mav.signing.secret_key = key
    mav.signing.link_id = link_id
    mav.signing.sign_outgoing = sign_outgoing
    mav.signing.allow_unsigned_callback = None
    epoch_offset = 1420070400
    mav.signing.timestamp = int((max(time.time(), epoch_offset) - epoch_offset) * 100 * 1000)


def encode_imu(path, key=None):
    data = b""
    values = []
    for mav, message, fields in imu_messages():
        if key is not None and not mav.signing.sign_outgoing:
            setup_signing(mav, key, link_id=3, sign_outgoing=True)
        data += message.pack(mav)
        values.append(fields)
    with open(path, "wb") as f:
        f.write(data)
    text = json.dumps(values, indent=1)
    with open(os.path.splitext(path)[0] + ".json", "w") as f:
        f.write(text)
    print(text)


def no_nan(value):
    """NaN (not valid JSON) as None, inside lists too."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, list):
        return [no_nan(v) for v in value]
    return value


def message_fields(message):
    """A parsed message's fields (NaN as None), its type, sender, sequence number and version."""
    fields = {k: no_nan(v) for k, v in message.to_dict().items()}
    fields["type"] = fields.pop("mavpackettype")
    fields["src_system"] = message.get_srcSystem()
    fields["src_component"] = message.get_srcComponent()
    fields["seq"] = message.get_seq()
    fields["mavlink_version"] = 2 if message.get_msgbuf()[0] == 0xFD else 1
    return fields


def decode(path):
    with open(path, "rb") as f:
        data = f.read()
    mav = mavlink2.MAVLink(None)
    messages = mav.parse_buffer(data) or []
    out = []
    for message in messages:
        out.append(message_fields(message))
    if len(data) > 0 and not out:
        sys.exit("no MAVLink message could be parsed from " + path)
    print(json.dumps(out, indent=1))


def verify(key_path, path):
    with open(path, "rb") as f:
        data = f.read()
    mav = mavlink2.MAVLink(None)
    mav.robust_parsing = True  # a refused message is a BAD_DATA, not an exception
    setup_signing(mav, read_key(key_path), link_id=0, sign_outgoing=False)
    taken = []
    refused = 0
    for message in mav.parse_buffer(data) or []:
        if message.get_type() == "BAD_DATA":
            refused += 1
            continue
        fields = message_fields(message)
        fields["signed"] = message.get_signed()
        taken.append(fields)
    s = mav.signing
    print(json.dumps({
        "taken": taken,
        "refused": refused,
        "goodsig": s.goodsig_count,
        "badsig": s.badsig_count,
        "unsigned_taken": s.unsigned_count,
    }, indent=1))


def main(argv):
    usage = ("usage: pymavlink_check.py encode-imu OUT.bin | decode IN.bin | "
             "sign-imu KEYFILE OUT.bin | verify KEYFILE IN.bin")
    if len(argv) == 3 and argv[1] == "encode-imu":
        encode_imu(argv[2])
    elif len(argv) == 3 and argv[1] == "decode":
        decode(argv[2])
    elif len(argv) == 4 and argv[1] == "sign-imu":
        encode_imu(argv[3], read_key(argv[2]))
    elif len(argv) == 4 and argv[1] == "verify":
        verify(argv[2], argv[3])
    else:
        sys.exit(usage)


if __name__ == "__main__":
    main(sys.argv)
