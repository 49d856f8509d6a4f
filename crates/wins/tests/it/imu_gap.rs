//! The estimator across a gap in the IMU stream: no pose from inside it, counted, and a restart
//! after it.

use wins::Config;
use wins::sim::{Scenario, simulate, write_dataset};

use super::pipeline_run::temp_dir;

#[test]
fn no_pose_comes_from_inside_an_imu_gap_and_the_estimate_starts_again_after_it() {
    let dir = temp_dir("imu-gap-run");
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.seed = 2;
    s.duration_s = 40.0;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(&dir, &s, &out).unwrap();
    // Two seconds of IMU lost in the middle of the circle.
    let (gap_from_ns, gap_to_ns) = (20_000_000_000_i64, 22_000_000_000_i64);
    let path = dir.join("imu.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.starts_with('#')
                || l.split(',')
                    .next()
                    .and_then(|t| t.parse::<i64>().ok())
                    .is_none_or(|t| t <= gap_from_ns || t >= gap_to_ns)
        })
        .collect();
    std::fs::write(&path, kept.join("\n") + "\n").unwrap();

    let run = wins::run_dataset(&dir, &Config::default()).unwrap();
    assert_eq!(run.wins.imu_gaps, 1, "{:?}", run.wins);
    assert!(run.wins.frames_in_imu_gap >= 50, "{:?}", run.wins);
    assert!(run.wins.restarts >= 1, "{:?}", run.wins);
    let inside: Vec<f64> = run
        .frames
        .iter()
        .filter(|f| f.t.0 > gap_from_ns && f.t.0 < gap_to_ns)
        .map(|f| f.t.0 as f64 * 1e-9)
        .collect();
    assert!(inside.is_empty(), "poses inside the gap at {inside:?} s");
    assert!(run.converged_at.is_some_and(|t| t.0 < gap_from_ns));
    // The run says so.
    let w = run.warnings.join("\n");
    assert!(w.contains("IMU gap"), "{w}");
}
