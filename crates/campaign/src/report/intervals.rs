//! Confidence intervals for campaign results: a Student-t interval on the mean of per-seed
//! values, the Wilson score interval on a binomial proportion, and quantile bands of curves.
//! The distributions come from `statrs`.

use savme_plot::Band;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

/// The confidence level of every interval savme reports.
pub const LEVEL: f64 = 0.95;

/// A point estimate with a two-sided 95 % interval.
///
/// ```
/// use savme_campaign::report::intervals::Interval;
/// let i = Interval::t_mean(&[1.0, 2.0, 3.0]).unwrap();
/// assert_eq!(i.mean, 2.0);
/// // t(0.975; 2) = 4.303, s = 1, n = 3: half-width 4.303 / √3 = 2.484.
/// assert!((i.hi.unwrap() - 4.484).abs() < 1e-3);
/// assert!(Interval::t_mean(&[5.0]).unwrap().lo.is_none()); // one seed: no interval
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Interval {
    /// The estimate (the mean of the values, or the pooled proportion).
    pub mean: f64,
    /// Lower bound (None when it cannot be computed: a single value).
    pub lo: Option<f64>,
    /// Upper bound.
    pub hi: Option<f64>,
    /// Number of values (seeds) or of Bernoulli trials behind the estimate.
    pub n: u64,
}

impl Interval {
    /// The mean of `values` with a Student-t 95 % interval (n − 1 degrees of freedom); None
    /// for no values. Non-finite values are left out (a speedup undefined in one seed).
    pub fn t_mean(values: &[f64]) -> Option<Interval> {
        let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        let n = v.len();
        if n == 0 {
            return None;
        }
        let mean = v.iter().sum::<f64>() / n as f64;
        if n == 1 {
            return Some(Interval {
                mean,
                lo: None,
                hi: None,
                n: 1,
            });
        }
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        let t = StudentsT::new(0.0, 1.0, (n - 1) as f64)
            .map(|d| d.inverse_cdf(0.5 + LEVEL / 2.0))
            .unwrap_or(f64::NAN);
        let half = t * (var / n as f64).sqrt();
        Some(Interval {
            mean,
            lo: Some(mean - half),
            hi: Some(mean + half),
            n: n as u64,
        })
    }

    /// The Wilson score 95 % interval of `k` successes in `n` Bernoulli trials (well-behaved
    /// near 0 and 1, unlike the normal approximation); None for `n = 0`.
    ///
    /// ```
    /// use savme_campaign::report::intervals::Interval;
    /// let w = Interval::wilson(0, 20).unwrap();
    /// assert_eq!(w.mean, 0.0);
    /// assert!(w.lo.unwrap().abs() < 1e-12);
    /// assert!((w.hi.unwrap() - 0.1611).abs() < 1e-3); // never a zero-width interval at 0
    /// ```
    pub fn wilson(k: u64, n: u64) -> Option<Interval> {
        if n == 0 {
            return None;
        }
        let z = z_value();
        let (nf, p) = (n as f64, k.min(n) as f64 / n as f64);
        let z2 = z * z;
        let centre = (p + z2 / (2.0 * nf)) / (1.0 + z2 / nf);
        let half = z / (1.0 + z2 / nf) * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
        Some(Interval {
            mean: p,
            lo: Some((centre - half).max(0.0)),
            hi: Some((centre + half).min(1.0)),
            n,
        })
    }

    /// True when `x` lies inside the interval (bounds included); false without bounds.
    pub fn contains(&self, x: f64) -> bool {
        matches!((self.lo, self.hi), (Some(lo), Some(hi)) if lo <= x && x <= hi)
    }

    /// `mean [lo, hi]` with `digits` decimals (the mean alone without bounds).
    pub fn show(&self, digits: usize) -> String {
        match (self.lo, self.hi) {
            (Some(lo), Some(hi)) => {
                format!("{:.digits$} [{lo:.digits$}, {hi:.digits$}]", self.mean)
            }
            _ => format!("{:.digits$}", self.mean),
        }
    }
}

/// The two-sided standard-normal quantile of [`LEVEL`] (1.95996…).
pub fn z_value() -> f64 {
    Normal::standard().inverse_cdf(0.5 + LEVEL / 2.0)
}

/// The `q`-quantile (0 ≤ q ≤ 1) of `values` by linear interpolation between order statistics
/// (type 7, as R and NumPy default); None for no values.
///
/// ```
/// use savme_campaign::report::intervals::quantile;
/// assert_eq!(quantile(&[3.0, 1.0, 2.0], 0.5), Some(2.0));
/// assert_eq!(quantile(&[1.0, 2.0], 0.25), Some(1.25));
/// ```
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let h = (v.len() - 1) as f64 * q.clamp(0.0, 1.0);
    let (i, frac) = (h.floor() as usize, h - h.floor());
    let next = v.get(i + 1).copied().unwrap_or(v[i]);
    Some(v[i] + frac * (next - v[i]))
}

/// The median, minimum and maximum of several curves (each a function of x) at each point of
/// `grid`: what a repeated campaign's figures draw (savme-plot's [`Band`]).
///
/// ```
/// use savme_campaign::report::intervals::band;
/// let (a, b, c) = (|x: f64| x, |x: f64| 2.0 * x, |x: f64| 4.0 * x);
/// let band = band(&[0.0, 1.0], &[&a, &b, &c]);
/// assert_eq!((band.median[1], band.lo[1], band.hi[1]), (2.0, 1.0, 4.0));
/// ```
pub fn band(grid: &[f64], curves: &[&dyn Fn(f64) -> f64]) -> Band {
    let mut b = Band {
        x: grid.to_vec(),
        median: Vec::with_capacity(grid.len()),
        lo: Vec::with_capacity(grid.len()),
        hi: Vec::with_capacity(grid.len()),
    };
    for &x in grid {
        let ys: Vec<f64> = curves.iter().map(|c| c(x)).collect();
        b.median.push(quantile(&ys, 0.5).unwrap_or(0.0));
        b.lo.push(quantile(&ys, 0.0).unwrap_or(0.0));
        b.hi.push(quantile(&ys, 1.0).unwrap_or(0.0));
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_t_interval_matches_a_hand_computed_one() {
        // Five values, mean 10, s² = 2.5; t(0.975; 4) = 2.7764: half = 2.7764·√0.5 = 1.9632.
        let i = Interval::t_mean(&[8.0, 9.0, 10.0, 11.0, 12.0]).unwrap();
        assert_eq!(i.n, 5);
        assert!((i.lo.unwrap() - 8.0368).abs() < 1e-3, "{i:?}");
        assert!((i.hi.unwrap() - 11.9632).abs() < 1e-3, "{i:?}");
        assert!(Interval::t_mean(&[]).is_none());
        let with_nan = Interval::t_mean(&[1.0, f64::NAN, 3.0]).unwrap();
        assert_eq!((with_nan.mean, with_nan.n), (2.0, 2));
    }

    #[test]
    fn wilson_matches_a_hand_computed_interval() {
        // 20 of 100: Wilson 95 % = [0.1334, 0.2888] (e.g. Agresti & Coull 1998, eq. 2).
        let w = Interval::wilson(20, 100).unwrap();
        assert!((w.lo.unwrap() - 0.1334).abs() < 1e-3, "{w:?}");
        assert!((w.hi.unwrap() - 0.2888).abs() < 1e-3, "{w:?}");
        let all = Interval::wilson(50, 50).unwrap();
        assert_eq!(all.hi, Some(1.0));
        assert!(all.lo.unwrap() > 0.92 && all.lo.unwrap() < 0.94);
        assert!(Interval::wilson(0, 0).is_none());
    }

    #[test]
    fn wilson_covers_the_true_rate_about_95_percent_of_the_time() {
        // 2,000 seeded binomial draws of n = 60 at p = 0.2: coverage within 93–97 %.
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let mut covered = 0;
        for _ in 0..2000 {
            let k = (0..60).filter(|_| rng.random::<f64>() < 0.2).count() as u64;
            covered += u32::from(Interval::wilson(k, 60).unwrap().contains(0.2));
        }
        assert!(
            (1860..=1940).contains(&covered),
            "coverage {covered} / 2000"
        );
    }

    #[test]
    fn a_band_holds_the_median_and_range_of_its_curves() {
        let (a, b, c) = (|x: f64| x, |x: f64| 2.0 * x, |x: f64| 4.0 * x);
        let band = band(&[0.0, 1.0, 2.0], &[&a, &b, &c]);
        assert_eq!(band.median, [0.0, 2.0, 4.0]);
        assert_eq!(band.lo, [0.0, 1.0, 2.0]);
        assert_eq!(band.hi, [0.0, 4.0, 8.0]);
    }
}
