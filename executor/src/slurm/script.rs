//! The batch script of one job, built without touching anything (pure, snapshot-tested).
//!
//! The script runs the solver in the run directory and records there what the local
//! wrapper records: `stdout.txt`, `stderr.txt`, the exit status in `exit_status`
//! (through a rename, never half-written) and start/end lines in `orch-attempts.log`.
//! So a job's outcome is known from its run directory whether or not Slurm accounting
//! is enabled, and after slurmctld has forgotten the job (`MinJobAge`).
//!
//! Jobs submitted together go out as one job array ([`array_script`]): its task `i`
//! runs the batch script of the run directory on line `i + 1` of the array's task
//! list, so each task records its outcome exactly as a job of its own does.

use std::fmt::Write;
use std::time::Duration;

use super::SlurmSettings;
use crate::{LaunchSpec, ATTEMPTS_LOG, EXIT_STATUS_FILE, LINE_BUFFERED, STDERR_FILE, STDOUT_FILE};

/// File name of the batch script in the run directory.
pub const BATCH_SCRIPT: &str = "orch-job.sbatch";
/// Slurm's own output of the batch script (`%j`: the job id), in the run directory.
pub const SLURM_OUTPUT: &str = "slurm-%j.out";
/// File name of an array's batch script, in the array's directory.
pub const ARRAY_SCRIPT: &str = "orch-array.sbatch";
/// The array's task list, in its directory: one run directory per line, task `i` on
/// line `i + 1`.
pub const ARRAY_TASKS: &str = "tasks";
/// Slurm's own output of an array task's script (`%A_%a`: array job id and task), in
/// the array's directory.
pub const ARRAY_OUTPUT: &str = "slurm-%A_%a.out";

/// The Slurm job name of an orch job: `orch.<study>.<job>` (study and job names are
/// letters, digits, `-` and `_`), so `squeue --name` finds it again.
pub fn slurm_job_name(spec_name: &str) -> String {
    format!("orch.{}", spec_name.replace('/', "."))
}

/// The Slurm job name of the arrays orch submits for `study`: `orch-array.<study>`, so
/// `squeue --name` finds them again.
pub fn array_job_name(study: &str) -> String {
    format!("orch-array.{study}")
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
/// A threaded job stays on one node; an MPI job's ranks go wherever Slurm finds CPUs,
/// across nodes when one has too few (`mpirun` reads the allocation from Slurm).
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
    let mut options = vec![
        format!("--job-name={}", slurm_job_name(&spec.name)),
        format!("--chdir={run_dir}"),
        format!("--output={SLURM_OUTPUT}"),
    ];
    options.extend(resource_options(spec, settings)?);

    let mut script = sbatch_header(&options);
    let _ = writeln!(
        script,
        "# Written by orch for job {}: runs the solver and records how it ended in this\n\
         # directory, so the outcome is known without Slurm accounting. Submitted alone or\n\
         # run by a task of a job array (then its #SBATCH lines are the array's business).",
        spec.name
    );
    let _ = writeln!(script, "cd {} || exit 97", shell_quote(&run_dir));
    // The handle orch knows the attempt by: the job, or the array's task.
    let _ = writeln!(
        script,
        "id=$SLURM_JOB_ID\n\
         [ -n \"$SLURM_ARRAY_TASK_ID\" ] && id=${{SLURM_ARRAY_JOB_ID}}_$SLURM_ARRAY_TASK_ID\n\
         echo \"start slurm:$id $(date +%s.%N) $(hostname) $SLURM_JOB_NODELIST\" >> {ATTEMPTS_LOG}"
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
        "{LINE_BUFFERED}\n\
         $line_buffered {} > {STDOUT_FILE} 2> {STDERR_FILE} < /dev/null\n\
         rc=$?\n\
         echo $rc > {EXIT_STATUS_FILE}.tmp && mv {EXIT_STATUS_FILE}.tmp {EXIT_STATUS_FILE}\n\
         echo \"end $rc $(date +%s.%N)\" >> {ATTEMPTS_LOG}\n\
         exit $rc",
        command.join(" ")
    );
    Ok(script)
}

/// The batch script of a job array of `tasks` tasks (indices `0..tasks`) submitted
/// from `array_dir` for `study`: task `i` runs the [`BATCH_SCRIPT`] of the run
/// directory on line `i + 1` of [`ARRAY_TASKS`]. Every task asks for what `first`
/// asks for (the caller groups jobs by what they ask for).
pub fn array_script(
    study: &str,
    array_dir: &std::path::Path,
    tasks: usize,
    first: &LaunchSpec,
    settings: &SlurmSettings,
) -> Result<String, ScriptError> {
    let dir = array_dir.display().to_string();
    check_value("the array directory", &dir, PATH_REMEDY)?;
    check_value("the study name", study, COMMAND_REMEDY)?;
    let mut options = vec![
        format!("--job-name={}", array_job_name(study)),
        format!("--array=0-{}", tasks.saturating_sub(1)),
        format!("--chdir={dir}"),
        format!("--output={ARRAY_OUTPUT}"),
    ];
    options.extend(resource_options(first, settings)?);
    let mut script = sbatch_header(&options);
    let _ = writeln!(
        script,
        "# Written by orch for {tasks} jobs of study {study}: task i runs the batch script\n\
         # of the run directory on line i + 1 of {ARRAY_TASKS}, which records how the job ended.\n\
         line=$((SLURM_ARRAY_TASK_ID + 1))\n\
         dir=$(sed -n \"${{line}}p\" {ARRAY_TASKS})\n\
         [ -n \"$dir\" ] || {{ echo \"orch: no line $line in $PWD/{ARRAY_TASKS}\" >&2; exit 98; }}\n\
         exec /bin/sh \"$dir/{BATCH_SCRIPT}\""
    );
    Ok(script)
}

/// What a job asks Slurm for, the same alone or as an array task: its tasks and CPUs,
/// time, and the study's `executor:` options.
pub fn resource_options(
    spec: &LaunchSpec,
    settings: &SlurmSettings,
) -> Result<Vec<String>, ScriptError> {
    let (tasks, cpus) = tasks_and_cpus(spec, settings);
    let mut options = vec!["--open-mode=append".to_string()];
    if !spec.command.mpi {
        options.push("--nodes=1".to_string());
    }
    options.extend([
        format!("--ntasks={tasks}"),
        format!("--cpus-per-task={cpus}"),
        // orch decides about another attempt (its retry budget), not Slurm.
        "--no-requeue".to_string(),
    ]);
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
    Ok(options)
}

/// `#!/bin/sh` and one `#SBATCH` line per option.
fn sbatch_header(options: &[String]) -> String {
    let mut script = String::from("#!/bin/sh\n");
    for option in options {
        let _ = writeln!(script, "#SBATCH {}", sbatch_quote(option));
    }
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
                mpi: false,
                same_result_on_any_cores: false,
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
            array_size: None,
        };
        insta::assert_snapshot!(batch_script(&spec(), &settings).unwrap());
    }

    #[test]
    fn array_script_runs_the_batch_script_of_the_task_s_line() {
        let settings = SlurmSettings {
            time_limit: Some(Duration::from_secs(300)),
            ..SlurmSettings::default()
        };
        let dir = std::path::Path::new("/data/.orch/runs/quickstart/slurm-arrays/a1");
        insta::assert_snapshot!(array_script("quickstart", dir, 50, &spec(), &settings).unwrap());
    }

    /// Runs `script` with `sh` as array task `task` in `dir`; its standard output.
    fn run_as_task(script: &str, dir: &std::path::Path, task: u32) -> std::process::Output {
        std::process::Command::new("/bin/sh")
            .arg("-c")
            .arg(script)
            .current_dir(dir)
            .env("SLURM_ARRAY_TASK_ID", task.to_string())
            .env("SLURM_ARRAY_JOB_ID", "77")
            .env("SLURM_JOB_ID", "80")
            .output()
            .unwrap()
    }

    #[test]
    fn each_array_task_runs_its_own_job_and_records_it_under_the_task_handle() {
        let root = tempfile::tempdir().unwrap();
        let array = root.path().join("array");
        std::fs::create_dir(&array).unwrap();
        let mut lines = String::new();
        for name in ["p0", "p 1"] {
            let run_dir = root.path().join(name);
            std::fs::create_dir(&run_dir).unwrap();
            let job = LaunchSpec {
                name: format!("q/{name}"),
                run_dir: run_dir.clone(),
                command: CommandSpec {
                    program: "sh".into(),
                    args: vec!["-c".into(), format!("echo ran {name}; exit 3")],
                    env: BTreeMap::new(),
                    cores: 1,
                    mpi: false,
                    same_result_on_any_cores: false,
                    log_file: "log".into(),
                },
            };
            let text = batch_script(&job, &SlurmSettings::default()).unwrap();
            std::fs::write(run_dir.join(BATCH_SCRIPT), text).unwrap();
            lines.push_str(&format!("{}\n", run_dir.display()));
        }
        std::fs::write(array.join(ARRAY_TASKS), lines).unwrap();
        let script = array_script("q", &array, 2, &spec(), &SlurmSettings::default()).unwrap();
        let output = run_as_task(&script, &array, 1);
        assert_eq!(output.status.code(), Some(3), "{output:?}");
        let second = root.path().join("p 1");
        let read = |file: &str| std::fs::read_to_string(second.join(file)).unwrap();
        assert_eq!(read(STDOUT_FILE), "ran p 1\n");
        assert_eq!(read(EXIT_STATUS_FILE), "3\n");
        assert!(
            read(ATTEMPTS_LOG).starts_with("start slurm:77_1 "),
            "{}",
            read(ATTEMPTS_LOG)
        );
        assert!(!root.path().join("p0").join(EXIT_STATUS_FILE).exists());
        // A task past the list says so and fails.
        let output = run_as_task(&script, &array, 2);
        assert_eq!(output.status.code(), Some(98));
        assert!(String::from_utf8_lossy(&output.stderr).contains("no line 3 in"));
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
                same_result_on_any_cores: false,
                log_file: "log.liggghts".into(),
            },
            ..spec()
        };
        let script = batch_script(&mpi, &defaults).unwrap();
        // Its ranks may spread over nodes: no --nodes=1.
        assert!(
            script.contains(
                "#SBATCH --open-mode=append\n#SBATCH --ntasks=2\n#SBATCH --cpus-per-task=1\n"
            ),
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
