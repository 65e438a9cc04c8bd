//! What the driver does with a run that ended well: read it with the study's parsers
//! (a stage's through its upstream), count it as the study asks, store it, prune its
//! directory, and settle a coupled chain.

use super::*;

/// Reads a finished run's results from its run directory, off the async threads.
type Parser = Box<dyn FnOnce(&Path) -> Result<RunResults, orch_adapters::ParseError> + Send>;

/// What the store keeps of a run's results: every series bounded to
/// [`orch_adapters::thin::MAX_SERIES_POINTS`], and what was thinned said in the note.
pub(super) fn job_results(results: RunResults) -> JobResults {
    let mut notes = results.notes;
    let series = results
        .series
        .into_iter()
        .map(|series| {
            let (series, note) = orch_adapters::thin::bound_series(series);
            notes.extend(note);
            (series.name, series.points)
        })
        .collect();
    JobResults {
        note: (!notes.is_empty()).then(|| notes.join("; ")),
        responses: results.responses,
        series,
    }
}

impl<E: Executor> Driver<'_, E> {
    /// After a rerun of the design in a coupled chain succeeded: when the study's
    /// response moved by less than the tolerance since the DEM run two jobs before
    /// ([`decide::coupling_settled`]), the chain's next job is cancelled (and the rest
    /// with it, [`decide::on_chain_settled`]); returns what happened, for the job's
    /// line.
    pub(super) async fn settle_coupling(
        &mut self,
        job: &JobRow,
        results: &JobResults,
    ) -> Result<Option<String>, DriverError> {
        let Some(coupling) = &self.study.coupling else {
            return Ok(None);
        };
        let Some(now) = results
            .responses
            .iter()
            .find(|(name, _)| *name == coupling.response)
            .map(|&(_, value)| value)
        else {
            return Ok(None);
        };
        let Some(cfd_id) = job.after_job_id else {
            return Ok(None);
        };
        let Some(dem_id) = self.store.job(cfd_id).await?.after_job_id else {
            return Ok(None);
        };
        let before = self.store.job_responses(dem_id).await?;
        let Some(&before) = before.get(&coupling.response) else {
            return Ok(None);
        };
        let Some(change) = decide::coupling_settled(before, now, coupling.tolerance) else {
            return Ok(Some(format!(
                "{} {before:.5} → {now:.5} in the CFD stage's air, not settled yet",
                coupling.response
            )));
        };
        let note = format!(
            "coupling settled at {}: {} {before:.5} → {now:.5} ({:.2} % < {:.2} %)",
            job.name,
            coupling.response,
            100.0 * change,
            100.0 * coupling.tolerance
        );
        let jobs = self.store.jobs(self.study_id).await?;
        for next in decide::on_chain_settled(&jobs, job.id, &note) {
            self.store.mark_cancelled(next.job(), &note).await?;
        }
        Ok(Some(note))
    }

    /// Parses a successful run and stores its results, or retries or fails the job
    /// with why not.
    pub(super) async fn collect(&mut self, job: &JobRow) -> Result<(), DriverError> {
        match self.read_run(job).await? {
            Read::Interrupted => Ok(()),
            Read::Unreadable(reason) => {
                let action = decide::retry_or_fail(job, &self.budgets, Failure::Unreadable(reason));
                self.record_failure(job, action).await
            }
            Read::Results(results) => {
                let Some(results) = self.as_the_study_counts(job, results, None).await? else {
                    return Ok(());
                };
                self.report_success(job, &results);
                self.store.mark_succeeded(job.id, 0, &results).await?;
                self.after_success(job, &results).await
            }
        }
    }

    /// Reads what the run in `job`'s run directory wrote, with this study's parsers: the
    /// same for a run that just ended and for one a job reuses (whose files were
    /// linked in), so a study that declares other responses reads them from the run.
    /// Ctrl-C or SIGTERM does not wait for a long read: [`Read::Interrupted`], and the
    /// job is left for `orch resume`.
    pub(super) async fn read_run(&mut self, job: &JobRow) -> Result<Read, DriverError> {
        // A stage reads its run through what it follows; a design job with its case.
        let parser: Parser = match job.stage_kind() {
            Some(kind) => {
                let read = match self.stage_of(kind) {
                    Ok(config) => self
                        .upstream_of(job, kind)
                        .await
                        .map(|upstream| (config.stage.clone(), stage_case(config, job), upstream)),
                    Err(reason) => Err(reason),
                };
                let (stage, case, upstream) = match read {
                    Ok(read) => read,
                    Err(reason) => return Ok(Read::Unreadable(reason)),
                };
                Box::new(move |dir| stage.results(&case, &upstream.view(), dir))
            }
            None => {
                let (case, simulation) = self.case_and_simulation(job).await?;
                Box::new(move |dir| simulation.results(&case, dir))
            }
        };
        let dir = PathBuf::from(&job.run_dir);
        if self.stopped() {
            self.uncollected.insert(job.id);
            return Ok(Read::Interrupted);
        }
        let parse = tokio::task::spawn_blocking(move || parser(&dir));
        let mut stop = self.stop.clone();
        let parsed = tokio::select! {
            joined = parse => {
                joined.unwrap_or_else(|e| panic!("the parser of {} panicked: {e}", job.name))
            }
            _ = stop.wait_for(|stopped| *stopped) => {
                self.uncollected.insert(job.id);
                return Ok(Read::Interrupted);
            }
        };
        Ok(match parsed {
            Ok(results) => Read::Results(results),
            Err(e) => Read::Unreadable(format!(
                "the solver exited 0 but its output cannot be read: {e}"
            )),
        })
    }

    /// `results` as this study counts them: with a response it asks for missing, the
    /// job fails (`missing_response: fail`, returns `None`) or succeeds saying why; a
    /// run stopped early says so.
    pub(super) async fn as_the_study_counts(
        &mut self,
        job: &JobRow,
        results: RunResults,
        reused_from: Option<&str>,
    ) -> Result<Option<JobResults>, DriverError> {
        let missing = self.missing_responses(job, &results);
        let mut results = job_results(results);
        if let Some(reason) = missing {
            if self.study.fail_on_missing_response {
                let reason = match reused_from {
                    Some(source) => format!("the same run as {source} (not run again) {reason}"),
                    None => reason,
                };
                self.report(job, &format!("failed: {reason}"));
                self.store.mark_failed(job.id, Some(0), &reason).await?;
                return Ok(None);
            }
            self.report(job, &reason);
            results.note = Some(match results.note.take() {
                Some(note) => format!("{reason}; {note}"),
                None => reason,
            });
        }
        if let Some(stopped) = convergence::stopped_early(Path::new(&job.run_dir)) {
            results.note = Some(match results.note.take() {
                Some(note) => format!("{note}; {stopped}"),
                None => stopped,
            });
        }
        Ok(Some(results))
    }

    /// What follows a stored success: the run directory pruned as `keep:` says, and a
    /// coupled chain checked for having settled.
    pub(super) async fn after_success(
        &mut self,
        job: &JobRow,
        results: &JobResults,
    ) -> Result<(), DriverError> {
        self.prune(job);
        self.prune_upstream(job).await?;
        let rerun = job
            .stage_kind()
            .and_then(|kind| self.study.stage(kind))
            .is_some_and(|stage| stage.stage.reruns_design());
        if rerun {
            if let Some(line) = self.settle_coupling(job, results).await? {
                self.report(job, &line);
            }
        }
        Ok(())
    }

    /// Prunes the run directory of a job whose results are stored, as the study's
    /// `keep:` says, but never below what a stage that follows it reads there
    /// ([`orch_adapters::Stage::upstream_files`]): a coupled chain's `cfd` job keeps
    /// at least `results` (the rerun reads its air), a job a user's script follows
    /// keeps everything. A directory that cannot be pruned is reported, and the study
    /// goes on.
    pub(super) fn prune(&self, job: &JobRow) {
        let needed = self
            .study
            .stages_following(job.stage_kind())
            .iter()
            .map(|stage| stage.stage.upstream_files())
            .max()
            .unwrap_or(UpstreamFiles::None);
        self.prune_to(job, self.study.keep.at_least(needed));
    }

    /// Prunes `job`'s run directory to `keep`; a directory that cannot be pruned is
    /// reported, and the study goes on.
    fn prune_to(&self, job: &JobRow, keep: crate::keep::Keep) {
        let run_dir = Path::new(&job.run_dir);
        if let Err(e) = crate::keep::prune(run_dir, keep, &self.log_file(job)) {
            self.report(
                job,
                &format!(
                    "keep: {} could not prune {}: {e}",
                    keep.name(),
                    run_dir.display()
                ),
            );
        }
    }

    /// Once every job that follows `job`'s upstream job has succeeded, nothing reads
    /// the upstream's directory any more: it is pruned to what `keep:` says, which
    /// [`Self::prune`] had raised for those followers. While a follower has not
    /// succeeded (it may be retried, or a person may look at what it read), the
    /// upstream keeps its files.
    async fn prune_upstream(&self, job: &JobRow) -> Result<(), DriverError> {
        let Some(upstream_id) = job.after_job_id else {
            return Ok(());
        };
        let followers = self.store.followers_of(upstream_id).await?;
        if followers.iter().all(|f| f.state == JobState::Succeeded) {
            let upstream = self.store.job(upstream_id).await?;
            self.prune_to(&upstream, self.study.keep);
        }
        Ok(())
    }

    /// Why a run that succeeded lacks responses the study asks for (its objective's and
    /// `responses:` that this kind of job produces), or `None` when it has them all.
    pub(super) fn missing_responses(&self, job: &JobRow, results: &RunResults) -> Option<String> {
        let stage = job.stage_kind().and_then(|k| self.study.stage(k));
        // A rerun of the design owes what the design job owes.
        let produced: Vec<&str> = match stage.filter(|s| !s.stage.reruns_design()) {
            Some(stage) => stage
                .stage
                .responses()
                .iter()
                .map(|r| r.name.as_ref())
                .collect(),
            None => self
                .simulation_of(job)
                .responses()
                .iter()
                .map(|r| r.name.as_ref())
                .collect(),
        };
        let has = |name: &str| results.responses.iter().any(|(n, _)| n == name);
        let missing: Vec<String> = crate::rounds::fitted_responses(self.study)
            .into_iter()
            .filter(|name| produced.contains(&name.as_str()) && !has(name))
            .collect();
        if missing.is_empty() {
            return None;
        }
        let why: Vec<String> = missing
            .iter()
            .map(|name| {
                let reason = results.missing.iter().find(|(n, _)| n == name);
                reason.map_or_else(
                    || format!("{name}: the run did not produce it"),
                    |(_, why)| format!("{name}: {why}"),
                )
            })
            .collect();
        Some(format!(
            "succeeded without {}: {}",
            missing.join(", "),
            why.join("; ")
        ))
    }

    pub(super) fn report_success(&self, job: &JobRow, results: &JobResults) {
        let took = now_s() - job.started_at.unwrap_or_else(now_s);
        self.report(
            job,
            &format!("succeeded in {took:.1} s: {}", self.shown(results)),
        );
    }

    /// The responses of `results` a job's line shows: the study's, not the solver's.
    pub(super) fn shown(&self, results: &JobResults) -> String {
        let shown: Vec<String> = results
            .responses
            .iter()
            .filter(|(name, _)| {
                self.study.responses.is_empty() || self.study.responses.contains(name)
            })
            .filter(|(name, _)| !name.starts_with("solver_"))
            .map(|(name, value)| format!("{name} = {value:.4}"))
            .collect();
        shown.join(", ")
    }
}
