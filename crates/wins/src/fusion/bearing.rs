//! The AoA measurement as the fusion stages see it: a cone angle to one AP, with the mirror side.
//!
//! A linear array measures only the cone angle θ (sin θ = û_a · ŷ_a, [`crate::aoa::steering`]),
//! which cannot tell front (û_a · x̂_a ≥ 0) from back. The fusion stages take the side as part of
//! the measurement: whoever feeds them (the pipeline, a test) must resolve it, from the state or
//! from the simulator's truth, and never pass a mirrored bearing unflagged.
//!
//! The linear estimator (paper `eqn:similar_equation`) needs a full direction: with the AP in the
//! array's `a_x a_y` plane (the paper's 5-DoF assumption, zero elevation) the direction toward the
//! AP in `a` is `d_a = (±cos θ, sin θ, 0)`. When the AP is off that plane by an elevation `e`,
//! sin θ = cos e · sin φ with φ the in-plane azimuth, so assuming `e = 0` biases the azimuth by
//! about `(1 − cos e) tan θ` rad; [`Bearing::direction_in_a`] takes the elevation as an argument so
//! that a caller with an estimate of it (from the state) can remove that bias.

use nalgebra::Vector3;

/// Which half-space of the array the AP is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Side {
    /// û_a · x̂_a ≥ 0: in front of the array (the paper's ±90° range).
    Front,
    /// û_a · x̂_a < 0: behind it; the same cone angle as the mirror image in front.
    Back,
}

/// One AoA measurement to one AP at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bearing {
    /// Index of the AP (the estimator's numbering; APs are added as they are first seen).
    pub ap: usize,
    /// Cone angle θ ∈ [−π/2, π/2], rad, as MUSIC reports it.
    pub aoa_rad: f64,
    /// The side of the array the AP is on (the mirror resolved).
    pub side: Side,
    /// Standard deviation of `aoa_rad`, rad (> 0).
    pub sigma_rad: f64,
}

impl Bearing {
    /// Unit direction toward the AP in the array frame `a`, for an AP at `elevation_rad` above the
    /// array's `a_x a_y` plane: `(±cos φ cos e, sin φ cos e, sin e)` with sin φ = sin θ / cos e
    /// (clamped), the sign of the first component from [`Side`]. With `elevation_rad = 0` this is
    /// the paper's `d_a = (±cos θ, sin θ, 0)`.
    pub fn direction_in_a(&self, elevation_rad: f64) -> Vector3<f64> {
        let (sin_e, cos_e) = elevation_rad.sin_cos();
        let sin_phi = (self.aoa_rad.sin() / cos_e.max(1e-9)).clamp(-1.0, 1.0);
        let cos_phi = (1.0 - sin_phi * sin_phi).max(0.0).sqrt();
        let x = match self.side {
            Side::Front => cos_phi,
            Side::Back => -cos_phi,
        };
        Vector3::new(x * cos_e, sin_phi * cos_e, sin_e)
    }

    /// Whether the numbers are usable: a finite angle in [−π/2, π/2] and a finite σ > 0.
    pub fn is_valid(&self) -> bool {
        self.aoa_rad.is_finite()
            && self.aoa_rad.abs() <= std::f64::consts::FRAC_PI_2 + 1e-12
            && self.sigma_rad.is_finite()
            && self.sigma_rad > 0.0
    }
}

/// The side of the array a direction (in `a`) lies on.
pub fn side_of(toward_ap_in_a: &Vector3<f64>) -> Side {
    if toward_ap_in_a.x >= 0.0 {
        Side::Front
    } else {
        Side::Back
    }
}

/// Elevation of a direction above the array's `a_x a_y` plane, rad (0 for a zero vector).
pub fn elevation_rad(toward_ap_in_a: &Vector3<f64>) -> f64 {
    let n = toward_ap_in_a.norm();
    if n > 0.0 {
        (toward_ap_in_a.z / n).clamp(-1.0, 1.0).asin()
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aoa::steering::aoa_rad;

    #[test]
    fn direction_reproduces_the_cone_angle_side_and_elevation() {
        for &(x, y, z) in &[
            (1.0, 0.3, 0.0),
            (2.0, -1.0, 0.4),
            (-1.5, 0.7, -0.3),
            (-0.2, -1.0, 0.1),
        ] {
            let u = Vector3::new(x, y, z);
            let b = Bearing {
                ap: 0,
                aoa_rad: aoa_rad(&u),
                side: side_of(&u),
                sigma_rad: 0.01,
            };
            let d = b.direction_in_a(elevation_rad(&u));
            assert!(
                (d - u.normalize()).norm() < 1e-12,
                "{d} vs {}",
                u.normalize()
            );
            // Without the elevation the cone angle is kept but the direction tilts into the plane.
            let flat = b.direction_in_a(0.0);
            assert!((flat.y - u.normalize().y).abs() < 1e-12 || z != 0.0);
            assert_eq!(flat.z, 0.0);
            assert!((flat.norm() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn validity() {
        let ok = Bearing {
            ap: 0,
            aoa_rad: 0.3,
            side: Side::Front,
            sigma_rad: 0.03,
        };
        assert!(ok.is_valid());
        assert!(
            !Bearing {
                aoa_rad: f64::NAN,
                ..ok
            }
            .is_valid()
        );
        assert!(!Bearing { aoa_rad: 2.0, ..ok }.is_valid());
        assert!(
            !Bearing {
                sigma_rad: 0.0,
                ..ok
            }
            .is_valid()
        );
    }
}
