//! What the campaign recording shows (laid out by `super::layout::campaign`), on two
//! timelines: `trial` (the campaign-wide told index) and `runtime` (the wall seconds of
//! simulation the trial's stage has spent so far, HF and LF runs — every stage starts at 0,
//! so stages compare on one plot as in the paper's figures).
//!
//! - `/campaign/found_failures/<stage>`: HF failures found so far (for an LF screening stage:
//!   the HF failures its confirmations and audits found, on the LF + HF runtime);
//! - `/campaign/fidelity_success/<stage>`: the share of paired trials so far whose θ_LF was a
//!   fidelity success (Table II: TP or TN at a cost ratio within the budget);
//! - `/campaign/cost_ratio/<stage>`: each paired trial's t_LF / t_HF, and
//!   `/campaign/cost_ratio/budget_<b>` the budget it is judged against;
//! - `/campaign/key`: the stages' colours (one per stage, the same on every plot: see
//!   `super::palette`), the key the plots share instead of legends over their data;
//! - `/posterior/<stage>/fidelity`: every fidelity setting's arms as a grid of cells (name,
//!   posterior mean as colour and text) with θ_HF outlined white and the MAP outlined magenta,
//!   and a key row below (the colour scale, the two outlines);
//! - `/posterior/<stage>/scenarios/<scenario>`: the same for each scenario's φ-bins (one view
//!   each);
//! - `/campaign/summary`: what was recorded, why, and how to open a trial.

use super::palette::{self, heat, rgb};
use super::plan::entity_label;
use super::plan::{name_box, CampaignPlan, CELL, CELL_FILL};
use super::stream::{err, RecordError, RecordOptions};
use rerun::RecordingStream;
use savme_campaign::log::{ScreenLine, TrialLine};
use savme_campaign::Stage;
use savme_campaign::{Problem, Protocol};
use savme_kernel::{Domain, Estimator, Kernel, Posterior, Space, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Boxes as (mins, sizes).
type BoxList = (Vec<(f32, f32)>, Vec<(f32, f32)>);

/// Where a grid cell's labels hang from, as a share of the cell's height below its top: the
/// viewer draws a label's text from ~5 px to ~21 px below its anchor, so in a ~50 px row the
/// arm's name (from the top) and its posterior mean (from 0.45) both sit inside the cell's box
/// with no border through them, and a one-line label (a row's name, a key cell) from 0.22 is
/// centred.
const NAME_LINE: f32 = 0.0;
const MEAN_LINE: f32 = 0.45;
const ONE_LINE: f32 = 0.22;
/// How far the white θ_HF outline lies outside its cell's box (the magenta MAP outline is the
/// box's own edge): in the gap between cells, clear of the cell's text.
const HF_MARGIN: f32 = 0.3;

/// The box of a grid cell (or a key cell) at `min`: [`CELL`] times [`CELL_FILL`].
fn cell_box() -> (f32, f32) {
    (CELL.0 * CELL_FILL, CELL.1 * CELL_FILL)
}

/// `mins` moved down by `share` of a cell's height: where labels of those cells hang from.
fn lines(mins: &[(f32, f32)], share: f32) -> Vec<(f32, f32)> {
    mins.iter().map(|(x, y)| (*x, y + share * CELL.1)).collect()
}

/// Labels hung from the points `boxes.0` (each centred over the width `boxes.1` of its box):
/// the viewer draws a 2D box's label just below the box, so each label hangs from a flat box
/// ending at its point (`path`, in the box's colour; its outline drawn 0 wide, so that it draws
/// no line through the label above).
fn log_labels(
    rec: &RecordingStream,
    path: String,
    boxes: BoxList,
    colours: Vec<rerun::Color>,
    labels: Vec<String>,
) -> Result<(), RecordError> {
    let flat: Vec<(f32, f32)> = boxes.1.iter().map(|(w, _)| (*w, 0.02)).collect();
    let mins: Vec<(f32, f32)> = boxes.0.iter().map(|(x, y)| (*x, y - 0.02)).collect();
    rec.log(
        path,
        &rerun::Boxes2D::from_mins_and_sizes(mins, flat)
            .with_colors(colours)
            .with_radii([0.0f32])
            .with_labels(labels)
            .with_show_labels(true)
            .with_draw_order(4.0),
    )
    .map_err(err)
}

#[derive(Debug, Default, Clone)]
struct StageTally {
    /// The stage's readable name ([`savme_campaign::StageId::title`]).
    title: String,
    runtime: f64,
    found: u64,
    paired: u64,
    successes: u64,
    trials: u64,
}

/// The campaign view's state.
#[derive(Debug)]
pub struct CampaignView {
    fidelity: Space,
    theta_hf_arms: Vec<usize>,
    scenarios: BTreeMap<String, Space>,
    stages: BTreeMap<String, StageTally>,
    colours: BTreeMap<String, rerun::Color>,
    budgets_logged: BTreeMap<String, bool>,
}

impl CampaignView {
    /// What the layout needs ([`CampaignPlan::new`]).
    pub fn plan(problem: &Problem, protocol: &Protocol) -> CampaignPlan {
        CampaignPlan::new(problem, protocol)
    }

    /// The view of a campaign running `protocol` on `problem`.
    pub fn new(problem: &Problem, protocol: &Protocol) -> Self {
        CampaignView {
            fidelity: problem.fidelity.clone(),
            theta_hf_arms: problem
                .fidelity
                .arms_of(&problem.theta_hf)
                .unwrap_or_default(),
            scenarios: problem.scenarios.clone(),
            stages: BTreeMap::new(),
            colours: palette::stage_colours(protocol),
            budgets_logged: BTreeMap::new(),
        }
    }

    /// The colour of stage `label` (the same on every plot).
    fn colour(&self, label: &str) -> rerun::Color {
        self.colours
            .get(label)
            .copied()
            .unwrap_or_else(|| rgb(palette::REFERENCE))
    }

    /// The stage key: one swatch per stage in its colour, labelled, four to a row.
    pub fn log_key(&self, rec: &RecordingStream) -> Result<(), RecordError> {
        let (w, h) = (16.0f32, 2.2f32);
        let (mut mins, mut sizes, mut colours, mut labels) = (vec![], vec![], vec![], vec![]);
        for (k, (label, c)) in self.colours.iter().enumerate() {
            let (col, row) = ((k % 4) as f32, (k / 4) as f32);
            mins.push((col * w * 1.05, row * h * 1.15));
            sizes.push((w, h));
            colours.push(*c);
            labels.push(label.clone());
        }
        rec.log_static(
            "campaign/key/swatches",
            &rerun::Boxes2D::from_mins_and_sizes(mins.clone(), sizes.clone())
                .with_colors(colours.clone())
                .with_radii([0.3f32])
                .with_draw_order(1.0),
        )
        .map_err(err)?;
        let flat: Vec<(f32, f32)> = sizes.iter().map(|(w, _)| (*w, 0.01)).collect();
        rec.log_static(
            "campaign/key/names",
            &rerun::Boxes2D::from_mins_and_sizes(mins, flat)
                .with_colors(colours)
                .with_labels(labels)
                .with_show_labels(true)
                .with_draw_order(2.0),
        )
        .map_err(err)
    }

    /// Logs a told trial (`n`: campaign-wide index).
    pub fn trial(
        &mut self,
        rec: &RecordingStream,
        n: u64,
        stage: &Stage,
        line: &TrialLine,
        kernel: &Kernel,
    ) -> Result<(), RecordError> {
        let runtime = line.hf.wall_seconds + line.lf.map_or(0.0, |l| l.wall_seconds);
        let label = self.found(rec, n, stage, runtime, line.hf.failure)?;
        if let (Some(outcome), Some(ratio), Some(budget)) =
            (line.outcome, line.cost_ratio, stage.budget)
        {
            let t = self.stages.entry(label.clone()).or_default();
            t.paired += 1;
            t.successes += u64::from(outcome.fidelity_success(ratio, budget));
            let rate = t.successes as f64 / t.paired as f64;
            rec.log(
                format!("campaign/fidelity_success/{label}"),
                &rerun::Scalars::single(rate),
            )
            .map_err(err)?;
            rec.log(
                format!("campaign/cost_ratio/{label}"),
                &rerun::Scalars::single(ratio),
            )
            .map_err(err)?;
            if t.paired == 1 {
                let c = self.colour(&stage.label());
                rec.log_static(
                    format!("campaign/cost_ratio/{label}"),
                    &rerun::SeriesPoints::new()
                        .with_names([stage.label()])
                        .with_colors([c])
                        .with_marker_sizes([2.0f32]),
                )
                .map_err(err)?;
                rec.log_static(
                    format!("campaign/fidelity_success/{label}"),
                    &rerun::SeriesLines::new()
                        .with_names([stage.label()])
                        .with_colors([c]),
                )
                .map_err(err)?;
            }
            self.log_budget(rec, budget)?;
        }
        let last = line.index + 1 == stage.iterations;
        if stage.phase().learns() && (line.index.is_multiple_of(10) || last) {
            self.log_posteriors(rec, &label, kernel)?;
        }
        Ok(())
    }

    /// The budget a paired trial's cost ratio is judged against, as a line on the cost plot
    /// (at the trial's time on the timelines: a flat line over every stage at that budget).
    fn log_budget(&mut self, rec: &RecordingStream, budget: f64) -> Result<(), RecordError> {
        let path = format!(
            "campaign/cost_ratio/budget_{}",
            entity_label(&budget.to_string())
        );
        if !self.budgets_logged.contains_key(&path) {
            rec.log_static(
                path.clone(),
                &rerun::SeriesLines::new()
                    .with_names([format!("budget {budget}")])
                    .with_colors([rgb(palette::REFERENCE)]),
            )
            .map_err(err)?;
            self.budgets_logged.insert(path.clone(), true);
        }
        rec.log(path, &rerun::Scalars::single(budget)).map_err(err)
    }

    /// Records screening trial number `n` of the campaign: its HF failure (a confirmed LF
    /// failure, or an audit's miss) on the found-failures plot, at the LF + HF runtime (every
    /// level of a fidelity ladder).
    pub fn screened(
        &mut self,
        rec: &RecordingStream,
        n: u64,
        stage: &Stage,
        line: &ScreenLine,
    ) -> Result<(), RecordError> {
        let seconds = |r: Option<savme_campaign::log::RunLine>| r.map_or(0.0, |r| r.wall_seconds);
        let rungs: f64 = line.ladder.iter().map(|r| seconds(r.lf)).sum();
        let runtime = rungs + seconds(line.lf) + seconds(line.hf);
        let failure = line.hf.is_some_and(|h| h.failure);
        self.found(rec, n, stage, runtime, failure).map(|_| ())
    }

    /// Counts one more trial of `stage` (its runtime, and an HF failure if `failure`), sets
    /// the timelines and logs the stage's found-failures curve; returns the stage's label.
    fn found(
        &mut self,
        rec: &RecordingStream,
        n: u64,
        stage: &Stage,
        runtime: f64,
        failure: bool,
    ) -> Result<String, RecordError> {
        let label = entity_label(&stage.label());
        let t = self.stages.entry(label.clone()).or_default();
        if t.title.is_empty() {
            t.title = stage.id().title();
        }
        t.trials += 1;
        t.runtime += runtime;
        t.found += u64::from(failure);
        let tally = t.clone();
        rec.set_time_sequence("trial", n as i64);
        rec.set_duration_secs("runtime", tally.runtime);
        if tally.trials == 1 {
            rec.log_static(
                format!("campaign/found_failures/{label}"),
                &rerun::SeriesLines::new()
                    .with_names([stage.label()])
                    .with_colors([self.colour(&stage.label())]),
            )
            .map_err(err)?;
        }
        rec.log(
            format!("campaign/found_failures/{label}"),
            &rerun::Scalars::single(tally.found as f64),
        )
        .map_err(err)?;
        Ok(label)
    }

    fn log_posteriors(
        &self,
        rec: &RecordingStream,
        label: &str,
        kernel: &Kernel,
    ) -> Result<(), RecordError> {
        log_grid(
            rec,
            &format!("posterior/{label}/fidelity"),
            &self.fidelity,
            kernel.fidelity_posterior(),
            Some(&self.theta_hf_arms),
            0.0,
        )?;
        for (name, space) in &self.scenarios {
            if let Some(p) = kernel.scenario_posterior(name) {
                let path = format!("posterior/{label}/scenarios/{name}");
                log_grid(rec, &path, space, p, None, 0.0)?;
            }
        }
        Ok(())
    }

    /// The campaign's summary document: the recorded trials and the selection rule.
    pub fn summary_markdown(&self, recorded: &[String], opts: &RecordOptions) -> String {
        let mut s = String::from("## Campaign\n\n| stage | trials | HF failures | fidelity success | runtime |\n|---|---|---|---|---|\n");
        for t in self.stages.values() {
            let rate = if t.paired > 0 {
                format!("{:.0} %", 100.0 * t.successes as f64 / t.paired as f64)
            } else {
                "—".into()
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {rate} | {:.1} s |",
                t.title, t.trials, t.found, t.runtime
            );
        }
        let _ = writeln!(
            s,
            "\n**{} trial recordings** (every {}-th trial, plus up to {} informative ones, spread over \
             the stages and the outcome classes FN, FP, TP and baseline HF failures). Each is a \
             recording of its own: open the left panel (the first of the three panel buttons at the \
             top right) and pick it under *Sources*, by its name:\n",
            recorded.len(),
            opts.every,
            opts.failure_cap
        );
        for r in recorded {
            let _ = writeln!(s, "- {r}");
        }
        s
    }
}

/// A compact name for an arm (it must fit a cell beside the mean): the value, or the bin's
/// representative to two significant digits or the unit.
fn arm_name(space: &Space, var: usize, arm: usize) -> String {
    let v = &space.variables()[var];
    match v.representative(arm) {
        Value::Real(x) if x.abs() >= 10.0 || x == x.round() => format!("{x:.0}"),
        Value::Real(x) if x.abs() >= 1.0 => format!("{x:.1}"),
        Value::Real(x) => format!("{x:.2}"),
        other => other.to_string(),
    }
}

/// A row's name: the variable's name, and for a continuous φ variable its range (the cells
/// are its bins, in order). One line: the viewer shows a label's first line only.
fn row_name(space: &Space, var: usize, name: &str, phi: bool) -> String {
    match &space.variables()[var].domain {
        Domain::Continuous { lo, hi, .. } if phi => format!("{name} {lo}–{hi}"),
        _ => name.to_string(),
    }
}

/// The key row under a grid: the colour scale (posterior mean 0 to 1), and what the white and
/// magenta outlines mean.
fn log_key(
    rec: &RecordingStream,
    path: &str,
    rows: usize,
    theta_hf: bool,
) -> Result<(), RecordError> {
    let (w, h) = CELL;
    let y = (rows as f32 + 0.4) * h;
    let steps = [0.0, 0.25, 0.5, 0.75, 1.0];
    let mins: Vec<(f32, f32)> = (0..steps.len()).map(|k| (k as f32 * w, y)).collect();
    let sizes = vec![cell_box(); steps.len()];
    rec.log_static(
        format!("{path}/key/scale"),
        &rerun::Boxes2D::from_mins_and_sizes(mins.clone(), sizes.clone())
            .with_colors(steps.iter().map(|t| heat(*t)).collect::<Vec<_>>())
            .with_draw_order(1.0),
    )
    .map_err(err)?;
    let mut labels: Vec<String> = steps.iter().map(|t| t.to_string()).collect();
    let (mut lmins, mut lsizes, mut colours) = (mins, sizes, vec![rgb(palette::REFERENCE); 5]);
    let mut outline = |k: usize, name: &str, c: rerun::Color| -> Result<(), RecordError> {
        let min = (k as f32 * w, y);
        rec.log_static(
            format!(
                "{path}/key/{}",
                name.replace('θ', "theta").replace(' ', "_")
            ),
            &rerun::Boxes2D::from_mins_and_sizes([min], [cell_box()])
                .with_colors([c])
                .with_radii([0.3f32])
                .with_draw_order(2.0),
        )
        .map_err(err)?;
        lmins.push(min);
        lsizes.push(cell_box());
        colours.push(c);
        labels.push(name.to_string());
        Ok(())
    };
    if theta_hf {
        outline(5, "θ_HF", rerun::Color::from_rgb(255, 255, 255))?;
    }
    outline(6, "MAP", rerun::Color::from_rgb(255, 0, 255))?;
    let (min, size) = name_box(y);
    lmins.push(min);
    lsizes.push(size);
    colours.push(rgb(palette::REFERENCE));
    labels.push("key: posterior mean".into());
    log_labels(
        rec,
        format!("{path}/key/labels"),
        (lines(&lmins, ONE_LINE), lsizes),
        colours,
        labels,
    )
}

/// One posterior as a grid: a row per variable (its name on the left), a cell per arm, the key
/// row below.
// Long because it lays out four entities (cells, names, θ_HF and MAP outlines) in one pass.
fn log_grid(
    rec: &RecordingStream,
    path: &str,
    space: &Space,
    p: &Posterior,
    highlight: Option<&[usize]>,
    y0: f32,
) -> Result<(), RecordError> {
    let g = GridBoxes::of(space, p, highlight, y0);
    let rows = g.names.len();
    rec.log(
        format!("{path}/cells"),
        &rerun::Boxes2D::from_mins_and_sizes(g.mins.clone(), g.sizes.clone())
            .with_colors(g.colours.clone())
            .with_draw_order(1.0),
    )
    .map_err(err)?;
    // Two one-line labels per cell: the arm's name at the top, its mean below.
    log_labels(
        rec,
        format!("{path}/cells/means"),
        (lines(&g.mins, MEAN_LINE), g.sizes.clone()),
        g.colours.clone(),
        g.means,
    )?;
    log_labels(
        rec,
        format!("{path}/cells/labels"),
        (lines(&g.mins, NAME_LINE), g.sizes),
        g.colours,
        g.labels,
    )?;
    let grey = vec![rgb(palette::REFERENCE); rows];
    log_labels(
        rec,
        format!("{path}/names"),
        (lines(&g.name_mins, ONE_LINE), g.name_sizes),
        grey,
        g.names,
    )?;
    log_outlines(rec, path, g.map_mins, g.hf_mins)?;
    log_key(rec, path, rows, highlight.is_some())
}

/// Where a grid's boxes go and what they say: one cell per arm (heat colour, name, mean), one
/// name per row, and the cells the MAP and θ_HF outlines mark.
struct GridBoxes {
    mins: Vec<(f32, f32)>,
    sizes: Vec<(f32, f32)>,
    colours: Vec<rerun::Color>,
    labels: Vec<String>,
    means: Vec<String>,
    name_mins: Vec<(f32, f32)>,
    name_sizes: Vec<(f32, f32)>,
    names: Vec<String>,
    hf_mins: Vec<(f32, f32)>,
    map_mins: Vec<(f32, f32)>,
}

impl GridBoxes {
    fn of(space: &Space, p: &Posterior, highlight: Option<&[usize]>, y0: f32) -> GridBoxes {
        let (w, h) = CELL;
        let map = p.best_arms(Estimator::Map);
        let mut g = GridBoxes {
            mins: Vec::new(),
            sizes: Vec::new(),
            colours: Vec::new(),
            labels: Vec::new(),
            means: Vec::new(),
            name_mins: Vec::new(),
            name_sizes: Vec::new(),
            names: Vec::new(),
            hf_mins: Vec::new(),
            map_mins: Vec::new(),
        };
        for (i, arms) in p.arms().iter().enumerate() {
            let y = y0 + i as f32 * h;
            let (min, size) = name_box(y);
            g.name_mins.push(min);
            g.name_sizes.push(size);
            g.names
                .push(row_name(space, i, &p.names()[i], highlight.is_none()));
            for (a, arm) in arms.iter().enumerate() {
                g.mins.push((a as f32 * w, y));
                g.sizes.push(cell_box());
                g.colours.push(heat(arm.mean()));
                g.labels.push(arm_name(space, i, a));
                g.means.push(format!("{:.2}", arm.mean()));
            }
            if let Some(hf) = highlight.and_then(|hl| hl.get(i)) {
                g.hf_mins.push((*hf as f32 * w, y));
            }
            if let Some(m) = map.get(i) {
                g.map_mins.push((f32::from(*m) * w, y));
            }
        }
        g
    }
}

/// The magenta MAP outline in every row (on its cell's edge) and, for the θ grid, the white
/// θ_HF outline (just outside its cell): neither through the cell's text.
fn log_outlines(
    rec: &RecordingStream,
    path: &str,
    map_mins: Vec<(f32, f32)>,
    hf_mins: Vec<(f32, f32)>,
) -> Result<(), RecordError> {
    let (w, h) = cell_box();
    let n_map = map_mins.len();
    rec.log(
        format!("{path}/map"),
        &rerun::Boxes2D::from_mins_and_sizes(map_mins, vec![(w, h); n_map])
            .with_colors([rerun::Color::from_rgb(255, 0, 255)])
            .with_radii([0.25f32])
            .with_labels(["MAP"])
            .with_show_labels(false)
            .with_draw_order(3.0),
    )
    .map_err(err)?;
    if !hf_mins.is_empty() {
        let n = hf_mins.len();
        let m = HF_MARGIN;
        let mins: Vec<(f32, f32)> = hf_mins.iter().map(|(x, y)| (x - m, y - m)).collect();
        rec.log_static(
            format!("{path}/theta_hf"),
            &rerun::Boxes2D::from_mins_and_sizes(mins, vec![(w + 2.0 * m, h + 2.0 * m); n])
                .with_colors([rerun::Color::from_rgb(255, 255, 255)])
                .with_radii([0.35f32])
                .with_labels(["θ_HF"])
                .with_show_labels(false)
                .with_draw_order(2.0),
        )
        .map_err(err)?;
    }
    Ok(())
}
