//! How the learning phases (train, test) draw scenario parameters φ: the paper's independent
//! Beta–Bernoulli bins, or a joint proposal learned from failures and near-misses.
//!
//! [`SearchModel::EliteMixture`] keeps, per scenario, an archive of the told trials' φ (as
//! positions in the unit cube) with their HF outcome and robustness. Each ask either draws
//! from the paper's independent-bin Thompson sampler (probability [`EliteMixture::explore`]),
//! or picks an *elite* — a failure, or a near-miss among the passes when the runs report a
//! robustness — and draws φ from a Gaussian kernel around it: a mixture of Gaussians in the
//! unit cube, weighted towards failing joint cells that hold few failures so far, so that the
//! search crawls along failure regions instead of resampling one hot spot. The bins keep
//! being credited per Table I either way, and the archive is rebuilt by replaying the tells,
//! so journals and snapshots restore the exact same asks.

use crate::outcome::Run;
use crate::posterior::Posterior;
use crate::space::Space;
use crate::value::Assignment;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, VecDeque};

mod gp;
use gp::{squared_distance, Gp};

/// Joint cell → (trials, failure mass): looked up, never iterated, so its order is irrelevant.
type Cells<'p> = HashMap<&'p [u16], (u32, f64), foldhash::fast::FixedState>;

/// How the train and test phases draw φ. Part of the [`crate::KernelConfig`]; the default is
/// the paper's.
///
/// ```
/// use savme_kernel::{EliteMixture, SearchModel};
/// assert_eq!(SearchModel::default(), SearchModel::IndependentBins);
/// let joint = SearchModel::EliteMixture(EliteMixture::default());
/// let json = serde_json::to_string(&joint)?;
/// assert!(json.starts_with(r#"{"model":"elite_mixture""#));
/// assert_eq!(serde_json::from_str::<SearchModel>(&json)?, joint);
/// # Ok::<(), serde_json::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum SearchModel {
    /// The paper's: one Beta–Bernoulli Thompson sampler per φ variable, independent bins.
    #[default]
    IndependentBins,
    /// A joint proposal per scenario: a Gaussian mixture around failures and near-misses,
    /// mixed with the independent bins for exploration.
    EliteMixture(EliteMixture),
}

impl SearchModel {
    /// True for the paper's [`SearchModel::IndependentBins`] (then the configuration
    /// serialises without a `search` field, exactly as before the field existed).
    pub fn is_independent_bins(&self) -> bool {
        matches!(self, SearchModel::IndependentBins)
    }

    /// Checks the model's parameters.
    pub fn validate(&self) -> Result<(), SearchError> {
        match self {
            SearchModel::IndependentBins => Ok(()),
            SearchModel::EliteMixture(m) => m.validate(),
        }
    }
}

/// The parameters of [`SearchModel::EliteMixture`]. Missing fields take their defaults when
/// deserialised.
///
/// ```
/// use savme_kernel::EliteMixture;
/// let m = EliteMixture { explore: 0.3, ..EliteMixture::default() };
/// assert!(m.validate().is_ok());
/// assert!(EliteMixture { bandwidth: 0.0, ..m }.validate().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EliteMixture {
    /// Probability that an ask draws from the independent bins instead (in `[0, 1]`); it is 1
    /// until the scenario has an elite.
    pub explore: f64,
    /// Standard deviation of the Gaussian kernel around an elite, in unit-cube widths (a
    /// variable's whole range is 1; with 10 bins a bin is 0.1); in `(0, 1]`.
    pub bandwidth: f64,
    /// Probability that a kernel draw uses four times the bandwidth (a jump to a neighbouring
    /// region); in `[0, 1]`.
    pub jump: f64,
    /// Fraction of passing runs counted as near-misses: those whose HF robustness is in the
    /// lowest `near_miss` quantile of the scenario's passes (in `[0, 1)`; 0 = failures only;
    /// runs without a robustness are never near-misses). Default 0: on the bundled
    /// simulator's eight scenarios near-misses (by clearance) cost failures per work unit
    /// (docs/RESULTS.md, issue 25); on a needle-like failure region they find it sooner.
    pub near_miss: f64,
    /// Weight of a near-miss relative to a failure as a centre (finite, ≥ 0).
    pub near_miss_weight: f64,
    /// Near-misses count only while the scenario's archive holds fewer failures than this:
    /// they lead the search to failures, then the failures lead (0 = never).
    pub near_miss_until: u32,
    /// Novelty: an elite's weight is divided by `1 + spread × (failures in its joint cell)`
    /// (finite, ≥ 0; 0 = every elite alike).
    pub spread: f64,
    /// Candidates per kernel draw, at least 1. The one with the highest score wins: the
    /// Parzen estimate of its failure probability (failures, and near-misses at their weight,
    /// against all archived trials, Gaussian kernels of the same bandwidth) divided by
    /// `1 + trials already in its joint cell` — likely failures in cells not yet tried.
    /// Each candidate's estimate is a sum over the scenario's archive, so beyond
    /// `parzen_points / tries` archived trials a draw ranks proportionally fewer (never
    /// fewer than `min(tries, 8)`): [`EliteMixture::tries_for`].
    pub tries: u32,
    /// Most trials kept per scenario (the oldest go first); at least 1.
    pub archive: usize,
    /// Rank candidates by failure odds per expected cost: the score is divided by the
    /// Parzen mean of what the archived trials near the candidate cost (every run told), so
    /// of two equally likely failures the cheaper one is drawn; and weight each elite by the
    /// archive's mean cost over its own (a cheap failure is a likelier centre of cheap ones). Missing from a stored
    /// configuration (written before it existed): false, the ranking by odds alone.
    #[serde(default)]
    pub per_cost: bool,
    /// Batch awareness: a candidate's score is divided by `1 + crowding × Σ K(candidate,
    /// trial in flight)` over the scenario's trials asked and not yet told (Gaussian kernels
    /// of `bandwidth`), so a window of trials spreads over the failure region instead of
    /// piling onto one spot (finite, ≥ 0; missing from a stored configuration: 0, none).
    #[serde(default)]
    pub crowding: f64,
    /// Fantasies for the trials in flight: the scenario's trials asked and not yet told count
    /// as archived trials whose outcome is what the archive expects at their φ (a failure
    /// mass of the Parzen odds there, at the Parzen cost), so a window of trials sees its
    /// cells as tried, as one trial in flight would see them once told; they are not centres.
    /// Off by default: the gain measured is within seed noise (docs/DISTRIBUTED.md). Missing from a stored configuration: false, none (and left out of
    /// the JSON when false, so configurations stored before it existed read back the same).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fantasies: bool,
    /// Learn from the robustness ρ where the runs report one (ρ < 0 on a failure, as a
    /// threshold's margin): a Gaussian process regression of ρ (squared-exponential kernel,
    /// length scale four bandwidths, at most 64 runs) — what Bayesian optimisation follows.
    /// While a scenario's archive holds no failure but [`EliteMixture::rho_start`] runs with a
    /// ρ (at most `d + 2`, `d` = the φ dimensions), a draw that does not explore fits it to the lowest-ρ runs and proposes, of
    /// `4 × tries` candidates (half Gaussian around the lowest-ρ run at four bandwidths, half
    /// uniform), the one most likely to have ρ < 0, instead of drawing from the bins until a
    /// run happens to fail (on a thin failure region every such run is a pass at a pass's full
    /// cost). Once it holds failures, the candidates around an elite are ranked with the
    /// process's probability of ρ < 0 (fitted to the runs nearest the elite) in place of the
    /// Parzen failure odds: it knows that an untried spot whose neighbours' ρ rises is a pass.
    /// Runs without a ρ leave every draw as it was. Missing from a stored configuration: false
    /// (and left out of the JSON when false).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub rho_model: bool,
    /// Runs with a ρ a scenario's archive needs before the ρ model proposes (before its first
    /// failure), at most `d + 2`; at least 2. None: `d + 2`, what a stored configuration without
    /// it means (and then left out of the JSON). The default, 3, lets a scenario rationed to
    /// a few trials follow its robustness from its fourth run (the Gaussian process's length
    /// scale is fixed, so a few runs fit it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rho_start: Option<u32>,
    /// Candidates × archived trials one draw sums its Parzen estimates over, at most (unless
    /// that leaves fewer than `min(tries, 8)` candidates): [`EliteMixture::tries_for`]. The
    /// default, [`PARZEN_POINTS`], keeps 32 candidates up to 1,024 archived trials and 8 at a
    /// full archive of 4,096. None: no bound, what a stored configuration without it means
    /// (its draws replay as they were made; then left out of the JSON); at least 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parzen_points: Option<u32>,
    /// The cost the archive keeps of a learning trial (train, test) is its HF run's, not the
    /// trial's: a paired trial's LF run is drawn independently of φ (its θ_LF from the fidelity
    /// bandit, whether it runs at all from the pairing), so counted in, it hides where φ is
    /// cheap under noise as large as the difference (highway-env: LF runs were 27 % of the
    /// search's work, a paired trial ≈ 1.5× an unpaired one, a cheap failure 0.6× a dear one).
    /// Deployed trials keep what the trial cost. Missing from a stored configuration: false
    /// (the trial's cost, as before; left out of the JSON when false).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub hf_cost: bool,
}

impl Default for EliteMixture {
    fn default() -> Self {
        // Tuned on the bundled simulator's eight meta-training scenarios at the peer
        // benchmark's budget (docs/RESULTS.md, issue 25): explore 0.2 → 0.05, jump 0.2 → 0.1
        // and tries 4 → 8 took HF failures per 10⁹ wu from 32 to 42–46.
        EliteMixture {
            explore: 0.05,
            bandwidth: 0.06,
            jump: 0.1,
            near_miss: 0.0,
            near_miss_weight: 0.5,
            near_miss_until: 20,
            // 5 (was 1): distinct failing cells per 10³ wu in the search 3.11 → 3.43
            // (BouncingBall earth+mars), 1.67 → 1.97 (moon), 1.80 → 1.88 and 1.56 → 1.62 (the
            // braking example without and with ρ, dry+wet), HF failures per wu level or up (6
            // seeds each; docs/RESULTS.md, issue 42): the ρ model's cheapest failures otherwise
            // pile up in a few cells. 10 gave the same cells but cost yield with 16 trials in
            // flight (kernel/tests/cost.rs: 0.923× one in flight, 5: 0.955×).
            spread: 5.0,
            // 32 (was 8): more candidates around each centre to rank per expected cost and
            // cell visits. Paired seeds (docs/RESULTS.md, issue 42, "More candidates"): HF
            // failures / failing cells / confirmed deployed failures per wu 79.2 / 57.2 / 295
            // → 87.6 / 66.1 / 445 on the bundled simulator's scenarios 1–8 and 125.5 / 93.1 /
            // 309 → 150.2 / 117.5 / 423 on 9–10 (20 seeds); BouncingBall earth+mars 26.2 /
            // 3.11 / 350 → 28.5 / 3.32 / 453, moon 40.3 / 2.14 / 400 → 43.7 / 2.35 / 486; the
            // braking example dry+wet 6.54 / 1.80 / 11.7 → 6.27 / 1.97 / 12.9, icy 3.55 /
            // 0.578 / 7.56 → 3.45 / 0.612 / 8.59 (60 seeds). 64 lost failures on BouncingBall
            // (26.0, moon 37.9). The price, four times the Parzen sums per draw, is bounded: past
            // 1,024 archived trials a draw ranks fewer ([`PARZEN_POINTS`]), 8 at a full archive.
            tries: 32,
            archive: 4096,
            per_cost: true,
            // Off: on kernel/tests/cost.rs's problem, crowding 1 lost yield with 4, 16 and 64
            // trials in flight (0.369 vs 0.409, 0.358 vs 0.360, 0.225 vs 0.258 failures per
            // unit cost): its failure regions are wide, and spreading a batch moves it off them.
            crowding: 0.0,
            fantasies: false,
            // On: HF failures per work unit in the search 9.6 → 23.3 per 10³ on the Reference
            // FMU BouncingBall (a thin failure band), 60.1 → 75.3 per 10⁹ on the bundled
            // simulator's scenarios 1–8 (3 seeds each; docs/RESULTS.md, issue 42).
            rho_model: true,
            // 3 (was d + 2): with the cost-rate allocation's scouting, the worst of the
            // bundled simulator's scenarios 1–8 against the best VerifAI sampler 0.25× → ≥ 0.8×
            // (docs/RESULTS.md, issue 42, "Scouting").
            rho_start: Some(3),
            parzen_points: Some(PARZEN_POINTS),
            hf_cost: true,
        }
    }
}

impl EliteMixture {
    /// The defaults with the parameters `given` (a JSON object of parameter → value) in
    /// their place: what a user who names a few parameters means. (Deserialising the object
    /// alone would read the switches it leaves out — `per_cost`, `rho_model` — as a stored
    /// configuration of before they existed: off.) Unknown names are refused.
    ///
    /// ```
    /// use savme_kernel::EliteMixture;
    /// let given = serde_json::json!({"explore": 0.1}).as_object().unwrap().clone();
    /// let m = EliteMixture::with(given)?;
    /// assert_eq!(m, EliteMixture { explore: 0.1, ..EliteMixture::default() });
    /// # Ok::<(), serde_json::Error>(())
    /// ```
    pub fn with(
        given: serde_json::Map<String, serde_json::Value>,
    ) -> Result<Self, serde_json::Error> {
        let mut all = match serde_json::to_value(EliteMixture::default())? {
            serde_json::Value::Object(all) => all,
            _ => serde_json::Map::new(),
        };
        all.extend(given);
        serde_json::from_value(serde_json::Value::Object(all))
    }

    /// The candidates one draw ranks with `archived` trials in the scenario's archive: `tries`
    /// while `tries × archived` ≤ `parzen_points`, then proportionally fewer, but never
    /// fewer than `min(tries, 8)`; always `tries` without a bound (`parzen_points` None).
    ///
    /// ```
    /// use savme_kernel::EliteMixture;
    /// let m = EliteMixture { tries: 32, ..EliteMixture::default() };
    /// assert_eq!(m.tries_for(200), 32);
    /// assert_eq!(m.tries_for(2048), 16);
    /// assert_eq!(m.tries_for(4096), 8);
    /// assert_eq!(EliteMixture { tries: 4, ..m }.tries_for(4096), 4);
    /// assert_eq!(EliteMixture { parzen_points: None, ..m }.tries_for(4096), 32);
    /// ```
    pub fn tries_for(&self, archived: usize) -> u32 {
        let Some(points) = self.parzen_points else {
            return self.tries;
        };
        let fit = points as usize / archived.max(1);
        let fit = u32::try_from(fit).unwrap_or(u32::MAX);
        self.tries.min(fit.max(self.tries.min(8)))
    }

    /// The defaults before candidates were ranked per cost (`per_cost` false): what a
    /// campaign stored without its elite parameters ran with (novelty `spread` 1 and 8
    /// `tries`, as then).
    pub fn legacy() -> Self {
        EliteMixture {
            spread: 1.0,
            tries: 8,
            per_cost: false,
            crowding: 0.0,
            fantasies: false,
            rho_model: false,
            rho_start: None,
            parzen_points: None,
            hf_cost: false,
            ..EliteMixture::default()
        }
    }
}

/// The default [`EliteMixture::parzen_points`]: 32 candidates up to 1,024 archived trials, 8 at
/// the full archive of 4,096 — what a draw cost with the 8 candidates of before
/// ([`EliteMixture::tries_for`]).
pub const PARZEN_POINTS: u32 = 32 * 1024;

/// A search model parameter out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SearchError {
    /// A parameter outside its documented range (or NaN).
    #[error("search parameter `{name}` = {value} is outside {range}")]
    BadParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range.
        range: &'static str,
    },
}

impl EliteMixture {
    /// Checks every parameter against its documented range.
    pub fn validate(&self) -> Result<(), SearchError> {
        let check = |name, value: f64, ok: bool, range| {
            if ok {
                Ok(())
            } else {
                Err(SearchError::BadParameter { name, value, range })
            }
        };
        let unit = |x: f64| (0.0..=1.0).contains(&x);
        check("explore", self.explore, unit(self.explore), "[0, 1]")?;
        let b = self.bandwidth;
        check("bandwidth", b, b > 0.0 && b <= 1.0, "(0, 1]")?;
        check("jump", self.jump, unit(self.jump), "[0, 1]")?;
        let q = self.near_miss;
        check("near_miss", q, (0.0..1.0).contains(&q), "[0, 1)")?;
        let w = self.near_miss_weight;
        check("near_miss_weight", w, w.is_finite() && w >= 0.0, "[0, ∞)")?;
        let s = self.spread;
        check("spread", s, s.is_finite() && s >= 0.0, "[0, ∞)")?;
        let c = self.crowding;
        check("crowding", c, c.is_finite() && c >= 0.0, "[0, ∞)")?;
        if let Some(n) = self.rho_start {
            check("rho_start", f64::from(n), n >= 2, "[2, ∞)")?;
        }
        if let Some(n) = self.parzen_points {
            check("parzen_points", f64::from(n), n >= 1, "[1, ∞)")?;
        }
        let t = f64::from(self.tries);
        check("tries", t, self.tries >= 1, "[1, ∞)")?;
        let a = self.archive as f64;
        check("archive", a, self.archive >= 1, "[1, ∞)")
    }
}

/// One told trial of a scenario, as the archive keeps it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Point {
    /// φ in the unit cube.
    u: Vec<f64>,
    /// φ's arms (its joint cell).
    cell: Vec<u16>,
    /// The HF run failed.
    failure: bool,
    /// The HF run's robustness, if reported.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    robustness: Option<f64>,
    /// What the trial cost (every run told); None in archives stored before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cost: Option<f64>,
}

impl Point {
    /// 1 for a failure, the near-miss weight for a pass at or below the near-miss
    /// `threshold`, 0 otherwise.
    fn weight(&self, m: &EliteMixture, threshold: Option<f64>) -> f64 {
        if self.failure {
            1.0
        } else if self.robustness.zip(threshold).is_some_and(|(r, t)| r <= t) {
            m.near_miss_weight
        } else {
            0.0
        }
    }
}

/// The told trials of one scenario ([`SearchModel::EliteMixture`]'s state).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub(crate) struct Archive {
    points: VecDeque<Point>,
}

impl Archive {
    /// Keeps a told trial: φ as drawn (`phi`, its `arms`), the HF run and what the trial
    /// cost.
    pub(crate) fn record(
        &mut self,
        space: &Space,
        phi: &Assignment,
        arms: &[u16],
        hf: &Run,
        cost: f64,
    ) {
        self.points.push_back(Point {
            u: space.unit_of(phi, arms),
            cell: arms.to_vec(),
            failure: hf.failure,
            robustness: hf.robustness,
            cost: Some(cost),
        });
    }

    /// True once a kept trial's HF run failed.
    pub(crate) fn has_failure(&self) -> bool {
        self.points.iter().any(|p| p.failure)
    }

    /// Drops the oldest points beyond `cap`.
    pub(crate) fn truncate(&mut self, cap: usize) {
        while self.points.len() > cap {
            self.points.pop_front();
        }
    }

    /// Checks that every point fits `space` (a restored snapshot).
    pub(crate) fn check_fits(&self, space: &Space) -> Result<(), String> {
        for (i, p) in self.points.iter().enumerate() {
            let arms_ok = p.cell.len() == space.len()
                && space
                    .variables()
                    .iter()
                    .zip(&p.cell)
                    .all(|(v, &a)| (a as usize) < v.arms());
            let u_ok = p.u.len() == space.len() && p.u.iter().all(|x| (0.0..=1.0).contains(x));
            let r_ok = p.robustness.is_none_or(f64::is_finite);
            let c_ok = p.cost.is_none_or(|c| c.is_finite() && c >= 0.0);
            if !(arms_ok && u_ok && r_ok && c_ok) {
                return Err(format!("archived trial {i} does not fit the scenario"));
            }
        }
        Ok(())
    }

    /// Draws φ (and pushes its arms onto `arms`); `draw.exploit` draws for failures rather
    /// than for new cells ([`crate::Deployment::exploit`]): no exploration, no novelty
    /// weighting, candidates ranked by failure odds (per expected cost with `per_cost`).
    pub(crate) fn propose<R: Rng + ?Sized>(
        &self,
        m: &EliteMixture,
        draw: &Draw<'_>,
        rng: &mut R,
        arms: &mut Vec<u16>,
    ) -> Assignment {
        let Draw {
            exploit,
            bins,
            space,
            in_flight,
        } = *draw;
        let explore: f64 = rng.random();
        let exploiting = EliteMixture {
            explore: 0.0,
            spread: 0.0,
            ..*m
        };
        let m = if exploit { &exploiting } else { m };
        let fantasies = if m.fantasies {
            self.fantasies(m, in_flight)
        } else {
            Vec::new()
        };
        if m.rho_model && explore >= m.explore {
            if let Some(phi) = self.descend(m, space, rng, arms) {
                return phi;
            }
        }
        let view = View::new(self, m, &fantasies);
        let tried = view.tried_cells();
        let elites = view.elites(m, &tried);
        let total: f64 = elites.iter().map(|e| e.1).sum();
        if explore < m.explore || total.is_nan() || total <= 0.0 {
            let start = arms.len();
            bins.thompson(rng, arms);
            return space.draw(&arms[start..], rng);
        }
        let mut pick = rng.random::<f64>() * total;
        let centre = elites
            .iter()
            .find(|e| {
                pick -= e.1;
                pick < 0.0
            })
            .map_or(elites[elites.len() - 1].0, |e| e.0);
        let centre = &view.points[centre].u;
        let wide = rng.random::<f64>() < m.jump;
        let sd = m.bandwidth * if wide { 4.0 } else { 1.0 };
        let start = arms.len();
        let tries = m.tries_for(self.points.len());
        let gp = if m.rho_model && tries > 1 {
            self.local_gp(m, centre, space.len())
        } else {
            None
        };
        let mut best: Option<(f64, Vec<u16>, Assignment)> = None;
        for _ in 0..tries {
            let u: Vec<f64> = centre
                .iter()
                .map(|&c| reflect(c + sd * rng.sample::<f64, _>(StandardNormal)))
                .collect();
            let mut cell = Vec::with_capacity(u.len());
            let phi = space.at_unit(&u, &mut cell);
            let score = if tries > 1 {
                let visits = if exploit {
                    0
                } else {
                    tried.get(&*cell).map_or(0, |c| c.0)
                };
                let (odds, cost) = parzen(&view, &u, m);
                let odds = gp.as_ref().map_or(odds, |g| g.failure_probability(&u));
                let mut score = odds / (1.0 + f64::from(visits));
                if let Some(cost) = cost {
                    score /= cost;
                }
                if m.crowding > 0.0 && !in_flight.is_empty() {
                    score /= 1.0 + m.crowding * crowd(&u, in_flight, m.bandwidth);
                }
                score
            } else {
                0.0
            };
            if best.as_ref().is_none_or(|b| score > b.0) {
                best = Some((score, cell, phi));
            }
        }
        arms.truncate(start);
        match best {
            Some((_, cell, phi)) => {
                arms.extend(cell);
                phi
            }
            None => space.at_unit(centre, arms),
        }
    }

    /// [`EliteMixture::rho_model`] before the first failure: None once the archive holds a
    /// failure or while fewer than `rho_start` (at most `d + 2`) of its runs report a robustness (then the caller
    /// draws as before).
    fn descend<R: Rng + ?Sized>(
        &self,
        m: &EliteMixture,
        space: &Space,
        rng: &mut R,
        arms: &mut Vec<u16>,
    ) -> Option<Assignment> {
        if self.has_failure() {
            return None;
        }
        let robust: Vec<(f64, usize)> = self
            .points
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.robustness.map(|r| (r, i)))
            .collect();
        let start = m.rho_start.map_or(usize::MAX, |n| n as usize);
        if robust.len() < start.min(space.len() + 2) {
            return None;
        }
        // The lowest ρ first; the GP sees at most gp::GP_POINTS of them.
        let robust: Vec<(&[f64], f64)> = gp::lowest(robust)
            .into_iter()
            .map(|(r, i)| (&self.points[i].u[..], r))
            .collect();
        let best = robust[0].0;
        let gp = Gp::fit(robust, 4.0 * m.bandwidth)?;
        let sd = 4.0 * m.bandwidth;
        let mut chosen: Option<(f64, Vec<f64>)> = None;
        for i in 0..4 * m.tries {
            // Half around the lowest ρ, half anywhere.
            let u: Vec<f64> = if i % 2 == 0 {
                best.iter()
                    .map(|&c| reflect(c + sd * rng.sample::<f64, _>(StandardNormal)))
                    .collect()
            } else {
                (0..best.len()).map(|_| rng.random::<f64>()).collect()
            };
            let p = gp.failure_probability(&u);
            if chosen.as_ref().is_none_or(|c| p > c.0) {
                chosen = Some((p, u));
            }
        }
        chosen.map(|(_, u)| space.at_unit(&u, arms))
    }

    /// [`EliteMixture::rho_model`] once failures are known: the process fitted to the (at most
    /// [`gp::GP_POINTS`]) runs with a robustness nearest `centre`; None with fewer than `d + 2`.
    fn local_gp(&self, m: &EliteMixture, centre: &[f64], d: usize) -> Option<Gp<'_>> {
        let near: Vec<(f64, usize)> = self
            .points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.robustness.is_some())
            .map(|(i, p)| (squared_distance(&p.u, centre), i))
            .collect();
        if near.len() < d + 2 {
            return None;
        }
        let near = gp::lowest(near).into_iter().filter_map(|(_, i)| {
            let p = &self.points[i];
            Some((&p.u[..], p.robustness?))
        });
        Gp::fit(near.collect(), 4.0 * m.bandwidth)
    }

    /// The trials in flight as the archive expects them to end: each carrying the Parzen cost
    /// at its φ, with the Parzen failure odds there as its failure mass.
    fn fantasies(&self, m: &EliteMixture, in_flight: &[InFlight]) -> Vec<(Point, f64)> {
        if in_flight.is_empty() {
            return Vec::new();
        }
        let told = View::new(self, m, &[]);
        in_flight
            .iter()
            .map(|f| {
                let (odds, cost) = parzen(&told, &f.u, m);
                let point = Point {
                    u: f.u.clone(),
                    cell: f.cell.clone(),
                    failure: false,
                    robustness: None,
                    cost,
                };
                (point, odds)
            })
            .collect()
    }

    /// The mean cost of the archived trials that carry one (None: none does).
    fn mean_cost(&self) -> Option<f64> {
        let (n, sum) = self
            .points
            .iter()
            .filter_map(|p| p.cost)
            .fold((0usize, 0.0), |(n, s), c| (n + 1, s + c));
        (n > 0 && sum > 0.0).then(|| sum / n as f64)
    }

    /// The robustness at the `q` quantile of the passing runs (None without enough of them).
    fn near_miss_threshold(&self, q: f64) -> Option<f64> {
        if q <= 0.0 {
            return None;
        }
        let mut r: Vec<f64> = self
            .points
            .iter()
            .filter(|p| !p.failure)
            .filter_map(|p| p.robustness)
            .collect();
        if r.len() < 5 {
            return None;
        }
        r.sort_by(f64::total_cmp);
        Some(r[((q * r.len() as f64) as usize).min(r.len() - 1)])
    }
}

/// The archive as one proposal sees it: the told trials, then the fantasies of the trials in
/// flight, each with its weight as a centre (0 for a fantasy) and its failure mass (1 or 0 for
/// a told trial, the expected odds for a fantasy).
struct View<'p> {
    points: Vec<&'p Point>,
    weights: Vec<f64>,
    failures: Vec<f64>,
    /// The told trials' mean cost, with `per_cost`.
    mean_cost: Option<f64>,
    /// Below this exponent a kernel value changes no Parzen sum ([`ln_cut`]).
    ln_cut: f64,
}

impl<'p> View<'p> {
    fn new(archive: &'p Archive, m: &EliteMixture, fantasies: &'p [(Point, f64)]) -> Self {
        let told = archive.points.iter().filter(|p| p.failure).count();
        let threshold = if told < m.near_miss_until as usize {
            archive.near_miss_threshold(m.near_miss)
        } else {
            None
        };
        let n = archive.points.len() + fantasies.len();
        let mut view = View {
            points: Vec::with_capacity(n),
            weights: Vec::with_capacity(n),
            failures: Vec::with_capacity(n),
            mean_cost: archive.mean_cost().filter(|_| m.per_cost),
            ln_cut: f64::NEG_INFINITY,
        };
        for p in &archive.points {
            view.points.push(p);
            view.weights.push(p.weight(m, threshold));
            view.failures.push(f64::from(u8::from(p.failure)));
        }
        // A fantasy is no centre (weight 0): as centres, fantasies cost yield (0.454 against
        // 0.470 failures per unit cost with 4 in flight, kernel/tests/cost.rs's problem).
        for (p, odds) in fantasies {
            view.points.push(p);
            view.weights.push(0.0);
            view.failures.push(*odds);
        }
        view.ln_cut = view.cut();
        view
    }

    /// [`ln_cut`] for this view's largest weight and cost.
    fn cut(&self) -> f64 {
        let w_max = self.weights.iter().copied().fold(0.0, f64::max);
        let c_max = self
            .points
            .iter()
            .filter_map(|p| p.cost)
            .fold(0.0, f64::max);
        ln_cut(w_max, self.mean_cost.map(|mean| (mean, c_max)))
    }

    /// Per joint cell: (trials, failure mass).
    fn tried_cells(&self) -> Cells<'p> {
        let mut cells = Cells::with_capacity_and_hasher(self.points.len(), Default::default());
        for (p, f) in self.points.iter().zip(&self.failures) {
            let c = cells.entry(&p.cell[..]).or_default();
            c.0 += 1;
            c.1 += f;
        }
        cells
    }

    /// The centres of the mixture: (index of the point, weight > 0).
    fn elites(&self, m: &EliteMixture, tried: &Cells<'_>) -> Vec<(usize, f64)> {
        let failures = |p: &Point| tried.get(&*p.cell).map_or(0.0, |c| c.1);
        let novelty = |p: &Point| 1.0 / (1.0 + m.spread * failures(p));
        // Ranking per cost: a failure that was cheap to run is a likelier centre of cheap ones.
        let cheap = |p: &Point| match (self.mean_cost, p.cost) {
            (Some(mean), Some(c)) if c > 0.0 => mean / c,
            _ => 1.0,
        };
        self.points
            .iter()
            .zip(&self.weights)
            .enumerate()
            // A point of weight 0 (a pass) is no centre: its cell is not looked up.
            .filter(|(_, (_, &w))| w > 0.0)
            .map(|(i, (p, w))| (i, w * novelty(p) * cheap(p)))
            .filter(|e| e.1 > 0.0)
            .collect()
    }
}

/// The Parzen estimates at `u`, in one pass over `points` (one kernel value per point): the
/// failure probability Σ K·w / (Σ K + 1) + ½-prior, with `w` = 1 for failures, the near-miss
/// weight for near-misses, 0 otherwise; and, given the archive's `mean_cost`, a trial's cost
/// Σ K·c / Σ K over the points that carry one, shrunk towards `mean_cost` with the weight of
/// one trial. Each sum adds its terms in archive order, as two passes would.
///
/// A point so far from `u` that its terms are below half a unit in the last place of every sum
/// they join cannot change any sum, so its kernel value is not computed (`ln_cut`): the sums
/// are bit for bit those of the full pass.
fn parzen(view: &View<'_>, u: &[f64], m: &EliteMixture) -> (f64, Option<f64>) {
    let inv = -0.5 / (m.bandwidth * m.bandwidth);
    let mean_cost = view.mean_cost;
    let (mut hit, mut all) = (0.5, 1.0);
    let (mut cost, mut costed) = (mean_cost.unwrap_or(0.0), 1.0);
    for (p, w) in view.points.iter().zip(&view.weights) {
        let exponent = squared_distance(&p.u, u) * inv;
        if exponent < view.ln_cut {
            continue;
        }
        let k = exponent.exp();
        hit += k * w;
        all += k;
        if let (Some(_), Some(c)) = (mean_cost, p.cost) {
            cost += k * c;
            costed += k;
        }
    }
    (hit / all, mean_cost.map(|_| cost / costed))
}

/// The log of the largest kernel value whose Parzen terms cannot change a sum: every sum
/// starts at ≥ ½ (the odds), 1 (the kernel mass) or the mean cost, and only grows, and a term
/// below 2⁻⁵⁴ of a sum's start is below half its last place; terms are K·w with w ≤ `w_max`
/// and K·c with c ≤ `c_max`. One more factor e for rounding in `exp`.
fn ln_cut(w_max: f64, cost: Option<(f64, f64)>) -> f64 {
    let mut scale = 0.5 / w_max.max(1.0);
    if let Some((mean, c_max)) = cost {
        if c_max > 0.0 {
            scale = scale.min(mean / c_max);
        }
    }
    if scale.is_finite() && scale > 0.0 {
        (scale * 2f64.powi(-54)).ln() - 1.0
    } else {
        f64::NEG_INFINITY
    }
}

/// A trial in flight: its φ in the unit cube and its joint cell.
#[derive(Debug, Clone)]
pub(crate) struct InFlight {
    pub(crate) u: Vec<f64>,
    pub(crate) cell: Vec<u16>,
}

/// What a draw of φ needs besides the archive and its parameters.
#[derive(Clone, Copy)]
pub(crate) struct Draw<'a> {
    /// Draw for failures ([`crate::Deployment::exploit`]).
    pub(crate) exploit: bool,
    /// The scenario's independent bins (exploration).
    pub(crate) bins: &'a Posterior,
    /// The scenario's φ-space.
    pub(crate) space: &'a Space,
    /// The scenario's trials in flight (with crowding or fantasies; else empty).
    pub(crate) in_flight: &'a [InFlight],
}

/// Σ K(u, v) over the trials in flight `v` (Gaussian kernels of `bandwidth`).
fn crowd(u: &[f64], in_flight: &[InFlight], bandwidth: f64) -> f64 {
    let inv = -0.5 / (bandwidth * bandwidth);
    in_flight
        .iter()
        .map(|v| (squared_distance(u, &v.u) * inv).exp())
        .sum()
}

/// Folds `x` back into `[0, 1]` by reflection at the walls.
fn reflect(x: f64) -> f64 {
    if !x.is_finite() {
        return 0.5;
    }
    let y = x.rem_euclid(2.0);
    if y > 1.0 {
        2.0 - y
    } else {
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Skipping the far points' kernel values leaves every Parzen sum bit for bit as the full
    /// pass adds it, with near-miss weights above 1 and costs 10⁹ times the mean.
    #[test]
    fn the_cut_parzen_sums_equal_the_full_ones_bit_for_bit() {
        use rand::SeedableRng;
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let m = EliteMixture {
            bandwidth: 0.03,
            near_miss_weight: 3.0,
            ..EliteMixture::default()
        };
        let mut archive = Archive::default();
        for i in 0..3000 {
            let u: Vec<f64> = (0..3).map(|_| rng.random()).collect();
            let cost = if i % 997 == 0 {
                1e9
            } else {
                rng.random::<f64>()
            };
            archive.points.push_back(Point {
                u,
                cell: vec![0; 3],
                failure: i % 3 == 0,
                robustness: Some(rng.random()),
                cost: Some(cost),
            });
        }
        let mut view = View::new(&archive, &m, &[]);
        view.weights.iter_mut().step_by(7).for_each(|w| *w = 3.0);
        view.ln_cut = view.cut();
        assert!(view.ln_cut > -800.0, "{}", view.ln_cut);
        let mut skipped = 0;
        for _ in 0..200 {
            let u: Vec<f64> = (0..3).map(|_| rng.random()).collect();
            let cut = parzen(&view, &u, &m);
            let full = parzen(
                &View {
                    ln_cut: f64::NEG_INFINITY,
                    points: view.points.clone(),
                    weights: view.weights.clone(),
                    failures: view.failures.clone(),
                    mean_cost: view.mean_cost,
                },
                &u,
                &m,
            );
            assert_eq!(cut.0.to_bits(), full.0.to_bits());
            assert_eq!(cut.1.map(f64::to_bits), full.1.map(f64::to_bits));
            let inv = -0.5 / (m.bandwidth * m.bandwidth);
            skipped += view
                .points
                .iter()
                .filter(|p| squared_distance(&p.u, &u) * inv < view.ln_cut)
                .count();
        }
        assert!(skipped > 200 * 1000, "only {skipped} kernel values skipped");
    }

    #[test]
    fn reflect_stays_in_the_unit_interval() {
        for &(x, y) in &[
            (0.3, 0.3),
            (-0.2, 0.2),
            (1.1, 0.9),
            (2.5, 0.5),
            (-1.25, 0.75),
        ] {
            assert!((reflect(x) - y).abs() < 1e-12, "{x}");
        }
        assert_eq!(reflect(f64::NAN), 0.5);
    }
}
