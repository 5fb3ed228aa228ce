//! A campaign file's name and text: reads it, parses sections of it, turns spans into lines
//! and builds errors. The campaign layer and every adapter parse their own sections from one
//! [`Source`].

use crate::ConfigError;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// A campaign file, read.
///
/// ```
/// use savme_campaign_file::Source;
/// let src = Source::new("c.toml", "[fmu]\nhf = 3\n");
/// #[derive(serde::Deserialize)]
/// struct Fmu { fmu: toml::Table }
/// let fmu: Fmu = src.parse().unwrap();
/// assert_eq!(fmu.fmu["hf"].as_integer(), Some(3));
/// let err = src.check_sections(&["campaign"]).unwrap_err();
/// assert_eq!(err.line, Some(1));
/// ```
#[derive(Debug, Clone)]
pub struct Source {
    file: String,
    text: String,
}

/// A TOML reader's message, with what to write instead where it is not plain: an integer
/// literal beyond the signed 64-bit range TOML has.
fn explained(message: &str) -> String {
    if message.contains("value was too large") || message.contains("number too large") {
        format!(
            "{message}: TOML integers are signed 64-bit (at most 9223372036854775807); write a \
             larger value (an FMI 3.0 UInt64) as a float (`1.5e19`): it is set as the integer \
             that float is, exactly (floats above 2^63 are 2048 apart)"
        )
    } else {
        message.to_string()
    }
}

impl Source {
    /// A file named `file` (as errors name it) with its text.
    pub fn new(file: impl Into<String>, text: impl Into<String>) -> Source {
        Source {
            file: file.into(),
            text: text.into(),
        }
    }

    /// Reads `path`; an error names the file.
    pub fn read(path: &Path) -> Result<Source, ConfigError> {
        let file = path.display().to_string();
        match std::fs::read_to_string(path) {
            Ok(text) => Ok(Source { file, text }),
            Err(e) => Err(ConfigError {
                file,
                line: None,
                key: None,
                message: e.to_string(),
            }),
        }
    }

    /// The file's name, as errors give it.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The 1-based line of a span's start.
    pub fn line(&self, span: Range<usize>) -> usize {
        line_of(&self.text, span.start)
    }

    /// An error in this file, at `line` and `key` when known.
    pub fn err(
        &self,
        line: Option<usize>,
        key: Option<&str>,
        message: impl Into<String>,
    ) -> ConfigError {
        ConfigError {
            file: self.file.clone(),
            line,
            key: key.map(String::from),
            message: message.into(),
        }
    }

    /// The TOML, deserialised as `T` (which reads the sections it declares and ignores the
    /// others); a syntax or type error names its line.
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T, ConfigError> {
        toml::from_str(&self.text).map_err(|e| {
            let line = e.span().map(|s| self.line(s));
            self.err(line, None, explained(e.message()))
        })
    }

    /// Refuses a top-level key that is none of `known` (the campaign's sections and the
    /// adapter's), at its line, as serde refuses an unknown field.
    pub fn check_sections(&self, known: &[&str]) -> Result<(), ConfigError> {
        let top: BTreeMap<String, Spanned<toml::Value>> = self.parse()?;
        match top.iter().find(|(k, _)| !known.contains(&k.as_str())) {
            None => Ok(()),
            Some((key, value)) => {
                let expected: Vec<String> = known.iter().map(|k| format!("`{k}`")).collect();
                Err(self.err(
                    Some(self.line(value.span())),
                    None,
                    format!(
                        "unknown field `{key}`, expected one of {}",
                        expected.join(", ")
                    ),
                ))
            }
        }
    }
}

/// The 1-based line of byte `offset` in `text`.
pub fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// `p` relative to the campaign file's directory `base`, unless absolute.
///
/// ```
/// use std::path::Path;
/// assert_eq!(savme_campaign_file::resolve(Path::new("/a"), "b.fmu"), Path::new("/a/b.fmu"));
/// assert_eq!(savme_campaign_file::resolve(Path::new("/a"), "/c.fmu"), Path::new("/c.fmu"));
/// ```
pub fn resolve(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}
