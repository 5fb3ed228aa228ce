//! `[fidelity]`: the fidelity space, θ_HF and what each setting binds to — the paper's Table II
//! (`paper = true`, from the caller) or the `[[fidelity.variable]]` tables.

use crate::variable::{binding, theta_hf_value, variables, Drives, Named, VarSection};
use crate::{CampaignSection, ConfigError, Source};
use savme_kernel::{Assignment, Space, Variable};
use toml::Spanned;

/// `[fidelity]` as serde reads it.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FidelitySection {
    /// The paper's Table II, each setting bound to the simulator variable of the same name.
    #[serde(default)]
    pub paper: Option<Spanned<bool>>,
    #[serde(default, rename = "variable")]
    pub variables: Vec<Spanned<VarSection>>,
}

/// The fidelity space as the file declares it.
#[derive(Debug, Clone)]
pub struct Fidelity {
    /// The space.
    pub space: Space,
    /// θ_HF.
    pub theta_hf: Assignment,
    /// Every setting in file order (for `paper = true`: the paper's order).
    pub settings: Vec<Setting>,
}

/// One fidelity setting: its variable and what it sets in a run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Setting {
    /// The savme variable.
    pub variable: String,
    /// What it sets.
    pub bound: Bound,
}

/// What a fidelity setting sets in a run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Bound {
    /// A simulator variable (for `paper = true`: the one of the setting's name, named by
    /// `fidelity.paper`).
    To(Named),
    /// The simulator's step size or tolerance (`drives`): every value positive, at most one
    /// setting of each kind, bound to no simulator variable.
    Drives {
        /// Which.
        drives: Drives,
        /// The line of `drives`.
        line: usize,
        /// `fidelity.variable[k].drives`.
        key: String,
    },
}

impl Fidelity {
    /// The setting that drives `what`, if any.
    pub fn driver(&self, what: Drives) -> Option<(&Setting, usize, &str)> {
        self.settings.iter().find_map(|s| match &s.bound {
            Bound::Drives { drives, line, key } if *drives == what => {
                Some((s, *line, key.as_str()))
            }
            _ => None,
        })
    }
}

/// `[fidelity]`: the paper's settings (`paper(bins)` with `[campaign] fidelity_bins`, default
/// 10), or the variables listed.
pub(crate) fn read(
    src: &Source,
    section: &Spanned<FidelitySection>,
    campaign: &CampaignSection,
    paper: &dyn Fn(u32) -> (Space, Assignment),
) -> Result<Fidelity, ConfigError> {
    let f = section.get_ref();
    let Some(paper_line) = f
        .paper
        .as_ref()
        .filter(|p| *p.get_ref())
        .map(|p| src.line(p.span()))
    else {
        return listed(src, section);
    };
    if let Some(first) = f.variables.first() {
        return Err(src.err(
            Some(src.line(first.span())),
            Some("fidelity.variable"),
            "give either `paper = true` or variables, not both",
        ));
    }
    let (space, theta_hf) = paper(paper_bins(src, campaign)?);
    let settings = space
        .variables()
        .iter()
        .map(|v| Setting {
            variable: v.name.to_string(),
            bound: Bound::To(Named {
                name: v.name.to_string(),
                line: paper_line,
                key: "fidelity.paper".into(),
            }),
        })
        .collect();
    Ok(Fidelity {
        space,
        theta_hf,
        settings,
    })
}

/// `[campaign] fidelity_bins` (default 10), between 1 and the kernel's maximum.
fn paper_bins(src: &Source, campaign: &CampaignSection) -> Result<u32, ConfigError> {
    let bins = campaign.fidelity_bins().unwrap_or(10);
    if bins >= 1 && bins <= savme_kernel::MAX_ARMS as i64 {
        return Ok(bins as u32);
    }
    let message = if bins < 1 {
        "must be at least 1".to_string()
    } else {
        format!(
            "{bins} bins: at most {} are supported",
            savme_kernel::MAX_ARMS
        )
    };
    Err(src.err(
        campaign.lines.get("fidelity_bins").copied(),
        Some("campaign.fidelity_bins"),
        message,
    ))
}

/// `[[fidelity.variable]]`: each variable with its θ_HF value and what it binds to.
fn listed(src: &Source, section: &Spanned<FidelitySection>) -> Result<Fidelity, ConfigError> {
    let list = &section.get_ref().variables;
    let vars = variables(src, "fidelity.variable", list)?;
    let space = Space::new(vars.clone()).map_err(|e| {
        src.err(
            Some(src.line(section.span())),
            Some("fidelity"),
            format!("{e}: give `paper = true` or [[fidelity.variable]] tables"),
        )
    })?;
    let mut theta_hf = Assignment::new();
    let mut settings: Vec<Setting> = Vec::new();
    for (k, (sv, var)) in list.iter().zip(&vars).enumerate() {
        let key = format!("fidelity.variable[{k}]");
        theta_hf.set(&var.name, theta_hf_value(src, &key, sv, var)?);
        let bound = match &sv.get_ref().drives {
            Some(d) => driver(src, &key, sv, d, var, &settings)?,
            None => Bound::To(binding(src, sv.get_ref(), &key)),
        };
        settings.push(Setting {
            variable: var.name.to_string(),
            bound,
        });
    }
    Ok(Fidelity {
        space,
        theta_hf,
        settings,
    })
}

/// A fidelity variable with `drives`: bound to no simulator variable (no `fmu` key), every
/// value a positive number of seconds (step size) or a positive tolerance, at most one per
/// kind.
fn driver(
    src: &Source,
    key: &str,
    sv: &Spanned<VarSection>,
    drives: &Spanned<Drives>,
    var: &Variable,
    earlier: &[Setting],
) -> Result<Bound, ConfigError> {
    let d = *drives.get_ref();
    let line = src.line(drives.span());
    let dkey = format!("{key}.drives");
    let what = d.what();
    if let Some(f) = &sv.get_ref().fmu {
        return Err(src.err(
            Some(src.line(f.span())),
            Some(&format!("{key}.fmu")),
            format!("a variable that drives {what} is bound to no FMU variable: remove `fmu`"),
        ));
    }
    let other = earlier.iter().find_map(|s| match &s.bound {
        Bound::Drives { drives, line, key } if *drives == d => Some((s, line, key)),
        _ => None,
    });
    if let Some((o, o_line, o_key)) = other {
        return Err(src.err(
            Some(line),
            Some(&dkey),
            format!(
                "`{}` already drives {what} (`{o_key}`, line {o_line})",
                o.variable
            ),
        ));
    }
    let positive = match &var.domain {
        savme_kernel::Domain::Continuous { lo, .. } => *lo > 0.0,
        savme_kernel::Domain::Discrete { values } => values
            .iter()
            .all(|v| v.as_f64().is_some_and(|x| x > 0.0 && x.is_finite())),
    };
    if !positive {
        return Err(src.err(
            Some(line),
            Some(&dkey),
            format!(
                "`{}` drives {what}: every value must be a positive number",
                var.name
            ),
        ));
    }
    Ok(Bound::Drives {
        drives: d,
        line,
        key: dkey,
    })
}
