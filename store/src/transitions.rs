//! A job's life in the store: each transition one transaction that checks the state it
//! leaves and records an event (`job_events`), and the reuse of a run another job made.

use super::*;

impl Store {
    /// Number of times a job reached `to_state`, from the event log.
    pub async fn transitions_to(&self, job_id: i64, to_state: JobState) -> Result<i64, StoreError> {
        sqlx::query_scalar("SELECT COUNT(*) FROM job_events WHERE job_id = ? AND to_state = ?")
            .bind(job_id)
            .bind(to_state.as_str())
            .fetch_one(&self.pool)
            .await
            .map_err(query_error("count job events"))
    }

    /// Moves a job from one of `from` to `to`, applying `set` (SQL assignments with
    /// their bound values appended after `state`), and logs the event, in one
    /// transaction. Fails with [`StoreError::Stale`] when the job was not in `from`.
    #[allow(clippy::too_many_arguments)]
    async fn transition(
        &self,
        tx: &mut sqlx::SqliteConnection,
        job_id: i64,
        from: &[JobState],
        to: JobState,
        set: &str,
        binds: Vec<Bind>,
        note: Option<&str>,
    ) -> Result<(), StoreError> {
        let current: Option<String> = sqlx::query_scalar("SELECT state FROM jobs WHERE id = ?")
            .bind(job_id)
            .fetch_optional(&mut *tx)
            .await
            .map_err(query_error("read a job's state"))?;
        let stale = || StoreError::Stale {
            job: job_id,
            expected: from
                .iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(" or "),
        };
        let current: JobState = rows::parse_state("jobs", job_id, current.ok_or_else(stale)?)?;
        if !from.contains(&current) {
            return Err(stale());
        }
        let assignments = if set.is_empty() {
            "state = ?".to_string()
        } else {
            format!("state = ?, {set}")
        };
        let sql = format!("UPDATE jobs SET {assignments} WHERE id = ?");
        let mut query = sqlx::query(&sql).bind(to);
        for bind in binds {
            query = match bind {
                Bind::Int(v) => query.bind(v),
                Bind::Real(v) => query.bind(v),
                Bind::Text(v) => query.bind(v),
                Bind::Null => query.bind(None::<i64>),
            };
        }
        query
            .bind(job_id)
            .execute(&mut *tx)
            .await
            .map_err(query_error("change a job's state"))?;
        sqlx::query("INSERT INTO job_events (job_id, at, from_state, to_state, note) VALUES (?, ?, ?, ?, ?)")
            .bind(job_id)
            .bind(now_s())
            .bind(current)
            .bind(to)
            .bind(note)
            .execute(&mut *tx)
            .await
            .map_err(query_error("log a job event"))?;
        Ok(())
    }

    /// Runs one guarded transition in its own transaction.
    async fn transition_alone(
        &self,
        job_id: i64,
        from: &[JobState],
        to: JobState,
        set: &str,
        binds: Vec<Bind>,
        note: Option<&str>,
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        self.transition(&mut tx, job_id, from, to, set, binds, note)
            .await?;
        tx.commit()
            .await
            .map_err(query_error("commit a job transition"))
    }

    /// pending → rendered, with the run's identity ([`orch_study::identity`]).
    pub async fn mark_rendered(&self, job_id: i64, identity: &str) -> Result<(), StoreError> {
        self.transition_alone(
            job_id,
            &[JobState::Pending],
            JobState::Rendered,
            "identity = ?",
            vec![Bind::Text(identity.to_string())],
            None,
        )
        .await
    }

    /// A succeeded run of the project (any study) with identity `identity`, other than
    /// `job_id`: one that ran, before one that was itself reused.
    pub async fn succeeded_run(
        &self,
        identity: &str,
        job_id: i64,
    ) -> Result<Option<ReuseSource>, StoreError> {
        let row: Option<(i64, String, String, Option<String>)> = sqlx::query_as(
            "SELECT j.id, s.name || '/' || j.name, j.run_dir, j.error FROM jobs j JOIN studies s ON s.id = j.study_id
             WHERE j.identity = ? AND j.state = 'succeeded' AND j.id <> ?
             ORDER BY j.reused_from_job IS NOT NULL, j.id LIMIT 1",
        )
        .bind(identity)
        .bind(job_id)
        .fetch_optional(&self.pool)
        .await
        .map_err(query_error("look for an identical run"))?;
        Ok(row.map(|(job_id, name, run_dir, note)| ReuseSource {
            job_id,
            name,
            run_dir: PathBuf::from(run_dir),
            note,
        }))
    }

    /// pending → succeeded without running: the job is the run `source`, with the
    /// `results` this study read from that run's files (its own parsers, so a study
    /// declaring other responses gets them), in one transaction. It keeps no start or
    /// end time (it never ran, so it tells nothing of how long a run takes).
    pub async fn mark_reused(
        &self,
        job_id: i64,
        identity: &str,
        source: &ReuseSource,
        results: &JobResults,
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        let note = format!("reused from {}", source.name);
        self.transition(
            &mut tx,
            job_id,
            &[JobState::Pending],
            JobState::Succeeded,
            "identity = ?, reused_from_job = ?, reused_from = ?, started_at = NULL, finished_at = NULL,
             exit_code = 0, error = ?",
            vec![
                Bind::Text(identity.to_string()),
                Bind::Int(source.job_id),
                Bind::Text(source.name.clone()),
                results.note.clone().map_or(Bind::Null, Bind::Text),
            ],
            Some(&note),
        )
        .await?;
        store_results(&mut tx, job_id, results).await?;
        tx.commit()
            .await
            .map_err(query_error("commit a reused run"))
    }

    /// Jobs of `study_id` that reused a run instead of running.
    pub async fn reused_count(&self, study_id: i64) -> Result<usize, StoreError> {
        let n: i64 = sqlx::query_scalar(
            "SELECT COUNT(*) FROM jobs WHERE study_id = ? AND reused_from IS NOT NULL",
        )
        .bind(study_id)
        .fetch_one(&self.pool)
        .await
        .map_err(query_error("count reused runs"))?;
        Ok(n as usize)
    }

    /// `study/job` of every job of another study that reused a run of `study_id`.
    pub async fn reusers_of(&self, study_id: i64) -> Result<Vec<String>, StoreError> {
        sqlx::query_scalar(
            "SELECT s.name || '/' || j.name FROM jobs j JOIN studies s ON s.id = j.study_id
             JOIN jobs source ON source.id = j.reused_from_job
             WHERE source.study_id = ?1 AND j.study_id <> ?1 ORDER BY j.id",
        )
        .bind(study_id)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("find the runs other studies reused"))
    }

    /// rendered → running with the executor's handle; counts an attempt.
    pub async fn mark_running(
        &self,
        job_id: i64,
        handle: &str,
        started_at: f64,
    ) -> Result<(), StoreError> {
        self.transition_alone(
            job_id,
            &[JobState::Rendered],
            JobState::Running,
            "attempts = attempts + 1, executor_handle = ?, started_at = ?, finished_at = NULL, exit_code = NULL, error = NULL",
            vec![Bind::Text(handle.to_string()), Bind::Real(started_at)],
            None,
        )
        .await
    }

    /// rendered → submitted to a batch scheduler with its handle; counts an attempt.
    /// The attempt starts (see [`Store::mark_started`]) when the scheduler runs it.
    pub async fn mark_submitted(&self, job_id: i64, handle: &str) -> Result<(), StoreError> {
        self.transition_alone(
            job_id,
            &[JobState::Rendered],
            JobState::Submitted,
            "attempts = attempts + 1, executor_handle = ?, started_at = NULL, finished_at = NULL, exit_code = NULL, error = NULL, scheduler_state = NULL",
            vec![Bind::Text(handle.to_string())],
            None,
        )
        .await
    }

    /// submitted → running: the scheduler started the job at `started_at`.
    pub async fn mark_started(&self, job_id: i64, started_at: f64) -> Result<(), StoreError> {
        self.transition_alone(
            job_id,
            &[JobState::Submitted],
            JobState::Running,
            "started_at = ?",
            vec![Bind::Real(started_at)],
            None,
        )
        .await
    }

    /// Records what the batch scheduler says about a job now; not a transition.
    pub async fn set_scheduler_state(
        &self,
        job_id: i64,
        scheduler_state: &str,
    ) -> Result<(), StoreError> {
        sqlx::query("UPDATE jobs SET scheduler_state = ? WHERE id = ?")
            .bind(scheduler_state)
            .bind(job_id)
            .execute(&self.pool)
            .await
            .map_err(query_error("record a job's scheduler state"))?;
        Ok(())
    }

    /// running (or submitted, when the scheduler ran it between two polls) → succeeded,
    /// replacing the job's responses and series.
    pub async fn mark_succeeded(
        &self,
        job_id: i64,
        exit_code: i32,
        results: &JobResults,
    ) -> Result<(), StoreError> {
        let mut tx = self.begin_write().await?;
        self.transition(
            &mut tx,
            job_id,
            &[JobState::Submitted, JobState::Running],
            JobState::Succeeded,
            "exit_code = ?, finished_at = ?, error = ?",
            vec![
                Bind::Int(exit_code as i64),
                Bind::Real(now_s()),
                results.note.clone().map_or(Bind::Null, Bind::Text),
            ],
            None,
        )
        .await?;
        store_results(&mut tx, job_id, results).await?;
        tx.commit()
            .await
            .map_err(query_error("commit a job's results"))
    }

    /// pending, rendered, submitted or running → failed with the reason a user needs.
    pub async fn mark_failed(
        &self,
        job_id: i64,
        exit_code: Option<i32>,
        error: &str,
    ) -> Result<(), StoreError> {
        self.transition_alone(
            job_id,
            &[
                JobState::Pending,
                JobState::Rendered,
                JobState::Submitted,
                JobState::Running,
            ],
            JobState::Failed,
            "exit_code = ?, finished_at = ?, error = ?",
            vec![
                exit_code.map(|c| Bind::Int(c as i64)).unwrap_or(Bind::Null),
                Bind::Real(now_s()),
                Bind::Text(error.to_string()),
            ],
            Some(error),
        )
        .await
    }

    /// rendered, submitted or running → pending, to run again. `refund_attempt` gives
    /// back the attempt (an interruption by the user is not the job's failure).
    pub async fn requeue(
        &self,
        job_id: i64,
        note: &str,
        refund_attempt: bool,
    ) -> Result<(), StoreError> {
        let set = if refund_attempt {
            "executor_handle = NULL, attempts = MAX(attempts - 1, 0), error = ?"
        } else {
            "executor_handle = NULL, error = ?"
        };
        self.transition_alone(
            job_id,
            &[JobState::Rendered, JobState::Submitted, JobState::Running],
            JobState::Pending,
            set,
            vec![Bind::Text(note.to_string())],
            Some(note),
        )
        .await
    }

    /// Any unfinished state → cancelled.
    pub async fn mark_cancelled(&self, job_id: i64, note: &str) -> Result<(), StoreError> {
        self.transition_alone(
            job_id,
            &[
                JobState::Pending,
                JobState::Rendered,
                JobState::Submitted,
                JobState::Running,
            ],
            JobState::Cancelled,
            "finished_at = ?, error = ?",
            vec![Bind::Real(now_s()), Bind::Text(note.to_string())],
            Some(note),
        )
        .await
    }

    /// cancelled (and, with `retry_failed`, failed) → pending with fresh attempts.
    pub async fn reopen(&self, job_id: i64, retry_failed: bool) -> Result<(), StoreError> {
        let from: &[JobState] = if retry_failed {
            &[JobState::Cancelled, JobState::Failed]
        } else {
            &[JobState::Cancelled]
        };
        self.transition_alone(
            job_id,
            from,
            JobState::Pending,
            "attempts = 0, executor_handle = NULL, error = NULL, exit_code = NULL",
            vec![],
            Some("reopened by orch resume"),
        )
        .await
    }
}
