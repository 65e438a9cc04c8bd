//! `orch`: runs simulation-driven shape optimisation studies for granular-flow equipment.
//!
//! The binary's pieces, from the outside in: [`cli`] parses arguments and dispatches;
//! [`study`] turns a study file into a validated [`study::Study`]; [`store`] is the
//! SQLite store that holds every state; [`driver`] runs a study's jobs through an
//! [`executor`], deciding through the pure functions of [`decide`]; [`status`] reads the store for people and scripts.

pub mod catalogue;
pub mod cli;
pub use orch_compare as compare;
pub mod convergence;
pub mod coupling;
pub mod decide;
pub mod driver;
pub use orch_executor as executor;
pub mod exit_codes;
pub mod export;
pub mod noise;
pub use orch_page::numbers;
pub mod output;
pub mod programs;
pub mod progress;
pub mod project;
pub mod report;
pub mod rounds;
pub mod status;
pub use orch_store as store;
pub use orch_study as study;
pub use orch_study::{identity, keep, plan};
pub mod surfaces;
pub mod tail;
pub mod verdict;
