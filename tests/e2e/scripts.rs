//! A user's post-processing script as a stage (`stages: {script: {case: …}}`): run after
//! each native design job, on that job's files, with its responses stored like any
//! other stage's.

use crate::support::{count, text, Project};

/// Two outlets on the native kernel, `keep: none`, each followed by a shell script that
/// counts the rows of its design job's crossings file and echoes its discharge rate.
const SCRIPTED: &str = "\
name: scripted
solver: native
executor: {max_parallel: 2, time_limit: 3min, retries: 0}
keep: none
factors:
  - {name: outlet_diameter, min: 0.018, max: 0.028, unit: m}
fixed: {n_particles: 400, fill_time: 0.15, discharge_time: 0.4}
design: {type: full_factorial, levels: 2}
seed: 3
responses: [discharge_rate, crossing_rows]
stages:
  script:
    fixed: {offset: 1}
    case:
      templates: [count.sh.tera]
      command: [sh, count.sh]
      parameters:
        offset: {default: 0, description: rows before the first crossing (the header)}
      responses:
        - {name: crossing_rows, regex: 'rows = (\\S+)'}
        - {name: echoed_rate, unit: kg/s, regex: 'rate = (\\S+)'}
";

const COUNT: &str = "\
rows=$(wc -l < \"{{ upstream_dir }}/post/crossings.csv\")
echo \"rows = $((rows - {{ offset }}))\"
echo \"rate = {{ upstream_discharge_rate }}\"
";

#[test]
fn a_script_stage_reads_its_design_job_s_files_and_its_responses_are_stored() {
    let project = Project::new();
    project.write("count.sh.tera", COUNT);
    let file = project.write("scripted.yaml", SCRIPTED);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    let status = project.status("scripted");
    assert_eq!(count(&status, "succeeded"), 4, "{status:#}");
    let jobs = status["jobs"].as_array().unwrap();
    let job = |name: &str| jobs.iter().find(|j| j["name"] == name).unwrap();
    for point in ["p000r0", "p001r0"] {
        let (design, script) = (job(point), job(&format!("{point}-script")));
        // The script read the design job's crossings (one row per particle that
        // crossed, at most the 400 inserted) and the rate stored for it.
        let rows = script["responses"]["crossing_rows"].as_f64().unwrap();
        assert!(rows > 0.0 && rows <= 400.0, "{script:#}");
        let rate = design["responses"]["discharge_rate"].as_f64().unwrap();
        let echoed = script["responses"]["echoed_rate"].as_f64().unwrap();
        assert!(
            rate > 0.0 && (echoed - rate).abs() <= 1e-9 * rate,
            "{rate} vs {echoed}"
        );
        // The design job kept every file until its script had run; then nothing read
        // them any more, and `keep: none` pruned them to its record.
        let run_dir = project.project_dir().join(format!("runs/scripted/{point}"));
        assert!(run_dir.join("orch-kept.txt").exists());
        assert!(!run_dir.join("post/crossings.csv").exists());
    }
    // `orch logs` shows the script's own log (its stdout; `keep: none` pruned the
    // script's own directory to its record once its responses were stored).
    let logs = text(&project.run(&["logs", "scripted/p000r0-script"]).stdout);
    assert!(logs.contains("rows = "), "{logs}");
    // Its response is fitted with the design's.
    let table = text(&project.run(&["status", "scripted"]).stdout);
    assert!(table.contains("crossing_rows"), "{table}");
}
