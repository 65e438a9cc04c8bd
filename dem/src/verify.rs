//! Verification benchmarks: a case file with a `[verify]` table names quantities to
//! measure on particle 1 (the first `[[particles]]` entry) and the reference value of
//! each, with a relative tolerance and the source of the reference. [`run`] steps the
//! case and measures them; `orch-dem verify` does so for every file of
//! `dem/verification/` and prints one table.
//!
//! ```toml
//! [verify]
//! description = "normal impact on a wall at 1 m/s, e = 0.5"
//! source = "the input restitution (docs/method.md, contact model)"
//!
//! [[verify.check]]
//! quantity = "restitution"
//! reference = 0.5
//! tolerance = 0.01
//! ```
//!
//! Impact quantities (`restitution`, `contact_duration`, `tangential_speed_loss`,
//! `rebound_spin`, `rebound_velocity`, `rebound_angular_velocity`, `max_overlap`,
//! `max_normal_force`) follow particle 1's first
//! contact, with a fixed wall or another particle, from the step it begins to the step
//! it ends; its normal is the wall's (towards the particle) or the line of centres at
//! the first step of contact. The overlap with a particle is `r1 + r2 − d`; with a wall,
//! particle 1's travel along the normal since the first step of contact (the overlap
//! at that step, under one step's travel, is not counted). The normal force is particle
//! 1's mass times its change of normal velocity over a step, over the step: measured
//! from the motion, not from the contact law. `rebound_velocity` and
//! `rebound_angular_velocity` are signed: particle 1's own velocity along `direction`
//! and spin about `spin_axis` at the first step out of contact, so that a reversal
//! (the contact point of a sticking sphere springs back) shows as a change of sign.
//! Window quantities (`acceleration`, `rolling_ratio`) compare particle 1's state at
//! the first steps at or after the two times of `window`.

use serde::Deserialize;

use crate::math::{Real, Vec3};
use crate::simulation::{Simulation, Unstable};

/// `[verify]`: what a verification case checks and where its references come from.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Verify {
    /// What the case is, in one line.
    pub description: String,
    /// Where the references come from (a formula and its book or paper).
    pub source: String,
    /// The quantities measured (`[[verify.check]]`).
    pub check: Vec<Check>,
}

/// `[[verify.check]]`: one quantity, its reference and its tolerance.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Check {
    /// What is measured.
    pub quantity: Quantity,
    /// The expected value, in the quantity's SI unit ([`Quantity::unit`]).
    pub reference: Real,
    /// Largest relative error `|measured − reference| / |reference|` that passes.
    pub tolerance: Real,
    /// Start and end time of the measurement, s (window quantities only).
    pub window: Option<[Real; 2]>,
    /// Direction along which velocity is measured (window quantities and
    /// `rebound_velocity`; normalised).
    pub direction: Option<[Real; 3]>,
    /// Axis about which spin is measured (`rolling_ratio` and
    /// `rebound_angular_velocity`; normalised).
    pub spin_axis: Option<[Real; 3]>,
}

/// A quantity measured on particle 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Normal rebound speed over normal approach speed of the first impact (relative
    /// to the other particle, if any); dimensionless.
    Restitution,
    /// Duration of the first impact, s.
    ContactDuration,
    /// Tangential (relative) centre speed before the first impact minus after, m/s.
    TangentialSpeedLoss,
    /// Angular speed after the first impact, rad/s.
    ReboundSpin,
    /// Mean acceleration along `direction` over `window`, m/s².
    Acceleration,
    /// `r Δω·spin_axis / Δv·direction` over `window`: 1 for rolling without slip,
    /// below 1 when the contact slides; dimensionless.
    RollingRatio,
    /// Largest overlap during the first impact, m.
    MaxOverlap,
    /// Largest normal force on particle 1 during the first impact, N.
    MaxNormalForce,
    /// Particle 1's velocity along `direction` after the first impact (signed), m/s.
    ReboundVelocity,
    /// Particle 1's angular velocity about `spin_axis` after the first impact
    /// (signed), rad/s.
    ReboundAngularVelocity,
}

impl Quantity {
    /// The name used in case files and tables.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Restitution => "restitution",
            Quantity::ContactDuration => "contact_duration",
            Quantity::TangentialSpeedLoss => "tangential_speed_loss",
            Quantity::ReboundSpin => "rebound_spin",
            Quantity::Acceleration => "acceleration",
            Quantity::RollingRatio => "rolling_ratio",
            Quantity::MaxOverlap => "max_overlap",
            Quantity::MaxNormalForce => "max_normal_force",
            Quantity::ReboundVelocity => "rebound_velocity",
            Quantity::ReboundAngularVelocity => "rebound_angular_velocity",
        }
    }

    /// The SI unit of the quantity ("-" when dimensionless).
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::Restitution | Quantity::RollingRatio => "-",
            Quantity::ContactDuration => "s",
            Quantity::TangentialSpeedLoss | Quantity::ReboundVelocity => "m/s",
            Quantity::ReboundSpin | Quantity::ReboundAngularVelocity => "rad/s",
            Quantity::Acceleration => "m/s^2",
            Quantity::MaxOverlap => "m",
            Quantity::MaxNormalForce => "N",
        }
    }

    fn uses_window(self) -> bool {
        matches!(self, Quantity::Acceleration | Quantity::RollingRatio)
    }

    /// Whether the quantity is measured along a `direction`.
    fn uses_direction(self) -> bool {
        self.uses_window() || self == Quantity::ReboundVelocity
    }

    /// Whether the quantity is measured about a `spin_axis`.
    fn uses_spin_axis(self) -> bool {
        matches!(
            self,
            Quantity::RollingRatio | Quantity::ReboundAngularVelocity
        )
    }
}

/// A `[verify]` table that cannot be measured as written: the field and what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{field}`: {message}")]
pub struct VerifyTableError {
    /// Key path, e.g. `verify.check[1].window`.
    pub field: String,
    /// What was expected.
    pub message: String,
}

impl Verify {
    /// Checks the table against a run of `end_time_s` seconds with `n_particles`
    /// explicit particles.
    pub fn validate(&self, end_time_s: Real, n_particles: usize) -> Result<(), VerifyTableError> {
        let error = |field: String, message: String| VerifyTableError { field, message };
        if n_particles == 0 {
            return Err(error(
                "verify".into(),
                "a verification case measures particle 1: place it with [[particles]]".into(),
            ));
        }
        if self.check.is_empty() {
            return Err(error(
                "verify.check".into(),
                "expected at least one [[verify.check]] entry".into(),
            ));
        }
        for (k, c) in self.check.iter().enumerate() {
            let field = |name: &str| format!("verify.check[{k}].{name}");
            if !(c.reference.is_finite() && c.reference != 0.0) {
                return Err(error(
                    field("reference"),
                    format!(
                        "expected a finite, non-zero value (errors are relative to it), got {}",
                        c.reference
                    ),
                ));
            }
            if !(c.tolerance.is_finite() && c.tolerance > 0.0) {
                return Err(error(
                    field("tolerance"),
                    format!(
                        "expected a positive relative tolerance, got {}",
                        c.tolerance
                    ),
                ));
            }
            let name = c.quantity.name();
            let q = c.quantity;
            for (key, given, wanted) in [
                ("window", c.window.is_some(), q.uses_window()),
                ("direction", c.direction.is_some(), q.uses_direction()),
                ("spin_axis", c.spin_axis.is_some(), q.uses_spin_axis()),
            ] {
                if given && !wanted {
                    let what = if q.uses_window() {
                        "is measured over its window"
                    } else {
                        "is measured over the first impact"
                    };
                    return Err(error(
                        field(key),
                        format!("`{name}` {what} and takes no {key}; remove it"),
                    ));
                }
            }
            if q.uses_window() {
                let Some([from, to]) = c.window else {
                    return Err(error(
                        field("window"),
                        format!("`{name}` needs window = [start, end] in s"),
                    ));
                };
                if !(from.is_finite()
                    && to.is_finite()
                    && 0.0 <= from
                    && from < to
                    && to <= end_time_s)
                {
                    return Err(error(
                        field("window"),
                        format!("expected 0 ≤ start < end ≤ run.end_time ({end_time_s} s), got [{from}, {to}]"),
                    ));
                }
            }
            if q.uses_direction() {
                unit_vector(&field("direction"), c.direction, name)
                    .map_err(|m| error(field("direction"), m))?;
            }
            if q.uses_spin_axis() {
                unit_vector(&field("spin_axis"), c.spin_axis, name)
                    .map_err(|m| error(field("spin_axis"), m))?;
            }
        }
        Ok(())
    }
}

fn unit_vector(field: &str, v: Option<[Real; 3]>, name: &str) -> Result<Vec3, String> {
    let Some(v) = v else {
        return Err(format!("`{name}` needs {field} = [x, y, z]"));
    };
    let v = Vec3::from(v);
    let norm = v.norm();
    if norm.is_finite() && norm > 0.0 {
        Ok(v / norm)
    } else {
        Err(format!("expected a non-zero finite vector, got {v:?}"))
    }
}

/// One measured check.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The check.
    pub quantity: Quantity,
    /// The measured value (`None` when the run never produced it, see `note`).
    pub measured: Option<Real>,
    /// The reference.
    pub reference: Real,
    /// The relative tolerance.
    pub tolerance: Real,
    /// Why nothing was measured, when so.
    pub note: Option<String>,
}

impl Outcome {
    /// `|measured − reference| / |reference|`, if measured.
    pub fn relative_error(&self) -> Option<Real> {
        self.measured
            .map(|m| (m - self.reference).abs() / self.reference.abs())
    }

    /// Whether the measurement is within the tolerance.
    pub fn passed(&self) -> bool {
        self.relative_error().is_some_and(|e| e <= self.tolerance)
    }
}

/// Particle 1's state at one step.
#[derive(Debug, Clone, Copy)]
struct State {
    time_s: Real,
    velocity_m_per_s: Vec3,
    spin: Vec3,
}

/// The first impact of particle 1, as it unfolds.
#[derive(Debug, Clone, Copy)]
enum Impact {
    /// Not yet touching.
    Approaching,
    /// Touching since `start_s` along `normal` (towards particle 1).
    Touching {
        start_s: Real,
        normal: Vec3,
        partner: Option<u32>,
        approach_m_per_s: Vec3,
        /// Particle 1's position at the first step of contact, m.
        start_position_m: Vec3,
        peaks: Peaks,
    },
    /// Over.
    Done {
        duration_s: Real,
        normal: Vec3,
        approach_m_per_s: Vec3,
        rebound_m_per_s: Vec3,
        /// Particle 1's own velocity at the first step out of contact, m/s.
        velocity_after_m_per_s: Vec3,
        spin_after: Vec3,
        peaks: Peaks,
    },
}

/// The largest overlap and normal force of an impact so far.
#[derive(Debug, Clone, Copy, Default)]
struct Peaks {
    overlap_m: Real,
    normal_force_n: Real,
}

/// The id of the particle a verification case measures: the first `[[particles]]`
/// entry.
const MEASURED_ID: u32 = 1;

/// Where particle 1 is in the stepper's order (which it may change at a rebuild).
fn measured(simulation: &Simulation) -> usize {
    simulation
        .particles
        .index_of(MEASURED_ID)
        .expect("a verification case keeps particle 1")
}

/// What particle 1 touches now: the unit normal towards it and the other particle's
/// id, or `None` when it touches nothing. A wall comes before a particle.
fn touching(simulation: &Simulation) -> Option<(Vec3, Option<u32>)> {
    let i = measured(simulation);
    if let Some(contact) = simulation.wall_contacts(i).first() {
        return Some((contact.normal, None));
    }
    let p = &simulation.particles;
    (0..p.len()).filter(|&j| j != i).find_map(|j| {
        let offset = p.position_m[i] - p.position_m[j];
        let distance = offset.norm();
        (distance < p.radius_m[i] + p.radius_m[j] && distance > 0.0)
            .then(|| (offset / distance, Some(p.id[j])))
    })
}

/// Particle 1's overlap now with `partner` (`r1 + r2 − d`), or with a wall (its travel
/// along `normal` since it was at `start_position_m`), m.
fn overlap_m(
    simulation: &Simulation,
    partner: Option<u32>,
    normal: Vec3,
    start_position_m: Vec3,
) -> Real {
    let p = &simulation.particles;
    let i = measured(simulation);
    match partner.and_then(|id| p.index_of(id)) {
        Some(j) => p.radius_m[i] + p.radius_m[j] - (p.position_m[i] - p.position_m[j]).norm(),
        None => (start_position_m - p.position_m[i]).dot(&normal),
    }
}

/// Particle 1's velocity relative to `partner` (a fixed wall when `None`), m/s, from
/// the ids and velocities of every particle.
fn relative_velocity(ids: &[u32], velocities_m_per_s: &[Vec3], partner: Option<u32>) -> Vec3 {
    let velocity_of = |id: u32| {
        ids.iter()
            .position(|&other| other == id)
            .map(|j| velocities_m_per_s[j])
    };
    let other = partner.and_then(velocity_of).unwrap_or_else(Vec3::zeros);
    velocity_of(MEASURED_ID).expect("a verification case keeps particle 1") - other
}

/// Why a verification run stopped before measuring.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VerifyError {
    /// The case has no `[verify]` table.
    #[error("the case has no [verify] table; add one naming the quantities to check, or run it with `orch-dem run`")]
    NoTable,
    /// The table cannot be measured.
    #[error(transparent)]
    Table(#[from] VerifyTableError),
    /// The run went unstable.
    #[error(transparent)]
    Unstable(#[from] Unstable),
}

/// Steps `simulation` for up to `end_time_s` (stopping once every check is measured)
/// and measures the checks of `verify` on particle 1.
pub fn run(
    simulation: &mut Simulation,
    verify: &Verify,
    end_time_s: Real,
) -> Result<Vec<Outcome>, VerifyError> {
    // Particle 1 must be there to be measured: its presence counts, not the rest.
    let measurable = usize::from(simulation.particles.index_of(MEASURED_ID).is_some());
    verify.validate(end_time_s, measurable)?;
    let dt = simulation.config().timestep_s;
    let steps = (end_time_s / dt).round() as u64;
    let wants_impact = verify.check.iter().any(|c| !c.quantity.uses_window());
    let last_window_s = verify
        .check
        .iter()
        .filter_map(|c| c.window.map(|w| w[1]))
        .fold(Real::NEG_INFINITY, Real::max);
    // The first states at or after each window bound, by check.
    let mut windows: Vec<[Option<State>; 2]> = vec![[None, None]; verify.check.len()];
    let mut impact = Impact::Approaching;
    // Particle 1's state at the previous step (its change gives the contact force).
    let mut before = State {
        time_s: simulation.time_s(),
        velocity_m_per_s: simulation.particles.velocity_m_per_s[measured(simulation)],
        spin: simulation.particles.angular_velocity[measured(simulation)],
    };
    // Every particle's id and velocity at the previous step: an impact's approach
    // velocity is the one of the step before the contact began.
    let mut previous: (Vec<u32>, Vec<Vec3>) = (Vec::new(), Vec::new());
    for step in 0..=steps {
        if step > 0 {
            simulation.step()?;
        }
        let p = &simulation.particles;
        let i = measured(simulation);
        let state = State {
            time_s: simulation.time_s(),
            velocity_m_per_s: p.velocity_m_per_s[i],
            spin: p.angular_velocity[i],
        };
        for (check, recorded) in verify.check.iter().zip(&mut windows) {
            if let Some(window) = check.window {
                for (slot, at) in recorded.iter_mut().zip(window) {
                    if slot.is_none() && state.time_s >= at - 0.5 * dt {
                        *slot = Some(state);
                    }
                }
            }
        }
        impact = match (impact, touching(simulation)) {
            (Impact::Approaching, Some((normal, partner))) => Impact::Touching {
                start_s: state.time_s,
                normal,
                partner,
                approach_m_per_s: if step == 0 {
                    relative_velocity(&p.id, &p.velocity_m_per_s, partner)
                } else {
                    relative_velocity(&previous.0, &previous.1, partner)
                },
                start_position_m: p.position_m[i],
                peaks: Peaks::default(),
            },
            (
                Impact::Touching {
                    start_s,
                    normal,
                    partner,
                    approach_m_per_s,
                    start_position_m,
                    peaks,
                },
                now,
            ) => {
                let peaks = Peaks {
                    overlap_m: peaks.overlap_m.max(overlap_m(
                        simulation,
                        partner,
                        normal,
                        start_position_m,
                    )),
                    normal_force_n: peaks.normal_force_n.max(
                        p.mass_kg[i]
                            * (state.velocity_m_per_s - before.velocity_m_per_s).dot(&normal)
                            / dt,
                    ),
                };
                match now {
                    Some(_) => Impact::Touching {
                        start_s,
                        normal,
                        partner,
                        approach_m_per_s,
                        start_position_m,
                        peaks,
                    },
                    None => Impact::Done {
                        duration_s: state.time_s - start_s,
                        normal,
                        approach_m_per_s,
                        rebound_m_per_s: relative_velocity(&p.id, &p.velocity_m_per_s, partner),
                        velocity_after_m_per_s: state.velocity_m_per_s,
                        spin_after: state.spin,
                        peaks,
                    },
                }
            }
            (impact, _) => impact,
        };
        before = state;
        if wants_impact && matches!(impact, Impact::Approaching) {
            previous.0.clone_from(&p.id);
            previous.1.clone_from(&p.velocity_m_per_s);
        }
        let impact_over = !wants_impact || matches!(impact, Impact::Done { .. });
        if impact_over && state.time_s >= last_window_s - 0.5 * dt {
            break;
        }
    }
    Ok(verify
        .check
        .iter()
        .zip(&windows)
        .map(|(check, recorded)| measure(check, recorded, &impact, simulation))
        .collect())
}

fn measure(
    check: &Check,
    recorded: &[Option<State>; 2],
    impact: &Impact,
    simulation: &Simulation,
) -> Outcome {
    let measured = if check.quantity.uses_window() {
        match recorded {
            [Some(a), Some(b)] => Ok(window_value(check, a, b, simulation)),
            _ => Err("the run ended before the window; lengthen run.end_time".to_string()),
        }
    } else {
        match *impact {
            Impact::Done {
                duration_s,
                normal,
                approach_m_per_s,
                rebound_m_per_s,
                velocity_after_m_per_s,
                spin_after,
                peaks,
            } => {
                let tangential = |v: Vec3| (v - v.dot(&normal) * normal).norm();
                Ok(match check.quantity {
                    Quantity::Restitution => rebound_m_per_s.dot(&normal) / -approach_m_per_s.dot(&normal),
                    Quantity::ContactDuration => duration_s,
                    Quantity::MaxOverlap => peaks.overlap_m,
                    Quantity::MaxNormalForce => peaks.normal_force_n,
                    Quantity::TangentialSpeedLoss => {
                        tangential(approach_m_per_s) - tangential(rebound_m_per_s)
                    }
                    Quantity::ReboundVelocity => velocity_after_m_per_s.dot(&unit(check.direction)),
                    Quantity::ReboundAngularVelocity => {
                        spin_after.dot(&unit(check.spin_axis))
                    }
                    _ => spin_after.norm(),
                })
            }
            Impact::Touching { .. } => Err(
                "particle 1 was still in contact at the end; lengthen run.end_time".to_string(),
            ),
            Impact::Approaching => Err(
                "particle 1 never touched a wall or another particle; aim it at one or lengthen run.end_time"
                    .to_string(),
            ),
        }
    };
    let (measured, note) = match measured {
        Ok(value) => (Some(value), None),
        Err(note) => (None, Some(note)),
    };
    Outcome {
        quantity: check.quantity,
        measured,
        reference: check.reference,
        tolerance: check.tolerance,
        note,
    }
}

/// A validated `direction` or `spin_axis`, normalised.
fn unit(v: Option<[Real; 3]>) -> Vec3 {
    let v = Vec3::from(v.unwrap_or([1.0, 0.0, 0.0]));
    v / v.norm()
}

/// A window quantity from the states at its two ends (the table was validated).
fn window_value(check: &Check, a: &State, b: &State, simulation: &Simulation) -> Real {
    let direction = unit(check.direction);
    let dv = (b.velocity_m_per_s - a.velocity_m_per_s).dot(&direction);
    match check.quantity {
        Quantity::Acceleration => dv / (b.time_s - a.time_s),
        _ => {
            let dw = (b.spin - a.spin).dot(&unit(check.spin_axis));
            simulation.particles.radius_m[measured(simulation)] * dw / dv
        }
    }
}
