//! A simulation's state between two steps, saved and taken up again: what a restart
//! file holds. A run resumed from it continues bit for bit as if it had never stopped,
//! because everything a step reads that its case does not give is in it: the particles
//! in their current order with the last step's forces, the pair list with each pair's
//! tangential history, the wall candidates and contacts, where the particles and walls
//! stood at the last rebuild, the sensor's and sink's marks, and each inflow's random
//! stream. What the case gives (materials, walls, their motion, the grid) is built
//! from the case again; the caller makes sure it is the same case.

use serde::{Deserialize, Serialize};

use super::{Simulation, StageTimers};
use crate::inflow::InflowProgress;
use crate::math::{Real, Vec3};
use crate::neighbour::{rows_fit, PairList};
use crate::particles::Particles;
use crate::walls::{WallCandidates, WallContactStore};

/// Everything a [`Simulation`] holds between steps that its case does not: see the
/// module's documentation. Made by [`Simulation::saved_state`], taken up by
/// [`Simulation::restore`].
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SavedState {
    particles: Particles,
    pairs: PairList,
    wall_candidates: WallCandidates,
    wall_contacts: WallContactStore,
    reference_positions: Vec<Vec3>,
    reference_offsets: Vec<Vec3>,
    time_s: Real,
    step: u64,
    crossed: Vec<bool>,
    leaving: Vec<bool>,
    leaving_count: usize,
    removed_mass_kg: Real,
    spilled: (u64, Real),
    particle_steps: u64,
    inflows: Vec<InflowProgress>,
    next_id: u32,
    wall_impact_energy_j: Real,
    largest_overlap_ratio: Real,
}

impl SavedState {
    /// Simulated time at which the state was saved, s.
    pub fn time_s(&self) -> Real {
        self.time_s
    }

    /// Steps taken when the state was saved.
    pub fn step_count(&self) -> u64 {
        self.step
    }
}

/// Why a saved state cannot be taken up by a simulation: it was saved from a
/// simulation of another shape (another number of meshes, inflows or particle types),
/// or its parts disagree on the number of particles.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the saved state does not fit this simulation: {0}; it was saved from another case, or is damaged")]
pub struct RestoreError(String);

impl Simulation {
    /// The state between steps, to continue from with [`Simulation::restore`].
    /// Crossings not yet taken ([`Simulation::take_crossings`]) are not part of it:
    /// take them first.
    pub fn saved_state(&self) -> SavedState {
        SavedState {
            particles: self.particles.clone(),
            pairs: self.pairs.clone(),
            wall_candidates: self.wall_candidates.clone(),
            wall_contacts: self.wall_contacts.clone(),
            reference_positions: self.reference_positions.clone(),
            reference_offsets: self.reference_offsets.clone(),
            time_s: self.time_s,
            step: self.step,
            crossed: self.crossed.clone(),
            leaving: self.leaving.clone(),
            leaving_count: self.leaving_count,
            removed_mass_kg: self.removed_mass_kg,
            spilled: self.spilled,
            particle_steps: self.particle_steps,
            inflows: self.inflows.iter().map(|f| f.progress()).collect(),
            next_id: self.next_id,
            wall_impact_energy_j: self.wall_impact_energy_j,
            largest_overlap_ratio: self.largest_overlap_ratio,
        }
    }

    /// Continues from `state`, saved from a simulation of the same case (the caller
    /// checks that: materials, walls, inflows and settings come from this simulation,
    /// not from `state`). The stage timers start again from zero. A state that cannot
    /// belong to a simulation of this shape is refused and nothing changes.
    pub fn restore(&mut self, state: SavedState) -> Result<(), RestoreError> {
        self.check_fits(&state)?;
        let mut inflows = self.inflows.clone();
        for (inflow, progress) in inflows.iter_mut().zip(state.inflows) {
            if !inflow.resume(progress) {
                return Err(RestoreError(
                    "an inflow counts another number of particle types".into(),
                ));
            }
        }
        self.inflows = inflows;
        self.particles = state.particles;
        self.pairs = state.pairs;
        self.pair_loads.clear();
        self.pair_loads
            .resize(self.pairs.len(), super::PairLoad::default());
        self.wall_candidates = state.wall_candidates;
        self.wall_contacts = state.wall_contacts;
        self.reference_positions = state.reference_positions;
        self.reference_offsets = state.reference_offsets;
        self.time_s = state.time_s;
        self.step = state.step;
        self.crossed = state.crossed;
        self.crossings.clear();
        self.leaving = state.leaving;
        self.leaving_count = state.leaving_count;
        self.removed_mass_kg = state.removed_mass_kg;
        self.spilled = state.spilled;
        self.particle_steps = state.particle_steps;
        self.next_id = state.next_id;
        self.wall_impact_energy_j = state.wall_impact_energy_j;
        self.largest_overlap_ratio = state.largest_overlap_ratio;
        self.timers = StageTimers::default();
        self.update_walls();
        Ok(())
    }

    /// Whether `state`'s parts agree with each other and with this simulation's
    /// meshes, inflows and types, so that stepping on from it cannot index out of
    /// bounds.
    fn check_fits(&self, state: &SavedState) -> Result<(), RestoreError> {
        let n = state.particles.len();
        let p = &state.particles;
        let per_particle = [
            ("particle kinds", p.kind.len()),
            ("radii", p.radius_m.len()),
            ("masses", p.mass_kg.len()),
            ("positions", p.position_m.len()),
            ("velocities", p.velocity_m_per_s.len()),
            ("angular velocities", p.angular_velocity.len()),
            ("forces", p.force_n.len()),
            ("torques", p.torque_n_m.len()),
            (
                "positions at the last rebuild",
                state.reference_positions.len(),
            ),
            ("sensor marks", state.crossed.len()),
            ("sink marks", state.leaving.len()),
            (
                "pair list rows",
                state.pairs.row_start.len().saturating_sub(1),
            ),
            (
                "pair list reverse rows",
                state.pairs.reverse_start.len().saturating_sub(1),
            ),
            (
                "well-formed wall candidate rows",
                state
                    .wall_candidates
                    .rows_for(&self.meshes)
                    .unwrap_or(usize::MAX),
            ),
        ];
        if let Some((what, len)) = per_particle.iter().find(|(_, len)| *len != n) {
            return Err(RestoreError(format!("{n} particles but {len} {what}")));
        }
        if !state
            .wall_contacts
            .fits(&state.wall_candidates, self.meshes.len())
        {
            return Err(RestoreError(
                "its wall contacts do not match its wall candidates".into(),
            ));
        }
        let pairs = &state.pairs;
        let count = pairs.partner.len();
        if pairs.shear_m.len() != count
            || pairs.in_contact.len() != count
            || pairs.reverse_pair.len() != count
            || !rows_fit(&pairs.row_start, count)
            || !rows_fit(&pairs.reverse_start, count)
            || pairs.partner.iter().any(|&j| j as usize >= n)
            || pairs.reverse_pair.iter().any(|&k| k as usize >= count)
        {
            return Err(RestoreError("its pair list is inconsistent".into()));
        }
        if p.kind.iter().any(|&k| usize::from(k) >= self.types.len()) {
            return Err(RestoreError(format!(
                "a particle of a type beyond this case's {}",
                self.types.len()
            )));
        }
        if state.reference_offsets.len() != self.meshes.len() {
            return Err(RestoreError(format!(
                "{} meshes saved, {} in this case",
                state.reference_offsets.len(),
                self.meshes.len()
            )));
        }
        if state.inflows.len() != self.inflows.len() {
            return Err(RestoreError(format!(
                "{} inflows saved, {} in this case",
                state.inflows.len(),
                self.inflows.len()
            )));
        }
        if !state.time_s.is_finite() {
            return Err(RestoreError(format!("its time is {}", state.time_s)));
        }
        Ok(())
    }
}
