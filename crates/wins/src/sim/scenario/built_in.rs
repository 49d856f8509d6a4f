//! The built-in scenarios, compiled in from `configs/scenarios/`.

use super::{Scenario, ScenarioError};

/// The built-in scenarios: (name, TOML).
pub const BUILT_IN: &[(&str, &str)] = &[
    (
        "paper-circle",
        include_str!("../../../../../configs/scenarios/paper-circle.toml"),
    ),
    (
        "paper-circle-restart",
        include_str!("../../../../../configs/scenarios/paper-circle-restart.toml"),
    ),
    (
        "paper-circle-uncalibrated",
        include_str!("../../../../../configs/scenarios/paper-circle-uncalibrated.toml"),
    ),
    (
        "paper-circle-3ap",
        include_str!("../../../../../configs/scenarios/paper-circle-3ap.toml"),
    ),
    (
        "paper-circle-obstacle",
        include_str!("../../../../../configs/scenarios/paper-circle-obstacle.toml"),
    ),
    (
        "figure8-yaw",
        include_str!("../../../../../configs/scenarios/figure8-yaw.toml"),
    ),
    (
        "hover",
        include_str!("../../../../../configs/scenarios/hover.toml"),
    ),
    (
        "random-flight",
        include_str!("../../../../../configs/scenarios/random-flight.toml"),
    ),
    (
        "ceiling-ap",
        include_str!("../../../../../configs/scenarios/ceiling-ap.toml"),
    ),
    (
        "warehouse",
        include_str!("../../../../../configs/scenarios/warehouse.toml"),
    ),
    (
        "warehouse-aisle",
        include_str!("../../../../../configs/scenarios/warehouse-aisle.toml"),
    ),
    (
        "three-walls",
        include_str!("../../../../../configs/scenarios/three-walls.toml"),
    ),
    (
        "consumer-two-ap",
        include_str!("../../../../../configs/scenarios/consumer-two-ap.toml"),
    ),
    (
        "busy-ap",
        include_str!("../../../../../configs/scenarios/busy-ap.toml"),
    ),
    (
        "long-flight",
        include_str!("../../../../../configs/scenarios/long-flight.toml"),
    ),
    (
        "near-walls",
        include_str!("../../../../../configs/scenarios/near-walls.toml"),
    ),
    (
        "static-capture",
        include_str!("../../../../../configs/scenarios/static-capture.toml"),
    ),
];

/// Built-in scenario `name` as a TOML document to edit: the file's own comment header, then every
/// field with its value, defaults included (what `wins simulate --print-scenario` prints).
pub fn printable_toml(name: &str) -> Result<String, ScenarioError> {
    let text = built_in_toml(name)?;
    let scenario = Scenario::built_in(name)?;
    let mut out: String = text
        .lines()
        .take_while(|l| l.starts_with('#'))
        .map(|l| format!("{l}\n"))
        .collect();
    out.push_str("#\n# Every field with its value, defaults included; units are in the names.\n\n");
    out.push_str(&scenario.to_toml()?);
    Ok(out)
}

/// The TOML text of built-in scenario `name`.
pub fn built_in_toml(name: &str) -> Result<&'static str, ScenarioError> {
    BUILT_IN
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| ScenarioError::Unknown {
            name: name.to_string(),
            known: BUILT_IN
                .iter()
                .map(|(n, _)| *n)
                .collect::<Vec<_>>()
                .join(", "),
        })
}
