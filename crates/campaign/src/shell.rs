//! Commands savme suggests in its messages (the `--resume` command, `savme worker …`), quoted
//! for a POSIX shell so that they can be pasted as they are printed (a URL's `&` or `?`, a
//! campaign name with spaces).

/// `text` quoted for a POSIX shell: as it is when it holds only characters no shell treats
/// specially, else in single quotes (a `'` inside written `'\''`).
///
/// ```
/// use savme_campaign::shell_quote;
/// assert_eq!(shell_quote("night-1"), "night-1");
/// assert_eq!(shell_quote("a&b"), "'a&b'");
/// assert_eq!(shell_quote("it's"), "'it'\\''s'");
/// assert_eq!(shell_quote(""), "''");
/// ```
pub fn shell_quote(text: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "-_./:@,+=%".contains(c);
    if !text.is_empty() && text.chars().all(plain) {
        return text.to_string();
    }
    format!("'{}'", text.replace('\'', r"'\''"))
}
