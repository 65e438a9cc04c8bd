//! `executor:` of a study: where and how its jobs run (local or Slurm), checked.

use super::*;

/// How jobs of a study run.
#[derive(Debug, Clone, PartialEq)]
pub struct ExecutorConfig {
    /// Which executor.
    pub kind: ExecutorKind,
    /// Jobs launched and not yet final at once: running locally (`max_parallel`), or
    /// submitted to Slurm (`max_submitted`).
    pub max_parallel: usize,
    /// Wall-time limit per attempt.
    pub time_limit: Option<Duration>,
    /// Extra attempts after a failure.
    pub retries: u32,
    /// Submission settings when `kind` is Slurm.
    pub slurm: Option<SlurmSettings>,
    /// Cores each design job uses (`cores_per_job`; a custom deck's `case.cores`).
    pub cores_per_job: usize,
    /// Cores the running jobs may use together: this machine's
    /// ([`std::thread::available_parallelism`]) for the local executor, so that two
    /// 2-core jobs do not run at once on 2 cores; none on Slurm, which places jobs on
    /// its nodes itself.
    pub core_budget: Option<usize>,
}

impl Checker<'_> {
    pub(super) fn executor(
        &self,
        executor: &ExecutorFile,
        simulation: &dyn Simulation,
    ) -> Result<ExecutorConfig, StudyError> {
        let cores = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1);
        let per_job = simulation.command().cores.max(1);
        if let Some(limit) = executor.time_limit {
            if limit.0.is_zero() {
                return Err(self.error("executor.time_limit", "expected a positive duration"));
            }
        }
        if executor.retries > 100 {
            return Err(self.error(
                "executor.retries",
                format!("expected at most 100, got {}", executor.retries),
            ));
        }
        let (max_parallel, slurm) = match executor.kind {
            ExecutorKind::Local => {
                self.refuse_slurm_fields(executor)?;
                let max_parallel = match executor.max_parallel {
                    Some(0) => {
                        return Err(self.error("executor.max_parallel", "expected at least 1"))
                    }
                    Some(n) => n,
                    None => (cores / per_job).max(1),
                };
                (max_parallel, None)
            }
            ExecutorKind::Slurm => {
                if executor.max_parallel.is_some() {
                    return Err(self.error(
                        "executor.max_parallel",
                        "Slurm decides how many jobs run at once; use max_submitted to limit the jobs orch keeps in its queue",
                    ));
                }
                let max_submitted = match executor.max_submitted {
                    Some(0) => {
                        return Err(self.error("executor.max_submitted", "expected at least 1"))
                    }
                    Some(n) => n,
                    None => orch_executor::slurm::DEFAULT_MAX_SUBMITTED,
                };
                self.check_cpus_per_task(executor, simulation)?;
                (max_submitted, Some(self.slurm_settings(executor)?))
            }
        };
        Ok(ExecutorConfig {
            kind: executor.kind,
            max_parallel,
            time_limit: executor.time_limit.map(|t| t.0),
            retries: executor.retries,
            slurm,
            cores_per_job: per_job,
            core_budget: (executor.kind == ExecutorKind::Local).then_some(cores),
        })
    }

    /// `cpus_per_task` of a built-in solver run as one process (the native kernel and
    /// YADE on `cores_per_job` threads, LIGGGHTS on one rank) must be its threads: more
    /// CPUs would sit idle and still be charged, fewer would be shared by its threads. A
    /// user's own deck and MPI ranks (which may be given several CPUs each, for memory
    /// bandwidth) keep the override.
    fn check_cpus_per_task(
        &self,
        executor: &ExecutorFile,
        simulation: &dyn Simulation,
    ) -> Result<(), StudyError> {
        let command = simulation.command();
        let threads = command.cores.max(1);
        let Some(cpus) = executor.cpus_per_task.map(|c| c as usize) else {
            return Ok(());
        };
        if command.mpi
            || cpus == threads
            || cpus == 0
            || simulation.equipment_name() == orch_adapters::custom::EQUIPMENT
        {
            return Ok(());
        }
        let solver = simulation.solver_name();
        let what = if cpus > threads {
            format!(
                "{} of them would sit idle and still be charged",
                cpus - threads
            )
        } else {
            "its threads would share them".to_string()
        };
        Err(self.error(
            "executor.cpus_per_task",
            format!(
                "{cpus} CPUs per job, but the {solver} solver runs {threads} thread(s) (cores_per_job: {threads}): {what}; set cores_per_job: {cpus} to run it on {cpus} threads, and leave cpus_per_task out (it follows cores_per_job)"
            ),
        ))
    }

    /// A local study naming Slurm options is a mistake worth telling.
    pub(super) fn refuse_slurm_fields(&self, executor: &ExecutorFile) -> Result<(), StudyError> {
        let given = [
            ("partition", executor.partition.is_some()),
            ("cpus_per_task", executor.cpus_per_task.is_some()),
            ("mem", executor.mem.is_some()),
            ("account", executor.account.is_some()),
            ("qos", executor.qos.is_some()),
            ("extra_sbatch", !executor.extra_sbatch.is_empty()),
            ("max_submitted", executor.max_submitted.is_some()),
            ("poll_interval", executor.poll_interval.is_some()),
            ("array_size", executor.array_size.is_some()),
        ];
        match given.iter().find(|(_, set)| *set) {
            Some((name, _)) => Err(self.error(
                &format!("executor.{name}"),
                "is a Slurm option; add `kind: slurm` to the executor, or remove it",
            )),
            None => Ok(()),
        }
    }

    pub(super) fn slurm_settings(
        &self,
        executor: &ExecutorFile,
    ) -> Result<SlurmSettings, StudyError> {
        // A value goes into an `#SBATCH --name=value` line: one word, no line breaks.
        let word = |name: &str, value: &Option<String>| -> Result<Option<String>, StudyError> {
            match value {
                Some(v) if v.is_empty() || v.chars().any(|c| c.is_whitespace() || c == '\'') => {
                    Err(self.error(
                        &format!("executor.{name}"),
                        format!("expected one word without spaces or quotes, got {v:?}"),
                    ))
                }
                other => Ok(other.clone()),
            }
        };
        let mem = word("mem", &executor.mem)?;
        if let Some(mem) = &mem {
            let digits = mem.trim_end_matches(['K', 'M', 'G', 'T']);
            if digits.is_empty()
                || !digits.chars().all(|c| c.is_ascii_digit())
                || mem.len() - digits.len() > 1
            {
                return Err(self.error(
                    "executor.mem",
                    format!("expected a size as sbatch writes it (4000, 500M, 2G), got {mem:?}"),
                ));
            }
        }
        if executor.cpus_per_task == Some(0) {
            return Err(self.error("executor.cpus_per_task", "expected at least 1"));
        }
        if executor.array_size == Some(0) {
            return Err(self.error(
                "executor.array_size",
                "expected at least 1 (1 submits each job with an sbatch of its own)",
            ));
        }
        for (i, option) in executor.extra_sbatch.iter().enumerate() {
            if !option.starts_with("--") || option.contains('\n') || option.len() < 3 {
                return Err(self.error(
                    &format!("executor.extra_sbatch[{i}]"),
                    format!(
                        "expected one sbatch option such as `--constraint=avx2`, got {option:?}"
                    ),
                ));
            }
        }
        let poll_interval = executor
            .poll_interval
            .map_or(orch_executor::slurm::DEFAULT_POLL_INTERVAL, |t| t.0);
        if poll_interval < Duration::from_millis(200) {
            return Err(self.error(
                "executor.poll_interval",
                "expected at least 200ms: every poll is a call to slurmctld",
            ));
        }
        Ok(SlurmSettings {
            partition: word("partition", &executor.partition)?,
            cpus_per_task: executor.cpus_per_task,
            mem,
            account: word("account", &executor.account)?,
            qos: word("qos", &executor.qos)?,
            extra_sbatch: executor.extra_sbatch.clone(),
            time_limit: executor.time_limit.map(|t| t.0),
            poll_interval,
            array_size: executor.array_size,
        })
    }
}
