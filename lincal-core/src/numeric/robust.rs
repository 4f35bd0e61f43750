//! Robust statistics shared by the linear solve and the pipeline: the losses of `--robust`
//! (IRLS weights), the median of a χ distribution (to standardise a residual norm with `m`
//! components) and an exact, memory-light median (for robust scale estimates).

/// A robust loss (`--robust`, [`crate::calibrate::CalibrateOptions::robust`]). Each pose's residual is standardised,
/// `z = ‖g_l‖ / (σ̂·√m_l)` (`σ̂` the robust scale, `m_l` the pose's residual components), and
/// weighted by the loss's `w(z)`; the fit is repeated with the new weights until the estimate
/// stops moving.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Robust {
    /// `w = min(1, c/z)`, `c = 1.345` (95 % efficiency on Gaussian noise).
    Huber,
    /// `w = 1/(1 + (z/c)²)`, `c = 2.385` (95 % efficiency; gross errors weigh almost nothing).
    Cauchy,
}

impl Robust {
    /// The loss's name, as the command line writes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Robust::Huber => "huber",
            Robust::Cauchy => "cauchy",
        }
    }

    /// The tuning constant `c`, in robust standard deviations.
    #[must_use]
    pub fn tuning(self) -> f64 {
        match self {
            Robust::Huber => 1.345,
            Robust::Cauchy => 2.385,
        }
    }

    /// The weight of a residual of `z` robust standard deviations.
    #[must_use]
    pub fn weight(self, z: f64) -> f64 {
        let c = self.tuning();
        match self {
            Robust::Huber => {
                if z <= c {
                    1.0
                } else {
                    c / z
                }
            }
            Robust::Cauchy => 1.0 / (1.0 + (z / c) * (z / c)),
        }
    }
}

/// The median of a χ distribution with `m` degrees of freedom (σ = 1): the median residual
/// norm of a pose with `m` Gaussian residual components.
pub fn chi_median(m: usize) -> f64 {
    match m {
        0 | 1 => 0.674_489_750_196_08,
        2 => 1.177_410_022_515_47,
        3 => 1.538_172_254_455_58,
        // Wilson-Hilferty: χ²_m median ≈ m (1 − 2/(9m))³.
        _ => {
            let m = m as f64;
            (m * (1.0 - 2.0 / (9.0 * m)).powi(3)).sqrt()
        }
    }
}

/// The exact median (the element of rank `n / 2`) of `u(0), …, u(n − 1)`, with half the
/// memory of a copy: the rank is first found among the values rounded to `f32`, then among
/// the few exact values that round to the same `f32` (all of them when every value ties, as
/// on exact data).
pub fn median_of(n: usize, u: impl Fn(usize) -> f64) -> f64 {
    if n == 0 {
        return f64::NAN;
    }
    let mid = n / 2;
    #[allow(clippy::cast_possible_truncation)] // rounding to f32 is the point
    let round = |v: f64| v as f32;
    let mut coarse: Vec<f32> = (0..n).map(|l| round(u(l))).collect();
    let guess = *coarse.select_nth_unstable_by(mid, f32::total_cmp).1;
    drop(coarse);
    let below = (0..n)
        .filter(|&l| round(u(l)).total_cmp(&guess).is_lt())
        .count();
    let mut tied: Vec<f64> = (0..n)
        .map(&u)
        .filter(|&v| round(v).total_cmp(&guess).is_eq())
        .collect();
    // `below ≤ mid < below + tied.len()`, by the choice of `guess`.
    let at = mid.saturating_sub(below).min(tied.len().saturating_sub(1));
    tied.select_nth_unstable_by(at, f64::total_cmp);
    tied.get(at).copied().unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};

    #[test]
    fn median_of_is_the_exact_median() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for n in [10, 11, 64, 1001] {
            // Values closer together than one f32 step, exact ties, and a far cluster.
            let v: Vec<f64> = (0..n)
                .map(|i| {
                    let far = if i % 7 == 0 { 1.0 } else { 0.0 };
                    1.0 + f64::from(rng.gen_range(0..50u32)) * 1e-12 + far
                })
                .collect();
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            assert_eq!(super::median_of(n, |l| v[l]), sorted[n / 2], "n = {n}");
        }
    }
}
