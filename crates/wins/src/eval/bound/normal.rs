//! The flight's information matrix over keyframe states, IMU biases, AP positions and the
//! barometer's offset, with the gauge (the first keyframe's position and heading) taken out.

use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, SMatrix, Vector3};

use super::model::{Mat9, POS, THETA};

/// Where each unknown sits in the information matrix.
#[derive(Clone, Copy, Debug)]
pub(super) struct Layout {
    /// Keyframes.
    pub keyframes: usize,
    /// APs.
    pub aps: usize,
    /// Whether a barometer offset is an unknown.
    pub baro: bool,
}

/// Index of the first bias unknown.
const BIAS: usize = 0;
/// Unknowns before the first keyframe's kept ones: the 6 biases.
const KEYFRAMES: usize = 6;
/// The first keyframe keeps only its tilt (2) and velocity (3): its position and its heading
/// are the gauge that the scoring's alignment leaves free.
const FIRST_KEPT: usize = 5;

impl Layout {
    /// Number of unknowns.
    pub fn len(&self) -> usize {
        KEYFRAMES
            + FIRST_KEPT
            + 9 * self.keyframes.saturating_sub(1)
            + 3 * self.aps
            + usize::from(self.baro)
    }

    /// The index of component `j` (0..9) of keyframe `k`'s error state, in the first keyframe's
    /// world-aligned attitude (see [`Normal::add`]); `None` for the gauge.
    pub fn keyframe(&self, k: usize, j: usize) -> Option<usize> {
        if k == 0 {
            match j {
                0 | 1 => Some(KEYFRAMES + j),
                3..=5 => Some(KEYFRAMES + j - 1),
                _ => None,
            }
        } else {
            Some(KEYFRAMES + FIRST_KEPT + 9 * (k - 1) + j)
        }
    }

    /// The index of bias component `j` (gyro 0..3, accelerometer 3..6).
    pub fn bias(&self, j: usize) -> usize {
        BIAS + j
    }

    /// The index of AP `i`'s coordinate `j`.
    pub fn ap(&self, i: usize, j: usize) -> usize {
        KEYFRAMES + FIRST_KEPT + 9 * self.keyframes.saturating_sub(1) + 3 * i + j
    }

    /// The index of the barometer's offset.
    pub fn baro_offset(&self) -> Option<usize> {
        self.baro.then(|| self.len() - 1)
    }
}

/// A measurement's rows over the unknowns it touches: keyframe blocks (9 columns each, in the
/// keyframe's own error state), the biases and single unknowns.
#[derive(Clone, Debug, Default)]
pub(super) struct Rows<const M: usize> {
    /// `(keyframe, ∂r/∂δx_k)`.
    pub keyframes: Vec<(usize, SMatrix<f64, M, 9>)>,
    /// `∂r/∂δb`.
    pub bias: Option<SMatrix<f64, M, 6>>,
    /// `(index, ∂r/∂x_index)`.
    pub singles: Vec<(usize, SMatrix<f64, M, 1>)>,
}

/// The information matrix being summed.
#[derive(Clone, Debug)]
pub(super) struct Normal {
    layout: Layout,
    /// `R̂₀`: the first keyframe's attitude, whose world-frame heading is the gauge.
    first_attitude: Matrix3<f64>,
    info: DMatrix<f64>,
}

impl Normal {
    /// Zero information over `layout`; the first keyframe at attitude `first_world_from_body`.
    pub fn new(layout: Layout, first_world_from_body: &Rotation3<f64>) -> Self {
        let n = layout.len();
        Self {
            layout,
            first_attitude: *first_world_from_body.matrix(),
            info: DMatrix::zeros(n, n),
        }
    }

    /// The layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Adds `Jᵀ W J` of a measurement with rows `rows` and information `w`. The first keyframe's
    /// attitude columns are turned into the world frame (`δθ_body = R̂₀ᵀ δφ_world`) so that its
    /// heading (`δφ_z`) can be left out as the gauge.
    pub fn add<const M: usize>(&mut self, rows: &Rows<M>, w: &SMatrix<f64, M, M>) {
        let mut cols: Vec<(usize, SMatrix<f64, M, 1>)> = Vec::new();
        for (k, h) in &rows.keyframes {
            let mut h = *h;
            if *k == 0 {
                let theta = h.fixed_view::<M, 3>(0, THETA) * self.first_attitude.transpose();
                h.fixed_view_mut::<M, 3>(0, THETA).copy_from(&theta);
            }
            for j in 0..9 {
                if let Some(i) = self.layout.keyframe(*k, j) {
                    cols.push((i, h.column(j).into_owned()));
                }
            }
        }
        if let Some(h) = &rows.bias {
            for j in 0..6 {
                cols.push((self.layout.bias(j), h.column(j).into_owned()));
            }
        }
        cols.extend(rows.singles.iter().copied());
        let weighted: Vec<SMatrix<f64, M, 1>> = cols.iter().map(|(_, c)| w * c).collect();
        for (a, (ia, _)) in cols.iter().enumerate() {
            for (ib, cb) in &cols {
                self.info[(*ia, *ib)] += (weighted[a].transpose() * cb)[(0, 0)];
            }
        }
    }

    /// Adds `1/σ²` on one unknown.
    pub fn add_prior(&mut self, index: usize, sigma: f64) {
        self.info[(index, index)] += 1.0 / (sigma * sigma);
    }

    /// The covariance of the columns `wanted` (a lower bound on any unbiased estimator's),
    /// `None` when the information is singular.
    pub fn covariance_of(self, wanted: &[usize]) -> Option<DMatrix<f64>> {
        let n = self.info.nrows();
        // Scale to unit diagonal so the factorization sees a well-conditioned matrix.
        let scale = DVector::from_iterator(
            n,
            (0..n).map(|i| 1.0 / self.info[(i, i)].max(f64::MIN_POSITIVE).sqrt()),
        );
        let mut scaled = self.info;
        for j in 0..n {
            for i in 0..n {
                scaled[(i, j)] *= scale[i] * scale[j];
            }
        }
        let chol = scaled.cholesky()?;
        let mut rhs = DMatrix::zeros(n, wanted.len());
        for (c, &i) in wanted.iter().enumerate() {
            rhs[(i, c)] = scale[i];
        }
        let x = chol.solve(&rhs);
        let mut out = DMatrix::zeros(wanted.len(), wanted.len());
        for (r, &i) in wanted.iter().enumerate() {
            for c in 0..wanted.len() {
                out[(r, c)] = scale[i] * x[(i, c)];
            }
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }
}

/// The expected squared error left by the scoring's alignment (a heading and a translation,
/// [`crate::eval::AlignMode::PosYaw`]), summed over the positions: `tr((I − P) Σ (I − P))` with
/// `P` the projection onto what the alignment can absorb, linearized at the true positions
/// (`δp_k = t + ψ e_z × p_k`).
pub(super) fn aligned_sum_of_squares(sigma: &DMatrix<f64>, positions: &[Vector3<f64>]) -> f64 {
    let n = positions.len();
    if n == 0 {
        return 0.0;
    }
    let centroid = positions.iter().sum::<Vector3<f64>>() / n as f64;
    let mut g = DMatrix::zeros(3 * n, 4);
    for (k, p) in positions.iter().enumerate() {
        let yaw = Vector3::z().cross(&(p - centroid));
        for a in 0..3 {
            g[(3 * k + a, a)] = 1.0;
            g[(3 * k + a, 3)] = yaw[a];
        }
    }
    let gtg = g.transpose() * &g;
    // Without a horizontal extent the heading is not absorbed: drop its column.
    let keep = if gtg[(3, 3)] > 1e-9 * n as f64 { 4 } else { 3 };
    let g = g.columns(0, keep).into_owned();
    let gtg = g.transpose() * &g;
    let Some(inv) = gtg.try_inverse() else {
        return sigma.trace();
    };
    let proj = &g * inv * g.transpose();
    let residual = DMatrix::identity(3 * n, 3 * n) - proj;
    (&residual * sigma * &residual).trace()
}

/// The rows of the position block of one keyframe.
pub(super) fn position_indices(layout: &Layout, k: usize) -> [Option<usize>; 3] {
    [0, 1, 2].map(|a| layout.keyframe(k, POS + a))
}

/// `δx_{k+1} − Φ δx_k − Γ δb`: the IMU's link between two keyframes, with information `Q⁻¹`.
pub(super) fn link_rows(k: usize, phi: &Mat9, gamma: &super::model::Mat9x6) -> Rows<9> {
    Rows {
        keyframes: vec![(k, -phi), (k + 1, Mat9::identity())],
        bias: Some(-gamma),
        singles: Vec::new(),
    }
}
