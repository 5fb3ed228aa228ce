//! `savme.CampaignResult`: what a finished campaign (or one per seed, and its `[estimate]`
//! stage) returns to Python.

use crate::convert;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use savme::campaign::estimate::EstimateOutcome;
use savme::campaign::{CampaignOutcome, RepeatedOutcome};
use std::path::PathBuf;

/// What the campaign thread finished: one campaign, or one per seed.
pub(crate) enum Finished {
    One(CampaignOutcome),
    Seeds(RepeatedOutcome),
}

/// What a finished campaign returns.
#[pyclass(name = "CampaignResult", module = "savme", frozen)]
pub struct PyCampaignResult {
    pub(crate) finished: Finished,
    pub(crate) estimate: Option<EstimateOutcome>,
}

impl PyCampaignResult {
    /// Each seed's campaign (one without `repeat`).
    fn outcomes(&self) -> Vec<&CampaignOutcome> {
        match &self.finished {
            Finished::One(o) => vec![o],
            Finished::Seeds(r) => r.runs.iter().collect(),
        }
    }
}

#[pymethods]
impl PyCampaignResult {
    /// The campaign directory.
    #[getter]
    fn out(&self) -> PathBuf {
        match &self.finished {
            Finished::One(o) => o
                .outputs
                .protocol
                .parent()
                .map(PathBuf::from)
                .unwrap_or_default(),
            Finished::Seeds(r) => r.out.clone(),
        }
    }

    /// The report as a dict (what `summary.json` holds under "report").
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.finished {
            Finished::One(o) => convert::json_to_py(py, &o.report),
            Finished::Seeds(r) => convert::json_to_py(py, &r.report),
        }
    }

    /// Table III as Markdown (`table.md`; over the seeds with `repeat`).
    #[getter]
    fn table_md(&self) -> String {
        match &self.finished {
            Finished::One(o) => o.report.table_md(),
            Finished::Seeds(r) => r.report.table_md(),
        }
    }

    /// Each seed's result, in seed order (`repeat`; one result without it).
    #[getter]
    fn runs(&self) -> Vec<PyCampaignResult> {
        self.outcomes()
            .into_iter()
            .map(|o| PyCampaignResult {
                finished: Finished::One(o.clone()),
                estimate: None,
            })
            .collect()
    }

    /// The `[estimate]` stage's result (a campaign file with one): its summary as a dict
    /// (`summary.json`), None otherwise.
    #[getter]
    fn estimate<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.estimate
            .as_ref()
            .map(|e| convert::json_to_py(py, e))
            .transpose()
    }

    /// The files written: protocol, trials, table, fidelity, summary, breakeven, meta_testing.
    #[getter]
    fn files<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let Finished::One(one) = &self.finished else {
            let out = self.out();
            for (k, f) in [
                ("table", "table.md"),
                ("summary", "summary.json"),
                ("breakeven", "breakeven.png"),
                ("meta_testing", "meta_testing.png"),
            ] {
                d.set_item(k, out.join(f))?;
            }
            return Ok(d);
        };
        let o = &one.outputs;
        for (k, v) in [
            ("protocol", &o.protocol),
            ("trials", &o.trials),
            ("table", &o.table),
            ("fidelity", &o.fidelity),
            ("summary", &o.summary),
            ("breakeven", &o.breakeven),
            ("meta_testing", &o.meta_testing),
        ] {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// Trials replayed from `trials.jsonl` (a resumed campaign).
    #[getter]
    fn replayed(&self) -> u64 {
        self.outcomes().iter().map(|o| o.replayed).sum()
    }

    /// Trials run by this call.
    #[getter]
    fn ran(&self) -> u64 {
        self.outcomes().iter().map(|o| o.ran).sum()
    }

    /// Wall-clock seconds this call took.
    #[getter]
    fn elapsed_seconds(&self) -> f64 {
        match &self.finished {
            Finished::One(o) => o.elapsed_seconds,
            Finished::Seeds(r) => r.elapsed_seconds,
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "CampaignResult(out={:?}, ran={}, replayed={}, elapsed_seconds={:.1})",
            self.out().display().to_string(),
            self.ran(),
            self.replayed(),
            self.elapsed_seconds()
        )
    }
}
