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

/// Why no batch script can be written for a job.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScriptError {
    /// A value that would reach the script holds a control character (a newline would
    /// end its line and start another).
    #[error("{what} {value:?} contains the control character {character:?}, which a Slurm batch script cannot carry; {remedy}")]
    ControlCharacter {
        /// What the value is (`the run directory`, `executor.partition`).
        what: String,
        /// The value, shown with its control characters escaped.
        value: String,
        /// The first control character in it.
        character: char,
        /// What the user should do.
        remedy: &'static str,
    },
    /// The solver's environment has a variable name a shell cannot `export`.
    #[error("the solver's environment variable name {0:?} is not a shell name (letters, digits and `_`, not starting with a digit); {COMMAND_REMEDY}")]
    NotAName(String),
}

/// What to do about a control character in a path of the project.
pub const PATH_REMEDY: &str = "move the project to a directory whose path has no control characters (or pass --project-dir) and submit again";
/// What to do about a control character in the study file's Slurm options.
const SETTING_REMEDY: &str = "remove it from the study file's `executor:` section and submit again";
/// What to do about a control character in the solver's command or environment.
const COMMAND_REMEDY: &str =
    "remove it from the study's parameters or the solver's installation path and submit again";

/// Refuses `value` when it holds a control character; `what` names it in the error.
pub fn check_value(what: &str, value: &str, remedy: &'static str) -> Result<(), ScriptError> {
    match value.chars().find(|c| c.is_control()) {
        Some(character) => Err(ScriptError::ControlCharacter {
            what: what.to_string(),
            value: value.to_string(),
            character,
            remedy,
        }),
        None => Ok(()),
    }
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

/// Quotes the value of an `#SBATCH` option (`--name=value`, or a bare word) for
/// sbatch's reader of those lines, which is not a shell: it splits at white space,
/// drops double quotes, takes the character after a backslash as it is and ends the
/// line at an unescaped `#`. A value with any of these is double-quoted with `"`,
/// `\` and `#` escaped.
pub fn sbatch_quote(option: &str) -> String {
    let (name, value) = match option.split_once('=') {
        Some((name, value)) if name.starts_with('-') => (Some(name), value),
        _ => (None, option),
    };
    let plain = !value.is_empty()
        && !value
            .chars()
            .any(|c| c.is_whitespace() || "\"'\\#".contains(c));
    let quoted = if plain {
        value.to_string()
    } else {
        let mut quoted = String::from("\"");
        for c in value.chars() {
            if "\"\\#".contains(c) {
                quoted.push('\\');
            }
            quoted.push(c);
        }
        quoted.push('"');
        quoted
    };
    match name {
        Some(name) => format!("{name}={quoted}"),
        None => quoted,
    }
}

/// `(--ntasks, --cpus-per-task)` of a job: a threaded solver (the native kernel, YADE)
/// is one task on as many CPUs as its command's cores; an MPI solver (LIGGGHTS on
/// several ranks, whose `mpirun` starts its ranks inside the allocation) is one task
/// per rank on one CPU each. `executor.cpus_per_task` overrides the CPUs per task.
/// Both on one node: orch's jobs are small enough, and `mpirun` then needs no hosts.
pub fn tasks_and_cpus(spec: &LaunchSpec, settings: &SlurmSettings) -> (usize, u32) {
    let cores = spec.command.cores.max(1);
    let (tasks, cpus) = if spec.command.mpi {
        (cores, 1)
    } else {
        (1, cores as u32)
    };
    (tasks, settings.cpus_per_task.unwrap_or(cpus))
}

/// The batch script for `spec`, or why none can be written: every value that reaches
/// it is refused when it holds a control character and quoted otherwise (shell
/// quoting in the script's commands, sbatch's quoting in `#SBATCH` lines).
pub fn batch_script(spec: &LaunchSpec, settings: &SlurmSettings) -> Result<String, ScriptError> {
    let run_dir = spec.run_dir.display().to_string();
    check_value("the run directory", &run_dir, PATH_REMEDY)?;
    check_value("the job name", &spec.name, COMMAND_REMEDY)?;
    check_value("the solver program", &spec.command.program, COMMAND_REMEDY)?;
    for arg in &spec.command.args {
        check_value("an argument of the solver", arg, COMMAND_REMEDY)?;
    }
    for (key, value) in &spec.command.env {
        let identifier = key.chars().next().is_some_and(|c| !c.is_ascii_digit())
            && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !identifier {
            return Err(ScriptError::NotAName(key.clone()));
        }
        check_value(
            &format!("the environment variable {key}"),
            value,
            COMMAND_REMEDY,
        )?;
    }
    let (tasks, cpus) = tasks_and_cpus(spec, settings);
    let mut options = vec![
        format!("--job-name={}", slurm_job_name(&spec.name)),
        format!("--chdir={run_dir}"),
        format!("--output={SLURM_OUTPUT}"),
        "--open-mode=append".to_string(),
        "--nodes=1".to_string(),
        format!("--ntasks={tasks}"),
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
            check_value(&format!("executor.{name}"), value, SETTING_REMEDY)?;
            options.push(format!("--{name}={value}"));
        }
    }
    for option in &settings.extra_sbatch {
        check_value("executor.extra_sbatch", option, SETTING_REMEDY)?;
        options.push(option.clone());
    }

    let mut script = String::from("#!/bin/sh\n");
    for option in &options {
        let _ = writeln!(script, "#SBATCH {}", sbatch_quote(option));
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
    Ok(script)
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
                mpi: false,
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
        insta::assert_snapshot!(batch_script(&spec(), &settings).unwrap());
    }

    #[test]
    fn batch_script_with_defaults_asks_for_the_solver_cores_and_nothing_else() {
        let script = batch_script(&spec(), &SlurmSettings::default()).unwrap();
        assert!(script.contains("#SBATCH --cpus-per-task=1\n"), "{script}");
        for absent in ["--time", "--partition", "--mem", "--account", "--qos"] {
            assert!(!script.contains(absent), "{absent} in {script}");
        }
    }

    #[test]
    fn threaded_jobs_are_one_task_on_many_cpus_and_mpi_jobs_one_task_per_rank() {
        let defaults = SlurmSettings::default();
        let mut threads = spec();
        threads.command.cores = 2;
        threads
            .command
            .args
            .extend(["--threads".into(), "2".into()]);
        let script = batch_script(&threads, &defaults).unwrap();
        assert!(
            script.contains("#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=2\n"),
            "{script}"
        );

        let mpi = LaunchSpec {
            command: CommandSpec {
                program: "mpirun".into(),
                args: ["-np", "2", "liggghts", "-in", "hopper.in"]
                    .map(String::from)
                    .to_vec(),
                env: BTreeMap::from([("OMPI_ALLOW_RUN_AS_ROOT".to_string(), "1".to_string())]),
                cores: 2,
                mpi: true,
                log_file: "log.liggghts".into(),
            },
            ..spec()
        };
        let script = batch_script(&mpi, &defaults).unwrap();
        assert!(
            script.contains("#SBATCH --nodes=1\n#SBATCH --ntasks=2\n#SBATCH --cpus-per-task=1\n"),
            "{script}"
        );
        assert!(
            script.contains("export OMPI_ALLOW_RUN_AS_ROOT=1\n"),
            "{script}"
        );
        assert!(
            script.contains("mpirun -np 2 liggghts -in hopper.in > stdout.txt"),
            "{script}"
        );
        // The study's cpus_per_task still decides the CPUs of each task.
        let four = SlurmSettings {
            cpus_per_task: Some(4),
            ..SlurmSettings::default()
        };
        assert_eq!(tasks_and_cpus(&mpi, &four), (2, 4));
        assert_eq!(tasks_and_cpus(&threads, &four), (1, 4));
        assert_eq!(tasks_and_cpus(&spec(), &defaults), (1, 1));
    }

    #[test]
    fn time_limits_round_up_to_whole_minutes() {
        assert_eq!(time_limit_minutes(Duration::from_secs(1)), 1);
        assert_eq!(time_limit_minutes(Duration::from_secs(60)), 1);
        assert_eq!(time_limit_minutes(Duration::from_secs(61)), 2);
        assert_eq!(time_limit_minutes(Duration::from_secs(7200)), 120);
    }

    fn spec_in(run_dir: &str) -> LaunchSpec {
        LaunchSpec {
            run_dir: run_dir.into(),
            ..spec()
        }
    }

    /// What `/bin/sh` makes of `words` (shell-quoted text): each word on its own line.
    fn sh_words(words: &str) -> String {
        let output = std::process::Command::new("/bin/sh")
            .arg("-c")
            .arg(format!("printf '%s\\n' {words}"))
            .current_dir(std::env::temp_dir())
            .output()
            .unwrap();
        assert!(output.status.success(), "{words}");
        String::from_utf8(output.stdout).unwrap()
    }

    /// What sbatch makes of an `#SBATCH` line's option, after its reader (see
    /// [`sbatch_quote`]): quotes dropped, escaped characters kept, split at blanks.
    fn sbatch_words(option: &str) -> Vec<String> {
        let mut words = vec![String::new()];
        let (mut quoted, mut escaped) = (false, false);
        for c in option.chars() {
            if escaped {
                escaped = false;
                words.last_mut().unwrap().push(c);
            } else if c == '\\' {
                escaped = true;
            } else if c == '"' {
                quoted = !quoted;
            } else if c == '#' {
                break;
            } else if c.is_whitespace() && !quoted {
                words.push(String::new());
            } else {
                words.last_mut().unwrap().push(c);
            }
        }
        words
    }

    #[test]
    fn a_newline_in_the_run_directory_is_refused_naming_the_path_and_what_to_do() {
        let error = batch_script(
            &spec_in("/data/x\nrm -rf ~\n/.orch/runs/q/p0"),
            &SlurmSettings::default(),
        )
        .unwrap_err();
        assert_eq!(
            error.to_string(),
            "the run directory \"/data/x\\nrm -rf ~\\n/.orch/runs/q/p0\" contains the control character '\\n', which a Slurm batch script cannot carry; move the project to a directory whose path has no control characters (or pass --project-dir) and submit again"
        );
        let tab = batch_script(&spec_in("/data/a\tb"), &SlurmSettings::default());
        assert!(tab.is_err(), "{tab:?}");
    }

    #[test]
    fn quotes_command_substitution_and_spaces_in_paths_stay_one_word() {
        for dir in [
            "/data/it's here/runs/q/p0",
            "/data/$(touch pwned)/runs/q/p0",
            "/data/`id`;rm -rf ~/runs",
            "/data/a \"b\" #c\\d/runs",
        ] {
            let script = batch_script(&spec_in(dir), &SlurmSettings::default()).unwrap();
            let chdir = script
                .lines()
                .find_map(|l| l.strip_prefix("#SBATCH --chdir="))
                .unwrap();
            assert_eq!(sbatch_words(chdir), vec![dir.to_string()], "{script}");
            let cd = script.lines().find_map(|l| l.strip_prefix("cd ")).unwrap();
            let cd = cd.strip_suffix(" || exit 97").unwrap();
            assert_eq!(sh_words(cd), format!("{dir}\n"), "{script}");
        }
    }

    #[test]
    fn slurm_options_and_solver_words_are_refused_or_quoted() {
        let settings = SlurmSettings {
            partition: Some("debug\nrm -rf ~".into()),
            ..SlurmSettings::default()
        };
        let error = batch_script(&spec(), &settings).unwrap_err().to_string();
        assert!(
            error.starts_with(
                "executor.partition \"debug\\nrm -rf ~\" contains the control character '\\n'"
            ),
            "{error}"
        );
        assert!(
            error.ends_with("remove it from the study file's `executor:` section and submit again"),
            "{error}"
        );

        let settings = SlurmSettings {
            extra_sbatch: vec!["--comment=two words # not a comment".into()],
            ..SlurmSettings::default()
        };
        let script = batch_script(&spec(), &settings).unwrap();
        let comment = script
            .lines()
            .find_map(|l| l.strip_prefix("#SBATCH --comment="))
            .unwrap();
        assert_eq!(sbatch_words(comment), vec!["two words # not a comment"]);

        let mut hostile = spec();
        hostile.command.args.push("$(touch pwned) 'x'".into());
        hostile
            .command
            .env
            .insert("ORCH_NOTE".into(), "a;b $(c)".into());
        let script = batch_script(&hostile, &SlurmSettings::default()).unwrap();
        let run = script.lines().find(|l| l.contains("> stdout.txt")).unwrap();
        let words = run.split(" > stdout.txt").next().unwrap();
        assert_eq!(
            sh_words(words),
            "/usr/local/bin/orch-dem\nrun\nhopper.toml\n--log\nit's.log\n$(touch pwned) 'x'\n"
        );
        assert!(script.contains("export ORCH_NOTE='a;b $(c)'\n"), "{script}");

        hostile.command.args.push("two\nlines".into());
        assert!(batch_script(&hostile, &SlurmSettings::default()).is_err());
        let mut bad_name = spec();
        bad_name.command.env.insert("A;B".into(), "1".into());
        assert_eq!(
            batch_script(&bad_name, &SlurmSettings::default()),
            Err(ScriptError::NotAName("A;B".into()))
        );
    }

    #[test]
    fn shell_quoting_survives_quotes_and_spaces() {
        assert_eq!(shell_quote("plain/path-1.toml"), "plain/path-1.toml");
        assert_eq!(shell_quote("two words"), "'two words'");
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
        assert_eq!(shell_quote(""), "''");
    }
}
