//! χ² quantiles: the estimator's acceptance and loss tests, the evaluation's consistency band.

/// Standard normal upper tail `Q(z) = P(Z > z)`, from `erfc` (Abramowitz & Stegun 7.1.26,
/// absolute error < 1.5·10⁻⁷).
fn normal_tail(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erfc = poly * (-x * x).exp();
    if z >= 0.0 {
        0.5 * erfc
    } else {
        1.0 - 0.5 * erfc
    }
}

/// The `z` with `Q(z) = alpha` (bisection; `alpha` in (0, 1), negative above 0.5).
pub fn normal_quantile(alpha: f64) -> f64 {
    if alpha > 0.5 {
        return -normal_quantile(1.0 - alpha);
    }
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if normal_tail(mid) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The χ² value with `dof` degrees of freedom exceeded with probability `alpha`
/// (Wilson–Hilferty: `(χ²/k)^{1/3}` is nearly normal with mean `1 − 2/(9k)` and variance
/// `2/(9k)`; within 1 % for k ≥ 3). `alpha` in (0, 1): `chi2_upper(k, 0.975)` is the lower
/// 2.5 % point.
pub fn chi2_upper(dof: f64, alpha: f64) -> f64 {
    let k = dof.max(1.0);
    let z = normal_quantile(alpha);
    let v = 2.0 / (9.0 * k);
    k * (1.0 - v + z * v.sqrt()).powi(3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        assert!((normal_quantile(0.05) - 1.644_85).abs() < 1e-4);
        assert!((normal_quantile(1e-3) - 3.090_23).abs() < 1e-4);
        // χ²(10) at 5 %: 18.307; χ²(100) at 0.1 %: 149.449.
        assert!((chi2_upper(10.0, 0.05) - 18.307).abs() / 18.307 < 0.01);
        assert!((chi2_upper(100.0, 1e-3) - 149.449).abs() / 149.449 < 0.005);
        // Lower points: χ²(60) at 97.5 % exceeded: 40.482; χ²(3): 0.2158 (Wilson–Hilferty is
        // coarse at 3 dof in the lower tail).
        assert!((normal_quantile(0.975) + 1.959_96).abs() < 1e-4);
        assert!((chi2_upper(60.0, 0.975) - 40.482).abs() / 40.482 < 0.01);
        assert!((chi2_upper(3.0, 0.975) - 0.2158).abs() < 0.04);
    }
}
