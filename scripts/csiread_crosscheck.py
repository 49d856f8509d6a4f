#!/usr/bin/env python3
"""Cross-check `wins csi export` against csiread on any Intel 5300 log, or on a random one.

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install csiread==1.4.1 numpy
    cargo build --release -p wins-cli
    /tmp/venv/bin/python scripts/csiread_crosscheck.py [FILE.dat] [--random N --seed S] [--time]

Without FILE it writes N random records with an encoder written here from the format description
(independent of the Rust writer), with 0xC1 frame records between some of them. Records are grouped
by how csiread and MATLAB's read_bf_file.m differ: csiread applies the antenna permutation to every
record, MATLAB (and wins) only when nrx > 1 and it is a permutation; csiread scales a record with no
RSSI as if it had 0 dBm, MATLAB gives zeros and wins reports it unscalable.
"""
import argparse, json, math, os, random, struct, subprocess, sys, tempfile, time

import numpy as np
import csiread


def random_log(path, n, seed):
    rng = random.Random(seed)
    out = bytearray()
    for i in range(n):
        nrx, ntx = rng.randint(1, 3), rng.randint(1, 3)
        calc = (30 * (nrx * ntx * 16 + 3) + 7) // 8
        sel = rng.choice([0b100100, 0b011000, 0b001001, 0b100001, 0b000110, rng.randint(0, 255)])
        rssi = [rng.choice([0, rng.randint(1, 60)]) for _ in range(3)]
        noise = rng.choice([-127, rng.randint(-100, -60)])
        hdr = struct.pack('<IHHBBBBBbBBHH', rng.getrandbits(32), rng.getrandbits(16), 0, nrx, ntx,
                          *rssi, noise, rng.randint(0, 70), sel, calc, rng.getrandbits(16))
        rec = bytes([0xBB]) + hdr + bytes(rng.getrandbits(8) for _ in range(calc))
        out += struct.pack('>H', len(rec)) + rec
        if rng.random() < 0.2:
            frame = bytes([0xC1]) + bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 300)))
            out += struct.pack('>H', len(frame)) + frame
    with open(path, 'wb') as f:
        f.write(out)


def matlab_scaled(o, csi):
    """get_scaled_csi.m, computed here independently."""
    mag = sum(10 ** (r / 10) for r in o['rssi'] if r)
    rss = 10 * math.log10(mag) - 44 - o['agc']
    scale = 10 ** (rss / 10) / (np.sum(np.abs(csi) ** 2) / 30)
    noise = -92 if o['noise'] == -127 else o['noise']
    f = math.sqrt(scale / (10 ** (noise / 10) + scale * o['nrx'] * o['ntx']))
    return csi * f * {1: 1, 2: math.sqrt(2), 3: math.sqrt(10 ** 0.45)}[o['ntx']]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('file', nargs='?')
    ap.add_argument('--random', type=int, default=2000)
    ap.add_argument('--seed', type=int, default=1)
    ap.add_argument('--time', action='store_true', help="also time csiread's read (best of 20)")
    ap.add_argument('--wins', default=os.path.join(os.path.dirname(__file__), '../target/release/wins'))
    a = ap.parse_args()
    tmp = tempfile.mkdtemp()
    path = a.file or os.path.join(tmp, 'random.dat')
    if not a.file:
        random_log(path, a.random, a.seed)
    jsonl = os.path.join(tmp, 'wins.jsonl')
    subprocess.run([a.wins, 'csi', 'export', path, '-o', jsonl], check=True)
    ours = [json.loads(l) for l in open(jsonl)]
    d = csiread.Intel(path, nrxnum=3, ntxnum=3, if_report=False)
    d.read()
    scaled = d.get_scaled_csi()
    print(f'records: csiread {d.count}, wins {len(ours)}')
    tally = {}
    def count(key):
        tally[key] = tally.get(key, 0) + 1
    for i, o in enumerate(ours):
        nrx, ntx = o['nrx'], o['ntx']
        head = [int(v[i]) for v in (d.timestamp_low, d.bfee_count, d.Nrx, d.Ntx, d.noise, d.agc, d.rate)]
        head += [int(d.rssi_a[i]), int(d.rssi_b[i]), int(d.rssi_c[i])] + [int(p) + 1 for p in d.perm[i]]
        mine = [o[k] for k in ('timestamp_low', 'bfee_count', 'nrx', 'ntx', 'noise', 'agc', 'rate')]
        count('header equal' if head == mine + o['rssi'] + o['perm'] else 'HEADER DIFFERS')
        p = [x - 1 for x in o['perm']]
        applies = nrx > 1 and sorted(p[:nrx]) == list(range(nrx))
        csi = np.array(o['csi_re_im'][0]) + 1j * np.array(o['csi_re_im'][1])  # [tx][rx][sc]
        theirs = d.csi[i][:, :nrx, :ntx].transpose(2, 1, 0)
        if applies:
            count('perm applied: raw CSI equal' if np.array_equal(theirs, csi) else 'perm applied: RAW CSI DIFFERS')
        else:
            count('perm not applied (nrx = 1 or invalid): csiread applies it anyway')
        if 'csi_scaled_re_im' not in o:
            count('wins: unscalable (no RSSI)' if o['rssi'] == [0, 0, 0] else 'WINS UNSCALABLE WITH RSSI')
            continue
        s = np.array(o['csi_scaled_re_im'][0]) + 1j * np.array(o['csi_scaled_re_im'][1])
        count('scaled equals get_scaled_csi.m (1e-9)' if np.allclose(s, matlab_scaled(o, csi), rtol=1e-9, atol=0)
              else 'SCALED DIFFERS FROM get_scaled_csi.m')
        if applies:
            count('scaled equals csiread (1e-9)' if np.allclose(s, scaled[i][:, :nrx, :ntx].transpose(2, 1, 0), rtol=1e-9, atol=0)
                  else 'scaled differs from csiread (csiread buffer has entries outside nrx x ntx)'
                  if np.abs(scaled[i]).sum() > np.abs(scaled[i][:, :nrx, :ntx]).sum() else 'SCALED DIFFERS FROM CSIREAD')
    if a.time:
        best = float('inf')
        for _ in range(20):
            t = time.perf_counter()
            csiread.Intel(path, nrxnum=3, ntxnum=3, if_report=False).read()
            best = min(best, time.perf_counter() - t)
        print(f'csiread {csiread.__version__} read: best of 20 {best * 1e3:.3f} ms, '
              f'{d.count / best / 1e6:.2f} M CSI records/s (file read included)')
    for k, v in sorted(tally.items()):
        print(f'{v:6d}  {k}')
    return 1 if any(k.isupper() or 'DIFFERS' in k for k in tally) else 0


if __name__ == '__main__':
    sys.exit(main())
