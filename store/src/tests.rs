use std::path::Path;

use super::*;
use orch_study::Study;

const STUDY: &str = "\
name: small
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028}
  - {name: amplitude, min: 0.0, max: 0.0008}
design: {type: central_composite, alpha: face_centred}
replicates: 2
";

async fn store_with_study() -> (tempfile::TempDir, Store, i64) {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path()).await.unwrap();
    let study = Study::from_text(Path::new("small.yaml"), STUDY, None).unwrap();
    let id = store
        .insert_study(&study, Path::new("small.yaml"), &dir.path().join("runs"))
        .await
        .unwrap();
    (dir, store, id)
}

#[tokio::test]
async fn a_study_is_recorded_with_points_and_jobs() {
    let (dir, store, id) = store_with_study().await;
    let jobs = store.jobs(id).await.unwrap();
    assert_eq!(jobs.len(), 18);
    assert!(jobs.iter().all(|j| j.state() == JobState::Pending));
    assert_eq!(jobs[1].name, "p000r1");
    assert_eq!(
        Path::new(&jobs[1].run_dir),
        dir.path().join("runs/small/p000r1")
    );
    let points = store.points(id).await.unwrap();
    assert_eq!(points.len(), 9);
    assert_eq!(points[0].coded, vec![-1.0, -1.0]);
    assert!((points[0].natural[0] - 0.020).abs() < 1e-15);
    let row = store.study_by_name("small").await.unwrap().unwrap();
    assert_eq!(row.file_text, STUDY);
    assert_eq!(row.state(), StudyState::Active);
    // The same name cannot be recorded twice.
    let study = Study::from_text(Path::new("small.yaml"), STUDY, None).unwrap();
    assert!(store
        .insert_study(&study, Path::new("small.yaml"), dir.path())
        .await
        .is_err());
    assert_eq!(store.jobs(id).await.unwrap().len(), 18);
}

#[tokio::test]
async fn a_job_moves_through_its_states_and_keeps_its_results() {
    let (_dir, store, id) = store_with_study().await;
    let job = store.jobs(id).await.unwrap()[0].id;
    store
        .mark_rendered(job, &format!("test run {}", job))
        .await
        .unwrap();
    store.mark_running(job, "123:456", 10.0).await.unwrap();
    let results = JobResults {
        responses: vec![("discharge_rate".into(), 0.15)],
        series: vec![("mass_flow_rate".into(), vec![(0.1, 0.2), (0.2, 0.3)])],
        note: None,
    };
    store.mark_succeeded(job, 0, &results).await.unwrap();
    let row = store.job(job).await.unwrap();
    assert_eq!(
        (row.state(), row.attempts, row.exit_code),
        (JobState::Succeeded, 1, Some(0))
    );
    assert_eq!(
        store.responses(id).await.unwrap()[&job].get("discharge_rate"),
        Some(0.15)
    );
    assert_eq!(
        store.series(job, "mass_flow_rate").await.unwrap(),
        vec![(0.1, 0.2), (0.2, 0.3)]
    );
    assert_eq!(
        store
            .transitions_to(job, JobState::Succeeded)
            .await
            .unwrap(),
        1
    );
}

/// One response and one series of `rate`.
fn rate_results(rate: f64) -> JobResults {
    JobResults {
        responses: vec![("discharge_rate".into(), rate)],
        series: vec![("mass_flow_rate".into(), vec![(0.1, rate)])],
        note: None,
    }
}

/// Runs `job` to success with identity `identity` and one response and series.
async fn succeed_as(store: &Store, job: i64, identity: &str, rate: f64) {
    store.mark_rendered(job, identity).await.unwrap();
    store.mark_running(job, "1:1", 1.0).await.unwrap();
    store
        .mark_succeeded(job, 0, &rate_results(rate))
        .await
        .unwrap();
}

#[tokio::test]
async fn a_job_with_a_succeeded_identity_is_that_run_with_the_results_read_from_it() {
    let (_dir, store, id) = store_with_study().await;
    let jobs = store.jobs(id).await.unwrap();
    let (first, copy) = (jobs[0].id, jobs[5].id);
    assert_eq!(store.succeeded_run("same", copy).await.unwrap(), None);
    succeed_as(&store, first, "same", 0.15).await;
    // Another identity, or a run that has not succeeded, is not a source.
    store.mark_rendered(jobs[1].id, "other").await.unwrap();
    assert_eq!(store.succeeded_run("other", copy).await.unwrap(), None);
    // A job is never its own source.
    assert_eq!(store.succeeded_run("same", first).await.unwrap(), None);

    let source = store.succeeded_run("same", copy).await.unwrap().unwrap();
    assert_eq!(
        (source.job_id, source.name.as_str()),
        (first, "small/p000r0")
    );
    store
        .mark_reused(copy, "same", &source, &rate_results(0.15))
        .await
        .unwrap();
    let row = store.job(copy).await.unwrap();
    assert_eq!(row.state(), JobState::Succeeded);
    assert_eq!(row.attempts, 0, "nothing was launched");
    assert_eq!(
        (row.started_at, row.finished_at),
        (None, None),
        "it never ran"
    );
    assert_eq!(row.identity.as_deref(), Some("same"));
    assert_eq!(row.reused_from.as_deref(), Some("small/p000r0"));
    assert_eq!(
        store.responses(id).await.unwrap()[&copy].get("discharge_rate"),
        Some(0.15)
    );
    assert_eq!(
        store.series(copy, "mass_flow_rate").await.unwrap(),
        vec![(0.1, 0.15)]
    );
    assert_eq!(store.reused_count(id).await.unwrap(), 1);
    // A job that ran is preferred as a source over one that was itself reused.
    let third = store
        .succeeded_run("same", jobs[6].id)
        .await
        .unwrap()
        .unwrap();
    assert_eq!(third.job_id, first);
    // Only a pending job can be recorded as reused.
    assert!(store
        .mark_reused(first, "same", &source, &rate_results(0.15))
        .await
        .is_err());
}

#[tokio::test]
async fn deleting_a_study_leaves_the_runs_other_studies_reused_whole() {
    let (dir, store, id) = store_with_study().await;
    let study = Study::from_text(Path::new("small.yaml"), STUDY, None).unwrap();
    let mut again = study.clone();
    again.rename("small-again").unwrap();
    let again_id = store
        .insert_study(&again, Path::new("small.yaml"), &dir.path().join("runs"))
        .await
        .unwrap();
    let first = store.jobs(id).await.unwrap()[0].id;
    succeed_as(&store, first, "same", 0.15).await;
    let reuser = store.jobs(again_id).await.unwrap()[0].id;
    let source = store.succeeded_run("same", reuser).await.unwrap().unwrap();
    store
        .mark_reused(reuser, "same", &source, &rate_results(0.15))
        .await
        .unwrap();
    assert_eq!(
        store.reusers_of(id).await.unwrap(),
        vec!["small-again/p000r0"]
    );
    assert!(store.reusers_of(again_id).await.unwrap().is_empty());

    let row = store.study_by_name("small").await.unwrap().unwrap();
    store.delete_study(&row, |_, _| false).await.unwrap();
    let kept = store.job(reuser).await.unwrap();
    assert_eq!(kept.reused_from.as_deref(), Some("small/p000r0"));
    assert_eq!(
        store.responses(again_id).await.unwrap()[&reuser].get("discharge_rate"),
        Some(0.15)
    );
    // With the source gone, the copy is the project's run of that identity.
    assert_eq!(
        store
            .succeeded_run("same", 0)
            .await
            .unwrap()
            .map(|s| s.job_id),
        Some(reuser)
    );
}

#[tokio::test]
async fn a_transition_from_the_wrong_state_is_refused_and_changes_nothing() {
    let (_dir, store, id) = store_with_study().await;
    let job = store.jobs(id).await.unwrap()[0].id;
    let error = store.mark_running(job, "1:1", 0.0).await.unwrap_err();
    assert!(matches!(error, StoreError::Stale { .. }), "{error}");
    let row = store.job(job).await.unwrap();
    assert_eq!((row.state(), row.attempts), (JobState::Pending, 0));
}

#[tokio::test]
async fn interruption_refunds_the_attempt_and_loss_does_not() {
    let (_dir, store, id) = store_with_study().await;
    let job = store.jobs(id).await.unwrap()[0].id;
    for refund in [true, false] {
        store
            .mark_rendered(job, &format!("test run {}", job))
            .await
            .unwrap();
        store.mark_running(job, "1:1", 0.0).await.unwrap();
        store.requeue(job, "put back", refund).await.unwrap();
    }
    let row = store.job(job).await.unwrap();
    assert_eq!((row.state(), row.attempts), (JobState::Pending, 1));
}

#[tokio::test]
async fn only_one_live_driver_may_claim_a_study() {
    let (_dir, store, id) = store_with_study().await;
    let study = store.study_by_name("small").await.unwrap().unwrap();
    assert_eq!(study.id, id);
    store
        .claim_driver(&study, 100, 1, |_, _| true)
        .await
        .unwrap();
    let busy = store
        .claim_driver(&study, 200, 1, |_, _| true)
        .await
        .unwrap_err();
    assert!(matches!(busy, StoreError::Busy { pid: 100, .. }));
    // A dead holder is taken over.
    store
        .claim_driver(&study, 200, 1, |_, _| false)
        .await
        .unwrap();
}

/// Runs `sql` with the schema's CHECK constraints off, as a damaged database or one
/// written by another version would look.
async fn damage(store: &Store, sql: &str, id: i64) {
    let mut connection = store.pool.acquire().await.unwrap();
    sqlx::query("PRAGMA ignore_check_constraints = ON")
        .execute(&mut *connection)
        .await
        .unwrap();
    sqlx::query(sql)
        .bind(id)
        .execute(&mut *connection)
        .await
        .unwrap();
    sqlx::query("PRAGMA ignore_check_constraints = OFF")
        .execute(&mut *connection)
        .await
        .unwrap();
}

#[tokio::test]
async fn an_unknown_job_state_is_an_error_naming_the_row_never_a_default() {
    let (_dir, store, id) = store_with_study().await;
    let job = store.jobs(id).await.unwrap()[1].id;
    damage(
        &store,
        "UPDATE jobs SET state = 'runnning' WHERE id = ?",
        job,
    )
    .await;
    let expected = format!(
        "jobs row {job} has state `runnning`, which this orch does not know; the database was written by another version or damaged: use the orch that wrote it, or restore orch.db from a backup"
    );
    let listed = store.jobs(id).await.unwrap_err();
    assert!(
        matches!(&listed, StoreError::UnknownState(u) if u.table == "jobs" && u.id == job && u.value == "runnning"),
        "{listed:?}"
    );
    assert_eq!(listed.to_string(), expected);
    assert_eq!(store.job(job).await.unwrap_err().to_string(), expected);
    // A transition reads the state too, and refuses rather than calling it stale.
    let moved = store.mark_cancelled(job, "no").await.unwrap_err();
    assert_eq!(moved.to_string(), expected);
    let events: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM job_events")
        .fetch_one(&store.pool)
        .await
        .unwrap();
    assert_eq!(events, 0);
}

#[tokio::test]
async fn an_unknown_study_state_is_an_error_naming_the_row_never_active() {
    let (_dir, store, id) = store_with_study().await;
    damage(
        &store,
        "UPDATE studies SET state = 'paused' WHERE id = ?",
        id,
    )
    .await;
    let expected = format!(
        "studies row {id} has state `paused`, which this orch does not know; the database was written by another version or damaged: use the orch that wrote it, or restore orch.db from a backup"
    );
    assert_eq!(
        store.study_state(id).await.unwrap_err().to_string(),
        expected
    );
    assert_eq!(
        store.study_by_name("small").await.unwrap_err().to_string(),
        expected
    );
    assert_eq!(store.studies().await.unwrap_err().to_string(), expected);
}

#[tokio::test]
async fn states_are_written_as_the_text_they_are_read_from() {
    let (_dir, store, id) = store_with_study().await;
    store
        .set_study_state(id, StudyState::Interrupted)
        .await
        .unwrap();
    let job = store.jobs(id).await.unwrap()[0].id;
    store.mark_cancelled(job, "test").await.unwrap();
    let (study, job): (String, String) = sqlx::query_as(
        "SELECT s.state, j.state FROM studies s JOIN jobs j ON j.study_id = s.id WHERE j.id = ?",
    )
    .bind(job)
    .fetch_one(&store.pool)
    .await
    .unwrap();
    assert_eq!((study.as_str(), job.as_str()), ("interrupted", "cancelled"));
    for state in JobState::ALL {
        assert_eq!(state.as_str().parse::<JobState>(), Ok(state));
    }
}

/// A stage kind is whatever the registry of stages names: the store takes a kind added
/// after its last migration (`script`) with no migration of its own, refuses an empty
/// one, and reads a kind this orch does not know as an error naming the row, never as
/// a design job.
#[tokio::test]
async fn a_job_of_a_new_stage_kind_is_stored_without_a_migration() {
    let (_dir, store, id) = store_with_study().await;
    let design = store.jobs(id).await.unwrap()[0].clone();
    let insert = |stage: &'static str, name: &'static str| {
        sqlx::query(
            "INSERT INTO jobs (study_id, point_id, replicate, name, seed, state, run_dir, stage, after_job_id)
             VALUES (?, ?, 0, ?, 1, 'pending', 'runs/x', ?, ?)",
        )
        .bind(id)
        .bind(design.point_id)
        .bind(name)
        .bind(stage)
        .bind(design.id)
        .execute(&store.pool)
    };
    insert("script", "p000r0-post").await.unwrap();
    assert!(insert("", "p000r0-empty").await.is_err());
    let jobs = store.jobs(id).await.unwrap();
    let post = jobs.iter().find(|j| j.name == "p000r0-post").unwrap();
    assert_eq!(post.stage_kind(), Some("script"));
    assert_eq!(post.kind, crate::JobKind::Stage("script"));
    assert_eq!(post.after_job_id, Some(design.id));
    let unknown = insert("dpm", "p000r0-dpm")
        .await
        .unwrap()
        .last_insert_rowid();
    let error = store.jobs(id).await.unwrap_err().to_string();
    assert!(
        error.contains(&format!(
            "jobs row {unknown} has stage `dpm`, which this orch does not know"
        )),
        "{error}"
    );
    sqlx::query("DELETE FROM jobs WHERE id = ?")
        .bind(unknown)
        .execute(&store.pool)
        .await
        .unwrap();
    // Deleting the design job still deletes the stage that follows it.
    sqlx::query("DELETE FROM jobs WHERE id = ?")
        .bind(design.id)
        .execute(&store.pool)
        .await
        .unwrap();
    let left = store.jobs(id).await.unwrap();
    assert!(left.iter().all(|j| j.name != "p000r0-post"));
}

/// A round's decision is an enum too: a value this orch does not know is an error
/// naming the row, not text passed on.
#[tokio::test]
async fn an_unknown_round_decision_is_an_error_naming_the_row() {
    let (_dir, store, id) = store_with_study().await;
    let mut conn = store.pool.acquire().await.unwrap();
    sqlx::query("PRAGMA ignore_check_constraints = ON")
        .execute(&mut *conn)
        .await
        .unwrap();
    sqlx::query(
        "INSERT INTO proposals (study_id, round, decision, note) VALUES (?, 0, 'someday', 'x')",
    )
    .bind(id)
    .execute(&mut *conn)
    .await
    .unwrap();
    drop(conn);
    let error = store.rounds(id).await.unwrap_err().to_string();
    assert!(
        error.contains("proposals row 0 has state `someday`, which this orch does not know"),
        "{error}"
    );
}

#[tokio::test]
async fn a_comparison_is_stored_and_read_back_with_missing_figures_as_nan() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path()).await.unwrap();
    let record = ComparisonRecord {
        started_at: 1.0e9,
        wall_time_s: 42.0,
        git_commit: Some("abc".into()),
        suite: "suite.yaml".into(),
        quick: true,
        perturbation: String::new(),
        solver_versions: "liggghts=3.8.0, native=0.1.0".into(),
        confidence: 0.95,
        verdict: "regression".into(),
    };
    let response = ResponseRecord {
        case: "c".into(),
        response: "rate".into(),
        reference_solver: "liggghts".into(),
        native: [1.0, f64::NAN],
        native_runs: 1,
        reference: [2.0, 0.1],
        reference_runs: 3,
        relative_difference: -0.5,
        interval: [f64::NAN, f64::NAN],
        tolerance: 0.1,
        verdict: "regression".into(),
    };
    let speed = SpeedRecord {
        case: "c".into(),
        solver: "native".into(),
        particle_steps_per_s: 5e6,
        runs: 3,
    };
    let id = store
        .insert_comparison(
            &record,
            std::slice::from_ref(&response),
            std::slice::from_ref(&speed),
        )
        .await
        .unwrap();
    let all = store.comparisons().await.unwrap();
    assert_eq!(all.len(), 1);
    assert_eq!(all[0].id, id);
    assert_eq!(all[0].record, record);
    assert_eq!(all[0].speeds, vec![speed]);
    let read = &all[0].responses[0];
    assert!(read.native[1].is_nan() && read.interval[0].is_nan());
    assert_eq!(read.native[0], 1.0);
    assert_eq!(read.relative_difference, -0.5);
    assert_eq!(read.verdict, "regression");
}

/// The driver's tick reads the jobs that run, the first pending jobs it could act on,
/// and the jobs those follow; not a pending job waiting for an unfinished one, nor the
/// pending jobs past the limit, and nothing once every job is final.
#[tokio::test]
async fn a_tick_reads_the_open_jobs_and_only_the_first_pending_ones_it_could_act_on() {
    let (_dir, store, id) = store_with_study().await;
    let jobs = store.jobs(id).await.unwrap();
    let (running, done) = (jobs[0].id, jobs[1].id);
    store
        .mark_rendered(running, &format!("test run {}", running))
        .await
        .unwrap();
    store.mark_running(running, "1:2", 1.0).await.unwrap();
    store
        .mark_rendered(done, &format!("test run {}", done))
        .await
        .unwrap();
    store.mark_running(done, "3:4", 1.0).await.unwrap();
    store
        .mark_succeeded(done, 0, &JobResults::default())
        .await
        .unwrap();
    let stage_after = |upstream: &JobRow, name: &'static str| {
        sqlx::query(
            "INSERT INTO jobs (study_id, point_id, replicate, name, seed, state, run_dir, stage, after_job_id)
             VALUES (?, ?, 0, ?, 1, 'pending', 'runs/x', 'cfd', ?) RETURNING id",
        )
        .bind(id)
        .bind(upstream.point_id)
        .bind(name)
        .bind(upstream.id)
        .fetch_one(&store.pool)
    };
    let waiting: i64 = stage_after(&jobs[0], "p000r0-cfd").await.unwrap().get(0);
    let ready: i64 = stage_after(&jobs[1], "p000r1-cfd").await.unwrap().get(0);
    let ids = |listed: Vec<JobRow>| listed.iter().map(|j| j.id).collect::<Vec<_>>();

    let first = ids(store.unfinished_jobs(id, 2).await.unwrap());
    assert_eq!(first, vec![running, jobs[2].id, jobs[3].id]);

    let all = ids(store.unfinished_jobs(id, 100).await.unwrap());
    let mut expected: Vec<i64> = jobs.iter().map(|j| j.id).collect();
    expected.push(ready);
    // The succeeded job is read as the upstream of the stage that may start now.
    assert_eq!(all, expected);
    assert!(!all.contains(&waiting));

    assert_eq!(
        ids(store.launched_jobs(id).await.unwrap()),
        vec![running],
        "submitted or running"
    );
    let counts = store.job_counts(id).await.unwrap();
    assert_eq!(counts[&JobState::Pending], 18);
    assert_eq!(counts[&JobState::Running], 1);
    assert_eq!(counts[&JobState::Succeeded], 1);
    assert_eq!(
        ids(store.jobs_in_state(id, JobState::Succeeded).await.unwrap()),
        vec![done]
    );

    for job in store.jobs(id).await.unwrap() {
        if !job.state().is_final() {
            store.mark_cancelled(job.id, "test").await.unwrap();
        }
    }
    assert!(store.unfinished_jobs(id, 100).await.unwrap().is_empty());
}

/// The driver reads the design points of the jobs it handles, not the study's.
#[tokio::test]
async fn points_are_read_by_id_and_the_latest_round_with_its_jobs() {
    let (_dir, store, id) = store_with_study().await;
    let all = store.points(id).await.unwrap();
    let picked = store
        .points_by_id(&[all[2].id, all[0].id, i64::MAX])
        .await
        .unwrap();
    assert_eq!(picked, vec![all[0].clone(), all[2].clone()]);
    assert!(store.points_by_id(&[]).await.unwrap().is_empty());
    let (round, jobs) = store.latest_round_jobs(id).await.unwrap();
    assert_eq!((round, jobs.len()), (0, 18));
}

/// The report's design table reads only the jobs it lists, by their place in the round.
#[tokio::test]
async fn a_round_is_counted_and_read_at_chosen_positions_in_id_order() {
    let (_dir, store, id) = store_with_study().await;
    let all = store.jobs(id).await.unwrap();
    assert_eq!(store.round_job_count(id, 0).await.unwrap(), all.len());
    assert_eq!(store.round_job_count(id, 1).await.unwrap(), 0);
    let picked = store.round_jobs_at(id, 0, &[0, 5, 17, 99]).await.unwrap();
    assert_eq!(
        picked,
        vec![all[0].clone(), all[5].clone(), all[17].clone()]
    );
    assert!(store.round_jobs_at(id, 0, &[]).await.unwrap().is_empty());
    assert!(store.round_jobs_at(id, 1, &[0]).await.unwrap().is_empty());
}

/// The report's table of runs reads only the jobs it lists, by their place in the
/// study, and their responses in one query.
#[tokio::test]
async fn a_study_s_jobs_are_read_at_chosen_positions_with_their_responses() {
    let (_dir, store, id) = store_with_study().await;
    let all = store.jobs(id).await.unwrap();
    let picked = store.jobs_at(id, &[1, 4, 17, 18]).await.unwrap();
    assert_eq!(
        picked,
        vec![all[1].clone(), all[4].clone(), all[17].clone()]
    );
    assert!(store.jobs_at(id, &[]).await.unwrap().is_empty());
    for (k, job) in all.iter().take(3).enumerate() {
        let results = JobResults {
            responses: vec![
                ("discharge_rate".into(), 0.1 + k as f64),
                ("segregation_index".into(), 0.5),
            ],
            series: Vec::new(),
            note: None,
        };
        store
            .mark_rendered(job.id, &format!("test run {}", job.id))
            .await
            .unwrap();
        store.mark_running(job.id, "1:1", 1.0).await.unwrap();
        store.mark_succeeded(job.id, 0, &results).await.unwrap();
    }
    let ids = [all[2].id, all[0].id, all[5].id];
    let read = store.responses_of_jobs(&ids).await.unwrap();
    let whole = store.responses(id).await.unwrap();
    assert_eq!(read.len(), 2, "the job without responses is left out");
    for job in [all[0].id, all[2].id] {
        assert_eq!(
            read[&job].clone().into_map(),
            store.job_responses(job).await.unwrap()
        );
        assert_eq!(read[&job], whole[&job]);
    }
    assert!(store.responses_of_jobs(&[]).await.unwrap().is_empty());
}

/// A job's values are kept in name order, looked up by name, and a name given twice
/// keeps its last value, as a map would.
#[test]
fn response_values_are_sorted_by_name_and_the_last_of_a_name_is_kept() {
    let values: ResponseValues = [("rate", 1.0), ("index", 2.0), ("rate", 3.0)]
        .into_iter()
        .map(|(n, v)| (n.to_string(), v))
        .collect();
    assert_eq!(
        values.iter().collect::<Vec<_>>(),
        vec![("index", 2.0), ("rate", 3.0)]
    );
    assert_eq!(
        (values.get("rate"), values.get("index"), values.get("speed")),
        (Some(3.0), Some(2.0), None)
    );
    assert!(ResponseValues::default().is_empty());
}

/// The report's series charts find the jobs of each series from the index and read
/// only the names of the jobs they draw.
#[tokio::test]
async fn the_jobs_of_each_series_are_listed_by_id_and_named_on_demand() {
    let (_dir, store, id) = store_with_study().await;
    let all = store.jobs(id).await.unwrap();
    assert!(store.series_job_ids(id).await.unwrap().is_empty());
    // Jobs 0, 2 and 3 store a mass flow; job 2 also a radial density.
    for (k, job) in [&all[0], &all[2], &all[3]].into_iter().enumerate() {
        let mut series = vec![("mass_flow_rate".to_string(), vec![(0.1, 1.0), (0.2, 2.0)])];
        if k == 1 {
            series.push(("radial_density".to_string(), vec![(0.0, 3.0)]));
        }
        let results = JobResults {
            responses: Vec::new(),
            series,
            note: None,
        };
        store
            .mark_rendered(job.id, &format!("test run {}", job.id))
            .await
            .unwrap();
        store.mark_running(job.id, "1:1", 1.0).await.unwrap();
        store.mark_succeeded(job.id, 0, &results).await.unwrap();
    }
    let by_series = store.series_job_ids(id).await.unwrap();
    assert_eq!(
        by_series.into_iter().collect::<Vec<_>>(),
        vec![
            (
                "mass_flow_rate".to_string(),
                vec![all[0].id, all[2].id, all[3].id]
            ),
            ("radial_density".to_string(), vec![all[2].id]),
        ]
    );
    let names = store
        .job_names(&[all[3].id, all[0].id, i64::MAX])
        .await
        .unwrap();
    assert_eq!(
        names.into_iter().collect::<Vec<_>>(),
        vec![
            (all[0].id, all[0].name.clone()),
            (all[3].id, all[3].name.clone())
        ]
    );
    assert!(store.job_names(&[]).await.unwrap().is_empty());
}

/// The jobs of each series are read a page at a time: a page may end inside a job's
/// series names, and the next page goes on from there.
#[tokio::test]
async fn the_jobs_of_each_series_are_read_across_pages() {
    let (_dir, store, id) = store_with_study().await;
    let all = store.jobs(id).await.unwrap();
    let names: Vec<String> = (0..super::PAGE_LEN + 5)
        .map(|k| format!("s{k:05}"))
        .collect();
    for job in &all[..2] {
        let results = JobResults {
            responses: Vec::new(),
            series: names
                .iter()
                .map(|n| (n.clone(), vec![(0.0, 1.0)]))
                .collect(),
            note: None,
        };
        store
            .mark_rendered(job.id, &format!("test run {}", job.id))
            .await
            .unwrap();
        store.mark_running(job.id, "1:1", 1.0).await.unwrap();
        store.mark_succeeded(job.id, 0, &results).await.unwrap();
    }
    let by_series = store.series_job_ids(id).await.unwrap();
    assert_eq!(by_series.len(), names.len());
    assert!(by_series
        .values()
        .all(|jobs| *jobs == [all[0].id, all[1].id]));
}

/// The analysis's lean read of the jobs keeps each job's link fields as the whole
/// rows have them, in the same order.
#[tokio::test]
async fn a_study_s_job_links_are_its_jobs_link_fields() {
    let (_dir, store, id) = store_with_study().await;
    let first = store.jobs(id).await.unwrap()[0].id;
    store
        .mark_rendered(first, &format!("test run {}", first))
        .await
        .unwrap();
    store.mark_running(first, "1:1", 1.0).await.unwrap();
    store
        .mark_failed(first, Some(1), "the solver crashed")
        .await
        .unwrap();
    let whole = store.jobs(id).await.unwrap();
    let lean = store.job_links(id).await.unwrap();
    assert_eq!(lean.len(), whole.len());
    for (l, w) in lean.iter().zip(&whole) {
        assert_eq!(
            (
                l.id(),
                l.point_id(),
                l.name(),
                l.state(),
                l.kind(),
                l.after_job_id()
            ),
            (
                w.id,
                w.point_id,
                w.name.as_str(),
                w.state,
                w.kind,
                w.after_job_id
            )
        );
    }
    assert_eq!(lean[0].state, JobState::Failed);
}

#[tokio::test]
async fn every_connection_keeps_the_small_page_cache() {
    let (_dir, store, _) = store_with_study().await;
    // Two connections held at once: the second is opened for this, not reused.
    let mut first = store.pool.acquire().await.unwrap();
    let mut second = store.pool.acquire().await.unwrap();
    for connection in [&mut first, &mut second] {
        let (kib,): (i64,) = sqlx::query_as("PRAGMA cache_size")
            .fetch_one(&mut **connection)
            .await
            .unwrap();
        assert_eq!(kib.to_string(), CACHE_SIZE_KIB);
    }
}

#[tokio::test]
async fn a_store_of_the_version_before_run_identity_opens_migrated_with_nothing_lost() {
    use sqlx::sqlite::SqlitePoolOptions;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(DATABASE_FILE);
    // The schema as the version before 0012 left it, with a study, a point and a
    // succeeded job with a response.
    let options = SqliteConnectOptions::new()
        .filename(&path)
        .create_if_missing(true)
        .foreign_keys(true);
    let pool = SqlitePoolOptions::new()
        .connect_with(options)
        .await
        .unwrap();
    let mut before = sqlx::migrate!("./migrations");
    before.migrations = before
        .migrations
        .iter()
        .filter(|m| m.version <= 11)
        .cloned()
        .collect::<Vec<_>>()
        .into();
    before.run(&pool).await.unwrap();
    for sql in [
        "INSERT INTO studies (id, name, solver, file_path, file_text, file_sha256, template_name, template_text, state, created_at, updated_at)
         VALUES (1, 'old', 'native', 'old.yaml', 'name: old', 'abc', 't', 't', 'finished', 0, 0)",
        "INSERT INTO points (id, study_id, round, idx) VALUES (1, 1, 0, 0)",
        "INSERT INTO jobs (id, study_id, point_id, replicate, name, seed, state, run_dir, attempts, exit_code)
         VALUES (1, 1, 1, 0, 'p000r0', 7002021, 'succeeded', '/runs/old/p000r0', 1, 0)",
        "INSERT INTO responses (job_id, name, value) VALUES (1, 'discharge_rate', 0.2075)",
    ] {
        sqlx::query(sql).execute(&pool).await.unwrap();
    }
    pool.close().await;

    let store = Store::open(dir.path()).await.unwrap();
    let job = store.job(1).await.unwrap();
    assert_eq!(
        (job.name.as_str(), job.seed, job.state(), job.attempts),
        ("p000r0", 7002021, JobState::Succeeded, 1)
    );
    assert_eq!((job.identity, job.reused_from), (None, None));
    assert_eq!(
        store.job_responses(1).await.unwrap()["discharge_rate"],
        0.2075
    );
    // Without an identity it is nobody's source.
    assert_eq!(store.reused_count(1).await.unwrap(), 0);
}

#[tokio::test]
async fn a_store_of_a_newer_orch_is_refused_with_what_to_do_and_left_as_it_was() {
    let (dir, store, _id) = store_with_study().await;
    sqlx::query(
        "INSERT INTO _sqlx_migrations (version, description, success, checksum, execution_time)
         VALUES (999, 'from the future', 1, x'00', 0)",
    )
    .execute(&store.pool)
    .await
    .unwrap();
    store.close().await;
    let error = Store::open(dir.path()).await.unwrap_err().to_string();
    assert!(
        error.contains("nothing stored was changed") && error.contains("needs that orch"),
        "{error}"
    );
    let rows: i64 = {
        let options = SqliteConnectOptions::new().filename(dir.path().join(DATABASE_FILE));
        let pool = sqlx::SqlitePool::connect_with(options).await.unwrap();
        sqlx::query_scalar("SELECT COUNT(*) FROM jobs")
            .fetch_one(&pool)
            .await
            .unwrap()
    };
    assert_eq!(rows, 18);
}
