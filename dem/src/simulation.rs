//! The time step: what happens, in order, when the simulation advances by `dt`.
//!
//! 1. **Kick and drift**: `v += dt/2 F/m`, `ω += dt/2 τ/I`, `x += dt v`
//!    (velocity Verlet, as LIGGGHTS's `nve/sphere`); crossings of the sensor plane and
//!    arrivals below the sink are recorded here, with the crossing time and position
//!    interpolated within the step.
//! 2. **Neighbours**: when some particle has moved, relative to the walls, more than
//!    half the skin since the last rebuild, or an inflow's batch is due, particles that
//!    reached the sink are removed, the inflows' batches are inserted
//!    ([`crate::inflow`]), the particles are sorted along a Morton curve over the
//!    neighbour cells (memory order follows space), and the pair list and wall
//!    candidates are rebuilt.
//! 3. **Pair forces** (parallel over blocks of [`BLOCK`] particles): each pair's
//!    Hertz–Mindlin force, histories updated in place. A block sums onto its own
//!    particles, both members of a pair inside it; a pair whose second member lies in a
//!    later block leaves that member's share in a per-pair slot.
//! 4. **Gather** (parallel over particles): gravity, air drag (when there is air; in
//!    the air's velocity field where one is given and covers the particle), the shares
//!    earlier blocks left in per-pair slots, in list order, and its wall contacts; the
//!    normal approach energy of wall contacts that begin is added to the wall impact
//!    energy (in index order).
//! 5. **Kick**: `v += dt/2 F/m`, `ω += dt/2 τ/I`; speeds and overlaps beyond their
//!    bounds stop the run with [`Unstable`].
//!
//! Every sum runs in an order fixed by the particle and pair indices and by the blocks,
//! whose bounds depend on the particle count alone, and the sort is a counting sort
//! whose ties keep index order, so a run gives the same numbers, bit for bit, with any
//! number of threads.

use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::air::Air;
use crate::air_field::AirField;
use crate::force::{hertz_mindlin, hertz_speed_for_overlap_m_per_s, ContactGeometry};
use crate::inflow::{Inflow, InflowError, InflowState};
use crate::material::{ContactTable, Material, ParticleType};
use crate::math::{Real, Vec3};
use crate::mesh::WallMesh;
use crate::neighbour::{CellGrid, CurveOrder, PairList, NEW_PARTICLE};
use crate::particles::{Particles, Reorder};
use crate::walls::{
    wall_load, MeshIndex, ParticleView, WallCandidates, WallContact, WallContactStore, WallLoad,
    WallState,
};

/// Settings of a simulation that are not particles or walls.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Time step, s.
    pub timestep_s: Real,
    /// Gravitational acceleration, m/s².
    pub gravity_m_per_s2: Vec3,
    /// Verlet skin added to the contact reach when listing neighbours, m.
    pub skin_m: Real,
    /// Box that the neighbour grid covers, m (particles outside still interact).
    pub domain_min_m: Vec3,
    /// See `domain_min_m`.
    pub domain_max_m: Vec3,
    /// Wall contacts on one mesh whose normals differ by less than this angle are one
    /// contact, degrees.
    pub coplanar_angle_deg: Real,
    /// A particle faster than this means the run has gone unstable, m/s.
    pub max_speed_m_per_s: Real,
    /// An overlap beyond this fraction of the smaller radius means the run has gone
    /// unstable (typical overlaps are below 1 %).
    pub max_overlap_ratio: Real,
    /// The material of every wall.
    pub wall_material: Material,
    /// Air that drags every particle ([`crate::air`]); `None`: vacuum.
    pub air: Option<Air>,
    /// The air's velocity on a grid ([`crate::air_field`]): inside the grid's box it
    /// replaces `air`'s uniform velocity; needs `air`. `None`: uniform air everywhere.
    pub air_field: Option<AirField>,
}

/// A particle crossing the sensor plane downwards, as every solver's crossings are
/// read ([`orch_granular::Crossing`]): its type numbered from 1, the velocity that at
/// the end of the step it crossed in.
pub use orch_granular::Crossing;

/// Why a run stopped: it went unstable at a given step.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Unstable {
    /// A particle moved too fast.
    #[error("the run went unstable at step {step} (t = {time_s:.6} s): particle {id} moves at {speed_m_per_s:.3e} m/s, beyond the bound of {bound_m_per_s} m/s; reduce the time step (now {timestep_s:.3e} s) or check the material stiffness")]
    Speed {
        /// Step number.
        step: u64,
        /// Simulated time, s.
        time_s: Real,
        /// Particle id.
        id: u32,
        /// Its speed, m/s (NaN when the state is no longer finite).
        speed_m_per_s: Real,
        /// The bound, m/s.
        bound_m_per_s: Real,
        /// The time step, s.
        timestep_s: Real,
    },
    /// Two bodies overlapped too deeply.
    #[error("the run went unstable at step {step} (t = {time_s:.6} s): particle {id} overlaps {other} by {ratio:.3} of its radius, beyond the bound of {bound}. The contact is too soft for its load: alone, the two would reach that overlap (Hertz) meeting head on at {bound_speed_m_per_s:.3} m/s, so they met that fast or something heavier pressed them together (a small sphere caught between a falling larger one and a wall), whatever the time step (now {timestep_s:.3e} s, within the Rayleigh and Hertz bounds when a case file set it); raise youngs_modulus (at a given load the overlap scales as E^-2/5), or check that no particle starts inside a wall")]
    Overlap {
        /// Step number.
        step: u64,
        /// Simulated time, s.
        time_s: Real,
        /// Particle id.
        id: u32,
        /// The other body ("particle 12" or "a wall").
        other: String,
        /// Overlap divided by the smaller radius.
        ratio: Real,
        /// The bound.
        bound: Real,
        /// The approach speed at which an undamped head-on Hertz impact of the two
        /// reaches the bound ([`crate::force::hertz_speed_for_overlap_m_per_s`]), m/s.
        bound_speed_m_per_s: Real,
        /// The time step, s.
        timestep_s: Real,
    },
}

/// Wall time spent in each stage of the step, for profiles.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimers {
    /// The opening half kick and drift, sensor and sink (the closing half kick is
    /// part of the gather).
    pub integrate: Duration,
    /// Neighbour list and wall candidate rebuilds.
    pub neighbours: Duration,
    /// Pair forces.
    pub pairs: Duration,
    /// Gathering forces and wall contacts, and the closing half kick.
    pub gather_and_walls: Duration,
    /// Number of neighbour list rebuilds.
    pub rebuilds: u64,
    /// Σ over rebuilds of the particles listed: with the next two, what a
    /// particle-step's pair work is made of.
    pub particles_at_rebuilds: u64,
    /// Σ over rebuilds of the pairs the new list holds (within the two radii and the
    /// skin).
    pub pairs_listed_at_rebuilds: u64,
    /// Σ over rebuilds of the pairs touching when the old list was given up.
    pub pairs_touching_at_rebuilds: u64,
}

impl StageTimers {
    /// Mean over rebuilds of the pairs listed per particle, and of the pairs touching
    /// per particle; `None` before the first rebuild with particles.
    pub fn pairs_per_particle(&self) -> Option<(f64, f64)> {
        let particles = self.particles_at_rebuilds as f64;
        (particles > 0.0).then(|| {
            (
                self.pairs_listed_at_rebuilds as f64 / particles,
                self.pairs_touching_at_rebuilds as f64 / particles,
            )
        })
    }
}

/// What a touching pair exerts on its second member when that member lies in a later
/// block than the first: stored per pair and gathered per particle (a block sums every
/// other share onto its own particles in the pair pass itself).
#[derive(Debug, Clone, Copy, Default)]
struct PairLoad {
    force_on_first: Vec3,
    torque_on_second: Vec3,
}

/// The deepest pair overlap of a block so far.
#[derive(Debug, Clone, Copy)]
struct Deepest {
    overlap_m: Real,
    /// The smaller radius of the pair, m.
    smaller_m: Real,
    i: usize,
    j: usize,
}

/// Pair rows are processed in blocks of this many particles, each block by one thread.
///
/// A block adds both shares of a pair whose members it holds straight onto their
/// sums; only a pair reaching into a later block goes through a per-pair slot that
/// the gather reads back from wherever its row lies, a read that misses the cache once
/// the pair slots outgrow it. Particles sit in Morton order, so a block is a compact
/// piece of space and most of its pairs stay inside it, more the larger it is.
/// Measured on a 30 000-sphere settled bed (one thread) against every pair going
/// through a slot: blocks of 64 ran 1.17× as fast, 256 a further 1.10×, 512 a further
/// 1.03×; 256 still leaves 118 blocks there to share among threads (12 on the
/// 3000-particle hopper). The bounds of the blocks follow from the particle count
/// alone, never from the number of threads, so the sums keep their order.
const BLOCK: usize = 256;

/// Integration runs over chunks of this many particles.
const CHUNK: usize = 512;

/// What one chunk of particles' drift found: its largest squared displacement since
/// the last rebuild (m²), and its particles (by index) that crossed the sensor plane
/// or reached the sink, in index order. Empty lists do not allocate.
#[derive(Debug, Default)]
struct DriftOutcome {
    moved_squared: Real,
    crossings: Vec<(usize, Crossing)>,
    sunk: Vec<usize>,
}

/// Whether overlap ratio `ratio` at particle `i` beats `other_ratio` at `other_i`
/// as the step's deepest: deeper, or as deep at a lower index, so two chunks' findings
/// merge to what one scan in index order finds.
fn deeper(ratio: Real, i: usize, other_ratio: Real, other_i: usize) -> bool {
    ratio > other_ratio || (ratio == other_ratio && i < other_i)
}

/// What the gather and closing half kick found: the deepest wall overlap (ratio to
/// the radius, particle index) and the first particle (by index) past the speed
/// bound, each the same on any number of threads.
#[derive(Debug, Default)]
struct Gathered {
    worst_wall: Option<(Real, usize)>,
    first_too_fast: Option<usize>,
}

impl Gathered {
    /// The two chunks' findings as one: the deeper overlap (the lower index on a
    /// tie) and the lower index past the bound.
    fn merge(self, other: Self) -> Self {
        let worst_wall = match (self.worst_wall, other.worst_wall) {
            (Some(a), Some(b)) if deeper(b.0, b.1, a.0, a.1) => Some(b),
            (Some(a), _) => Some(a),
            (None, b) => b,
        };
        let first_too_fast = match (self.first_too_fast, other.first_too_fast) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        Self {
            worst_wall,
            first_too_fast,
        }
    }
}

/// Half a velocity-Verlet kick of one sphere: `v += dt/2 F/m`, `ω += dt/2 τ/I` with
/// `I = 2/5 m r²`.
#[inline]
fn half_kick(
    velocity: &mut Vec3,
    spin: &mut Vec3,
    force: Vec3,
    torque: Vec3,
    mass_kg: Real,
    radius_m: Real,
    half_dt_s: Real,
) {
    *velocity += half_dt_s / mass_kg * force;
    *spin += half_dt_s / (0.4 * mass_kg * radius_m * radius_m) * torque;
}

mod saved;
pub use saved::{RestoreError, SavedState};

/// A DEM simulation: particles, walls, and the scratch state of the stepper.
#[derive(Debug)]
pub struct Simulation {
    config: Config,
    types: Vec<ParticleType>,
    table: ContactTable,
    /// The particles (read them between steps; the stepper owns their order).
    pub particles: Particles,
    meshes: Vec<WallMesh>,
    mesh_indexes: Vec<MeshIndex>,
    grid: CellGrid,
    curve: CurveOrder,
    pairs: PairList,
    pair_loads: Vec<PairLoad>,
    wall_candidates: WallCandidates,
    wall_contacts: WallContactStore,
    reference_positions: Vec<Vec3>,
    reference_offsets: Vec<Vec3>,
    /// Each wall's displacement (m), velocity (m/s) and presence at `time_s`, set
    /// once per step by `update_walls`.
    mesh_offsets: Vec<Vec3>,
    mesh_velocities: Vec<Vec3>,
    mesh_present: Vec<bool>,
    time_s: Real,
    step: u64,
    sensor_z_m: Option<Real>,
    /// Time from which the sensor records crossings, s.
    sensor_start_s: Real,
    crossed: Vec<bool>,
    crossings: Vec<Crossing>,
    sink_z_m: Option<Real>,
    leaving: Vec<bool>,
    leaving_count: usize,
    removed_mass_kg: Real,
    /// Particles and mass the sink took before the sensor's start: material spilled
    /// while filling (over a hopper's rim), not discharge.
    spilled: (u64, Real),
    /// What each chunk of the last drift found (scratch, kept for its allocation).
    drift_outcomes: Vec<DriftOutcome>,
    particle_steps: u64,
    timers: StageTimers,
    inflows: Vec<InflowState>,
    next_id: u32,
    /// Each particle's wall impact energy of the last force computation, J (scratch).
    impact_energy_j: Vec<Real>,
    wall_impact_energy_j: Real,
    largest_overlap_ratio: Real,
}

/// Why a simulation cannot be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SetupError {
    /// A number that must be positive and finite is not.
    #[error("{what} must be a positive finite number, got {value}")]
    NotPositive {
        /// What the number is.
        what: String,
        /// Its value.
        value: Real,
    },
    /// A particle is larger than the domain.
    #[error("particle type {kind} (radius {radius_m} m) is larger than the domain ({extent_m:.4} m across its smallest side); enlarge the domain or use smaller particles")]
    ParticleLargerThanDomain {
        /// Type index.
        kind: usize,
        /// Its radius, m.
        radius_m: Real,
        /// The domain's smallest extent, m.
        extent_m: Real,
    },
    /// A velocity field was given without air to carry it.
    #[error("an air velocity field needs air (its density and viscosity); add the air or drop the field")]
    AirFieldWithoutAir,
    /// The initial state already overlaps beyond the bound.
    #[error("the initial state: {0}")]
    Initial(#[from] Unstable),
}

impl Simulation {
    /// A simulation of `particles` of `types` among `meshes`.
    pub fn new(
        config: Config,
        types: Vec<ParticleType>,
        particles: Particles,
        meshes: Vec<WallMesh>,
    ) -> Result<Self, SetupError> {
        let positive = |what: &str, value: Real| {
            if value > 0.0 && value.is_finite() {
                Ok(())
            } else {
                Err(SetupError::NotPositive {
                    what: what.to_string(),
                    value,
                })
            }
        };
        positive("the time step (s)", config.timestep_s)?;
        positive("the skin (m)", config.skin_m)?;
        positive("max_speed (m/s)", config.max_speed_m_per_s)?;
        positive("max_overlap_ratio", config.max_overlap_ratio)?;
        if config.air_field.is_some() && config.air.is_none() {
            return Err(SetupError::AirFieldWithoutAir);
        }
        let extent = (config.domain_max_m - config.domain_min_m).min();
        positive("the domain's smallest extent (m)", extent)?;
        for (kind, t) in types.iter().enumerate() {
            positive(&format!("particle type {kind}'s radius (m)"), t.radius_m)?;
            positive(
                &format!("particle type {kind}'s density (kg/m^3)"),
                t.density_kg_m3,
            )?;
            positive(
                &format!("particle type {kind}'s Young's modulus (Pa)"),
                t.material.youngs_modulus_pa,
            )?;
            positive(
                &format!("particle type {kind}'s restitution"),
                t.material.restitution,
            )?;
            if 2.0 * t.radius_m > extent {
                return Err(SetupError::ParticleLargerThanDomain {
                    kind,
                    radius_m: t.radius_m,
                    extent_m: extent,
                });
            }
        }
        // Particles placed by hand may be larger than their type.
        let largest = types
            .iter()
            .map(|t| t.radius_m)
            .chain(particles.radius_m.iter().copied())
            .fold(0.0, Real::max);
        let reach = 2.0 * largest + config.skin_m;
        let grid = CellGrid::new(config.domain_min_m, config.domain_max_m, reach);
        let curve = CurveOrder::new(&grid);
        let mesh_indexes = meshes
            .iter()
            .map(|m| MeshIndex::new(m, largest + config.skin_m))
            .collect();
        let table = ContactTable::new(&types, &config.wall_material);
        let n = particles.len();
        let mut simulation = Self {
            table,
            types,
            mesh_indexes,
            grid,
            curve,
            pairs: PairList::default(),
            pair_loads: Vec::new(),
            wall_candidates: WallCandidates::default(),
            wall_contacts: WallContactStore::default(),
            reference_positions: Vec::new(),
            reference_offsets: vec![Vec3::zeros(); meshes.len()],
            mesh_offsets: Vec::new(),
            mesh_velocities: Vec::new(),
            mesh_present: Vec::new(),
            meshes,
            time_s: 0.0,
            step: 0,
            sensor_z_m: None,
            sensor_start_s: 0.0,
            crossed: vec![false; n],
            crossings: Vec::new(),
            sink_z_m: None,
            leaving: vec![false; n],
            leaving_count: 0,
            removed_mass_kg: 0.0,
            spilled: (0, 0.0),
            drift_outcomes: Vec::new(),
            particle_steps: 0,
            timers: StageTimers::default(),
            inflows: Vec::new(),
            impact_energy_j: Vec::new(),
            wall_impact_energy_j: 0.0,
            largest_overlap_ratio: 0.0,
            next_id: particles.max_id().map_or(1, |id| id + 1),
            particles,
            config,
        };
        simulation.update_walls();
        simulation.rebuild();
        simulation.forces_and_kick(None)?;
        Ok(simulation)
    }

    /// Records particles crossing the horizontal plane `z = z_m` downwards, from
    /// `start_s` (s) on.
    pub fn set_sensor_plane(&mut self, z_m: Real, start_s: Real) {
        self.sensor_z_m = Some(z_m);
        self.sensor_start_s = start_s;
    }

    /// Removes particles whose centre falls below `z = z_m`, counted as discharged
    /// (before a sensor's start, as spilled: [`Simulation::spilled`]).
    pub fn set_sink_plane(&mut self, z_m: Real) {
        self.sink_z_m = Some(z_m);
    }

    /// Feeds `inflow` from now on (its batches are inserted as the run reaches them).
    pub fn add_inflow(&mut self, inflow: Inflow) -> Result<(), InflowError> {
        inflow.validate(&self.types)?;
        self.inflows
            .push(InflowState::new(inflow, self.types.len()));
        Ok(())
    }

    /// The inflows and how much each has inserted.
    pub fn inflows(&self) -> &[InflowState] {
        &self.inflows
    }

    /// Mass the inflows have inserted so far, kg.
    pub fn inserted_mass_kg(&self) -> Real {
        self.inflows.iter().map(InflowState::inserted_mass_kg).sum()
    }

    /// Sum over every particle–wall impact so far (a contact beginning) of the kinetic
    /// energy of its normal approach, `½ m v_n²`, J: divided by a wall's area, a proxy
    /// of its wear.
    pub fn wall_impact_energy_j(&self) -> Real {
        self.wall_impact_energy_j
    }

    /// The deepest overlap of any two particles, or of a particle and a wall, in any
    /// step so far, as a fraction of the smaller radius: how close the run came to the
    /// bound ([`Config::max_overlap_ratio`]) that stops it. Soft spheres in a dense
    /// flow sit at a few per cent; a sphere squeezed between a heavier falling one and
    /// a wall goes much deeper.
    pub fn largest_overlap_ratio(&self) -> Real {
        self.largest_overlap_ratio
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> Real {
        self.time_s
    }

    /// Steps taken.
    pub fn step_count(&self) -> u64 {
        self.step
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The particle types.
    pub fn types(&self) -> &[ParticleType] {
        &self.types
    }

    /// The walls.
    pub fn meshes(&self) -> &[WallMesh] {
        &self.meshes
    }

    /// Particles still in the simulation (not yet past the sink).
    pub fn remaining(&self) -> usize {
        self.particles.len() - self.leaving_count
    }

    /// Mass that has passed the sink since the sensor's start, kg.
    pub fn discharged_mass_kg(&self) -> Real {
        self.removed_mass_kg
    }

    /// Particles and mass (kg) the sink took before the sensor's start: spilled while
    /// filling, not counted as discharged.
    pub fn spilled(&self) -> (u64, Real) {
        self.spilled
    }

    /// Sum over steps of the particles advanced, for throughput figures.
    pub fn particle_steps(&self) -> u64 {
        self.particle_steps
    }

    /// Time spent per stage so far.
    pub fn timers(&self) -> StageTimers {
        self.timers
    }

    /// Takes the crossings recorded since the last call.
    pub fn take_crossings(&mut self) -> Vec<Crossing> {
        std::mem::take(&mut self.crossings)
    }

    /// Number of wall contacts particle index `i` had in the last step (tests use it
    /// to check that a shared edge or vertex is counted once).
    pub fn wall_contact_count(&self, i: usize) -> usize {
        self.wall_contacts.of(i).len()
    }

    /// The wall contacts particle index `i` had in the last step, each with its unit
    /// normal from the wall towards the particle.
    pub fn wall_contacts(&self, i: usize) -> &[WallContact] {
        self.wall_contacts.of(i)
    }

    /// Advances the simulation by one time step.
    pub fn step(&mut self) -> Result<(), Unstable> {
        let dt = self.config.timestep_s;
        let started = Instant::now();
        let moved = self.kick_and_drift(dt);
        self.time_s += dt;
        self.update_walls();
        self.step += 1;
        self.particle_steps += self.particles.len() as u64;
        self.timers.integrate += started.elapsed();

        let inflow_due = self.inflows.iter().any(|f| f.is_due(self.time_s));
        if inflow_due || self.needs_rebuild(moved) {
            let started = Instant::now();
            self.rebuild();
            self.timers.neighbours += started.elapsed();
        }
        self.forces_and_kick(Some(dt))
    }

    /// Half kick and drift of every particle; returns the largest displacement since
    /// the last rebuild, m. Each chunk also finds its particles that crossed the
    /// sensor plane or reached the sink in this drift (rare), and those are recorded
    /// after, in index order, as one sequential scan would: the same crossings and the
    /// same sum of discharged mass, bit for bit, on any number of threads.
    fn kick_and_drift(&mut self, dt: Real) -> Real {
        let half = 0.5 * dt;
        let Particles {
            position_m,
            velocity_m_per_s,
            angular_velocity,
            force_n,
            torque_n_m,
            mass_kg,
            radius_m,
            id,
            kind,
            ..
        } = &mut self.particles;
        let (force_n, torque_n_m, mass_kg, radius_m, id, kind) =
            (&*force_n, &*torque_n_m, &*mass_kg, &*radius_m, &*id, &*kind);
        let reference = &self.reference_positions;
        let (crossed, leaving) = (&self.crossed, &self.leaving);
        let (sensor_z_m, sink_z_m, time) = (self.sensor_z_m, self.sink_z_m, self.time_s);
        let sensor_start_s = self.sensor_start_s;
        position_m
            .par_chunks_mut(CHUNK)
            .zip(velocity_m_per_s.par_chunks_mut(CHUNK))
            .zip(angular_velocity.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, ((xs, vs), ws))| {
                let mut outcome = DriftOutcome::default();
                // The chunk's slices of what the drift reads, zipped: no index checks.
                let chunk = c * CHUNK..c * CHUNK + xs.len();
                let loads = force_n[chunk.clone()]
                    .iter()
                    .zip(&torque_n_m[chunk.clone()]);
                let bodies = mass_kg[chunk.clone()].iter().zip(&radius_m[chunk.clone()]);
                let state = xs.iter_mut().zip(vs).zip(ws);
                let each = state.zip(loads).zip(bodies).zip(&reference[chunk]);
                for (k, (((((x, v), w), (&f, &t)), (&m, &r)), &x0)) in each.enumerate() {
                    let i = c * CHUNK + k;
                    half_kick(v, w, f, t, m, r, half);
                    *x += dt * *v;
                    outcome.moved_squared = outcome.moved_squared.max((*x - x0).norm_squared());
                    // z before the drift is z - dt vz.
                    if let Some(plane) = sensor_z_m {
                        let z_before = x.z - dt * v.z;
                        if x.z <= plane && z_before > plane && !crossed[i] {
                            let fraction = (z_before - plane) / (z_before - x.z);
                            let time_s = time + fraction * dt;
                            // Crossings before the sensor's start are not recorded (nor
                            // marked: the particle may cross again later).
                            if time_s >= sensor_start_s {
                                let at = *x - (1.0 - fraction) * dt * *v;
                                outcome.crossings.push((
                                    i,
                                    Crossing {
                                        time_s,
                                        id: u64::from(id[i]),
                                        particle_type: u32::from(kind[i]) + 1,
                                        radius_m: r,
                                        mass_kg: m,
                                        position_m: [at.x, at.y, at.z],
                                        velocity_m_per_s: [v.x, v.y, v.z],
                                    },
                                ));
                            }
                        }
                    }
                    if sink_z_m.is_some_and(|sink| x.z < sink) && !leaving[i] {
                        outcome.sunk.push(i);
                    }
                }
                outcome
            })
            .collect_into_vec(&mut self.drift_outcomes);
        let recorded = self.crossings.len();
        let mut moved_squared: Real = 0.0;
        for outcome in self.drift_outcomes.drain(..) {
            moved_squared = moved_squared.max(outcome.moved_squared);
            for (i, crossing) in outcome.crossings {
                self.crossed[i] = true;
                self.crossings.push(crossing);
            }
            for i in outcome.sunk {
                self.leaving[i] = true;
                self.leaving_count += 1;
                let mass_kg = self.particles.mass_kg[i];
                if self.sensor_z_m.is_some() && self.time_s < self.sensor_start_s {
                    self.spilled.0 += 1;
                    self.spilled.1 += mass_kg;
                } else {
                    self.removed_mass_kg += mass_kg;
                }
            }
        }
        // A step's crossings in id order, whatever order the particles are in.
        self.crossings[recorded..].sort_unstable_by_key(|c| c.id);
        moved_squared.sqrt()
    }

    /// Where the walls are, how fast they move and which exist at `time_s`: written
    /// over the last step's values, so a step allocates nothing here.
    fn update_walls(&mut self) {
        let t = self.time_s;
        let meshes = &self.meshes;
        self.mesh_offsets.clear();
        self.mesh_offsets
            .extend(meshes.iter().map(|m| m.motion.displacement_m(t)));
        self.mesh_velocities.clear();
        self.mesh_velocities
            .extend(meshes.iter().map(|m| m.motion.velocity_m_per_s(t)));
        self.mesh_present.clear();
        self.mesh_present
            .extend(meshes.iter().map(|m| m.is_present(t)));
    }

    fn needs_rebuild(&self, moved_m: Real) -> bool {
        let wall_moved = self
            .mesh_offsets
            .iter()
            .zip(&self.reference_offsets)
            .map(|(d, d0)| (d - d0).norm())
            .fold(0.0, Real::max);
        moved_m + wall_moved > 0.5 * self.config.skin_m
    }

    /// How much closer a particle and a wall can come before the next rebuild, m.
    ///
    /// A rebuild is due once a particle's displacement plus a wall's exceeds half the
    /// skin, and walls only translate; so a triangle farther than radius plus half the
    /// skin at a rebuild cannot touch the particle before the next one. Listing only
    /// those within that reach (not the full skin, as for pairs, where both ends move)
    /// drops candidates that could never touch, and the forces stay the same, bit for
    /// bit. The 0.1 % over half the skin absorbs rounding in the distances.
    fn wall_margin_m(&self) -> Real {
        0.5 * self.config.skin_m * 1.001
    }

    /// Removes particles past the sink, inserts the inflows' due batches, sorts the
    /// particles along the curve, rebuilds the pair list and wall candidates.
    fn rebuild(&mut self) {
        // The inflows append their particles (ids above every other); the sort below
        // places them, and having no former index they start without history.
        let before = self.particles.len();
        let mut inflows = std::mem::take(&mut self.inflows);
        for inflow in &mut inflows {
            inflow.insert_due(
                self.time_s,
                &self.types,
                &mut self.particles,
                &mut self.next_id,
            );
        }
        self.inflows = inflows;
        let n = self.particles.len();
        self.crossed.resize(n, false);
        self.leaving.resize(n, false);
        // One selection removes, reorders and tells each particle its former index.
        let staying: Vec<u32> = (0..n as u32)
            .filter(|&i| !self.leaving[i as usize])
            .collect();
        let order = self
            .curve
            .sort(&self.grid, &self.particles.position_m, &staying);
        let reorder = Reorder::new(&order, n);
        self.particles.reorder(&reorder);
        reorder.apply(&mut self.crossed);
        self.leaving = vec![false; order.len()];
        self.leaving_count = 0;
        let former: Vec<u32> = order
            .iter()
            .map(|&i| {
                if (i as usize) < before {
                    i
                } else {
                    NEW_PARTICLE
                }
            })
            .collect();
        let touching = self.pairs.in_contact.iter().filter(|&&t| t).count();
        let p = &self.particles;
        self.pairs = PairList::build(
            &self.grid,
            &p.position_m,
            &p.radius_m,
            self.config.skin_m,
            &self.pairs,
            &former,
        );
        // Loads are read only where `in_contact` says this step wrote them.
        self.pair_loads
            .resize(self.pairs.len(), PairLoad::default());
        self.wall_candidates = WallCandidates::build(
            &self.meshes,
            &self.mesh_indexes,
            &self.mesh_offsets,
            &self.mesh_present,
            &p.position_m,
            &p.radius_m,
            self.wall_margin_m(),
        );
        self.wall_contacts =
            WallContactStore::carried(&self.wall_contacts, &self.wall_candidates, &former);
        let p = &self.particles;
        self.reference_positions = p.position_m.clone();
        self.reference_offsets = self.mesh_offsets.clone();
        self.timers.rebuilds += 1;
        self.timers.particles_at_rebuilds += p.len() as u64;
        self.timers.pairs_listed_at_rebuilds += self.pairs.len() as u64;
        self.timers.pairs_touching_at_rebuilds += touching as u64;
    }

    /// The step's forces, then (with `Some(dt)`) its closing half kick, fused into
    /// the gather: each particle is kicked as soon as its force is summed, which no
    /// other particle's gather reads, so the result is that of a separate pass, with
    /// one pass over the particles fewer. A pair overlap past the bound stops before
    /// the gather; a wall overlap or a speed past its bound is reported after it (the
    /// state is then that of a failed step, not to be stepped on).
    fn forces_and_kick(&mut self, kick_dt_s: Option<Real>) -> Result<(), Unstable> {
        let started = Instant::now();
        let worst_pair = self.pair_forces();
        self.timers.pairs += started.elapsed();
        let bound = self.config.max_overlap_ratio;
        if let Some((ratio, i, j)) = worst_pair {
            self.largest_overlap_ratio = self.largest_overlap_ratio.max(ratio);
            if ratio > bound {
                return Err(self.overlap_error(i, Some(j), ratio));
            }
        }
        let started = Instant::now();
        let gathered = self.gather_and_kick(kick_dt_s);
        self.timers.gather_and_walls += started.elapsed();
        if let Some((ratio, i)) = gathered.worst_wall {
            self.largest_overlap_ratio = self.largest_overlap_ratio.max(ratio);
            if ratio > bound {
                return Err(self.overlap_error(i, None, ratio));
            }
        }
        match gathered.first_too_fast {
            None => Ok(()),
            Some(i) => Err(Unstable::Speed {
                step: self.step,
                time_s: self.time_s,
                id: self.particles.id[i],
                speed_m_per_s: self.particles.velocity_m_per_s[i].norm(),
                bound_m_per_s: self.config.max_speed_m_per_s,
                timestep_s: self.config.timestep_s,
            }),
        }
    }

    /// Particle `i` overlapping particle `j` (`None`: a wall) by `ratio` of the
    /// smaller radius, past the bound.
    fn overlap_error(&self, i: usize, j: Option<usize>, ratio: Real) -> Unstable {
        let p = &self.particles;
        let bound = self.config.max_overlap_ratio;
        let kind_i = usize::from(p.kind[i]);
        let (other, constants, radius_m, mass_kg, smaller_radius_m) = match j {
            Some(j) => (
                format!("particle {}", p.id[j]),
                self.table.particles(kind_i, usize::from(p.kind[j])),
                p.radius_m[i] * p.radius_m[j] / (p.radius_m[i] + p.radius_m[j]),
                p.mass_kg[i] * p.mass_kg[j] / (p.mass_kg[i] + p.mass_kg[j]),
                p.radius_m[i].min(p.radius_m[j]),
            ),
            None => (
                "a wall".to_string(),
                self.table.wall(kind_i),
                p.radius_m[i],
                p.mass_kg[i],
                p.radius_m[i],
            ),
        };
        Unstable::Overlap {
            step: self.step,
            time_s: self.time_s,
            id: p.id[i],
            other,
            ratio,
            bound,
            bound_speed_m_per_s: hertz_speed_for_overlap_m_per_s(
                mass_kg,
                radius_m,
                constants.effective_youngs_pa,
                bound * smaller_radius_m,
            ),
            timestep_s: self.config.timestep_s,
        }
    }

    /// Pair forces onto each block's particles, and into per-pair slots for second
    /// members in later blocks; returns the deepest overlap (ratio, i, j).
    fn pair_forces(&mut self) -> Option<(Real, usize, usize)> {
        let n = self.particles.len();
        let rows = &self.pairs.row_start;
        let blocks = n.div_ceil(BLOCK);
        let mut shear_blocks = Vec::with_capacity(blocks);
        let mut load_blocks = Vec::with_capacity(blocks);
        let mut shear_rest: &mut [Vec3] = &mut self.pairs.shear_m;
        let mut contact_rest: &mut [bool] = &mut self.pairs.in_contact;
        let mut load_rest: &mut [PairLoad] = &mut self.pair_loads;
        let Particles {
            position_m,
            velocity_m_per_s,
            angular_velocity,
            radius_m,
            mass_kg,
            kind,
            force_n,
            torque_n_m,
            ..
        } = &mut self.particles;
        let mut force_rest: &mut [Vec3] = force_n;
        let mut torque_rest: &mut [Vec3] = torque_n_m;
        let mut sum_blocks = Vec::with_capacity(blocks);
        for first in (0..n).step_by(BLOCK) {
            let last = (first + BLOCK).min(n);
            let len = (rows[last] - rows[first]) as usize;
            let (shear, rest) = shear_rest.split_at_mut(len);
            shear_rest = rest;
            let (in_contact, rest) = contact_rest.split_at_mut(len);
            contact_rest = rest;
            shear_blocks.push((first, last, shear, in_contact));
            let (loads, rest) = load_rest.split_at_mut(len);
            load_rest = rest;
            load_blocks.push(loads);
            let (forces, rest) = force_rest.split_at_mut(last - first);
            force_rest = rest;
            let (torques, rest) = torque_rest.split_at_mut(last - first);
            torque_rest = rest;
            sum_blocks.push((forces, torques));
        }
        let (position_m, velocity_m_per_s, angular_velocity) =
            (&*position_m, &*velocity_m_per_s, &*angular_velocity);
        let (radius_m, mass_kg, kind) = (&*radius_m, &*mass_kg, &*kind);
        let partner = &self.pairs.partner;
        let table = &self.table;
        let dt = self.config.timestep_s;
        shear_blocks
            .into_par_iter()
            .zip(load_blocks.into_par_iter())
            .zip(sum_blocks.into_par_iter())
            .filter_map(
                |(((first, last, shear, in_contact), loads), (forces, torques))| {
                    let base = rows[first] as usize;
                    let mut worst: Option<Deepest> = None;
                    forces.fill(Vec3::zeros());
                    torques.fill(Vec3::zeros());
                    for i in first..last {
                        let mut force_i = Vec3::zeros();
                        let mut torque_i = Vec3::zeros();
                        let (xi, vi, wi) =
                            (position_m[i], velocity_m_per_s[i], angular_velocity[i]);
                        let (ri, mi, ki) = (radius_m[i], mass_kg[i], kind[i] as usize);
                        let row = rows[i] as usize..rows[i + 1] as usize;
                        // The row's slices of the per-pair state, zipped with its
                        // partners: no index checks on them.
                        let local = row.start - base..row.end - base;
                        let entries = partner[row]
                            .iter()
                            .zip(&mut in_contact[local.clone()])
                            .zip(&mut shear[local.clone()])
                            .zip(&mut loads[local]);
                        for (((&j, touching), history), load) in entries {
                            let j = j as usize;
                            let rj = radius_m[j];
                            let offset = xi - position_m[j];
                            let reach = ri + rj;
                            let distance_squared = offset.norm_squared();
                            if distance_squared >= reach * reach {
                                // Only touching pairs carry a history and a load.
                                if *touching {
                                    *touching = false;
                                    *history = Vec3::zeros();
                                }
                                continue;
                            }
                            let distance = distance_squared.sqrt();
                            let overlap = reach - distance;
                            // Deepest relative to the smaller radius, compared without
                            // a division: a / b > c / d ⇔ a d > c b for b, d > 0.
                            let smaller = ri.min(rj);
                            if worst.is_none_or(|w| overlap * w.smaller_m > w.overlap_m * smaller) {
                                worst = Some(Deepest {
                                    overlap_m: overlap,
                                    smaller_m: smaller,
                                    i,
                                    j,
                                });
                            }
                            if distance == 0.0 {
                                *touching = false;
                                continue;
                            }
                            *touching = true;
                            let n = offset * (1.0 / distance);
                            let mj = mass_kg[j];
                            let wj = angular_velocity[j];
                            let contact_velocity =
                                vi - velocity_m_per_s[j] - (ri * wi + rj * wj).cross(&n);
                            // R* = ri rj / (ri + rj) and m* = mi mj / (mi + mj) from
                            // one division.
                            let mass_sum = mi + mj;
                            let shared = 1.0 / (reach * mass_sum);
                            let geometry = ContactGeometry {
                                normal: n,
                                overlap_m: overlap,
                                effective_radius_m: ri * rj * mass_sum * shared,
                                effective_mass_kg: mi * mj * reach * shared,
                            };
                            let constants = table.particles(ki, kind[j] as usize);
                            let result = hertz_mindlin(
                                constants,
                                &geometry,
                                contact_velocity,
                                wi - wj,
                                history,
                                dt,
                            );
                            let lever = n.cross(&result.tangential);
                            force_i += result.force;
                            torque_i += -ri * lever + result.rolling_torque;
                            let torque_j = -rj * lever - result.rolling_torque;
                            if j < last {
                                // Both members in the block: summed here, in pair order.
                                forces[j - first] -= result.force;
                                torques[j - first] += torque_j;
                            } else {
                                *load = PairLoad {
                                    force_on_first: result.force,
                                    torque_on_second: torque_j,
                                };
                            }
                        }
                        // After the shares of the block's earlier rows, as second member.
                        forces[i - first] += force_i;
                        torques[i - first] += torque_i;
                    }
                    worst.map(|w| (w.overlap_m / w.smaller_m, w.i, w.j))
                },
            )
            .reduce_with(|a, b| if deeper(b.0, b.1, a.0, a.1) { b } else { a })
    }

    /// Per particle: gravity, pair forces, wall contacts, then (with `Some(dt)`) the
    /// half kick `v += dt/2 F/m` with the force just summed. Returns the deepest wall
    /// overlap and the first particle past the speed bound.
    fn gather_and_kick(&mut self, kick_dt_s: Option<Real>) -> Gathered {
        let walls = WallState {
            meshes: &self.meshes,
            offsets_m: &self.mesh_offsets,
            velocities_m_per_s: &self.mesh_velocities,
            present: &self.mesh_present,
            table: &self.table,
            dt_s: self.config.timestep_s,
            cos_coplanar: self.config.coplanar_angle_deg.to_radians().cos(),
        };
        let gravity = self.config.gravity_m_per_s2;
        let air = self.config.air;
        let air_field = self.config.air_field.as_ref();
        let pairs = &self.pairs;
        let loads = &self.pair_loads;
        let candidates = &self.wall_candidates;
        self.impact_energy_j.resize(self.particles.len(), 0.0);
        let bound_squared = self.config.max_speed_m_per_s.powi(2);
        let half = kick_dt_s.map(|dt| 0.5 * dt);
        let p = &mut self.particles;
        let (position, mass, radius, kind) = (&p.position_m, &p.mass_kg, &p.radius_m, &p.kind);
        let gathered = p
            .force_n
            .par_chunks_mut(CHUNK)
            .zip(p.torque_n_m.par_chunks_mut(CHUNK))
            .zip(p.velocity_m_per_s.par_chunks_mut(CHUNK))
            .zip(p.angular_velocity.par_chunks_mut(CHUNK))
            .zip(self.impact_energy_j.par_chunks_mut(CHUNK))
            .zip(self.wall_contacts.chunks_mut(CHUNK))
            .enumerate()
            .map(
                |(c, (((((forces, torques), velocities), spins), impacts), mut lists))| {
                    let mut worst: Option<(Real, usize)> = None;
                    let mut first_too_fast = None;
                    let first = c * CHUNK;
                    for (k, ((((force, torque), velocity), spin), impact)) in forces
                        .iter_mut()
                        .zip(torques)
                        .zip(velocities)
                        .zip(spins)
                        .zip(impacts)
                        .enumerate()
                    {
                        let i = first + k;
                        // The pair pass left this particle's sum over its block's pairs
                        // here; the pairs of earlier blocks come first in its reverse
                        // index (pairs are numbered row by row), up to its block's rows.
                        let mut f = *force;
                        let mut t = *torque;
                        let block_rows = pairs.row_start[i - i % BLOCK];
                        for &k in &pairs.reverse_pair
                            [pairs.reverse_start[i] as usize..pairs.reverse_start[i + 1] as usize]
                        {
                            if k >= block_rows {
                                break;
                            }
                            if pairs.in_contact[k as usize] {
                                let load = &loads[k as usize];
                                f -= load.force_on_first;
                                t += load.torque_on_second;
                            }
                        }
                        let near = candidates.of(i);
                        let wall = if near.is_empty() {
                            WallLoad::default()
                        } else {
                            // Particles with candidates hold the chunk's lists in order.
                            let (contacts, rest) = std::mem::take(&mut lists)
                                .split_first_mut()
                                .expect("one wall contact list per particle with candidates");
                            lists = rest;
                            let particle = ParticleView {
                                position_m: position[i],
                                velocity_m_per_s: *velocity,
                                angular_velocity: *spin,
                                radius_m: radius[i],
                                mass_kg: mass[i],
                                kind: kind[i] as usize,
                            };
                            wall_load(&walls, near, &particle, contacts)
                        };
                        let drag = air.map_or(Vec3::zeros(), |a| {
                            match air_field.and_then(|field| field.velocity_at(position[i])) {
                                Some(wind) => a.drag_in_n(wind, radius[i], *velocity),
                                None => a.drag_n(radius[i], *velocity),
                            }
                        });
                        *force = f + wall.force_n + mass[i] * gravity + drag;
                        *torque = t + wall.torque_n_m;
                        *impact = wall.impact_energy_j;
                        if wall.worst_overlap_ratio > 0.0
                            && worst.is_none_or(|(w, _)| wall.worst_overlap_ratio > w)
                        {
                            worst = Some((wall.worst_overlap_ratio, i));
                        }
                        if let Some(half) = half {
                            half_kick(velocity, spin, *force, *torque, mass[i], radius[i], half);
                            let speed_squared = velocity.norm_squared();
                            if first_too_fast.is_none()
                                && (speed_squared.is_nan() || speed_squared > bound_squared)
                            {
                                first_too_fast = Some(i);
                            }
                        }
                    }
                    Gathered {
                        worst_wall: worst,
                        first_too_fast,
                    }
                },
            )
            .reduce(Gathered::default, Gathered::merge);
        // In index order, whatever the number of threads.
        self.wall_impact_energy_j += self.impact_energy_j.iter().sum::<Real>();
        gathered
    }
}
