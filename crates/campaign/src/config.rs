//! A campaign's [`Protocol`] and [`Problem`], from a preset or a campaign file plus the
//! command line's flags — in one place, for every command: a preset (or a file's `[campaign]`
//! section) first, then the flags, then validation.

pub use super::values::Overrides;
use super::{CampaignError, Problem, Protocol};
use savme_campaign_file::{CampaignSection, ConfigError};

/// The number of seeds `repeat` asks for (None: one campaign, not a repeated one), checked
/// against [`super::MAX_REPEAT`].
///
/// ```
/// use savme_campaign::config::check_repeat;
/// assert_eq!(check_repeat(Some(5)).unwrap(), Some(5));
/// assert_eq!(check_repeat(None).unwrap(), None);
/// assert!(check_repeat(Some(0)).unwrap_err().to_string().contains("`repeat`"));
/// ```
pub fn check_repeat(repeat: Option<u32>) -> Result<Option<u32>, CampaignError> {
    match repeat {
        Some(n) if n == 0 || n > super::MAX_REPEAT => Err(CampaignError::Protocol {
            field: "repeat".into(),
            message: format!("{n} is not between 1 and {}", super::MAX_REPEAT),
        }),
        r => Ok(r),
    }
}

/// The simulator label of the toy simulator (`savme toy`).
pub const TOY: &str = "savme-toy";
/// The simulator label of the null simulator (`savme toy --null`).
pub const NULL: &str = "savme-null";

/// The label of the toy simulator sleeping `ms` milliseconds per run.
pub fn toy_label(ms: u64) -> String {
    if ms == 0 {
        TOY.into()
    } else {
        format!("{TOY}/sleep={ms}ms")
    }
}

/// The protocol and problem of a campaign on the toy simulator (`savme toy`): the quick
/// preset's stages on its two scenarios (`stopped_obstacle` for meta-training,
/// `braking_lead` for meta-testing), under the simulator `label`, validated.
pub fn toy(label: &str, o: &Overrides) -> Result<(Protocol, Problem), CampaignError> {
    let (train, test) = (
        vec![crate::toy::SCENARIOS[0].to_string()],
        vec![crate::toy::SCENARIOS[1].to_string()],
    );
    let mut p = Protocol::quick(label, train, test);
    let lookup = |k: &str| crate::toy::phi_space(k).map(|_| k.to_string());
    o.apply(&mut p, &lookup, &crate::toy::SCENARIOS.join(", "))?;
    p.validate()?;
    let (fidelity, theta_hf) = crate::toy::fidelity();
    let scenarios = crate::toy::SCENARIOS
        .iter()
        .filter_map(|s| crate::toy::phi_space(s).map(|space| (s.to_string(), space)))
        .collect();
    Ok((
        p,
        Problem {
            fidelity,
            theta_hf,
            scenarios,
        },
    ))
}

impl Overrides {
    /// A campaign file's `[campaign]` section as overrides of the paper's protocol; a key that
    /// is no protocol value, or a value of the wrong type, is an error naming the file, line
    /// and key.
    pub fn from_section(c: &CampaignSection, file: &str) -> Result<Overrides, ConfigError> {
        Overrides::from_entries(c.values.iter().map(|(k, v)| (k, v.clone()))).map_err(|e| {
            ConfigError {
                file: file.into(),
                line: c.lines.get(&e.key).copied(),
                key: Some(format!("campaign.{}", e.key)),
                message: e.message,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(entries: &[(&str, toml::Value, usize)]) -> CampaignSection {
        CampaignSection {
            values: entries
                .iter()
                .map(|(k, v, _)| (k.to_string(), v.clone()))
                .collect(),
            out: None,
            lines: entries
                .iter()
                .map(|(k, _, l)| (k.to_string(), *l))
                .collect(),
        }
    }

    #[test]
    fn a_campaign_section_is_read_by_the_declared_names() {
        let c = section(&[
            ("cost", "work".into(), 11),
            ("screen_iterations", 5.into(), 12),
            ("repeat", 2.into(), 13),
        ]);
        let o = Overrides::from_section(&c, "campaign.toml").unwrap();
        assert_eq!(o.cost, Some(crate::Cost::Work));
        assert_eq!((o.screen_iterations, o.repeat), (Some(5), Some(2)));
    }

    #[test]
    fn a_wrong_key_or_value_names_file_line_and_key() {
        let c = section(&[("cost", "cpu".into(), 11)]);
        let e = Overrides::from_section(&c, "campaign.toml").unwrap_err();
        assert_eq!(e.line, Some(11));
        assert_eq!(e.key.as_deref(), Some("campaign.cost"));
        assert!(e.message.contains("`wall`"), "{e}");
        let c = section(&[("iterations", 5.into(), 14)]);
        let e = Overrides::from_section(&c, "campaign.toml").unwrap_err();
        assert_eq!(
            (e.line, e.key.as_deref()),
            (Some(14), Some("campaign.iterations"))
        );
        assert!(e.message.contains("train_iterations"), "{e}");
        let c = section(&[("seed", (-1).into(), 3)]);
        let e = Overrides::from_section(&c, "campaign.toml").unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("campaign.toml, line 3, key `campaign.seed`: {}", e.message)
        );
    }
}
