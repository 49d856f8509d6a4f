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
