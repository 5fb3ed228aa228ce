//! How the evaluate phase — evaluation, and LF screening, the deployed search — uses what the
//! search learned.
//!
//! The paper freezes the φ proposal once the search ends: evaluation and screening draw from
//! p_ψ as learned and credit nothing. A falsification tool's deployed search keeps sampling
//! adaptively instead (VerifAI's samplers do), and counts failures, not new failure modes. With
//! [`Deployment::learn`] every evaluate-phase result teaches the φ search — an HF run by its
//! failure, an LF pass that screening did not confirm as a pass — so the proposal keeps
//! concentrating where failures are confirmed. With [`Deployment::exploit`] the elite mixture
//! ([`crate::SearchModel::EliteMixture`]) draws for failures rather than for new cells: no
//! independent-bin exploration, no novelty weighting, candidates ranked by their estimated
//! failure odds alone. The fidelity bandit p_ω(θ_LF) learns nothing in either case, so θ_LF*
//! stays the search's.
//!
//! The default is the paper's (nothing learned, nothing changed) and serialises as nothing,
//! so the paper's campaigns keep their trials bit for bit.
//!
//! ```
//! use savme_kernel::Deployment;
//! assert!(Deployment::default().is_frozen());
//! let adaptive = Deployment::ADAPTIVE;
//! assert!(adaptive.learn && adaptive.exploit && !adaptive.is_frozen());
//! let json = serde_json::to_string(&adaptive)?;
//! assert_eq!(serde_json::from_str::<Deployment>(&json)?, adaptive);
//! # Ok::<(), serde_json::Error>(())
//! ```

use serde::{Deserialize, Serialize};

/// What the evaluate phase learns and how it draws φ. Part of the [`crate::KernelConfig`];
/// missing fields take their defaults (false) when deserialised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Deployment {
    /// Evaluate-phase results credit the φ search (bins and the elite archive): an HF run by
    /// its failure, an unconfirmed LF pass as a pass. θ_LF* is not changed.
    pub learn: bool,
    /// The elite mixture draws evaluate-phase φ for failures: no exploration, no novelty
    /// weighting, candidates ranked by failure odds alone (no effect on independent bins).
    pub exploit: bool,
}

impl Deployment {
    /// The paper's: the proposal is frozen and drawn as in the search.
    pub const FROZEN: Deployment = Deployment {
        learn: false,
        exploit: false,
    };
    /// Keeps learning and exploits: the deployed search of a falsification tool.
    pub const ADAPTIVE: Deployment = Deployment {
        learn: true,
        exploit: true,
    };

    /// True for the paper's frozen deployment (then the field is left out of the JSON).
    pub fn is_frozen(&self) -> bool {
        *self == Deployment::FROZEN
    }
}
