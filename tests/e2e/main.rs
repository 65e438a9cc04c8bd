//! End-to-end tests of the `orch` binary with real solvers.
//!
//! They drive the built `orch` (target/debug/orch, or `ORCH_BIN`) as a user would.
//! Tests that need LIGGGHTS fail when `CI=true` and it is missing, and say they
//! skipped otherwise. Solver tests take a lock so that they do not compete for the
//! machine's cores.

mod air;
mod architecture;
mod bounds;
mod chute;
mod compare;
mod concurrency;
mod cores;
mod crash_resume;
mod custom;
mod faults;
mod fidelity;
mod native;
mod noise;
mod oblique_impacts;
mod openfoam;
mod outputs;
mod pipes;
mod pour;
mod real_liggghts;
mod refusals;
mod reports;
mod repose;
mod restart;
mod reuse;
mod rounds;
mod scripts;
mod slurm;
mod stop_when;
mod study_files;
mod support;
mod text_factors;
mod yade;
