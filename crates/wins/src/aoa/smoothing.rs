//! The smoothed CSI matrix of SpotFi (Kotaru et al. 2015, §3.2 and Fig. 4): every window of
//! `M_s` neighbouring antennas × `W` neighbouring subcarriers becomes one column, so that the
//! columns are snapshots of the same (AoA, ToF) steering vectors with different path gains.
//!
//! Rows are ordered antenna-major, `row = m·W + w`, matching the steering vector
//! `a(θ) ⊗ b(τ)` with `a` over the window's antennas and `b` over its subcarriers.
//!
//! Smoothing is exact only where the subcarriers of a window are uniformly spaced. HT40's 30
//! groups are uniform (step 4, 1.25 MHz), so SpotFi's 2 × 15 windows give its 30 × 32 matrix. HT20's
//! are not (−28…−2 step 2, −1…27 step 2, then 28): windows here stay inside the uniform runs, so
//! with the default `W = 8` HT20 gives a 16 × 30 matrix (7 + 8 subcarrier shifts × 2 antenna
//! shifts). Smoothing across the irregular joins, as popular SpotFi clones do, puts a ToF-dependent
//! phase error on half the columns.

use nalgebra::DMatrix;
use num_complex::Complex64;

use super::music::error::MusicError;

/// Where the windows of the smoothed matrix sit.
#[derive(Clone, Debug, PartialEq)]
pub struct SmoothingLayout {
    num_antennas: usize,
    num_subcarriers: usize,
    antennas_per_window: usize,
    subcarriers_per_window: usize,
    step_hz: f64,
    /// (first antenna, first subcarrier) of each column's window.
    columns: Vec<(usize, usize)>,
}

impl SmoothingLayout {
    /// A layout for CSI with `num_antennas` antennas on subcarriers at `offsets_hz` (strictly
    /// increasing). The window step is the most common spacing between neighbouring subcarriers;
    /// windows are placed wherever `subcarriers_per_window` consecutive subcarriers are spaced by
    /// exactly that step.
    pub fn new(
        offsets_hz: &[f64],
        num_antennas: usize,
        antennas_per_window: usize,
        subcarriers_per_window: usize,
    ) -> Result<Self, MusicError> {
        let bad = |reason: String| Err(MusicError::Layout(reason));
        if antennas_per_window == 0 || antennas_per_window > num_antennas {
            return bad(format!(
                "{antennas_per_window} antennas per window with {num_antennas} antennas"
            ));
        }
        if subcarriers_per_window < 2 {
            return bad("a window needs at least 2 subcarriers".into());
        }
        if offsets_hz
            .windows(2)
            .any(|p| p[1].partial_cmp(&p[0]) != Some(std::cmp::Ordering::Greater))
            || offsets_hz.iter().any(|o| !o.is_finite())
        {
            return bad("subcarrier offsets must be finite and strictly increasing".into());
        }
        let step_hz = dominant_step_hz(offsets_hz)
            .ok_or_else(|| MusicError::Layout("fewer than two subcarriers".into()))?;
        let tolerance_hz = 1e-6 * step_hz;
        let mut starts = Vec::new();
        let mut run_start = 0;
        for k in 1..=offsets_hz.len() {
            let continues = k < offsets_hz.len()
                && ((offsets_hz[k] - offsets_hz[k - 1]) - step_hz).abs() <= tolerance_hz;
            if !continues {
                let run_len = k - run_start;
                if run_len >= subcarriers_per_window {
                    starts.extend(run_start..=k - subcarriers_per_window);
                }
                run_start = k;
            }
        }
        if starts.is_empty() {
            return bad(format!(
                "no {subcarriers_per_window} uniformly spaced subcarriers to smooth over"
            ));
        }
        let columns = (0..=num_antennas - antennas_per_window)
            .flat_map(|m| starts.iter().map(move |&k| (m, k)))
            .collect();
        Ok(Self {
            num_antennas,
            num_subcarriers: offsets_hz.len(),
            antennas_per_window,
            subcarriers_per_window,
            step_hz,
            columns,
        })
    }

    /// Rows of the smoothed matrix: `M_s · W`.
    pub fn rows(&self) -> usize {
        self.antennas_per_window * self.subcarriers_per_window
    }

    /// Columns (snapshots) of the smoothed matrix.
    pub fn cols(&self) -> usize {
        self.columns.len()
    }

    /// Antennas per window, `M_s`.
    pub fn antennas_per_window(&self) -> usize {
        self.antennas_per_window
    }

    /// Subcarriers per window, `W`.
    pub fn subcarriers_per_window(&self) -> usize {
        self.subcarriers_per_window
    }

    /// Frequency spacing of neighbouring subcarriers inside a window, Hz. The ToF is unambiguous
    /// over `1 / step_hz`.
    pub fn step_hz(&self) -> f64 {
        self.step_hz
    }

    /// Entries of the CSI this layout reads: antennas × subcarriers.
    pub fn csi_len(&self) -> usize {
        self.num_antennas * self.num_subcarriers
    }

    /// Fills the smoothed matrix from `csi` (row-major, antenna `m`'s subcarrier `k` at
    /// `m·K + k`). `out` is resized if its shape differs.
    pub fn fill(&self, csi: &[Complex64], out: &mut DMatrix<Complex64>) -> Result<(), MusicError> {
        if csi.len() != self.csi_len() {
            return Err(MusicError::CsiLength {
                len: csi.len(),
                expected: self.csi_len(),
            });
        }
        if out.shape() != (self.rows(), self.cols()) {
            *out = DMatrix::zeros(self.rows(), self.cols());
        }
        let (ms, w_len, k_len) = (
            self.antennas_per_window,
            self.subcarriers_per_window,
            self.num_subcarriers,
        );
        for (c, &(m0, k0)) in self.columns.iter().enumerate() {
            let mut col = out.column_mut(c);
            for m in 0..ms {
                let src = &csi[(m0 + m) * k_len + k0..][..w_len];
                for (w, v) in src.iter().enumerate() {
                    col[m * w_len + w] = *v;
                }
            }
        }
        Ok(())
    }
}

/// The most common positive spacing between neighbouring offsets (ties: the smaller).
fn dominant_step_hz(offsets_hz: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = offsets_hz.windows(2).map(|p| p[1] - p[0]).collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    let mut best = (0usize, steps[0]);
    let mut i = 0;
    while i < steps.len() {
        let tol = 1e-6 * steps[i];
        let j = i + steps[i..]
            .iter()
            .take_while(|s| (**s - steps[i]).abs() <= tol)
            .count();
        if j - i > best.0 {
            best = (j - i, steps[i]);
        }
        i = j;
    }
    Some(best.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csi::Bandwidth;

    #[test]
    fn ht40_gives_spotfis_30_by_32_matrix() {
        let l = SmoothingLayout::new(&Bandwidth::Ht40.subcarrier_offsets_hz(), 3, 2, 15).unwrap();
        assert_eq!((l.rows(), l.cols()), (30, 32));
        assert_eq!(l.step_hz(), 1.25e6);
    }

    #[test]
    fn ht20_windows_stay_inside_the_uniform_runs() {
        let offsets = Bandwidth::Ht20.subcarrier_offsets_hz();
        let l = SmoothingLayout::new(&offsets, 3, 2, 8).unwrap();
        assert_eq!((l.rows(), l.cols()), (16, 30));
        assert_eq!(l.step_hz(), 625e3);
        for &(_, k0) in &l.columns {
            for k in k0..k0 + 7 {
                assert!(
                    (offsets[k + 1] - offsets[k] - 625e3).abs() < 1e-3,
                    "window at {k0}"
                );
            }
        }
        // 15 subcarriers fit only the run −1…27 (15 long), once: 2 antenna shifts, 2 columns.
        let l15 = SmoothingLayout::new(&offsets, 3, 2, 15).unwrap();
        assert_eq!(l15.cols(), 2);
        assert!(SmoothingLayout::new(&offsets, 3, 2, 16).is_err());
    }

    #[test]
    fn fill_places_each_window_antenna_major() {
        let offsets = Bandwidth::Ht40.subcarrier_offsets_hz();
        let l = SmoothingLayout::new(&offsets, 3, 2, 15).unwrap();
        let csi: Vec<Complex64> = (0..90).map(|i| Complex64::new(i as f64, 0.0)).collect();
        let mut x = DMatrix::zeros(1, 1);
        l.fill(&csi, &mut x).unwrap();
        // Column 17 = antenna shift 1, subcarrier shift 1: row m·15 + w holds csi[(1+m)·30 + 1 + w].
        for m in 0..2 {
            for w in 0..15 {
                assert_eq!(x[(m * 15 + w, 17)].re, ((1 + m) * 30 + 1 + w) as f64);
            }
        }
        assert!(l.fill(&csi[..89], &mut x).is_err());
    }

    #[test]
    fn bad_layouts_are_errors() {
        let offsets = Bandwidth::Ht40.subcarrier_offsets_hz();
        assert!(SmoothingLayout::new(&offsets, 3, 4, 15).is_err());
        assert!(SmoothingLayout::new(&offsets, 3, 0, 15).is_err());
        assert!(SmoothingLayout::new(&offsets, 3, 2, 1).is_err());
        assert!(SmoothingLayout::new(&[0.0, 0.0, 1.0], 3, 2, 2).is_err());
        assert!(SmoothingLayout::new(&[0.0], 3, 2, 2).is_err());
    }
}
