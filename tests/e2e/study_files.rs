//! Bad study files: refused with file, line, column and field; nothing is written.

use crate::support::{text, Project};

const GOOD: &str = "\
name: tiny
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028}
design: {type: full_factorial, levels: 2}
";

/// Submits `study` and returns stderr, asserting exit code 2 and no project written.
fn refused(study: &str) -> String {
    let project = Project::new();
    let file = project.write("study.yaml", study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2), "{}", text(&output.stderr));
    assert!(
        !project.project_dir().exists(),
        "a refused study wrote {}",
        project.project_dir().display()
    );
    text(&output.stderr)
}

/// Submits `study` with nothing on PATH and returns stderr, asserting exit code 2 and
/// no project written.
fn refused_with_empty_path(study: &str) -> String {
    let project = Project::new();
    let file = project.write("study.yaml", study);
    let output = project
        .orch(&["submit", file.to_str().unwrap()])
        .env("PATH", project.dir.path())
        .output()
        .unwrap();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(!project.project_dir().exists());
    stderr
}

#[test]
fn every_kind_of_bad_study_file_is_refused_before_anything_is_written() {
    let cases = [
        (
            GOOD.replace("levels: 2", "levels: 2, colour: red"),
            "study.yaml:5:43: design.colour: unknown field `colour`",
        ),
        (
            GOOD.replace("min: 0.020", "min: wide"),
            "study.yaml:4:34: factors[0].min: invalid type: string \"wide\", expected f64",
        ),
        (
            GOOD.replace("min: 0.020, max: 0.028", "min: 0.028, max: 0.020"),
            "study.yaml:4:46: factors[0].max: expected max greater than min (0.028), got 0.02",
        ),
        (
            GOOD.replace("solver: liggghts", "solver: edem"),
            "study.yaml:2:9: solver: unknown solver `edem`; expected one of: liggghts",
        ),
        (
            GOOD.replace(
                "solver: liggghts\n",
                "solver: liggghts\ntemplate: mine.tera\n",
            ),
            "study.yaml:3:11: template: cannot read ",
        ),
    ];
    for (study, expected) in cases {
        let stderr = refused(&study);
        assert!(
            stderr.contains(expected),
            "expected `{expected}` in:\n{stderr}"
        );
        assert!(stderr.contains("nothing was written"), "{stderr}");
    }
}

/// Job counts far past the run limit are refused at once (not after minutes of
/// building points, nor by aborting on a huge allocation), and nothing is written.
#[test]
fn oversized_designs_replicates_and_samples_are_refused_at_once() {
    let two = GOOD.replace(
        "  - {name: outlet_diameter, min: 0.020, max: 0.028}\n",
        "  - {name: outlet_diameter, min: 0.020, max: 0.028}\n  - {name: amplitude, min: 0.0, max: 0.0006}\n",
    );
    let three = two.replace(
        "  - {name: amplitude, min: 0.0, max: 0.0006}\n",
        "  - {name: amplitude, min: 0.0, max: 0.0006}\n  - {name: frequency, min: 20, max: 50}\n",
    );
    let cases = [
        (
            two.replace(
                "{type: full_factorial, levels: 2}",
                "{type: central_composite, center_points: 100000000000}",
            ),
            "study.yaml:6:50: design.center_points: expected at most 100000 centre points, got 100000000000",
        ),
        (
            three.replace(
                "{type: full_factorial, levels: 2}",
                "{type: box_behnken, center_points: 1000000}",
            ),
            "study.yaml:7:44: design.center_points: expected at most 100000 centre points, got 1000000",
        ),
        (
            format!("{GOOD}replicates: 4000000000\n"),
            "study.yaml:6:13: replicates: expected 1 to 100000 replicates, got 4000000000",
        ),
        (
            format!("{two}uncertainty:\n  samples: 10000000000000\n  parameters: [{{name: amplitude, distribution: uniform, low: 0.0, high: 0.0006}}]\n"),
            "study.yaml:8:12: uncertainty.samples: expected at most 10000000 samples (10^7), got 10000000000000",
        ),
    ];
    for (study, expected) in cases {
        let started = std::time::Instant::now();
        let stderr = refused(&study);
        assert!(
            stderr.contains(expected),
            "expected `{expected}` in:\n{stderr}"
        );
        assert!(stderr.contains("nothing was written"), "{stderr}");
        assert!(
            started.elapsed() < std::time::Duration::from_secs(10),
            "took {:?} to refuse",
            started.elapsed()
        );
    }
}

#[test]
fn a_missing_solver_is_refused_before_anything_is_written() {
    let stderr = refused_with_empty_path(GOOD);
    assert!(
        stderr.contains("the liggghts solver `liggghts` is not installed"),
        "{stderr}"
    );
    assert!(stderr.contains("apt-get install -y liggghts"), "{stderr}");
}

#[test]
fn a_slurm_study_without_slurm_commands_is_refused_before_anything_is_written() {
    let stderr = refused_with_empty_path(&GOOD.replace(
        "solver: liggghts",
        "solver: native\nexecutor: {kind: slurm}",
    ));
    assert!(
        stderr.contains("the study runs on Slurm but `sbatch` is not on PATH"),
        "{stderr}"
    );
    assert!(stderr.contains("scripts/slurm up"), "{stderr}");
}

#[test]
fn dry_run_prints_the_design_and_writes_nothing() {
    let project = Project::new();
    let file = project.write("study.yaml", GOOD);
    let output = project.run(&["submit", "--dry-run", file.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    assert!(
        stdout.starts_with("tiny: 2 design points × 1 replicates = 2 jobs: hopper on liggghts\n"),
        "{stdout}"
    );
    // Every parameter with its value and where it comes from, then what is measured.
    let line = |name: &str| {
        stdout
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("no `{name}` line in:\n{stdout}"))
            .split_whitespace()
            .collect::<Vec<_>>()
    };
    assert_eq!(line("density"), ["density", "2500", "kg/m^3", "default"]);
    assert!(stdout.contains("\nresponses: "), "{stdout}");
    assert!(stdout.contains("\nrounds: at most 1\n"), "{stdout}");
    assert!(!project.project_dir().exists());
}

#[test]
fn params_and_template_show_list_what_a_study_can_use() {
    let project = Project::new();
    let output = project.run(&["params"]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let overview = text(&output.stdout);
    for name in ["hopper", "liggghts", "native", "yade", "cfd"] {
        assert!(overview.contains(name), "{name} missing from:\n{overview}");
    }
    let output = project.run(&["params", "hopper", "--solver", "native"]);
    let table = text(&output.stdout);
    let outlet = table
        .lines()
        .find(|l| l.trim_start().starts_with("outlet_diameter "))
        .unwrap_or_else(|| panic!("{table}"));
    assert_eq!(
        outlet.split_whitespace().take(4).collect::<Vec<_>>(),
        ["outlet_diameter", "0.024", "m", "[0.001,"]
    );
    assert!(table.contains("discharge_rate"), "{table}");
    assert!(table.contains("rendered as hopper.toml"), "{table}");
    let output = project.run(&["params", "cfd"]);
    assert!(text(&output.stdout).contains("air_entrained_flow"));
    let output = project.run(&["params", "chute", "--solver", "native"]);
    let table = text(&output.stdout);
    assert!(
        table.contains("impact_speed") && table.contains("drop_height"),
        "{table}"
    );
    assert!(table.contains("rendered as chute.toml"), "{table}");

    let output = project.run(&["template", "show", "hopper", "--solver", "liggghts"]);
    assert!(output.status.success());
    let deck =
        std::fs::read_to_string(crate::support::root().join("templates/liggghts/hopper.in.tera"))
            .unwrap();
    assert_eq!(text(&output.stdout), deck);

    let output = project.run(&["params", "silo"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        text(&output.stderr)
            .contains("no equipment or stage `silo`; expected one of: hopper, chute, cfd"),
        "{}",
        text(&output.stderr)
    );
    let output = project.run(&["template", "show", "hopper", "--solver", "lammps"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(text(&output.stderr)
        .contains("unknown solver `lammps`; expected one of: liggghts, native, yade"));
}

#[test]
fn status_and_logs_of_unknown_things_say_what_to_do() {
    let project = Project::new();
    let output = project.run(&["status", "nosuch"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        text(&output.stderr).contains("no study named `nosuch`"),
        "{}",
        text(&output.stderr)
    );
    let output = project.run(&["status"]);
    assert!(output.status.success());
    assert_eq!(
        text(&output.stdout),
        "no studies yet: submit one with `orch submit STUDY.yaml`\n"
    );
}

#[test]
fn every_study_in_jobs_validates() {
    let jobs = crate::support::root().join("jobs");
    let mut checked = 0;
    // jobs/ and jobs/thesis/ (jobs/compare/ holds the comparison suite, not studies).
    let files = [jobs.clone(), jobs.join("thesis")]
        .iter()
        .flat_map(|dir| std::fs::read_dir(dir).unwrap().flatten())
        .map(|entry| entry.path())
        .collect::<Vec<_>>();
    for path in files {
        if path.extension().is_some_and(|e| e == "yaml") {
            let project = Project::new();
            let output = project.run(&["submit", "--dry-run", path.to_str().unwrap()]);
            assert!(
                output.status.success(),
                "{}: {}",
                path.display(),
                text(&output.stderr)
            );
            checked += 1;
        }
    }
    assert!(checked >= 2, "expected study files in {}", jobs.display());
}
