//! The zero-velocity factor: a keyframe taken while the IMU is still ([`crate::fusion::nonlinear::start::still`]) and the
//! window's speed estimate is small holds its velocity at zero,
//!
//! ```text
//! r = v_k        (world frame, m/s; 1σ = NonlinearConfig::zero_velocity_sigma_m_s per axis)
//! ```
//!
//! With one AP, motion along the line of sight is unseen by the bearings once the drone stops
//! moving across it; the position is then held only by the IMU's integration, and a window whose
//! accelerometer bias is poorly known drifts (a window restarted after a hole most of all). On
//! the ground the IMU knows better: the velocity is zero. Consecutive still keyframes, tied by the
//! IMU factor between them, then also hold the position.
//!
//! The factor touches one keyframe: marginalizing it folds it into the prior like the keyframe's
//! other measurements. Its cost counts in the χ² tests, its residuals not among their degrees
//! of freedom ([`crate::fusion::nonlinear::passes_chi2`]).

use crate::fusion::arrow::{ArrowSystem, Linearized, Weight};
use crate::fusion::nonlinear::solve::fit::FitStats;
use crate::fusion::nonlinear::solve::{Keyframe, NonlinearWindow};
use crate::fusion::nonlinear::state::{NavState, STATE_DIM, VEL};

/// The residual `r = v` (module doc), m/s.
pub fn zero_velocity_residual(x: &NavState) -> nalgebra::Vector3<f64> {
    x.v_b_in_w
}

/// `∂r/∂δx`: the identity on the velocity block (`v ⊞ δ = v + δv`).
pub fn zero_velocity_jacobian() -> nalgebra::SMatrix<f64, 3, STATE_DIM> {
    let mut j = nalgebra::SMatrix::<f64, 3, STATE_DIM>::zeros();
    j.fixed_view_mut::<3, 3>(0, VEL)
        .copy_from(&nalgebra::Matrix3::identity());
    j
}

impl NonlinearWindow {
    /// Holds the newest keyframe at zero velocity from now on (it was taken while still).
    pub fn hold_newest_still(&mut self) {
        if let Some(k) = self.keyframes.back_mut() {
            k.still = true;
        }
    }

    /// Keyframes held at zero velocity.
    pub fn still_keyframes(&self) -> usize {
        self.keyframes.iter().filter(|k| k.still).count()
    }

    /// Adds keyframe `k`'s zero-velocity factor to `sys` (the Jacobian is constant, so first
    /// estimates change nothing).
    pub(in crate::fusion::nonlinear) fn add_zero_velocity(
        &self,
        k: usize,
        kf: &Keyframe,
        sys: &mut ArrowSystem<STATE_DIM>,
        cost: &mut f64,
        stats: &mut FitStats,
    ) {
        let r = zero_velocity_residual(&kf.x);
        let info = self.model.config.zero_velocity_sigma_m_s.powi(-2);
        let j = zero_velocity_jacobian();
        let e2 = r.norm_squared() * info;
        *cost += e2;
        stats.zero_velocity += 3;
        stats.zero_velocity_chi2 += e2;
        sys.add(&Linearized::on_frame(k, j, r, Weight::Scalar(info)));
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{SVector, Vector3};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::fusion::nonlinear::solve::aps::tests::window;
    use crate::fusion::nonlinear::state::testing::{
        assert_close, central_difference, random_state,
    };
    use crate::time::Timestamp;

    #[test]
    fn zero_velocity_jacobian_matches_finite_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(51);
        for _ in 0..3 {
            let x = random_state(&mut rng, Timestamp(0));
            let fd = central_difference(|d| -> SVector<f64, 3> {
                zero_velocity_residual(&x.boxplus(d))
            });
            assert_close(&fd, &zero_velocity_jacobian(), "∂r/∂x");
        }
        let x = random_state(&mut rng, Timestamp(0));
        let still = NavState {
            v_b_in_w: Vector3::zeros(),
            ..x
        };
        assert_eq!(zero_velocity_residual(&still), Vector3::zeros());
    }

    /// A window at rest whose IMU reads gravity plus an accelerometer bias of 0.5 m/s² along x,
    /// with `n` keyframes 0.1 s apart after the first (each held still when `held`).
    fn biased_rest(n: i64, held: bool) -> NonlinearWindow {
        use crate::imu::{ImuBiases, ImuSample, Preintegrator};
        let mut w = window(Vec::new());
        let x0 = *w.keyframes().next().unwrap();
        let g = w.model.gravity_m_s2;
        let sample = |ms: i64| ImuSample {
            t: Timestamp(ms * 1_000_000),
            gyro_rad_s: Vector3::zeros(),
            accel_m_s2: Vector3::new(0.5, 0.0, g),
        };
        let mut pre = Preintegrator::new(w.model.imu_noise.clone(), ImuBiases::zero());
        for k in 1..=n {
            for ms in ((k - 1) * 100..k * 100).step_by(10) {
                pre.push(&sample(ms)).unwrap();
            }
            let t = Timestamp(k * 100_000_000);
            let interval = pre.cut(t, &sample(k * 100)).unwrap();
            assert!(
                w.push_keyframe(NavState { t, ..x0 }, interval, Vec::new())
                    .is_some()
            );
            if held {
                w.hold_newest_still();
            }
        }
        // The tilt that explains the drift is slow to reach from a level start.
        w.optimize(50).unwrap();
        w
    }

    /// Held still, the window's velocities stay at zero against the IMU's drift (it is taken
    /// for a tilt or a bias, which a rest cannot tell apart); without the holds they follow it.
    #[test]
    fn a_still_window_holds_its_velocity_against_the_drift() {
        let w = biased_rest(4, true);
        assert_eq!(w.still_keyframes(), 4);
        assert_eq!(w.fit().zero_velocity, 12);
        for x in w.keyframes().skip(1) {
            assert!(x.v_b_in_w.norm() < 1e-3, "{:?}", x.v_b_in_w);
        }
        let drifting = biased_rest(4, false);
        assert_eq!(drifting.fit().zero_velocity, 0);
        let v = drifting.keyframes().last().unwrap().v_b_in_w;
        assert!(v.x > 0.05, "{v:?}");
    }

    /// When a held keyframe leaves the window its hold goes into the prior on the next one's
    /// velocity, once (the marginalization's copy of the next keyframe carries none).
    #[test]
    fn a_marginalized_hold_stays_in_the_prior() {
        let velocity_information = |held: bool| {
            let mut w = biased_rest(3, held);
            w.marginalize_oldest();
            w.marginalize_oldest();
            assert_eq!(w.fit().zero_velocity, if held { 6 } else { 0 });
            w.prior.h.fixed_view::<3, 3>(VEL, VEL).diagonal().min()
        };
        let info = 0.02_f64.powi(-2);
        let held = velocity_information(true);
        assert!(held > 0.9 * info && held < 1.1 * info, "{held}");
        let free = velocity_information(false);
        assert!(free < 10.0, "{free}");
    }
}
