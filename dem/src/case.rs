//! The case file: a TOML description of one native-kernel run, which `orch` renders
//! from `templates/native/hopper.toml.tera` or `chute.toml.tera` (every value SI).
//!
//! Parsing checks every field (unknown keys are errors, so a misspelt key cannot be
//! silently ignored) and reports errors by key path; the caller adds the file name.
//! Mesh files are named here but read by the caller, which passes their bytes to
//! [`Case::wall_mesh`].

use serde::Deserialize;

use crate::inflow::Inflow;
use crate::insert::{counts_from_mass_fractions, insert, Region};
use crate::material::{Material, ParticleType};
use crate::math::{Real, Vec3, STANDARD_GRAVITY_M_S2};
use crate::mesh::{parse_stl, Motion, WallMesh, WeldedMesh};
use crate::particles::Particles;
use crate::simulation::{Config, Simulation};

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
    /// Particles inserted at the start (none when absent).
    pub insert: Option<Insert>,
    /// Continuous inflows (`[[inflow]]`), fed while the run goes on.
    #[serde(default)]
    pub inflow: Vec<InflowEntry>,
    /// Plane whose downward crossings are recorded.
    pub sensor: Option<Plane>,
    /// Plane below which particles are removed and counted as discharged.
    pub sink: Option<Plane>,
    /// What is written, and how often.
    #[serde(default)]
    pub output: Output,
}

/// `[run]`: time stepping and stopping.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Run {
    /// Time step, s; when absent, `rayleigh_fraction` × the smallest Rayleigh time.
    pub timestep: Option<Real>,
    /// Fraction of the smallest Rayleigh time used as the time step (default 0.15).
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
    /// Steps between log lines.
    #[serde(default = "default_thermo_every")]
    pub thermo_every: u64,
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
        Ok(case)
    }

    fn validate(&self) -> Result<(), CaseError> {
        let run = &self.run;
        if let Some(dt) = run.timestep {
            finite_positive("run.timestep", dt)?;
        }
        finite_positive("run.rayleigh_fraction", run.rayleigh_fraction)?;
        finite_positive("run.end_time", run.end_time)?;
        finite_positive("run.max_speed", run.max_speed)?;
        finite_positive("run.max_overlap_ratio", run.max_overlap_ratio)?;
        if let Some(skin) = run.skin {
            finite_positive("run.skin", skin)?;
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
            mass_rate_kg_s: entry.mass_rate,
            velocity_m_s: velocity,
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

    /// The time step, s: given, or a fraction of the smallest Rayleigh time.
    pub fn timestep_s(&self) -> Real {
        self.run.timestep.unwrap_or_else(|| {
            self.run.rayleigh_fraction
                * self
                    .particle_types()
                    .iter()
                    .map(ParticleType::rayleigh_time_s)
                    .fold(Real::INFINITY, Real::min)
        })
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
                velocity_m_s: Vec3::from(velocity),
                start_s: start,
            },
        };
        let mut wall = WallMesh::new(entry.name.clone(), welded, motion);
        wall.removed_at_s = entry.removed_at;
        Ok(wall)
    }

    /// Inserts the particles and sets up the simulation among `walls` (built with
    /// [`Case::wall_mesh`], in case order).
    pub fn build(&self, walls: Vec<WallMesh>) -> Result<Simulation, CaseError> {
        let types = self.particle_types();
        let mut particles = Particles::default();
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
        let largest = types.iter().map(|t| t.radius_m).fold(0.0, Real::max);
        let config = Config {
            timestep_s: self.timestep_s(),
            gravity_m_s2: self.run.gravity.map(Vec3::from).unwrap_or(Vec3::new(
                0.0,
                0.0,
                -STANDARD_GRAVITY_M_S2,
            )),
            skin_m: self.run.skin.unwrap_or(0.5 * largest),
            domain_min_m: Vec3::from(self.domain.min),
            domain_max_m: Vec3::from(self.domain.max),
            coplanar_angle_deg: self.run.coplanar_angle,
            max_speed_m_s: self.run.max_speed,
            max_overlap_ratio: self.run.max_overlap_ratio,
            wall_material: material(&self.wall_material),
        };
        let mut simulation = Simulation::new(config, types, particles, walls)
            .map_err(|e| CaseError::Setup(e.to_string()))?;
        if let Some(sensor) = &self.sensor {
            simulation.set_sensor_plane(sensor.z);
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
