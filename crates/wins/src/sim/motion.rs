//! Quadrotor body motion by differential flatness: attitude, exact angular rate, specific force.
//!
//! A quadrotor's thrust is along its body z axis, so the attitude follows from the acceleration
//! and the yaw. With world `w` z up and gravity `g > 0` pointing down:
//!
//! ```text
//! t   = a + g e_z                       thrust direction (per unit mass)
//! z_b = t / |t|
//! y_c = (−sin ψ, cos ψ, 0)              perpendicular of the commanded heading
//! x_b = (y_c × z_b) / |y_c × z_b|
//! y_b = z_b × x_b
//! R_w_b = [x_b y_b z_b]                 world_from_body
//! ```
//!
//! This is the Z-Y-X (yaw-pitch-roll) form of Faessler, Franchi & Scaramuzza 2018 ("Differential
//! flatness of quadrotor dynamics subject to rotor drag", eqns 18–20): x_b projected onto the
//! horizontal points exactly along ψ, so "toward a point" really faces the point. It differs from
//! Mellinger & Kumar 2011 (y_b = normalize(z_b × x_c), x_c = (cos ψ, sin ψ, 0), the Z-X-Y form) at
//! second order in the tilt; that form is our fallback at its singularity.
//!
//! The angular rate is exact, not differenced: every column is differentiated analytically with
//! `d/dt (u/|u|) = (u̇ − n (n·u̇)) / |u|`, `ṫ = j` (jerk), `ẏ_c = −ψ̇ (cos ψ, sin ψ, 0)`, and
//! `[ω_b]× = R_w_bᵀ Ṙ_w_b` gives `ω_x = z_b·ẏ_b`, `ω_y = x_b·ż_b`, `ω_z = y_b·ẋ_b`.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::flight::Flight;
use super::trajectory::Translation;
use super::yaw::YawConfig;

pub use crate::imu::STANDARD_GRAVITY_M_S2;

/// Below this norm a normalised direction is undefined and a fallback is used (see
/// [`body_state`]).
const DEGENERATE_NORM: f64 = 1e-9;

/// Full body state at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// Time since the start of the flight, s.
    pub t_s: f64,
    /// Position of the body origin in `w`, m.
    pub p_b_in_w: Vector3<f64>,
    /// Velocity of the body origin in `w`, m/s.
    pub v_b_in_w: Vector3<f64>,
    /// Acceleration of the body origin in `w`, m/s².
    pub a_b_in_w: Vector3<f64>,
    /// Attitude `R_w_b`: maps body-frame vectors into the world frame.
    pub world_from_body: UnitQuaternion<f64>,
    /// Angular rate of `b` relative to `w`, expressed in `b` (what a perfect gyro reads), rad/s.
    pub omega_b_in_b: Vector3<f64>,
}

/// `u/|u|` and its time derivative `(u̇ − n (n·u̇)) / |u|`; `None` when `|u| < 1e-9`.
fn normalize_with_rate(
    u: Vector3<f64>,
    u_dot: Vector3<f64>,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let norm = u.norm();
    if norm < DEGENERATE_NORM {
        return None;
    }
    let n = u / norm;
    Some((n, (u_dot - n * n.dot(&u_dot)) / norm))
}

/// Body attitude and angular rate of a quadrotor flying `tr` with yaw `yaw_rad` (rate
/// `yaw_rate_rad_s`) under gravity `gravity_m_s2` (> 0, pointing along −z of `w`), by
/// differential flatness in Z-Y-X form (Faessler et al. 2018 eqns 18–20; see the module doc).
///
/// Assumes the thrust `t = a + g e_z` does not vanish, which holds whenever `|a| < g` (then
/// `|t| ≥ g − |a| > 0`, and the tilt stays below 90°); a scenario checks `|a| < 0.9 g` every
/// 50 ms of its flight ([`super::Scenario::validate`]). It never panics on degenerate input, and
/// falls back deterministically instead:
/// - `|t| < 1e-9` (free fall): `z_b = e_z`, `ż_b = 0`.
/// - `|y_c × z_b| < 1e-9` (body z horizontal and across the heading, tilt 90°): the Mellinger &
///   Kumar 2011 form with `x_c = (cos ψ, sin ψ, 0)`, `y_b = normalize(z_b × x_c)`,
///   `x_b = y_b × z_b`, differentiated the same way.
/// - If that fails too (cannot happen: `x_c ⟂ y_c`), the level frame with heading ψ.
pub fn body_state(
    tr: &Translation,
    yaw_rad: f64,
    yaw_rate_rad_s: f64,
    gravity_m_s2: f64,
    t_s: f64,
) -> BodyState {
    let thrust = tr.a_b_in_w + Vector3::z() * gravity_m_s2;
    let (z_b, z_b_dot) =
        normalize_with_rate(thrust, tr.j_b_in_w).unwrap_or((Vector3::z(), Vector3::zeros()));

    let (sin_psi, cos_psi) = yaw_rad.sin_cos();
    let x_c = Vector3::new(cos_psi, sin_psi, 0.0);
    let y_c = Vector3::new(-sin_psi, cos_psi, 0.0);
    // ẋ_c = ψ̇ y_c, ẏ_c = −ψ̇ x_c.
    let x_c_dot = y_c * yaw_rate_rad_s;
    let y_c_dot = -x_c * yaw_rate_rad_s;

    let columns = if let Some((x_b, x_b_dot)) =
        normalize_with_rate(y_c.cross(&z_b), y_c_dot.cross(&z_b) + y_c.cross(&z_b_dot))
    {
        let y_b = z_b.cross(&x_b);
        let y_b_dot = z_b_dot.cross(&x_b) + z_b.cross(&x_b_dot);
        Some((x_b, x_b_dot, y_b, y_b_dot))
    } else {
        normalize_with_rate(z_b.cross(&x_c), z_b_dot.cross(&x_c) + z_b.cross(&x_c_dot)).map(
            |(y_b, y_b_dot)| {
                let x_b = y_b.cross(&z_b);
                let x_b_dot = y_b_dot.cross(&z_b) + y_b.cross(&z_b_dot);
                (x_b, x_b_dot, y_b, y_b_dot)
            },
        )
    };
    let (x_b, x_b_dot, y_b, y_b_dot, z_b, z_b_dot) = match columns {
        Some((x_b, x_b_dot, y_b, y_b_dot)) => (x_b, x_b_dot, y_b, y_b_dot, z_b, z_b_dot),
        None => (x_c, x_c_dot, y_c, y_c_dot, Vector3::z(), Vector3::zeros()),
    };

    let omega_b_in_b = Vector3::new(z_b.dot(&y_b_dot), x_b.dot(&z_b_dot), y_b.dot(&x_b_dot));
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x_b, y_b, z_b]));
    let world_from_body = UnitQuaternion::new_normalize(
        *UnitQuaternion::from_rotation_matrix(&rotation).quaternion(),
    );

    BodyState {
        t_s,
        p_b_in_w: tr.p_b_in_w,
        v_b_in_w: tr.v_b_in_w,
        a_b_in_w: tr.a_b_in_w,
        world_from_body,
        omega_b_in_b,
    }
}

/// What a perfect accelerometer reads: `f_b = R_w_bᵀ (a + g e_z)`, m/s². At hover (0, 0, +g).
pub fn specific_force_in_b(s: &BodyState, gravity_m_s2: f64) -> Vector3<f64> {
    s.world_from_body
        .inverse_transform_vector(&(s.a_b_in_w + Vector3::z() * gravity_m_s2))
}

/// Evaluates the flight and the yaw profile at `t_s` and returns [`body_state`]. The yaw profile
/// runs on mission time (see [`super::flight`]): ψ = ψ_profile(s), ψ̇ = ψ̇_profile(s)·ṡ.
pub fn sample(flight: &Flight, yaw: &YawConfig, gravity_m_s2: f64, t_s: f64) -> BodyState {
    let point = flight.at(t_s);
    let (yaw_rad, yaw_rate_rad_s) = yaw.yaw(point.mission_s, &point.mission_translation);
    body_state(
        &point.translation,
        yaw_rad,
        yaw_rate_rad_s * point.mission_rate,
        gravity_m_s2,
        t_s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::trajectory::TrajectoryConfig;
    use crate::sim::yaw::YawMode;
    use nalgebra::Quaternion;

    const G: f64 = STANDARD_GRAVITY_M_S2;

    fn paper_circle() -> Flight {
        // The paper's circle is the default.
        TrajectoryConfig::default().build(0, 60.0).into()
    }

    fn oscillating_toward_point() -> YawConfig {
        YawConfig {
            mode: YawMode::TowardPoint {
                point_m: [1.0, 4.0, 1.5],
            },
            offset_deg: 0.0,
            oscillation_amplitude_deg: 30.0,
            oscillation_period_s: 5.0,
        }
    }

    fn figure_eight() -> Flight {
        TrajectoryConfig::FigureEight {
            center_m: [5.0, 5.0, 1.5],
            half_length_m: 3.0,
            half_width_m: 1.5,
            period_s: 20.0,
        }
        .build(0, 60.0)
        .into()
    }

    fn tangent() -> YawConfig {
        YawConfig {
            mode: YawMode::Tangent,
            ..YawConfig::default()
        }
    }

    fn random_flight() -> (Flight, YawConfig) {
        let traj = TrajectoryConfig::RandomSmooth {
            bounds_min_m: [0.0, 0.0, 0.5],
            bounds_max_m: [10.0, 8.0, 2.5],
            max_speed_m_s: 2.0,
            num_harmonics: 6,
            min_period_s: 4.0,
            max_period_s: 30.0,
        }
        .build(11, 60.0)
        .into();
        let yaw = YawConfig {
            mode: YawMode::Fixed { yaw_deg: -40.0 },
            offset_deg: 0.0,
            oscillation_amplitude_deg: 45.0,
            oscillation_period_s: 7.0,
        };
        (traj, yaw)
    }

    #[test]
    fn hover_is_level_with_upward_specific_force() {
        let tr = TrajectoryConfig::Hover {
            position_m: [1.0, 2.0, 3.0],
        }
        .build(0, 0.0)
        .at(4.0);
        for yaw_deg in [0.0, 37.0, -120.0, 180.0] {
            let psi = f64::to_radians(yaw_deg);
            let s = body_state(&tr, psi, 0.0, G, 4.0);
            let f = specific_force_in_b(&s, G);
            assert!((f - Vector3::new(0.0, 0.0, G)).norm() < 1e-12, "{f:?}");
            assert_eq!(s.omega_b_in_b, Vector3::zeros());
            let expected = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), psi);
            assert!(s.world_from_body.angle_to(&expected) < 1e-12);
            assert_eq!(s.t_s, 4.0);
            assert_eq!(s.p_b_in_w, Vector3::new(1.0, 2.0, 3.0));
        }
    }

    /// Log(R(t)ᵀ R(t+h)) / h against ω(t + h/2).
    fn assert_omega_matches_attitude_difference(traj: &Flight, yaw: &YawConfig) {
        let h = 1e-4;
        for i in 0..40 {
            let t = 0.73 * i as f64;
            let (r0, r1) = (sample(traj, yaw, G, t), sample(traj, yaw, G, t + h));
            let numeric = (r0.world_from_body.inverse() * r1.world_from_body).scaled_axis() / h;
            let exact = sample(traj, yaw, G, t + h / 2.0).omega_b_in_b;
            let err = (numeric - exact).norm();
            assert!(err < 1e-7, "t={t}: {numeric:?} vs {exact:?} ({err})");
            assert!(exact.norm() > 1e-3, "trajectory must actually rotate");
        }
    }

    #[test]
    fn omega_matches_attitude_difference_circle() {
        assert_omega_matches_attitude_difference(&paper_circle(), &oscillating_toward_point());
    }

    #[test]
    fn omega_matches_attitude_difference_random() {
        let (traj, yaw) = random_flight();
        assert_omega_matches_attitude_difference(&traj, &yaw);
    }

    #[test]
    fn omega_matches_attitude_difference_figure_eight() {
        assert_omega_matches_attitude_difference(&figure_eight(), &tangent());
    }

    #[test]
    fn body_z_along_thrust_and_heading_is_yaw() {
        let (traj, yaw) = random_flight();
        for i in 0..200 {
            let t = 0.37 * i as f64;
            let tr = traj.at(t).translation;
            let (psi, _) = yaw.yaw(t, &tr);
            let s = sample(&traj, &yaw, G, t);
            let r = s.world_from_body.to_rotation_matrix();
            let thrust = tr.a_b_in_w + Vector3::z() * G;
            let z_b = r * Vector3::z();
            assert!((z_b - thrust.normalize()).norm() < 1e-12);
            // Specific force has no x/y component: all thrust.
            let f = specific_force_in_b(&s, G);
            assert!(f.xy().norm() < 1e-12 && (f.z - thrust.norm()).abs() < 1e-12);
            // x_b projected to the horizontal points along ψ.
            let x_b = r * Vector3::x();
            let heading = x_b.xy().normalize();
            assert!((heading - nalgebra::Vector2::new(psi.cos(), psi.sin())).norm() < 1e-12);
        }
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let mut tr = TrajectoryConfig::Hover {
            position_m: [0.0; 3],
        }
        .build(0, 0.0)
        .at(0.0);
        // Free fall.
        tr.a_b_in_w = Vector3::new(0.0, 0.0, -G);
        let s = body_state(&tr, 0.3, 0.1, G, 0.0);
        assert!(
            s.world_from_body
                .angle_to(&UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.3))
                < 1e-12
        );
        // Thrust horizontal across the heading (tilt 90°).
        tr.a_b_in_w = Vector3::new(0.0, 5.0, -G);
        tr.j_b_in_w = Vector3::new(0.0, 1.0, 0.5);
        let s = body_state(&tr, 0.0, 0.2, G, 0.0);
        let z_b = s.world_from_body * Vector3::z();
        assert!((z_b - Vector3::y()).norm() < 1e-12);
        assert!(s.omega_b_in_b.iter().all(|w| w.is_finite()));
    }

    /// q̇ = ½ q ⊗ (0, ω), v̇ = R(q) f − g e_z, ṗ = v.
    fn derivative(
        q: &Quaternion<f64>,
        v: &Vector3<f64>,
        omega: &Vector3<f64>,
        f: &Vector3<f64>,
    ) -> (Quaternion<f64>, Vector3<f64>, Vector3<f64>) {
        let q_dot = q * Quaternion::from_imag(*omega) * 0.5;
        let r = UnitQuaternion::new_normalize(*q);
        (q_dot, r * f - Vector3::z() * G, *v)
    }

    /// Integrates perfect 1000 Hz IMU samples with RK4 (step 2 ms, samples at k, k+1, k+2) for
    /// 60 s and returns the final (position error m, attitude error rad).
    fn integrate_perfect_imu(traj: &Flight, yaw: &YawConfig) -> (f64, f64) {
        integrate_perfect_imu_at(traj, yaw, 1000)
    }

    /// [`integrate_perfect_imu`] with IMU samples at `rate_hz`.
    fn integrate_perfect_imu_at(traj: &Flight, yaw: &YawConfig, rate_hz: usize) -> (f64, f64) {
        let dt = 1.0 / rate_hz as f64;
        let n = 60 * rate_hz;
        let imu: Vec<(Vector3<f64>, Vector3<f64>)> = (0..=n)
            .map(|k| {
                let s = sample(traj, yaw, G, k as f64 * dt);
                (s.omega_b_in_b, specific_force_in_b(&s, G))
            })
            .collect();
        let s0 = sample(traj, yaw, G, 0.0);
        let (mut q, mut v, mut p) = (*s0.world_from_body.quaternion(), s0.v_b_in_w, s0.p_b_in_w);
        let h = 2.0 * dt;
        for k in (0..n).step_by(2) {
            let (w0, f0) = imu[k];
            let (w1, f1) = imu[k + 1];
            let (w2, f2) = imu[k + 2];
            let (q1, v1, p1) = derivative(&q, &v, &w0, &f0);
            let (q2, v2, p2) = derivative(&(q + q1 * (h / 2.0)), &(v + v1 * (h / 2.0)), &w1, &f1);
            let (q3, v3, p3) = derivative(&(q + q2 * (h / 2.0)), &(v + v2 * (h / 2.0)), &w1, &f1);
            let (q4, v4, p4) = derivative(&(q + q3 * h), &(v + v3 * h), &w2, &f2);
            q = (q + (q1 + q2 * 2.0 + q3 * 2.0 + q4) * (h / 6.0)).normalize();
            v += (v1 + v2 * 2.0 + v3 * 2.0 + v4) * (h / 6.0);
            p += (p1 + p2 * 2.0 + p3 * 2.0 + p4) * (h / 6.0);
        }
        let truth = sample(traj, yaw, G, n as f64 * dt);
        let position_error = (p - truth.p_b_in_w).norm();
        let attitude_error = UnitQuaternion::new_normalize(q).angle_to(&truth.world_from_body);
        (position_error, attitude_error)
    }

    #[test]
    fn perfect_imu_integration_reproduces_paper_circle() {
        let (dp, dq) = integrate_perfect_imu(&paper_circle(), &oscillating_toward_point());
        // Acceptance: ≤ 1 mm and ≤ 1e-6 rad; RK4 at 2 ms reaches ~1e-11 m and ~1e-14 rad.
        assert!(dp <= 1e-6, "position error {dp} m");
        assert!(dq <= 1e-9, "attitude error {dq} rad");
    }

    #[test]
    fn perfect_imu_integration_reproduces_figure_eight() {
        let (dp, dq) = integrate_perfect_imu(&figure_eight(), &tangent());
        // Acceptance: ≤ 1 mm and ≤ 1e-6 rad; RK4 at 2 ms reaches ~1e-11 m and ~1e-14 rad.
        assert!(dp <= 1e-6, "position error {dp} m");
        assert!(dq <= 1e-9, "attitude error {dq} rad");
    }

    /// The paper's circle inside the default phases (3 s rest, 4 s take-off, 3 s ramps, 4 s
    /// landing, 2 s rest) over 60 s, and a waypoint loop with the heading along the path.
    fn phased(mission: TrajectoryConfig) -> Flight {
        use crate::sim::flight::PhasesConfig;
        let phases = PhasesConfig::default();
        phases.validate("phases", 60.0).unwrap();
        Flight::with_phases(mission.build(0, 60.0), &phases, 60.0)
    }

    fn waypoint_loop() -> TrajectoryConfig {
        crate::sim::waypoints::example_loop()
    }

    #[test]
    fn perfect_imu_integration_reproduces_phased_flights_across_every_join() {
        for (mission, yaw) in [
            (TrajectoryConfig::default(), oscillating_toward_point()),
            (waypoint_loop(), tangent()),
        ] {
            // A join that steps the IMU (or its derivative) leaves an error of the step's order
            // whatever the rate; a smooth flight's error falls as the rate⁴ (RK4). The waypoint
            // corners (1.5 m/s turned by 90° in 2 s) need 4 kHz to reach 1e-7 m by RK4 alone.
            let (dp, dq) = integrate_perfect_imu_at(&phased(mission), &yaw, 4000);
            assert!(dp <= 1e-7, "position error {dp} m");
            assert!(dq <= 1e-9, "attitude error {dq} rad");
        }
    }

    #[test]
    fn at_rest_the_imu_reads_gravity_only() {
        let flight = phased(TrajectoryConfig::default());
        let yaw = oscillating_toward_point();
        for t in [0.0, 1.0, 2.99, 58.5, 60.0, 70.0] {
            let s = sample(&flight, &yaw, G, t);
            let f = specific_force_in_b(&s, G);
            assert!(
                (f - Vector3::new(0.0, 0.0, G)).norm() < 1e-12,
                "t={t}: {f:?}"
            );
            assert_eq!(s.omega_b_in_b, Vector3::zeros(), "t={t}");
            assert!((s.p_b_in_w.z - 0.1).abs() < 1e-12, "t={t}: on the ground");
        }
        // Airborne in the mission.
        assert!((sample(&flight, &yaw, G, 30.0).p_b_in_w.z - 1.5).abs() < 1e-12);
    }

    #[test]
    fn omega_matches_attitude_difference_phased() {
        assert_omega_matches_attitude_difference_over(
            &phased(waypoint_loop()),
            &tangent(),
            (8..55).map(|t| f64::from(t) + 0.31),
        );
    }

    fn assert_omega_matches_attitude_difference_over(
        flight: &Flight,
        yaw: &YawConfig,
        times: impl Iterator<Item = f64>,
    ) {
        let h = 1e-4;
        for t in times {
            let (r0, r1) = (sample(flight, yaw, G, t), sample(flight, yaw, G, t + h));
            let numeric = (r0.world_from_body.inverse() * r1.world_from_body).scaled_axis() / h;
            let exact = sample(flight, yaw, G, t + h / 2.0).omega_b_in_b;
            assert!(
                (numeric - exact).norm() < 1e-7,
                "t={t}: {numeric:?} vs {exact:?}"
            );
        }
    }
}
