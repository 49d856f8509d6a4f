"""wins from Python: Intel 5300 CSI logs to numpy, per-packet AoA, WINS runs, simulated flights.

Everything here calls the Rust library the ``wins`` command line calls, with the same settings
(``wins.default_config()`` prints them); an error of wins is raised as ``wins.WinsError`` with
its message.

>>> import wins
>>> log = wins.read_csi("capture.dat")            # doctest: +SKIP
>>> log.csi.shape                                  # (packets, 30, nrx, ntx), as csiread's
"""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Tuple, Union

import numpy as np

from . import _wins
from ._wins import WinsError, __version__

PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "Aoa",
    "AtherosData",
    "Check",
    "CsiData",
    "FeitData",
    "NexmonData",
    "Packet",
    "Packets",
    "PicoData",
    "Run",
    "Sweep",
    "WinsError",
    "__version__",
    "aoa",
    "check",
    "default_config",
    "iter_csi",
    "load_run",
    "load_sweep",
    "read_atheros",
    "read_csi",
    "read_feitcsi",
    "read_nexmon",
    "read_packets",
    "read_picoscenes",
    "run",
    "scenarios",
    "simulate",
]


@dataclass
class CsiData:
    """The CSI records of an Intel 5300 log, as csiread's ``Intel`` reader gives them.

    ``csi`` is ``(count, 30, nrx, ntx)`` complex128, the raw CSI after the antenna permutation
    (zero where a packet has fewer chains or streams); the other arrays hold one value per
    packet (``perm`` three, 0-based). ``timestamp_ns`` is the NIC clock unwrapped across
    ``timestamp_low``'s wraps, ``offset`` each record's byte offset, ``skipped`` every byte
    range that was not a CSI record: ``(offset, length, reason)``.
    """

    count: int
    nrx: int
    ntx: int
    csi: np.ndarray
    timestamp_low: np.ndarray
    timestamp_ns: np.ndarray
    offset: np.ndarray
    bfee_count: np.ndarray
    Nrx: np.ndarray
    Ntx: np.ndarray
    rssi_a: np.ndarray
    rssi_b: np.ndarray
    rssi_c: np.ndarray
    noise: np.ndarray
    agc: np.ndarray
    perm: np.ndarray
    rate: np.ndarray
    skipped: List[Tuple[int, int, str]] = field(default_factory=list)


def _csi_data(d: Dict[str, Any]) -> CsiData:
    columns = {
        name: np.frombuffer(raw, dtype=dtype).reshape(shape)
        for name, (raw, dtype, shape) in d["columns"].items()
    }
    re_im = columns.pop("csi_re_im")
    count, nrx, ntx = d["count"], d["nrx"], d["ntx"]
    csi = re_im.astype(np.float64).view(np.complex128).reshape(count, 30, nrx, ntx)
    scalars = {name: array.copy() for name, array in columns.items()}
    return CsiData(count=count, nrx=nrx, ntx=ntx, csi=csi, skipped=list(d["skipped"]), **scalars)


def read_csi(path: PathLike, nrx: int = 3, ntx: Optional[int] = None) -> CsiData:
    """Reads a whole Intel 5300 CSI Tool log (``.dat``).

    ``nrx`` and ``ntx`` size the CSI block as csiread's ``nrxnum`` and ``ntxnum`` do (``ntx``
    defaults to the most streams a packet of the log has). Damaged stretches are skipped and
    listed in ``skipped``; a file that cannot be read raises ``WinsError``.
    """
    return _csi_data(_wins.read_csi(os.fspath(path), nrx, ntx))


def iter_csi(
    path: PathLike, chunk: int = 10_000, nrx: int = 3, ntx: int = 3
) -> Iterator[CsiData]:
    """Reads a log of any size in chunks of ``chunk`` packets, with bounded memory."""
    for d in _wins.CsiChunks(os.fspath(path), chunk, nrx, ntx):
        yield _csi_data(d)


@dataclass
class NexmonData:
    """The CSI packets of a Nexmon (nexmon_csi) pcap capture, one row per packet (one receive
    core and spatial stream of a received frame), with csiread's ``Nexmon`` names: ``sec``,
    ``usec``, ``caplen``, ``wirelen``, ``magic``, ``src_addr`` ``(n, 6)``, ``seq``, ``core``,
    ``spatial``, ``chan_spec``, and ``csi`` ``(n, bins)`` complex128 in FFT-bin order, autoscaled
    as csiread decodes it (``float_shift`` per packet) or exact (``exact=True``). Besides:
    ``channel``, ``bandwidth_mhz``, ``chip``, ``rssi`` (dBm, NaN with the old header) and
    ``frame``, the received frame each packet belongs to (its cores grouped)."""

    count: int
    csi: np.ndarray
    sec: np.ndarray
    usec: np.ndarray
    caplen: np.ndarray
    wirelen: np.ndarray
    magic: np.ndarray
    src_addr: np.ndarray
    seq: np.ndarray
    core: np.ndarray
    spatial: np.ndarray
    chan_spec: np.ndarray
    channel: np.ndarray
    bandwidth_mhz: np.ndarray
    chip: np.ndarray
    rssi: np.ndarray
    float_shift: np.ndarray
    frame: np.ndarray
    other_records: int = 0
    tail: Optional[str] = None


def read_nexmon(path: PathLike, exact: bool = False) -> NexmonData:
    """Reads a Nexmon capture (a pcap of nexmon_csi's UDP packets; both header versions, either
    byte order). ``exact=False`` decodes the CSI as csiread does (each packet autoscaled);
    ``exact=True`` gives the chip's exact values, as nexcsi does."""
    d = _wins.read_nexmon(os.fspath(path), exact)
    columns = {
        name: np.frombuffer(raw, dtype=dtype).reshape(shape).copy()
        for name, (raw, dtype, shape) in d["columns"].items()
    }
    re_im = columns.pop("csi_re_im")
    csi = re_im.view(np.complex128).reshape(d["count"], d["bins"])
    rssi = columns.pop("rssi").astype(np.float64)
    rssi[rssi == float(np.iinfo(np.int64).min)] = math.nan
    return NexmonData(
        count=d["count"], csi=csi, rssi=rssi, other_records=d["other_records"], tail=d["tail"],
        **columns,
    )


@dataclass
class FeitData:
    """The records of a FeitCSI file (Intel AX200/AX210): ``csi`` ``(records, subcarriers, rx,
    tx)`` complex128 (zero where a record has fewer), and one value per record of its header:
    ``ftm_clock``, ``mu_clock``, ``num_rx``, ``num_tx``, ``num_subcarriers``, ``rssi1``, ``rssi2``,
    ``source_mac`` ``(records, 6)``, ``rate_flags`` and from them ``mcs``, ``width_mhz`` and
    ``format`` (``"HT"``, ``"HE"``, …). The file holds neither the carrier nor the subcarrier
    indices."""

    count: int
    csi: np.ndarray
    offset: np.ndarray
    ftm_clock: np.ndarray
    mu_clock: np.ndarray
    num_rx: np.ndarray
    num_tx: np.ndarray
    num_subcarriers: np.ndarray
    rssi1: np.ndarray
    rssi2: np.ndarray
    rate_flags: np.ndarray
    mcs: np.ndarray
    width_mhz: np.ndarray
    source_mac: np.ndarray
    format: np.ndarray
    tail: Optional[str] = None


def read_feitcsi(path: PathLike) -> FeitData:
    """Reads a FeitCSI file (Intel AX200/AX210) as FeitCSI documents its records."""
    d = _wins.read_feitcsi(os.fspath(path))
    columns, csi = _card_columns(d)
    return FeitData(
        count=d["count"], csi=csi, format=np.array(d["format"], dtype=object), tail=d["tail"],
        **columns,
    )


@dataclass
class AtherosData:
    """The records of an Atheros CSI Tool log, with csiread's ``Atheros`` names (``timestamp``,
    ``csi_len``, ``tx_channel``, ``err_info``, ``noise_floor``, ``rate``, ``bandwidth``,
    ``num_tones``, ``nr``, ``nc``, ``rssi``, ``rssi_1..3``, ``payload_len``) and ``csi``
    ``(records, tones, nr, nc)`` complex128 in the vendor's layout (csiread 1.4.1 transposes the
    receive and transmit chains of a 2-stream record; this does not), ``payloads`` (each
    record's 802.11 frame), ``order`` (``"little"`` or ``"big"``)."""

    count: int
    csi: np.ndarray
    offset: np.ndarray
    timestamp: np.ndarray
    csi_len: np.ndarray
    tx_channel: np.ndarray
    err_info: np.ndarray
    noise_floor: np.ndarray
    rate: np.ndarray
    bandwidth: np.ndarray
    num_tones: np.ndarray
    nr: np.ndarray
    nc: np.ndarray
    rssi: np.ndarray
    rssi_1: np.ndarray
    rssi_2: np.ndarray
    rssi_3: np.ndarray
    payload_len: np.ndarray
    payloads: List[bytes]
    order: str
    tail: Optional[str] = None


@dataclass
class PicoData:
    """The frames with CSI of a PicoScenes file: ``csi`` ``(frames, tones, rx, streams)``
    complex128 as stored (pilots included; real part first, as CSIKit reads it; zero where a
    frame has fewer), the receiver's report per frame (``device_type``, ``packet_format``,
    ``cbw``, ``mcs``, ``num_sts``, ``noise_floor``, ``rssi``, ``rssi_ctl0..2``; the minimum int64
    where absent), the CSI header's ``carrier_freq``, ``firmware_version``, ``num_tone``,
    ``num_rx``, the Intel ``mu_clock``, the MPDU's ``frame_control``, ``seq_ctl``, ``addr1`` and
    ``addr2`` (``None`` where the frame has none)."""

    count: int
    csi: np.ndarray
    offset: np.ndarray
    mu_clock: np.ndarray
    device_type: np.ndarray
    packet_format: np.ndarray
    cbw: np.ndarray
    mcs: np.ndarray
    num_sts: np.ndarray
    noise_floor: np.ndarray
    rssi: np.ndarray
    rssi_ctl0: np.ndarray
    rssi_ctl1: np.ndarray
    rssi_ctl2: np.ndarray
    carrier_freq: np.ndarray
    firmware_version: np.ndarray
    num_tone: np.ndarray
    num_rx: np.ndarray
    frame_control: np.ndarray
    seq_ctl: np.ndarray
    addr1: List[Optional[str]]
    addr2: List[Optional[str]]
    tail: Optional[str] = None


def _card_columns(d: Dict[str, Any]) -> Tuple[Dict[str, np.ndarray], np.ndarray]:
    """A card reader's columns as numpy arrays, and its CSI block as complex128."""
    columns = {
        name: np.frombuffer(raw, dtype=dtype).reshape(shape).copy()
        for name, (raw, dtype, shape) in d["columns"].items()
    }
    re_im = columns.pop("csi_re_im")
    csi = re_im.astype(np.float64).view(np.complex128).reshape(re_im.shape[:-1])
    return columns, csi


def read_atheros(path: PathLike) -> AtherosData:
    """Reads an Atheros CSI Tool log (either byte order, with or without its byte-order byte)."""
    d = _wins.read_atheros(os.fspath(path))
    columns, csi = _card_columns(d)
    return AtherosData(count=d["count"], csi=csi, payloads=list(d["payloads"]), order=d["order"],
                       tail=d["tail"], **columns)


def read_picoscenes(path: PathLike) -> PicoData:
    """Reads a PicoScenes file's frames with CSI (RxSBasic v3, MVMExtra v1, CSI v4; another
    version of those raises ``WinsError`` naming it)."""
    d = _wins.read_picoscenes(os.fspath(path))
    columns, csi = _card_columns(d)
    return PicoData(count=d["count"], csi=csi, addr1=list(d["addr1"]), addr2=list(d["addr2"]),
                    tail=d["tail"], **columns)


@dataclass
class Packet:
    """One packet's CSI from any card: ``csi`` ``(subcarriers, rx, tx)`` complex128, with the
    ``subcarriers`` (indices) it belongs to, ``spacing_hz`` between them, the receive ``chains``
    (cores), the ``carrier_hz`` (``None`` when the file does not say), ``clock_ns`` (the clock
    the format carries, as stored), ``rssi`` per chain as the card reports it, and the
    ``transmitter`` and ``sequence`` when the format carries them."""

    offset: int
    clock_ns: int
    carrier_hz: Optional[float]
    bandwidth_mhz: int
    spacing_hz: float
    subcarriers: np.ndarray
    chains: List[int]
    csi: np.ndarray
    rssi: List[Optional[float]]
    transmitter: Optional[str]
    sequence: Optional[int]


@dataclass
class Packets:
    """A capture's packets (``format``: ``"intel5300"``, ``"nexmon"``, ``"feitcsi"``,
    ``"picoscenes"`` or ``"atheros"``), the records read but not made packets per reason
    (``skipped``), and what the reader could not read (``lost``)."""

    format: str
    packets: List[Packet]
    skipped: Dict[str, int]
    lost: Optional[str] = None


def read_packets(path: PathLike, format: Optional[str] = None) -> Packets:
    """Reads any card's capture (an Intel 5300 log, a Nexmon pcap, a FeitCSI, PicoScenes or
    Atheros CSI Tool file; told from its first bytes unless ``format`` names it) as one CSI type
    per packet (``wins.Packet``); a Nexmon frame's cores make one packet."""
    d = _wins.read_packets(os.fspath(path), format)
    packets = []
    for p in d["packets"]:
        shape = (len(p["subcarriers"]), len(p["chains"]), p["num_tx"])
        csi = np.frombuffer(p["csi"], dtype="<f8").copy().view(np.complex128).reshape(shape)
        packets.append(
            Packet(
                offset=p["offset"],
                clock_ns=p["clock_ns"],
                carrier_hz=p["carrier_hz"],
                bandwidth_mhz=p["bandwidth_mhz"],
                spacing_hz=p["spacing_hz"],
                subcarriers=np.array(p["subcarriers"], dtype=np.int32),
                chains=list(p["chains"]),
                csi=csi,
                rssi=list(p["rssi"]),
                transmitter=p["transmitter"],
                sequence=p["sequence"],
            )
        )
    return Packets(format=d["format"], packets=packets, skipped=dict(d["skipped"]), lost=d["lost"])


def _columns(rows: List[Dict[str, Any]]) -> Dict[str, np.ndarray]:
    """Rows of one JSON object each to one numpy array per key: numbers (None as NaN) or text."""
    out: Dict[str, np.ndarray] = {}
    for key in rows[0].keys() if rows else []:
        values = [r.get(key) for r in rows]
        present = [v for v in values if v is not None]
        if present and all(isinstance(v, bool) for v in present):
            out[key] = np.array(values, dtype=bool if len(present) == len(values) else object)
        elif all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
            kind = np.int64 if all(isinstance(v, int) for v in values) else np.float64
            out[key] = np.array([math.nan if v is None else v for v in values], dtype=kind)
        else:
            out[key] = np.array(["" if v is None else str(v) for v in values], dtype=object)
    return out


@dataclass
class Aoa:
    """Per-packet AoA as ``wins aoa`` gives it: one array per column of its CSV (``aoa_deg``,
    ``tof_ns``, ``status``, ``reason``, …; NaN where a packet gave none), the counts, and the
    warnings ``wins aoa`` prints."""

    rows: Dict[str, np.ndarray]
    summary: Dict[str, Any]
    warnings: List[str]


def aoa(
    path: PathLike,
    ap: Optional[str] = None,
    *,
    channel: Optional[int] = None,
    center_freq_hz: Optional[float] = None,
    spacing_m: Optional[float] = None,
    config: Optional[PathLike] = None,
    calibration: Optional[PathLike] = None,
    mode: str = "music",
    group_size: int = 10,
    csi_format: Optional[str] = None,
) -> Aoa:
    """The AoA of every packet of a capture of any card (or of AP ``ap`` of a dataset folder),
    with the settings of ``wins aoa`` (``config``: a settings file; ``mode``: ``"music"`` or
    ``"spotfi"``, the latter for Intel 5300 logs; ``csi_format`` forces the capture's format;
    ``channel`` or ``center_freq_hz`` for a FeitCSI file, which does not carry its carrier)."""
    rows, summary, warnings = _wins.aoa(
        os.fspath(path),
        ap,
        channel,
        center_freq_hz,
        spacing_m,
        None if config is None else os.fspath(config),
        None if calibration is None else os.fspath(calibration),
        mode,
        group_size,
        csi_format,
    )
    return Aoa(rows=_columns(json.loads(rows)), summary=json.loads(summary), warnings=warnings)


@dataclass
class Check:
    """Whether a capture is usable for AoA, as ``wins csi check`` says: the overall ``verdict``
    (``"good"``, ``"warning"``, ``"bad"`` or ``"unknown"``) and one finding per topic
    (``topic``, ``verdict``, ``measured``, ``advice``)."""

    verdict: str
    findings: List[Dict[str, Any]]

    @property
    def usable(self) -> bool:
        """Usable for AoA: no finding is bad."""
        return self.verdict != "bad"


def check(
    path: PathLike,
    *,
    channel: Optional[int] = None,
    calibration: Optional[PathLike] = None,
    format: Optional[str] = None,
) -> Check:
    """Checks a capture of any card for AoA before any flight (``wins csi check``): antennas,
    signal, clipping, the chains' phases, a calibration, the channel, the packets' rate and
    gaps. ``channel`` and ``calibration`` serve Intel 5300 logs, which carry neither."""
    d = json.loads(_wins.check(
        os.fspath(path), channel, None if calibration is None else os.fspath(calibration), format,
    ))
    return Check(verdict=d["verdict"], findings=list(d["check"]["findings"]))


@dataclass
class Run:
    """A run folder's content (``wins run`` writes it; docs in the README, "Outputs").

    ``t`` (s), ``p_b_in_w`` ``(n, 3)`` and ``q_xyzw`` ``(n, 4)`` are ``trajectory.tum``;
    ``covariance`` is ``(n, 6, 6)`` over x, y, z, rx, ry, rz (NaN where a pose has none);
    ``aps`` maps each AP's name to its position and its 3 × 3 covariance (NaN when not given);
    ``metrics`` is ``metrics.json`` (``None`` without a truth), ``stats`` ``stats.json``.
    """

    out: Path
    t: np.ndarray
    p_b_in_w: np.ndarray
    q_xyzw: np.ndarray
    covariance: np.ndarray
    aps: Dict[str, Tuple[np.ndarray, np.ndarray]]
    stats: Dict[str, Any]
    metrics: Optional[Dict[str, Any]]
    warnings: List[str] = field(default_factory=list)
    evaluation: str = ""


def _tum(path: Path) -> np.ndarray:
    rows = np.loadtxt(path, comments="#", ndmin=2)
    return rows.reshape(-1, 8)


_COVARIANCE_AXES = ["x", "y", "z", "rx", "ry", "rz"]


def _covariance(path: Path, n: int) -> np.ndarray:
    out = np.full((n, 6, 6), math.nan)
    if not path.is_file():
        return out
    with open(path, newline="") as f:
        for k, row in enumerate(csv.DictReader(f)):
            if k >= n:
                break
            for i, a in enumerate(_COVARIANCE_AXES):
                for j in range(i, 6):
                    cell = row.get(f"c_{a}_{_COVARIANCE_AXES[j]}", "")
                    value = float(cell) if cell else math.nan
                    out[k, i, j] = out[k, j, i] = value
    return out


def _aps(path: Path) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
    out: Dict[str, Tuple[np.ndarray, np.ndarray]] = {}
    if not path.is_file():
        return out
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            p = np.array([float(row[k]) for k in ("x_m", "y_m", "z_m")])
            c = np.full((3, 3), math.nan)
            for i, a in enumerate("xyz"):
                for j in range(i, 3):
                    cell = row.get(f"c_{a}_{'xyz'[j]}") or ""
                    c[i, j] = c[j, i] = float(cell) if cell else math.nan
            out[row["name"]] = (p, c)
    return out


def load_run(out: PathLike) -> Run:
    """Loads a run folder written by ``wins run`` (or by :func:`run`)."""
    out = Path(out)
    if not (out / "run.json").is_file():
        raise WinsError(f"{out} is not a run folder (it has no run.json)")
    tum = _tum(out / "trajectory.tum")
    metrics_path = out / "metrics.json"
    return Run(
        out=out,
        t=tum[:, 0],
        p_b_in_w=tum[:, 1:4],
        q_xyzw=tum[:, 4:8],
        covariance=_covariance(out / "covariance.csv", len(tum)),
        aps=_aps(out / "aps.csv"),
        stats=json.loads((out / "stats.json").read_text()),
        metrics=json.loads(metrics_path.read_text()) if metrics_path.is_file() else None,
    )


def run(
    dataset: PathLike,
    out: PathLike,
    *,
    config: Optional[PathLike] = None,
    calibration: Optional[PathLike] = None,
    no_calibration: bool = False,
) -> Run:
    """Runs WINS on a dataset folder into the run folder ``out``, as ``wins run --no-plots``
    does (the same files, the same checks of ``out``), and loads it."""
    done = _wins.run(
        os.fspath(dataset),
        os.fspath(out),
        None if config is None else os.fspath(config),
        None if calibration is None else os.fspath(calibration),
        no_calibration,
    )
    result = load_run(out)
    result.warnings = list(done["warnings"])
    result.evaluation = done["evaluation"]
    return result


def simulate(
    out: PathLike,
    scenario: Optional[str] = None,
    *,
    family: Optional[str] = None,
    seed: Optional[int] = None,
    duration_s: Optional[float] = None,
    airborne: bool = False,
    card: Optional[str] = None,
) -> str:
    """Simulates a built-in flight (``scenario``, default ``"paper-circle"``) or a family's
    drawn flight (``family="room"``, ``seed``) into the dataset folder ``out``, as
    ``wins simulate`` does; ``card`` (``"atheros"``, ``"nexmon"``, ``"feitcsi"``) flies another
    card's rig, its logs in that card's format. Returns the simulator's summary."""
    return _wins.simulate(os.fspath(out), scenario, family, seed, duration_s, airborne, card)


def scenarios() -> List[Tuple[str, str]]:
    """The built-in flights and the families (``"family:room"``), with their descriptions."""
    return list(_wins.scenarios())


def default_config() -> str:
    """The shipped settings (TOML), as ``wins config`` prints them."""
    return _wins.default_config()


@dataclass
class Sweep:
    """A sweep folder (``wins sweep`` writes it): ``runs`` one array per column of
    ``runs.csv`` (NaN or ``""`` where a run has no value), ``summary`` ``summary.json``."""

    runs: Dict[str, np.ndarray]
    summary: Dict[str, Any]


def _cell(text: str) -> Any:
    if text == "":
        return None
    if text in ("true", "false"):
        return text == "true"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def load_sweep(folder: PathLike) -> Sweep:
    """Loads a sweep folder's ``runs.csv`` and ``summary.json``."""
    folder = Path(folder)
    runs_csv = folder / "runs.csv"
    if not runs_csv.is_file():
        raise WinsError(f"{folder} is not a sweep folder (it has no runs.csv)")
    with open(runs_csv, newline="") as f:
        rows = [{k: _cell(v) for k, v in row.items()} for row in csv.DictReader(f)]
    summary_path = folder / "summary.json"
    summary = json.loads(summary_path.read_text()) if summary_path.is_file() else {}
    return Sweep(runs=_columns(rows), summary=summary)
