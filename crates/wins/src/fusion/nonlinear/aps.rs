//! The window's APs: placed ones (in the border, their bearings used) and placeholders for APs
//! seen but not yet placed (the border keeps their slot so that an AP's index is its number; a
//! vanishing prior keeps the system regular; their bearings are skipped). An AP is placed at the
//! start, or later from its triangulation ([`super::late_ap`]), whose information joins the
//! prior at that point.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::config::NonlinearConfig;
use super::state::STATE_DIM;
use super::triangulate::{Sight, Triangulated, triangulate};
use super::window::{NonlinearWindow, PLACEHOLDER_INFORMATION};

/// The largest horizontal σ (of the x–y block) of a position covariance, m.
pub fn horizontal_sigma_m(covariance: &Matrix3<f64>) -> f64 {
    covariance
        .fixed_view::<2, 2>(0, 0)
        .into_owned()
        .symmetric_eigenvalues()
        .max()
        .max(0.0)
        .sqrt()
}

/// The AP `sights` see, triangulated, when its horizontal σ is within `config`'s bounds at its
/// smallest range from the sights ([`NonlinearConfig::ap_sigma_ok`]).
pub fn triangulate_within_bounds(
    sights: &[Sight],
    config: &NonlinearConfig,
) -> Option<Triangulated> {
    let t = triangulate(sights, config.cauchy_scale)?;
    let range = sights
        .iter()
        .map(|s| (t.c_in_w - s.p_a_in_w).norm())
        .fold(f64::INFINITY, f64::min);
    config
        .ap_sigma_ok(horizontal_sigma_m(&t.covariance), range)
        .then_some(t)
}

impl NonlinearWindow {
    /// Places AP `l` at `c_in_w` with information `info` (from bearings the window does not
    /// hold) in the prior, at that point (its first estimate); APs between the last one and `l`
    /// get placeholders.
    pub fn place_ap(&mut self, l: usize, c_in_w: Vector3<f64>, info: &Matrix3<f64>) {
        while self.aps.len() <= l {
            self.push_placeholder();
        }
        let o = STATE_DIM + self.ap_offset(l);
        let n = self.prior_h.nrows();
        self.prior_h.view_mut((o, 0), (3, n)).fill(0.0);
        self.prior_h.view_mut((0, o), (n, 3)).fill(0.0);
        self.prior_h.view_mut((o, o), (3, 3)).copy_from(info);
        self.prior_g.rows_mut(o, 3).fill(0.0);
        self.aps[l] = c_in_w;
        self.ap_lin[l] = Some(c_in_w);
        self.placed[l] = true;
    }

    fn push_placeholder(&mut self) {
        let dim = self.prior_h.nrows();
        let full = STATE_DIM + self.border_dim() + 3;
        let mut h = DMatrix::zeros(full, full);
        h.view_mut((0, 0), (dim, dim)).copy_from(&self.prior_h);
        h.view_mut((full - 3, full - 3), (3, 3))
            .fill_diagonal(PLACEHOLDER_INFORMATION);
        let mut g = DVector::zeros(full);
        g.rows_mut(0, dim).copy_from(&self.prior_g);
        self.prior_h = h;
        self.prior_g = g;
        self.aps.push(Vector3::zeros());
        self.ap_lin.push(None);
        self.placed.push(false);
    }

    /// Whether AP `l` is placed.
    pub fn is_placed(&self, l: usize) -> bool {
        self.placed.get(l).copied().unwrap_or(false)
    }

    /// AP `l`'s position in `w`, when placed.
    pub fn ap(&self, l: usize) -> Option<Vector3<f64>> {
        self.is_placed(l).then(|| self.aps[l])
    }

    /// AP `l`'s marginal position covariance (last solve), m², when placed.
    pub fn ap_covariance(&self, l: usize) -> Option<Matrix3<f64>> {
        let o = self.ap_offset(l);
        (self.is_placed(l) && self.border_covariance.nrows() >= o + 3)
            .then(|| self.border_covariance.fixed_view::<3, 3>(o, o).into_owned())
    }

    /// AP `l`'s largest marginal σ (largest eigenvalue of its block), m.
    pub fn ap_sigma_m(&self, l: usize) -> Option<f64> {
        self.ap_covariance(l)
            .map(|p| p.symmetric_eigenvalues().max().max(0.0).sqrt())
    }

    /// AP `l`'s largest horizontal marginal σ (of its x–y block), m. An AP near the array's
    /// height is seen at an elevation `e ≈ 0`, where the cone angle changes only to second order
    /// with `e` (`sin θ = cos e sin φ`): its height is weakly determined, and matters as little
    /// to the bearings.
    pub fn ap_horizontal_sigma_m(&self, l: usize) -> Option<f64> {
        self.ap_covariance(l).map(|p| horizontal_sigma_m(&p))
    }
}
