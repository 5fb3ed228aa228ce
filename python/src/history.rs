//! The told records a Python `Kernel` keeps for `trials()`: all of them (the default), the
//! last N, or none (`Kernel(history=...)`), so that a long-running kernel's memory is bounded.

use crate::convert;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyBool;
use savme_kernel::TrialRecord;
use std::collections::VecDeque;
use std::sync::Arc;

/// The records of the trials told, in tell order, at most `limit` of them (the latest).
/// Each is shared with the `Record` that `tell` returned (an `Arc`, not a copy: a deep copy
/// of a record cost ~0.5 µs per tell, a tenth of a Python ask + tell).
#[derive(Debug, Default)]
pub struct History {
    records: VecDeque<Arc<TrialRecord>>,
    /// None: every record is kept.
    limit: Option<usize>,
}

impl History {
    /// A history of `records` (a resumed journal's, a pickled kernel's) keeping at most
    /// `limit` (the latest).
    pub fn new(records: Vec<TrialRecord>, limit: Option<usize>) -> Self {
        let mut records: VecDeque<_> = records.into_iter().map(Arc::new).collect();
        if let Some(n) = limit {
            let excess = records.len().saturating_sub(n);
            records.drain(..excess);
        }
        History { records, limit }
    }

    /// Keeps `record` (dropping the oldest when the history is full; nothing when it keeps
    /// none).
    pub fn push(&mut self, record: &Arc<TrialRecord>) {
        match self.limit {
            Some(0) => {}
            Some(n) => {
                if self.records.len() >= n {
                    self.records.pop_front();
                }
                self.records.push_back(Arc::clone(record));
            }
            None => self.records.push_back(record.clone()),
        }
    }

    /// The records kept, oldest first.
    pub fn records(&self) -> impl Iterator<Item = &Arc<TrialRecord>> {
        self.records.iter()
    }

    /// How many records it keeps at most (None: all).
    pub fn limit(&self) -> Option<usize> {
        self.limit
    }
}

/// `history=`: None or True keeps every told record, False or 0 none, an int N the last N;
/// anything else is a `TypeError`/`ValueError` naming `history`.
pub fn limit_of(arg: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let Some(arg) = arg.filter(|a| !a.is_none()) else {
        return Ok(None);
    };
    if arg.is_instance_of::<PyBool>() {
        return Ok(if arg.is_truthy()? { None } else { Some(0) });
    }
    let n: i128 = arg.extract().map_err(|_| {
        PyTypeError::new_err(format!(
            "history must be True (keep every told record), False (keep none) or an int N (keep the last N), got {}",
            arg.repr().map_or_else(|_| "?".into(), |r| r.to_string())
        ))
    })?;
    convert::whole("history", n).map(Some)
}
