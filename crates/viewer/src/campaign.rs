//! What the campaign recording shows (laid out by `super::layout::campaign`), on two
//! timelines: `trial` (the campaign-wide told index) and `runtime` (the wall seconds of
//! simulation the trial's stage has spent so far, HF and LF runs — every stage starts at 0,
//! so stages compare on one plot as in the paper's figures).
//!
//! - `/campaign/found_failures/<stage>`: HF failures found so far (for an LF screening stage:
//!   the HF failures its confirmations and audits found, on the LF + HF runtime);
//! - `/campaign/fidelity_success/<stage>`: the share of paired trials so far whose θ_LF was a
//!   fidelity success (Table II: TP or TN at a cost ratio within the budget);
//! - `/campaign/cost_ratio/<stage>`: each paired trial's t_LF / t_HF;
//! - `/posterior/<stage>/fidelity`: every fidelity setting's arms as a grid of cells (name,
//!   posterior mean as colour and text) with θ_HF outlined white and the MAP outlined magenta;
//! - `/posterior/<stage>/scenarios`: the same for each scenario's φ-bins;
//! - `/campaign/summary`: what was recorded, and why.

use super::stream::{err, RecordError, RecordOptions};
use rerun::RecordingStream;
use savme_campaign::log::{ScreenLine, TrialLine};
use savme_campaign::Stage;
use savme_campaign::{Problem, Protocol};
use savme_kernel::{Estimator, Kernel, Posterior, Space, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Cell size of the posterior grids (2D view units; tall enough for a label inside).
const CELL: (f32, f32) = (10.0, 4.0);
/// Width of the column of row names left of a grid, in cells (a label is centred on its box,
/// so a name never reaches into the grid, and the view, which frames the boxes, never crops it).
const NAME_CELLS: f32 = 3.0;

/// The box of a row's name: `NAME_CELLS` cells wide, left of the grid's first column, at `y`.
fn name_box(y: f32) -> ((f32, f32), (f32, f32)) {
    let (w, h) = CELL;
    ((-(NAME_CELLS + 0.1) * w, y), (NAME_CELLS * w, h * 0.9))
}

/// Boxes as (mins, sizes).
type BoxList = (Vec<(f32, f32)>, Vec<(f32, f32)>);

/// Labels shown inside boxes `mins` + `sizes`: the viewer draws a 2D box's label just below
/// the box, so each label hangs from a flat box along the top edge of its box (`path`, in the
/// box's colour).
fn log_labels(
    rec: &RecordingStream,
    path: String,
    boxes: BoxList,
    colours: Vec<rerun::Color>,
    labels: Vec<String>,
) -> Result<(), RecordError> {
    let flat: Vec<(f32, f32)> = boxes.1.iter().map(|(w, _)| (*w, 0.02)).collect();
    rec.log(
        path,
        &rerun::Boxes2D::from_mins_and_sizes(boxes.0, flat)
            .with_colors(colours)
            .with_labels(labels)
            .with_show_labels(true)
            .with_draw_order(4.0),
    )
    .map_err(err)
}

#[derive(Debug, Default, Clone)]
struct StageTally {
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
}

/// A stage label as an entity-path part: `train@0.3` → `train_0_3`.
pub fn entity_label(label: &str) -> String {
    label.replace(['@', '.'], "_")
}

impl CampaignView {
    /// The view of a campaign on `problem`.
    pub fn new(problem: &Problem) -> Self {
        CampaignView {
            fidelity: problem.fidelity.clone(),
            theta_hf_arms: problem
                .fidelity
                .arms_of(&problem.theta_hf)
                .unwrap_or_default(),
            scenarios: problem.scenarios.clone(),
            stages: BTreeMap::new(),
        }
    }

    /// The entity labels of the stages that learn (one tab of posterior grids each).
    pub fn learning_labels(protocol: &Protocol) -> Vec<String> {
        protocol
            .stages()
            .iter()
            .filter(|s| s.phase().learns())
            .map(|s| entity_label(&s.label()))
            .collect()
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
                rec.log_static(
                    format!("campaign/cost_ratio/{label}"),
                    &rerun::SeriesPoints::new()
                        .with_names([stage.label()])
                        .with_marker_sizes([2.0f32]),
                )
                .map_err(err)?;
                rec.log_static(
                    format!("campaign/fidelity_success/{label}"),
                    &rerun::SeriesLines::new().with_names([stage.label()]),
                )
                .map_err(err)?;
            }
        }
        let last = line.index + 1 == stage.iterations;
        if stage.phase().learns() && (line.index.is_multiple_of(10) || last) {
            self.log_posteriors(rec, &label, kernel)?;
        }
        Ok(())
    }

    /// Records screening trial number `n` of the campaign: its HF failure (a confirmed LF
    /// failure, or an audit's miss) on the found-failures plot, at the LF + HF runtime.
    pub fn screened(
        &mut self,
        rec: &RecordingStream,
        n: u64,
        stage: &Stage,
        line: &ScreenLine,
    ) -> Result<(), RecordError> {
        let runtime = line.lf.wall_seconds + line.hf.map_or(0.0, |h| h.wall_seconds);
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
        t.trials += 1;
        t.runtime += runtime;
        t.found += u64::from(failure);
        let tally = t.clone();
        rec.set_time_sequence("trial", n as i64);
        rec.set_duration_secs("runtime", tally.runtime);
        if tally.trials == 1 {
            rec.log_static(
                format!("campaign/found_failures/{label}"),
                &rerun::SeriesLines::new().with_names([stage.label()]),
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
        let mut y = 0.0;
        for (name, space) in &self.scenarios {
            if let Some(p) = kernel.scenario_posterior(name) {
                let path = format!("posterior/{label}/scenarios/{name}");
                let (min, size) = name_box(y - CELL.1);
                log_labels(
                    rec,
                    format!("{path}/title"),
                    (vec![min], vec![size]),
                    vec![rerun::Color::from_rgb(240, 240, 240)],
                    vec![format!("scenario {name}")],
                )?;
                log_grid(rec, &path, space, p, None, y)?;
                y += (space.variables().len() as f32 + 2.0) * CELL.1;
            }
        }
        Ok(())
    }

    /// The campaign's summary document: the recorded trials and the selection rule.
    pub fn summary_markdown(&self, recorded: &[String], opts: &RecordOptions) -> String {
        let mut s = String::from("## Campaign\n\n| stage | trials | HF failures | fidelity success | runtime |\n|---|---|---|---|---|\n");
        for (label, t) in &self.stages {
            let rate = if t.paired > 0 {
                format!("{:.0} %", 100.0 * t.successes as f64 / t.paired as f64)
            } else {
                "—".into()
            };
            let _ = writeln!(
                s,
                "| {label} | {} | {} | {rate} | {:.1} s |",
                t.trials, t.found, t.runtime
            );
        }
        let _ = writeln!(
            s,
            "\n**{} trial recordings** (every {}-th trial, plus up to {} informative ones: FN and FP \
             first, then TP, then baseline HF failures). Pick one under *Recordings*:\n",
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

/// Dark blue (0) to yellow (1).
fn heat(t: f64) -> rerun::Color {
    let t = t.clamp(0.0, 1.0) as f32;
    let lerp = |a: f32, b: f32| (a + (b - a) * t) as u8;
    rerun::Color::from_rgb(lerp(30.0, 250.0), lerp(40.0, 220.0), lerp(110.0, 40.0))
}

/// One posterior as a grid: a row per variable (its name on the left), a cell per arm.
// Long because it lays out four entities (cells, names, θ_HF and MAP outlines) in one pass.
fn log_grid(
    rec: &RecordingStream,
    path: &str,
    space: &Space,
    p: &Posterior,
    highlight: Option<&[usize]>,
    y0: f32,
) -> Result<(), RecordError> {
    let (w, h) = CELL;
    let map = p.best_arms(Estimator::Map);
    let (mut mins, mut sizes, mut colours, mut labels) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut name_mins, mut name_sizes, mut names) = (Vec::new(), Vec::new(), Vec::new());
    let (mut hf_mins, mut map_mins) = (Vec::new(), Vec::new());
    for (i, arms) in p.arms().iter().enumerate() {
        let y = y0 + i as f32 * h;
        let (min, size) = name_box(y);
        name_mins.push(min);
        name_sizes.push(size);
        names.push(p.names()[i].clone());
        for (a, arm) in arms.iter().enumerate() {
            let x = a as f32 * w;
            mins.push((x, y));
            sizes.push((w * 0.95, h * 0.9));
            colours.push(heat(arm.mean()));
            labels.push(format!("{} {:.2}", arm_name(space, i, a), arm.mean()));
        }
        if let Some(hf) = highlight.and_then(|hl| hl.get(i)) {
            hf_mins.push((*hf as f32 * w, y));
        }
        if let Some(m) = map.get(i) {
            map_mins.push((f32::from(*m) * w + 0.3, y + 0.2));
        }
    }
    rec.log(
        format!("{path}/cells"),
        &rerun::Boxes2D::from_mins_and_sizes(mins.clone(), sizes.clone())
            .with_colors(colours.clone())
            .with_draw_order(1.0),
    )
    .map_err(err)?;
    log_labels(
        rec,
        format!("{path}/cells/labels"),
        (mins, sizes),
        colours,
        labels,
    )?;
    let grey = vec![rerun::Color::from_rgb(150, 150, 150); names.len()];
    log_labels(
        rec,
        format!("{path}/names"),
        (name_mins, name_sizes),
        grey,
        names,
    )?;
    let n_map = map_mins.len();
    rec.log(
        format!("{path}/map"),
        &rerun::Boxes2D::from_mins_and_sizes(
            map_mins,
            vec![(w * 0.95 - 0.6, h * 0.9 - 0.4); n_map],
        )
        .with_colors([rerun::Color::from_rgb(255, 0, 255)])
        .with_radii([0.25f32])
        .with_labels(["MAP"])
        .with_show_labels(false)
        .with_draw_order(3.0),
    )
    .map_err(err)?;
    if !hf_mins.is_empty() {
        let n = hf_mins.len();
        rec.log_static(
            format!("{path}/theta_hf"),
            &rerun::Boxes2D::from_mins_and_sizes(hf_mins, vec![(w * 0.95, h * 0.9); n])
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
