use super::*;

#[test]
fn the_shipped_live_example_is_valid_and_lists_every_live_setting() {
    let example = Config::from_toml_str(LIVE_EXAMPLE_TOML, "configs/live.toml")
        .expect("the shipped example is valid");
    let mut want = Config::default();
    want.live.rig = "my_rig".into();
    assert_eq!(example, want);
    let file: toml::Table = toml::from_str(LIVE_EXAMPLE_TOML).unwrap();
    let code = toml::Table::try_from(Config::default()).unwrap();
    let keys = |t: &toml::Table| -> Vec<String> {
        t.get("live")
            .and_then(toml::Value::as_table)
            .map(|l| l.keys().cloned().collect())
            .unwrap_or_default()
    };
    assert_eq!(
        keys(&file),
        keys(&code),
        "configs/live.toml lacks or adds keys"
    );
}

#[test]
fn the_shipped_defaults_equal_the_code() {
    let shipped = Config::from_toml_str(DEFAULT_TOML, "configs/default.toml")
        .expect("the shipped defaults are valid");
    assert_eq!(shipped, Config::default());
    // Every key is written out, so the file documents the whole tree.
    let file: toml::Table = toml::from_str(DEFAULT_TOML).unwrap();
    let code = toml::Table::try_from(Config::default()).unwrap();
    assert_eq!(file, code, "configs/default.toml lacks or adds keys");
    assert_eq!(Config::default().validate().ok(), Some(()));
}

#[test]
fn every_problem_is_listed_at_once() {
    let text = "[aoa]\npaoa_half_width_deg = 120.0\n[aoa.music]\naoa_step_deg = 1e-9\n\
                [pipeline]\ngate_rad = 0.1\nmax_misses = \"many\"\n[window]\n\
                max_frames = 0\nbody_from_array = 1\n[extra]\n";
    let Err(ConfigError::Invalid { problems, origin }) = Config::from_toml_str(text, "t.toml")
    else {
        panic!("accepted");
    };
    assert_eq!(origin, "t.toml");
    let keys: Vec<&str> = problems.0.iter().map(|p| p.key.as_str()).collect();
    for want in [
        "extra",
        "pipeline.gate_rad",
        "pipeline.max_misses",
        "window.body_from_array",
        "aoa.music.aoa_step_deg",
        "aoa.paoa_half_width_deg",
        "window.max_frames",
    ] {
        assert!(keys.contains(&want), "{want} missing from {keys:?}");
    }
    assert_eq!(keys.len(), 7, "{problems}");
    assert!(
        problems.to_string().contains("did you mean `gate_deg`"),
        "{problems}"
    );
}

#[test]
fn the_estimator_is_chosen_by_name_and_an_unknown_one_is_refused() {
    use crate::fusion::choice::EstimatorKind;
    assert_eq!(Config::default().estimator, EstimatorKind::Nonlinear);
    let c = Config::from_toml_str("estimator = \"paper\"\n", "t").unwrap();
    assert_eq!(c.estimator, EstimatorKind::Paper);
    let c = Config::from_toml_str("estimator = \"nonlinear\"\n", "t").unwrap();
    assert_eq!(c.estimator, EstimatorKind::Nonlinear);
    // An unknown name is a problem of its key, with the names it could be.
    let Err(ConfigError::Invalid { problems, .. }) =
        Config::from_toml_str("estimator = \"kalman\"\n", "t")
    else {
        panic!("accepted");
    };
    assert_eq!(problems.0[0].key, "estimator", "{problems}");
    assert!(problems.0[0].message.contains("`paper`"), "{problems}");
    let Err(ConfigError::Invalid { problems, .. }) =
        Config::from_toml_str("[eval]\nalign = \"foo\"\n", "t")
    else {
        panic!("accepted");
    };
    assert_eq!(
        problems.to_string(),
        "eval.align: unknown variant `foo`, expected `posyaw` or `se3`"
    );
    // A slip of the keyboard gets the key it meant.
    let Err(ConfigError::Invalid { problems, .. }) =
        Config::from_toml_str("estimater = \"paper\"\n", "t")
    else {
        panic!("accepted");
    };
    assert!(
        problems.to_string().contains("did you mean `estimator`?"),
        "{problems}"
    );
    let Err(ConfigError::Invalid { problems, .. }) =
        Config::from_toml_str("[nonlinear]\nmax_keyframes = 1\n", "t")
    else {
        panic!("accepted");
    };
    assert_eq!(problems.0[0].key, "nonlinear.max_keyframes", "{problems}");
}

#[test]
fn missing_keys_take_the_defaults_and_integers_pass_for_floats() {
    let c = Config::from_toml_str("[pipeline]\ngate_deg = 7\n", "t").unwrap();
    assert_eq!(c.pipeline.gate_deg, 7.0);
    assert_eq!(c.window, WindowConfig::default());
    assert!(matches!(
        Config::from_toml_str("[pipeline", "t"),
        Err(ConfigError::Syntax { .. })
    ));
    // A negative count has the right kind (integer) but not the right type.
    let Err(ConfigError::Invalid { problems, .. }) =
        Config::from_toml_str("[window]\nmax_frames = -3\n", "t")
    else {
        panic!("accepted");
    };
    assert_eq!(problems.0.len(), 1, "{problems}");
}
