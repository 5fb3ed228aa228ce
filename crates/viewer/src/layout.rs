//! The layouts the viewer opens a recording with (rerun blueprints, stored in the recording so
//! that `rerun FILE.rrd` shows them): the trial view (HF | LF side by side, each a camera above
//! a 3D view that follows the ego, time series below, the outcome on the right), the FMU trial
//! view (a plot per recorded output, HF and LF in each, the outcome on the right) and the
//! campaign view (failures over runtime, fidelity success and cost, posterior grids).
//!
//! Built with the SDK's blueprint API. What that API cannot say — where a 3D view's eye sits,
//! a time series' y range — [`Layout::send`] adds as view properties (`EyeControls3D`,
//! `ScalarAxis`) to the same blueprint store before activating it: a chase camera behind and
//! above the ego, the clearance plot zoomed to the braking threshold.

use super::error::{err, RecordError};
use rerun::blueprint::components::PanelState;
use rerun::blueprint::{
    Blueprint, BlueprintActivation, BlueprintPanel, ContainerLike, Grid, Horizontal,
    SelectionPanel, Spatial2DView, Spatial3DView, Tabs, TextDocumentView, TextLogView, TimePanel,
    TimeSeriesView, Vertical,
};
use rerun::external::re_log_types::LogMsg;
use rerun::external::re_sdk_types::blueprint::archetypes::{EyeControls3D, ScalarAxis, TimeAxis};
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

/// A time series view with its y range fixed to `range` (the default zooms out to all data).
fn series(name: &str, origin: &str, range: Option<[f64; 2]>, props: &mut Props) -> ContainerLike {
    let (c, path) = child(TimeSeriesView::new(name).with_origin(origin));
    if let Some(r) = range {
        prop(props, &path, "ScalarAxis", &ScalarAxis::new().with_range(r));
    }
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

/// The names of the trial view's views (also what the tests look for).
pub mod names {
    /// The HF run's camera.
    pub const HF_CAMERA: &str = "HF camera";
    /// The LF run's camera.
    pub const LF_CAMERA: &str = "LF camera";
    /// The HF run in 3D.
    pub const HF_3D: &str = "HF 3D (follows the ego)";
    /// The LF run in 3D.
    pub const LF_3D: &str = "LF 3D (follows the ego)";
    /// Clearance of both runs and the braking threshold.
    pub const CLEARANCE: &str = "Clearance (m) and braking threshold";
    /// Speeds of both egos.
    pub const SPEED: &str = "Ego speed (m/s)";
    /// Braking flags.
    pub const BRAKING: &str = "Braking (1 = brakes)";
    /// The outcome document.
    pub const OUTCOME: &str = "Outcome";
    /// Collisions and closest approaches.
    pub const EVENTS: &str = "Events";
    /// Found failures over runtime, per stage.
    pub const FAILURES: &str = "Found failures over runtime (s), per stage";
    /// Fidelity success rate, per stage.
    pub const SUCCESS: &str = "Fidelity success rate (TP / (TP + FN + FP)), per stage";
    /// Cost ratio, per stage.
    pub const COST: &str = "Cost ratio t_LF / t_HF, per stage";
    /// The campaign's summary document.
    pub const CAMPAIGN: &str = "Campaign";
}

/// One run's column: camera above the 3D view.
fn run_column(run: &str, camera: &str, view3d: &str, props: &mut Props) -> Vertical {
    let cam = Spatial2DView::new(camera)
        .with_origin(format!("/{run}/ego/camera"))
        .with_contents(["$origin/**"]);
    let (v3, path) = child(
        Spatial3DView::new(view3d)
            .with_origin(format!("/{run}/ego"))
            .with_contents(["/world/**".to_string(), format!("/{run}/**")]),
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
    .with_row_shares([0.65, 0.35]);
    runs.push(side.into());
    let shares: Vec<f32> = if paired {
        vec![0.38, 0.38, 0.24]
    } else {
        vec![0.7, 0.3]
    };
    let plots = Horizontal::new([
        series(
            CLEARANCE,
            "/plots/clearance",
            Some([-2.0, 25.0]),
            &mut props,
        ),
        series(SPEED, "/plots/speed", None, &mut props),
        series(BRAKING, "/plots/braking", Some([-0.1, 1.1]), &mut props),
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

/// The name of the plot of FMU output `output` in the FMU trial view.
pub fn output_view_name(output: &str) -> String {
    format!("{output} (HF, LF)")
}

/// The FMU trial view: one time series per recorded output (`[fmu] record`), HF and LF in
/// each, in a grid on the left; the outcome and the failure events on the right.
pub fn fmu_trial(record: &[String]) -> Layout {
    use names::*;
    let plots: Vec<ContainerLike> = record
        .iter()
        .map(|name| {
            TimeSeriesView::new(output_view_name(name))
                .with_origin(plot_path(name))
                .into()
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
    .with_row_shares([0.65, 0.35]);
    let root =
        Horizontal::new([Grid::new(plots).into(), side.into()]).with_column_shares([0.72, 0.28]);
    Layout {
        blueprint: Blueprint::new(root)
            .with_time_panel(TimePanel::new().with_timeline("sim_time"))
            .with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
            .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed)),
        props: Vec::new(),
    }
}

/// The campaign view: `learning` are the entity-path labels of the learning stages (one tab
/// of posterior grids each).
pub fn campaign(learning: &[String]) -> Layout {
    use names::*;
    let mut props = Vec::new();
    // Every curve over its whole runtime, wherever the time cursor is (by default a plot
    // scrolls with a cursor that follows incoming data, hiding the shorter stages).
    let mut whole = |name: &str, origin: &str| {
        let (c, path) = child(TimeSeriesView::new(name).with_origin(origin));
        let axis = TimeAxis::new().with_view_range(rerun::datatypes::TimeRange::EVERYTHING);
        prop(&mut props, &path, "TimeAxis", &axis);
        c
    };
    let curves = Vertical::new([
        whole(FAILURES, "/campaign/found_failures"),
        Horizontal::new([
            whole(SUCCESS, "/campaign/fidelity_success"),
            whole(COST, "/campaign/cost_ratio"),
        ])
        .into(),
    ])
    .with_row_shares([0.55, 0.45]);
    let posterior_tabs: Vec<ContainerLike> = learning
        .iter()
        .flat_map(|label| {
            [
                Spatial2DView::new(format!("θ posterior — {label}"))
                    .with_origin(format!("/posterior/{label}/fidelity"))
                    .into(),
                Spatial2DView::new(format!("φ-bins — {label}"))
                    .with_origin(format!("/posterior/{label}/scenarios"))
                    .into(),
            ]
        })
        .collect();
    let right = Vertical::new([
        Tabs::new(posterior_tabs).into(),
        TextDocumentView::new(CAMPAIGN)
            .with_origin("/campaign/summary")
            .with_contents(["$origin"])
            .into(),
    ])
    .with_row_shares([0.75, 0.25]);
    let root = Horizontal::new([curves.into(), right.into()]).with_column_shares([0.5, 0.5]);
    Layout {
        blueprint: Blueprint::new(root)
            // The time panel folded, to give the views the room.
            .with_time_panel(
                TimePanel::new()
                    .with_timeline("runtime")
                    .with_state(PanelState::Collapsed),
            )
            .with_blueprint_panel(BlueprintPanel::new().with_state(PanelState::Collapsed))
            .with_selection_panel(SelectionPanel::new().with_state(PanelState::Collapsed)),
        props,
    }
}

impl Layout {
    /// Sends the layout to `rec` as its application's active and default blueprint.
    pub fn send(self, rec: &RecordingStream) -> Result<(), RecordError> {
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
        rec.send_blueprint(msgs, activation);
        Ok(())
    }
}

/// The entity path of an FMU output `name`'s plot (any FMU name, escaped as one path part).
pub fn plot_path(name: &str) -> rerun::EntityPath {
    rerun::EntityPath::new(vec!["plots".into(), name.into()])
}
