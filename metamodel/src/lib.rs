//! Designs of experiments and response surfaces for `orch`.
//!
//! This crate is pure: it knows nothing of files, databases, solvers or async runtimes.
//! Everything here is a function from numbers to numbers, so it can be tested against
//! closed-form answers and published tables.
//!
//! Design points live in *coded* units, every factor scaled to `[-1, 1]`;
//! [`FactorRange`] converts between coded and natural (SI) units.

pub mod design;
mod scaling;

pub use design::{CentralCompositeAlpha, Design, DesignError, DesignKind};
pub use scaling::FactorRange;
