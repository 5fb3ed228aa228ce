//! The checksum chain of a [`JsonlStore`](super::JsonlStore): every line savme writes ends
//! with `"c":"<16 hex digits>"`, a 64-bit digest of this line's other bytes chained with the
//! digest of every line before it. A line changed after it was written (a failure flag, a φ,
//! a runtime edited by hand or by a script) no longer matches its digest, and the store
//! refuses it, naming the line, while a torn last line (a process killed mid-write) is not a
//! complete line and is dropped as before.
//!
//! Compatibility: lines without a digest (written by a savme before the chain) are read
//! unchecked, and a store that has them continues the chain after them; but once a line
//! carries a digest, every later line must carry one (deleting the digests of a few lines
//! does not pass). The chain is a check against accidental and naive edits, not a signature:
//! anyone who recomputes it (or strips every digest) can change the file unnoticed.
//!
//! ```
//! use savme_store::chain::{Chain, ChainCheck};
//! let mut chain = Chain::default();
//! let mut line = b"{\"v\":1,\"stage\":\"train@0.3\",\"hf\":true".to_vec();
//! chain.seal(&mut line);
//! assert!(line.ends_with(b"\"}"));
//! let mut reader = Chain::default();
//! assert!(matches!(reader.check(&line), ChainCheck::Sealed { .. }));
//! // The same line with its failure flag changed:
//! let edited = String::from_utf8(line.clone()).unwrap().replace("true", "fals");
//! let mut reader = Chain::default();
//! assert!(matches!(reader.check(edited.as_bytes()), ChainCheck::Mismatch { .. }));
//! ```

/// `,"c":"` + 16 hex digits + `"}`.
const SUFFIX_LEN: usize = 6 + 16 + 2;

/// The running digest over a store's complete lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chain {
    state: u64,
    /// Whether a line with a digest was seen (then every later line needs one).
    sealed: bool,
}

impl Default for Chain {
    fn default() -> Self {
        Chain {
            state: 0xcbf2_9ce4_8422_2325,
            sealed: false,
        }
    }
}

/// What [`Chain::check`] found in one complete line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChainCheck {
    /// The line carries its digest, and it matches: `body` bytes of it are the object
    /// (without the digest).
    Sealed {
        /// The length of the line's object without `,"c":"…"` (its closing brace excluded).
        body: usize,
    },
    /// A line without a digest before any line with one (an earlier savme's): read unchecked.
    Unsealed,
    /// A line without a digest after a line with one.
    Missing,
    /// The digest does not match the line and the lines before it: `body` as for
    /// [`ChainCheck::Sealed`].
    Mismatch {
        /// The length of the line's object without `,"c":"…"` (its closing brace excluded).
        body: usize,
    },
}

impl Chain {
    /// The next state after `bytes` (a line's object without its digest).
    fn next(&self, parts: &[&[u8]]) -> u64 {
        let mut h = self.state;
        for part in parts {
            for &b in *part {
                h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
        // SplitMix64's finaliser, so that nearby states spread.
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^ (h >> 31)
    }

    /// Ends `open` (a line's object without its closing brace, e.g. `{"v":1,"a":2`) with its
    /// digest and the closing brace, and advances the chain.
    pub fn seal(&mut self, open: &mut Vec<u8>) {
        self.state = self.next(&[open, b"}"]);
        self.sealed = true;
        open.extend_from_slice(format!(",\"c\":\"{:016x}\"}}", self.state).as_bytes());
    }

    /// Checks one complete line (without its newline) and advances the chain over it.
    pub fn check(&mut self, line: &[u8]) -> ChainCheck {
        match digest_of(line) {
            Some((body, digest)) => {
                let state = self.next(&[&line[..body], b"}"]);
                self.state = state;
                self.sealed = true;
                if state == digest {
                    ChainCheck::Sealed { body }
                } else {
                    ChainCheck::Mismatch { body }
                }
            }
            None => {
                self.state = self.next(&[line]);
                if self.sealed {
                    ChainCheck::Missing
                } else {
                    ChainCheck::Unsealed
                }
            }
        }
    }
}

/// The line's digest and where it starts, if the line ends with `,"c":"<16 hex>"}`.
fn digest_of(line: &[u8]) -> Option<(usize, u64)> {
    let start = line.len().checked_sub(SUFFIX_LEN)?;
    let tail = &line[start..];
    if !tail.starts_with(b",\"c\":\"") || !tail.ends_with(b"\"}") {
        return None;
    }
    let hex = std::str::from_utf8(&tail[6..22]).ok()?;
    // Lower-case only, as written: `A` for `a` would read as the same digest.
    if !hex
        .bytes()
        .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
    {
        return None;
    }
    Some((start, u64::from_str_radix(hex, 16).ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sealed(lines: &[&str]) -> Vec<Vec<u8>> {
        let mut chain = Chain::default();
        lines
            .iter()
            .map(|l| {
                let mut b = l.strip_suffix('}').unwrap().as_bytes().to_vec();
                chain.seal(&mut b);
                b
            })
            .collect()
    }

    fn checks(lines: &[Vec<u8>]) -> Vec<ChainCheck> {
        let mut chain = Chain::default();
        lines.iter().map(|l| chain.check(l)).collect()
    }

    #[test]
    fn sealed_lines_check_and_any_changed_byte_is_found_at_its_line() {
        let lines = sealed(&["{\"v\":1,\"a\":1}", "{\"v\":1,\"hf\":true}", "{\"v\":1}"]);
        assert!(checks(&lines)
            .iter()
            .all(|c| matches!(c, ChainCheck::Sealed { .. })));
        for at in 0..lines[1].len() - SUFFIX_LEN {
            let mut edited = lines.clone();
            edited[1][at] ^= 0x01;
            let c = checks(&edited);
            assert!(matches!(c[0], ChainCheck::Sealed { .. }));
            assert!(matches!(c[1], ChainCheck::Mismatch { .. }), "byte {at}");
        }
    }

    #[test]
    fn old_lines_pass_unchecked_but_not_after_a_sealed_one() {
        let mut lines = vec![b"{\"a\":1}".to_vec()];
        let mut chain = Chain::default();
        chain.check(&lines[0]);
        let mut next = b"{\"v\":1,\"a\":2".to_vec();
        chain.seal(&mut next);
        lines.push(next);
        lines.push(b"{\"v\":1,\"a\":3}".to_vec());
        let c = checks(&lines);
        assert_eq!(c[0], ChainCheck::Unsealed);
        assert!(matches!(c[1], ChainCheck::Sealed { .. }));
        assert_eq!(c[2], ChainCheck::Missing);
        // An edited old line breaks the first sealed line after it.
        lines[0] = b"{\"a\":9}".to_vec();
        assert!(matches!(checks(&lines)[1], ChainCheck::Mismatch { .. }));
    }
}
