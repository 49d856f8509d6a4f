//! The draws: every range covered to its ends over 1000 seeds, every category drawn, every
//! flight valid and inside its room, the same seed the same flight.

use std::collections::BTreeSet;

use super::rig::{AIRBORNE_SHARE, DURATION_S, LOSS, PACKET_RATE_HZ, VIBRATION_M_S2};
use super::*;
use crate::sim::lab_calibration::capture_scenario;

const SEEDS: u64 = 1000;
/// Sampling step of the check that the flight stays in its room, s.
const FIT_STEP_S: f64 = 0.25;
/// The body keeps at least this far from the walls and the ceiling, m.
const FIT_MARGIN_M: f64 = 0.3;

/// Values of one quantity over the draws.
#[derive(Default)]
struct Seen(Vec<f64>);

impl Seen {
    /// Every value in `[lo, hi]`, and some in the lowest and in the highest tenth.
    fn covers(&self, what: &str, (lo, hi): (f64, f64)) {
        let tenth = (hi - lo) / 10.0;
        assert!(
            self.0.iter().all(|&x| (lo..=hi).contains(&x)),
            "{what}: a value outside [{lo}, {hi}]: {:?}",
            self.0.iter().find(|&&x| !(lo..=hi).contains(&x))
        );
        assert!(
            self.0.iter().any(|&x| x <= lo + tenth),
            "{what}: low tenth missed"
        );
        assert!(
            self.0.iter().any(|&x| x >= hi - tenth),
            "{what}: high tenth missed"
        );
    }
}

/// What a family's draws must show.
struct Expected {
    size_m: [(f64, f64); 3],
    aps: (usize, usize),
    obstacles: (usize, usize),
    speed_m_s: (f64, f64),
}

/// Draws `SEEDS` flights and checks each (valid, in its room, its calibration flight valid) and
/// all of them together (ranges, categories, the airborne share).
fn check_family(family: Family, expected: &Expected) -> Vec<Draw> {
    let mut draws = Vec::new();
    let mut size: [Seen; 3] = Default::default();
    let (mut speed, mut rate, mut loss, mut duration, mut vibration): (
        Seen,
        Seen,
        Seen,
        Seen,
        Seen,
    ) = Default::default();
    let mut categories: BTreeSet<String> = BTreeSet::new();
    let mut airborne = 0;
    for seed in 1..=SEEDS {
        let draw = family
            .draw(seed)
            .unwrap_or_else(|e| panic!("{} seed {seed}: {e}", family.name()));
        let (sc, f) = (&draw.scenario, &draw.flight);
        assert_eq!(f, &DrawnFlight::of(family, seed, sc));
        assert_eq!((f.family, f.seed, sc.seed), (family, seed, seed));
        fits_room(sc);
        if sc.radio.lab_calibration {
            capture_scenario(sc)
                .unwrap()
                .validate()
                .unwrap_or_else(|e| {
                    panic!("{} seed {seed}: calibration flight: {e}", family.name())
                });
        }
        for (seen, &v) in size.iter_mut().zip(&sc.room.size_m) {
            seen.0.push(v);
        }
        speed.0.push(f.speed_m_s);
        rate.0.push(f.packet_rate_hz);
        loss.0.push(f.loss_probability);
        duration.0.push(f.duration_s);
        vibration.0.push(f.vibration_m_s2);
        let model = sc
            .imu
            .vibration_model()
            .expect("every drawn flight vibrates");
        assert_eq!(model.accel_rms_m_s2, f.vibration_m_s2);
        assert!(
            (0.005..=0.03).contains(&model.gyro_rms_rad_s),
            "gyro vibration {} rad/s",
            model.gyro_rms_rad_s
        );
        airborne += usize::from(f.start == Start::Air);
        assert_eq!(f.start == Start::Ground, sc.phases.is_some());
        for (k, v) in f.labels() {
            if [
                "aps",
                "imu",
                "bandwidth",
                "start",
                "calibration",
                "trajectory",
                "yaw",
                "obstacles",
            ]
            .contains(&k)
            {
                categories.insert(format!("{k}={v}"));
            }
        }
        draws.push(draw);
    }
    for (k, s) in size.iter().enumerate() {
        s.covers(&format!("room size axis {k}"), expected.size_m[k]);
    }
    speed.covers("speed", expected.speed_m_s);
    rate.covers("packet rate", PACKET_RATE_HZ);
    loss.covers("loss", LOSS);
    duration.covers("duration", DURATION_S);
    vibration.covers("vibration", VIBRATION_M_S2);
    let share = airborne as f64 / SEEDS as f64;
    assert!(
        (share - AIRBORNE_SHARE).abs() < 0.03,
        "{share} of the flights start in the air"
    );
    let mut wanted: Vec<String> = [
        "imu=tactical",
        "imu=consumer",
        "bandwidth=ht20",
        "bandwidth=ht40",
        "start=ground",
        "start=air",
        "calibration=lab",
        "calibration=restart",
        "calibration=none",
        "trajectory=circle",
        "trajectory=figure-eight",
        "trajectory=random-smooth",
        "trajectory=waypoints",
        "yaw=fixed",
        "yaw=toward-point",
        "yaw=tangent",
    ]
    .map(str::to_string)
    .to_vec();
    wanted.extend((expected.aps.0..=expected.aps.1).map(|n| format!("aps={n}")));
    wanted.extend((expected.obstacles.0..=expected.obstacles.1).map(|n| format!("obstacles={n}")));
    let wanted: BTreeSet<String> = wanted.into_iter().collect();
    let other: BTreeSet<&String> = categories.difference(&wanted).collect();
    assert!(other.is_empty(), "values outside the family: {other:?}");
    let missed: BTreeSet<&String> = wanted.difference(&categories).collect();
    assert!(missed.is_empty(), "never drawn: {missed:?}");
    draws
}

/// The body stays inside the room with a margin, above the floor and under the ceiling, all
/// flight long.
fn fits_room(sc: &Scenario) {
    let flight = sc.build_flight();
    let size = sc.room.size_m;
    let steps = (sc.duration_s / FIT_STEP_S).ceil() as usize;
    for i in 0..=steps {
        let t_s = (i as f64 * FIT_STEP_S).min(sc.duration_s);
        let p = flight.at(t_s).translation.p_b_in_w;
        let inside = (0..2).all(|k| p[k] >= FIT_MARGIN_M && p[k] <= size[k] - FIT_MARGIN_M)
            && p.z >= 0.05
            && p.z <= size[2] - FIT_MARGIN_M;
        assert!(
            inside,
            "{}: the body at {p:?} at t = {t_s} s, room {size:?}",
            sc.name
        );
    }
}

#[test]
fn room_draws_cover_their_ranges_and_fit_their_rooms() {
    let draws = check_family(
        Family::Room,
        &Expected {
            size_m: room::SIZE_M,
            aps: room::APS,
            obstacles: room::BOARDS,
            speed_m_s: room::LIMITS.speed_m_s,
        },
    );
    let (mut on_ceiling, mut on_walls) = (0, 0);
    for d in &draws {
        let [x, y, h] = d.scenario.room.size_m;
        for ap in &d.scenario.aps {
            let [ax, ay, az] = ap.position_m;
            if [ax, x - ax, ay, y - ay].iter().any(|&g| g < 0.1) {
                on_walls += 1;
            } else {
                let drop = h - az;
                assert!(
                    (room::CEILING_AP_DROP_M.0 - 1e-9..=room::CEILING_AP_DROP_M.1 + 1e-9)
                        .contains(&drop),
                    "{}: AP {} {drop} m under the ceiling",
                    d.scenario.name,
                    ap.name
                );
                on_ceiling += 1;
            }
        }
    }
    assert!(
        on_ceiling > 100 && on_walls > 300,
        "{on_ceiling} on ceilings, {on_walls} on walls"
    );
}

#[test]
fn hall_draws_cover_their_ranges_and_fit_their_halls() {
    let draws = check_family(
        Family::Hall,
        &Expected {
            size_m: hall::SIZE_M,
            aps: hall::APS,
            obstacles: (1, 3),
            speed_m_s: hall::LIMITS.speed_m_s,
        },
    );
    let mut heights = Seen::default();
    for d in &draws {
        heights
            .0
            .extend(d.scenario.aps.iter().map(|a| a.position_m[2]));
        for ap in &d.scenario.aps {
            assert!(ap.position_m[2] <= d.scenario.room.size_m[2] - 0.3 + 1e-9);
        }
    }
    heights.covers("AP height", hall::AP_Z_M);
}

#[test]
fn a_seed_draws_one_flight() {
    for family in FAMILIES {
        for seed in [0, 1, 2, 77, u64::MAX] {
            let a = family.draw(seed).unwrap();
            let b = family.draw(seed).unwrap();
            assert_eq!(a.scenario_toml().unwrap(), b.scenario_toml().unwrap());
            assert_eq!(a, b);
            // What the file says is what was drawn, to the bit.
            let back = Scenario::from_toml(&a.scenario_toml().unwrap(), "draw").unwrap();
            assert_eq!(back, a.scenario);
            let labels: DrawnFlight = toml::from_str(&toml::to_string(&a.flight).unwrap()).unwrap();
            assert_eq!(labels, a.flight);
        }
        let one = family.draw(1).unwrap().scenario.to_toml().unwrap();
        let two = family.draw(2).unwrap().scenario.to_toml().unwrap();
        assert_ne!(one, two);
    }
}

/// A fixed seed's room, pinned: a change to the draws shows here (and should bump
/// [`GENERATOR_VERSION`]).
#[test]
fn the_draw_of_a_seed_is_pinned() {
    let d = Family::Room.draw(7).unwrap();
    let sc = &d.scenario;
    assert_eq!(sc.room.size_m, [11.4, 7.0, 3.4]);
    let aps: Vec<[f64; 3]> = sc.aps.iter().map(|a| a.position_m).collect();
    assert_eq!(
        aps,
        [[11.35, 2.96, 2.05], [2.83, 5.7, 3.34], [6.44, 0.05, 2.04]]
    );
    assert_eq!(
        sc.trajectory,
        crate::sim::trajectory::TrajectoryConfig::Waypoints {
            points_m: vec![
                [8.71, 5.15, 0.7],
                [8.9, 1.88, 1.29],
                [5.97, 1.35, 0.6],
                [2.98, 1.73, 1.08],
                [2.72, 5.22, 0.65]
            ],
            speed_m_s: 0.87,
            corner_s: 2.0,
        }
    );
    assert_eq!(
        toml::to_string(&d.flight).unwrap(),
        "family = \"room\"\nseed = 7\naps = 3\nimu = \"consumer\"\npacket_rate_hz = 40.0\n\
         loss_probability = 0.142\nbandwidth = \"ht40\"\nstart = \"ground\"\n\
         calibration = \"none\"\ntrajectory = \"waypoints\"\nyaw = \"tangent\"\n\
         speed_m_s = 0.87\nduration_s = 478.0\nobstacles = 1\nvibration_m_s2 = 0.85\n"
    );
}

#[test]
fn overrides_show_in_the_labels() {
    let draw = (1..)
        .map(|seed| Family::Room.draw(seed).unwrap())
        .find(|d| d.flight.start == Start::Ground)
        .unwrap();
    let short = draw.clone().with_overrides(Some(25.0), true).unwrap();
    assert_eq!(short.flight.duration_s, 25.0);
    assert_eq!(short.flight.start, Start::Air);
    assert!(short.scenario.phases.is_none());
    let too_short = draw.with_overrides(Some(Family::Room.min_duration_s() - 1.0), false);
    assert!(matches!(too_short, Err(FamilyError::Invalid { .. })));
}

#[test]
fn an_unknown_family_is_refused_with_the_known_ones() {
    let e = Family::from_name("garage").unwrap_err().to_string();
    assert!(
        e.contains("garage") && e.contains("room") && e.contains("hall"),
        "{e}"
    );
    for f in FAMILIES {
        assert_eq!(Family::from_name(f.name()).unwrap(), f);
        assert!(f.plan_toml().contains(f.name()));
    }
}

#[test]
fn breakdowns_bin_numbers_and_keep_categories() {
    let rate = BREAKDOWNS
        .iter()
        .find(|b| b.label == "packet_rate_hz")
        .unwrap();
    assert_eq!(rate.group("10"), Some((0, "10–25".to_string())));
    assert_eq!(rate.group("49.5"), Some((1, "25–50".to_string())));
    assert_eq!(rate.group("100"), Some((2, "50–100".to_string())));
    assert_eq!(rate.group("101"), None);
    assert_eq!(rate.group(""), None);
    let imu = BREAKDOWNS.iter().find(|b| b.label == "imu").unwrap();
    assert_eq!(imu.group("consumer"), Some((0, "consumer".to_string())));
    let labels = Family::Room.draw(3).unwrap().flight.labels();
    let labels: Vec<&str> = labels.iter().map(|l| l.0).collect();
    assert!(BREAKDOWNS.iter().all(|b| labels.contains(&b.label)));
}
