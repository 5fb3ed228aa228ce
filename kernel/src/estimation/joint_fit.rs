//! Fitting the joint proposal's mixture ([`super::joint::Mixture`]) to the pilot rounds: the
//! cross-entropy method over a mixture (Rubinstein & Kroese 2004; Kurtz & Song 2013).
//!
//! The target is the zero-variance density ∝ p(φ)·1{failure}: every pilot trial that failed
//! is a sample of it with weight w = p/q of the proposal it was drawn from. While the pilot
//! holds fewer than [`MIN_ELITE`] failures, the target is the wider p(φ)·1{robustness ≤ γ}
//! (multi-level cross-entropy): γ is the robustness below which the failures and the closest
//! near-misses make up [`ELITE_SHARE`] of the pilot's trials (at least [`MIN_ELITE`]), so that
//! early rounds move toward where runs come close to failing. The mixture is fitted to the
//! weighted elite by expectation–maximisation (a fixed number of iterations from a k-means++
//! start drawn from a seeded generator), so the fit — and every draw after it — depends only
//! on the seed and the pilot's outcomes, told in any order.

use super::joint::Mixture;
use rand::{Rng, RngExt, SeedableRng};
use rand_pcg::Pcg64 as Rng64;
use std::collections::BTreeMap;

/// Failures the pilot needs before the fit aims at the failures alone.
pub(crate) const MIN_ELITE: usize = 100;
/// The share of the pilot's trials an intermediate (robustness) level keeps.
pub(crate) const ELITE_SHARE: f64 = 0.1;
/// Effective elite points per component: fewer components when the weights are uneven.
const PER_COMPONENT: f64 = 10.0;
/// Expectation–maximisation iterations.
const EM_ITERATIONS: usize = 50;
/// The share of every component's bin distribution that follows the nominal's bins, so that
/// no bin the nominal weighs is left to the defensive share alone.
pub(crate) const BIN_SMOOTHING: f64 = 0.3;
/// A component at the k-means++ start: this share on its centre's bin of each variable,
/// the rest the nominal's bins.
const START_SHARE: f64 = 0.5;

/// A pilot trial as the fit sees it.
#[derive(Debug, Clone)]
pub(crate) struct PilotPoint {
    /// The bin of every variable ([`super::joint::point_of`]).
    pub point: Vec<usize>,
    /// p(φ)/q(φ) of the proposal it was drawn from.
    pub weight: f64,
    pub failure: bool,
    pub robustness: Option<f64>,
}

/// The elite of the pilot: its failures, or (too few failures) the trials at or below the
/// robustness level; each with its weight.
pub(crate) fn elite(points: &[PilotPoint]) -> Vec<(&[usize], f64)> {
    let failures = points.iter().filter(|p| p.failure).count();
    let level = if failures >= MIN_ELITE {
        None
    } else {
        let mut r: Vec<f64> = points
            .iter()
            .filter(|p| !p.failure)
            .filter_map(|p| p.robustness)
            .collect();
        r.sort_by(f64::total_cmp);
        let want = ((ELITE_SHARE * points.len() as f64).ceil() as usize).max(MIN_ELITE);
        let extra = want.saturating_sub(failures);
        (extra > 0 && !r.is_empty()).then(|| r[(extra - 1).min(r.len() - 1)])
    };
    points
        .iter()
        .filter(|p| p.failure || level.is_some_and(|g| p.robustness.is_some_and(|r| r <= g)))
        .filter(|p| p.weight > 0.0 && p.weight.is_finite())
        .map(|p| (p.point.as_slice(), p.weight))
        .collect()
}

/// The mixture of at most `components` components fitted to the weighted elite of `points`;
/// `nominal` is each variable's nominal bin probabilities (0: never drawn). None: no elite
/// with a positive weight.
pub(crate) fn fit<R: Rng + ?Sized>(
    nominal: &[Vec<f64>],
    points: &[PilotPoint],
    components: usize,
    rng: &mut R,
) -> Option<Mixture> {
    let mut elite = elite(points);
    elite.retain(|(p, _)| p.len() == nominal.len());
    let total: f64 = elite.iter().map(|(_, w)| w).sum();
    if elite.is_empty() || !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let pts: Vec<&[usize]> = elite.iter().map(|(p, _)| *p).collect();
    let w: Vec<f64> = elite.iter().map(|(_, w)| w / total).collect();
    let ess = 1.0 / w.iter().map(|w| w * w).sum::<f64>();
    let k = components
        .min((ess / PER_COMPONENT).floor() as usize)
        .max(1);
    let mut mixture = start(nominal, &pts, &w, k, rng);
    for _ in 0..EM_ITERATIONS {
        mixture = em_step(nominal, &pts, &w, &mixture);
    }
    Some(mixture)
}

/// The k-means++ start: k centres drawn ∝ weight × squared distance to the nearest centre so
/// far, each a component with [`START_SHARE`] on the centre's bins.
fn start<R: Rng + ?Sized>(
    nominal: &[Vec<f64>],
    pts: &[&[usize]],
    w: &[f64],
    k: usize,
    rng: &mut R,
) -> Mixture {
    let mut centres: Vec<usize> = Vec::with_capacity(k);
    let mut nearest = vec![1.0; pts.len()];
    while centres.len() < k {
        let score: Vec<f64> = w.iter().zip(&nearest).map(|(w, d)| w * d).collect();
        let total: f64 = score.iter().sum();
        if total.is_nan() || total <= 0.0 {
            break; // every point is a centre already
        }
        let mut u = rng.random::<f64>() * total;
        let c = score
            .iter()
            .position(|s| {
                u -= s;
                u < 0.0
            })
            .unwrap_or_else(|| score.iter().rposition(|s| *s > 0.0).unwrap_or(0));
        centres.push(c);
        for (d, p) in nearest.iter_mut().zip(pts) {
            *d = f64::min(*d, distance2(nominal, p, pts[c]));
        }
    }
    let components: Vec<Vec<Vec<f64>>> = centres
        .iter()
        .map(|&c| {
            nominal
                .iter()
                .zip(pts[c])
                .map(|(prior, &b)| {
                    let mut p = vec![0.0; prior.len()];
                    p[b] = 1.0;
                    smooth(p, prior, START_SHARE)
                })
                .collect()
        })
        .collect();
    Mixture {
        alpha: vec![1.0 / components.len() as f64; components.len()],
        components,
    }
}

/// Squared distance of two points, each variable's bin index in units of its bin count.
fn distance2(nominal: &[Vec<f64>], a: &[usize], b: &[usize]) -> f64 {
    nominal
        .iter()
        .zip(a.iter().zip(b))
        .map(|(prior, (&x, &y))| {
            let d = (x as f64 - y as f64) / prior.len() as f64;
            d * d
        })
        .sum()
}

/// `share` of the (normalised) fitted bin probabilities `p` plus the rest of the nominal's
/// `prior`; bins the nominal never draws get 0.
fn smooth(p: Vec<f64>, prior: &[f64], share: f64) -> Vec<f64> {
    let total: f64 = p
        .iter()
        .zip(prior)
        .filter(|(_, q)| **q > 0.0)
        .map(|(x, _)| x)
        .sum();
    let mixed: Vec<f64> = p
        .iter()
        .zip(prior)
        .map(|(x, q)| match (*q > 0.0, total > 0.0) {
            (false, _) => 0.0,
            (true, true) => share * x / total + (1.0 - share) * q,
            (true, false) => *q,
        })
        .collect();
    let sum: f64 = mixed.iter().sum();
    mixed.iter().map(|x| x / sum).collect()
}

/// Each point's responsibilities (one per component, summing to 1).
fn responsibilities(mixture: &Mixture, point: &[usize]) -> Vec<f64> {
    let ln: Vec<f64> = mixture
        .alpha
        .iter()
        .zip(&mixture.components)
        .map(|(a, dims)| a.ln() + dims.iter().zip(point).map(|(p, &b)| p[b].ln()).sum::<f64>())
        .collect();
    let top = ln.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return vec![1.0 / ln.len() as f64; ln.len()];
    }
    let e: Vec<f64> = ln.iter().map(|l| (l - top).exp()).collect();
    let s: f64 = e.iter().sum();
    e.iter().map(|x| x / s).collect()
}

/// One expectation–maximisation step of the weighted fit (each component's bins smoothed
/// toward the nominal's by [`BIN_SMOOTHING`]); a component left with no weight is dropped.
fn em_step(nominal: &[Vec<f64>], pts: &[&[usize]], w: &[f64], mixture: &Mixture) -> Mixture {
    let r: Vec<Vec<f64>> = pts.iter().map(|p| responsibilities(mixture, p)).collect();
    let mut alpha = Vec::new();
    let mut components = Vec::new();
    for k in 0..mixture.components.len() {
        let a: f64 = w.iter().zip(&r).map(|(w, r)| w * r[k]).sum();
        if a.is_nan() || a <= 1e-9 {
            continue;
        }
        let dims = nominal
            .iter()
            .enumerate()
            .map(|(i, prior)| {
                let mut p = vec![0.0; prior.len()];
                for (pt, (w, r)) in pts.iter().zip(w.iter().zip(&r)) {
                    p[pt[i]] += w * r[k];
                }
                smooth(p, prior, 1.0 - BIN_SMOOTHING)
            })
            .collect();
        alpha.push(a);
        components.push(dims);
    }
    let total: f64 = alpha.iter().sum();
    Mixture {
        alpha: alpha.iter().map(|a| a / total).collect(),
        components,
    }
}

/// The joint proposal's side of a cross-entropy pilot: every trial told in the rounds so
/// far, and the refit at a round's end.
#[derive(Debug, Clone)]
pub(crate) struct JointPilot {
    components: usize,
    seed: u64,
    /// This round's told trials by id, with their scenario (pooled in id order at the
    /// round's end, so the fit does not depend on the order of the tells).
    round: BTreeMap<u64, (usize, PilotPoint)>,
    /// Per scenario, the trials of the finished rounds, in id order.
    pooled: Vec<Vec<PilotPoint>>,
}

impl JointPilot {
    pub(crate) fn new(components: usize, seed: u64, scenarios: usize) -> JointPilot {
        JointPilot {
            components,
            seed,
            round: BTreeMap::new(),
            pooled: vec![Vec::new(); scenarios],
        }
    }

    /// Records a told pilot trial.
    pub(crate) fn told(&mut self, id: u64, scenario: usize, point: PilotPoint) {
        self.round.insert(id, (scenario, point));
    }

    /// Pools the round's trials and fits each scenario's mixture to all rounds so far (None
    /// for a scenario without an elite: it keeps its proposal).
    pub(crate) fn end_round(
        &mut self,
        round: u32,
        nominal: &[Vec<Vec<f64>>],
    ) -> Vec<Option<Mixture>> {
        for (scenario, point) in std::mem::take(&mut self.round).into_values() {
            self.pooled[scenario].push(point);
        }
        nominal
            .iter()
            .zip(&self.pooled)
            .enumerate()
            .map(|(s, (bins, points))| {
                let stream = (u64::from(round) << 32) | s as u64;
                let mut rng = Rng64::seed_from_u64(self.seed ^ stream.wrapping_mul(FIT_STREAM));
                fit(bins, points, self.components, &mut rng)
            })
            .collect()
    }
}

/// Spreads the fit's seeds (round, scenario) over the 64 bits (the golden-ratio constant).
const FIT_STREAM: u64 = 0x9E37_79B9_7F4A_7C15;
