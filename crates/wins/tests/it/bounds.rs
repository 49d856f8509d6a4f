//! Settings that size an allocation are bounded, and the limit is in the error: the MUSIC grid,
//! a simulation's samples and packets, a dataset's files that are not regular files.

use std::path::PathBuf;

use wins::dataset::{Dataset, DatasetError};
use wins::sim::{Scenario, simulate, write_dataset};
use wins::{Config, ConfigError};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wins-bounds-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn a_music_grid_of_more_than_a_million_points_is_refused_with_its_size() {
    let text = "[aoa.music]\naoa_step_deg = 0.05\ntof_step_s = 5e-10\n";
    let Err(ConfigError::Invalid { problems, .. }) = Config::from_toml_str(text, "t") else {
        panic!("accepted");
    };
    assert_eq!(problems.0.len(), 1, "{problems}");
    assert_eq!(problems.0[0].key, "aoa.music.aoa_step_deg");
    let message = &problems.0[0].message;
    assert!(
        message.contains("5.729191e6 grid points (3601 AoA × 1591 ToF)"),
        "{message}"
    );
    assert!(message.contains("at most 1e6"), "{message}");
    // The finest step on one axis alone is fine.
    assert!(Config::from_toml_str("[aoa.music]\naoa_step_deg = 0.05\n", "t").is_ok());
    // A step below its range is refused by its range, not by the grid.
    let Err(ConfigError::Invalid { problems, .. }) =
        Config::from_toml_str("[aoa.music]\naoa_step_deg = 1e-9\n", "t")
    else {
        panic!("accepted");
    };
    assert!(
        problems.to_string().contains("is not in [0.05, 30]"),
        "{problems}"
    );
}

#[test]
fn a_simulation_too_long_for_its_rates_is_refused_with_the_limit() {
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.duration_s = 3600.0;
    s.imu.rate_hz = 10_000.0;
    let e = s.validate().unwrap_err();
    assert_eq!(e.field, "imu.rate_hz");
    assert!(
        e.reason.contains("3.6e7 IMU samples; at most 1.44e6"),
        "{e}"
    );
    s.imu.rate_hz = 200.0;
    s.radio.packet_rate_hz = 2000.0;
    let e = s.validate().unwrap_err();
    assert_eq!(e.field, "radio.packet_rate_hz");
    assert!(
        e.reason.contains("7.2e6 packet slots; at most 720000"),
        "{e}"
    );
    // An hour at the shipped rates is within them.
    s.radio.packet_rate_hz = 50.0;
    assert!(s.validate().is_ok());
}

#[test]
fn a_log_that_is_not_a_regular_file_is_refused_at_once() {
    let dir = scratch("devzero");
    let mut s = Scenario::built_in("hover").unwrap().airborne();
    s.duration_s = 2.0;
    write_dataset(&dir, &s, &simulate(&s, &mut |_| {}).unwrap()).unwrap();
    let manifest = dir.join("dataset.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let log = format!("log = \"{}.dat\"", s.aps[0].name);
    assert!(text.contains(&log), "{text}");
    for (target, name) in [("/dev/zero", "a device"), (".", "a folder")] {
        let spoiled = text.replace(&log, &format!("log = {target:?}"));
        std::fs::write(&manifest, spoiled).unwrap();
        let started = std::time::Instant::now();
        let e = Dataset::load(&dir).unwrap_err();
        assert!(matches!(e, DatasetError::Log(_)), "{name}: {e:?}");
        let chain = format!(
            "{e}: {}",
            std::error::Error::source(&e).map_or(String::new(), |c| c.to_string())
        );
        assert!(chain.contains("not a regular file"), "{name}: {chain}");
        assert!(
            started.elapsed().as_secs() < 5,
            "{name}: took {:?}",
            started.elapsed()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
