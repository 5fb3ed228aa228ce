//! A campaign's simulator label (`fmu:HF|LF`, canonical paths) and whether a stored label names
//! the same FMUs: the campaign's identity, whatever directory savme runs in.

use std::path::Path;

/// The simulator label of a campaign on `hf` and `lf`: `fmu:HF|LF`, each the FMU's canonical
/// path (absolute, links resolved), so that the campaign's identity does not depend on the
/// directory `savme` runs in or on how the campaign file's path is spelled (`./ref.toml`,
/// `../x/ref.toml`). A path that cannot be resolved is kept as given.
pub fn label(hf: &Path, lf: &Path) -> String {
    let canonical = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    format!(
        "fmu:{}|{}",
        canonical(hf).display(),
        canonical(lf).display()
    )
}

/// Whether a stored campaign's simulator label `stored` names the FMUs of `given` (a label of
/// [`label`]): equal, or each of its paths resolves to the same file as `given`'s. A label
/// written before labels were canonical holds the paths as given then (relative to the
/// directory `savme` ran in): a relative one matches if it resolves to the same file from the
/// current directory or from a directory above the FMU.
///
/// ```
/// use savme_fmu::campaign_file::same_label;
/// assert!(same_label("fmu:a.fmu|a.fmu", "fmu:a.fmu|a.fmu"));
/// assert!(!same_label("savme-sim", "fmu:a.fmu|a.fmu"));
/// ```
pub fn same_label(stored: &str, given: &str) -> bool {
    if stored == given {
        return true;
    }
    fn pair(l: &str) -> Option<(&str, &str)> {
        l.strip_prefix("fmu:")?.split_once('|')
    }
    let (Some((sh, sl)), Some((gh, gl))) = (pair(stored), pair(given)) else {
        return false;
    };
    same_file(sh, gh) && same_file(sl, gl)
}

/// Whether path `stored` (absolute, or relative to an unknown directory) is the file `given`.
fn same_file(stored: &str, given: &str) -> bool {
    let Ok(given) = std::fs::canonicalize(given) else {
        return false;
    };
    let stored = Path::new(stored);
    let is_given = |p: &Path| std::fs::canonicalize(p).is_ok_and(|p| p == given);
    if stored.is_absolute() {
        return is_given(stored);
    }
    let cwd = std::env::current_dir().ok();
    cwd.iter()
        .map(|d| d.as_path())
        .chain(given.ancestors().skip(1))
        .any(|base| is_given(&base.join(stored)))
}
