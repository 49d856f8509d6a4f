//! A drawn flight flown: its scenario file flies the same dataset, byte for byte.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::*;
use crate::sim::{simulate, write_dataset};

/// Flight length of the flights simulated here, s: the shortest a ground start allows.
const DURATION_S: f64 = 20.0;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-family-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Every file under `dir`, by path relative to it.
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                pending.push(path);
            } else {
                let rel = path.strip_prefix(dir).unwrap().to_path_buf();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

#[test]
fn a_draws_scenario_file_flies_the_same_dataset() {
    // A lab-calibrated flight, so the calibration flight is in the round trip too.
    for family in FAMILIES {
        let draw = (1..)
            .map(|seed| family.draw(seed).unwrap())
            .find(|d| d.flight.calibration == Calibration::Lab)
            .unwrap()
            .with_overrides(Some(DURATION_S), false)
            .unwrap();
        let root = temp_dir(family.name());
        let (drawn, again) = (root.join("drawn"), root.join("again"));
        let out = simulate(&draw.scenario, &mut |_| {}).unwrap();
        write_dataset(&drawn, &draw.scenario, &out).unwrap();
        let written = draw.write_files(&drawn).unwrap();
        assert_eq!(written, [drawn.join(SCENARIO_FILE), drawn.join(DRAWN_FILE)]);

        let scenario = Scenario::from_file(&drawn.join(SCENARIO_FILE)).unwrap();
        assert_eq!(scenario, draw.scenario);
        let out = simulate(&scenario, &mut |_| {}).unwrap();
        write_dataset(&again, &scenario, &out).unwrap();

        let mut first = files(&drawn);
        for extra in [SCENARIO_FILE, DRAWN_FILE] {
            assert!(first.remove(Path::new(extra)).is_some());
        }
        let second = files(&again);
        assert_eq!(
            first.keys().collect::<Vec<_>>(),
            second.keys().collect::<Vec<_>>()
        );
        assert!(first.contains_key(Path::new("calibration.toml")));
        for (path, bytes) in &first {
            assert!(&second[path] == bytes, "{} differs", path.display());
        }
        let labels: DrawnFlight =
            toml::from_str(&std::fs::read_to_string(drawn.join(DRAWN_FILE)).unwrap()).unwrap();
        assert_eq!(labels, draw.flight);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
