"""`import wins` against csiread on every real capture, and against the `wins` command line.

Run from the repository root after `pip install ./crates/wins-py csiread pytest`:
`pytest crates/wins-py/tests`. The real captures come from `data/intel5300/` and from
`../shared/data/intel5300/` (`WINS_SHARED_DATA=DIR` points elsewhere); the command line is
`target/release/wins` (`WINS_BIN=FILE`). Under CI a missing one fails instead of skipping.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import wins

REPO = Path(__file__).resolve().parents[3]
SHARED = Path(os.environ.get("WINS_SHARED_DATA", REPO.parent / "shared" / "data"))
WINS_BIN = Path(os.environ.get("WINS_BIN", REPO / "target" / "release" / "wins"))
IN_CI = bool(os.environ.get("CI"))


def missing(what: str) -> None:
    """A missing input fails under CI and skips (saying so) elsewhere."""
    if IN_CI:
        pytest.fail(f"{what} is missing (CI runs every test)")
    pytest.skip(f"{what} is missing")


def captures() -> list[Path]:
    found = sorted((REPO / "data" / "intel5300").glob("*.dat"))
    shared = SHARED / "intel5300"
    if shared.is_dir():
        found += sorted(shared.rglob("*.dat"))
    return found


def cli(*args: str) -> subprocess.CompletedProcess:
    if not WINS_BIN.is_file():
        missing(f"the wins binary {WINS_BIN} (cargo build --release -p wins-cli)")
    done = subprocess.run([str(WINS_BIN), *args], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done


def test_the_shared_captures_are_there() -> None:
    for card in ["intel5300", "nexmon"]:
        if not (SHARED / card).is_dir():
            missing(f"the shared captures {SHARED / card}")
    assert len(captures()) > 10
    assert len(nexmon_captures()) == 3


@pytest.mark.parametrize("path", captures(), ids=lambda p: p.name)
def test_every_real_capture_reads_as_csiread_reads_it(path: Path) -> None:
    csiread = pytest.importorskip("csiread")
    ours = wins.read_csi(path)
    theirs = csiread.Intel(str(path), nrxnum=3, ntxnum=ours.ntx, if_report=False)
    theirs.read()
    assert ours.count == theirs.count
    assert ours.csi.shape == theirs.csi.shape
    assert ours.csi.dtype == theirs.csi.dtype
    # Bit-exact: the same raw CSI, every entry.
    assert np.array_equal(ours.csi, theirs.csi)
    for name in ["timestamp_low", "bfee_count", "Nrx", "Ntx", "rssi_a", "rssi_b", "rssi_c",
                 "noise", "agc", "perm", "rate"]:
        a, b = getattr(ours, name), getattr(theirs, name)
        assert a.dtype == b.dtype, name
        assert np.array_equal(a, b), name


def nexmon_captures() -> list[Path]:
    return sorted((SHARED / "nexmon").glob("*.pcap")) if (SHARED / "nexmon").is_dir() else []


@pytest.mark.parametrize("path", nexmon_captures(), ids=lambda p: p.name)
def test_every_nexmon_capture_reads_as_csiread_reads_it(path: Path) -> None:
    csiread = pytest.importorskip("csiread")
    ours = wins.read_nexmon(path)
    theirs = csiread.Nexmon(str(path), chip="4366c0", bw=20, if_report=False)
    theirs.read()
    assert ours.count == theirs.count
    assert np.array_equal(ours.csi, theirs.csi)
    for name in ["sec", "usec", "caplen", "wirelen", "magic", "src_addr", "seq", "core",
                 "spatial", "chan_spec"]:
        assert np.array_equal(getattr(ours, name), getattr(theirs, name)), name
    # The frames group each frame's cores: none holds a core twice.
    for f in np.unique(ours.frame):
        cores = ours.core[ours.frame == f]
        assert len(set(cores)) == len(cores)
    exact = wins.read_nexmon(path, exact=True)
    ratio = np.abs(exact.csi[0]).max() / max(np.abs(ours.csi[0]).max(), 1)
    assert ratio == 2.0 ** (42 - ours.float_shift[0])


@pytest.mark.parametrize("name", ["csikit_HT20_2452", "csikit_HESU80_5500"])
def test_every_feitcsi_file_reads_as_csikit_reads_it(name: str) -> None:
    folder = SHARED / "feitcsi"
    if not folder.is_dir():
        missing(f"the shared captures {folder}")
    ours = wins.read_feitcsi(folder / f"{name}.csi")
    refs = [json.loads(line) for line in (folder / f"{name}.csikit_ref.jsonl").read_text().splitlines()]
    assert ours.count == len(refs)
    for k, r in enumerate(refs):
        ref = np.array(r["csi"], dtype=np.float64)
        assert np.array_equal(ours.csi[k], ref[..., 0] + 1j * ref[..., 1]), k
        assert (ours.mcs[k], ours.width_mhz[k], ours.format[k]) == (
            r["mcs"], r["channel_width_mhz"], r["rate_format"])
        assert (ours.rssi1[k], ours.rssi2[k], ours.ftm_clock[k]) == (
            r["rssi1"], r["rssi2"], r["ftm_clock"])
        mac = ":".join(f"{b:02x}" for b in ours.source_mac[k])
        assert mac == r["source_mac"]


def test_atheros_and_picoscenes_read_as_their_references_as_packets() -> None:
    for card in ["atheros", "picoscenes"]:
        if not (SHARED / card).is_dir():
            missing(f"the shared captures {SHARED / card}")
    # Atheros: the packet's CSI is the reference's [tone][rx][tx], every value.
    log = SHARED / "atheros" / "csiread_ath_csi_1.dat"
    ath = wins.read_packets(log)
    refs = [json.loads(line) for line in
            (SHARED / "atheros" / "csiread_ath_csi_1.csiread_ref.jsonl").read_text().splitlines()]
    assert (ath.format, len(ath.packets)) == ("atheros", len(refs))
    for p, r in zip(ath.packets, refs):
        ref = np.array(r["csi"], dtype=np.float64)
        assert np.array_equal(p.csi, ref[..., 0] + 1j * ref[..., 1])
        assert (p.carrier_hz, p.transmitter) == (2437e6, r["payload_addr2"])
        assert list(p.subcarriers) == list(range(-28, 0)) + list(range(1, 29))
    # PicoScenes: the AX200's four HT pilots dropped, the rest as the reference holds it.
    pico = wins.read_packets(SHARED / "picoscenes" / "csikit_picoscenes_ax200_example.csi")
    refs = [json.loads(line) for line in (SHARED / "picoscenes" /
            "csikit_picoscenes_ax200_example.csikit_ref.jsonl").read_text().splitlines()]
    assert (pico.format, len(pico.packets), pico.lost) == ("picoscenes", 885, None)
    kept = [i for i in range(56) if i not in (7, 21, 34, 48)]
    for p, r in zip(pico.packets, refs):
        if len(r["csi"]) != 56:
            continue
        ref = np.array(r["csi"], dtype=np.float64)[kept]
        assert np.array_equal(p.csi, ref[..., 0] + 1j * ref[..., 1])
        assert p.transmitter == r["mpdu"]["addr2"]
    # Per-packet AoA of any card, as `wins aoa` gives it.
    a = wins.aoa(log)
    assert len(a.rows["aoa_deg"]) == 401 and a.summary["with_aoa"] == 401
    with pytest.raises(wins.WinsError, match="spotfi"):
        wins.aoa(log, mode="spotfi")
    with pytest.raises(wins.WinsError, match="unknown CSI format"):
        wins.read_packets(log, format="pico")


def test_atheros_and_picoscenes_raw_readers_equal_their_references() -> None:
    for card in ["atheros", "picoscenes"]:
        if not (SHARED / card).is_dir():
            missing(f"the shared captures {SHARED / card}")
    ath = wins.read_atheros(SHARED / "atheros" / "csiread_ath_csi_1.dat")
    refs = [json.loads(line) for line in
            (SHARED / "atheros" / "csiread_ath_csi_1.csiread_ref.jsonl").read_text().splitlines()]
    assert (ath.count, ath.order, ath.tail) == (len(refs), "little", None)
    for k, r in enumerate(refs):
        ref = np.array(r["csi"], dtype=np.float64)
        assert np.array_equal(ath.csi[k], ref[..., 0] + 1j * ref[..., 1]), k
        assert (ath.timestamp[k], ath.tx_channel[k], ath.rate[k], ath.rssi_1[k]) == (
            r["timestamp"], r["channel"], r["rate"], r["rssi1"])
        assert len(ath.payloads[k]) == r["payload_len"]
    pico = wins.read_picoscenes(SHARED / "picoscenes" / "csikit_picoscenes_ax200_example.csi")
    refs = [json.loads(line) for line in (SHARED / "picoscenes" /
            "csikit_picoscenes_ax200_example.csikit_ref.jsonl").read_text().splitlines()]
    assert pico.count == len(refs) == 885
    for k, r in enumerate(refs):
        ref = np.array(r["csi"], dtype=np.float64)
        tones = ref.shape[0]
        assert np.array_equal(pico.csi[k, :tones], ref[..., 0] + 1j * ref[..., 1]), k
        assert (pico.mcs[k], pico.rssi_ctl1[k], pico.carrier_freq[k], pico.mu_clock[k]) == (
            r["rxs_basic"]["mcs"], r["rxs_basic"]["rssi_ctl1"], r["csi_header"]["carrierFreq"],
            r["mvm_extra"]["mu_clock"])
        assert (pico.addr1[k], pico.addr2[k]) == (r["mpdu"]["addr1"], r["mpdu"]["addr2"])
    with pytest.raises(wins.WinsError, match="no PicoScenes frame"):
        wins.read_picoscenes(SHARED / "atheros" / "csiread_ath_csi_1.dat")


def test_check_gives_every_cards_verdict_as_the_command_line() -> None:
    pico = SHARED / "picoscenes" / "csikit_picoscenes_ax200_example.csi"
    if not pico.is_file():
        missing(f"the shared capture {pico}")
    c = wins.check(pico)
    phases = next(f for f in c.findings if f["topic"] == "chain phases")
    assert (c.verdict, c.usable, phases["verdict"]) == ("warning", True, "warning")
    assert "180°" in phases["measured"]
    done = cli("csi", "check", "--json", str(pico))
    assert json.loads(done.stdout)["check"]["findings"] == c.findings
    log = REPO / "data" / "intel5300" / "csikit_example.dat"
    # CSIKit's example: its chains step by quarter turns from packet to packet.
    five = wins.check(log, channel=64)
    assert (five.verdict, five.usable) == ("bad", False)
    assert next(f for f in five.findings if f["topic"] == "chain phases")["verdict"] == "bad"
    with pytest.raises(wins.WinsError, match="not a Wi-Fi channel"):
        wins.check(log, channel=500)


def test_chunks_are_the_whole_log() -> None:
    path = max(captures(), key=lambda p: p.stat().st_size)
    whole = wins.read_csi(path, ntx=3)
    chunks = list(wins.iter_csi(path, chunk=97, ntx=3))
    assert sum(c.count for c in chunks) == whole.count
    assert all(c.count <= 97 for c in chunks)
    assert np.array_equal(np.concatenate([c.csi for c in chunks]), whole.csi)
    assert np.array_equal(np.concatenate([c.timestamp_ns for c in chunks]), whole.timestamp_ns)


def test_a_damaged_log_is_read_around_the_damage(tmp_path: Path) -> None:
    path = captures()[0]
    data = path.read_bytes()
    damaged = tmp_path / "damaged.dat"
    middle = len(data) // 2
    damaged.write_bytes(data[:middle] + b"\xff" * 999 + data[middle:])
    ours = wins.read_csi(damaged)
    clean = wins.read_csi(path)
    assert clean.count - 1 <= ours.count <= clean.count
    assert sum(length for _, length, _ in ours.skipped) >= 999


def test_errors_are_wins_errors_with_the_reason(tmp_path: Path) -> None:
    with pytest.raises(wins.WinsError, match="No such file"):
        wins.read_csi(tmp_path / "absent.dat")
    text = tmp_path / "notes.txt"
    text.write_text("not a capture\n" * 100)
    with pytest.raises(wins.WinsError, match="no CSI records"):
        wins.aoa(text)
    pcap = tmp_path / "nexmon.pcap"
    pcap.write_bytes(bytes([0xD4, 0xC3, 0xB2, 0xA1]) + bytes(range(256)) * 16)
    with pytest.raises(wins.WinsError, match="no CSI records.*a pcap capture"):
        wins.read_csi(pcap)
    with pytest.raises(wins.WinsError, match="1 to 3"):
        wins.read_csi(captures()[0], nrx=4)
    with pytest.raises(wins.WinsError, match="no-such-flight"):
        wins.simulate(tmp_path / "x", "no-such-flight")
    with pytest.raises(wins.WinsError, match="run.json"):
        wins.load_run(tmp_path)


def test_aoa_is_what_wins_aoa_writes(tmp_path: Path) -> None:
    path = REPO / "data" / "intel5300" / "csiread_sample_0x5_64_3000.dat"
    if not path.is_file():
        path = captures()[-1]
    ours = wins.aoa(path)
    out = tmp_path / "aoa.csv"
    cli("aoa", str(path), "--out", str(out))
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(ours.rows["aoa_deg"]) == ours.summary["packets"]
    cli_aoa = np.array([float(r["aoa_deg"]) if r["aoa_deg"] else math.nan for r in rows])
    assert np.allclose(ours.rows["aoa_deg"], cli_aoa, equal_nan=True, rtol=0, atol=1e-9)
    assert [r["status"] for r in rows] == list(ours.rows["status"])


def test_a_run_is_what_wins_run_writes(tmp_path: Path) -> None:
    dataset = tmp_path / "dataset"
    summary = wins.simulate(dataset, "paper-circle", seed=3, duration_s=20)
    assert "packets" in summary
    ours = wins.run(dataset, tmp_path / "py")
    cli("run", str(dataset), "--out", str(tmp_path / "cli"), "--no-plots")
    theirs = wins.load_run(tmp_path / "cli")
    assert len(ours.t) > 100
    assert np.array_equal(ours.t, theirs.t)
    assert np.array_equal(ours.p_b_in_w, theirs.p_b_in_w)
    assert np.array_equal(ours.q_xyzw, theirs.q_xyzw)
    assert np.array_equal(ours.covariance, theirs.covariance, equal_nan=True)
    assert ours.covariance.shape == (len(ours.t), 6, 6)
    assert np.all(ours.covariance[:, [0, 1, 2], [0, 1, 2]] > 0)
    assert set(ours.aps) == {"ap0"}
    position, covariance = ours.aps["ap0"]
    assert position.shape == (3,) and np.all(np.linalg.eigvalsh(covariance) > 0)
    assert ours.metrics is not None and ours.metrics["ate_rmse_m"] < 2.0
    assert ours.evaluation == "ok"
    assert ours.stats["packets"]["per_ap"][0]["name"] == "ap0"
    # The folder rules of `wins run`: the dataset is never an output.
    with pytest.raises(wins.WinsError, match="dataset"):
        wins.run(dataset, dataset)


def test_another_cards_rig_is_simulated_in_its_format_and_flown(tmp_path: Path) -> None:
    dataset = tmp_path / "nexmon"
    wins.simulate(dataset, "paper-circle-3ap", seed=2, duration_s=60, card="nexmon")
    assert 'card = "nexmon"' in (dataset / "dataset.toml").read_text()
    packets = wins.read_packets(dataset / "ap0.dat")
    assert packets.format == "nexmon"
    ours = wins.run(dataset, tmp_path / "run")
    assert len(ours.t) > 100
    # The same flight as the Rust tests' Nexmon rig (0.339 m there).
    assert ours.metrics is not None and ours.metrics["ate_rmse_m"] < 0.5
    with pytest.raises(wins.WinsError, match="picoscenes"):
        wins.simulate(tmp_path / "x", "paper-circle", duration_s=20, card="picoscenes")


def test_a_family_flight_and_a_sweep_load(tmp_path: Path) -> None:
    drawn = tmp_path / "room"
    wins.simulate(drawn, family="room", seed=4, duration_s=20)
    assert (drawn / "dataset.toml").is_file() and (drawn / "truth").is_dir()
    assert ("family:room" in [name for name, _ in wins.scenarios()])
    sweep = tmp_path / "sweep"
    cli("sweep", "--scenario", "paper-circle", "--seeds", "1..2", "--duration-s", "20",
        "--out", str(sweep))
    loaded = wins.load_sweep(sweep)
    assert list(loaded.runs["seed"]) == [1, 2]
    assert loaded.runs["scenario"][0] == "paper-circle"
    assert loaded.summary


def test_the_readme_example_runs_as_written(tmp_path: Path, monkeypatch, capsys) -> None:
    readme = (REPO / "README.md").read_text()
    section = readme.split("## From Python", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    if not (REPO / "target" / "demo" / "run" / "run.json").is_file():
        missing("target/demo/run (the README's first command, `wins demo`)")
    monkeypatch.chdir(REPO)
    exec(compile(code, "README.md", "exec"), {})
    printed = capsys.readouterr().out
    assert "(26, 30, 3, 2) complex128" in printed
    assert ", 6, 6)" in printed


def test_the_settings_are_the_shipped_ones() -> None:
    shipped = (REPO / "configs" / "default.toml").read_text()
    assert wins.default_config() == shipped
    assert wins.__version__


@pytest.fixture(autouse=True, scope="session")
def _no_leftovers(tmp_path_factory: pytest.TempPathFactory):
    yield
    shutil.rmtree(tmp_path_factory.getbasetemp(), ignore_errors=True)
