#!/usr/bin/env python3
"""Independent SpotFi-style MUSIC check of a `wins simulate` dataset against its `truth/`.

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install csiread==1.4.1 numpy
    cargo build --release -p wins-cli
    ./target/release/wins simulate --scenario paper-circle --out /tmp/mc/paper-circle
    /tmp/venv/bin/python scripts/music_check.py DATASET_DIR [--ap NAME] [--max-packets N]
                                                [--no-calibration] [--stride K]

Written only from the dataset README's conventions and the SpotFi paper (Kotaru et al., SIGCOMM
2015), not from the Rust AoA code. Each AP's log is read with csiread; the truth rows with
`received = true` must match its records one to one (count and bfee_count), otherwise exit 1.
Per packet: remove `truth.toml: chain_phase_offsets_rad` (multiply antenna m by exp(-j*off_m);
skipped with --no-calibration), sanitize as SpotFi Algorithm 1 (unwrap each antenna's phase over
the subcarriers, fit one line to all antennas' (frequency offset, phase) pairs, remove its slope
from every antenna, so the inter-antenna phase survives), build the smoothed CSI matrix, and run
2-D MUSIC over AoA theta in [-90, 90] deg (0.5 deg) and ToF tau in [-150, 400] ns (2 ns) relative to
the sanitized reference. Steering (README): antenna m gets exp(+j*2*pi*f*y_m*sin(theta)/c), y_m =
(m - (M-1)/2)*d, subcarrier k gets exp(-j*2*pi*df_k*tau).

Smoothing. HT40's 30 groups (-58, -54, ..., 58) are uniform (1.25 MHz): SpotFi's own 30 x 32
matrix (rows: 2 antennas x 15 subcarriers, columns: 2 antenna shifts x 16 subcarrier shifts).
HT20's groups (-28, -26, ..., -2, -1, 1, 3, ..., 27, 28) are not uniform, and smoothing over a
non-uniform comb gives every column a different steering vector. They are two uniform runs of
step 2 (625 kHz), -28..-2 (14) and -1..27 (15), plus 28: we smooth inside each run with windows
of L = 8 subcarriers and pool the columns (rows 2 x 8 = 16, columns 2 x (7 + 8) = 30), so every
column shares one exact steering vector; group 28 is not used.

Paths: eigenvalues of X X^H; the noise floor is the mean of the smallest quarter, an eigenvalue
is signal if it is above 10 dB over that floor and within 30 dB of the largest (at least 1, at
most rows - 2). Peaks: 2-D local maxima (8-neighbourhood) of the pseudo-spectrum 1/|En^H a|^2
at least 0.1 of its global maximum. Direct path: (a) the strongest peak, (b) the peak with the
smallest ToF (SpotFi's intuition). Errors |theta_est - theta_true| (truth aoa_deg) are reported
for the in-front packets (truth in_front and |aoa| <= 60 deg) and for all processed packets.
With --no-calibration the errors should be much larger. Exit code 0 unless the files disagree.
"""
import argparse, csv, math, os, sys, time, tomllib

import numpy as np
import csiread

C = 299_792_458.0
SC_SPACING_HZ = 312.5e3
HT20 = list(range(-28, -1, 2)) + [-1] + list(range(1, 28, 2)) + [28]
HT40 = list(range(-58, -1, 4)) + list(range(2, 59, 4))
THETA_DEG = np.arange(-90.0, 90.0 + 1e-9, 0.5)
TAU_S = np.arange(-150e-9, 400e-9 + 1e-15, 2e-9)
PEAK_FRACTION = 0.1
SIGNAL_OVER_FLOOR_DB, SIGNAL_RANGE_DB = 10.0, 30.0
assert len(HT20) == 30 and len(HT40) == 30


def smoothing_plan(idx):
    """Uniform runs of the subcarrier index list, window length L, and the list of window starts."""
    idx = np.asarray(idx)
    step = int(np.bincount(np.diff(idx)).argmax())
    runs, start = [], 0
    for i in range(1, len(idx) + 1):
        if i == len(idx) or idx[i] - idx[i - 1] != step:
            runs.append((start, i))
            start = i
    longest = max(b - a for a, b in runs)
    L = 15 if longest == 30 else 8  # HT40: SpotFi's 15; HT20: see the docstring
    starts = [s for a, b in runs for s in range(a, b - L + 1)]
    return step, L, starts


class Music:
    def __init__(self, idx, fc, d, M):
        self.step, self.L, self.starts = smoothing_plan(idx)
        self.df = np.asarray(idx, float) * SC_SPACING_HZ
        self.M, self.A = M, 2  # antennas per subarray (SpotFi: 2 of 3)
        self.shifts = M - self.A + 1
        # steering parts; the common factor of each column (its first antenna and subcarrier) cancels
        sin = np.sin(np.radians(THETA_DEG))
        self.ant = np.exp(2j * np.pi * fc * np.outer(sin, np.arange(self.A) * d) / C)   # (T, A)
        r = np.arange(self.L) * self.step * SC_SPACING_HZ
        self.tof = np.exp(-2j * np.pi * np.outer(TAU_S, r))                          # (U, L)

    def sanitize(self, h):
        """SpotFi Algorithm 1 on h (M, 30): one line over all antennas, slope removed from each."""
        psi = np.unwrap(np.angle(h), axis=1)
        x = np.tile(self.df, self.M)
        A = np.stack([x, np.ones_like(x)], axis=1)
        slope = np.linalg.lstsq(A, psi.ravel(), rcond=None)[0][0]
        return h * np.exp(-1j * slope * self.df)[None, :]

    def smoothed(self, h):
        cols = [h[m:m + self.A, s:s + self.L].ravel()  # row = antenna * L + subcarrier
                for m in range(self.shifts) for s in self.starts]
        return np.stack(cols, axis=1)

    def spectrum(self, h):
        X = self.smoothed(h)
        w, V = np.linalg.eigh(X @ X.conj().T)  # ascending
        w = np.maximum(w, 1e-30)
        floor = w[: max(1, len(w) // 4)].mean()
        sig = (w > floor * 10 ** (SIGNAL_OVER_FLOOR_DB / 10)) & (w > w[-1] * 10 ** (-SIGNAL_RANGE_DB / 10))
        npaths = int(min(max(sig.sum(), 1), len(w) - 2))
        En = V[:, : len(w) - npaths].reshape(self.A, self.L, -1)
        # En^H a(theta, tau) = sum_a ant[theta, a] * sum_r tof[tau, r] * conj(En[a, r, :])
        B = np.einsum('ur,arn->aun', self.tof, En.conj())
        P = np.einsum('ta,aun->tun', self.ant, B)
        return 1.0 / np.maximum((np.abs(P) ** 2).sum(axis=2), 1e-30), npaths

    @staticmethod
    def peaks(S):
        pad = np.pad(S, 1, constant_values=-np.inf)
        core = pad[1:-1, 1:-1]
        is_max = np.ones_like(S, bool)
        for dt in (-1, 0, 1):
            for du in (-1, 0, 1):
                if dt or du:
                    nb = pad[1 + dt: 1 + dt + S.shape[0], 1 + du: 1 + du + S.shape[1]]
                    is_max &= core >= nb
        is_max &= S >= PEAK_FRACTION * S.max()
        return np.argwhere(is_max)  # (n, 2): theta index, tau index


def read_truth(path):
    with open(path, newline='') as f:
        return [r for r in csv.DictReader(f) if r['received'].strip().lower() == 'true']


def stats(err):
    if len(err) == 0:
        return '   n=0' + ' ' * 29
    e = np.asarray(err)
    return f'{len(e):5d}  {np.median(e):6.2f}  {np.percentile(e, 90):6.2f}'


def check_ap(ds, ap, cfg, truth_toml, a):
    name = ap['name']
    rows = read_truth(os.path.join(ds, 'truth', f'packets_{name}.csv'))
    geo = cfg['array']['geometry']
    M, d = int(geo['num_antennas']), float(geo['spacing_m'])
    fc = float(cfg['channel']['center_freq_hz'])
    bw = ap.get('bandwidth', cfg['channel']['bandwidth']).lower()
    idx = {'ht20': HT20, 'ht40': HT40}[bw]
    log = csiread.Intel(os.path.join(ds, ap['log']), nrxnum=3, ntxnum=3, if_report=False)
    log.read()
    n = int(log.count)
    if n != len(rows):
        print(f'{name}: {n} CSI records in {ap["log"]} but {len(rows)} received truth rows')
        sys.exit(1)
    bfee = np.asarray(log.bfee_count[:n], int)
    tb = np.array([int(r['bfee_count']) for r in rows]) % 65536
    if not np.array_equal(bfee, tb):
        i = int(np.argmax(bfee != tb))
        print(f'{name}: bfee_count differs first at record {i}: log {bfee[i]}, truth {tb[i]}')
        sys.exit(1)
    if np.any(np.asarray(log.Nrx[:n]) != M):
        print(f'{name}: records with Nrx != num_antennas = {M}')
        sys.exit(1)
    csi = np.asarray(log.csi[:n])  # (packets, 30 subcarriers, nrx, ntx), perm already applied
    assert csi.shape[1:3] == (30, 3), csi.shape
    off = np.asarray(truth_toml['chain_phase_offsets_rad'], float)[:M]
    cal = np.ones(M, complex) if a.no_calibration else np.exp(-1j * off)

    stride = a.stride or max(1, n // 300)
    sel = list(range(0, n, stride))[: a.max_packets or None]
    mu = Music(idx, fc, d, M)
    res = {k: [] for k in ('front_strong', 'front_first', 'all_strong', 'all_first')}
    npaths, t0 = [], time.perf_counter()
    for i in sel:
        h = csi[i, :, :M, 0].T * cal[:, None]  # (antenna, subcarrier), tx chain 0
        S, k = mu.spectrum(mu.sanitize(h))
        npaths.append(k)
        pk = Music.peaks(S)
        strong = pk[np.argmax(S[pk[:, 0], pk[:, 1]])]
        first = pk[np.argmin(pk[:, 1])]
        th = float(rows[i]['aoa_deg'])
        front = rows[i]['in_front'].strip().lower() == 'true' and abs(th) <= 60.0
        for tag, p in (('strong', strong), ('first', first)):
            e = abs(THETA_DEG[p[0]] - th)
            res['all_' + tag].append(e)
            if front:
                res['front_' + tag].append(e)
    ms = (time.perf_counter() - t0) / max(1, len(sel)) * 1e3
    calib = 'none' if a.no_calibration else 'truth'
    print(f'{name}: {bw}, M={M}, d={d * 1e3:.2f} mm, fc={fc / 1e9:.3f} GHz, calibration {calib}; '
          f'{len(sel)}/{n} packets (stride {stride}), smoothed {2 * mu.L}x{mu.shifts * len(mu.starts)}, '
          f'paths median {np.median(npaths):.0f} [{min(npaths)}, {max(npaths)}], {ms:.1f} ms/packet')
    print(f'  {"subset":<22}{"peak":<10}{"n":>5}  {"med":>6}  {"p90":>6}   (|theta_est - theta_true|, deg)')
    for sub, lab in (('front', 'in front, |aoa|<=60'), ('all', 'all')):
        for tag, plab in (('strong', 'strongest'), ('first', 'min ToF')):
            print(f'  {lab:<22}{plab:<10}{stats(res[sub + "_" + tag])}')


def main():
    p = argparse.ArgumentParser()
    p.add_argument('dataset')
    p.add_argument('--ap', help='only this AP (default: all in dataset.toml)')
    p.add_argument('--max-packets', type=int, default=0, help='at most N packets per AP (after --stride)')
    p.add_argument('--no-calibration', action='store_true', help='keep the chain phase offsets')
    p.add_argument('--stride', type=int, default=0, help='every K-th packet (default: ~300 per AP)')
    a = p.parse_args()
    with open(os.path.join(a.dataset, 'dataset.toml'), 'rb') as f:
        cfg = tomllib.load(f)
    with open(os.path.join(a.dataset, 'truth', 'truth.toml'), 'rb') as f:
        truth_toml = tomllib.load(f)
    aps = [ap for ap in cfg['aps'] if a.ap in (None, ap['name'])]
    if not aps:
        print(f'no AP named {a.ap} in dataset.toml')
        return 1
    for ap in aps:
        check_ap(a.dataset, ap, cfg, truth_toml, a)
    return 0


if __name__ == '__main__':
    sys.exit(main())
