//! The case file: a TOML description of one native-kernel run, which `orch` renders
//! from `templates/native/hopper.toml.tera` or `chute.toml.tera` (every value SI).
//!
//! Parsing checks every field (unknown keys are errors, so a misspelt key cannot be
//! silently ignored) and reports errors by key path; the caller adds the file name.
//! Mesh files are named here but read by the caller, which passes their bytes to
//! [`Case::wall_mesh`].
//!
//! Particles present at the start come either from random insertion (`[insert]`, a
//! count and mass fractions in a region) or from a list of explicit particles
//! (`[[particles]]`, each placed and launched by hand, as impact tests need), never
//! both in one case: the insertion does not know where explicit particles are, so it
//! could place a sphere inside one. `[[inflow]]` may join either, since inflow batches
//! avoid every particle present. Explicit particles get ids 1, 2, … in file order:
//!
//! ```toml
//! [[particles]]
//! type = "glass"                  # a `[[types]]` name, or its number from 1 as in dumps
//! position = [0.0, 0.0, 0.00102]  # m
//! velocity = [0.0, 0.0, -1.0]     # m/s, default 0
//! angular_velocity = [0.0, 0.0, 0.0]  # rad/s, default 0
//! radius = 0.001                  # m, default the type's radius
//! ```
//!
//! A radius other than the type's keeps the type's density and material (its mass
//! follows from the radius); the default time step and skin account for it.
//!
//! An `[air]` table drags every particle through air ([`crate::air`], the
//! Schiller–Naumann drag of a sphere), still, blowing uniformly, or blowing as a field
//! given on a grid:
//!
//! ```toml
//! [air]
//! density = 1.2                   # kg/m³, default 1.2
//! viscosity = 1.8e-5              # Pa·s, default 1.8e-5
//! velocity = [0.0, 0.0, 0.0]      # m/s, default still air
//! velocity_field = "air-field.csv"  # default none
//! ```
//!
//! `velocity_field` names a CSV file, relative to the case file's folder, with the
//! header `x,y,z,ux,uy,uz` (m, m/s) and one row per node of a rectilinear grid, in any
//! order ([`crate::air_field`]); inside the grid's box the air's velocity at a particle
//! is the trilinear interpolation of its cell's nodes, outside it `velocity`. The
//! caller reads the file and hands its text to [`Case::air_field`].
//!
//! A run may be ended from outside: `stop_file` in `[run]` names a file, relative to
//! the case file's folder, whose appearance ends the run as if `end_time` had been
//! reached (`orch-dem run` looks for it every `thermo_every` steps, writes every output
//! in full, logs the step and time it stopped at and exits with status 0), so that a
//! caller can stop a run whose response has converged:
//!
//! ```toml
//! [run]
//! end_time = 2.0
//! seed = 1
//! thermo_every = 1000             # steps between log lines and looks for the file
//! stop_file = "STOP"              # default: none
//! ```
//!
//! A `[verify]` table makes the case a verification benchmark ([`crate::verify`]):
//! `orch-dem verify` measures its quantities and compares them with the references;
//! `orch-dem run` ignores it.

use serde::Deserialize;

use crate::air::Air;
use crate::air_field::AirField;
use crate::inflow::Inflow;
use crate::insert::{counts_from_mass_fractions, insert, Region};
use crate::material::{Material, ParticleType};
use crate::math::{Real, Vec3, STANDARD_GRAVITY_M_S2};
use crate::mesh::{parse_stl, Motion, WallMesh, WeldedMesh};
use crate::packing::parse_lammps_data;
use crate::particles::Particles;
use crate::simulation::{Config, Simulation};
use crate::timestep::{
    impact_speed_bound_m_per_s, TimestepLimits, MAX_HERTZ_FRACTION, MAX_RAYLEIGH_FRACTION,
};
use crate::verify::Verify;

/// A whole case file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Time stepping and stopping.
    pub run: Run,
    /// The box the neighbour grid covers.
    pub domain: Domain,
    /// Particle types, in type order (type 1 in dumps is the first).
    pub types: Vec<MaterialEntry>,
    /// Material of every wall.
    pub wall_material: WallMaterial,
    /// Walls.
    #[serde(default)]
    pub meshes: Vec<MeshEntry>,
    /// Particles inserted at random at the start (none when absent); excludes
    /// `particles`.
    pub insert: Option<Insert>,
    /// Explicit particles present at the start (`[[particles]]`); excludes `insert`.
    #[serde(default)]
    pub particles: Vec<ParticleEntry>,
    /// Particles at rest at the start, read from a LAMMPS data file (`[packing]`);
    /// excludes `insert` and `particles`.
    pub packing: Option<PackingEntry>,
    /// Continuous inflows (`[[inflow]]`), fed while the run goes on.
    #[serde(default)]
    pub inflow: Vec<InflowEntry>,
    /// Plane whose downward crossings are recorded (from its `start`).
    pub sensor: Option<Sensor>,
    /// Plane below which particles are removed and counted as discharged.
    pub sink: Option<Plane>,
    /// What is written, and how often.
    #[serde(default)]
    pub output: Output,
    /// The quantities a verification case measures and their references (`[verify]`);
    /// only `orch-dem verify` reads it.
    pub verify: Option<Verify>,
    /// Air that drags every particle (`[air]`); absent: vacuum.
    pub air: Option<AirEntry>,
}

/// `[air]`: the air around the particles, still or moving uniformly.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AirEntry {
    /// Density, kg/m³ (default 1.2, air at 20 °C).
    #[serde(default = "default_air_density")]
    pub density: Real,
    /// Dynamic viscosity, Pa·s (default 1.8e-5, air at 20 °C).
    #[serde(default = "default_air_viscosity")]
    pub viscosity: Real,
    /// Velocity, m/s (default still air); outside `velocity_field`'s grid when one is
    /// given.
    #[serde(default)]
    pub velocity: [Real; 3],
    /// CSV file of the air's velocity on a grid (`x,y,z,ux,uy,uz`, m and m/s),
    /// relative to the case file's folder, read by the caller ([`Case::air_field`]);
    /// absent: `velocity` everywhere.
    pub velocity_field: Option<String>,
}

fn default_air_density() -> Real {
    1.2
}

fn default_air_viscosity() -> Real {
    1.8e-5
}

/// `[run]`: time stepping and stopping.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Run {
    /// Time step, s; at most the largest safe step of [`crate::timestep`]; when
    /// absent, `rayleigh_fraction` × the smallest Rayleigh time, and at most 0.1 of the
    /// shortest Hertz contact time.
    pub timestep: Option<Real>,
    /// Fraction of the smallest Rayleigh time used as the time step when none is
    /// given (default 0.15, at most 0.3).
    #[serde(default = "default_rayleigh_fraction")]
    pub rayleigh_fraction: Real,
    /// Simulated time to run, s.
    pub end_time: Real,
    /// Seed of the insertion.
    pub seed: u64,
    /// After this time, s, the run stops as soon as at most `stop_when_at_most`
    /// particles remain.
    #[serde(default)]
    pub stop_check_after: Real,
    /// See `stop_check_after`; absent: never stop early.
    pub stop_when_at_most: Option<usize>,
    /// Steps between log lines (and between looks for `stop_file`).
    #[serde(default = "default_thermo_every")]
    pub thermo_every: u64,
    /// A file, named relative to the case file's folder, whose appearance ends the run
    /// as if `end_time` had been reached; the caller looks for it every `thermo_every`
    /// steps. Absent: the run never looks.
    pub stop_file: Option<String>,
    /// Verlet skin, m (default: half the largest radius, as the LIGGGHTS deck).
    pub skin: Option<Real>,
    /// Gravity, m/s² (default 9.81 downwards along z).
    pub gravity: Option<[Real; 3]>,
    /// Coplanar angle of wall contacts, degrees (default 20).
    #[serde(default = "default_coplanar_angle")]
    pub coplanar_angle: Real,
    /// Speed that means the run has gone unstable, m/s (default 50).
    #[serde(default = "default_max_speed")]
    pub max_speed: Real,
    /// Overlap / radius that means the run has gone unstable (default 0.25).
    #[serde(default = "default_max_overlap_ratio")]
    pub max_overlap_ratio: Real,
}

fn default_rayleigh_fraction() -> Real {
    0.15
}
fn default_thermo_every() -> u64 {
    1000
}
fn default_coplanar_angle() -> Real {
    20.0
}
fn default_max_speed() -> Real {
    50.0
}
fn default_max_overlap_ratio() -> Real {
    0.25
}

/// `[domain]`: the box of the neighbour grid, m.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    /// Lower corner, m.
    pub min: [Real; 3],
    /// Upper corner, m.
    pub max: [Real; 3],
}

/// `[[types]]`: one particle type.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialEntry {
    /// Name for messages.
    pub name: String,
    /// Radius, m.
    pub radius: Real,
    /// Density, kg/m³.
    pub density: Real,
    /// Material.
    #[serde(flatten)]
    pub material: WallMaterial,
}

/// The contact properties of a material.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallMaterial {
    /// Young's modulus, Pa.
    pub youngs_modulus: Real,
    /// Poisson ratio.
    pub poisson_ratio: Real,
    /// Coefficient of restitution.
    pub restitution: Real,
    /// Sliding friction.
    pub friction: Real,
    /// Rolling friction (constant directional torque); default 0.
    #[serde(default)]
    pub rolling_friction: Real,
}

/// `[[meshes]]`: one wall.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshEntry {
    /// Name for messages.
    pub name: String,
    /// STL file, relative to the case file.
    pub file: String,
    /// Time the wall is removed, s.
    pub removed_at: Option<Real>,
    /// How it moves (default: fixed).
    pub motion: Option<MotionEntry>,
}

/// A wall's motion.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum MotionEntry {
    /// Sinusoidal: `A sin(2π f (t - start))`.
    Vibration {
        /// Amplitude vector, m.
        amplitude: [Real; 3],
        /// Frequency, Hz.
        frequency: Real,
        /// Start time, s.
        #[serde(default)]
        start: Real,
    },
    /// Constant velocity.
    Translation {
        /// Velocity, m/s.
        velocity: [Real; 3],
        /// Start time, s.
        #[serde(default)]
        start: Real,
    },
}

/// `[insert]`: the particles placed at the start.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Insert {
    /// Number of particles.
    pub count: usize,
    /// Mass fraction of each type, in type order; sums to 1.
    pub mass_fractions: Vec<Real>,
    /// Where.
    pub region: RegionEntry,
}

/// `[[particles]]`: one particle placed by hand, for impacts and other set-ups that
/// need exact initial states.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleEntry {
    /// Its type: a `[[types]]` name, or the type's number counted from 1 as in dumps.
    #[serde(rename = "type")]
    pub kind: TypeRef,
    /// Centre, m.
    pub position: [Real; 3],
    /// Velocity, m/s (default at rest).
    #[serde(default)]
    pub velocity: [Real; 3],
    /// Angular velocity, rad/s (default not spinning).
    #[serde(default)]
    pub angular_velocity: [Real; 3],
    /// Radius, m (default the type's); the type's density and material still apply.
    pub radius: Option<Real>,
}

/// `[packing]`: the particles present at the start, at rest, from a LAMMPS data file
/// ([`crate::packing`]) that LAMMPS and LIGGGHTS can read too, so that codes compared
/// start from the same spheres. Each sphere's type counts from 1 in `[[types]]` order,
/// and its radius and density must be its type's (to 1 part in 10⁹), so that the
/// default time step and skin, which follow from the types, hold for it.
///
/// ```toml
/// [packing]
/// file = "packing.data"           # relative to the case file's folder
/// ```
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PackingEntry {
    /// The data file, relative to the case file's folder, read by the caller
    /// ([`Case::build_from`]).
    pub file: String,
}

/// A reference to a particle type: by name, or by number from 1 (the dumps' numbering).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum TypeRef {
    /// The `name` of a `[[types]]` entry.
    Name(String),
    /// The type's number, 1 for the first `[[types]]` entry.
    Number(i64),
}

/// `[[inflow]]`: a mixture fed through a region at a mass rate over a time window
/// ([`crate::inflow`]). For example, 0.2 kg/s of a half-and-half mixture for 0.5 s
/// through a thin box, moving at 1 m/s along x:
///
/// ```toml
/// [[inflow]]
/// mass_rate = 0.2
/// mass_fractions = [0.5, 0.5]
/// velocity = [1.0, 0.0, 0.0]
/// start = 0.0
/// end = 0.5
/// region = { kind = "box", min = [0.0, -0.02, 0.1], max = [0.01, 0.02, 0.12] }
/// ```
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InflowEntry {
    /// Mass fed per second, kg/s.
    pub mass_rate: Real,
    /// Mass fraction of each type, in type order; sums to 1.
    pub mass_fractions: Vec<Real>,
    /// Velocity of the inserted particles, m/s.
    #[serde(default)]
    pub velocity: [Real; 3],
    /// Start of the window, s (default 0).
    #[serde(default)]
    pub start: Real,
    /// End of the window, s.
    pub end: Real,
    /// Time between batches, s; default: the time the velocity takes to cross the
    /// region (required when the velocity is zero).
    pub interval: Option<Real>,
    /// Where particles appear; it must be clear of walls.
    pub region: RegionEntry,
}

/// An insertion region.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
pub enum RegionEntry {
    /// Vertical cylinder.
    Cylinder {
        /// Axis (x, y), m.
        centre: [Real; 2],
        /// Radius, m.
        radius: Real,
        /// Bottom, m.
        z_min: Real,
        /// Top, m.
        z_max: Real,
    },
    /// Axis-aligned box.
    Box {
        /// Lower corner, m.
        min: [Real; 3],
        /// Upper corner, m.
        max: [Real; 3],
    },
}

/// `[sensor]`: a horizontal plane whose downward crossings are recorded, from `start`
/// on: a hopper's sensor starts when its plug is removed, as the LIGGGHTS and YADE
/// decks start theirs, so material spilled over the rim while filling (a poured
/// stream splashes fines out of the hopper) is not counted as discharged through the
/// outlet.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    /// Height, m.
    pub z: Real,
    /// Time from which crossings are recorded, s (default 0).
    #[serde(default)]
    pub start: Real,
}

/// A horizontal plane.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plane {
    /// Height, m.
    pub z: Real,
}

/// `[output]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// Steps between `dump custom` files of all particles; 0 = none.
    #[serde(default)]
    pub dump_every: u64,
    /// Steps between VTK legacy files of all particles; 0 = none.
    #[serde(default)]
    pub vtk_every: u64,
}

/// What is wrong with a case file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CaseError {
    /// The TOML does not match the format.
    #[error("{0}")]
    Syntax(String),
    /// A value is out of its range.
    #[error("`{field}`: {message}")]
    Invalid {
        /// Key path, e.g. `types[1].radius`.
        field: String,
        /// What was expected.
        message: String,
    },
    /// A mesh file is not a usable STL.
    #[error("mesh `{name}` ({file}): {message}")]
    Mesh {
        /// Mesh name.
        name: String,
        /// File as named in the case.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The air's velocity field file is not a usable grid.
    #[error("`air.velocity_field` ({file}): {message}")]
    AirField {
        /// File as named in the case.
        file: String,
        /// What is wrong, with the line when one line is.
        message: String,
    },
    /// The packing file is not a usable packing for this case.
    #[error("`packing.file` ({file}): {message}")]
    Packing {
        /// File as named in the case.
        file: String,
        /// What is wrong, with the line when one line is.
        message: String,
    },
    /// The simulation cannot start.
    #[error("{0}")]
    Setup(String),
}

fn invalid(field: impl Into<String>, message: impl Into<String>) -> CaseError {
    CaseError::Invalid {
        field: field.into(),
        message: message.into(),
    }
}

fn finite_positive(field: &str, value: Real) -> Result<(), CaseError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("expected a positive number, got {value}"),
        ))
    }
}

fn finite(field: &str, values: &[Real]) -> Result<(), CaseError> {
    match values.iter().find(|v| !v.is_finite()) {
        None => Ok(()),
        Some(v) => Err(invalid(field, format!("expected finite numbers, got {v}"))),
    }
}

impl Case {
    /// Parses and validates a case file's text.
    pub fn parse(text: &str) -> Result<Self, CaseError> {
        let case: Case = toml::from_str(text).map_err(|e| CaseError::Syntax(e.to_string()))?;
        case.validate()?;
        case.check_timestep()?;
        Ok(case)
    }

    fn validate(&self) -> Result<(), CaseError> {
        let run = &self.run;
        if let Some(dt) = run.timestep {
            finite_positive("run.timestep", dt)?;
        }
        finite_positive("run.rayleigh_fraction", run.rayleigh_fraction)?;
        if run.rayleigh_fraction > MAX_RAYLEIGH_FRACTION {
            return Err(invalid(
                "run.rayleigh_fraction",
                format!(
                    "{} is above {MAX_RAYLEIGH_FRACTION}, the largest safe fraction of the Rayleigh time; give at most {MAX_RAYLEIGH_FRACTION}",
                    run.rayleigh_fraction
                ),
            ));
        }
        finite_positive("run.end_time", run.end_time)?;
        finite_positive("run.max_speed", run.max_speed)?;
        finite_positive("run.max_overlap_ratio", run.max_overlap_ratio)?;
        if let Some(skin) = run.skin {
            finite_positive("run.skin", skin)?;
        }
        if let Some(file) = run.stop_file.as_ref().filter(|f| f.trim().is_empty()) {
            return Err(invalid(
                "run.stop_file",
                format!("expected a file name relative to the case file's folder, got {file:?}"),
            ));
        }
        if let Some(air) = &self.air {
            finite_positive("air.density", air.density)?;
            finite_positive("air.viscosity", air.viscosity)?;
            finite("air.velocity", &air.velocity)?;
            if let Some(file) = air.velocity_field.as_ref().filter(|f| f.trim().is_empty()) {
                return Err(invalid(
                    "air.velocity_field",
                    format!(
                        "expected a CSV file name relative to the case file's folder, got {file:?}"
                    ),
                ));
            }
        }
        finite("domain.min", &self.domain.min)?;
        finite("domain.max", &self.domain.max)?;
        for k in 0..3 {
            if self.domain.max[k] <= self.domain.min[k] {
                return Err(invalid(
                    "domain",
                    format!(
                        "max must exceed min along every axis (axis {k}: min {}, max {})",
                        self.domain.min[k], self.domain.max[k]
                    ),
                ));
            }
        }
        if self.types.is_empty() {
            return Err(invalid("types", "expected at least one [[types]] entry"));
        }
        for (k, t) in self.types.iter().enumerate() {
            let field = |name: &str| format!("types[{k}].{name}");
            finite_positive(&field("radius"), t.radius)?;
            finite_positive(&field("density"), t.density)?;
            check_material(&format!("types[{k}]"), &t.material)?;
        }
        check_material("wall_material", &self.wall_material)?;
        for (k, entry) in self.inflow.iter().enumerate() {
            let inflow = self.inflow_of(k, entry)?;
            inflow
                .validate(&self.particle_types())
                .map_err(|e| invalid(format!("inflow[{k}]"), e.to_string()))?;
        }
        self.validate_particles()?;
        if let Some(verify) = &self.verify {
            verify
                .validate(self.run.end_time, self.particles.len())
                .map_err(|e| invalid(e.field, e.message))?;
        }
        let Some(insert) = &self.insert else {
            return self.validate_meshes();
        };
        if insert.mass_fractions.len() != self.types.len() {
            return Err(invalid(
                "insert.mass_fractions",
                format!(
                    "expected one fraction per type ({}), got {}",
                    self.types.len(),
                    insert.mass_fractions.len()
                ),
            ));
        }
        let sum: Real = insert.mass_fractions.iter().sum();
        if insert
            .mass_fractions
            .iter()
            .any(|w| !(0.0..=1.0).contains(w))
            || (sum - 1.0).abs() > 1e-6
        {
            return Err(invalid(
                "insert.mass_fractions",
                format!(
                    "expected fractions in [0, 1] that sum to 1, got {:?} (sum {sum})",
                    insert.mass_fractions
                ),
            ));
        }
        self.validate_meshes()
    }

    fn validate_particles(&self) -> Result<(), CaseError> {
        if let Some(packing) = &self.packing {
            if self.insert.is_some() || !self.particles.is_empty() {
                return Err(invalid(
                    "packing",
                    "a case takes its initial particles from one place: [packing], [insert] or [[particles]]; remove the others (an [[inflow]] may join any)",
                ));
            }
            if packing.file.trim().is_empty() {
                return Err(invalid(
                    "packing.file",
                    "expected a data file name relative to the case file's folder",
                ));
            }
        }
        if self.insert.is_some() && !self.particles.is_empty() {
            return Err(invalid(
                "particles",
                "a case places its particles either at random ([insert]) or by hand ([[particles]]), not both; remove one (an [[inflow]] may join either)",
            ));
        }
        for (k, p) in self.particles.iter().enumerate() {
            let field = |name: &str| format!("particles[{k}].{name}");
            self.type_index(k, &p.kind)?;
            finite(&field("position"), &p.position)?;
            finite(&field("velocity"), &p.velocity)?;
            finite(&field("angular_velocity"), &p.angular_velocity)?;
            if let Some(radius) = p.radius {
                finite_positive(&field("radius"), radius)?;
            }
            let speed = Vec3::from(p.velocity).norm();
            if speed > self.run.max_speed {
                return Err(invalid(
                    field("velocity"),
                    format!(
                        "the speed {speed} m/s exceeds run.max_speed ({} m/s), which would stop the run at once; launch it slower or raise run.max_speed",
                        self.run.max_speed
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The index into `types` of explicit particle `k`'s type.
    fn type_index(&self, k: usize, kind: &TypeRef) -> Result<usize, CaseError> {
        let names: Vec<&str> = self.types.iter().map(|t| t.name.as_str()).collect();
        let found = match kind {
            TypeRef::Name(name) => names.iter().position(|n| n == name),
            TypeRef::Number(number) => usize::try_from(*number)
                .ok()
                .filter(|n| (1..=names.len()).contains(n))
                .map(|n| n - 1),
        };
        found.ok_or_else(|| {
            let given = match kind {
                TypeRef::Name(name) => format!("\"{name}\""),
                TypeRef::Number(number) => number.to_string(),
            };
            invalid(
                format!("particles[{k}].type"),
                format!(
                    "no particle type {given}; expected one of the [[types]] names {names:?} or a number from 1 to {} (types count from 1, as in dumps)",
                    names.len()
                ),
            )
        })
    }

    /// The radius of explicit particle `entry`, m: its own, or its type's.
    fn radius_of(&self, kind: usize, entry: &ParticleEntry) -> Real {
        entry.radius.unwrap_or(self.types[kind].radius)
    }

    /// The explicit particles, ids 1, 2, … in file order (call after validation).
    fn explicit_particles(&self, types: &[ParticleType]) -> Result<Particles, CaseError> {
        let mut particles = Particles::default();
        for (k, entry) in self.particles.iter().enumerate() {
            let kind = self.type_index(k, &entry.kind)?;
            let sized = ParticleType {
                radius_m: self.radius_of(kind, entry),
                ..types[kind]
            };
            particles.push(
                k as u32 + 1,
                kind as u16,
                &sized,
                Vec3::from(entry.position),
            );
            particles.velocity_m_per_s[k] = Vec3::from(entry.velocity);
            particles.angular_velocity[k] = Vec3::from(entry.angular_velocity);
        }
        Ok(particles)
    }

    /// The largest radius of any type or explicit particle, m.
    fn largest_radius_m(&self) -> Real {
        let explicit = self.particles.iter().filter_map(|p| p.radius);
        self.types
            .iter()
            .map(|t| t.radius)
            .chain(explicit)
            .fold(0.0, Real::max)
    }

    fn validate_meshes(&self) -> Result<(), CaseError> {
        for (k, mesh) in self.meshes.iter().enumerate() {
            match &mesh.motion {
                Some(MotionEntry::Vibration {
                    amplitude,
                    frequency,
                    start,
                }) => {
                    finite(&format!("meshes[{k}].motion.amplitude"), amplitude)?;
                    finite(&format!("meshes[{k}].motion.start"), &[*start])?;
                    if !(frequency.is_finite() && *frequency >= 0.0) {
                        return Err(invalid(
                            format!("meshes[{k}].motion.frequency"),
                            format!("expected a frequency ≥ 0 Hz, got {frequency}"),
                        ));
                    }
                }
                Some(MotionEntry::Translation { velocity, start }) => {
                    finite(&format!("meshes[{k}].motion.velocity"), velocity)?;
                    finite(&format!("meshes[{k}].motion.start"), &[*start])?;
                }
                None => {}
            }
        }
        Ok(())
    }

    /// The inflow of entry `k`, its region, interval and seed resolved.
    fn inflow_of(&self, k: usize, entry: &InflowEntry) -> Result<Inflow, CaseError> {
        let field = |name: &str| format!("inflow[{k}].{name}");
        finite(&field("velocity"), &entry.velocity)?;
        let region = region(&entry.region);
        let velocity = Vec3::from(entry.velocity);
        let interval = match entry.interval {
            Some(interval) => {
                finite_positive(&field("interval"), interval)?;
                interval
            }
            None => Inflow::crossing_time_s(&region, velocity).ok_or_else(|| {
                invalid(
                    field("interval"),
                    "required when the velocity is zero (the default is the time the velocity takes to cross the region)",
                )
            })?,
        };
        Ok(Inflow {
            region,
            mass_fractions: entry.mass_fractions.clone(),
            mass_rate_kg_per_s: entry.mass_rate,
            velocity_m_per_s: velocity,
            start_s: entry.start,
            end_s: entry.end,
            interval_s: interval,
            seed: self
                .run
                .seed
                .wrapping_add(0x9E37_79B9_7F4A_7C15u64.wrapping_mul(k as u64 + 1)),
        })
    }

    /// The particle types.
    pub fn particle_types(&self) -> Vec<ParticleType> {
        self.types
            .iter()
            .map(|t| ParticleType {
                radius_m: t.radius,
                density_kg_m3: t.density,
                material: material(&t.material),
            })
            .collect()
    }

    /// The Rayleigh and Hertz times this case's step is measured against
    /// ([`crate::timestep`]): of the types, each at the smallest radius it is given
    /// (its own, or an explicit particle's), against each other and the wall.
    pub fn timestep_limits(&self) -> TimestepLimits {
        let mut types = self.particle_types();
        for (k, p) in self.particles.iter().enumerate() {
            if let (Some(radius_m), Ok(kind)) = (p.radius, self.type_index(k, &p.kind)) {
                types[kind].radius_m = types[kind].radius_m.min(radius_m);
            }
        }
        TimestepLimits::of(
            &types,
            &material(&self.wall_material),
            impact_speed_bound_m_per_s(self),
        )
    }

    /// The time step, s: given, or chosen from the Rayleigh and Hertz times
    /// ([`TimestepLimits::chosen_s`]).
    pub fn timestep_s(&self) -> Real {
        self.run
            .timestep
            .unwrap_or_else(|| self.timestep_limits().chosen_s(self.run.rayleigh_fraction))
    }

    /// Refuses a given step above the largest safe one, naming that one.
    fn check_timestep(&self) -> Result<(), CaseError> {
        let limits = self.timestep_limits();
        let largest = limits.largest_s();
        match self.run.timestep {
            Some(dt) if dt > largest => Err(invalid(
                "run.timestep",
                format!(
                    "{dt:.4e} s is above the largest safe time step for these particles, {largest:.4e} s ({MAX_RAYLEIGH_FRACTION} of the smallest Rayleigh time, {:.4e} s, and {MAX_HERTZ_FRACTION} of the shortest Hertz contact time, {:.4e} s at an impact speed of {:.3} m/s); give at most {largest:.4e} s (a case file without `timestep` gets {:.4e} s)",
                    limits.rayleigh_time_s,
                    limits.hertz_time_s,
                    limits.impact_speed_m_per_s,
                    limits.chosen_s(self.run.rayleigh_fraction),
                ),
            )),
            _ => Ok(()),
        }
    }

    /// Builds wall `index` from its STL file's bytes.
    pub fn wall_mesh(&self, index: usize, stl: &[u8]) -> Result<WallMesh, CaseError> {
        let entry = &self.meshes[index];
        let error = |message: String| CaseError::Mesh {
            name: entry.name.clone(),
            file: entry.file.clone(),
            message,
        };
        let triangles = parse_stl(stl).map_err(|e| error(e.to_string()))?;
        let welded = WeldedMesh::from_triangles(&triangles).map_err(|e| error(e.to_string()))?;
        let motion = match entry.motion {
            None => Motion::Fixed,
            Some(MotionEntry::Vibration {
                amplitude,
                frequency,
                start,
            }) => Motion::Vibration {
                amplitude_m: Vec3::from(amplitude),
                frequency_hz: frequency,
                start_s: start,
            },
            Some(MotionEntry::Translation { velocity, start }) => Motion::Translation {
                velocity_m_per_s: Vec3::from(velocity),
                start_s: start,
            },
        };
        let mut wall = WallMesh::new(entry.name.clone(), welded, motion);
        wall.removed_at_s = entry.removed_at;
        Ok(wall)
    }

    /// The CSV file `[air] velocity_field` names, relative to the case file's folder;
    /// `None` when the case names none.
    pub fn air_field_file(&self) -> Option<&str> {
        self.air.as_ref()?.velocity_field.as_deref()
    }

    /// Builds the air's velocity field from the text of the file
    /// [`Case::air_field_file`] names.
    pub fn air_field(&self, csv: &str) -> Result<AirField, CaseError> {
        let file = self.air_field_file().ok_or_else(|| {
            invalid(
                "air.velocity_field",
                "the case's [air] names no velocity field",
            )
        })?;
        AirField::parse_csv(csv).map_err(|e| CaseError::AirField {
            file: file.to_string(),
            message: e.to_string(),
        })
    }

    /// The LAMMPS data file `[packing]` names, relative to the case file's folder;
    /// `None` when the case names none.
    pub fn packing_file(&self) -> Option<&str> {
        self.packing.as_ref().map(|p| p.file.as_str())
    }

    /// The particles of the packing file's text, ids as in the file, each with its
    /// type's radius and density (which the file's must match).
    fn packed_particles(&self, types: &[ParticleType], text: &str) -> Result<Particles, CaseError> {
        let file = self.packing_file().unwrap_or_default();
        let error = |message: String| CaseError::Packing {
            file: file.to_string(),
            message,
        };
        let spheres = parse_lammps_data(text).map_err(|e| error(e.to_string()))?;
        let mut particles = Particles::default();
        for sphere in spheres {
            let kind = sphere.kind as usize - 1;
            let Some(particle_type) = types.get(kind) else {
                return Err(error(format!(
                    "particle {} has type {}, but the case has {} types",
                    sphere.id,
                    sphere.kind,
                    types.len()
                )));
            };
            let close = |a: Real, b: Real| (a - b).abs() <= 1e-9 * b.abs();
            if !close(sphere.radius_m, particle_type.radius_m)
                || !close(sphere.density_kg_m3, particle_type.density_kg_m3)
            {
                return Err(error(format!(
                    "particle {} has radius {} m and density {} kg/m³, its type {} ({}) {} m and {} kg/m³",
                    sphere.id,
                    sphere.radius_m,
                    sphere.density_kg_m3,
                    sphere.kind,
                    self.types[kind].name,
                    particle_type.radius_m,
                    particle_type.density_kg_m3
                )));
            }
            particles.push(sphere.id, kind as u16, particle_type, sphere.position_m);
        }
        Ok(particles)
    }

    /// Inserts the particles and sets up the simulation among `walls` (built with
    /// [`Case::wall_mesh`], in case order), for a case that names no air velocity
    /// field (else [`Case::build_with_air_field`]) and no packing (else
    /// [`Case::build_from`]).
    pub fn build(&self, walls: Vec<WallMesh>) -> Result<Simulation, CaseError> {
        self.build_with_air_field(walls, None)
    }

    /// As [`Case::build`], with the air's velocity field built by [`Case::air_field`]:
    /// given exactly when the case names one.
    pub fn build_with_air_field(
        &self,
        walls: Vec<WallMesh>,
        air_field: Option<AirField>,
    ) -> Result<Simulation, CaseError> {
        self.build_from(walls, air_field, None)
    }

    /// As [`Case::build_with_air_field`], with the text of the packing file
    /// [`Case::packing_file`] names: given exactly when the case names one.
    pub fn build_from(
        &self,
        walls: Vec<WallMesh>,
        air_field: Option<AirField>,
        packing: Option<&str>,
    ) -> Result<Simulation, CaseError> {
        match (self.packing_file(), packing) {
            (Some(file), None) => {
                return Err(invalid(
                    "packing.file",
                    format!("the case names {file}, but its text was not given; read the file and build with Case::build_from"),
                ))
            }
            (None, Some(_)) => {
                return Err(invalid(
                    "packing",
                    "a packing was given, but the case names none",
                ))
            }
            _ => {}
        }
        match (self.air_field_file(), &air_field) {
            (Some(file), None) => {
                return Err(invalid(
                    "air.velocity_field",
                    format!("the case names {file}, but its field was not given; read the file and build with Case::build_with_air_field"),
                ))
            }
            (None, Some(_)) => {
                return Err(invalid(
                    "air.velocity_field",
                    "a velocity field was given, but the case's [air] names none",
                ))
            }
            _ => {}
        }
        let types = self.particle_types();
        let mut particles = match packing {
            Some(text) => self.packed_particles(&types, text)?,
            None => self.explicit_particles(&types)?,
        };
        if let Some(entry) = &self.insert {
            let counts = counts_from_mass_fractions(&types, &entry.mass_fractions, entry.count);
            insert(
                &mut particles,
                &types,
                &counts,
                &region(&entry.region),
                self.run.seed,
                1,
            )
            .map_err(|e| invalid("insert", e.to_string()))?;
        }
        let largest = self.largest_radius_m();
        let config = Config {
            timestep_s: self.timestep_s(),
            gravity_m_per_s2: self.run.gravity.map(Vec3::from).unwrap_or(Vec3::new(
                0.0,
                0.0,
                -STANDARD_GRAVITY_M_S2,
            )),
            skin_m: self.run.skin.unwrap_or(0.5 * largest),
            domain_min_m: Vec3::from(self.domain.min),
            domain_max_m: Vec3::from(self.domain.max),
            coplanar_angle_deg: self.run.coplanar_angle,
            max_speed_m_per_s: self.run.max_speed,
            max_overlap_ratio: self.run.max_overlap_ratio,
            wall_material: material(&self.wall_material),
            air: self.air.as_ref().map(|a| Air {
                density_kg_m3: a.density,
                viscosity_pa_s: a.viscosity,
                velocity_m_per_s: Vec3::from(a.velocity),
            }),
            air_field,
        };
        let mut simulation = Simulation::new(config, types, particles, walls)
            .map_err(|e| CaseError::Setup(e.to_string()))?;
        if let Some(sensor) = &self.sensor {
            simulation.set_sensor_plane(sensor.z, sensor.start);
        }
        if let Some(sink) = &self.sink {
            simulation.set_sink_plane(sink.z);
        }
        for (k, entry) in self.inflow.iter().enumerate() {
            simulation
                .add_inflow(self.inflow_of(k, entry)?)
                .map_err(|e| invalid(format!("inflow[{k}]"), e.to_string()))?;
        }
        Ok(simulation)
    }
}

fn check_material(prefix: &str, m: &WallMaterial) -> Result<(), CaseError> {
    finite_positive(&format!("{prefix}.youngs_modulus"), m.youngs_modulus)?;
    if !(0.0..0.5).contains(&m.poisson_ratio) {
        return Err(invalid(
            format!("{prefix}.poisson_ratio"),
            format!("expected 0 ≤ ν < 0.5, got {}", m.poisson_ratio),
        ));
    }
    if !(m.restitution > 0.0 && m.restitution <= 1.0) {
        return Err(invalid(
            format!("{prefix}.restitution"),
            format!("expected 0 < e ≤ 1, got {}", m.restitution),
        ));
    }
    for (name, value) in [
        ("friction", m.friction),
        ("rolling_friction", m.rolling_friction),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(invalid(
                format!("{prefix}.{name}"),
                format!("expected a coefficient ≥ 0, got {value}"),
            ));
        }
    }
    Ok(())
}

fn region(entry: &RegionEntry) -> Region {
    match *entry {
        RegionEntry::Cylinder {
            centre,
            radius,
            z_min,
            z_max,
        } => Region::Cylinder {
            centre_m: centre,
            radius_m: radius,
            z_min_m: z_min,
            z_max_m: z_max,
        },
        RegionEntry::Box { min, max } => Region::Box {
            min_m: Vec3::from(min),
            max_m: Vec3::from(max),
        },
    }
}

fn material(m: &WallMaterial) -> Material {
    Material {
        youngs_modulus_pa: m.youngs_modulus,
        poisson_ratio: m.poisson_ratio,
        restitution: m.restitution,
        friction: m.friction,
        rolling_friction: m.rolling_friction,
    }
}

#[cfg(test)]
mod tests;
