use super::*;
use crate::csi::format::CaptureFormat;

fn seeds(text: &str) -> Vec<u64> {
    Seeds::parse(text).unwrap().as_slice().to_vec()
}

fn reason(text: &str) -> String {
    match Seeds::parse(text) {
        Err(SweepError::Seeds { reason, .. }) => reason,
        other => panic!("{text}: {other:?}"),
    }
}

/// A fresh directory under the temp dir for test `name`.
pub(crate) fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-sweep-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn seed_ranges_are_inclusive_and_lists_sorted() {
    assert_eq!(seeds("1..20").len(), 20);
    assert_eq!(seeds("1..20"), (1..=20).collect::<Vec<_>>());
    assert_eq!(seeds("1..=3"), [1, 2, 3]);
    assert_eq!(seeds("7"), [7]);
    assert_eq!(seeds("9, 1,5"), [1, 5, 9]);
    assert_eq!(seeds("1..3,10,5..6"), [1, 2, 3, 5, 6, 10]);
    assert_eq!(seeds("0..0"), [0]);
    assert_eq!(seeds(&format!("{}", u64::MAX)), [u64::MAX]);
}

#[test]
fn bad_seeds_say_what_is_wrong() {
    assert!(reason("").contains("empty item"));
    assert!(reason("1,,2").contains("empty item"));
    assert!(reason("1,").contains("empty item"));
    assert!(reason("5..1").contains("backwards"));
    assert!(reason("a").contains("not a seed"));
    assert!(reason("1..x").contains("not a seed"));
    assert!(reason("-1").contains("not a seed"));
    assert!(reason("1..3,2").contains("seed 2 is given twice"));
    assert!(reason("0..18446744073709551615").contains("more than"));
    assert!(matches!(Seeds::from_list(vec![]), Err(SweepError::NoSeeds)));
}

#[test]
fn shards_parse_and_partition_the_runs() {
    assert_eq!(Shard::parse("2/8").unwrap(), Shard { index: 2, count: 8 });
    assert_eq!(Shard::parse(" 1 / 1 ").unwrap().to_string(), "1/1");
    for bad in ["0/3", "4/3", "1/0", "3", "a/b", "1/2/3", ""] {
        assert!(
            matches!(Shard::parse(bad), Err(SweepError::Shard { .. })),
            "{bad}"
        );
    }
    for n in 1..6 {
        for i in 0..40 {
            let owners = (1..=n)
                .filter(|&k| Shard { index: k, count: n }.keeps(i))
                .count();
            assert_eq!(owners, 1, "run {i} of {n} shards");
        }
    }
    // The documented rule: shard K of N keeps i % N == K − 1.
    let s = Shard { index: 2, count: 3 };
    let kept: Vec<usize> = (0..9).filter(|&i| s.keeps(i)).collect();
    assert_eq!(kept, [1, 4, 7]);
}

#[test]
fn runs_are_scenario_major_then_seed() {
    let names = ["hover".to_string(), "paper-circle".to_string()];
    let plan = Plan::new(
        &names,
        &[],
        Seeds::parse("3,1,2").unwrap(),
        None,
        None,
        None,
        false,
    )
    .unwrap();
    let runs: Vec<(usize, usize, u64)> = plan
        .runs()
        .iter()
        .map(|r| (r.index, r.scenario, r.seed))
        .collect();
    assert_eq!(
        runs,
        [
            (0, 0, 1),
            (1, 0, 2),
            (2, 0, 3),
            (3, 1, 1),
            (4, 1, 2),
            (5, 1, 3)
        ]
    );
    assert_eq!(plan.scenarios[1].label, "paper-circle");
    assert_eq!(plan.scenarios[1].source, BUILT_IN_SOURCE);
    let s = plan.scenarios[0].for_run(3, Some(21.5));
    assert_eq!((s.seed, s.duration_s), (3, 21.5));
    let record = plan.record(None).unwrap();
    assert_eq!(record.runs, 6);
    assert_eq!(record.run_index("paper-circle", 2), Some(4));
    assert_eq!(record.run_index("paper-circle", 7), None);
    assert_eq!(record.run_index("nope", 1), None);
}

#[test]
fn scenario_files_sit_beside_built_in_names() {
    let dir = temp_dir("plan-files");
    let mut s = Scenario::built_in("hover").unwrap();
    s.description = "my own hover".into();
    std::fs::write(dir.join("my-hover.toml"), s.to_toml().unwrap()).unwrap();
    std::fs::write(dir.join("pipeline.toml"), "[window]\n").unwrap();
    std::fs::write(
        dir.join("plan.toml"),
        "scenarios = [\"hover\", \"my-hover.toml\"]\nseeds = [4, 2]\nduration_s = 30.0\n\
         config = \"pipeline.toml\"\n",
    )
    .unwrap();
    let plan = Plan::from_file(&dir.join("plan.toml")).unwrap();
    assert_eq!(plan.scenarios[1].label, "my-hover");
    assert_eq!(plan.scenarios[1].scenario.description, "my own hover");
    assert!(plan.scenarios[1].source.ends_with("my-hover.toml"));
    assert_eq!(plan.seeds.as_slice(), [2, 4]);
    assert_eq!(plan.duration_s, Some(30.0));
    assert!(
        plan.config_source
            .as_deref()
            .unwrap()
            .ends_with("pipeline.toml")
    );

    // The same file given as a path from here.
    let path = dir.join("my-hover.toml").display().to_string();
    let direct = SweepScenario::resolve(&path, None).unwrap();
    assert_eq!(direct.scenario, plan.scenarios[1].scenario);

    let text = |body: &str| {
        std::fs::write(dir.join("bad.toml"), body).unwrap();
        Plan::from_file(&dir.join("bad.toml"))
            .unwrap_err()
            .to_string()
    };
    assert!(text("scenarios = [\"hover\"]\n").contains("seeds"));
    assert!(text("scenarios = [\"hover\"]\nseeds = \"1..2\"\nspeed = 3\n").contains("speed"));
    assert!(text("scenarios = [\"nope.toml\"]\nseeds = \"1\"\n").contains("nope.toml"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_plans_card_flies_every_run_with_that_card_and_an_unknown_one_is_refused() {
    let dir = temp_dir("plan-card");
    std::fs::write(
        dir.join("plan.toml"),
        "scenarios = [\"paper-circle\"]\nfamilies = [\"room\"]\nseeds = \"1..2\"\n\
         card = \"feitcsi\"\n",
    )
    .unwrap();
    let plan = Plan::from_file(&dir.join("plan.toml")).unwrap();
    assert_eq!(plan.card, Some(CaptureFormat::FeitCsi));
    for run in plan.runs() {
        let flight = plan.flight(run).unwrap().scenario;
        assert_eq!(flight.radio.card, CaptureFormat::FeitCsi);
        // The AX210 has two chains: its rig keeps two antennas.
        assert_eq!(flight.array.geometry.num_antennas, 2);
        flight.validate().unwrap();
    }
    std::fs::write(
        dir.join("plan.toml"),
        "scenarios = [\"paper-circle\"]\nseeds = \"1\"\ncard = \"picoscenes\"\n",
    )
    .unwrap();
    let e = Plan::from_file(&dir.join("plan.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("card = picoscenes") && e.contains("(not picoscenes)"),
        "{e}"
    );
    std::fs::write(
        dir.join("plan.toml"),
        "scenarios = [\"paper-circle\"]\nseeds = \"1\"\ncard = \"broadcom\"\n",
    )
    .unwrap();
    let e = Plan::from_file(&dir.join("plan.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown CSI format \"broadcom\""), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn plans_that_cannot_run_are_refused_before_any_run() {
    let new = |names: &[&str], duration_s: Option<f64>| {
        let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        Plan::new(
            &names,
            &[],
            Seeds::parse("1").unwrap(),
            duration_s,
            None,
            None,
            false,
        )
    };
    assert!(matches!(new(&[], None), Err(SweepError::NoScenarios)));
    let unknown = new(&["paper-square"], None).unwrap_err().to_string();
    assert!(
        unknown.contains("paper-circle"),
        "lists the built-in names: {unknown}"
    );
    assert!(matches!(
        new(&["hover", "hover"], None),
        Err(SweepError::DuplicateScenario { .. })
    ));
    for d in [-1.0, 0.0, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(new(&["hover"], Some(d)), Err(SweepError::Duration { .. })),
            "{d}"
        );
    }
    let two = ["hover".to_string(), "paper-circle".to_string()];
    let half = format!("1..{}", MAX_RUNS / 2 + 1);
    assert!(matches!(
        Plan::new(
            &two,
            &[],
            Seeds::parse(&half).unwrap(),
            None,
            None,
            None,
            false
        ),
        Err(SweepError::TooManyRuns { .. })
    ));
    let names = vec!["hover".to_string()];
    let missing = Plan::new(
        &names,
        &[],
        Seeds::parse("1").unwrap(),
        None,
        Some(Path::new("/nonexistent/pipeline.toml")),
        None,
        false,
    );
    assert!(matches!(missing, Err(SweepError::Config(_))));
}
