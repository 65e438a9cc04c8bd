//! `coupling:`: the staggered DEM ↔ air iteration of a design point.
//!
//! A design job runs the DEM (in still air, or in vacuum); its `cfd` stage computes
//! the air that stream drags along. With `coupling:` the chain goes on: a job of kind
//! [`AIR_STAGE`] runs the design point's DEM again with the CFD stage's air velocity on
//! a grid ([`AIR_FIELD_FILE`], the native kernel's `[air] velocity_field`), a second
//! `cfd` job computes the air of that stream, and so on:
//!
//! ```text
//! p000r0 → p000r0-cfd → p000r0-air1 → p000r0-cfd2 → p000r0-air2 → …
//! ```
//!
//! Each job follows the one before it (`after_job_id`). When a DEM run in air has
//! changed the study's response by less than the tolerance against the DEM run before
//! it, the next `cfd` job is cancelled with why, and the rest of the chain follows it.
//! Fits and reports use the last DEM run and the last CFD run of each chain
//! ([`superseded`]).

use std::collections::{HashMap, HashSet};

use orch_adapters::Case;

use crate::store::{JobLink, JobState, DESIGN_STAGE};

/// The stage kind of a DEM job run in the air of the CFD job before it.
pub const AIR_STAGE: &str = "air";

/// The air velocities a coupled DEM job reads, in its run directory.
pub const AIR_FIELD_FILE: &str = "air-field.csv";

/// Parameters an equipment needs to run in moving air.
pub const AIR_PARAMETERS: &[&str] = &["air_density", "air_viscosity", "air_field"];

/// The air of the CFD stage, as the DEM takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AirProperties {
    /// Density, kg/m³.
    pub density_kg_m3: f64,
    /// Dynamic viscosity, Pa·s (the CFD stage's kinematic viscosity times density).
    pub dynamic_viscosity_pa_s: f64,
}

impl Default for AirProperties {
    /// Air at 20 °C.
    fn default() -> Self {
        AirProperties {
            density_kg_m3: 1.2,
            dynamic_viscosity_pa_s: 1.8e-5,
        }
    }
}

impl AirProperties {
    /// The air of a `cfd` stage case (`air_density` kg/m³, `air_viscosity` m²/s).
    pub fn of_cfd(cfd: &Case) -> AirProperties {
        let density = cfd.get("air_density");
        AirProperties {
            density_kg_m3: density,
            dynamic_viscosity_pa_s: cfd.get("air_viscosity") * density,
        }
    }
}

/// `case` run in the air of [`AIR_FIELD_FILE`]: the CFD stage's density and
/// viscosity, `air_field` on.
pub fn in_moving_air(case: &Case, air: &AirProperties) -> Case {
    let mut moving = case.clone();
    moving.parameters.set("air_density", air.density_kg_m3);
    moving
        .parameters
        .set("air_viscosity", air.dynamic_viscosity_pa_s);
    moving.parameters.set("air_field", 1.0);
    moving
}

/// Names and kinds of the jobs chained after design job `design` and its first `cfd`
/// job (`<design>-cfd`), for `iterations` DEM runs in air, in order.
pub fn chain(design: &str, iterations: u32) -> Vec<(String, &'static str)> {
    let cfd = orch_adapters::openfoam::KIND;
    let mut jobs = Vec::new();
    for k in 1..=iterations {
        jobs.push((format!("{design}-{AIR_STAGE}{k}"), AIR_STAGE));
        if k < iterations {
            jobs.push((format!("{design}-{cfd}{}", k + 1), cfd));
        }
    }
    jobs
}

/// The relative change of a response from `before` to `now` when it is below
/// `tolerance` (the iteration has settled), else `None`.
pub fn settled(before: f64, now: f64, tolerance: f64) -> Option<f64> {
    let change = ((now - before) / before).abs();
    (before != 0.0 && change.is_finite() && change < tolerance).then_some(change)
}

/// True for the jobs that run the DEM: design jobs and [`AIR_STAGE`] jobs.
fn runs_dem(job: &impl JobLink) -> bool {
    job.stage() == DESIGN_STAGE || job.stage() == AIR_STAGE
}

/// Succeeded jobs that a later job of the same chain replaces: a DEM run followed (two
/// jobs on) by a succeeded DEM run in air, and a CFD run followed by a succeeded CFD
/// run. Fits use every other succeeded job.
pub fn superseded<J: JobLink>(jobs: &[J]) -> HashSet<i64> {
    let by_id: HashMap<i64, &J> = jobs.iter().map(|j| (j.id(), j)).collect();
    let before = |job: &J| job.after_job_id().and_then(|id| by_id.get(&id).copied());
    jobs.iter()
        .filter(|j| j.state() == JobState::Succeeded)
        .filter_map(|later| {
            let earlier = before(before(later)?)?;
            let same_kind = if runs_dem(later) {
                runs_dem(earlier)
            } else {
                earlier.stage() == later.stage()
            };
            (same_kind && earlier.state() == JobState::Succeeded).then_some(earlier.id())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::{JobLinkRow, JobRow};

    fn job(id: i64, stage: &str, after: Option<i64>, state: JobState) -> JobRow {
        JobRow {
            id,
            study_id: 1,
            point_id: 1,
            replicate: 0,
            name: format!("job{id}"),
            seed: 1,
            state,
            attempts: 1,
            executor_handle: None,
            run_dir: format!("/runs/job{id}"),
            started_at: None,
            finished_at: None,
            exit_code: None,
            error: None,
            scheduler_state: None,
            stage: stage.to_string(),
            after_job_id: after,
            identity: None,
            reused_from: None,
        }
    }

    fn case(specs: &[orch_adapters::ParameterSpec], values: &[(&str, f64)]) -> Case {
        let mut parameters = orch_adapters::ResolvedParameters::defaults(specs);
        for (name, value) in values {
            parameters.set(name, *value);
        }
        Case {
            parameters,
            seed: 1,
            text: Default::default(),
        }
    }

    #[test]
    fn the_chain_alternates_dem_in_air_and_cfd() {
        assert_eq!(
            chain("p000r0", 3),
            vec![
                ("p000r0-air1".to_string(), "air"),
                ("p000r0-cfd2".to_string(), "cfd"),
                ("p000r0-air2".to_string(), "air"),
                ("p000r0-cfd3".to_string(), "cfd"),
                ("p000r0-air3".to_string(), "air"),
            ]
        );
        assert_eq!(chain("p1", 1), vec![("p1-air1".to_string(), "air")]);
    }

    #[test]
    fn a_change_below_the_tolerance_settles() {
        assert!((settled(0.200, 0.201, 0.01).unwrap() - 0.005).abs() < 1e-12);
        assert_eq!(settled(0.200, 0.210, 0.01), None);
        assert_eq!(settled(0.0, 0.0, 0.01), None);
    }

    #[test]
    fn only_the_last_dem_and_cfd_runs_of_a_chain_count() {
        use JobState::*;
        let jobs = vec![
            job(1, "dem", None, Succeeded),
            job(2, "cfd", Some(1), Succeeded),
            job(3, "air", Some(2), Succeeded),
            job(4, "cfd", Some(3), Succeeded),
            job(5, "air", Some(4), Failed),
            job(6, "cfd", Some(5), Failed),
        ];
        assert_eq!(superseded(&jobs), HashSet::from([1, 2]));
        // Without coupling nothing is superseded.
        assert!(superseded(&jobs[..2]).is_empty());
        // The lean rows an analysis reads say the same.
        let lean: Vec<JobLinkRow> = jobs
            .iter()
            .map(|j| JobLinkRow {
                id: j.id,
                point_id: j.point_id,
                name: j.name.as_str().into(),
                state: j.state,
                stage: j.stage.as_str().into(),
                after_job_id: j.after_job_id,
                identity: None,
            })
            .collect();
        assert_eq!(superseded(&lean), HashSet::from([1, 2]));
    }

    #[test]
    fn the_dem_in_air_takes_the_cfd_stage_s_air() {
        let cfd = case(
            orch_adapters::openfoam::PARAMETERS,
            &[("air_density", 1.2), ("air_viscosity", 1.5e-5)],
        );
        let air = AirProperties::of_cfd(&cfd);
        assert_eq!(air.density_kg_m3, 1.2);
        assert!((air.dynamic_viscosity_pa_s - 1.8e-5).abs() < 1e-20);
        let still = case(orch_adapters::hopper::PARAMETERS, &[]);
        assert_eq!(still.get("air_field"), 0.0);
        let moving = in_moving_air(&still, &air);
        assert_eq!(moving.get("air_field"), 1.0);
        assert_eq!(moving.get("air_density"), 1.2);
    }
}
