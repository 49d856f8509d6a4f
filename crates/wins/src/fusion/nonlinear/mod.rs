//! The 6-DoF nonlinear sliding-window estimator, the default (docs/ESTIMATOR.md).
//!
//! State per keyframe `k` ([`state::NavState`]): attitude `R_k` on SO(3), position, velocity,
//! gyro and accelerometer biases, in a gravity-aligned world frame `w` (z up); every AP's position
//! in 3-D; the barometer's offset when there is one; without a chain calibration, a common offset
//! of every bearing's `sin θ` (what an error in the receive chains' uniform phase step does). The
//! error state of a keyframe is `[δθ, δp, δv, δb_g, δb_a]` with `R = R̂ Exp(δθ)` (15 numbers).
//!
//! Its rooms, one concept each:
//!
//! - [`estimator`]: the push API and the frame handler, one `match` on the flight's [`phase`]
//!   (at rest, starting, tracking, recovering), whose transitions all happen in one place;
//! - [`state`]: the keyframe state, its `⊞`/`⊟`, and the partial preintegration that ties a
//!   measurement between keyframes to the keyframe before it ([`state::pose_at`]);
//! - [`factors`]: each factor's residual and Jacobian (IMU, AoA cone, barometer, zero velocity,
//!   range anchor), handed to the solver as a linearization;
//! - [`solve`]: the window ([`solve::NonlinearWindow`]): keyframes, APs, the marginalization
//!   prior with first-estimate Jacobians, the Gauss–Newton solve ([`solve::optimize`]) and the
//!   residual statistics and χ² test ([`solve::fit`]);
//! - [`start`]: the start from the rest ([`start::rest`]), the inertial and start-solver
//!   proposals ([`start::proposal`]), and the stillness detector of the zero-velocity holds
//!   ([`start::still`]);
//! - [`triangulate`]: an AP placed from bearings against known poses (the start, late APs, the
//!   relocation after a hole);
//! - `track`: a keyframe while tracking, its solve, the loss test, and APs that join late;
//! - `transitions`: every change of phase, in one place;
//! - `recovery`: after a hole in the information (an IMU gap, a CSI outage), where the new
//!   window is placed by what the lost one knew;
//! - `output`: the pose and its covariance, in the output frame.
//!
//! It imports no estimator of the paper's: a flight started in the air is proposed by a start
//! solver handed in through [`crate::fusion::proposal`].

pub mod config;
pub mod estimator;
pub mod factors;
mod late_ap;
mod output;
pub mod phase;
pub mod recovery;
pub mod solve;
pub mod start;
pub mod state;
pub mod track;
mod transitions;
pub mod triangulate;

pub use config::{NonlinearConfig, Sensors};
pub use estimator::NonlinearEstimator;
pub use phase::{PhaseChange, PhaseKind, Reason};
pub use solve::fit::passes_chi2;
pub use solve::optimize::{SolveError, SolveReport};
pub use solve::{FitStats, NonlinearWindow, SubFrame};
