//! The batch script of one job, built without touching anything (pure, snapshot-tested).
//!
//! The script runs the solver in the run directory and records there what the local
//! wrapper records: `stdout.txt`, `stderr.txt`, the exit status in `exit_status`
//! (through a rename, never half-written) and start/end lines in `orch-attempts.log`.
//! So a job's outcome is known from its run directory whether or not Slurm accounting
//! is enabled, and after slurmctld has forgotten the job (`MinJobAge`).

use std::fmt::Write;
use std::time::Duration;

use super::SlurmSettings;
use crate::executor::{LaunchSpec, ATTEMPTS_LOG, EXIT_STATUS_FILE, STDERR_FILE, STDOUT_FILE};

/// File name of the batch script in the run directory.
pub const BATCH_SCRIPT: &str = "orch-job.sbatch";
/// Slurm's own output of the batch script (`%j`: the job id), in the run directory.
pub const SLURM_OUTPUT: &str = "slurm-%j.out";

/// The Slurm job name of an orch job: `orch.<study>.<job>` (study and job names are
/// letters, digits, `-` and `_`), so `squeue --name` finds it again.
pub fn slurm_job_name(spec_name: &str) -> String {
    format!("orch.{}", spec_name.replace('/', "."))
}

/// Slurm's `--time` in whole minutes, rounded up (Slurm counts minutes).
pub fn time_limit_minutes(limit: Duration) -> u64 {
    limit.as_secs().div_ceil(60).max(1)
}

/// Quotes `text` for `/bin/sh`.
pub fn shell_quote(text: &str) -> String {
    if !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./:=+,@%".contains(c))
    {
        return text.to_string();
    }
    format!("'{}'", text.replace('\'', r"'\''"))
}

/// The batch script for `spec`.
pub fn batch_script(spec: &LaunchSpec, settings: &SlurmSettings) -> String {
    let run_dir = spec.run_dir.display().to_string();
    let cpus = settings
        .cpus_per_task
        .unwrap_or(spec.command.cores.max(1) as u32);
    let mut options = vec![
        format!("--job-name={}", slurm_job_name(&spec.name)),
        format!("--chdir={run_dir}"),
        format!("--output={SLURM_OUTPUT}"),
        "--open-mode=append".to_string(),
        "--nodes=1".to_string(),
        "--ntasks=1".to_string(),
        format!("--cpus-per-task={cpus}"),
        // orch decides about another attempt (its retry budget), not Slurm.
        "--no-requeue".to_string(),
    ];
    if let Some(limit) = settings.time_limit {
        options.push(format!("--time={}", time_limit_minutes(limit)));
    }
    let optional = [
        ("partition", &settings.partition),
        ("mem", &settings.mem),
        ("account", &settings.account),
        ("qos", &settings.qos),
    ];
    for (name, value) in optional {
        if let Some(value) = value {
            options.push(format!("--{name}={value}"));
        }
    }
    options.extend(settings.extra_sbatch.iter().cloned());

    let mut script = String::from("#!/bin/sh\n");
    for option in &options {
        let _ = writeln!(script, "#SBATCH {option}");
    }
    let _ = writeln!(
        script,
        "# Written by orch for job {}: runs the solver and records how it ended in this\n\
         # directory, so the outcome is known without Slurm accounting.",
        spec.name
    );
    let _ = writeln!(script, "cd {} || exit 97", shell_quote(&run_dir));
    let _ = writeln!(
        script,
        "echo \"start slurm:$SLURM_JOB_ID $(date +%s.%N) $(hostname)\" >> {ATTEMPTS_LOG}"
    );
    for (key, value) in &spec.command.env {
        let _ = writeln!(script, "export {key}={}", shell_quote(value));
    }
    let command: Vec<String> = std::iter::once(&spec.command.program)
        .chain(&spec.command.args)
        .map(|word| shell_quote(word))
        .collect();
    let _ = writeln!(
        script,
        "{} > {STDOUT_FILE} 2> {STDERR_FILE} < /dev/null\n\
         rc=$?\n\
         echo $rc > {EXIT_STATUS_FILE}.tmp && mv {EXIT_STATUS_FILE}.tmp {EXIT_STATUS_FILE}\n\
         echo \"end $rc $(date +%s.%N)\" >> {ATTEMPTS_LOG}\n\
         exit $rc",
        command.join(" ")
    );
    script
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use orch_adapters::CommandSpec;

    use super::*;

    fn spec() -> LaunchSpec {
        LaunchSpec {
            name: "quickstart/p004r0".into(),
            run_dir: "/data/.orch/runs/quickstart/p004r0".into(),
            command: CommandSpec {
                program: "/usr/local/bin/orch-dem".into(),
                args: vec![
                    "run".into(),
                    "hopper.toml".into(),
                    "--log".into(),
                    "it's.log".into(),
                ],
                env: BTreeMap::from([("OMP_NUM_THREADS".to_string(), "1".to_string())]),
                cores: 1,
                log_file: "log.native".into(),
            },
        }
    }

    #[test]
    fn batch_script_with_every_option() {
        let settings = SlurmSettings {
            partition: Some("debug".into()),
            cpus_per_task: Some(2),
            mem: Some("2G".into()),
            account: Some("granular".into()),
            qos: Some("short".into()),
            extra_sbatch: vec!["--constraint=avx2".into(), "--exclusive".into()],
            time_limit: Some(Duration::from_secs(90)),
            poll_interval: Duration::from_secs(5),
        };
        insta::assert_snapshot!(batch_script(&spec(), &settings));
    }

    #[test]
    fn batch_script_with_defaults_asks_for_the_solver_cores_and_nothing_else() {
        let script = batch_script(&spec(), &SlurmSettings::default());
        assert!(script.contains("#SBATCH --cpus-per-task=1\n"), "{script}");
        for absent in ["--time", "--partition", "--mem", "--account", "--qos"] {
            assert!(!script.contains(absent), "{absent} in {script}");
        }
    }

    #[test]
    fn time_limits_round_up_to_whole_minutes() {
        assert_eq!(time_limit_minutes(Duration::from_secs(1)), 1);
        assert_eq!(time_limit_minutes(Duration::from_secs(60)), 1);
        assert_eq!(time_limit_minutes(Duration::from_secs(61)), 2);
        assert_eq!(time_limit_minutes(Duration::from_secs(7200)), 120);
    }

    #[test]
    fn shell_quoting_survives_quotes_and_spaces() {
        assert_eq!(shell_quote("plain/path-1.toml"), "plain/path-1.toml");
        assert_eq!(shell_quote("two words"), "'two words'");
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
        assert_eq!(shell_quote(""), "''");
    }
}
