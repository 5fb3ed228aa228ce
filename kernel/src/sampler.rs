//! Exact Beta sampling, fast: a Beta(α, β) draw is X / (X + Y) with X ~ Gamma(α), Y ~ Gamma(β),
//! each drawn by Marsaglia and Tsang's method (2000) with its constants computed once per arm.
//! Beta(1, 1) is drawn as a uniform, Gamma(1) as an exponential.

use rand::{Rng, RngExt};
use rand_distr::{Exp1, StandardNormal};

#[derive(Debug, Clone, Copy)]
enum Gamma {
    /// Shape 1: an exponential.
    One,
    /// Shape a > 1: Marsaglia–Tsang with `d = a − 1/3`, `c = 1 / √(9d)`.
    Large { d: f64, c: f64 },
    /// Shape a < 1: Gamma(a + 1) · U^(1/a).
    Small { d: f64, c: f64, inv_a: f64 },
}

impl Gamma {
    fn new(a: f64) -> Self {
        if a == 1.0 {
            Gamma::One
        } else if a > 1.0 {
            let d = a - 1.0 / 3.0;
            Gamma::Large {
                d,
                c: 1.0 / (9.0 * d).sqrt(),
            }
        } else {
            let d = a + 1.0 - 1.0 / 3.0;
            Gamma::Small {
                d,
                c: 1.0 / (9.0 * d).sqrt(),
                inv_a: 1.0 / a,
            }
        }
    }

    // Always inlined into the Thompson draw, the paper-method ask's hot loop: with a plain
    // `#[inline]` rustc stopped inlining it when unrelated code was added to the crate, and the
    // paper-method ask + tell went from 1.78 to 2.37 µs (kernel/benches/guard.rs caught it).
    #[inline(always)]
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        match *self {
            Gamma::One => rng.sample(Exp1),
            Gamma::Large { d, c } => marsaglia_tsang(d, c, rng),
            Gamma::Small { d, c, inv_a } => {
                let u = 1.0 - rng.random::<f64>(); // in (0, 1]
                marsaglia_tsang(d, c, rng) * u.powf(inv_a)
            }
        }
    }
}

#[inline(always)]
fn marsaglia_tsang<R: Rng + ?Sized>(d: f64, c: f64, rng: &mut R) -> f64 {
    loop {
        let x: f64 = rng.sample(StandardNormal);
        let v = 1.0 + c * x;
        if v <= 0.0 {
            continue;
        }
        let v = v * v * v;
        let u: f64 = rng.random();
        let x2 = x * x;
        // Squeeze first: accepts ~98 % of draws without a logarithm.
        if u < 1.0 - 0.0331 * x2 * x2 || u.ln() < 0.5 * x2 + d * (1.0 - v + v.ln()) {
            return d * v;
        }
    }
}

/// One Gamma(`shape`, 1) draw (`shape` > 0; Marsaglia–Tsang).
pub(crate) fn gamma<R: Rng + ?Sized>(shape: f64, rng: &mut R) -> f64 {
    Gamma::new(shape).sample(rng)
}

/// A Beta(α, β) sampler with its constants precomputed.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BetaSampler {
    x: Gamma,
    y: Gamma,
    uniform: bool,
}

impl BetaSampler {
    pub(crate) fn new(alpha: f64, beta: f64) -> Self {
        BetaSampler {
            x: Gamma::new(alpha),
            y: Gamma::new(beta),
            uniform: alpha == 1.0 && beta == 1.0,
        }
    }

    #[inline]
    pub(crate) fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        if self.uniform {
            return rng.random();
        }
        let x = self.x.sample(rng);
        let y = self.y.sample(rng);
        let s = x + y;
        if s > 0.0 {
            x / s
        } else {
            // Both draws underflowed (shapes far below 1): the mass sits at 0 and 1 alike.
            f64::from(u8::from(rng.random::<bool>()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Mean and variance of many draws match Beta(α, β) for every kind of shape.
    #[test]
    fn moments_match_the_beta_distribution() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        for &(a, b) in &[
            (1.0, 1.0),
            (1.0, 5.0),
            (3.0, 1.0),
            (0.5, 0.5),
            (2.5, 7.0),
            (400.0, 90.0),
            (0.3, 4.0),
        ] {
            let s = BetaSampler::new(a, b);
            let n = 200_000;
            let xs: Vec<f64> = (0..n).map(|_| s.sample(&mut rng)).collect();
            assert!(xs.iter().all(|x| (0.0..=1.0).contains(x)));
            let mean = xs.iter().sum::<f64>() / n as f64;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
            let m = a / (a + b);
            let v = a * b / ((a + b).powi(2) * (a + b + 1.0));
            // Standard error of the mean is √(v/n); allow 5 of them.
            assert!(
                (mean - m).abs() < 5.0 * (v / n as f64).sqrt(),
                "Beta({a},{b}) mean {mean} vs {m}"
            );
            assert!(
                (var - v).abs() < 0.03 * v,
                "Beta({a},{b}) variance {var} vs {v}"
            );
        }
    }
}
