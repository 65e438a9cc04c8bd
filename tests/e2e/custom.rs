//! A user's own deck (`equipment: custom`): a hand-written LIGGGHTS deck that is not a
//! hopper runs as a study on real LIGGGHTS; bad templates, unused factors and paths
//! outside the study folder are refused before anything is written; a response whose
//! file the run did not write is recorded naming the file, or fails the job under
//! `missing_response: fail`; a changed template under
//! the same name is refused with what to do, and what was stored is what resumes.
//!
//! The decks of the refusal and bookkeeping tests run a user's own shell script, as a
//! user may (`command: [sh, run.sh]`): they test orch's handling of the deck, not a
//! solver's results.

use std::collections::BTreeMap;

use crate::support::{count, require_liggghts, root, solver_lock, text, Project};

/// Copies `jobs/inclined-plane.yaml` and its deck into the project.
fn inclined_plane(project: &Project) -> std::path::PathBuf {
    let deck = project.dir.path().join("inclined-plane");
    std::fs::create_dir_all(&deck).unwrap();
    for file in ["in.plane.tera", "materials.in"] {
        std::fs::copy(
            root().join("jobs/inclined-plane").join(file),
            deck.join(file),
        )
        .unwrap();
    }
    let study = std::fs::read_to_string(root().join("jobs/inclined-plane.yaml")).unwrap();
    project.write("inclined-plane.yaml", &study)
}

#[test]
fn a_hand_written_liggghts_deck_runs_as_a_study_with_its_declared_responses() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let project = Project::new();
    let file = inclined_plane(&project);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));

    let status = project.status("inclined-plane");
    assert_eq!(count(&status, "succeeded"), 9, "{status:#}");
    // Mean speed down the slope by (angle, friction): steeper is faster, more friction
    // slower, at every level of the other factor.
    let mut speed: BTreeMap<(u64, u64), f64> = BTreeMap::new();
    for job in status["jobs"].as_array().unwrap() {
        let angle = job["factors"]["angle"].as_f64().unwrap();
        let friction = job["factors"]["friction"].as_f64().unwrap();
        let responses = &job["responses"];
        let mean = responses["mean_speed"].as_f64().unwrap();
        let acceleration = responses["acceleration"].as_f64().unwrap();
        eprintln!(
            "{}: angle {angle}°, friction {friction}: mean speed {mean:.4} m/s, acceleration {acceleration:.4} m/s²",
            job["name"]
        );
        assert_eq!(responses["particles_left"].as_f64(), Some(400.0));
        // Rolling spheres accelerate at most at (5/7) g sin θ down a slope.
        let rolling = 5.0 / 7.0 * 9.81 * angle.to_radians().sin();
        assert!(
            acceleration > 0.0 && acceleration < rolling,
            "{acceleration} m/s² against {rolling}"
        );
        speed.insert(((angle * 10.0) as u64, (friction * 10.0) as u64), mean);
    }
    for friction in [3, 5, 7] {
        assert!(speed[&(200, friction)] < speed[&(250, friction)]);
        assert!(speed[&(250, friction)] < speed[&(300, friction)]);
    }
    for angle in [200, 250, 300] {
        assert!(speed[&(angle, 3)] > speed[&(angle, 7)], "{speed:?}");
    }
    // The table a response is read from is stored as its series; the rendered deck
    // and the side file are in the run directory.
    let rows = project.query(
        "SELECT COUNT(*) FROM series s JOIN jobs j ON j.id = s.job_id WHERE j.name = 'p000r0' AND s.name = 'mean_speed'",
    );
    assert_ne!(rows[0][0], "0");
    let run = project.project_dir().join("runs/inclined-plane/p000r0");
    let deck = std::fs::read_to_string(run.join("in.plane")).unwrap();
    assert!(
        deck.contains("fix gravi all gravity 9.81 chute 20"),
        "{deck}"
    );
    assert!(deck.contains("pair_style      gran model hertz"), "{deck}");
    // The side file keeps its path relative to the study file.
    assert!(run.join("inclined-plane/materials.in").is_file());
}

/// A study of a user's script: `run.sh` writes `post/out.json` and prints a line.
const SCRIPT_STUDY: &str = "\
name: script
equipment: custom
case:
  templates: [deck.sh.tera]
  command: [sh, deck.sh]
  responses:
    - {name: doubled, json: post/out.json, key: result.doubled}
    - {name: printed, regex: 'value = (\\S+)', unit: m}
executor: {max_parallel: 2, retries: 0}
factors:
  - {name: x, min: 1, max: 3}
fixed: {label: run}
design: {type: full_factorial, levels: 3}
";

const SCRIPT: &str = "\
mkdir -p post
echo \"{{ label }}: value = {{ x }}\"
echo '{\"result\": {\"doubled\": {{ x * 2 }}}}' > post/out.json
";

#[test]
fn a_user_script_reports_json_and_log_responses() {
    let project = Project::new();
    project.write("deck.sh.tera", SCRIPT);
    let file = project.write("script.yaml", SCRIPT_STUDY);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("script");
    for job in status["jobs"].as_array().unwrap() {
        let x = job["factors"]["x"].as_f64().unwrap();
        assert_eq!(
            job["responses"]["doubled"].as_f64(),
            Some(2.0 * x),
            "{job:#}"
        );
        assert_eq!(job["responses"]["printed"].as_f64(), Some(x), "{job:#}");
    }

    // Another response declared for the same decks: nothing runs again, every run's
    // files are read with the new declarations.
    let more = SCRIPT_STUDY.replace(
        "    - {name: printed, regex: 'value = (\\S+)', unit: m}\n",
        "    - {name: printed, regex: 'value = (\\S+)', unit: m}\n    - {name: value_lines, regex: 'value = (\\S+)', reduce: count}\n",
    );
    assert_ne!(more, SCRIPT_STUDY);
    let file = project.write("more.yaml", &more);
    let output = project.run(&["submit", "--as", "script-more", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("3 of them reused"), "{stderr}");
    let status = project.status("script-more");
    for job in status["jobs"].as_array().unwrap() {
        assert_eq!(job["attempts"], 0, "{job:#}");
        assert_eq!(
            job["responses"]["value_lines"].as_f64(),
            Some(1.0),
            "{job:#}"
        );
    }
}

/// `orch submit` of `study` with `template` as `deck.sh.tera`: exit code and stderr.
fn refused(study: &str, template: &str) -> String {
    let project = Project::new();
    project.write("deck.sh.tera", template);
    let file = project.write("script.yaml", study);
    for args in [vec!["submit", "--dry-run"], vec!["submit"]] {
        let mut args = args;
        args.push(file.to_str().unwrap());
        let output = project.run(&args);
        assert_eq!(output.status.code(), Some(2), "{}", text(&output.stderr));
        assert!(
            !project.project_dir().exists(),
            "a refused study wrote the project"
        );
    }
    let output = project.run(&["submit", file.to_str().unwrap()]);
    text(&output.stderr)
}

#[test]
fn bad_templates_unused_factors_and_outside_paths_are_refused_before_anything_is_written() {
    let syntax = refused(SCRIPT_STUDY, "mkdir -p post\necho {{ x }\n");
    assert!(
        syntax
            .contains("script.yaml:4:14: case.templates: template deck.sh.tera:2: Failed to parse"),
        "{syntax}"
    );
    let undefined = refused(SCRIPT_STUDY, "mkdir -p post\n\necho {{ y }}\n");
    assert!(
        undefined.contains(
            "case.templates: design point 0 (x = 1) cannot run: template deck.sh.tera:3: "
        ) && undefined.contains("`y` not found"),
        "{undefined}"
    );
    let unused = refused(SCRIPT_STUDY, "mkdir -p post\necho value = 1\n");
    assert!(
        unused.contains("factors[0].name: factor `x` is not used by the templates: they render the same with x = 1, 2 and 3; use it in a template (`{{ x }}`) or remove the factor"),
        "{unused}"
    );
    // A switch that only the lowest level turns on is used.
    let project = Project::new();
    project.write(
        "deck.sh.tera",
        "{% if x < 2 %}echo low{% endif %}\necho \"{{ label }}: value = 1\"\n",
    );
    let file = project.write("script.yaml", SCRIPT_STUDY);
    let output = project.run(&["submit", "--dry-run", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    // A misspelt `fixed:` name is no silent default.
    let misspelt = refused(
        &SCRIPT_STUDY.replace("fixed: {label: run}", "fixed: {label: run, lable: walk}"),
        SCRIPT,
    );
    assert!(
        misspelt.contains("fixed.lable: `lable` is not used by the templates and the deck declares no such parameter; did you mean `label`?"),
        "{misspelt}"
    );
    let environment = refused(SCRIPT_STUDY, "echo {{ x }} {{ get_env(name=\"HOME\") }}\n");
    assert!(
        environment.contains("templates cannot read orch's environment"),
        "{environment}"
    );
    let outside = refused(
        &SCRIPT_STUDY.replace("[deck.sh.tera]", "[../deck.sh.tera]"),
        SCRIPT,
    );
    assert!(
        outside.contains("case.templates[0]: expected a path inside the study's folder (relative, no `..`), got `../deck.sh.tera`"),
        "{outside}"
    );
    let absolute = refused(
        &SCRIPT_STUDY.replace("[deck.sh.tera]", "[/etc/passwd]"),
        SCRIPT,
    );
    assert!(absolute.contains("got `/etc/passwd`"), "{absolute}");
    let two_sources = refused(
        &SCRIPT_STUDY.replace(
            "json: post/out.json, key: result.doubled",
            "json: post/out.json, key: a, table: t.txt",
        ),
        SCRIPT,
    );
    assert!(
        two_sources.contains("case.responses[0]: expected exactly one source"),
        "{two_sources}"
    );
}

/// A built-in equipment with the user's own template gets the same checks.
#[test]
fn a_hopper_template_of_the_users_that_cannot_render_is_refused_at_validation() {
    let project = Project::new();
    project.write(
        "my-hopper.in.tera",
        "# my deck\nvariable n index {{ n_particles }}\nvariable d index {{ no_such_value }}\n",
    );
    let file = project.write(
        "mine.yaml",
        "name: mine\nsolver: native\ntemplate: my-hopper.in.tera\n\
         factors:\n  - {name: outlet_diameter, min: 0.02, max: 0.028}\n\
         design: {type: full_factorial, levels: 2}\n",
    );
    let output = project.run(&["submit", "--dry-run", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2));
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("mine.yaml:3:11: template: design point 0 (outlet_diameter = 0.02) cannot run: template ")
            && stderr.contains("my-hopper.in.tera:3: ")
            && stderr.contains("no_such_value"),
        "{stderr}"
    );
    assert!(!project.project_dir().exists());
}

/// Responses stand alone: one whose file the run did not write is recorded with the
/// file it looked for and the others are kept (`missing_response: record`, the
/// default), or the job fails naming the file (`missing_response: fail`).
#[test]
fn a_response_whose_file_the_run_did_not_write_is_recorded_or_fails_the_job_naming_the_file() {
    let project = Project::new();
    project.write(
        "deck.sh.tera",
        "echo \"{{ label }}: value = {{ x }}\"\n# writes no post/out.json\n",
    );
    let expected = "post/out.json is missing: response `doubled` is read from it; check that the deck writes post/out.json (relative to the run directory)";
    let file = project.write("script.yaml", SCRIPT_STUDY);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("script");
    assert_eq!(count(&status, "succeeded"), 3, "{status:#}");
    for job in status["jobs"].as_array().unwrap() {
        let x = job["factors"]["x"].as_f64().unwrap();
        assert_eq!(job["responses"]["printed"].as_f64(), Some(x), "{job:#}");
        assert!(job["responses"].get("doubled").is_none(), "{job:#}");
        let note = job["error"].as_str().unwrap();
        assert!(
            note.starts_with("succeeded without doubled: doubled: ") && note.contains(expected),
            "{note}"
        );
    }

    let failing = SCRIPT_STUDY.replace("name: script", "name: script-fails")
        + "missing_response: fail\nseed: 2\n";
    let file = project.write("script-fails.yaml", &failing);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output.stderr));
    let status = project.status("script-fails");
    assert_eq!(count(&status, "failed"), 3, "{status:#}");
    let error = status["jobs"][0]["error"].as_str().unwrap();
    assert!(error.contains(expected), "{error}");
}

/// [`SCRIPT`] with a version mark, failing for x > 2.5 (the third point).
const VERSIONED: &str = "\
# version 1
mkdir -p post
echo \"{{ label }}: value = {{ x }}\"
echo '{\"result\": {\"doubled\": {{ x * 2 }}}}' > post/out.json
awk 'BEGIN { exit ({{ x }} > 2.5) }'
";

#[test]
fn a_changed_template_is_refused_under_the_same_name_and_the_stored_one_is_what_resumes() {
    let project = Project::new();
    let template = project.write("deck.sh.tera", VERSIONED);
    let file = project.write("script.yaml", SCRIPT_STUDY);
    let file = file.to_str().unwrap();
    assert_eq!(project.run(&["submit", file]).status.code(), Some(1));

    let changed = VERSIONED
        .replace("version 1", "version 2")
        .replace("x * 2", "x * 3");
    std::fs::write(&template, changed).unwrap();
    let output = project.run(&["submit", file]);
    assert_eq!(output.status.code(), Some(2));
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("a different study named `script` already exists")
            && stderr.contains("this file, its template or its files differ")
            && stderr.contains("orch submit --as NAME")
            && stderr.contains("orch delete script"),
        "{stderr}"
    );
    // Under another name it runs with the changed template.
    let output = project.run(&["submit", "--as", "script-tripled", file]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output.stderr));
    let tripled = project.status("script-tripled");
    assert_eq!(
        tripled["jobs"][0]["responses"]["doubled"].as_f64(),
        Some(3.0)
    );

    // With the template gone from disk, the first study still resumes, and its failed
    // job runs again from the stored template.
    std::fs::remove_file(&template).unwrap();
    let output = project.run(&["resume", "script", "--retry-failed"]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output.stderr));
    let deck =
        std::fs::read_to_string(project.project_dir().join("runs/script/p002r0/deck.sh")).unwrap();
    assert!(deck.starts_with("# version 1"), "{deck}");
    let attempts = project.query("SELECT attempts FROM jobs WHERE name = 'p002r0' AND study_id = (SELECT id FROM studies WHERE name = 'script')");
    assert_eq!(attempts[0][0], "1", "a fresh attempt after --retry-failed");

    // orch delete removes a study and its runs; the name is free again.
    let output = project.run(&["delete", "script"]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(!project.project_dir().join("runs/script").exists());
    assert_eq!(project.run(&["status", "script"]).status.code(), Some(2));
    let rows = project.query(
        "SELECT COUNT(*) FROM jobs j JOIN studies s ON s.id = j.study_id WHERE s.name = 'script'",
    );
    assert_eq!(rows[0][0], "0");
}
