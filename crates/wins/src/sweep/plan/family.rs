//! The families of a plan: checking one, and what each of its runs flies.

use super::{FAMILY_SOURCE, SweepScenario};
use crate::sim::Scenario;
use crate::sim::family::{DrawnFlight, Family};
use crate::sweep::SweepError;

/// What one run flies.
#[derive(Clone, Debug, PartialEq)]
pub struct RunFlight {
    /// The scenario, its seed and duration set.
    pub scenario: Scenario,
    /// For a family's run, what was drawn (as flown).
    pub drawn: Option<DrawnFlight>,
}

impl SweepScenario {
    /// The family `name` ([`Family::from_name`]: an unknown name lists the families), checked
    /// by drawing the flight of `first_seed` with the plan's duration and start; a duration
    /// override must leave a flight that starts on the ground its phases.
    pub fn from_family(
        name: &str,
        first_seed: u64,
        duration_s: Option<f64>,
        airborne: bool,
    ) -> Result<Self, SweepError> {
        let family = Family::from_name(name)?;
        let label = family.name().to_string();
        if let Some(d) = duration_s.filter(|&d| !airborne && d < family.min_duration_s()) {
            return Err(SweepError::Duration {
                label,
                duration_s: d,
                source: crate::sim::ConfigError::new(
                    "duration_s",
                    format!(
                        "a flight of the family that starts on the ground needs at least {} s \
                         (rest, take-off, landing, final rest, the mission's ramps)",
                        family.min_duration_s()
                    ),
                ),
            });
        }
        let draw = family
            .draw(first_seed)?
            .with_overrides(duration_s, airborne)?;
        Ok(Self {
            label,
            source: FAMILY_SOURCE.to_string(),
            scenario: draw.scenario,
            family: Some(family),
        })
    }

    /// What the run of `seed` flies: the scenario with that seed, the plan's duration (if any)
    /// and start; for a family, the flight drawn from `seed` with those overrides.
    pub fn flight(
        &self,
        seed: u64,
        duration_s: Option<f64>,
        airborne: bool,
    ) -> Result<RunFlight, SweepError> {
        Ok(match self.family {
            Some(family) => {
                let draw = family.draw(seed)?.with_overrides(duration_s, airborne)?;
                RunFlight {
                    scenario: draw.scenario,
                    drawn: Some(draw.flight),
                }
            }
            None => {
                let scenario = self.for_run(seed, duration_s);
                RunFlight {
                    scenario: if airborne {
                        scenario.airborne()
                    } else {
                        scenario
                    },
                    drawn: None,
                }
            }
        })
    }
}
