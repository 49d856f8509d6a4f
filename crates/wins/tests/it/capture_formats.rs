//! Every real capture in `../shared/data` (and the repository's own logs) is told for the format
//! its folder says, and summarized; a format forced on the wrong file reads nothing and says why.

use std::path::PathBuf;

use wins::csi::capture::CaptureSummary;
use wins::csi::format::CaptureFormat;

use super::data::{repo_data, shared_data};

/// Files under `dir` (recursively) whose names end in one of `exts`.
fn files(dir: &std::path::Path, exts: &[&str]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(files(&path, exts));
        } else if exts.iter().any(|e| path.to_string_lossy().ends_with(e)) {
            out.push(path);
        }
    }
    out.sort();
    out
}

#[test]
fn every_real_capture_is_told_for_its_format() {
    let Some(shared) = shared_data() else { return };
    let folders = [
        ("intel5300", &[".dat"][..], CaptureFormat::Intel5300, 12),
        ("nexmon", &[".pcap"], CaptureFormat::Nexmon, 3),
        ("feitcsi", &[".csi"], CaptureFormat::FeitCsi, 2),
        ("picoscenes", &[".csi"], CaptureFormat::PicoScenes, 1),
        ("atheros", &[".dat"], CaptureFormat::Atheros, 1),
    ];
    for (folder, exts, format, at_least) in folders {
        let found = files(&shared.join(folder), exts);
        assert!(found.len() >= at_least, "{folder}: {found:?}");
        for path in found {
            assert_eq!(
                CaptureFormat::of_path(&path).unwrap(),
                Some(format),
                "{}",
                path.display()
            );
            let summary = CaptureSummary::of_path(&path, None).unwrap();
            assert_eq!(
                summary.json_key() == "summary",
                format == CaptureFormat::Intel5300
            );
            assert_eq!(summary.why_empty(&path), None, "{}", path.display());
        }
    }
    for path in files(&repo_data(), &[".dat"]) {
        let format = CaptureFormat::of_path(&path).unwrap();
        assert!(
            matches!(format, Some(CaptureFormat::Intel5300) | None),
            "{}: {format:?}",
            path.display()
        );
    }
}

#[test]
fn a_format_forced_on_the_wrong_file_reads_nothing_and_says_why() {
    let Some(shared) = shared_data() else { return };
    let pico = shared.join("picoscenes/csikit_picoscenes_ax200_example.csi");
    let ath = shared.join("atheros/csiread_ath_csi_1.dat");
    for (path, format, says) in [
        (&pico, CaptureFormat::Atheros, "not an Atheros record"),
        (&ath, CaptureFormat::PicoScenes, "not a PicoScenes frame"),
        (&ath, CaptureFormat::FeitCsi, "not a FeitCSI header"),
    ] {
        let summary = CaptureSummary::of_path(path, Some(format)).unwrap();
        let why = summary.why_empty(path).expect("nothing read");
        assert!(why.contains(says), "{format}: {why}");
    }
    // Read as an Intel 5300 log, each names what it is.
    for (path, says) in [
        (&pico, "a PicoScenes file"),
        (&ath, "an Atheros CSI Tool log"),
    ] {
        let summary = CaptureSummary::of_path(path, Some(CaptureFormat::Intel5300)).unwrap();
        let why = summary.why_empty(path).expect("nothing read");
        assert!(why.contains(says), "{why}");
    }
    assert!("pico".parse::<CaptureFormat>().is_err());
    for f in CaptureFormat::ALL {
        assert_eq!(f.name().parse::<CaptureFormat>(), Ok(f));
    }
}
