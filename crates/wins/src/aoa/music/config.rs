//! MUSIC's settings (the `[aoa.music]` table of a configuration) and their ranges.

use serde::{Deserialize, Serialize};

use super::MAX_WINDOW_ANTENNAS;
use crate::aoa::subspace::PathCount;
use crate::check::{Problems, num};
use crate::csi::NUM_SUBCARRIERS;

/// MUSIC settings. Defaults follow SpotFi where it is exact (see `super::smoothing`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MusicConfig {
    /// Antennas per smoothing window, `M_s` (SpotFi: 2 of 3).
    pub antennas_per_window: usize,
    /// Subcarriers per window on HT20 (its uniform runs hold 14 and 15).
    pub subcarriers_per_window_ht20: usize,
    /// Subcarriers per window on HT40 (SpotFi: 15, giving 30 × 32).
    pub subcarriers_per_window_ht40: usize,
    /// Forward–backward averaging (real-valued eigendecomposition); needs calibrated chains.
    pub forward_backward: bool,
    /// How many eigenvectors are paths.
    pub paths: PathCount,
    /// AoA grid step, degrees (the grid spans −90°…90°).
    pub aoa_step_deg: f64,
    /// First ToF of the grid, s (sanitized ToFs are relative and can be negative).
    pub tof_min_s: f64,
    /// Last ToF of the grid, s. `tof_max_s − tof_min_s` must stay below the unambiguous span
    /// `1/Δf` (1.6 µs on HT20, 0.8 µs on HT40).
    pub tof_max_s: f64,
    /// ToF grid step, s.
    pub tof_step_s: f64,
    /// A peak is credible when its residual is at most this (0.1 = 10 dB pseudo-spectrum).
    pub max_residual: f64,
    /// ... and its pseudo-spectrum within this many dB of the packet's strongest peak.
    pub max_below_strongest_db: f64,
}

/// Finest AoA grid step, degrees (3601 angles): finer only costs time, the peaks are refined off
/// the grid.
pub const MIN_AOA_STEP_DEG: f64 = 0.05;
/// Finest ToF grid step, s.
pub const MIN_TOF_STEP_S: f64 = 0.5e-9;
/// Most (AoA, ToF) grid points: a packet's spectrum holds one `f64` per point (8 MB here).
pub const MAX_GRID_POINTS: usize = 1_000_000;
/// The ToF span must stay below HT40's unambiguous span `1/Δf` (Δf = 1.25 MHz between the Intel
/// 5300's reported HT40 subcarriers), s; HT20's is twice that.
pub const MAX_TOF_SPAN_S: f64 = 800e-9;

impl MusicConfig {
    /// Every setting in its range, under `prefix`: the grids bounded (so a packet's spectrum is
    /// bounded in time and memory), the ToF span below HT40's unambiguous 800 ns.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        let n = self.antennas_per_window;
        p.require(
            (2..=MAX_WINDOW_ANTENNAS).contains(&n),
            prefix,
            "antennas_per_window",
            format!("{n} is not in [2, {MAX_WINDOW_ANTENNAS}]"),
        );
        for (key, w) in [
            (
                "subcarriers_per_window_ht20",
                self.subcarriers_per_window_ht20,
            ),
            (
                "subcarriers_per_window_ht40",
                self.subcarriers_per_window_ht40,
            ),
        ] {
            p.require(
                (1..=NUM_SUBCARRIERS).contains(&w),
                prefix,
                key,
                format!("{w} is not in [1, {NUM_SUBCARRIERS}]"),
            );
        }
        p.require(
            self.paths.max_paths >= 1,
            prefix,
            "paths.max_paths",
            "must be ≥ 1",
        );
        p.in_range(
            prefix,
            "paths.floor_margin_db",
            self.paths.floor_margin_db,
            0.0,
            100.0,
        );
        p.in_range(
            prefix,
            "paths.max_below_largest_db",
            self.paths.max_below_largest_db,
            0.0,
            300.0,
        );
        p.in_range(
            prefix,
            "aoa_step_deg",
            self.aoa_step_deg,
            MIN_AOA_STEP_DEG,
            30.0,
        );
        p.in_range(
            prefix,
            "tof_step_s",
            self.tof_step_s,
            MIN_TOF_STEP_S,
            100e-9,
        );
        p.in_range(
            prefix,
            "tof_min_s",
            self.tof_min_s,
            -MAX_TOF_SPAN_S,
            MAX_TOF_SPAN_S,
        );
        let span = self.tof_max_s - self.tof_min_s;
        p.require(
            span.is_finite() && span > 0.0 && span < MAX_TOF_SPAN_S,
            prefix,
            "tof_max_s",
            format!(
                "the ToF span tof_max_s − tof_min_s = {span:e} s must be > 0 and below the \
                 unambiguous {MAX_TOF_SPAN_S:e} s of HT40"
            ),
        );
        if let Some(points) = self.grid_points()
            && points > MAX_GRID_POINTS
        {
            p.push(
                prefix,
                "aoa_step_deg",
                format!(
                    "aoa_step_deg {} and tof_step_s {} give {} grid points ({} AoA × {} ToF); \
                     at most {} (a coarser step on either axis)",
                    num(self.aoa_step_deg),
                    num(self.tof_step_s),
                    num(points as f64),
                    self.aoa_points(),
                    self.tof_points(),
                    num(MAX_GRID_POINTS as f64),
                ),
            );
        }
        p.in_range(
            prefix,
            "max_residual",
            self.max_residual,
            f64::MIN_POSITIVE,
            1.0,
        );
        p.in_range(
            prefix,
            "max_below_strongest_db",
            self.max_below_strongest_db,
            0.0,
            100.0,
        );
        p
    }
}

impl MusicConfig {
    /// AoA grid points over −90°…90° (meaningful for a step in range).
    pub fn aoa_points(&self) -> usize {
        (180.0 / self.aoa_step_deg).round() as usize + 1
    }

    /// ToF grid points from `tof_min_s` to `tof_max_s` (meaningful for a step and span in range).
    pub fn tof_points(&self) -> usize {
        ((self.tof_max_s - self.tof_min_s) / self.tof_step_s).floor() as usize + 1
    }

    /// The grid's points when both steps and the span are in range, else `None` (those are
    /// problems of their own).
    fn grid_points(&self) -> Option<usize> {
        let span = self.tof_max_s - self.tof_min_s;
        let steps_ok = self.aoa_step_deg.is_finite()
            && self.aoa_step_deg >= MIN_AOA_STEP_DEG
            && self.tof_step_s.is_finite()
            && self.tof_step_s >= MIN_TOF_STEP_S
            && span.is_finite()
            && span > 0.0
            && span < MAX_TOF_SPAN_S;
        steps_ok.then(|| self.aoa_points().saturating_mul(self.tof_points()))
    }
}

impl Default for MusicConfig {
    fn default() -> Self {
        Self {
            antennas_per_window: 2,
            subcarriers_per_window_ht20: 8,
            subcarriers_per_window_ht40: 15,
            forward_backward: true,
            paths: PathCount::default(),
            aoa_step_deg: 1.0,
            tof_min_s: -200e-9,
            tof_max_s: 595e-9,
            tof_step_s: 5e-9,
            max_residual: 0.1,
            max_below_strongest_db: 10.0,
        }
    }
}
