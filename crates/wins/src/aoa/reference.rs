//! The straightforward MUSIC, as SpotFi's MATLAB does it: forward–backward covariance as a complex
//! n × n matrix, complex Hermitian eigendecomposition, noise projector `H = E_n·E_nᴴ`, and the n × n
//! quadratic form `sᴴ·H·s` at every grid point. Slow on purpose: it is the benchmark's baseline
//! and the tests' oracle for [`super::music`] (same settings, same numbers).

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use num_complex::Complex64;

use super::music::{AoaWindow, Music, MusicError, Spectrum};

/// The spectrum of one sanitized, calibrated packet over `window`, computed the long way. Uses the
/// path count rule and grids of `music`, so it equals [`Music::spectrum`] to rounding.
pub fn reference_spectrum(
    music: &Music,
    csi: &[Complex64],
    window: AoaWindow,
) -> Result<Spectrum, MusicError> {
    let layout = music.layout();
    let mut x = DMatrix::zeros(layout.rows(), layout.cols());
    layout.fill(csi, &mut x)?;
    if x.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
        return Err(MusicError::NonFinite);
    }
    let (n, snapshots) = x.shape();
    let mut r = &x * x.adjoint() * Complex64::new(1.0 / snapshots as f64, 0.0);
    let rank = if music.config().forward_backward {
        let flipped = DMatrix::from_fn(n, n, |i, j| r[(n - 1 - i, n - 1 - j)].conj());
        r = (r + flipped) * Complex64::new(0.5, 0.0);
        (2 * snapshots).min(n)
    } else {
        snapshots.min(n)
    };
    let eig = SymmetricEigen::new(r);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let values: Vec<f64> = order.iter().map(|&i| eig.eigenvalues[i]).collect();
    if values.iter().any(|v| !v.is_finite()) || values[0] <= 0.0 {
        return Err(MusicError::NoSignal);
    }
    let (paths, _) = music.config().paths.judge(&values, rank);
    let noise = DMatrix::from_fn(n, n - paths, |i, j| eig.eigenvectors[(i, order[paths + j])]);
    let h = &noise * noise.adjoint();

    let aoa: Vec<f64> = music
        .aoa_grid()
        .iter()
        .copied()
        .filter(|&t| t >= window.min_rad - 1e-12 && t <= window.max_rad + 1e-12)
        .collect();
    let mut residual = Vec::with_capacity(aoa.len() * music.tof_grid().len());
    for &tof in music.tof_grid() {
        let b = music.tof_phasors(tof);
        for &theta in &aoa {
            let a = music.aoa_phasors(theta);
            let s =
                DVector::from_iterator(n, a.iter().flat_map(|am| b.iter().map(move |bw| am * bw)));
            let q = (s.adjoint() * &h * &s)[(0, 0)].re;
            residual.push((q / n as f64).clamp(1e-12, 1.0));
        }
    }
    Ok(Spectrum {
        aoa_rad: aoa,
        tof_s: music.tof_grid().to_vec(),
        residual,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aoa::{AoaConfig, AoaEstimator};
    use crate::csi::Bandwidth;
    use crate::rig::{ArrayGeometry, ChainCalibration};
    use crate::sim::{Scenario, simulate};

    /// The Kronecker spectrum equals the n × n quadratic form on simulated multipath packets,
    /// HT20 (16 × 30) and HT40 (SpotFi's 30 × 32), full range and a PAoA window.
    #[test]
    fn kronecker_spectrum_equals_the_quadratic_form() {
        for bw in [Bandwidth::Ht20, Bandwidth::Ht40] {
            let mut s = Scenario::built_in("paper-circle").unwrap().airborne();
            s.duration_s = 0.3;
            s.radio.bandwidth = bw;
            let out = simulate(&s, &mut |_| {}).unwrap();
            let mut cal = ChainCalibration::identity(3);
            cal.phase_offsets_rad = out.chain_phase_offsets_rad.clone();
            let mut config = AoaConfig::default();
            config.music.aoa_step_deg = 3.0;
            config.music.tof_step_s = 20e-9;
            let est =
                AoaEstimator::new(&config, ArrayGeometry::default(), 5.32e9, Some(cal)).unwrap();
            let mut checked = 0;
            for (_, record) in out.aps[0].received().take(5) {
                let csi = est.prepare(record).unwrap();
                let music = est.music(bw);
                let subspace = music.subspace(&csi).unwrap();
                for window in [AoaWindow::FULL, AoaWindow::around(0.3, 0.35)] {
                    let fast = music.spectrum(&subspace, window);
                    let slow = reference_spectrum(music, &csi, window).unwrap();
                    assert_eq!(fast.aoa_rad, slow.aoa_rad);
                    assert_eq!(fast.residual.len(), slow.residual.len());
                    for (f, r) in fast.residual.iter().zip(&slow.residual) {
                        assert!((f - r).abs() < 1e-9, "{bw:?}: {f} vs {r}");
                    }
                    checked += 1;
                }
            }
            assert_eq!(checked, 10);
        }
    }
}
