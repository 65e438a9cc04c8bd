//! Designs of experiments and response surfaces for `orch`.
//!
//! This crate is pure: it knows nothing of files, databases, solvers or async runtimes.
//! Everything here is a function from numbers to numbers, so it can be tested against
//! closed-form answers and published tables.
//!
//! Design points live in *coded* units, every factor scaled to `[-1, 1]`;
//! [`FactorRange`] converts between coded and natural (SI) units.

pub mod basis;
pub mod design;
pub mod fit;
pub mod optimise;
pub mod pareto;
pub mod propagate;
pub mod propose;
mod scaling;
pub mod sobol;
pub mod student;

pub use basis::{Basis, BasisKind};
pub use design::{run_count, CentralCompositeAlpha, Design, DesignError, DesignKind, MAX_RUNS};
pub use fit::{Fit, FitError, Quality, TestQuality};
pub use optimise::{optimise, optimise_subject_to, BoxBounds, Constraint, Goal, Optimum};
pub use pareto::{non_dominated, pareto_front, Objective, ParetoPoint};
pub use propagate::{propagate, Distribution, Spread};
pub use scaling::FactorRange;
pub use sobol::{legendre_sobol, sobol_indices, Estimate, SobolError, SobolIndices};
pub use student::{
    student_t_cdf, student_t_quantile, welch_interval, SampleSummary, WelchInterval,
};
