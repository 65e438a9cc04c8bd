//! Every transition of the decision core, without processes, a database or a clock.

use std::collections::HashSet;
use std::time::Duration;

use proptest::prelude::*;

use super::*;
use crate::store::JobKind;

const NOW: f64 = 1_000_000.0;

/// A design job in `state`; launched states have a handle, started at `NOW - 10`.
fn job(id: i64, state: JobState) -> JobRow {
    let launched = matches!(state, JobState::Submitted | JobState::Running);
    JobRow {
        id,
        study_id: 1,
        point_id: id,
        replicate: 0,
        name: format!("p{id:03}r0"),
        seed: id,
        state,
        attempts: i64::from(launched),
        executor_handle: launched.then(|| format!("{}:1", 100 + id)),
        run_dir: format!("/runs/p{id:03}r0"),
        started_at: (state == JobState::Running).then_some(NOW - 10.0),
        finished_at: None,
        exit_code: None,
        error: None,
        scheduler_state: None,
        kind: JobKind::Design,
        after_job_id: None,
        identity: None,
        reused_from: None,
    }
}

/// A `cfd` stage job chained after `upstream`.
fn stage(id: i64, state: JobState, upstream: i64) -> JobRow {
    JobRow {
        name: format!("p{upstream:03}r0-cfd"),
        kind: JobKind::Stage("cfd"),
        after_job_id: Some(upstream),
        ..job(id, state)
    }
}

fn budgets(max_parallel: usize, retries: u32) -> Budgets {
    Budgets {
        max_parallel,
        retries,
        time_limit: Some(Duration::from_secs(60)),
        batch: false,
        cores: None,
    }
}

/// Every job on one core.
fn one_core(_: &JobRow) -> usize {
    1
}

fn report(status: JobStatus) -> Report {
    Report {
        status,
        scheduler_state: None,
    }
}

/// The actions for one polled job.
fn on(job: &JobRow, status: JobStatus, budgets: &Budgets) -> Vec<Action> {
    on_reports(&[(job, report(status))], budgets, NOW)
}

fn launches(actions: &[Action]) -> Vec<i64> {
    actions
        .iter()
        .filter_map(|a| match a {
            Action::Launch { job } => Some(*job),
            _ => None,
        })
        .collect()
}

fn none() -> HashSet<i64> {
    HashSet::new()
}

// ---- launches ----

#[test]
fn pending_jobs_are_launched_in_id_order_up_to_the_free_slots() {
    use JobState::*;
    let jobs = vec![
        job(1, Succeeded),
        job(2, Running),
        job(3, Failed),
        job(4, Pending),
        job(5, Submitted),
        job(6, Pending),
        job(7, Pending),
        job(8, Cancelled),
    ];
    // Two of four slots are held (running, submitted).
    assert_eq!(
        settle_and_launch(&jobs, &budgets(4, 0), &none(), one_core),
        vec![Action::Launch { job: 4 }, Action::Launch { job: 6 }]
    );
    assert_eq!(
        launches(&settle_and_launch(&jobs, &budgets(3, 0), &none(), one_core)),
        vec![4]
    );
    assert_eq!(
        launches(&settle_and_launch(
            &jobs,
            &budgets(10, 0),
            &none(),
            one_core
        )),
        vec![4, 6, 7]
    );
}

#[test]
fn no_job_is_launched_when_every_slot_is_held_or_over_held() {
    use JobState::*;
    let jobs = vec![job(1, Running), job(2, Submitted), job(3, Pending)];
    assert!(settle_and_launch(&jobs, &budgets(2, 0), &none(), one_core).is_empty());
    // A smaller max_parallel after a resume: more are running than allowed.
    assert!(settle_and_launch(&jobs, &budgets(1, 0), &none(), one_core).is_empty());
    assert!(settle_and_launch(&jobs, &budgets(0, 0), &none(), one_core).is_empty());
}

/// Design jobs on 2 cores each, `cfd` stage jobs on 1.
fn two_core_design_jobs(job: &JobRow) -> usize {
    if job.kind == JobKind::Design {
        2
    } else {
        1
    }
}

fn cores(max_parallel: usize, cores: usize) -> Budgets {
    Budgets {
        cores: Some(cores),
        ..budgets(max_parallel, 0)
    }
}

#[test]
fn two_core_jobs_on_two_cores_run_one_at_a_time() {
    use JobState::*;
    let pending = vec![job(1, Pending), job(2, Pending), job(3, Pending)];
    // max_parallel allows three, the cores one.
    assert_eq!(
        launches(&settle_and_launch(
            &pending,
            &cores(3, 2),
            &none(),
            two_core_design_jobs
        )),
        vec![1]
    );
    let one_running = vec![job(1, Running), job(2, Pending)];
    assert!(
        settle_and_launch(&one_running, &cores(3, 2), &none(), two_core_design_jobs).is_empty()
    );
    // On four cores two of them fit; on one core a 2-core job still runs, alone.
    assert_eq!(
        launches(&settle_and_launch(
            &pending,
            &cores(3, 4),
            &none(),
            two_core_design_jobs
        )),
        vec![1, 2]
    );
    assert_eq!(
        launches(&settle_and_launch(
            &pending,
            &cores(3, 1),
            &none(),
            two_core_design_jobs
        )),
        vec![1]
    );
    // Without a core budget (Slurm) only max_parallel counts.
    assert_eq!(
        launches(&settle_and_launch(
            &pending,
            &budgets(3, 0),
            &none(),
            two_core_design_jobs
        )),
        vec![1, 2, 3]
    );
}

#[test]
fn a_one_core_stage_fills_the_core_a_two_core_job_leaves_free() {
    use JobState::*;
    // On 3 cores: job 1 (2 cores) runs, job 2 succeeded, its 1-core stage 3 fits;
    // the 2-core job 4 behind it does not, and nothing jumps ahead of it.
    let jobs = vec![
        job(1, Running),
        job(2, Succeeded),
        stage(3, Pending, 2),
        job(4, Pending),
        stage(5, Pending, 2),
    ];
    assert_eq!(
        launches(&settle_and_launch(
            &jobs,
            &cores(8, 3),
            &none(),
            two_core_design_jobs
        )),
        vec![3]
    );
}

#[test]
fn rendered_final_and_pending_jobs_hold_no_slot() {
    use JobState::*;
    let jobs = vec![
        job(1, Rendered),
        job(2, Succeeded),
        job(3, Failed),
        job(4, Cancelled),
        job(5, Pending),
    ];
    assert_eq!(
        launches(&settle_and_launch(&jobs, &budgets(1, 0), &none(), one_core)),
        vec![5]
    );
}

#[test]
fn a_job_whose_last_attempt_is_still_being_terminated_waits() {
    let jobs = vec![job(1, JobState::Pending), job(2, JobState::Pending)];
    let terminating = HashSet::from([1]);
    assert_eq!(
        launches(&settle_and_launch(
            &jobs,
            &budgets(1, 0),
            &terminating,
            one_core
        )),
        vec![2]
    );
}

#[test]
fn a_stage_job_is_launched_only_after_its_upstream_job_succeeded() {
    use JobState::*;
    for upstream in [Pending, Rendered, Submitted, Running] {
        let jobs = vec![job(1, upstream), stage(2, Pending, 1)];
        let actions = settle_and_launch(&jobs, &budgets(4, 0), &none(), one_core);
        assert!(
            !launches(&actions).contains(&2),
            "stage launched while its upstream is {upstream}: {actions:?}"
        );
        assert!(
            actions.iter().all(|a| matches!(a, Action::Launch { .. })),
            "{actions:?}"
        );
    }
    let jobs = vec![job(1, Succeeded), stage(2, Pending, 1), job(3, Pending)];
    assert_eq!(
        launches(&settle_and_launch(&jobs, &budgets(4, 0), &none(), one_core)),
        vec![2, 3]
    );
}

#[test]
fn a_stage_whose_upstream_is_unknown_is_neither_launched_nor_settled() {
    let jobs = vec![stage(2, JobState::Pending, 99)];
    assert!(settle_and_launch(&jobs, &budgets(4, 0), &none(), one_core).is_empty());
}

// ---- orphaned stages ----

#[test]
fn a_stage_whose_upstream_failed_fails_and_is_not_launched() {
    let jobs = vec![job(1, JobState::Failed), stage(2, JobState::Pending, 1)];
    assert_eq!(
        settle_and_launch(&jobs, &budgets(4, 0), &none(), one_core),
        vec![Action::FailOrphan {
            job: 2,
            upstream: "p001r0".into()
        }]
    );
}

#[test]
fn a_stage_whose_upstream_was_cancelled_is_cancelled_and_not_launched() {
    let jobs = vec![job(1, JobState::Cancelled), stage(2, JobState::Pending, 1)];
    assert_eq!(
        settle_and_launch(&jobs, &budgets(4, 0), &none(), one_core),
        vec![Action::Cancel {
            job: 2,
            cause: CancelCause::Upstream("p001r0".into())
        }]
    );
}

#[test]
fn orphans_are_settled_before_launches_and_final_stages_are_left_alone() {
    use JobState::*;
    let jobs = vec![
        job(1, Failed),
        stage(2, Failed, 1),
        job(3, Cancelled),
        stage(4, Pending, 3),
        job(5, Pending),
        job(6, Failed),
        stage(7, Pending, 6),
    ];
    assert_eq!(
        settle_and_launch(&jobs, &budgets(4, 0), &none(), one_core),
        vec![
            Action::Cancel {
                job: 4,
                cause: CancelCause::Upstream("p003r0".into())
            },
            Action::FailOrphan {
                job: 7,
                upstream: "p006r0".into()
            },
            Action::Launch { job: 5 },
        ]
    );
}

// ---- reports ----

#[test]
fn a_queued_job_is_left_alone_and_a_started_one_is_marked_running() {
    let submitted = job(1, JobState::Submitted);
    assert!(on(&submitted, JobStatus::Queued, &budgets(1, 0)).is_empty());
    assert_eq!(
        on(&submitted, JobStatus::Running, &budgets(1, 0)),
        vec![Action::MarkStarted { job: 1 }]
    );
}

#[test]
fn a_running_job_within_its_time_limit_is_left_alone() {
    let running = job(1, JobState::Running);
    assert!(on(&running, JobStatus::Running, &budgets(1, 0)).is_empty());
    let at_limit = JobRow {
        started_at: Some(NOW - 60.0),
        ..running.clone()
    };
    assert!(on(&at_limit, JobStatus::Running, &budgets(1, 0)).is_empty());
    // Without a recorded start it has only just started.
    let unstarted = JobRow {
        started_at: None,
        ..running
    };
    assert!(on(&unstarted, JobStatus::Running, &budgets(1, 0)).is_empty());
}

#[test]
fn a_local_job_past_its_time_limit_is_terminated_and_retried_then_failed() {
    let late = JobRow {
        started_at: Some(NOW - 60.5),
        ..job(1, JobState::Running)
    };
    let terminate = Action::Terminate {
        job: 1,
        handle: "101:1".into(),
    };
    let limit = Failure::TimeLimit(Duration::from_secs(60));
    assert_eq!(
        on(&late, JobStatus::Running, &budgets(1, 1)),
        vec![
            terminate.clone(),
            Action::Retry {
                job: 1,
                attempt: 1,
                budget: 2,
                failure: limit.clone()
            }
        ]
    );
    let second = JobRow {
        attempts: 2,
        ..late.clone()
    };
    assert_eq!(
        on(&second, JobStatus::Running, &budgets(1, 1)),
        vec![
            terminate,
            Action::Fail {
                job: 1,
                failure: limit
            }
        ]
    );
    // A handle lost to the store cannot be terminated; the job still fails.
    let handleless = JobRow {
        executor_handle: None,
        ..late
    };
    assert_eq!(
        on(&handleless, JobStatus::Running, &budgets(1, 0)),
        vec![Action::Fail {
            job: 1,
            failure: Failure::TimeLimit(Duration::from_secs(60))
        }]
    );
}

#[test]
fn no_time_limit_is_enforced_without_one_or_on_a_batch_scheduler() {
    let ancient = JobRow {
        started_at: Some(0.0),
        ..job(1, JobState::Running)
    };
    let unlimited = Budgets {
        time_limit: None,
        ..budgets(1, 0)
    };
    assert!(on(&ancient, JobStatus::Running, &unlimited).is_empty());
    let batch = Budgets {
        batch: true,
        ..budgets(1, 0)
    };
    assert!(on(&ancient, JobStatus::Running, &batch).is_empty());
}

#[test]
fn an_exit_0_is_collected_whatever_the_attempts() {
    for attempts in [1, 5] {
        let running = JobRow {
            attempts,
            ..job(1, JobState::Running)
        };
        assert_eq!(
            on(&running, JobStatus::Exited(0), &budgets(1, 0)),
            vec![Action::Collect { job: 1 }]
        );
    }
    // Also a job the scheduler ran between two polls.
    assert_eq!(
        on(
            &job(1, JobState::Submitted),
            JobStatus::Exited(0),
            &budgets(1, 0)
        ),
        vec![Action::Collect { job: 1 }]
    );
}

/// Every failure path spends one attempt of `1 + retries`: retried while attempts
/// are left, failed on the last, with the exit code a failed job keeps.
#[test]
fn every_failure_path_spends_the_retry_budget() {
    let paths: Vec<(JobStatus, Failure, Option<i32>)> = vec![
        (JobStatus::Exited(3), Failure::Exited(3), Some(3)),
        (JobStatus::Exited(-9), Failure::Exited(-9), Some(-9)),
        (JobStatus::Lost, Failure::Lost, None),
        (
            JobStatus::Stopped {
                cause: StopCause::TimeLimit,
                reason: "TIMEOUT".into(),
            },
            Failure::Stopped("TIMEOUT".into()),
            None,
        ),
        (
            JobStatus::Stopped {
                cause: StopCause::NodeLost,
                reason: "NODE_FAIL".into(),
            },
            Failure::Stopped("NODE_FAIL".into()),
            None,
        ),
        (
            JobStatus::Stopped {
                cause: StopCause::OutOfMemory,
                reason: "OUT_OF_MEMORY".into(),
            },
            Failure::Stopped("OUT_OF_MEMORY".into()),
            None,
        ),
        (
            JobStatus::Stopped {
                cause: StopCause::Other,
                reason: "FAILED".into(),
            },
            Failure::Stopped("FAILED".into()),
            None,
        ),
    ];
    for (status, failure, exit_code) in paths {
        for retries in [0_u32, 1, 2] {
            let budget = 1 + i64::from(retries);
            for attempts in 1..=budget {
                let running = JobRow {
                    attempts,
                    ..job(1, JobState::Running)
                };
                let actions = on(&running, status.clone(), &budgets(1, retries));
                let expected = if attempts < budget {
                    Action::Retry {
                        job: 1,
                        attempt: attempts,
                        budget,
                        failure: failure.clone(),
                    }
                } else {
                    Action::Fail {
                        job: 1,
                        failure: failure.clone(),
                    }
                };
                assert_eq!(actions, vec![expected], "{status:?}, attempt {attempts}");
            }
        }
        assert_eq!(failure.exit_code(), exit_code, "{failure:?}");
    }
}

#[test]
fn a_lost_job_is_not_retried_for_ever() {
    // Attempts past the budget (a smaller `retries` after a resume) fail at once.
    let lost = JobRow {
        attempts: 7,
        ..job(1, JobState::Running)
    };
    assert_eq!(
        on(&lost, JobStatus::Lost, &budgets(1, 2)),
        vec![Action::Fail {
            job: 1,
            failure: Failure::Lost
        }]
    );
}

#[test]
fn unreadable_output_of_an_exit_0_spends_the_budget_and_keeps_exit_code_0() {
    let running = job(1, JobState::Running);
    let failure = Failure::Unreadable("no dump".into());
    assert_eq!(
        retry_or_fail(&running, &budgets(1, 1), failure.clone()),
        Action::Retry {
            job: 1,
            attempt: 1,
            budget: 2,
            failure: failure.clone()
        }
    );
    assert_eq!(
        retry_or_fail(&running, &budgets(1, 0), failure.clone()),
        Action::Fail {
            job: 1,
            failure: failure.clone()
        }
    );
    assert_eq!(failure.exit_code(), Some(0));
}

#[test]
fn a_job_the_scheduler_cancelled_is_cancelled_not_retried() {
    let status = JobStatus::Stopped {
        cause: StopCause::Cancelled,
        reason: "CANCELLED by 1000".into(),
    };
    assert_eq!(
        on(&job(1, JobState::Running), status, &budgets(1, 5)),
        vec![Action::Cancel {
            job: 1,
            cause: CancelCause::Scheduler("CANCELLED by 1000".into())
        }]
    );
}

#[test]
fn what_the_scheduler_says_is_noted_when_it_changed_before_acting() {
    let submitted = JobRow {
        scheduler_state: Some("PENDING (Priority)".into()),
        ..job(1, JobState::Submitted)
    };
    let said = |status, words: &str| Report {
        status,
        scheduler_state: Some(words.to_string()),
    };
    assert!(on_reports(
        &[(&submitted, said(JobStatus::Queued, "PENDING (Priority)"))],
        &budgets(1, 0),
        NOW
    )
    .is_empty());
    assert_eq!(
        on_reports(
            &[(&submitted, said(JobStatus::Running, "RUNNING on n1"))],
            &budgets(1, 0),
            NOW
        ),
        vec![
            Action::NoteSchedulerState {
                job: 1,
                state: "RUNNING on n1".into()
            },
            Action::MarkStarted { job: 1 }
        ]
    );
}

#[test]
fn reports_are_acted_on_in_the_order_polled() {
    let a = job(1, JobState::Running);
    let b = job(2, JobState::Submitted);
    let c = job(3, JobState::Running);
    let actions = on_reports(
        &[
            (&a, report(JobStatus::Exited(0))),
            (&b, report(JobStatus::Running)),
            (&c, report(JobStatus::Lost)),
        ],
        &budgets(3, 0),
        NOW,
    );
    assert_eq!(
        actions.iter().map(Action::job).collect::<Vec<_>>(),
        [1, 2, 3]
    );
}

// ---- interrupt, cancel, end ----

#[test]
fn ctrl_c_terminates_and_requeues_local_running_and_rendered_jobs() {
    use JobState::*;
    let jobs = vec![
        job(1, Running),
        job(2, Rendered),
        job(3, Pending),
        job(4, Succeeded),
        job(5, Failed),
    ];
    assert_eq!(
        on_interrupt(&jobs, &budgets(4, 0)),
        vec![
            Action::Terminate {
                job: 1,
                handle: "101:1".into()
            },
            Action::Requeue { job: 1 },
            Action::Requeue { job: 2 },
        ]
    );
}

#[test]
fn ctrl_c_leaves_batch_jobs_on_the_cluster_and_requeues_rendered_ones() {
    use JobState::*;
    let batch = Budgets {
        batch: true,
        ..budgets(4, 0)
    };
    let jobs = vec![job(1, Running), job(2, Submitted), job(3, Rendered)];
    assert_eq!(
        on_interrupt(&jobs, &batch),
        vec![Action::Requeue { job: 3 }]
    );
}

#[test]
fn a_cancelled_study_terminates_everything_first_then_cancels_every_unfinished_job() {
    use JobState::*;
    let jobs = vec![
        job(1, Running),
        job(2, Pending),
        job(3, Succeeded),
        job(4, Submitted),
        job(5, Cancelled),
    ];
    let study = CancelCause::Study;
    assert_eq!(
        on_cancel(&jobs),
        vec![
            Action::Terminate {
                job: 1,
                handle: "101:1".into()
            },
            Action::Terminate {
                job: 4,
                handle: "104:1".into()
            },
            Action::Cancel {
                job: 1,
                cause: study.clone()
            },
            Action::Cancel {
                job: 2,
                cause: study.clone()
            },
            Action::Cancel {
                job: 4,
                cause: study
            },
        ]
    );
}

#[test]
fn a_study_is_finished_when_every_job_is_final() {
    use JobState::*;
    assert!(is_finished(&[
        job(1, Succeeded),
        job(2, Failed),
        job(3, Cancelled)
    ]));
    for open in [Pending, Rendered, Submitted, Running] {
        assert!(!is_finished(&[job(1, Succeeded), job(2, open)]), "{open}");
    }
}

// ---- properties ----

fn any_state() -> impl Strategy<Value = JobState> {
    proptest::sample::select(JobState::ALL.to_vec())
}

prop_compose! {
    /// Up to 30 jobs, some of them stages after an earlier job.
    fn any_jobs()(specs in proptest::collection::vec((any_state(), any::<bool>(), 0..30_usize), 0..30))
        -> Vec<JobRow> {
        specs
            .into_iter()
            .enumerate()
            .map(|(i, (state, is_stage, up))| {
                let id = i as i64 + 1;
                if is_stage && i > 0 {
                    stage(id, state, (up % i) as i64 + 1)
                } else {
                    job(id, state)
                }
            })
            .collect()
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Launches are pending, ready jobs, in increasing id order, never more than the
    /// free slots, and as many as both allow; nothing else but orphans is touched.
    #[test]
    fn launches_respect_slots_order_and_upstreams(jobs in any_jobs(), max_parallel in 0..8_usize) {
        let actions = settle_and_launch(&jobs, &budgets(max_parallel, 0), &none(), one_core);
        let state = |id: i64| jobs[id as usize - 1].state;
        let launched = launches(&actions);
        let held = jobs.iter().filter(|j| is_launched(j.state)).count();
        let free = max_parallel.saturating_sub(held);
        prop_assert!(launched.len() <= free);
        prop_assert!(launched.windows(2).all(|w| w[0] < w[1]));
        let ready: Vec<i64> = jobs
            .iter()
            .filter(|j| j.state == JobState::Pending)
            .filter(|j| j.after_job_id.is_none_or(|up| state(up) == JobState::Succeeded))
            .map(|j| j.id)
            .collect();
        prop_assert_eq!(&launched[..], &ready[..ready.len().min(free)]);
        for action in &actions {
            match action {
                Action::Launch { .. } => {}
                Action::FailOrphan { job, .. } => {
                    let up = jobs[*job as usize - 1].after_job_id.unwrap();
                    prop_assert_eq!(state(up), JobState::Failed);
                    prop_assert_eq!(state(*job), JobState::Pending);
                }
                Action::Cancel { job, .. } => {
                    let up = jobs[*job as usize - 1].after_job_id.unwrap();
                    prop_assert_eq!(state(up), JobState::Cancelled);
                    prop_assert_eq!(state(*job), JobState::Pending);
                }
                other => prop_assert!(false, "unexpected {:?}", other),
            }
        }
    }

    /// Whatever an executor reports, a job gets at most `1 + retries` attempts: a
    /// failing job at or past its budget is never put back.
    #[test]
    fn no_report_puts_back_a_job_that_spent_its_budget(
        attempts in 1..6_i64,
        retries in 0..4_u32,
        status in prop_oneof![
            Just(JobStatus::Lost),
            (-200..200_i32).prop_map(JobStatus::Exited),
            Just(JobStatus::Stopped { cause: StopCause::NodeLost, reason: "NODE_FAIL".into() }),
            Just(JobStatus::Stopped { cause: StopCause::Other, reason: "FAILED".into() }),
            Just(JobStatus::Running),
        ],
        started_ago in 0.0..120.0_f64,
    ) {
        let running = JobRow { attempts, started_at: Some(NOW - started_ago), ..job(1, JobState::Running) };
        for action in on(&running, status, &budgets(1, retries)) {
            if let Action::Retry { attempt, budget, .. } = action {
                prop_assert!(attempt < budget);
                prop_assert_eq!(budget, 1 + i64::from(retries));
                prop_assert!(attempts < 1 + i64::from(retries));
            }
        }
    }
}

#[test]
fn a_coupled_chain_settles_when_the_response_moves_less_than_the_tolerance() {
    assert!((coupling_settled(0.200, 0.201, 0.01).unwrap() - 0.005).abs() < 1e-12);
    assert_eq!(coupling_settled(0.200, 0.210, 0.01), None);
    // A zero or non-finite response cannot tell a relative change.
    assert_eq!(coupling_settled(0.0, 0.0, 0.01), None);
    assert_eq!(coupling_settled(0.2, f64::NAN, 0.01), None);
}

#[test]
fn a_settled_chain_cancels_the_pending_job_after_the_settling_run_only() {
    // dem 1 → cfd 2 → air 3 (settled) → cfd 4 (pending) → air 5 (pending).
    let jobs = vec![
        job(1, JobState::Succeeded),
        stage(2, JobState::Succeeded, 1),
        stage(3, JobState::Succeeded, 2),
        stage(4, JobState::Pending, 3),
        stage(5, JobState::Pending, 4),
    ];
    let actions = on_chain_settled(&jobs, 3, "settled at air1");
    assert_eq!(
        actions,
        vec![Action::Cancel {
            job: 4,
            cause: CancelCause::Settled("settled at air1".into()),
        }]
    );
    // The rest of the chain follows its cancelled upstream job.
    let mut after = jobs.clone();
    after[3] = stage(4, JobState::Cancelled, 3);
    let next = settle_and_launch(&after, &budgets(4, 0), &none(), one_core);
    assert!(next.contains(&Action::Cancel {
        job: 5,
        cause: CancelCause::Upstream(after[3].name.clone()),
    }));
    // A job already running is not taken back.
    let mut running = jobs.clone();
    running[3] = stage(4, JobState::Running, 3);
    assert!(on_chain_settled(&running, 3, "settled").is_empty());
}
