//! What the default views show, checked on the recorded geometry: at the closest approach no
//! label and no camera frustum covers a vehicle in the 3D views (seen from their chase eye),
//! and the posterior grids' values sit inside their cells, clear of every border.
//!
//! The viewer's drawing rules these checks model (rerun 0.36, `re_view_spatial::ui`): a label
//! hangs below its anchor — a 3D point, or a 2D box's bottom centre — its background from 1 px to
//! [`LABEL_PX`] px below it (its text from ~5 px to ~21 px), centred, [`CHAR_PX`] px per
//! character plus 12 px wide; a 3D view's
//! default vertical field of view is 55°. Pixel sizes are those of the default window
//! (1600×1000, `docs/screenshots.sh`), measured on `docs/rerun_trial.png` and
//! `docs/rerun_campaign.png`.

use super::*;
use rerun::external::re_log_types::{EntityPath, EntityPathFilter, EntityPathSubs};
use rerun::external::re_sdk_types::archetypes as a;
use rerun::external::re_sdk_types::blueprint::archetypes::{
    EyeControls3D, ViewContents, VisualBounds2D,
};
use rerun::external::re_sdk_types::blueprint::components as bc;
use rerun::external::re_types_core::{Component, ComponentIdentifier};

/// Height of a label's background below its anchor, px (5 px offset, a 13 px font's 16 px
/// line, 4 px padding).
const LABEL_PX: f32 = 26.0;
/// Width per character of a label's text, px (the viewer's font averages ~6.1 px on the
/// grids' names in the screenshot).
const CHAR_PX: f32 = 6.5;
/// The 3D views' default vertical field of view, radians.
const FOV_Y: f32 = 55.0 * std::f32::consts::PI / 180.0;
/// Size of each 3D view of the trial view in the default window, px.
const VIEW_3D_PX: (f32, f32) = (560.0, 297.0);

/// The stores of an .rrd file.
type Rrd = BTreeMap<rerun::external::re_log_types::StoreId, ChunkStore>;

fn open(path: &Path) -> Rrd {
    let mut f = std::fs::File::open(path).unwrap();
    ChunkStore::from_rrd_reader(&ChunkStoreConfig::DEFAULT, &mut f).unwrap()
}

/// Rows of component `C` at `entity` in the recordings (not blueprints) of `stores`: (time on
/// `sim_time`, `i64::MIN` when static; the row's values), in time order.
fn timed<C: Component>(
    stores: &Rrd,
    entity: &str,
    component: ComponentIdentifier,
) -> Vec<(i64, Vec<C>)> {
    let timeline = rerun::external::re_log_types::TimelineName::from_static_str("sim_time");
    let mut out = Vec::new();
    for (id, store) in stores {
        if id.is_blueprint() {
            continue;
        }
        for chunk in store.iter_physical_chunks() {
            if chunk.entity_path().to_string() != entity {
                continue;
            }
            let times = chunk.iter_component_indices(timeline, component);
            for ((t, _), values) in times.zip(chunk.iter_component::<C>(component)) {
                out.push((t.as_i64(), values.to_vec()));
            }
        }
    }
    out.sort_by_key(|(t, _)| *t);
    out
}

/// The values of the last row at or before `t`, if any.
fn latest<C: Clone>(rows: &[(i64, Vec<C>)], t: i64) -> Option<(i64, Vec<C>)> {
    rows.iter().rev().find(|(at, _)| *at <= t).cloned()
}

/// A view of a blueprint: its origin, its contents' query, its eye (position, look target),
/// its 2D bounds (`[x_min, x_max, y_min, y_max]`).
#[derive(Debug, Default)]
struct View {
    origin: String,
    query: Vec<String>,
    eye: Option<([f32; 3], [f32; 3])>,
    bounds: Option<[f32; 4]>,
}

/// The views of the blueprint of `app` in `stores`, by name.
fn views(stores: &Rrd, app: &str) -> BTreeMap<String, View> {
    let mut by_path: BTreeMap<String, View> = BTreeMap::new();
    let mut names: BTreeMap<String, String> = BTreeMap::new();
    let mut eyes: BTreeMap<String, ([f32; 3], [f32; 3])> = BTreeMap::new();
    for (id, store) in stores {
        if !id.is_blueprint() || !of_app_name(id.application_id().as_str(), app) {
            continue;
        }
        for chunk in store.iter_physical_chunks() {
            let e = chunk.entity_path().to_string();
            let view = e
                .trim_end_matches("/ViewContents")
                .trim_end_matches("/EyeControls3D")
                .trim_end_matches("/VisualBounds2D");
            let v = by_path.entry(view.to_string()).or_default();
            for x in chunk.iter_component::<rerun::components::Name>(
                ViewBlueprint::descriptor_display_name().component,
            ) {
                names.extend(x.iter().map(|n| (n.as_str().to_string(), view.to_string())));
            }
            for x in chunk.iter_component::<bc::ViewOrigin>(
                ViewBlueprint::descriptor_space_origin().component,
            ) {
                v.origin = x.iter().map(|o| o.0.to_string()).next().unwrap_or_default();
            }
            for x in chunk
                .iter_component::<bc::QueryExpression>(ViewContents::descriptor_query().component)
            {
                v.query.extend(x.iter().map(|q| q.0.as_str().to_string()));
            }
            let pos = chunk
                .iter_component::<rerun::components::Position3D>(
                    EyeControls3D::descriptor_position().component,
                )
                .flat_map(|x| x.to_vec())
                .next();
            let target = chunk
                .iter_component::<rerun::components::Position3D>(
                    EyeControls3D::descriptor_look_target().component,
                )
                .flat_map(|x| x.to_vec())
                .next();
            for x in chunk
                .iter_component::<bc::VisualBounds2D>(VisualBounds2D::descriptor_range().component)
            {
                if let Some(r) = x.first() {
                    let (rx, ry) = (r.0.x_range.0, r.0.y_range.0);
                    v.bounds = Some([rx[0], rx[1], ry[0], ry[1]].map(|c| c as f32));
                }
            }
            if let (Some(p), Some(t)) = (pos, target) {
                eyes.insert(view.to_string(), (p.0.into(), t.0.into()));
            }
        }
    }
    names
        .into_iter()
        .filter_map(|(name, path)| {
            let mut v = by_path.remove(&path)?;
            v.eye = eyes.get(&path).copied();
            Some((name, v))
        })
        .collect()
}

fn of_app_name(id: &str, app: &str) -> bool {
    id == app || (app == savme::viewer::CAMPAIGN_APP && savme::viewer::is_campaign_app(id))
}

/// A pose: translation and rotation (x, y, z, w).
#[derive(Clone, Copy, Debug)]
struct Pose {
    t: [f32; 3],
    q: [f32; 4],
}

impl Pose {
    const IDENTITY: Pose = Pose {
        t: [0.0; 3],
        q: [0.0, 0.0, 0.0, 1.0],
    };

    fn rotate(&self, v: [f32; 3]) -> [f32; 3] {
        let [x, y, z, w] = self.q;
        let u = [x, y, z];
        let cross = |a: [f32; 3], b: [f32; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let t = cross(u, v).map(|c| 2.0 * c);
        let c = cross(u, t);
        [0, 1, 2].map(|i| v[i] + w * t[i] + c[i])
    }

    /// A point of this pose's frame in the parent frame.
    fn apply(&self, p: [f32; 3]) -> [f32; 3] {
        let r = self.rotate(p);
        [0, 1, 2].map(|i| r[i] + self.t[i])
    }
}

/// The pose of `entity` (a `Transform3D` over `sim_time`) at time `t`.
fn pose_at(rrd: &Rrd, entity: &str, t: i64) -> Pose {
    let tr = timed::<rerun::components::Translation3D>(
        rrd,
        entity,
        a::Transform3D::descriptor_translation().component,
    );
    let q = timed::<rerun::components::RotationQuat>(
        rrd,
        entity,
        a::Transform3D::descriptor_quaternion().component,
    );
    let t3 = latest(&tr, t)
        .unwrap_or_else(|| panic!("no pose of {entity} at {t}"))
        .1[0];
    let q4 = latest(&q, t)
        .unwrap_or_else(|| panic!("no rotation of {entity} at {t}"))
        .1[0];
    Pose {
        t: t3.0.into(),
        q: q4.0 .0,
    }
}

/// A rectangle on screen, px: (left, top, right, bottom), y down.
type Rect = [f32; 4];

fn overlap(a: Rect, b: Rect) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// A perspective eye at `eye` looking at `target` (z up), onto a view of `VIEW_3D_PX`.
struct Eye {
    at: [f32; 3],
    f: [f32; 3],
    r: [f32; 3],
    u: [f32; 3],
}

impl Eye {
    fn new(eye: [f32; 3], target: [f32; 3]) -> Eye {
        let norm = |v: [f32; 3]| {
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / n)
        };
        let f = norm([0, 1, 2].map(|i| target[i] - eye[i]));
        let r = norm([f[1], -f[0], 0.0]); // f × z
        let u = [
            r[1] * f[2] - r[2] * f[1],
            r[2] * f[0] - r[0] * f[2],
            r[0] * f[1] - r[1] * f[0],
        ];
        Eye { at: eye, f, r, u }
    }

    /// Where `p` shows in the view, px from its top left (None behind the eye).
    fn project(&self, p: [f32; 3]) -> Option<(f32, f32)> {
        let d = [0, 1, 2].map(|i| p[i] - self.at[i]);
        let dot = |a: [f32; 3]| a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
        let depth = dot(self.f);
        if depth <= 0.0 {
            return None;
        }
        let half = VIEW_3D_PX.1 / 2.0 / (FOV_Y / 2.0).tan();
        Some((
            VIEW_3D_PX.0 / 2.0 + dot(self.r) / depth * half,
            VIEW_3D_PX.1 / 2.0 - dot(self.u) / depth * half,
        ))
    }

    /// The screen rectangle of a body box (`centre`, `half` sizes, in the frame of `pose`).
    fn body(&self, pose: Pose, centre: [f32; 3], half: [f32; 3]) -> Rect {
        let mut r = [
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ];
        for k in 0..8 {
            let s = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
            let corner = [0, 1, 2].map(|i| centre[i] + s(i) * half[i]);
            if let Some((x, y)) = self.project(pose.apply(corner)) {
                r = [r[0].min(x), r[1].min(y), r[2].max(x), r[3].max(y)];
            }
        }
        r
    }

    /// The screen rectangle of a label `text` anchored at `p`.
    fn label(&self, p: [f32; 3], text: &str) -> Option<Rect> {
        let (x, y) = self.project(p)?;
        let w = text.chars().count() as f32 * CHAR_PX + 12.0;
        Some([x - w / 2.0, y + 1.0, x + w / 2.0, y + LABEL_PX])
    }
}

/// The labelled entities under `/{run}` at time `t`: (anchor in the world frame, text).
fn labels_at(rrd: &Rrd, r: &Store, run: &str, t: i64, ego: Pose) -> Vec<([f32; 3], String)> {
    let mut out = Vec::new();
    for entity in r
        .texts
        .keys()
        .filter(|e| e.starts_with(&format!("/{run}/")))
    {
        if entity.contains("/camera/") {
            continue; // 2D, in the camera's view
        }
        let frame = if entity.starts_with(&format!("/{run}/ego/")) {
            ego
        } else {
            Pose::IDENTITY
        };
        let clears = timed::<rerun::components::ClearIsRecursive>(
            rrd,
            entity,
            a::Clear::descriptor_is_recursive().component,
        );
        let cleared = latest(&clears, t).map_or(i64::MIN, |c| c.0);
        let mut anchors = Vec::new();
        for (labels, positions) in [
            (
                a::Points3D::descriptor_labels().component,
                timed::<rerun::components::Position3D>(
                    rrd,
                    entity,
                    a::Points3D::descriptor_positions().component,
                )
                .into_iter()
                .map(|(t, p)| (t, p.iter().map(|p| p.0.into()).collect::<Vec<[f32; 3]>>()))
                .collect::<Vec<_>>(),
            ),
            (
                a::LineStrips3D::descriptor_labels().component,
                timed::<rerun::components::LineStrip3D>(
                    rrd,
                    entity,
                    a::LineStrips3D::descriptor_strips().component,
                )
                .into_iter()
                .map(|(t, s)| {
                    // A strip's label sits at its middle.
                    let pts: Vec<[f32; 3]> = s[0].0.iter().map(|p| (*p).into()).collect();
                    let n = pts.len() as f32;
                    let mid = [0, 1, 2].map(|i| pts.iter().map(|p| p[i]).sum::<f32>() / n);
                    (t, vec![mid])
                })
                .collect(),
            ),
        ] {
            let texts = timed::<rerun::components::Text>(rrd, entity, labels);
            if let (Some((lt, text)), Some((_, pos))) = (latest(&texts, t), latest(&positions, t)) {
                if lt > cleared && !text.is_empty() && !pos.is_empty() {
                    anchors.push((frame.apply(pos[0]), text[0].as_str().to_string()));
                }
            }
        }
        out.extend(anchors);
    }
    out
}

// The issue's complaint: at the closest approach the labels ("closest 3.03 m", "predicted
// clearance …") and the camera's frustum lines covered the lead vehicle in 3D.
#[test]
fn at_the_closest_approach_no_label_or_frustum_covers_a_vehicle() {
    let dir = made_dir("views3d");
    for (scenario, phi) in [
        ("7", PHI),
        // LF passes at 6.83 m: a closest approach with a gap.
        ("7", "ego_speed=20,lead_speed=10,gap=28,lead_decel=5,brake_time=0.5"),
        // The screenshot's FN: the intruder turns across the ego.
        (
            "intruder_turns_left_across_ego",
            "ego_speed=19.052481924886354,intruder_speed=7.292077626030616,time_offset=0.837683984724011",
        ),
    ] {
        let rrd = dir.join("run.rrd");
        let o = Command::new(EXE)
            .args(["simulate", "--scenario", scenario, "--phi", phi])
            .args(["--fidelity", "simulation_rate_hz=4", "--record"])
            .arg(&rrd)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stores = load(&rrd);
        let r = recordings(&stores, savme::viewer::PAIRED_APP)[0];
        let rrd = open(&rrd);
        let views = views(&rrd, savme::viewer::PAIRED_APP);
        // Entities with a pinhole (a camera, drawn in 3D as a frustum and image plane).
        let pinholes: Vec<EntityPath> = r
            .rows
            .keys()
            .filter(|e| {
                !timed::<rerun::components::PinholeProjection>(
                    &rrd,
                    e,
                    a::Pinhole::descriptor_image_from_camera().component,
                )
                .is_empty()
            })
            .map(|e| EntityPath::parse_forgiving(e))
            .collect();
        assert!(!pinholes.is_empty(), "the cameras are recorded");
        for (run, name) in [("hf", names::HF_3D), ("lf", names::LF_3D)] {
            let view = &views[name];
            let filter = EntityPathFilter::parse_forgiving(view.query.join("\n"))
                .resolve_forgiving(&EntityPathSubs::new_with_origin(&EntityPath::parse_forgiving(
                    &view.origin,
                )));
            for p in &pinholes {
                assert!(
                    !filter.matches(p),
                    "{name} draws the camera {p} (its frustum reaches over the vehicle ahead): {:?}",
                    view.query
                );
            }
            // The closest approach, the poses there, the eye (in the ego's frame).
            let strip = timed::<rerun::components::LineStrip3D>(
                &rrd,
                &format!("/{run}/closest_approach"),
                a::LineStrips3D::descriptor_strips().component,
            );
            let t = strip.last().expect("a closest approach").0;
            let ego = pose_at(&rrd, &format!("/{run}/ego"), t);
            let intruder = pose_at(&rrd, &format!("/{run}/intruder"), t);
            let (at, target) = view.eye.expect("a chase eye");
            let eye = Eye::new(ego.apply(at), ego.apply(target));
            let half = savme_sim::vehicle::body().half_extents;
            let (c, h) = ([0.0, 0.0, half.z], [half.x, half.y, half.z]);
            let bodies = [("ego", eye.body(ego, c, h)), ("the other vehicle", eye.body(intruder, c, h))];
            let labels = labels_at(&rrd, r, run, t, ego);
            assert!(!labels.is_empty(), "{run}: the closest approach is labelled");
            for (anchor, text) in labels {
                let rect = eye
                    .label(anchor, &text)
                    .unwrap_or_else(|| panic!("`{text}` is behind the eye"));
                let inside = rect[0] >= 0.0
                    && rect[1] >= 0.0
                    && rect[2] <= VIEW_3D_PX.0
                    && rect[3] <= VIEW_3D_PX.1;
                assert!(inside, "{run} φ {phi}: `{text}` at {rect:?} is outside the view");
                for (what, body) in bodies {
                    assert!(
                        !overlap(rect, body),
                        "{run} φ {phi}: `{text}` at {rect:?} covers {what} at {body:?} \
                         (ego at {:?}, the other at {:?})",
                        ego.t,
                        intruder.t
                    );
                }
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Size of the posterior grids' pane in the campaign view in the default window, px (measured
/// on docs/rerun_campaign.png: a θ grid row is ~54 px there).
const GRID_PANE_PX: (f32, f32) = (875.0, 915.0);

/// The last row of component `C` at `entity` (on any timeline).
fn last_row<C: Component>(stores: &Rrd, entity: &str, component: ComponentIdentifier) -> Vec<C> {
    let mut last = Vec::new();
    for (id, store) in stores {
        if id.is_blueprint() {
            continue;
        }
        for chunk in store.iter_physical_chunks() {
            if chunk.entity_path().to_string() == entity {
                if let Some(x) = chunk.iter_component::<C>(component).last() {
                    last = x.to_vec();
                }
            }
        }
    }
    last
}

/// The boxes of a 2D `entity`: (min x, min y, max x, max y), its radius, its labels (none when
/// hidden).
fn boxes_2d(stores: &Rrd, entity: &str) -> (Vec<Rect>, f32, Vec<String>) {
    let centres = last_row::<rerun::components::Position2D>(
        stores,
        entity,
        a::Boxes2D::descriptor_centers().component,
    );
    let halves = last_row::<rerun::components::HalfSize2D>(
        stores,
        entity,
        a::Boxes2D::descriptor_half_sizes().component,
    );
    let rects = centres
        .iter()
        .zip(halves.iter().cycle())
        .map(|(c, h)| {
            let (c, h): ([f32; 2], [f32; 2]) = (c.0.into(), h.0.into());
            [c[0] - h[0], c[1] - h[1], c[0] + h[0], c[1] + h[1]]
        })
        .collect();
    let radius = last_row::<rerun::components::Radius>(
        stores,
        entity,
        a::Boxes2D::descriptor_radii().component,
    )
    .first()
    .map_or(-1.0, |r| r.0 .0);
    let shown = last_row::<rerun::components::ShowLabels>(
        stores,
        entity,
        a::Boxes2D::descriptor_show_labels().component,
    )
    .first()
    .is_none_or(|s| s.0 .0);
    let labels = if shown {
        last_row::<rerun::components::Text>(
            stores,
            entity,
            a::Boxes2D::descriptor_labels().component,
        )
        .iter()
        .map(|t| t.as_str().to_string())
        .collect()
    } else {
        Vec::new()
    };
    (rects, radius, labels)
}

// The complaint: the φ/θ grids' cell borders ran through the posterior-mean values.
#[test]
fn no_border_of_a_posterior_grid_runs_through_its_text() {
    let dir = made_dir("grids");
    let (rrd, _) = campaign(&dir, "1000", "0");
    let stores = load(&rrd);
    let camp = recordings(&stores, savme::viewer::CAMPAIGN_APP)[0];
    let rrd = open(&rrd);
    let views = views(&rrd, savme::viewer::CAMPAIGN_APP);
    let grids: Vec<(&String, &View)> = views
        .iter()
        .filter(|(n, _)| n.starts_with("θ posterior") || n.starts_with("φ-bins "))
        .filter(|(_, v)| v.bounds.is_some())
        .collect();
    assert!(
        grids.iter().any(|(n, _)| n.starts_with("θ")),
        "{:?}",
        views.keys()
    );
    assert!(
        grids.iter().any(|(n, _)| n.starts_with("φ")),
        "{:?}",
        views.keys()
    );
    for (name, view) in grids {
        let [x0, x1, y0, y1] = view.bounds.unwrap();
        // The view frames its bounds whole: units to px.
        let ppu = (GRID_PANE_PX.0 / (x1 - x0)).min(GRID_PANE_PX.1 / (y1 - y0));
        let (mut borders, mut texts, mut cells) = (Vec::new(), Vec::new(), Vec::new());
        for entity in camp
            .rows
            .keys()
            .filter(|e| e.starts_with(&format!("{}/", view.origin)))
        {
            let (rects, radius, labels) = boxes_2d(&rrd, entity);
            // A radius: positive in scene units, negative in UI points (the default: ~1.5).
            let half = if radius < 0.0 {
                1.5 / ppu
            } else {
                radius.max(0.5 / ppu)
            };
            for (k, r) in rects.iter().enumerate() {
                if radius != 0.0 && r[3] - r[1] > 0.1 {
                    // Its four edges, as thin rectangles.
                    borders.push(([r[0] - half, r[1] - half, r[2] + half, r[1] + half], entity));
                    borders.push(([r[0] - half, r[3] - half, r[2] + half, r[3] + half], entity));
                    borders.push(([r[0] - half, r[1] - half, r[0] + half, r[3] + half], entity));
                    borders.push(([r[2] - half, r[1] - half, r[2] + half, r[3] + half], entity));
                }
                if entity.ends_with("/cells") {
                    cells.push(*r);
                }
                if let Some(text) = labels.get(k) {
                    // The text's glyphs: ~5 to ~21 px below the box's bottom centre.
                    let x = (r[0] + r[2]) / 2.0;
                    let w = text.chars().count() as f32 * CHAR_PX / 2.0 / ppu;
                    let glyphs = [x - w, r[3] + 5.0 / ppu, x + w, r[3] + 21.0 / ppu];
                    texts.push((glyphs, text.clone(), entity.clone()));
                }
            }
        }
        assert!(
            !texts.is_empty() && !cells.is_empty(),
            "{name}: nothing drawn"
        );
        for (glyphs, text, entity) in &texts {
            for (border, of) in &borders {
                assert!(
                    !overlap(*glyphs, *border),
                    "{name}: a border of {of} ({border:?}) runs through `{text}` of {entity} \
                     ({glyphs:?}, {ppu:.1} px per unit)"
                );
            }
            if entity.ends_with("/cells/means") || entity.ends_with("/cells/labels") {
                assert!(
                    cells.iter().any(|c| glyphs[0] >= c[0]
                        && glyphs[2] <= c[2]
                        && glyphs[1] >= c[1]
                        && glyphs[3] <= c[3]),
                    "{name}: `{text}` of {entity} ({glyphs:?}) is not inside a cell"
                );
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
