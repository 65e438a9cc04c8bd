//! `coupling:`: the staggered DEM ↔ air iteration of a design point, and which runs of
//! its chain count.
//!
//! A design job runs the DEM (in still air, or in vacuum); its `cfd` stage computes
//! the air that stream drags along. With `coupling:` the chain goes on
//! ([`crate::plan`] names it): a job of the stage `air`
//! ([`orch_adapters::dem_in_air`]) runs the design point's DEM again in the air of the
//! `cfd` job before it, a second `cfd` job computes the air of that stream, and so on:
//!
//! ```text
//! p000r0 → p000r0-cfd → p000r0-air1 → p000r0-cfd2 → p000r0-air2 → …
//! ```
//!
//! Each job follows the one before it (`after_job_id`). When a DEM run in air has
//! changed the study's response by less than the tolerance against the DEM run before
//! it ([`crate::decide::coupling_settled`]), the next `cfd` job is cancelled with why,
//! and the rest of the chain follows it. Fits and reports use the last DEM run and the
//! last CFD run of each chain ([`superseded`]).

use std::collections::{HashMap, HashSet};

use crate::store::{JobKind, JobLink, JobState};

/// True for the jobs that run the DEM: design jobs and jobs of a stage that runs the
/// design again.
fn runs_dem(job: &impl JobLink) -> bool {
    match job.kind() {
        JobKind::Design => true,
        JobKind::Stage(kind) => {
            orch_adapters::stage_for(kind).is_some_and(|stage| stage.reruns_design())
        }
    }
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
                earlier.kind() == later.kind()
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
            kind: JobKind::parse(stage).unwrap(),
            after_job_id: after,
            identity: None,
            reused_from: None,
        }
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
                kind: j.kind,
                after_job_id: j.after_job_id,
                identity: None,
            })
            .collect();
        assert_eq!(superseded(&lean), HashSet::from([1, 2]));
    }
}
