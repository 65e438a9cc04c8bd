//! Designs of experiments and response surfaces for `orch`.
//!
//! This crate is pure: it knows nothing of files, databases, solvers or async runtimes.
//! Everything here is a function from numbers to numbers, so it can be tested against
//! closed-form answers and published tables.
//!
//! Design points live in *coded* units, every factor scaled to `[-1, 1]`;
//! [`FactorRange`] converts between coded and natural (SI) units.

pub mod basis;
pub mod co_kriging;
pub mod design;
pub mod fit;
pub mod improvement;
pub mod kriging;
mod kriging_search;
pub mod lack_of_fit;
pub mod levels;
mod nelder_mead;
pub mod optimise;
pub mod pareto;
pub mod per_level;
pub mod propagate;
pub mod propose;
pub mod prune;
pub mod robust;
mod scaling;
pub mod sobol;
pub mod student;
pub mod surrogate;

pub use basis::{Basis, BasisKind};
pub use co_kriging::{
    nested_subset, propose_fidelity, propose_fidelity_batch, CoKriging, CoKrigingError,
    FidelityProposal, LevelRuns,
};
pub use design::{run_count, CentralCompositeAlpha, Design, DesignError, DesignKind, MAX_RUNS};
pub use fit::{test_quality, Fit, FitError, Interval, Quality, TestQuality};
pub use improvement::{erf, erfc, expected_improvement, normal_cdf, normal_pdf, propose_batch};
pub use kriging::{
    pure_error_variance, Kernel, Kriging, KrigingError, KrigingOptions, Nugget, Trend,
};
pub use lack_of_fit::{lack_of_fit, LackOfFit};
pub use optimise::{optimise, optimise_subject_to, BoxBounds, Constraint, Goal, Optimum};
pub use pareto::{non_dominated, pareto_front, Objective, ParetoPoint};
pub use propagate::{propagate, propagate_with_error, Distribution, Spread};
pub use prune::prune;
pub use scaling::FactorRange;
pub use sobol::{legendre_sobol, sobol_indices, Estimate, SobolError, SobolIndices};
pub use student::{
    f_cdf, f_quantile, f_survival, student_t_cdf, student_t_quantile, welch_interval,
    SampleSummary, WelchInterval,
};
