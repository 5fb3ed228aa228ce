//! The layouts the viewer opens a recording with (rerun blueprints, stored in the recording so
//! that `rerun FILE.rrd` shows them): the trial view (HF | LF side by side, each a camera above
//! a 3D view that follows the ego, time series below, the outcome on the right), the FMU trial
//! view (a plot per recorded output, HF and LF in each, the outcome on the right) and the
//! campaign view (failures over runtime, fidelity success and cost, posterior grids).
//!
//! Built with the SDK's blueprint API. What that API cannot say — where a 3D view's eye sits,
//! a time series' y range, its legend, a 2D view's bounds — [`Layout::send`] adds as view
//! properties (`EyeControls3D`, `ScalarAxis`, `PlotLegend`, `VisualBounds2D`) to the same
//! blueprint store before activating it: a chase camera behind and above the ego, the distance
//! plot zoomed to the failure threshold, no legend over the data (a plot's title names its
//! colours; the campaign's plots share a key of stage colours), grids framed whole.

use super::error::{err, RecordError};
use super::plan::{grid_bounds, CampaignPlan};
use rerun::blueprint::components::{PanelState, PlayState};
use rerun::blueprint::{
    Blueprint, BlueprintActivation, BlueprintPanel, ContainerLike, Grid, Horizontal,
    SelectionPanel, Spatial2DView, Spatial3DView, Tabs, TextDocumentView, TextLogView, TimePanel,
    TimeSeriesView, Vertical,
};
use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    EyeControls3D, PlotLegend, ScalarAxis, TimeAxis, VisualBounds2D,
};
use rerun::external::re_sdk_types::blueprint::components::Eye3DKind;
use rerun::external::re_sdk_types::{AsComponents, SerializedComponentBatch};
use rerun::{RecordingStream, RecordingStreamBuilder};

/// View properties the SDK's view builders cannot set: (entity path in the blueprint store,
/// the property's components).
type Props = Vec<(String, Vec<SerializedComponentBatch>)>;

/// A blueprint and the view properties to add to it.
pub struct Layout {
    blueprint: Blueprint,
    props: Props,
}

/// A view property: `archetype` (e.g. `EyeControls3D`) of the view at `view` (`view/<uuid>`).
fn prop(props: &mut Props, view: &str, archetype: &str, value: &dyn AsComponents) {
    props.push((format!("{view}/{archetype}"), value.as_serialized_batches()));
}

/// A time series view without a legend (its title names the colours), its y range fixed to
/// `range` (the default zooms out to all data).
fn series(name: &str, origin: &str, range: Option<[f64; 2]>, props: &mut Props) -> ContainerLike {
    let (c, path) = child(TimeSeriesView::new(name).with_origin(origin));
    if let Some(r) = range {
        prop(props, &path, "ScalarAxis", &ScalarAxis::new().with_range(r));
    }
    no_legend(props, &path);
    c
}

/// Hides the legend of the time series view at `path` (a legend sits over the data).
fn no_legend(props: &mut Props, path: &str) {
    prop(
        props,
        path,
        "PlotLegend",
        &PlotLegend::new().with_visible(false),
    );
}

/// A 2D view of the grid at `origin` showing `bounds` (`[x_min, x_max, y_min, y_max]`).
fn grid_view(name: String, origin: String, bounds: [f32; 4], props: &mut Props) -> ContainerLike {
    let (c, path) = child(Spatial2DView::new(name).with_origin(origin));
    let [x0, x1, y0, y1] = bounds.map(f64::from);
    let range = rerun::datatypes::Range2D {
        x_range: rerun::datatypes::Range1D([x0, x1]),
        y_range: rerun::datatypes::Range1D([y0, y1]),
    };
    prop(props, &path, "VisualBounds2D", &VisualBounds2D::new(range));
    c
}

/// A view as a container child, with its blueprint path (`view/<uuid>`).
fn child(view: impl Into<ContainerLike>) -> (ContainerLike, String) {
    let c: ContainerLike = view.into();
    let path = match &c {
        ContainerLike::View(v) => v.blueprint_path().to_string(),
        _ => String::new(),
    };
    (c, path)
}

/// The eye of a 3D view whose origin is the ego (x forward, z up): 22 m behind, 12 m up,
/// looking at a point 10 m ahead — the ego, the intruder's approach and the lidar in view.
fn chase_eye() -> EyeControls3D {
    EyeControls3D::new()
        .with_kind(Eye3DKind::Orbital)
        .with_position([-22.0f32, 0.0, 12.0])
        .with_look_target([10.0f32, 0.0, 0.0])
        .with_eye_up([0.0f32, 0.0, 1.0])
}

/// The names of the views (also what the tests look for).
pub mod names {
    /// The HF run's camera.
    pub const HF_CAMERA: &str = "HF camera";
    /// The LF run's camera.
    pub const LF_CAMERA: &str = "LF camera";
    /// The HF run in 3D.
    pub const HF_3D: &str = "HF in 3D, following the ego (ego red, intruder orange)";
    /// The LF run in 3D.
    pub const LF_3D: &str = "LF in 3D, following the ego (ego blue, intruder purple)";
    /// The distance between the bodies of each run (what the failure is judged on), and the
    /// failure threshold: a collision, 0 m (the grey line).
    pub const DISTANCE: &str = "Body distance (m): HF red, LF blue; collision at 0";
    /// The same, HF alone.
    pub const DISTANCE_HF: &str = "Body distance (m): HF red; collision at 0";
    /// Speeds of both egos.
    pub const SPEED: &str = "Ego speed (m/s): HF red, LF blue";
    /// The HF ego's speed.
    pub const SPEED_HF: &str = "Ego speed (m/s): HF red";
    /// Braking flags.
    pub const BRAKING: &str = "Ego braking (1 = brakes): HF red, LF blue";
    /// The HF ego's braking flag.
    pub const BRAKING_HF: &str = "Ego braking (1 = brakes): HF red";
    /// The outcome document.
    pub const OUTCOME: &str = "Outcome";
    /// Collisions and closest approaches.
    pub const EVENTS: &str = "Events";
    /// The stages' colours.
    pub const KEY: &str = "Stages: each one's colour on every plot";
    /// Found failures over runtime, per stage.
    pub const FAILURES: &str = "HF failures found over the stage's runtime (s)";
    /// Fidelity success rate, per stage.
    pub const SUCCESS: &str =
        "Fidelity success: share of paired trials that are TP or TN at cost ratio ≤ budget";
    /// Cost ratio, per stage.
    pub const COST: &str = "Cost ratio t_LF / t_HF of each paired trial; grey: the budget";
    /// The campaign's summary document.
    pub const CAMPAIGN: &str = "Campaign";

    /// The θ grid of stage `label`.
    pub fn theta(label: &str) -> String {
        format!("θ posterior — {label}")
    }

    /// The tab of φ-bins grids of stage `label`.
    pub fn phi_tab(label: &str) -> String {
        format!("φ-bins — {label}")
    }

    /// The φ-bins grid of `scenario` in stage `label`.
    pub fn phi(label: &str, scenario: &str) -> String {
        format!("φ-bins {scenario} — {label}")
    }
}

/// One run's column: camera above the 3D view.
fn run_column(run: &str, camera: &str, view3d: &str, props: &mut Props) -> Vertical {
    let cam = Spatial2DView::new(camera)
        .with_origin(format!("/{run}/ego/camera"))
        .with_contents(["$origin/**"]);
    // The camera (its pinhole, image and box) stays in the camera view: drawn in 3D, its
    // frustum and image plane reach ahead of the ego's bumper and, at a closest approach, over
    // the other vehicle.
    let (v3, path) = child(
        Spatial3DView::new(view3d)
            .with_origin(format!("/{run}/ego"))
            .with_contents([
                "/world/**".to_string(),
                format!("/{run}/**"),
                format!("- /{run}/ego/camera/**"),
            ]),
    );
    prop(props, &path, "EyeControls3D", &chase_eye());
    Vertical::new([cam.into(), v3]).with_row_shares([0.42, 0.58])
}

/// The trial view. `paired`: the trial has an LF run (else HF alone).
pub fn trial(paired: bool) -> Layout {
    use names::*;
    let mut props = Vec::new();
    let mut runs: Vec<ContainerLike> = vec![run_column("hf", HF_CAMERA, HF_3D, &mut props).into()];
    if paired {
        runs.push(run_column("lf", LF_CAMERA, LF_3D, &mut props).into());
    }
    let side = Vertical::new([
        TextDocumentView::new(OUTCOME)
            .with_origin("/outcome")
            .with_contents(["$origin"])
            .into(),
        TextLogView::new(EVENTS)
            .with_contents(["/hf/events", "/lf/events"])
            .into(),
    ])
    .with_row_shares([0.6, 0.4]);
    runs.push(side.into());
    let shares: Vec<f32> = if paired {
        vec![0.35, 0.35, 0.3]
    } else {
        vec![0.64, 0.36]
    };
    let pick = |both: &'static str, hf: &'static str| if paired { both } else { hf };
    let plots = Horizontal::new([
        series(
            pick(DISTANCE, DISTANCE_HF),
            "/plots/distance",
            Some([-1.0, 25.0]),
            &mut props,
        ),
        series(pick(SPEED, SPEED_HF), "/plots/speed", None, &mut props),
        series(
            pick(BRAKING, BRAKING_HF),
            "/plots/braking",
            Some([-0.1, 1.1]),
            &mut props,
        ),
    ]);
    let root = Vertical::new([
        Horizontal::new(runs).with_column_shares(shares).into(),
        plots.into(),
    ])
    .with_row_shares([0.68, 0.32]);
    Layout {
        blueprint: Blueprint::new(root)
            .with_time_panel(TimePanel::new().with_timeline("sim_time"))
            .with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
            .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed)),
        props,
    }
}

/// The name of the plot of FMU output `output` in the FMU trial view of a paired trial (HF
/// and LF) or an HF-only one.
pub fn output_view_name(output: &str, paired: bool) -> String {
    if paired {
        format!("{output}: HF red, LF blue")
    } else {
        format!("{output}: HF red")
    }
}

/// The FMU trial view: one time series per recorded output (`[fmu] record`), HF and (for a
/// paired trial) LF in each, in a grid on the left; the outcome and the failure events on the
/// right.
pub fn fmu_trial(record: &[String], paired: bool) -> Layout {
    use names::*;
    let mut props = Vec::new();
    let plots: Vec<ContainerLike> = record
        .iter()
        .map(|name| {
            let (c, path) = child(
                TimeSeriesView::new(output_view_name(name, paired)).with_origin(plot_path(name)),
            );
            no_legend(&mut props, &path);
            c
        })
        .collect();
    let side = Vertical::new([
        TextDocumentView::new(OUTCOME)
            .with_origin("/outcome")
            .with_contents(["$origin"])
            .into(),
        TextLogView::new(EVENTS)
            .with_contents(["/hf/events", "/lf/events"])
            .into(),
    ])
    .with_row_shares([0.6, 0.4]);
    let root =
        Horizontal::new([Grid::new(plots).into(), side.into()]).with_column_shares([0.6, 0.4]);
    Layout {
        blueprint: Blueprint::new(root)
            .with_time_panel(TimePanel::new().with_timeline("sim_time"))
            .with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
            .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed)),
        props,
    }
}

/// The tabs of posterior grids: per learning stage its θ grid, and a tab of its scenarios'
/// φ-bins grids (one view each).
fn posterior_tabs(plan: &CampaignPlan, props: &mut Props) -> Vec<ContainerLike> {
    let mut tabs = Vec::new();
    for stage in &plan.learning {
        tabs.push(grid_view(
            names::theta(&stage.label),
            format!("/posterior/{}/fidelity", stage.entity),
            grid_bounds(&plan.fidelity),
            props,
        ));
        let phi: Vec<ContainerLike> = stage
            .scenarios
            .iter()
            .map(|(scenario, space)| {
                grid_view(
                    names::phi(&stage.label, scenario),
                    format!("/posterior/{}/scenarios/{scenario}", stage.entity),
                    grid_bounds(space),
                    props,
                )
            })
            .collect();
        if !phi.is_empty() {
            tabs.push(
                Tabs::new(phi)
                    .with_name(names::phi_tab(&stage.label))
                    .into(),
            );
        }
    }
    tabs
}

/// The campaign view: the stage key above the curves (found failures, fidelity success, cost
/// ratio) and the summary on the left; the posterior grids (a tab per grid, the whole height)
/// on the right.
pub fn campaign(plan: &CampaignPlan) -> Layout {
    use names::*;
    let mut props = Vec::new();
    // Every curve over its whole runtime, wherever the time cursor is (by default a plot
    // scrolls with a cursor that follows incoming data, hiding the shorter stages); no legend
    // over the data: the key above says which stage each colour is.
    let mut whole = |name: &str, origin: &str| {
        let (c, path) = child(TimeSeriesView::new(name).with_origin(origin));
        let axis = TimeAxis::new().with_view_range(rerun::datatypes::TimeRange::EVERYTHING);
        prop(&mut props, &path, "TimeAxis", &axis);
        no_legend(&mut props, &path);
        c
    };
    let key = Spatial2DView::new(KEY).with_origin("/campaign/key");
    let left = Vertical::new([
        key.into(),
        whole(FAILURES, "/campaign/found_failures"),
        whole(SUCCESS, "/campaign/fidelity_success"),
        whole(COST, "/campaign/cost_ratio"),
        TextDocumentView::new(CAMPAIGN)
            .with_origin("/campaign/summary")
            .with_contents(["$origin"])
            .into(),
    ])
    .with_row_shares([0.11, 0.3, 0.19, 0.19, 0.21]);
    // The grids take the whole height: the viewer draws their text at a fixed pixel size, so
    // a θ grid's row needs the height for its two lines inside the cell's borders.
    let right = Tabs::new(posterior_tabs(plan, &mut props));
    let root = Horizontal::new([left.into(), right.into()]).with_column_shares([0.45, 0.55]);
    Layout {
        blueprint: Blueprint::new(root)
            // The time panel folded, to give the views the room.
            // Following: the cursor at the end of the runtime timeline, where every curve is
            // whole and every grid shows its stage's final posterior.
            .with_time_panel(
                TimePanel::new()
                    .with_timeline("runtime")
                    .with_play_state(PlayState::Following)
                    .with_state(PanelState::Collapsed),
            )
            .with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
            .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed)),
        props,
    }
}

impl Layout {
    /// A layout of `blueprint` as it is (e.g. a simulator's own trial view, see
    /// [`super::TrialFrames`]).
    pub fn new(blueprint: Blueprint) -> Self {
        Layout {
            blueprint,
            props: Vec::new(),
        }
    }

    /// Sends the layout to `rec` as its application's active and default blueprint; returns
    /// the activation, to send again (with [`activate`]) to bring this application's view back
    /// to the front.
    pub fn send(self, rec: &RecordingStream) -> Result<BlueprintActivationCommand, RecordError> {
        let app = rec
            .store_info()
            .map(|i| i.application_id().clone())
            .ok_or_else(|| RecordError("the recording is disabled".into()))?;
        // The SDK's blueprint messages, captured in memory.
        let (mem, storage) = RecordingStreamBuilder::new(app)
            .send_properties(false)
            .memory()
            .map_err(err)?;
        self.blueprint
            .send(
                &mem,
                BlueprintActivation {
                    make_active: true,
                    make_default: true,
                },
            )
            .map_err(err)?;
        let mut msgs = Vec::new();
        let mut activation = None;
        for m in storage.take() {
            match m {
                LogMsg::BlueprintActivationCommand(c) => activation = Some(c),
                m if m.store_id().is_blueprint() => msgs.push(m),
                _ => {}
            }
        }
        let activation =
            activation.ok_or_else(|| RecordError("the blueprint was not activated".into()))?;
        // The eyes, in the same blueprint store.
        let (extra, extra_storage) =
            RecordingStreamBuilder::from_store_id(&activation.blueprint_id)
                .send_properties(false)
                .memory()
                .map_err(err)?;
        extra.set_time_sequence("blueprint", 0);
        for (path, batches) in self.props {
            extra
                .log_serialized_batches(path, false, batches)
                .map_err(err)?;
        }
        msgs.extend(
            extra_storage
                .take()
                .into_iter()
                .filter(|m| matches!(m, LogMsg::ArrowMsg(..))),
        );
        rec.send_blueprint(msgs, activation.clone());
        Ok(activation)
    }
}

/// Sends `activation` again on `rec`: a viewer reading the file (or the stream) switches to
/// that blueprint's application — the recording a viewer opens on is the last one activated.
pub fn activate(rec: &RecordingStream, activation: BlueprintActivationCommand) {
    rec.record_msg(LogMsg::BlueprintActivationCommand(activation));
}

/// The entity path of an FMU output `name`'s plot (any FMU name, escaped as one path part).
pub fn plot_path(name: &str) -> rerun::EntityPath {
    rerun::EntityPath::new(vec!["plots".into(), name.into()])
}
