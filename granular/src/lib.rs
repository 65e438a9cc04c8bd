//! Hopper geometry and granular-flow responses for `orch`.
//!
//! Pure: this crate owns two formats (ASCII STL it writes into a `String`, and the
//! crossings table, [`crossing_csv`]) and never touches files, processes or databases. Units are SI throughout:
//! metres, seconds, kilograms; angles in degrees only where a name says `_deg`.
//!
//! - [`geometry`]: the conical hopper, its outlet plug, an internal valve and sensor
//!   planes as triangle meshes ([`mesh::TriMesh`]).
//! - [`chute`]: the transfer chute (a B-spline plate, side walls, receiving plane).
//! - [`stream`]: responses of the stream a chute throws onto its receiving plane.
//! - [`profile`]: the cone's wall as a clamped B-spline moved by the shape offsets.
//! - [`bed`]: radial size segregation of a settled bed (poured or placed at random).
//! - [`air`]: the drag of a falling particle stream on the air, for the CFD stage.
//! - [`crossing`]: turns particle sightings near a sensor plane into one crossing per
//!   particle, with interpolated time and position; [`crossing_csv`] their table.
//! - [`responses`]: discharge rate, radial segregation and fine fraction in the outer
//!   layers of the stream (SCIENCE.md §4), and the reference formulas.
//! - [`steady`]: the steady window of a discharge, its rate and 95 % interval.
//! - [`radial`]: radial statistics of a stream's crossings (stream radius, outer
//!   layers, densities).

pub mod air;
pub mod bed;
pub mod chute;
pub mod crossing;
pub mod crossing_csv;
pub mod geometry;
pub mod mesh;
pub mod profile;
pub mod radial;
pub mod reference;
pub mod responses;
pub mod steady;
pub mod stream;
#[cfg(test)]
pub(crate) mod synthetic;
pub mod temporal;

pub use chute::{ChuteError, ChuteGeometry};
pub use crossing::{Crossing, CrossingDetector, Sighting};
pub use geometry::{GeometryError, HopperGeometry};
pub use mesh::TriMesh;
pub use profile::{ConeProfile, ProfileError};
pub use responses::{DischargeResponses, ResponseOptions};
