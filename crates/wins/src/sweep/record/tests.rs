use super::*;
use crate::sweep::{Plan, Seeds};

fn plan(names: &[&str], seeds: &str) -> Plan {
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    Plan::new(
        &names,
        &[],
        Seeds::parse(seeds).unwrap(),
        None,
        None,
        None,
        false,
    )
    .unwrap()
}

#[test]
fn the_identity_ignores_the_shard_and_the_sources_only() {
    let p = plan(&["hover", "paper-circle"], "1..4");
    let whole = p.record(None).unwrap();
    let shard = p.record(Some(Shard { index: 2, count: 3 })).unwrap();
    assert_eq!(whole.plan_id, shard.plan_id);
    assert_eq!(whole.plan_id.len(), 16);
    assert!(whole.differences(&shard).is_empty());
    let mut moved = whole.clone();
    moved.scenarios[0].source = "elsewhere/hover.toml".into();
    moved.config_source = Some("other.toml".into());
    assert!(whole.differences(&moved).is_empty());

    let other_seeds = plan(&["hover", "paper-circle"], "1..5")
        .record(None)
        .unwrap();
    assert_ne!(whole.plan_id, other_seeds.plan_id);
    let d = whole.differences(&other_seeds).join("; ");
    assert!(d.contains("seeds 1..4 vs 1..5"), "{d}");

    let other_order = plan(&["paper-circle", "hover"], "1..4")
        .record(None)
        .unwrap();
    assert!(whole.differences(&other_order)[0].starts_with("scenarios"));

    let mut edited = whole.clone();
    edited.scenarios[1].toml.push_str("\n# edited\n");
    let d = whole.differences(&edited).join("; ");
    assert!(d.contains("\"paper-circle\" has different contents"), "{d}");

    let mut p2 = plan(&["hover", "paper-circle"], "1..4");
    p2.config.window.max_frames += 1;
    let d = whole.differences(&p2.record(None).unwrap()).join("; ");
    assert!(d.contains("settings"), "{d}");
    p2.config = crate::Config::default();
    p2.duration_s = Some(30.0);
    let d = whole.differences(&p2.record(None).unwrap()).join("; ");
    assert!(d.contains("duration_s"), "{d}");
}

#[test]
fn plan_json_reads_back_as_written() {
    let record = plan(&["hover"], "3,9")
        .record(Some(Shard { index: 1, count: 2 }))
        .unwrap();
    let text = serde_json::to_string_pretty(&record).unwrap();
    let back: PlanRecord = serde_json::from_str(&text).unwrap();
    assert_eq!(back, record);
    // The scenario's TOML is a scenario file that gives the same flight.
    let s = crate::sim::Scenario::from_toml(&back.scenarios[0].toml, "plan.json").unwrap();
    assert_eq!(s, crate::sim::Scenario::built_in("hover").unwrap());
    assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
    assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
}
