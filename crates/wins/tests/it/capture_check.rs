//! `wins csi check` on real captures, on simulated ones and on files that are not CSI Tool logs:
//! each verdict is what a person reading the raw CSI finds (the numbers in the comments are
//! from the raw CSI, `wins csi export` and a few lines of numpy).

use std::path::{Path, PathBuf};

use wins::aoa::capture_check::{
    CaptureCheck, CheckOptions, Finding, Identified, Verdict, check_capture,
};
use wins::aoa::capture_stats::{CaptureStats, capture_stats};
use wins::rig::ChainCalibration;

use super::data::shared_data;

fn topic<'a>(check: &'a CaptureCheck, topic: &str) -> &'a Finding {
    check
        .findings
        .iter()
        .find(|f| f.topic == topic)
        .unwrap_or_else(|| panic!("no {topic} finding in {check}"))
}

fn checked(path: &Path) -> CaptureCheck {
    check_capture(path, &CheckOptions::default()).expect("read")
}

fn intel(dir: &Path, name: &str) -> PathBuf {
    dir.join("intel5300").join(name)
}

#[test]
fn every_static_lgtm_capture_has_its_antennas_and_a_signal() {
    let Some(dir) = shared_data() else { return };
    let lgtm = dir.join("intel5300/lgtm");
    let mut captures: Vec<PathBuf> = std::fs::read_dir(&lgtm)
        .expect("lgtm folder")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "dat"))
        .collect();
    captures.sort();
    assert!(captures.len() >= 8, "{captures:?}");
    for path in &captures {
        let c = checked(path);
        let name = path.display();
        // Every antenna connected (the weakest within 12 dB: a multipath null, not a loose
        // connector), 30–38 dB of SNR against the CSI Tool's −92 dBm, nothing clipped.
        assert_ne!(topic(&c, "antennas").verdict, Verdict::Bad, "{name}: {c}");
        assert_eq!(topic(&c, "signal").verdict, Verdict::Good, "{name}: {c}");
        assert!(topic(&c, "signal").measured.contains("assumed"), "{name}");
        assert_eq!(topic(&c, "clipping").verdict, Verdict::Good, "{name}: {c}");
        assert_eq!(topic(&c, "file").verdict, Verdict::Good, "{name}: {c}");
        assert_ne!(c.verdict(), Verdict::Bad, "{name}: {c}");
        // Static captures: the phases between neighbouring chains hold within 1° (IQR), except
        // test-5's, which drift by 40° over the capture (something moved).
        let phases = topic(&c, "chain phases");
        if name.to_string().contains("test-5") {
            assert_eq!(phases.verdict, Verdict::Unknown, "{name}: {c}");
            assert!(phases.measured.contains("move"), "{name}: {c}");
        } else {
            assert_eq!(phases.verdict, Verdict::Good, "{name}: {c}");
        }
    }
}

#[test]
fn a_capture_whose_chains_step_by_quarter_turns_is_refused() {
    let Some(dir) = shared_data() else { return };
    // The CSI Tool's AP-mode sample (2.4 GHz): the phase between chains A and B takes four
    // values 90° apart from packet to packet (−148°, −58°, 32°, 122°), at 9 packets/s.
    let c = checked(&intel(&dir, "csiread_sample_0x1_ap.dat"));
    let phases = topic(&c, "chain phases");
    assert_eq!(phases.verdict, Verdict::Bad, "{c}");
    assert!(phases.measured.contains("90°"), "{c}");
    assert_eq!(topic(&c, "packets").verdict, Verdict::Bad, "{c}");
    assert_eq!(c.verdict(), Verdict::Bad);
}

#[test]
fn a_capture_with_two_weak_antennas_is_refused() {
    let Some(dir) = shared_data() else { return };
    // Chains B and C are 19 dB under chain A over the whole capture.
    let c = checked(&intel(&dir, "csiread_sample_0x5_64_3000.dat"));
    let antennas = topic(&c, "antennas");
    assert_eq!(antennas.verdict, Verdict::Bad, "{c}");
    assert!(
        antennas
            .advice
            .as_deref()
            .is_some_and(|a| a.contains("connected")),
        "{c}"
    );
    // 1000 packets/s, none missing.
    assert_eq!(topic(&c, "packets").verdict, Verdict::Good, "{c}");
}

#[test]
fn files_of_other_formats_are_named() {
    let Some(dir) = shared_data() else { return };
    let pcap = dir.join("nexmon/mutrack_D2_CSI_2G_20M_AP3_tr2.pcap");
    let c = checked(&pcap);
    assert_eq!(c.verdict(), Verdict::Bad);
    assert_eq!(c.findings.len(), 1, "{c}");
    assert!(topic(&c, "file").measured.contains("pcap"), "{c}");
    let text = intel(&dir, "csikit_example.matlab_ref.jsonl");
    assert!(topic(&checked(&text), "file").measured.contains("text"));
}

/// `bytes` with every CSI record rewritten by `edit` (its payload after the code byte) and
/// `prefix` bytes written in front of every record.
fn rewritten(bytes: &[u8], prefix: usize, edit: impl Fn(&[u8]) -> Vec<u8>) -> Vec<u8> {
    let (mut out, mut at) = (Vec::new(), 0);
    while at + 3 <= bytes.len() {
        let len = usize::from(u16::from_be_bytes([bytes[at], bytes[at + 1]]));
        let code = bytes[at + 2];
        let payload = &bytes[at + 3..at + 2 + len];
        let payload = if code == 0xBB {
            edit(payload)
        } else {
            payload.to_vec()
        };
        out.extend(std::iter::repeat_n(0x5A, prefix));
        out.extend(
            u16::try_from(payload.len() + 1)
                .expect("short")
                .to_be_bytes(),
        );
        out.push(code);
        out.extend(payload);
        at += 2 + len;
    }
    out
}

#[test]
fn logs_of_a_modified_csi_tool_are_named_not_only_refused() {
    let Some(dir) = shared_data() else { return };
    let bytes = std::fs::read(dir.join("intel5300/lgtm/lgtm-1m-0-degrees--laptop-1--test-1.dat"))
        .expect("read");
    let tmp = std::env::temp_dir().join(format!("wins-check-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("tmp");
    // Eight bytes between the 20-byte header and the CSI of every CSI record: nothing frames
    // as the CSI Tool's.
    let longer = tmp.join("longer.dat");
    let extra = |p: &[u8]| [&p[..20], &[0u8; 8][..], &p[20..]].concat();
    std::fs::write(&longer, rewritten(&bytes, 0, extra)).expect("write");
    // Eight bytes in front of every record: the CSI records are recovered, the frames lost.
    let prefixed = tmp.join("prefixed.dat");
    std::fs::write(&prefixed, rewritten(&bytes, 8, <[u8]>::to_vec)).expect("write");
    let (a, b) = (checked(&longer), checked(&prefixed));
    let _ = std::fs::remove_dir_all(&tmp);
    assert_eq!(a.verdict(), Verdict::Bad);
    assert!(
        topic(&a, "file").measured.contains("modified CSI Tool"),
        "{a}"
    );
    assert!(topic(&a, "file").measured.contains("8 bytes more"), "{a}");
    assert_eq!(
        wins::aoa::capture_check::identify_bytes(&rewritten(&bytes, 0, extra)),
        Some(Identified::LongerCsiRecords { extra: 8 })
    );
    assert_eq!(topic(&b, "file").verdict, Verdict::Warning, "{b}");
    assert!(
        topic(&b, "file")
            .advice
            .as_deref()
            .is_some_and(|s| s.contains("preceded by 8 bytes"))
    );
    assert_eq!(b.summary.csi_records, 1025);
    assert_ne!(b.verdict(), Verdict::Bad, "{b}");
}

#[test]
fn a_simulated_capture_checks_out() {
    let mut scenario = wins::sim::Scenario::built_in("hover").expect("built-in");
    scenario.duration_s = 20.0;
    let out = wins::sim::simulate(&scenario, &mut |_| {}).expect("simulated");
    let dir = std::env::temp_dir().join(format!("wins-check-sim-{}", std::process::id()));
    wins::sim::write_dataset(&dir, &scenario, &out).expect("written");
    let calibration = ChainCalibration::load(&dir.join("calibration.toml")).expect("calibration");
    let options = CheckOptions {
        center_freq_hz: Some(scenario.radio.center_freq_hz),
        calibration: Some(calibration),
    };
    let c = check_capture(&dir.join("ap0.dat"), &options).expect("read");
    let _ = std::fs::remove_dir_all(&dir);
    // Three antennas, a strong signal, nothing clipped, 50 packets/s.
    for t in ["file", "antennas", "signal", "clipping", "packets"] {
        assert_eq!(topic(&c, t).verdict, Verdict::Good, "{t}: {c}");
    }
    // The room's reflections scatter the chains' curvature (agreement 0.24 while hovering):
    // not compared with the calibration.
    assert_eq!(topic(&c, "calibration").verdict, Verdict::Unknown, "{c}");
    assert_eq!(c.verdict(), Verdict::Good, "{c}");
}

#[test]
fn a_calibration_is_checked_against_a_static_capture() {
    let Some(dir) = shared_data() else { return };
    let log = dir.join("intel5300/lgtm/lgtm-1m-20-degrees--laptop-1--test-1.dat");
    // The capture's own curvature (89.5°) as a calibration, then chain C a half turn off it.
    let curvature = 89.5f64.to_radians();
    let calibration = |c: f64| ChainCalibration {
        phase_offsets_rad: vec![0.0, 0.0, c],
        ..ChainCalibration::identity(3)
    };
    let with = |c: f64| {
        check_capture(
            &log,
            &CheckOptions {
                center_freq_hz: Some(5.32e9),
                calibration: Some(calibration(c)),
            },
        )
        .expect("read")
    };
    let holds = with(curvature);
    assert_eq!(
        topic(&holds, "calibration").verdict,
        Verdict::Good,
        "{holds}"
    );
    let stepped = with(curvature + std::f64::consts::PI);
    let step = topic(&stepped, "calibration");
    assert_eq!(step.verdict, Verdict::Warning, "{stepped}");
    assert!(step.measured.contains("1 restart step"), "{stepped}");
    // A quarter turn is no restart step at 5 GHz: another set-up.
    let other = with(curvature + std::f64::consts::FRAC_PI_2);
    assert!(
        topic(&other, "calibration")
            .advice
            .as_deref()
            .is_some_and(|a| a.contains("not a whole restart step"))
    );
    // At 2.4 GHz it is one.
    let at_2g4 = check_capture(
        &log,
        &CheckOptions {
            center_freq_hz: Some(2.437e9),
            calibration: Some(calibration(curvature + std::f64::consts::FRAC_PI_2)),
        },
    )
    .expect("read");
    assert!(
        topic(&at_2g4, "calibration")
            .measured
            .contains("1 restart step"),
        "{at_2g4}"
    );
}

#[test]
fn a_missing_file_is_an_error_and_a_damaged_one_a_finding() {
    let missing = Path::new("/nonexistent/wins/capture.dat");
    assert!(check_capture(missing, &CheckOptions::default()).is_err());
    let Some(dir) = shared_data() else { return };
    let mut bytes =
        std::fs::read(dir.join("intel5300/lgtm/lgtm-1m-10-degrees--laptop-1--test-1.dat"))
            .expect("read");
    // Garbage over a stretch in the middle, and the tail cut.
    for b in &mut bytes[100_000..103_000] {
        *b = 0xEE;
    }
    bytes.truncate(bytes.len() - 77);
    let path = std::env::temp_dir().join(format!("wins-check-damaged-{}.dat", std::process::id()));
    std::fs::write(&path, &bytes).expect("write");
    let c = checked(&path);
    let _ = std::fs::remove_file(&path);
    let file = topic(&c, "file");
    assert_eq!(file.verdict, Verdict::Warning, "{c}");
    assert!(file.measured.contains("do not frame"), "{c}");
    assert!(c.summary.csi_records > 1000, "{c}");
}

/// `wins csi stats` of `records` on the lgtm rig (0.1 m, channel 64), default settings.
fn lgtm_stats(records: &[wins::csi::intel5300::CsiRecord]) -> CaptureStats {
    let geometry = wins::rig::ArrayGeometry {
        num_antennas: 3,
        spacing_m: 0.1,
    };
    capture_stats(
        records,
        &wins::aoa::AoaConfig::default(),
        geometry,
        wins::rig::array::CHANNEL_64_HZ,
    )
    .expect("measured")
    .expect("three-chain records")
}

/// A statistic of [`CaptureStats`]: its name, how to read it, and the sampling error allowed
/// outside the real range.
type Statistic = (&'static str, fn(&CaptureStats) -> f64, f64);

#[test]
fn the_simulated_static_capture_is_within_the_real_captures_range() {
    let Some(dir) = shared_data() else { return };
    let lgtm = dir.join("intel5300/lgtm");
    let mut real = Vec::new();
    for entry in std::fs::read_dir(&lgtm).expect("lgtm") {
        let path = entry.expect("entry").path();
        let name = path.display().to_string();
        if name.ends_with(".dat") && !name.contains("test-5") {
            real.push(lgtm_stats(
                &wins::csi::intel5300::read_log(&path).expect("log").records,
            ));
        }
    }
    assert_eq!(real.len(), 7);
    let scenario = wins::sim::Scenario::built_in("static-capture").expect("built-in");
    let out = wins::sim::simulate(&scenario, &mut |_| {}).expect("simulated");
    let sim = lgtm_stats(
        &out.aps[0]
            .received()
            .map(|(_, r)| r.clone())
            .collect::<Vec<_>>(),
    );
    let fields: [Statistic; 10] = [
        ("phase IQR", |s| s.chain_phase_iqr_deg, 0.0),
        ("curvature agreement", |s| s.curvature_agreement, 0.0),
        ("λ2/λ1", |s| s.eigenvalue_db[0], 0.0),
        ("λ3/λ1", |s| s.eigenvalue_db[1], 0.0),
        ("λ4/λ1", |s| s.eigenvalue_db[2], 0.0),
        ("amplitude ripple", |s| s.amplitude_ripple_db, 0.0),
        (
            "chains' amplitude ripple",
            |s| s.chain_amplitude_ripple_db,
            0.0,
        ),
        ("chains' phase ripple", |s| s.chain_phase_ripple_deg, 0.0),
        // A uniform draw's IQR over ~1000 packets scatters by about ±0.4 ns.
        ("timing offset IQR", |s| s.timing_offset_iqr_ns, 0.5),
        ("AGC changes", |s| s.agc_changes_per_100, 0.0),
    ];
    // Not asserted: the credible peaks per packet and the share of packets with a peak in another
    // direction, on which the simulated capture is richer than the real ones (its room's
    // reflections, as the simulator draws them, against the lab's: docs/VALIDATION.md,
    // "Simulated CSI against real"); printed for the record.
    println!(
        "peaks per packet: simulated {:.2}, real {:?}; another direction: simulated {:.1} %, real {:?}",
        sim.peaks_per_packet,
        real.iter().map(|s| s.peaks_per_packet).collect::<Vec<_>>(),
        sim.other_direction_pct,
        real.iter()
            .map(|s| s.other_direction_pct)
            .collect::<Vec<_>>()
    );
    // What those two measure: a real static capture holds one direction per packet, and so does
    // the simulated one with the direct path alone.
    assert!(
        real.iter()
            .all(|s| s.other_direction_pct < 5.0 && s.peaks_per_packet < 1.6),
        "{real:?}"
    );
    let mut direct = scenario.clone();
    direct.room.max_order = 0;
    let out = wins::sim::simulate(&direct, &mut |_| {}).expect("simulated");
    let direct = lgtm_stats(
        &out.aps[0]
            .received()
            .map(|(_, r)| r.clone())
            .collect::<Vec<_>>(),
    );
    assert!(direct.other_direction_pct < 1.0, "{direct:?}");
    let mut outside = Vec::new();
    for (name, get, tolerance) in fields {
        let (lo, hi) = real
            .iter()
            .map(get)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
        let v = get(&sim);
        if !(lo - tolerance..=hi + tolerance).contains(&v) {
            outside.push(format!("{name}: simulated {v:.2}, real {lo:.2} – {hi:.2}"));
        }
    }
    assert!(outside.is_empty(), "{outside:#?}");
    // Without the measured receiver response the smoothed covariance has no floor.
    let mut flat = scenario.clone();
    flat.radio.receiver_response = wins::sim::ReceiverResponse::Flat;
    let out = wins::sim::simulate(&flat, &mut |_| {}).expect("simulated");
    let flat = lgtm_stats(
        &out.aps[0]
            .received()
            .map(|(_, r)| r.clone())
            .collect::<Vec<_>>(),
    );
    let lowest = real
        .iter()
        .map(|s| s.eigenvalue_db[1])
        .fold(f64::INFINITY, f64::min);
    assert!(flat.eigenvalue_db[1] < lowest - 10.0, "{flat:?}");
}
