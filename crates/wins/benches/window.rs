//! One sliding-window update of a converged window (`WindowConfig::iterations` Gauss–Newton
//! iterations, one by default: build the normal
//! equations, block Cholesky; then marginalize the leaving frame) at 30 frames (the paper: 37.19
//! ms) and 300 frames, one AP, 50 Hz frames on the paper's circle. Reference in the same run: the same system solved densely (nalgebra Cholesky),
//! so the ratio is machine-independent.
//!
//! `cargo bench -p wins --bench window`

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use divan::Bencher;
use nalgebra::Vector3;
use wins::aoa::steering::aoa_rad;
use wins::fusion::bearing::{Bearing, side_of};
use wins::fusion::paper::window::{SlidingWindow, WindowConfig};
use wins::imu::{ImuBiases, ImuSample, Preintegrator};
use wins::sim::motion::{sample, specific_force_in_b};
use wins::sim::run::world_from_array;
use wins::sim::scenario::Scenario;
use wins::time::Timestamp;

fn main() {
    divan::main();
}

/// A converged window holding `frames` frames (full): 16 s of flight plus the window.
fn window(frames: usize) -> SlidingWindow {
    let sc = Scenario::built_in("paper-circle")
        .expect("built-in")
        .airborne();
    let traj = sc.build_flight();
    let body_from_array = sc.body_from_array();
    let ap = Vector3::from(sc.aps[0].position_m);
    let mut pre = Preintegrator::new(sc.imu.model.noise(), ImuBiases::zero());
    let mut w = SlidingWindow::new(WindowConfig {
        max_frames: frames,
        body_from_array,
        ..WindowConfig::default()
    });
    let first = sample(&traj, &sc.yaw, sc.gravity_m_s2, 0.0);
    for i in 0..(frames + 800) * 4 {
        let t = Timestamp(i as i64 * 5_000_000);
        let s = sample(&traj, &sc.yaw, sc.gravity_m_s2, t.as_secs_f64());
        let imu = ImuSample {
            t,
            gyro_rad_s: s.omega_b_in_b,
            accel_m_s2: specific_force_in_b(&s, sc.gravity_m_s2),
        };
        if i % 4 == 0 {
            let from_prev = (i > 0).then(|| pre.cut(t, &imu).expect("cut"));
            let u = world_from_array(&s, &body_from_array)
                .inverse_transform_point(&ap.into())
                .coords;
            let bearing = Bearing {
                ap: 0,
                aoa_rad: aoa_rad(&u),
                side: side_of(&u),
                sigma_rad: 2f64.to_radians(),
            };
            let rot = first.world_from_body.inverse() * s.world_from_body;
            w.add_frame(t, rot, from_prev, vec![bearing])
                .expect("frame");
            w.solve().expect("solve");
        }
        pre.push(&imu).expect("push");
    }
    assert!(w.converged_at().is_some() && w.len() == frames);
    w
}

#[divan::bench(args = [30, 300])]
fn update(bencher: Bencher, frames: usize) {
    let w = window(frames);
    bencher
        .with_inputs(|| w.clone())
        .bench_local_values(|mut w| {
            w.solve().expect("solve");
            w
        });
}

#[divan::bench(args = [30, 300], sample_count = 10, sample_size = 1)]
fn reference_dense_cholesky(bencher: Bencher, frames: usize) {
    let w = window(frames);
    let (h, b) = w.normal_equations().to_dense();
    bencher.bench_local(|| {
        let c = h.clone().cholesky().expect("PD");
        c.solve(&b)
    });
}
