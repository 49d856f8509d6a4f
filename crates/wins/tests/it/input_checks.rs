//! The input checks of a dataset (`wins::dataset::checks`): each damage a careless or hostile
//! user can do to a flight's files is counted with its time, warned about, or refused with a
//! reason; what can be used is used.

use std::fs;
use std::path::Path;

use wins::Config;
use wins::csi::intel5300::read_log;
use wins::csi::logged::{LogWriter, Logged};
use wins::dataset::{Dataset, DatasetError};
use wins::sim::{Scenario, simulate, write_dataset};

use super::pipeline_run::{TempDir, temp_dir};

/// A 20 s paper-circle dataset (seed 1), written to a fresh folder.
fn flight(name: &str) -> TempDir {
    let dir = temp_dir(&format!("inputs-{name}"));
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.seed = 1;
    s.duration_s = 20.0;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(&dir, &s, &out).unwrap();
    dir
}

/// Rewrites the data lines of `imu.csv` (header kept) with `edit` over `(t_ns, fields)`.
fn edit_imu(dir: &Path, edit: impl FnOnce(&mut Vec<Vec<String>>)) {
    let path = dir.join("imu.csv");
    let text = fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let mut rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    edit(&mut rows);
    let mut out = header + "\n";
    for r in rows {
        out += &r.join(",");
        out += "\n";
    }
    fs::write(path, out).unwrap();
}

/// The first row at or after `t_s`.
fn row_at(rows: &[Vec<String>], t_s: f64) -> usize {
    rows.iter()
        .position(|r| r[0].parse::<i64>().unwrap() as f64 >= t_s * 1e9)
        .unwrap()
}

fn load(dir: &Path) -> Dataset {
    Dataset::load(dir).unwrap()
}

fn load_err(dir: &Path) -> String {
    match Dataset::load(dir) {
        Err(e @ DatasetError::Inputs { .. }) | Err(e @ DatasetError::Invalid { .. }) => {
            e.to_string()
        }
        other => panic!("expected a refusal, got {:?}", other.map(|d| d.inputs)),
    }
}

#[test]
fn an_imu_gap_is_counted_with_its_length_and_time() {
    let dir = flight("gap");
    edit_imu(&dir, |rows| {
        let (a, b) = (row_at(rows, 10.0), row_at(rows, 12.0));
        rows.drain(a..b);
    });
    let d = load(&dir);
    assert_eq!(d.inputs.imu.gaps, 1);
    assert!((d.inputs.imu.longest_gap_s - 2.005).abs() < 1e-6);
    let w = d.inputs.warnings.join("\n");
    assert!(
        w.contains("IMU gaps") && w.contains("2.005 s") && w.contains("9.995 s"),
        "{w}"
    );
    // An undamaged flight has no gap and no warning.
    let clean = load(&flight("no-gap"));
    assert_eq!(clean.inputs.imu.gaps, 0);
    assert!(
        clean.inputs.warnings.is_empty(),
        "{:?}",
        clean.inputs.warnings
    );
}

#[test]
fn samples_beyond_range_not_finite_or_back_in_time_are_dropped_and_counted() {
    let dir = flight("values");
    let rows_before = load(&dir).imu.len();
    edit_imu(&dir, |rows| {
        let i = row_at(rows, 5.0);
        rows[i][4] = format!("{}", 16.0 * 9.80665); // 16 g: the sensor's full scale
        rows[i + 10][5] = "1e308".into();
        rows[i + 20][1] = "NaN".into();
        rows.swap(i + 30, i + 31); // time goes back once
    });
    let d = load(&dir);
    let imu = &d.inputs.imu;
    assert_eq!(imu.beyond_range, 2);
    assert_eq!(imu.not_finite, 1);
    assert_eq!(imu.time_not_increasing, 1);
    assert_eq!(d.imu.len(), rows_before - 4);
    assert!(d.imu.windows(2).all(|w| w[0].t < w[1].t));
    let w = d.inputs.warnings.join("\n");
    assert!(w.contains("beyond the sensor's range, dropped: 2"), "{w}");
    assert!(w.contains("not finite, dropped: 1"), "{w}");
    assert!(w.contains("time going back, dropped: 1"), "{w}");
}

#[test]
fn an_imu_file_cut_while_written_loses_its_last_line_and_says_it_ends_early() {
    let dir = flight("cut-imu");
    let path = dir.join("imu.csv");
    let text = fs::read_to_string(&path).unwrap();
    // Cut at 10 s, inside the last number.
    let at = text.find("\n10000000000,").unwrap();
    fs::write(&path, &text[..at - 3]).unwrap();
    let d = load(&dir);
    assert!(d.inputs.imu.cut_last_line);
    assert!(d.imu.last().unwrap().t.as_secs_f64() < 10.0);
    assert!(d.inputs.aps[0].after_imu > 0);
    let w = d.inputs.warnings.join("\n");
    assert!(w.contains("last line has no line end"), "{w}");
    assert!(w.contains("the IMU ends at 10.0 s"), "{w}");
}

#[test]
fn timestamps_in_microseconds_are_refused_with_the_likely_cause() {
    let dir = flight("micros");
    edit_imu(&dir, |rows| {
        for r in rows {
            r[0] = (r[0].parse::<i64>().unwrap() / 1000).to_string();
        }
    });
    let e = load_err(&dir);
    assert!(e.contains("200000") && e.contains("nanoseconds"), "{e}");
}

fn set_offset(dir: &Path, f: impl Fn(i64) -> String) {
    let path = dir.join("dataset.toml");
    let text = fs::read_to_string(&path).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("imu_minus_nic_ns"))
        .unwrap();
    let value: i64 = line.split('=').nth(1).unwrap().trim().parse().unwrap();
    fs::write(
        &path,
        text.replace(line, &format!("imu_minus_nic_ns = {}", f(value))),
    )
    .unwrap();
}

#[test]
fn a_clock_offset_that_puts_no_packet_under_the_imu_or_overflows_is_refused() {
    let dir = flight("hour");
    set_offset(&dir, |v| (v + 3_600_000_000_000).to_string());
    let e = load_err(&dir);
    assert!(
        e.contains("no packet of any AP") && e.contains("3600."),
        "{e}"
    );
    let dir = flight("overflow");
    set_offset(&dir, |_| i64::MAX.to_string());
    let e = load_err(&dir);
    assert!(e.contains("out of range") && e.contains("ap0"), "{e}");
    // No overflow, but a packet time the pipeline's frame grid would overflow: refused too.
    let dir = flight("far");
    set_offset(&dir, |_| (i64::MAX - 5_000_000_000_000).to_string());
    let e = load_err(&dir);
    assert!(e.contains("out of range") && e.contains("146 years"), "{e}");
}

/// Rewrites `ap0.dat` from its records, `edit` applied to the record list.
fn edit_log(dir: &Path, edit: impl FnOnce(&mut Vec<wins::csi::intel5300::CsiRecord>)) {
    let path = dir.join("ap0.dat");
    let mut records = read_log(&path).unwrap().records;
    edit(&mut records);
    let mut w = LogWriter::new(Vec::new());
    for r in records {
        w.write(&Logged::Intel5300(r)).unwrap();
    }
    fs::write(path, w.finish().unwrap()).unwrap();
}

#[test]
fn a_log_written_twice_keeps_one_copy() {
    let dir = flight("twice");
    let n = load(&dir).aps[0].packets.len();
    let bytes = fs::read(dir.join("ap0.dat")).unwrap();
    fs::write(dir.join("ap0.dat"), [bytes.clone(), bytes].concat()).unwrap();
    let d = load(&dir);
    assert_eq!(d.aps[0].packets.len(), n);
    assert_eq!(d.inputs.aps[0].repeated as usize, n);
    assert_eq!(d.inputs.aps[0].clock_jumps_back, 0);
    assert!(
        d.inputs
            .warnings
            .join("\n")
            .contains("repeated records dropped")
    );
}

#[test]
fn a_nic_clock_reset_mid_log_drops_the_records_it_cannot_place() {
    let dir = flight("reset");
    let n = load(&dir).aps[0].packets.len();
    edit_log(&dir, |records| {
        let half = records.len() / 2;
        for r in &mut records[half..] {
            r.header.timestamp_low = r.header.timestamp_low.wrapping_sub(8_000_000);
        }
    });
    let d = load(&dir);
    let ap = &d.inputs.aps[0];
    assert_eq!(ap.clock_jumps_back, 1);
    assert!(ap.after_clock_jump > 0);
    assert_eq!(ap.kept + ap.after_clock_jump, n as u64);
    let w = d.inputs.warnings.join("\n");
    assert!(
        w.contains("jumped back") && w.contains("the first at"),
        "{w}"
    );
}

#[test]
fn a_silent_ap_is_counted_with_its_length_and_time() {
    let dir = flight("silent");
    let n = load(&dir).aps[0].packets.len();
    let mut cut = 0;
    edit_log(&dir, |records| {
        let before = records.len();
        // 3 s without a record from 8 s on (NIC µs, from its first record near 0 s).
        let t0 = records[0].header.timestamp_low;
        records.retain(|r| {
            !(8_000_000..11_000_000).contains(&r.header.timestamp_low.wrapping_sub(t0))
        });
        cut = before - records.len();
    });
    let d = load(&dir);
    let ap = &d.inputs.aps[0];
    assert!(cut > 100, "{cut} records cut");
    assert_eq!(ap.kept as usize, n - cut);
    assert_eq!(ap.silences, 1, "{ap:?}");
    assert!((ap.longest_silence_s - 3.0).abs() < 0.1, "{ap:?}");
    let w = d.inputs.warnings.join("\n");
    assert!(
        w.contains("AP ap0: silent for longer than 1 s (an outage?): 1 times")
            && w.contains("the first at 7.9"),
        "{w}"
    );
    let event = &d.inputs.events[0];
    assert!(event.what.contains("no record for 3.0"), "{event:?}");
}

#[test]
fn a_log_cut_short_says_so_and_the_run_accounts_for_it() {
    let dir = flight("half-log");
    let bytes = fs::read(dir.join("ap0.dat")).unwrap();
    fs::write(dir.join("ap0.dat"), &bytes[..bytes.len() / 2]).unwrap();
    let run = wins::run_dataset(&dir, &Config::default()).unwrap();
    let w = run.warnings.join("\n");
    assert!(
        w.contains("the log ends at") && w.contains("before the IMU"),
        "{w}"
    );
    assert_eq!(run.inputs.aps[0].kept as usize, run.packets.len());
}

#[test]
fn manifest_values_that_cannot_be_used_are_refused() {
    for (old, new, key) in [
        ("rate_hz = 200.0", "rate_hz = 0.0", "imu.rate_hz"),
        ("rate_hz = 200.0", "rate_hz = 1e9", "imu.rate_hz"),
    ] {
        let dir = flight("manifest");
        let path = dir.join("dataset.toml");
        let text = fs::read_to_string(&path).unwrap();
        assert!(text.contains(old));
        fs::write(&path, text.replacen(old, new, 1)).unwrap();
        let e = load_err(&dir);
        assert!(e.contains(key), "{e}");
    }
    let dir = flight("translation");
    let path = dir.join("dataset.toml");
    let text = fs::read_to_string(&path).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("translation_m"))
        .unwrap();
    fs::write(&path, text.replace(line, "translation_m = [nan, 0.0, 0.0]")).unwrap();
    let e = load_err(&dir);
    assert!(e.contains("array.translation_m"), "{e}");
}
