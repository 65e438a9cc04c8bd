//! `orch-dem`: orch's native discrete element kernel.
//!
//! Spheres of several types interact through LIGGGHTS's Hertz–Mindlin contact law
//! ([`force`]) with each other and with rigid, possibly moving triangle-mesh walls
//! ([`mesh`], [`walls`]), and air may drag them ([`air`], blowing uniformly or as a
//! gridded field, [`air_field`]). [`simulation::Simulation`] advances them by velocity Verlet;
//! [`insert`] fills a region without overlaps; [`packing`] reads a given packing; [`inflow`] feeds a mixture through a
//! region at a mass rate over a time window; [`case`] reads the case file format
//! (TOML) that `orch` renders and [`output`] writes LIGGGHTS-compatible dumps, VTK
//! files and the sensor's crossings; [`verify`] measures what a verification case
//! names and compares it with the case's references.
//!
//! The kernel does no I/O: callers hand it bytes and writers. It is deterministic: the
//! same case and seed give the same numbers, bit for bit, with any number of rayon
//! threads (forces are summed per particle in a fixed order). [`awake::AwakeWorkers`]
//! keeps a pool's other threads polling between a step's parallel passes, where they
//! would otherwise sleep and be woken three times a step.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod air;
pub mod air_field;
pub mod awake;
pub mod case;
pub mod contact;
pub mod force;
pub mod inflow;
pub mod insert;
pub mod material;
pub mod math;
pub mod mesh;
pub mod neighbour;
pub mod output;
pub mod packing;
pub mod particles;
pub mod simulation;
pub mod timestep;
pub mod verify;
pub mod walls;

pub use math::{Real, Vec3};
pub use simulation::{Config, Crossing, Simulation, Unstable};
