//! Peaks of the MUSIC spectrum: 2-D local maxima on the grid, refined off the grid by shrinking
//! parabolic steps along each axis on the exact spectrum, then screened for credibility.

use num_complex::Complex64;

use super::{AoaWindow, MAX_WINDOW_ANTENNAS, Music, Spectrum};
use crate::aoa::peak::Peak;
use crate::aoa::subspace::Subspace;

/// Refinement rounds; each halves the step, so 6 rounds reach 1/64 of a grid step.
const REFINE_ROUNDS: usize = 6;
/// Grid minima whose residual exceeds this multiple of the credibility bound are not refined.
const GRID_SLACK: f64 = 3.0;
/// Two peaks whose sines differ by a multiple of `λ/d` within this are aliases (refined peaks
/// agree to a small fraction of a degree).
const ALIAS_SINE_TOLERANCE: f64 = 0.01;

impl Music {
    /// The credible peaks of a packet inside `window`, refined, lowest ToF first. Empty when the
    /// window holds no credible peak (see [`super::MusicConfig::max_residual`]).
    pub fn peaks(&self, subspace: &Subspace, window: AoaWindow) -> Vec<Peak> {
        let spectrum = self.spectrum(subspace, window);
        self.peaks_of(subspace, &spectrum, window)
    }

    /// The credible peaks of an already computed `spectrum` (see [`Music::peaks`]).
    pub fn peaks_of(
        &self,
        subspace: &Subspace,
        spectrum: &Spectrum,
        window: AoaWindow,
    ) -> Vec<Peak> {
        // Refining costs more than the grid; a grid minimum this far above the credibility bound
        // cannot refine below it (peaks span several grid steps).
        let loose = (GRID_SLACK * self.config.max_residual).min(1.0);
        let mut peaks: Vec<Peak> = grid_minima(spectrum, window, loose)
            .into_iter()
            .map(|(ia, it)| self.refine(subspace, spectrum.aoa_rad[ia], spectrum.tof_s[it], window))
            .collect();
        // Two grid minima may climb to the same peak.
        let (da, dt) = (
            0.25 * self.config.aoa_step_deg.to_radians(),
            0.25 * self.config.tof_step_s,
        );
        let mut unique: Vec<Peak> = Vec::with_capacity(peaks.len());
        peaks.sort_by(|a, b| a.residual.total_cmp(&b.residual));
        for p in peaks {
            if !unique
                .iter()
                .any(|u| (u.aoa_rad - p.aoa_rad).abs() < da && (u.tof_s - p.tof_s).abs() < dt)
            {
                unique.push(p);
            }
        }
        let Some(strongest) = unique.first().map(|p| p.residual) else {
            return unique;
        };
        let floor = strongest * 10f64.powf(self.config.max_below_strongest_db / 10.0);
        unique.retain(|p| p.residual <= self.config.max_residual && p.residual <= floor);
        let mut unique = self.one_per_alias_family(unique, window);
        unique.sort_by(|a, b| a.tof_s.total_cmp(&b.tof_s));
        unique
    }

    /// On an array wider than λ/2 the members of an alias family (same ToF, sines a multiple of
    /// `λ/d` apart) are one path seen at several angles: the member nearest the window's centre
    /// stands for the family ([`crate::rig::ArrayGeometry::aliases_rad`] lists the others).
    fn one_per_alias_family(&self, peaks: Vec<Peak>, window: AoaWindow) -> Vec<Peak> {
        let period = self.geometry.alias_period(self.center_freq_hz);
        if period >= 2.0 || peaks.len() < 2 {
            return peaks;
        }
        let centre = 0.5 * (window.min_rad + window.max_rad);
        let same_family = |a: &Peak, b: &Peak| {
            let k = (a.aoa_rad.sin() - b.aoa_rad.sin()) / period;
            (a.tof_s - b.tof_s).abs() <= self.config.tof_step_s
                && k.round() != 0.0
                && (k - k.round()).abs() * period <= ALIAS_SINE_TOLERANCE
        };
        let mut kept: Vec<Peak> = Vec::with_capacity(peaks.len());
        for p in peaks {
            match kept.iter_mut().find(|k| same_family(k, &p)) {
                Some(k) if (p.aoa_rad - centre).abs() < (k.aoa_rad - centre).abs() => *k = p,
                Some(_) => {}
                None => kept.push(p),
            }
        }
        kept
    }

    /// Shrinking parabolic steps in θ then τ from a grid point, staying inside `window` and the
    /// ToF grid.
    fn refine(&self, subspace: &Subspace, aoa_rad: f64, tof_s: f64, window: AoaWindow) -> Peak {
        let ms = self.layout.antennas_per_window();
        let mut g = [Complex64::new(0.0, 0.0); MAX_WINDOW_ANTENNAS * MAX_WINDOW_ANTENNAS];
        let g = &mut g[..ms * ms];
        let (t_lo, t_hi) = (
            self.tof_s.first().copied().unwrap_or(tof_s),
            self.tof_s.last().copied().unwrap_or(tof_s),
        );
        let (mut theta, mut tau) = (aoa_rad, tof_s);
        let mut h_theta = self.config.aoa_step_deg.to_radians();
        let mut h_tau = self.config.tof_step_s;
        for _ in 0..REFINE_ROUNDS {
            self.gram_at(&subspace.basis, tau, g);
            let along_theta =
                |t: f64| self.residual_with(g, t.clamp(window.min_rad, window.max_rad));
            theta = (theta + parabolic_step(along_theta, theta, along_theta(theta), h_theta))
                .clamp(window.min_rad, window.max_rad);
            // At `tau` itself the gram is the one just computed.
            let at_tau = self.residual_with(g, theta);
            let along_tau = |t: f64| self.residual_at(subspace, theta, t.clamp(t_lo, t_hi));
            tau = (tau + parabolic_step(along_tau, tau, at_tau, h_tau)).clamp(t_lo, t_hi);
            h_theta *= 0.5;
            h_tau *= 0.5;
        }
        Peak {
            aoa_rad: theta,
            tof_s: tau,
            residual: self.residual_at(subspace, theta, tau),
        }
    }
}

/// The step toward the minimum of the parabola through `f(x − h), f(x) = f0, f(x + h)`, limited
/// to ±h (a full step toward the lower side when the three points are not convex).
fn parabolic_step(f: impl Fn(f64) -> f64, x: f64, f0: f64, h: f64) -> f64 {
    let (fm, fp) = (f(x - h), f(x + h));
    let curvature = fm - 2.0 * f0 + fp;
    if curvature > 0.0 {
        (0.5 * h * (fm - fp) / curvature).clamp(-h, h)
    } else if fm < f0.min(fp) {
        -h
    } else if fp < f0 {
        h
    } else {
        0.0
    }
}

/// Grid points (AoA index, ToF index) with a residual at most `max_residual` that is a local
/// minimum over their 8 neighbours. Points on the ToF edges never count (the true peak may lie
/// beyond); points on the AoA edges count only where the edge is ±90° itself, not the edge of a
/// search window.
fn grid_minima(s: &Spectrum, window: AoaWindow, max_residual: f64) -> Vec<(usize, usize)> {
    let (na, nt) = (s.aoa_rad.len(), s.tof_s.len());
    if na == 0 || nt < 3 || s.residual.len() != na * nt {
        return Vec::new();
    }
    let half_pi = std::f64::consts::FRAC_PI_2 - 1e-9;
    let first_ok = s.aoa_rad[0] <= -half_pi && window.min_rad <= -half_pi;
    let last_ok = s.aoa_rad[na - 1] >= half_pi && window.max_rad >= half_pi;
    // Strict against earlier neighbours (the row above, the point to the left), non-strict
    // against later ones: one point per plateau. A missing neighbour (the AoA edges) passes.
    let below_row = |row: &[f64], ia: usize, v: f64, strict: bool| {
        let lo = ia.saturating_sub(1);
        let hi = (ia + 1).min(na - 1);
        row[lo..=hi]
            .iter()
            .all(|&u| if strict { v < u } else { v <= u })
    };
    let mut out = Vec::new();
    for it in 1..nt - 1 {
        let row = &s.residual[it * na..(it + 1) * na];
        // Most rows hold no point below the bound: one vectorizable pass skips them.
        if row
            .iter()
            .fold(f64::INFINITY, |m, &v| if v < m { v } else { m })
            > max_residual
        {
            continue;
        }
        let (above, below) = (
            &s.residual[(it - 1) * na..it * na],
            &s.residual[(it + 1) * na..(it + 2) * na],
        );
        let mut consider = |ia: usize| {
            let v = row[ia];
            if below_row(above, ia, v, true) && below_row(below, ia, v, false) {
                out.push((ia, it));
            }
        };
        if na == 1 {
            if first_ok && last_ok && row[0] <= max_residual {
                consider(0);
            }
            continue;
        }
        if first_ok && row[0] <= max_residual && row[0] <= row[1] {
            consider(0);
        }
        // Along the row first, without branches (most points fail), then the rows around.
        for (i, w) in row.windows(3).enumerate() {
            let v = w[1];
            if (v <= max_residual) & (v < w[0]) & (v <= w[2]) {
                consider(i + 1);
            }
        }
        if last_ok && row[na - 1] <= max_residual && row[na - 1] < row[na - 2] {
            consider(na - 1);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aoa::music::MusicConfig;
    use crate::csi::Bandwidth;
    use crate::rig::ArrayGeometry;
    use crate::rig::array::CHANNEL_64_HZ;
    use nalgebra::DMatrix;
    use num_complex::Complex64;

    #[test]
    fn grams_on_the_grid_equal_the_per_point_gram() {
        for antennas_per_window in [2, 3] {
            let config = MusicConfig {
                antennas_per_window,
                ..MusicConfig::default()
            };
            let offsets = Bandwidth::Ht20.subcarrier_offsets_hz();
            let music = Music::new(
                &config,
                ArrayGeometry::default(),
                CHANNEL_64_HZ,
                &offsets,
                15,
            )
            .unwrap();
            let rows = music.layout().rows();
            // Any three columns will do (the gram does not need them orthonormal).
            let basis = DMatrix::from_fn(rows, 3, |r, c| {
                Complex64::new(
                    (r as f64 * 0.7 + c as f64).sin(),
                    (r as f64 * 1.3 - c as f64).cos(),
                )
            });
            let grams = music.grams_on_grid(&basis);
            let ms = antennas_per_window;
            assert_eq!(grams.len(), music.tof_grid().len() * ms * ms);
            let mut g = vec![Complex64::new(0.0, 0.0); ms * ms];
            for (it, &tof) in music.tof_grid().iter().enumerate() {
                music.gram_at(&basis, tof, &mut g);
                for (a, b) in grams[it * ms * ms..][..ms * ms].iter().zip(&g) {
                    assert!(
                        (a - b).norm() < 1e-9 * (1.0 + b.norm()),
                        "τ {tof}: {a} vs {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn parabolic_step_finds_the_vertex() {
        let f = |x: f64| (x - 0.3).powi(2);
        assert!((parabolic_step(f, 0.0, f(0.0), 1.0) - 0.3).abs() < 1e-12);
        assert_eq!(parabolic_step(f, 0.0, f(0.0), 0.1), 0.1);
        // At a maximum either side is downhill: a full step.
        assert_eq!(parabolic_step(|x: f64| -x * x, 0.0, 0.0, 0.1).abs(), 0.1);
    }

    /// The 8-neighbour test written out point by point.
    fn minima_by_definition(s: &Spectrum, window: AoaWindow, bound: f64) -> Vec<(usize, usize)> {
        let (na, nt) = (s.aoa_rad.len() as i64, s.tof_s.len() as i64);
        let half_pi = std::f64::consts::FRAC_PI_2 - 1e-9;
        let edge_ok = |ia: i64| {
            (ia > 0 || (s.aoa_rad[0] <= -half_pi && window.min_rad <= -half_pi))
                && (ia < na - 1
                    || (s.aoa_rad[na as usize - 1] >= half_pi && window.max_rad >= half_pi))
        };
        let at = |ia: i64, it: i64| s.residual[(it * na + ia) as usize];
        let mut out = Vec::new();
        for it in 1..nt - 1 {
            for ia in 0..na {
                let v = at(ia, it);
                if v > bound || !edge_ok(ia) {
                    continue;
                }
                let mut is_min = true;
                for dt in -1..=1 {
                    for da in -1..=1 {
                        let ja = ia + da;
                        if (dt, da) == (0, 0) || ja < 0 || ja >= na {
                            continue;
                        }
                        let u = at(ja, it + dt);
                        let earlier = dt < 0 || (dt == 0 && da < 0);
                        is_min &= if earlier { v < u } else { v <= u };
                    }
                }
                if is_min {
                    out.push((ia as usize, it as usize));
                }
            }
        }
        out
    }

    #[test]
    fn grid_minima_follow_the_definition_on_rough_spectra() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut found = 0;
        for (na, nt) in [(1, 3), (2, 4), (5, 3), (41, 20), (181, 7)] {
            let aoa_rad: Vec<f64> = (0..na)
                .map(|i| (-90.0 + 180.0 * i as f64 / (na.max(2) - 1) as f64).to_radians())
                .collect();
            for _ in 0..20 {
                // Few levels, so plateaus (equal neighbours) are common.
                let residual = (0..na * nt)
                    .map(|_| f64::from(rng.random_range(0..6u8)) / 5.0)
                    .collect();
                let s = Spectrum {
                    aoa_rad: aoa_rad.clone(),
                    tof_s: (0..nt).map(|i| i as f64).collect(),
                    residual,
                };
                for window in [
                    AoaWindow::FULL,
                    AoaWindow {
                        min_rad: -0.5,
                        max_rad: 1.0,
                    },
                ] {
                    let want = minima_by_definition(&s, window, 0.5);
                    assert_eq!(grid_minima(&s, window, 0.5), want, "{na} × {nt}");
                    found += want.len();
                }
            }
        }
        assert!(found > 100, "the cases hold minima: {found}");
    }

    #[test]
    fn grid_minima_skip_window_edges_but_keep_endfire() {
        let aoa_rad: Vec<f64> = [-90.0f64, -89.0, -88.0]
            .iter()
            .map(|d| d.to_radians())
            .collect();
        let tof_s = vec![0.0, 1.0, 2.0];
        // Minimum at the −90° column, middle row.
        let residual = vec![0.5, 0.6, 0.7, 0.1, 0.6, 0.7, 0.5, 0.6, 0.7];
        let s = Spectrum {
            aoa_rad,
            tof_s,
            residual,
        };
        assert_eq!(grid_minima(&s, AoaWindow::FULL, 1.0), vec![(0, 1)]);
        assert!(grid_minima(&s, AoaWindow::FULL, 0.0).is_empty());
        let window = AoaWindow {
            min_rad: -89.5f64.to_radians(),
            max_rad: 0.0,
        };
        assert!(grid_minima(&s, window, 1.0).is_empty());
    }
}
