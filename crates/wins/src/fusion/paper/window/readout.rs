//! What the window reports: its frames' estimates and inputs, the APs' positions and
//! covariances, the biases, the convergence time and the normal equations as they stand.

use nalgebra::{Matrix3, Vector3};

use super::assemble::ap_offset;
use super::factors::BIAS_DIM;
use super::{Frame, FrameEstimate, SlidingWindow};
use crate::fusion::arrow::ArrowSystem;
use crate::fusion::bearing::Bearing;
use crate::imu::Preintegrated;
use crate::time::Timestamp;

impl SlidingWindow {
    /// Largest marginal position σ over the APs (largest eigenvalue of each 3×3 block), m;
    /// infinite without APs.
    pub fn max_ap_sigma_m(&self) -> f64 {
        (0..self.num_aps).filter_map(|l| self.ap_sigma_m(l)).fold(
            if self.num_aps == 0 {
                f64::INFINITY
            } else {
                0.0
            },
            f64::max,
        )
    }

    /// When the estimate first converged (module doc), if it has.
    pub fn converged_at(&self) -> Option<Timestamp> {
        self.health.converged_at
    }

    /// Frames in the window, oldest first.
    pub fn frames(&self) -> impl Iterator<Item = FrameEstimate> + '_ {
        self.frames.iter().map(|f| self.estimate(f))
    }

    fn estimate(&self, f: &Frame) -> FrameEstimate {
        FrameEstimate {
            t: f.t,
            p_in_b0: f.x.fixed_rows::<3>(0).into_owned(),
            v_in_bk: f.x.fixed_rows::<3>(3).into_owned(),
            g_in_bk: f.x.fixed_rows::<3>(6).into_owned(),
            b0_from_bk: f.rotation(&self.gyro_bias_rad_s),
        }
    }

    /// Per window frame: the IMU interval from the previous frame (None for the oldest frame of
    /// the very first window), the bearings, and the upward direction the AoA rows use.
    pub fn frame_inputs(
        &self,
    ) -> impl Iterator<Item = (Option<&Preintegrated>, &[Bearing], Vector3<f64>)> + '_ {
        let adaptive = self.config.adaptive_weights;
        self.frames
            .iter()
            .map(move |f| (f.from_prev.as_ref(), f.bearings.as_slice(), f.up(adaptive)))
    }

    /// The gyro bias the IMU intervals are corrected to, rad/s.
    pub fn gyro_bias_rad_s(&self) -> Vector3<f64> {
        self.gyro_bias_rad_s
    }

    /// The newest frame.
    pub fn latest(&self) -> Option<FrameEstimate> {
        self.frames.back().map(|f| self.estimate(f))
    }

    /// Number of frames in the window.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether the window has no frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frames marginalized so far.
    pub fn marginalized(&self) -> usize {
        self.marginalized
    }

    /// Number of APs with a state.
    pub fn num_aps(&self) -> usize {
        self.num_aps
    }

    /// AP `l`'s position in `b0`, m.
    pub fn ap_in_b0(&self, l: usize) -> Option<Vector3<f64>> {
        (l < self.num_aps).then(|| self.border.fixed_rows::<3>(ap_offset(l)).into_owned())
    }

    /// AP `l`'s marginal position covariance, m².
    pub fn ap_covariance(&self, l: usize) -> Option<Matrix3<f64>> {
        let o = ap_offset(l);
        (l < self.num_aps).then(|| self.border_covariance.fixed_view::<3, 3>(o, o).into_owned())
    }

    /// AP `l`'s largest marginal position σ (largest eigenvalue of its 3×3 block), m.
    pub fn ap_sigma_m(&self, l: usize) -> Option<f64> {
        self.ap_covariance(l)
            .map(|p| p.symmetric_eigenvalues().max().max(0.0).sqrt())
    }

    /// The accelerometer bias estimate, m/s².
    pub fn accel_bias_m_s2(&self) -> Vector3<f64> {
        self.border.fixed_rows::<3>(0).into_owned()
    }

    /// Marginal covariance of the biases `[b_a, b_g]`.
    pub fn bias_covariance(&self) -> nalgebra::Matrix6<f64> {
        self.border_covariance
            .fixed_view::<BIAS_DIM, BIAS_DIM>(0, 0)
            .into_owned()
    }

    /// The window's normal equations as they stand (for inspection and benchmarks).
    pub fn normal_equations(&self) -> ArrowSystem {
        self.build()
    }
}
