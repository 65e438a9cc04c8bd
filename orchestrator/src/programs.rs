//! The programs a command runs: the first word, and behind the wrappers users put in
//! front of a solver (`stdbuf -oL`, `env VAR=…`, `time`, `nice`, `mpirun -np 2`,
//! `srun`, `sh -c "…"`), the solver itself. `orch submit` (and `--dry-run`) checks that
//! each is installed before anything is written, so a missing solver is found before
//! its jobs fail one by one.

/// Wrappers whose options are skipped to reach the program they run, with the options
/// that take a separate value.
const WRAPPERS: &[(&str, &[&str])] = &[
    (
        "env",
        &["-u", "--unset", "-C", "--chdir", "-S", "--split-string"],
    ),
    ("time", &["-o", "--output", "-f", "--format"]),
    ("stdbuf", &["-i", "-o", "-e"]),
    ("nice", &["-n", "--adjustment"]),
    ("nohup", &[]),
    ("timeout", &["-s", "--signal", "-k", "--kill-after"]),
    ("mpirun", MPI_OPTIONS),
    ("mpiexec", MPI_OPTIONS),
    (
        "srun",
        &[
            "-n",
            "--ntasks",
            "-c",
            "--cpus-per-task",
            "-N",
            "--nodes",
            "-p",
            "--partition",
            "-t",
            "--time",
        ],
    ),
];

/// Options of Open MPI's and MPICH's launchers that take a value.
const MPI_OPTIONS: &[&str] = &[
    "-n",
    "-np",
    "-c",
    "--np",
    "-N",
    "--npernode",
    "-H",
    "--host",
    "--hostfile",
    "--map-by",
    "--bind-to",
    "--rank-by",
    "-x",
    "--mca",
    "-mca",
    "--wdir",
    "-wdir",
];

/// Shells whose `-c` string is a command line of its own.
const SHELLS: &[&str] = &["sh", "bash", "dash", "zsh"];

/// Every program `words` (a command line, program first) runs, outermost first: the
/// first word, then each program behind a known wrapper or a shell's `-c` string.
pub fn programs_of(words: &[String]) -> Vec<String> {
    let mut programs = Vec::new();
    let mut rest: Vec<String> = words.to_vec();
    while let Some(program) = rest.first().cloned() {
        programs.push(program.clone());
        let name = program.rsplit('/').next().unwrap_or(&program).to_string();
        if SHELLS.contains(&name.as_str()) {
            // `sh -c "liggghts -in deck"`: the string's first word; `sh script.sh` runs a
            // file of the run directory, whose content is the user's.
            match rest.iter().position(|w| w == "-c") {
                Some(at) => match rest.get(at + 1) {
                    Some(line) => {
                        rest = line.split_whitespace().map(str::to_string).collect();
                        continue;
                    }
                    None => break,
                },
                None => break,
            }
        }
        let Some((_, valued)) = WRAPPERS.iter().find(|(w, _)| *w == name) else {
            break;
        };
        let mut k = 1;
        while let Some(word) = rest.get(k) {
            let is_assignment = name == "env" && word.contains('=') && !word.starts_with('-');
            if word == "--" {
                k += 1;
                break;
            }
            if !(word.starts_with('-') || is_assignment) {
                // `timeout 60 prog` and `nice 5 prog` take a leading number.
                if (name == "timeout" || name == "nice")
                    && word.chars().next().is_some_and(|c| c.is_ascii_digit())
                    && k == 1
                {
                    k += 1;
                    continue;
                }
                break;
            }
            let takes_value = valued.contains(&word.as_str()) && !word.contains('=');
            k += if takes_value { 2 } else { 1 };
        }
        rest = rest.split_off(k.min(rest.len()));
    }
    programs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn programs(line: &str) -> Vec<String> {
        let words: Vec<String> = line.split(' ').map(str::to_string).collect();
        programs_of(&words)
    }

    #[test]
    fn the_solver_behind_the_wrappers_users_write_is_found() {
        assert_eq!(programs("liggghts -in deck"), ["liggghts"]);
        assert_eq!(
            programs("stdbuf -oL liggghts -in deck"),
            ["stdbuf", "liggghts"]
        );
        assert_eq!(programs("stdbuf -o L lmp -in deck"), ["stdbuf", "lmp"]);
        assert_eq!(
            programs("mpirun -np 2 --oversubscribe liggghts -in deck"),
            ["mpirun", "liggghts"]
        );
        assert_eq!(
            programs("env OMP_NUM_THREADS=1 -u HOME time -p yade -x run.py"),
            ["env", "time", "yade"]
        );
        assert_eq!(
            programs("timeout 600 nice -n 5 srun -n 2 lmp"),
            ["timeout", "nice", "srun", "lmp"]
        );
        assert_eq!(
            programs("/usr/bin/stdbuf -oL ./solver"),
            ["/usr/bin/stdbuf", "./solver"]
        );
    }

    #[test]
    fn a_shell_c_string_is_followed_and_a_script_is_the_users() {
        let words = vec![
            "sh".to_string(),
            "-c".to_string(),
            "stdbuf -oL liggghts -in deck".to_string(),
        ];
        assert_eq!(programs_of(&words), ["sh", "stdbuf", "liggghts"]);
        assert_eq!(programs("sh run.sh"), ["sh"]);
        assert_eq!(programs("bash -e run.sh"), ["bash"]);
        assert_eq!(programs("python3 post.py"), ["python3"]);
    }
}
