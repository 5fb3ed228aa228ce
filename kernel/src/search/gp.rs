//! [`EliteMixture::rho_model`](crate::EliteMixture::rho_model)'s Gaussian process of the
//! robustness ρ: the choice of the runs it sees ([`lowest`]) and its fit and evaluation
//! ([`Gp`]).
//!
//! Every draw depends on these numbers bit for bit, so they are computed as they were first
//! written (issue 42), only faster: each sum of the Cholesky factorisation and of the
//! triangular solves adds the same products in the same order from the same start as the
//! original row-by-row loops did, but the factor is stored by column, so that the sums of one
//! column (or of one solve step) for every row below it run side by side in vector registers
//! instead of one dependent addition at a time; and the runs nearest a point are selected in
//! linear time instead of by sorting the whole archive, in the same order (ties by archive
//! position, as the stable sort kept them). `kernel/tests/rho_model.rs`
//! (`the_rho_model_asks_what_it_asked_over_a_long_run`) holds the asks of long seeded runs to
//! a digest taken before the change.

use std::cmp::Ordering;

/// Most runs the process is fitted to.
pub(super) const GP_POINTS: usize = 64;

/// The GP's nugget (noise variance in standardised units).
const NUGGET: f64 = 1e-4;

/// The start of every sum below: what `Iterator::sum` of `f64` starts from (−0.0 in current
/// Rust), so that an empty or all-zero sum is the same number the original iterator sums gave.
fn sum_start() -> f64 {
    std::iter::empty::<f64>().sum()
}

/// The (at most [`GP_POINTS`]) entries `(key, position)` of `keyed` with the smallest keys, in
/// ascending key order, ties by position — what a stable sort by key of the items in position
/// order, then truncation, keeps — found in linear time. Keys are compared with `total_cmp`.
pub(super) fn lowest(mut keyed: Vec<(f64, usize)>) -> Vec<(f64, usize)> {
    let order = |a: &(f64, usize), b: &(f64, usize)| -> Ordering {
        a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
    };
    if keyed.len() > GP_POINTS {
        keyed.select_nth_unstable_by(GP_POINTS - 1, order);
        keyed.truncate(GP_POINTS);
    }
    keyed.sort_unstable_by(order);
    keyed
}

/// A Gaussian process regression of the robustness ρ (squared-exponential kernel of a fixed
/// length scale in the unit cube, ρ standardised, a small nugget), as Bayesian optimisation
/// fits it: its probability that ρ < 0 at a point leads
/// [`EliteMixture::rho_model`](crate::EliteMixture::rho_model).
pub(super) struct Gp<'p> {
    points: Vec<(&'p [f64], f64)>,
    /// Cholesky factor L of the kernel matrix, by column: `cols[j·k + i]` = L[i][j] (i ≥ j).
    cols: Vec<f64>,
    /// K⁻¹ z, z the standardised ρ.
    alpha: Vec<f64>,
    /// −½ / ℓ².
    inv: f64,
    /// ρ = 0 in standardised units.
    zero: f64,
}

impl<'p> Gp<'p> {
    /// Fits `(u, ρ)`; None if the kernel matrix is not positive definite or the weights are
    /// not finite.
    pub(super) fn fit(points: Vec<(&'p [f64], f64)>, length: f64) -> Option<Self> {
        let n = points.len() as f64;
        let mean = points.iter().map(|p| p.1).sum::<f64>() / n;
        let var = points.iter().map(|p| (p.1 - mean).powi(2)).sum::<f64>() / n;
        let scale = if var > 0.0 { var.sqrt() } else { 1.0 };
        let inv = -0.5 / (length * length);
        let cols = cholesky(&points, inv)?;
        let k = points.len();
        let z: Vec<f64> = points.iter().map(|p| (p.1 - mean) / scale).collect();
        let y = forward(&cols, k, &z);
        let alpha = backward(&cols, k, &y);
        let zero = -mean / scale;
        alpha.iter().all(|a| a.is_finite()).then_some(Gp {
            points,
            cols,
            alpha,
            inv,
            zero,
        })
    }

    /// P(ρ < 0) at `u` under the posterior.
    pub(super) fn failure_probability(&self, u: &[f64]) -> f64 {
        let k = self.points.len();
        let ks: Vec<f64> = self
            .points
            .iter()
            .map(|p| (squared_distance(p.0, u) * self.inv).exp())
            .collect();
        let mu: f64 = ks.iter().zip(&self.alpha).map(|(a, b)| a * b).sum();
        let v = forward(&self.cols, k, &ks);
        let var = (1.0 + NUGGET - v.iter().map(|x| x * x).sum::<f64>()).max(1e-12);
        let t = (self.zero - mu) / var.sqrt();
        0.5 * statrs::function::erf::erfc(-t / std::f64::consts::SQRT_2)
    }
}

/// The Cholesky factor (by column) of the kernel matrix of `points` (`exp(inv · d²)`, plus the
/// nugget on the diagonal); None if a pivot is not positive and finite.
///
/// L[i][j] = (K[i][j] − Σ_{l<j} L[i][l]·L[j][l]) / L[j][j], the sum taken in ascending l from
/// [`sum_start`], exactly as the row-by-row loop computed it; here column j's sums for every
/// row i ≥ j advance together, one l at a time (independent additions the compiler
/// vectorises).
fn cholesky(points: &[(&[f64], f64)], inv: f64) -> Option<Vec<f64>> {
    let k = points.len();
    let mut cols = vec![0.0; k * k];
    let mut acc = vec![0.0; k];
    for j in 0..k {
        let sums = &mut acc[j..];
        sums.fill(sum_start());
        for l in 0..j {
            let col = &cols[l * k..(l + 1) * k];
            let ljl = col[j];
            for (s, lil) in sums.iter_mut().zip(&col[j..]) {
                *s += lil * ljl;
            }
        }
        let kernel = |i: usize| (squared_distance(points[i].0, points[j].0) * inv).exp();
        let diag = kernel(j) + NUGGET - acc[j];
        if diag <= 0.0 || !diag.is_finite() {
            return None;
        }
        let pivot = diag.sqrt();
        cols[j * k + j] = pivot;
        for i in j + 1..k {
            cols[j * k + i] = (kernel(i) - acc[i]) / pivot;
        }
    }
    Some(cols)
}

/// Solves L y = b (L by column, k × k): y[i] = (b[i] − Σ_{j<i} L[i][j]·y[j]) / L[i][i], each
/// sum in ascending j from [`sum_start`] as the row-by-row solve took it, the sums of all rows
/// below j advanced together once y[j] is known.
fn forward(cols: &[f64], k: usize, b: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; k];
    let mut acc = vec![sum_start(); k];
    for j in 0..k {
        let col = &cols[j * k..(j + 1) * k];
        let yj = (b[j] - acc[j]) / col[j];
        y[j] = yj;
        for (s, lij) in acc[j + 1..].iter_mut().zip(&col[j + 1..]) {
            *s += lij * yj;
        }
    }
    y
}

/// Solves Lᵀ x = y (L by column): x[i] = (y[i] − Σ_{j>i} L[j][i]·x[j]) / L[i][i], the sum in
/// ascending j (column i of L is contiguous).
fn backward(cols: &[f64], k: usize, y: &[f64]) -> Vec<f64> {
    let mut x = vec![0.0; k];
    for i in (0..k).rev() {
        let col = &cols[i * k..(i + 1) * k];
        let s: f64 = col[i + 1..]
            .iter()
            .zip(&x[i + 1..])
            .map(|(lji, xj)| lji * xj)
            .sum();
        x[i] = (y[i] - s) / col[i];
    }
    x
}

/// Σ (a − b)², in coordinate order.
pub(super) fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-by-row factorisation and solves as first written (issue 42), kept to hold the
    /// column form to them bit for bit.
    fn reference(points: &[(&[f64], f64)], inv: f64, b: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
        let k = points.len();
        let mut chol = vec![0.0; k * k];
        for i in 0..k {
            for j in 0..=i {
                let mut s = (squared_distance(points[i].0, points[j].0) * inv).exp();
                if i == j {
                    s += NUGGET;
                }
                s -= (0..j)
                    .map(|l| chol[i * k + l] * chol[j * k + l])
                    .sum::<f64>();
                chol[i * k + j] = if i == j {
                    if s <= 0.0 || !s.is_finite() {
                        return None;
                    }
                    s.sqrt()
                } else {
                    s / chol[j * k + j]
                };
            }
        }
        let mut y = vec![0.0; k];
        for i in 0..k {
            let s: f64 = (0..i).map(|j| chol[i * k + j] * y[j]).sum();
            y[i] = (b[i] - s) / chol[i * k + i];
        }
        let mut x = vec![0.0; k];
        for i in (0..k).rev() {
            let s: f64 = (i + 1..k).map(|j| chol[j * k + i] * x[j]).sum();
            x[i] = (y[i] - s) / chol[i * k + i];
        }
        Some((chol, x))
    }

    /// A small deterministic generator (no dependency on the random crate's streams).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn the_column_factor_and_solves_equal_the_row_ones_bit_for_bit() {
        let mut state = 42;
        for (k, d) in [(1, 1), (5, 2), (64, 2), (64, 4), (40, 3)] {
            let us: Vec<Vec<f64>> = (0..k)
                .map(|i| {
                    // Some duplicated points: equal rows make the nugget carry the pivot.
                    if i % 7 == 6 {
                        vec![0.5; d]
                    } else {
                        (0..d).map(|_| lcg(&mut state)).collect()
                    }
                })
                .collect();
            let points: Vec<(&[f64], f64)> =
                us.iter().map(|u| (&u[..], lcg(&mut state) - 0.3)).collect();
            let b: Vec<f64> = (0..k).map(|_| lcg(&mut state) * 2.0 - 1.0).collect();
            let inv = -0.5 / (0.24 * 0.24);
            let (chol, x) = reference(&points, inv, &b).expect("positive definite");
            let cols = cholesky(&points, inv).expect("positive definite");
            for i in 0..k {
                for j in 0..=i {
                    assert_eq!(cols[j * k + i].to_bits(), chol[i * k + j].to_bits());
                }
            }
            let y = forward(&cols, k, &b);
            let ours = backward(&cols, k, &y);
            let same = ours.iter().zip(&x).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "k = {k}, d = {d}");
        }
    }

    #[test]
    fn lowest_keeps_what_a_stable_sort_kept() {
        let mut state = 7;
        for n in [0, 3, 64, 65, 300, 4096] {
            // Coarse keys: many ties, which must keep their order.
            let items: Vec<(f64, usize)> = (0..n)
                .map(|i| ((lcg(&mut state) * 20.0).floor(), i))
                .collect();
            let mut sorted = items.clone();
            sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
            sorted.truncate(GP_POINTS);
            assert_eq!(lowest(items), sorted, "n = {n}");
        }
    }
}
