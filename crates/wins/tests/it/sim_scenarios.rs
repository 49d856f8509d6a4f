//! Scenarios are TOML; the built-ins parse, validate and round-trip; bad ones name the field.

use wins::sim::scenario::{BUILT_IN, Scenario, ScenarioError, built_in_toml, printable_toml};

#[test]
fn built_in_scenarios_validate_and_round_trip_through_toml() {
    let names: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
    for required in [
        "paper-circle",
        "paper-circle-3ap",
        "paper-circle-obstacle",
        "figure8-yaw",
        "hover",
        "ceiling-ap",
        "warehouse",
        "warehouse-aisle",
        "three-walls",
        "consumer-two-ap",
        "busy-ap",
        "long-flight",
        "near-walls",
    ] {
        assert!(
            names.contains(&required),
            "{required} missing from {names:?}"
        );
    }
    for (name, text) in BUILT_IN {
        let s = Scenario::from_toml(text, name).unwrap();
        assert_eq!(&s.name, name, "the file's name field matches its key");
        let again = Scenario::from_toml(&s.to_toml().unwrap(), "printed").unwrap();
        assert_eq!(again, s, "{name}");
        // What `--print-scenario` prints: the header comments plus every field, defaults included.
        let printed = printable_toml(name).unwrap();
        assert_eq!(
            Scenario::from_toml(&printed, "printed").unwrap(),
            s,
            "{name}"
        );
        assert!(printed.starts_with("# ") && printed.contains("implementation_snr_db"));
        // Every built-in flight starts on the ground, at rest for at least 2 s, and takes off;
        // every one has a barometer. The one capture on a bench has no take-off.
        let Some(phases) = s.phases.as_ref() else {
            assert_eq!(*name, "static-capture");
            continue;
        };
        assert!(phases.rest_s >= 2.0 && phases.takeoff_s > 0.0, "{name}");
        assert!(s.baro.is_some(), "{name}");
    }
}

#[test]
fn every_built_in_flight_simulates_and_starts_at_rest_on_the_ground() {
    for (name, _) in BUILT_IN {
        let mut s = Scenario::built_in(name).unwrap();
        s.duration_s = s.duration_s.min(30.0);
        let out = wins::sim::simulate(&s, &mut |_| {}).unwrap();
        let Some(phases) = s.phases.as_ref() else {
            // The capture on a bench: nothing moves, from the first sample to the last.
            let first = &out.states[0].1;
            assert!(
                out.states
                    .iter()
                    .all(|(_, b)| (b.p_b_in_w - first.p_b_in_w).norm() < 1e-12)
            );
            continue;
        };
        let ground_m = phases.ground_height_m;
        // Still on the ground for the first 2 s: the truth does not move.
        let first = &out.states[0].1;
        let at_rest = out
            .states
            .iter()
            .take_while(|(t, _)| t.as_secs_f64() <= 2.0);
        for (_, b) in at_rest {
            assert!((b.p_b_in_w - first.p_b_in_w).norm() < 1e-12, "{name}");
            assert!((b.p_b_in_w.z - ground_m).abs() < 1e-12, "{name}");
        }
        for ap in &out.aps {
            assert!(
                ap.received().count() > 0,
                "{name}: {} received nothing",
                ap.config.name
            );
        }
        assert!(!out.baro.is_empty(), "{name}");
    }
}

#[test]
fn the_shipped_files_are_the_compiled_in_ones() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/scenarios");
    for (name, text) in BUILT_IN {
        let on_disk = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        assert_eq!(&on_disk, text);
    }
    let files = std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(
        files,
        BUILT_IN.len(),
        "every file in configs/scenarios is built in"
    );
}

#[test]
fn bad_scenarios_say_what_is_wrong() {
    let base = built_in_toml("paper-circle").unwrap();
    let misspelt = base.replace("duration_s", "durration_s");
    let e = Scenario::from_toml(&misspelt, "edited").unwrap_err();
    assert!(matches!(e, ScenarioError::Parse { .. }), "{e}");
    assert!(e.to_string().contains("durration_s"), "{e}");

    let outside = base.replace(
        "position_m = [1.0, 4.0, 1.5]",
        "position_m = [13.0, 4.0, 1.5]",
    );
    match Scenario::from_toml(&outside, "edited").unwrap_err() {
        ScenarioError::Invalid { source, .. } => assert_eq!(source.field, "aps[0].position_m"),
        e => panic!("{e}"),
    }

    let through_wall = base.replace("radius_m = 2.5", "radius_m = 5.5");
    match Scenario::from_toml(&through_wall, "edited").unwrap_err() {
        ScenarioError::Invalid { source, .. } => {
            assert_eq!(source.field, "trajectory");
            assert!(source.reason.contains("boundary"), "{}", source.reason);
        }
        e => panic!("{e}"),
    }

    assert!(matches!(
        Scenario::built_in("no-such"),
        Err(ScenarioError::Unknown { .. })
    ));
}
