use std::path::Path;

use super::*;

const VALID: &str = "\
name: hopper-vibration
solver: liggghts
executor:
  max_parallel: 2
  time_limit: 10min
  retries: 1
factors:
  - {name: amplitude, min: 0.0002, max: 0.0009, unit: m}
  - {name: frequency, min: 20, max: 50, unit: Hz}
  - {name: valve_gap, min: 0.010, max: 0.025}
fixed:
  valve_diameter: 0.012
design:
  type: central_composite
  alpha: orthogonal
  center_points: 1
responses: [discharge_rate, segregation_ratio]
";

fn load(text: &str) -> Result<Study, StudyError> {
    Study::from_text(Path::new("jobs/study.yaml"), text, None)
}

/// The error's full message, as a user sees it.
fn error(text: &str) -> String {
    load(text).unwrap_err().to_string()
}

#[test]
fn a_valid_three_factor_ccd_has_fifteen_runs() {
    let study = load(VALID).unwrap();
    assert_eq!(study.points.len(), 15);
    assert_eq!(study.executor.max_parallel, 2);
    assert_eq!(study.executor.time_limit, Some(Duration::from_secs(600)));
    // Natural values stay within the factor ranges.
    for point in &study.points {
        for (value, factor) in point.natural.iter().zip(&study.factors) {
            assert!(*value >= factor.range.min - 1e-12 && *value <= factor.range.max + 1e-12);
        }
    }
    let case = study.case(&study.points[14], 5);
    assert_eq!(case.get("valve_diameter"), 0.012);
    assert!((case.get("frequency") - 35.0).abs() < 1e-12);
}

#[test]
fn a_two_factor_ccd_has_nine_runs() {
    let text = VALID.replace("  - {name: valve_gap, min: 0.010, max: 0.025}\n", "");
    assert_eq!(load(&text).unwrap().points.len(), 9);
}

#[test]
fn unknown_key_is_refused_with_line_and_column() {
    let text = VALID.replace("  retries: 1\n", "  retries: 1\n  retrys: 2\n");
    assert_eq!(
        error(&text),
        "jobs/study.yaml:7:3: executor.retrys: unknown field `retrys`, expected one of `kind`, `max_parallel`, `cores_per_job`, `time_limit`, `retries`, `partition`, `cpus_per_task`, `mem`, `account`, `qos`, `extra_sbatch`, `max_submitted`, `poll_interval`, `array_size`"
    );
}

#[test]
fn wrong_type_is_refused_with_the_field_path() {
    let text = VALID.replace("min: 20, max: 50", "min: twenty, max: 50");
    assert_eq!(
        error(&text),
        "jobs/study.yaml:9:28: factors[1].min: invalid type: string \"twenty\", expected f64"
    );
}

#[test]
fn min_not_below_max_is_refused() {
    let text = VALID.replace("min: 20, max: 50", "min: 50, max: 20");
    assert_eq!(
        error(&text),
        "jobs/study.yaml:9:37: factors[1].max: expected max greater than min (50), got 20"
    );
}

#[test]
fn unknown_solver_is_refused() {
    let text = VALID.replace("solver: liggghts", "solver: edem");
    assert_eq!(
        error(&text),
        "jobs/study.yaml:2:9: solver: unknown solver `edem`; expected one of: liggghts, native, yade"
    );
}

#[test]
fn missing_template_is_refused() {
    let text = VALID.replace(
        "solver: liggghts\n",
        "solver: liggghts\ntemplate: no/such.in.tera\n",
    );
    let message = error(&text);
    assert!(
        message.starts_with("jobs/study.yaml:3:11: template: cannot read jobs/no/such.in.tera: "),
        "{message}"
    );
}

#[test]
fn unknown_parameter_and_out_of_range_values_are_refused() {
    let text = VALID.replace("name: valve_gap", "name: valve_gapp");
    let message = error(&text);
    assert!(message.starts_with("jobs/study.yaml:10:12: factors[2].name: `valve_gapp` is not a parameter of the hopper equipment; expected one of: n_particles,"), "{message}");
    let text = VALID.replace("valve_diameter: 0.012", "restitution: 1.5");
    assert_eq!(
        error(&text),
        "jobs/study.yaml:12:16: fixed.restitution: `restitution` must lie within [0.01, 1] -, got 1.5"
    );
}

#[test]
fn design_fields_that_do_not_apply_are_refused() {
    let text = VALID.replace(
        "  alpha: orthogonal\n",
        "  alpha: orthogonal\n  levels: 3\n",
    );
    assert_eq!(
        error(&text),
        "jobs/study.yaml:16:11: design.levels: `levels` does not apply to a central_composite design"
    );
}

#[test]
fn impossible_design_points_are_refused_before_running() {
    let text = VALID.replace(
        "fixed:\n  valve_diameter: 0.012\n",
        "fixed:\n  valve_diameter: 0.040\n",
    );
    let message = error(&text);
    assert!(
        message.starts_with("jobs/study.yaml:8:3: factors: design point 0 ("),
        "{message}"
    );
    assert!(message.contains("does not fit"), "{message}");
}

#[test]
fn syntax_errors_point_at_the_text() {
    let message = error("name: 'unterminated\n");
    assert!(
        message.starts_with("jobs/study.yaml:2:1: name: found unexpected end of stream"),
        "{message}"
    );
}

#[test]
fn latin_hypercube_needs_samples() {
    let text = VALID.replace(
        "  type: central_composite\n  alpha: orthogonal\n  center_points: 1\n",
        "  type: latin_hypercube\n",
    );
    assert_eq!(
        error(&text),
        "jobs/study.yaml:14:7: design: a latin_hypercube design needs `samples:` (number of runs)"
    );
    let text = text.replace(
        "  type: latin_hypercube\n",
        "  type: latin_hypercube\n  samples: 12\n  seed: 4\n",
    );
    assert_eq!(load(&text).unwrap().points.len(), 12);
}

#[test]
fn objectives_name_their_responses_and_need_one_form() {
    let base = VALID.to_string();
    let with = |objective: &str| format!("{base}{objective}");
    let study = load(&with("objective:\n  weights: {discharge_rate: 1.0, segregation_ratio: -0.5}\n  goal: maximise\n  constraints: [{response: R1_mean, max: 0.01}]\nrounds: 3\n")).unwrap();
    let objective = study.objective.unwrap();
    assert_eq!(
        objective.name(),
        "1*discharge_rate + -0.5*segregation_ratio"
    );
    assert_eq!(
        objective.responses(),
        ["discharge_rate", "segregation_ratio", "R1_mean"]
    );
    assert_eq!(study.rounds, 3);
    assert_eq!(
        error(&with("objective: {goal: maximise}\n")),
        "jobs/study.yaml:18:12: objective: expected either `response:` or `weights:` (a map of response to weight), not both"
    );
    assert_eq!(
        error(&with("objective: {response: flow, goal: maximise}\n")),
        "jobs/study.yaml:18:23: objective.response: unknown response `flow`; expected one of: discharged_count, discharged_mass, discharge_rate, discharge_rate_ci95, R1_mean, R2_mean, segregation_ratio, segregation_ratio_normalised, stream_radius, stream_radius_95, exit_speed, fine_fraction_first_quarter, fine_fraction_last_quarter, fine_fraction_outer_2, fine_fraction_outer_5, fine_fraction_outer_10, fine_fraction_outer_12"
    );
    assert_eq!(
        error(&with("rounds: 2\n")),
        "jobs/study.yaml:18:9: rounds: more than one round needs an `objective:` to move the box towards"
    );
    assert_eq!(
        error(&with("uncertainty: {parameters: [{name: densty, distribution: normal, mean: 2500, std: 100}]}\n")),
        "jobs/study.yaml:18:35: uncertainty.parameters[0].name: `densty` is neither a factor nor a parameter of the equipment; name a factor (held at its mean while optimising, or with `std:` only, a tolerance) or a parameter (varied by the noise design around the optimum)"
    );
}

#[test]
fn a_slurm_executor_takes_its_submission_options() {
    let text = VALID.replace(
        "executor:\n  max_parallel: 2\n",
        "executor:\n  kind: slurm\n  cores_per_job: 2\n  partition: debug\n  cpus_per_task: 2\n  mem: 2G\n  account: granular\n  qos: short\n  extra_sbatch: [--constraint=avx2]\n  max_submitted: 40\n  poll_interval: 2s\n",
    );
    let study = load(&text).unwrap();
    assert_eq!(study.executor.kind, ExecutorKind::Slurm);
    assert_eq!(study.executor.max_parallel, 40);
    let slurm = study.executor.slurm.unwrap();
    assert_eq!(slurm.partition.as_deref(), Some("debug"));
    assert_eq!(slurm.cpus_per_task, Some(2));
    assert_eq!(slurm.mem.as_deref(), Some("2G"));
    assert_eq!(slurm.extra_sbatch, vec!["--constraint=avx2".to_string()]);
    assert_eq!(slurm.time_limit, Some(Duration::from_secs(600)));
    assert_eq!(slurm.poll_interval, Duration::from_secs(2));
    assert_eq!(slurm.array_size, None);
    let arrays = load(&text.replace("  max_submitted: 40\n", "  array_size: 200\n")).unwrap();
    assert_eq!(arrays.executor.slurm.unwrap().array_size, Some(200));
    // Defaults.
    let text = VALID.replace("  max_parallel: 2\n", "  kind: slurm\n");
    let study = load(&text).unwrap();
    assert_eq!(study.executor.max_parallel, 500);
    assert_eq!(
        study.executor.slurm.unwrap().poll_interval,
        Duration::from_secs(5)
    );
}

#[test]
fn cores_per_job_sets_the_solver_command_and_the_default_parallelism() {
    let machine = std::thread::available_parallelism().map_or(1, |n| n.get());
    let text = VALID.replace("  max_parallel: 2\n", "  cores_per_job: 2\n");
    let study = load(&text).unwrap();
    assert_eq!(study.executor.cores_per_job, 2);
    assert_eq!(study.executor.core_budget, Some(machine));
    assert_eq!(study.executor.max_parallel, (machine / 2).max(1));
    let command = study.simulation.command();
    assert_eq!((command.program.as_str(), command.cores), ("mpirun", 2));
    // Left out: one core, the command of every study before the key existed.
    let study = load(VALID).unwrap();
    assert_eq!(study.executor.cores_per_job, 1);
    assert_eq!(study.simulation.command().program, "liggghts");
    // Slurm places jobs itself: no core budget.
    let text = VALID.replace("  max_parallel: 2\n", "  kind: slurm\n  cores_per_job: 4\n");
    let study = load(&text).unwrap();
    assert_eq!(study.executor.core_budget, None);
    assert_eq!(study.simulation.command().cores, 4);
}

#[test]
fn slurm_cpus_per_task_of_a_single_process_must_be_its_threads() {
    let native = |executor: &str| {
        VALID
            .replace("solver: liggghts\n", "solver: native\n")
            .replace("  max_parallel: 2\n", &format!("  kind: slurm\n{executor}"))
    };
    // Eight CPUs, one thread: the mistake of the thesis-scale files before this check.
    let idle = error(&native("  cpus_per_task: 8\n"));
    assert!(
        idle.contains(
            "executor.cpus_per_task: 8 CPUs per job, but the native solver runs 1 thread(s) (cores_per_job: 1): 7 of them would sit idle and still be charged; set cores_per_job: 8"
        ),
        "{idle}"
    );
    let shared = error(&native("  cores_per_job: 4\n  cpus_per_task: 2\n"));
    assert!(shared.contains("its threads would share them"), "{shared}");
    let matched = load(&native("  cores_per_job: 4\n  cpus_per_task: 4\n")).unwrap();
    assert_eq!(matched.executor.slurm.unwrap().cpus_per_task, Some(4));
    assert_eq!(matched.simulation.command().cores, 4);
    // MPI ranks may have several CPUs each (memory bandwidth).
    let liggghts = VALID.replace(
        "  max_parallel: 2\n",
        "  kind: slurm\n  cores_per_job: 2\n  cpus_per_task: 2\n",
    );
    assert_eq!(
        load(&liggghts)
            .unwrap()
            .executor
            .slurm
            .unwrap()
            .cpus_per_task,
        Some(2)
    );
}

#[test]
fn zero_cores_per_job_is_refused_with_line_and_column() {
    let text = VALID.replace("  max_parallel: 2\n", "  cores_per_job: 0\n");
    assert_eq!(
        error(&text),
        "jobs/study.yaml:4:18: executor.cores_per_job: expected 1 to 4096 cores (threads or MPI ranks of one job), got 0; leave it out for one core"
    );
    let text = VALID.replace("  max_parallel: 2\n", "  cores_per_job: -2\n");
    assert!(
        error(&text).starts_with("jobs/study.yaml:4:"),
        "{}",
        error(&text)
    );
}

#[test]
fn a_custom_deck_is_told_to_set_its_cores_with_case_cores() {
    let text = "\
name: script
equipment: custom
case:
  templates: [deck.sh.tera]
  command: [sh, deck.sh]
  responses: [{name: printed, regex: 'value = (\\S+)'}]
executor: {cores_per_job: 2}
factors:
  - {name: x, min: 1, max: 3}
design: {type: full_factorial, levels: 3}
";
    assert_eq!(
        error(text),
        "jobs/study.yaml:7:27: executor.cores_per_job: sets the cores of a built-in equipment's solver; a custom case sets its own with `case.cores` (and `{{ cores }}` in its command)"
    );
}

#[test]
fn slurm_options_are_checked_and_name_their_field() {
    let slurm = |line: &str| {
        error(&VALID.replace("  max_parallel: 2\n", &format!("  kind: slurm\n  {line}\n")))
    };
    assert_eq!(
        slurm("mem: 2 GB"),
        "jobs/study.yaml:5:8: executor.mem: expected one word without spaces or quotes, got \"2 GB\""
    );
    assert!(slurm("mem: 2GB").contains(
        "executor.mem: expected a size as sbatch writes it (4000, 500M, 2G), got \"2GB\""
    ));
    assert!(slurm("extra_sbatch: [exclusive]").contains(
        "executor.extra_sbatch[0]: expected one sbatch option such as `--constraint=avx2`, got \"exclusive\""
    ));
    assert!(slurm("max_parallel: 4").contains(
        "executor.max_parallel: Slurm decides how many jobs run at once; use max_submitted"
    ));
    assert!(slurm("cpus_per_task: 0").contains("executor.cpus_per_task: expected at least 1"));
    assert!(
        slurm("poll_interval: 10ms").contains("executor.poll_interval: expected at least 200ms")
    );
    assert_eq!(
        slurm("array_size: 0"),
        "jobs/study.yaml:5:15: executor.array_size: expected at least 1 (1 submits each job with an sbatch of its own)"
    );
    // A local study with a Slurm option is told so.
    let local = error(&VALID.replace("  retries: 1\n", "  retries: 1\n  partition: debug\n"));
    assert!(
        local.contains("executor.partition: is a Slurm option; add `kind: slurm` to the executor, or remove it"),
        "{local}"
    );
}

#[test]
fn equipment_defaults_to_the_hopper_and_unknown_equipment_is_refused() {
    let study = load(VALID).unwrap();
    assert_eq!(study.simulation.equipment_name(), "hopper");
    let named = load(&VALID.replace(
        "solver: liggghts\n",
        "equipment: hopper\nsolver: liggghts\n",
    ));
    assert_eq!(named.unwrap().file_sha256.len(), 64);
    assert_eq!(
        error(&VALID.replace("solver: liggghts\n", "equipment: silo\nsolver: liggghts\n")),
        "jobs/study.yaml:2:12: equipment: unknown equipment `silo`; expected one of: hopper, chute, custom"
    );
}

#[test]
fn responses_come_from_the_equipment_and_its_stages() {
    let study = load(VALID).unwrap();
    assert!(study.known_responses().contains(&"discharge_rate"));
    assert!(!study.known_responses().contains(&"air_ring_speed"));
    assert_eq!(study.response_unit("discharge_rate"), Some("kg/s"));
    let without = VALID.replace("responses: [discharge_rate, segregation_ratio]\n", "");
    assert_eq!(
        load(&without).unwrap().shown_responses(),
        ["discharge_rate", "segregation_ratio"],
        "the hopper's headline responses"
    );
    let with_stage = format!("{VALID}stages:\n  cfd: {{fixed: {{end_time: 0.2}}}}\n");
    let study = load(&with_stage).unwrap();
    assert_eq!(study.stages.len(), 1);
    assert_eq!(study.stages[0].case().get("end_time"), 0.2);
    assert!(study.known_responses().contains(&"air_ring_speed"));
    // `cfd:` is shorthand for the same stage.
    let shorthand = format!("{VALID}cfd:\n  fixed: {{end_time: 0.2}}\n");
    assert_eq!(load(&shorthand).unwrap().stages[0].stage.kind(), "cfd");
}

#[test]
fn stage_sections_are_checked() {
    assert_eq!(
        error(&format!("{VALID}stages:\n  dpm: {{}}\n")),
        "jobs/study.yaml:19:8: stages.dpm: unknown stage `dpm`; expected one of: cfd, script"
    );
    assert!(error(&format!("{VALID}stages:\n  cfd: {{fixed: {{end_tme: 1}}}}\n")).starts_with(
        "jobs/study.yaml:19:26: stages.cfd.fixed.end_tme: `end_tme` is not a parameter of the cfd stage; expected one of: air_density,"
    ));
    assert_eq!(
        error(&format!("{VALID}cfd:\n  fixed: {{cores: 0}}\n")),
        "jobs/study.yaml:19:18: cfd.fixed.cores: `cores` must lie within [1, 64] -, got 0"
    );
    assert_eq!(
        error(&format!("{VALID}cfd: {{}}\nstages:\n  cfd: {{}}\n")),
        "jobs/study.yaml:18:6: cfd: the cfd stage is given twice, as `cfd:` and under `stages:`; keep one"
    );
}

#[test]
fn a_script_stage_is_a_deck_of_the_user_s_run_after_each_design_job() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("count.sh.tera"),
        "wc -l < {{ upstream_dir }}/post/crossings.csv\n",
    )
    .unwrap();
    let load = |stages: &str| {
        let path = dir.path().join("scripted.yaml");
        std::fs::write(&path, format!("{VALID}stages:\n{stages}")).unwrap();
        Study::load(&path)
    };
    let script = "  script:\n    case:\n      templates: [count.sh.tera]\n      command: [sh, count.sh]\n      responses:\n        - {name: crossings, regex: '^(\\d+)'}\n";
    let study = load(script).unwrap();
    let stage = study.stage("script").unwrap();
    assert_eq!(stage.stage.responses()[0].name, "crossings");
    assert_eq!(stage.stage.programs(), ["sh"]);
    assert!(study.known_responses().contains(&"crossings"));
    // The design job keeps its files for it, whatever `keep:` says.
    let following = study.stages_following(None);
    assert_eq!(following.len(), 1);
    assert_eq!(
        following[0].stage.upstream_files(),
        orch_adapters::UpstreamFiles::Everything
    );
    // Its template is one of the study's inputs, so the stored study renders it again.
    assert!(study.inputs.iter().any(|(path, _)| path == "count.sh.tera"));
    let error = |stages: &str| load(stages).map(drop).unwrap_err().to_string();
    assert!(
        error("  script: {}\n")
            .contains("stages.script: the script stage runs your own deck: give it a `case:`"),
        "{}",
        error("  script: {}\n")
    );
    let missing = error(&script.replace("count.sh.tera", "cuont.sh.tera"));
    assert!(
        missing.contains("stages.script.case.templates[0]"),
        "{missing}"
    );
    let cfd_with_case =
        error("  cfd:\n    case: {templates: [count.sh.tera], command: [sh], responses: []}\n");
    assert!(
        cfd_with_case.contains("stages.cfd.case: the cfd stage is built in and takes no `case:`"),
        "{cfd_with_case}"
    );
}

#[test]
fn every_path_to_a_job_count_is_bounded_before_anything_is_allocated() {
    let ccd = VALID.replace("center_points: 1", "center_points: 200000");
    assert_eq!(
        error(&ccd),
        "jobs/study.yaml:16:18: design.center_points: expected at most 100000 centre points, got 200000"
    );
    let bb = VALID
        .replace("type: central_composite", "type: box_behnken")
        .replace("  alpha: orthogonal\n", "")
        .replace("center_points: 1", "center_points: 200000");
    assert_eq!(
        error(&bb),
        "jobs/study.yaml:15:18: design.center_points: expected at most 100000 centre points, got 200000"
    );
    let near = VALID.replace("center_points: 1", "center_points: 99990");
    assert_eq!(
        error(&near),
        "jobs/study.yaml:14:7: design: the design would have 100004 runs, more than the limit of 100000; expected fewer levels, samples or centre points"
    );
    let replicates = format!("{VALID}replicates: 4000000000\n");
    assert_eq!(
        error(&replicates),
        "jobs/study.yaml:18:13: replicates: expected 1 to 100000 replicates, got 4000000000"
    );
    let jobs = format!("{VALID}replicates: 7000\n");
    assert_eq!(
        error(&jobs),
        "jobs/study.yaml:18:13: replicates: the study would run 105000 jobs ((15 design points + 0 test points) × 7000 replicates × 1 round), more than the limit of 100000; expected fewer replicates, points or rounds"
    );
    let rounds = format!(
        "{VALID}replicates: 200\nobjective: {{response: discharge_rate, goal: maximise}}\nrounds: 50\n"
    );
    assert_eq!(
        error(&rounds),
        "jobs/study.yaml:18:13: replicates: the study would run 150000 jobs ((15 design points + 0 test points) × 200 replicates × 50 rounds), more than the limit of 100000; expected fewer replicates, points or rounds"
    );
    let samples = format!(
        "{VALID}uncertainty:\n  samples: 10000000000000\n  parameters: [{{name: frequency, distribution: normal, mean: 35, std: 2}}]\n"
    );
    assert_eq!(
        error(&samples),
        "jobs/study.yaml:19:12: uncertainty.samples: expected at most 10000000 samples (10^7), got 10000000000000"
    );
}

#[test]
fn a_full_factorial_grid_with_an_objective_gets_off_grid_test_points_unless_told_otherwise() {
    let grid = VALID.replace(
        "  type: central_composite\n  alpha: orthogonal\n  center_points: 1\n",
        "  type: full_factorial\n  levels: 3\n",
    );
    let objective = "objective: {response: discharge_rate, goal: maximise}\n";
    // k + 2 = 5 off-grid points for three factors on a grid with an objective.
    assert_eq!(
        load(&format!("{grid}{objective}"))
            .unwrap()
            .metamodel
            .test_points,
        5
    );
    // A sweep without an objective, and a study that says 0, get none.
    assert_eq!(load(&grid).unwrap().metamodel.test_points, 0);
    let none = format!("{grid}{objective}metamodel: {{test_points: 0}}\n");
    assert_eq!(load(&none).unwrap().metamodel.test_points, 0);
    // Other designs keep the old default.
    assert_eq!(
        load(&format!("{VALID}{objective}"))
            .unwrap()
            .metamodel
            .test_points,
        0
    );
}

#[test]
fn the_metamodel_is_chosen_automatically_unless_a_model_or_an_order_is_given() {
    let with = |section: &str| load(&format!("{VALID}metamodel: {section}\n"));
    assert_eq!(load(VALID).unwrap().metamodel.model, ModelChoice::Auto);
    assert_eq!(
        with("{order: 3}").unwrap().metamodel.model,
        ModelChoice::Polynomial { order: 3 }
    );
    assert_eq!(
        with("{model: polynomial}").unwrap().metamodel.model,
        ModelChoice::Polynomial { order: 2 }
    );
    let kriging = with("{model: kriging, kernel: squared_exponential, trend: linear}").unwrap();
    assert_eq!(kriging.metamodel.model, ModelChoice::Kriging);
    assert_eq!(kriging.metamodel.kernel, Kernel::SquaredExponential);
    assert_eq!(kriging.metamodel.trend, Trend::Linear);
    assert_eq!(
        error(&format!("{VALID}metamodel: {{model: auto, order: 2}}\n")),
        "jobs/study.yaml:18:33: metamodel.order: `order` sets the polynomial of `model: polynomial`; `model: auto` chooses its own (remove `order`, or write `model: polynomial`)"
    );
    assert_eq!(
        error(&format!(
            "{VALID}metamodel: {{model: polynomial, order: 4}}\n"
        )),
        "jobs/study.yaml:18:39: metamodel.order: expected an order of 1, 2 or 3, got 4"
    );
    assert!(error(&format!("{VALID}metamodel: {{model: spline}}\n"))
        .contains("metamodel.model: unknown variant `spline`, expected one of `auto`, `polynomial`, `kriging`"));
}

#[test]
fn materials_and_tolerances_make_a_noise_design_around_the_optimum() {
    let objective = "objective: {response: discharge_rate, goal: maximise}\n";
    let with = |uncertainty: &str| load(&format!("{VALID}{objective}uncertainty: {uncertainty}\n"));
    // Density is no factor: a material, rendered at its mean while optimising; the
    // valve gap without a mean is a tolerance around the optimum.
    let study = with("{parameters: [{name: density, distribution: normal, mean: 2400, std: 96}, {name: valve_gap, distribution: normal, std: 0.0005}]}").unwrap();
    let noise = study.uncertainty.as_ref().unwrap().noise.as_ref().unwrap();
    assert_eq!(noise.materials.len(), 1);
    assert_eq!(noise.tolerances, [(2, 0.0005)]);
    assert_eq!(noise.half_width, 3.0);
    // Two dimensions: a central composite design with one centre point, 9 runs.
    assert_eq!(noise.runs, 9);
    assert_eq!(study.fixed["density"], 2400.0);
    assert!(study.uncertainty.as_ref().unwrap().parameters.is_empty());
    // One material alone gets a 5-level sweep.
    let one =
        with("{parameters: [{name: density, distribution: normal, mean: 2400, std: 96}]}").unwrap();
    assert_eq!(one.uncertainty.unwrap().noise.unwrap().runs, 5);
    // The given design, its half-width, and what is refused.
    let ccd = with("{parameters: [{name: density, distribution: normal, mean: 2400, std: 96}, {name: restitution, distribution: normal, mean: 0.6, std: 0.03}], noise_design: {design: {type: full_factorial, levels: 3}, half_width: 2}}").unwrap();
    let noise = ccd.uncertainty.unwrap().noise.unwrap();
    assert_eq!((noise.runs, noise.half_width), (9, 2.0));
    assert_eq!(
        error(&format!("{VALID}{objective}fixed2: 1\n").replace("fixed2: 1\n", "uncertainty: {parameters: [{name: restitution, distribution: normal, mean: 0.6, std: 0.25}]}\n")),
        "jobs/study.yaml:19:35: uncertainty.parameters[0].name: the noise design would run `restitution` over [-0.15, 1.35], outside its range [0.01, 1]; narrow the distribution or `noise_design.half_width`"
    );
    assert_eq!(
        error(&format!("{VALID}{objective}uncertainty: {{parameters: [{{name: valve_diameter, distribution: normal, mean: 0.012, std: 0.0001}}]}}\n")),
        "jobs/study.yaml:19:35: uncertainty.parameters[0].name: `valve_diameter` is both fixed and uncertain; remove it from `fixed:` (its mean is its value while the design is optimised)"
    );
    assert_eq!(
        error(&format!("{VALID}{objective}uncertainty: {{parameters: [{{name: frequency, distribution: normal, mean: 30, std: 1}}], noise_design: {{half_width: 2}}}}\n")),
        "jobs/study.yaml:19:102: uncertainty.noise_design: a noise design varies parameters that are not factors, or factors' tolerances (`std:` without `mean:`); the study has neither"
    );
}

#[test]
fn a_pareto_objective_lists_two_or_more_responses_each_with_its_goal() {
    let with = |objective: &str| format!("{VALID}{objective}");
    let pair = "  objectives:\n    - {response: discharge_rate, goal: maximise}\n    - {response: segregation_ratio, goal: minimise}\n";
    let study = load(&with(&format!(
        "objective:\n{pair}  constraints: [{{response: R1_mean, max: 0.01}}]\nrounds: 3\n"
    )))
    .unwrap();
    let objective = study.objective.unwrap();
    assert!(objective.is_pareto());
    assert_eq!(objective.name(), "discharge_rate vs segregation_ratio");
    assert_eq!(
        objective.objectives,
        [
            ("discharge_rate".to_string(), Goal::Maximise),
            ("segregation_ratio".to_string(), Goal::Minimise)
        ]
    );
    assert_eq!(objective.front_points, DEFAULT_FRONT_POINTS);
    assert_eq!(
        objective.responses(),
        ["discharge_rate", "segregation_ratio", "R1_mean"]
    );
    // The first objective stands for the front where one value is needed.
    assert_eq!(objective.terms, [("discharge_rate".to_string(), 1.0)]);
    assert_eq!(objective.goal, Goal::Maximise);
    let study = load(&with(&format!("objective:\n{pair}  front_points: 40\n"))).unwrap();
    assert_eq!(study.objective.unwrap().front_points, 40);

    // `objectives:` excludes the single objective's fields.
    assert_eq!(
        error(&with(&format!("objective:\n{pair}  goal: maximise\n"))),
        "jobs/study.yaml:22:9: objective.goal: `objectives:` gives each response its own goal and takes no `goal:`; remove `goal:`, or `objectives:` to optimise one response"
    );
    assert_eq!(
        error(&with(&format!("objective:\n  response: discharge_rate\n{pair}"))),
        "jobs/study.yaml:19:13: objective.response: `objectives:` gives each response its own goal and takes no `response:`; remove `response:`, or `objectives:` to optimise one response"
    );
    assert_eq!(
        error(&with("objective:\n  objectives: [{response: discharge_rate, goal: maximise}]\n")),
        "jobs/study.yaml:19:15: objective.objectives: expected two or more objectives for a Pareto front, got 1; for one write `response:` and `goal:` instead"
    );
    assert_eq!(
        error(&with("objective:\n  objectives:\n    - {response: discharge_rate, goal: maximise}\n    - {response: flow, goal: minimise}\n")),
        "jobs/study.yaml:21:18: objective.objectives[1].response: unknown response `flow`; expected one of: discharged_count, discharged_mass, discharge_rate, discharge_rate_ci95, R1_mean, R2_mean, segregation_ratio, segregation_ratio_normalised, stream_radius, stream_radius_95, exit_speed, fine_fraction_first_quarter, fine_fraction_last_quarter, fine_fraction_outer_2, fine_fraction_outer_5, fine_fraction_outer_10, fine_fraction_outer_12"
    );
    assert_eq!(
        error(&with("objective:\n  objectives:\n    - {response: discharge_rate, goal: maximise}\n    - {response: discharge_rate, goal: minimise}\n")),
        "jobs/study.yaml:21:18: objective.objectives[1].response: `discharge_rate` is listed twice; a Pareto front needs different responses"
    );
    assert_eq!(
        error(&with(&format!("objective:\n{pair}  front_points: 2\n"))),
        "jobs/study.yaml:22:17: objective.front_points: expected 3 to 100 points on the Pareto front, got 2"
    );
    assert_eq!(
        error(&with("objective: {response: discharge_rate, goal: maximise, front_points: 20}\n")),
        "jobs/study.yaml:18:69: objective.front_points: only a Pareto front has points; list two or more `objectives:` or remove `front_points:`"
    );
    // Unknown keys in an entry are refused; each entry needs its goal.
    assert_eq!(
        error(&with("objective:\n  objectives:\n    - {response: discharge_rate, goal: maximise, weight: 2}\n    - {response: segregation_ratio, goal: minimise}\n")),
        "jobs/study.yaml:20:50: objective.objectives[0].weight: unknown field `weight`, expected `response` or `goal`"
    );
    assert_eq!(
        error(&with("objective:\n  objectives:\n    - {response: discharge_rate}\n    - {response: segregation_ratio, goal: minimise}\n")),
        "jobs/study.yaml:20:7: objective.objectives[0]: missing field `goal`"
    );
    // A single objective still needs its goal.
    assert_eq!(
        error(&with("objective: {response: discharge_rate}\n")),
        "jobs/study.yaml:18:12: objective: missing field `goal`; add `goal: maximise` or `goal: minimise`"
    );
}

#[test]
fn robust_objectives_and_probabilistic_bounds_need_a_spread() {
    let with = |objective: &str| format!("{VALID}objective: {objective}\n");
    let robust = "{response: discharge_rate, goal: maximise, robust: {k: 2}}";
    assert_eq!(
        error(&with(robust)),
        "jobs/study.yaml:18:63: objective.robust: needs a spread to be robust against: an uncertain factor (with `mean:`) or a factor's tolerance (`std:` only) in `uncertainty.parameters` (materials that are not factors are outside the surfaces; their noise design runs after the rounds)"
    );
    let tolerance =
        "uncertainty: {parameters: [{name: valve_gap, distribution: normal, std: 0.0002}]}\n";
    let study = load(&format!("{}{tolerance}", with(robust))).unwrap();
    assert_eq!(study.objective.unwrap().robust, Some(2.0));
    assert_eq!(
        error(&with("{response: discharge_rate, goal: maximise, robust: {k: 0}}")),
        "jobs/study.yaml:18:67: objective.robust.k: expected a number of standard deviations in (0, 6], got 0"
    );
    let bounded = "{response: discharge_rate, goal: maximise, constraints: [{response: R1_mean, max: 0.01, probability: 0.7}]}";
    assert_eq!(
        error(&format!("{}{tolerance}", with(bounded))),
        "jobs/study.yaml:18:113: objective.constraints[0].probability: expected a probability of passing the bound in (0, 0.5], got 0.7"
    );
    let both = "{response: discharge_rate, goal: maximise, constraints: [{response: R1_mean, min: 0.001, max: 0.01, probability: 0.05}]}";
    assert!(error(&format!("{}{tolerance}", with(both)))
        .ends_with("objective.constraints[0].probability: a probabilistic bound takes `min:` or `max:`, not both; write two constraints"));
}

#[test]
fn stop_when_names_a_response_with_an_interval_and_a_relative_target() {
    let study = load(&format!(
        "{VALID}stop_when: {{response: discharge_rate, ci95_below: 0.03, check_every: 2s}}\n"
    ))
    .unwrap();
    assert_eq!(
        study.stop_when,
        Some(StopWhen {
            response: "discharge_rate".to_string(),
            ci95_response: "discharge_rate_ci95".to_string(),
            relative_ci95: 0.03,
            check_every: Duration::from_secs(2),
        })
    );
    assert_eq!(load(VALID).unwrap().stop_when, None);
    assert_eq!(
        error(&format!(
            "{VALID}stop_when: {{response: exit_speed, ci95_below: 0.03}}\n"
        )),
        "jobs/study.yaml:18:23: stop_when.response: expected a response reported with its 95 % interval (`orch params` names each one's), got `exit_speed`; such responses here: discharge_rate"
    );
    assert_eq!(
        error(&format!(
            "{VALID}stop_when: {{response: discharge_rate, ci95_below: 3}}\n"
        )),
        "jobs/study.yaml:18:51: stop_when.ci95_below: expected the relative half-width of the interval, between 0 and 1 (0.03 = ±3 %), got 3"
    );
}

#[test]
fn coupling_needs_the_cfd_stage_and_the_native_kernel_and_defaults_to_the_headline_response() {
    let native = VALID.replace("solver: liggghts", "solver: native");
    let cfd = "cfd:\n  fixed: {end_time: 0.2}\n";
    let study = load(&format!(
        "{native}{cfd}coupling: {{iterations: 2, tolerance: 0.01}}\n"
    ))
    .unwrap();
    let coupling = study.coupling.as_ref().unwrap();
    assert_eq!(
        (
            coupling.iterations,
            coupling.response.as_str(),
            coupling.tolerance
        ),
        (2, "discharge_rate", 0.01)
    );
    // The rerun of the design is the `air` stage, fed by the study's `cfd` stage, and
    // the study finds it by its kind as it finds `cfd`.
    assert_eq!(
        (coupling.rerun.stage.kind(), coupling.feeder.stage.kind()),
        ("air", "cfd")
    );
    assert_eq!(coupling.feeder.fixed.get("end_time"), Some(&0.2));
    assert!(study.stage("air").is_some_and(|s| s.stage.reruns_design()));
    // Listed under `stages:` instead of chained, it is refused with what to do.
    let listed = error(&format!("{native}{cfd}stages: {{air: {{}}}}\n"));
    assert!(
        listed.contains("stages.air: the air stage runs the design point again after a `cfd` job; `coupling:` chains it"),
        "{listed}"
    );
    let without_cfd = error(&format!(
        "{native}coupling: {{iterations: 2, tolerance: 0.01}}\n"
    ));
    assert!(
        without_cfd.contains("coupling: couples the DEM with the air of the `cfd` stage"),
        "{without_cfd}"
    );
    let on_liggghts = error(&format!(
        "{VALID}{cfd}coupling: {{iterations: 2, tolerance: 0.01}}\n"
    ));
    assert!(
        on_liggghts.contains("the liggghts solver cannot run the DEM in the CFD stage's air")
            && on_liggghts.contains("needs the native kernel"),
        "{on_liggghts}"
    );
    let zero = error(&format!(
        "{native}{cfd}coupling: {{iterations: 0, tolerance: 0.01}}\n"
    ));
    assert!(
        zero.contains("coupling.iterations: expected 1 to 10"),
        "{zero}"
    );
}

/// A custom deck whose factor `x` and fixed value take any number, so that only the
/// finiteness checks can refuse them.
const CUSTOM_ANY_RANGE: &str = "\
name: bounded
equipment: custom
case:
  templates: [deck.sh.tera]
  command: [sh, deck.sh]
  responses:
    - {name: y, regex: 'y = (\\S+)'}
factors:
  - {name: x, min: -1, max: 1}
fixed: {z: 2}
design: {type: full_factorial, levels: 3}
";

#[test]
fn a_custom_response_names_the_response_holding_its_interval() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("deck.sh.tera"),
        "echo y = {{ x }} {{ z }}\n",
    )
    .unwrap();
    let load = |responses: &str, extra: &str| {
        let text = CUSTOM_ANY_RANGE.replace("    - {name: y, regex: 'y = (\\S+)'}\n", responses);
        let path = dir.path().join("bounded.yaml");
        std::fs::write(&path, format!("{text}{extra}")).unwrap();
        Study::load(&path)
    };
    let with_interval = "    - {name: y, regex: 'y = (\\S+)', interval: y_half}\n    - {name: y_half, regex: 'h = (\\S+)'}\n";
    let stop = "stop_when: {response: y, ci95_below: 0.05}\n";
    let study = load(with_interval, stop).unwrap();
    assert_eq!(study.interval_of("y"), Some("y_half"));
    assert_eq!(study.interval_of("y_half"), None);
    assert_eq!(study.stop_when.unwrap().ci95_response, "y_half");
    // Without one, `stop_when:` has nothing to watch; a name not declared is refused.
    let without = "    - {name: y, regex: 'y = (\\S+)'}\n";
    let error = load(without, stop).map(drop).unwrap_err().to_string();
    assert!(
        error.contains("stop_when.response: expected a response reported with its 95 % interval"),
        "{error}"
    );
    let unknown = with_interval.replace("interval: y_half", "interval: y_ci95");
    let error = load(&unknown, "").map(drop).unwrap_err().to_string();
    assert!(
        error.contains("case.responses[0].interval: expected another declared response holding the half-width of `y`'s 95 % interval, got `y_ci95`"),
        "{error}"
    );
}

#[test]
fn a_range_too_wide_for_a_float_and_non_finite_values_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("deck.sh.tera"),
        "echo y = {{ x }} {{ z }}\n",
    )
    .unwrap();
    let load = |text: &str| {
        let path = dir.path().join("bounded.yaml");
        std::fs::write(&path, text).unwrap();
        Study::load(&path).map(|_| ()).unwrap_err().to_string()
    };
    let wide = load(&CUSTOM_ANY_RANGE.replace("min: -1, max: 1", "min: -1e308, max: 1e308"));
    assert!(
        wide.contains("factors[0].max: the range [-1e308, 1e308] is wider than a number can hold"),
        "{wide}"
    );
    let infinite = load(&CUSTOM_ANY_RANGE.replace("max: 1}", "max: .inf}"));
    assert!(
        infinite.contains("factors[0].max: expected a finite number, got inf"),
        "{infinite}"
    );
    let negative = load(&CUSTOM_ANY_RANGE.replace("fixed: {z: 2}", "fixed: {z: -.inf}"));
    assert!(
        negative.contains("fixed.z: expected a finite number, got -inf"),
        "{negative}"
    );
    let nan = load(&CUSTOM_ANY_RANGE.replace("fixed: {z: 2}", "fixed: {z: .nan}"));
    assert!(
        nan.contains("fixed.z: expected a finite number, got NaN"),
        "{nan}"
    );
    let ok = CUSTOM_ANY_RANGE.to_string();
    std::fs::write(dir.path().join("bounded.yaml"), &ok).unwrap();
    assert!(Study::load(&dir.path().join("bounded.yaml")).is_ok());
}

#[test]
fn a_study_name_longer_than_a_file_name_may_be_is_refused() {
    let long = "a".repeat(MAX_STUDY_NAME + 1);
    let message = error(&VALID.replace("name: hopper-vibration", &format!("name: {long}")));
    assert!(
        message.contains("name: expected at most 200 characters (it names folders and files, and file systems allow 255 bytes per name), got 201"),
        "{message}"
    );
    let mut study = load(VALID).unwrap();
    assert!(study
        .rename(&long)
        .unwrap_err()
        .starts_with("--as: expected at most 200"));
    assert!(study.rename(&"b".repeat(MAX_STUDY_NAME)).is_ok());
}

#[test]
fn side_files_keep_their_paths_folders_are_copied_whole_and_links_out_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir_all(root.join("meshes/parts")).unwrap();
    std::fs::write(
        root.join("deck.sh.tera"),
        "cat meshes/chute.stl\necho y = {{ x }}\n",
    )
    .unwrap();
    std::fs::write(root.join("meshes/chute.stl"), "solid chute").unwrap();
    std::fs::write(root.join("meshes/parts/lip.stl"), "solid lip").unwrap();
    let study = |files: &str| {
        format!(
            "name: sides\nequipment: custom\ncase:\n  templates: [deck.sh.tera]\n  files: {files}\n  folders: [dumps]\n  command: [sh, deck.sh]\n  responses:\n    - {{name: y, table: post/y.txt, column: 2}}\nfactors:\n  - {{name: x, min: 0, max: 1}}\ndesign: {{type: full_factorial, levels: 2}}\n"
        )
    };
    let load = |text: &str| {
        let path = root.join("sides.yaml");
        std::fs::write(&path, text).unwrap();
        Study::load(&path)
    };
    let loaded = load(&study("[./meshes]")).unwrap();
    let run = tempfile::tempdir().unwrap();
    loaded
        .simulation
        .render(&loaded.case(&loaded.points[0], 1), run.path())
        .unwrap();
    let read = |f: &str| std::fs::read_to_string(run.path().join(f)).unwrap();
    assert_eq!(read("meshes/chute.stl"), "solid chute");
    assert_eq!(read("meshes/parts/lip.stl"), "solid lip");
    assert!(
        run.path().join("post").is_dir(),
        "a response's folder is made"
    );
    assert!(
        run.path().join("dumps").is_dir(),
        "a declared folder is made"
    );
    let inputs: Vec<&str> = loaded.inputs.iter().map(|(p, _)| p.as_str()).collect();
    assert_eq!(
        inputs,
        ["deck.sh.tera", "meshes/chute.stl", "meshes/parts/lip.stl"]
    );

    let elsewhere = tempfile::tempdir().unwrap();
    std::fs::write(elsewhere.path().join("secret"), "not the study's").unwrap();
    std::os::unix::fs::symlink(
        elsewhere.path().join("secret"),
        root.join("meshes/host.stl"),
    )
    .unwrap();
    let error = load(&study("[meshes/host.stl]")).unwrap_err().to_string();
    assert!(
        error.contains("case.files[0]: meshes/host.stl is a link to ")
            && error.contains(
                "secret, outside the study's folder; copy the file into the folder instead"
            ),
        "{error}"
    );
    let error = load(&study("[meshes]")).unwrap_err().to_string();
    assert!(
        error.contains("meshes/host.stl is a link to"),
        "a link inside a folder: {error}"
    );
    std::fs::remove_file(root.join("meshes/host.stl")).unwrap();
    // A link that stays inside the folder is followed.
    std::os::unix::fs::symlink(root.join("meshes/chute.stl"), root.join("meshes/again.stl"))
        .unwrap();
    assert!(load(&study("[meshes/again.stl]")).is_ok());
}

#[test]
fn a_vtk_response_names_its_field_and_where_it_is() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("deck.sh.tera"), "echo {{ x }}\n").unwrap();
    let study = |response: &str| {
        format!(
            "name: worn\nequipment: custom\ncase:\n  templates: [deck.sh.tera]\n  command: [sh, deck.sh]\n  responses:\n    - {response}\nfactors:\n  - {{name: x, min: 0, max: 1}}\ndesign: {{type: full_factorial, levels: 2}}\n"
        )
    };
    let load = |text: &str| {
        let path = dir.path().join("worn.yaml");
        std::fs::write(&path, text).unwrap();
        Study::load(&path).map(|_| ())
    };
    load(&study(
        "{name: wear, vtk: 'post/mesh_*.vtk', field: wear, at: cell, reduce: sum, pick: newest}",
    ))
    .unwrap();
    let no_field = load(&study("{name: wear, vtk: post/mesh.vtk}"))
        .unwrap_err()
        .to_string();
    assert!(
        no_field.contains("a `vtk:` response needs `field:`"),
        "{no_field}"
    );
    let bad_at = load(&study(
        "{name: wear, vtk: post/mesh.vtk, field: wear, at: edge}",
    ))
    .unwrap_err()
    .to_string();
    assert!(
        bad_at.contains("case.responses[0].at: expected `point` or `cell`, got `edge`"),
        "{bad_at}"
    );
    let misplaced = load(&study("{name: y, regex: 'y (\\S+)', field: wear}"))
        .unwrap_err()
        .to_string();
    assert!(
        misplaced.contains("case.responses[0].field: `field` does not apply to this source"),
        "{misplaced}"
    );
    let pick = load(&study("{name: y, json: out.json, key: y, pick: last}"))
        .unwrap_err()
        .to_string();
    assert!(
        pick.contains("`pick` chooses among the files of a glob"),
        "{pick}"
    );
}

/// A custom study of `factors` and `design` whose script uses every name in `uses`.
fn text_study(factors: &str, design: &str, uses: &[&str]) -> Result<Study, StudyError> {
    let dir = tempfile::tempdir().unwrap();
    let script: String = uses
        .iter()
        .map(|n| format!("echo {n} = {{{{ {n} }}}}\n"))
        .collect();
    std::fs::write(dir.path().join("deck.sh.tera"), script).unwrap();
    let text = format!(
        "name: words\nequipment: custom\ncase:\n  templates: [deck.sh.tera]\n  command: [sh, deck.sh]\n  responses:\n    - {{name: y, regex: 'y = (\\S+)'}}\nfactors:\n{factors}design: {design}\n"
    );
    let path = dir.path().join("words.yaml");
    std::fs::write(&path, &text).unwrap();
    Study::load(&path)
}

#[test]
fn text_factors_cross_every_design_but_a_hypercube_which_shares_levels_out() {
    let factors = "  - {name: x, min: 0, max: 2}\n  - {name: y, min: 0, max: 1}\n  - {name: model, levels: [hertz, hooke]}\n";
    let uses = ["x", "y", "model"];
    // A central composite over x and y (4 + 4 + 1 points) at each of 2 levels.
    let ccd = text_study(
        factors,
        "{type: central_composite, center_points: 1}",
        &uses,
    )
    .unwrap();
    assert_eq!(ccd.points.len(), 18);
    assert_eq!(ccd.levels(), [0, 0, 2]);
    let hooke: Vec<&DesignPoint> = ccd.points.iter().filter(|p| p.natural[2] == 1.0).collect();
    assert_eq!(hooke.len(), 9);
    assert!(hooke.iter().all(|p| p.coded[2] == 1.0));
    // The template sees the level's text, not its index.
    let case = ccd.case(hooke[0], 7);
    assert_eq!(case.text["model"], "hooke");
    assert!(!case.parameters.0.contains_key("model"));
    // A Latin hypercube of 9: the levels get 5 and 4 runs, x keeps one run per stratum.
    let lhs = text_study(factors, "{type: latin_hypercube, samples: 9}", &uses).unwrap();
    let hertz = lhs.points.iter().filter(|p| p.natural[2] == 0.0).count();
    assert!(hertz == 4 || hertz == 5, "{hertz}");
    let mut strata: Vec<usize> = lhs
        .points
        .iter()
        .map(|p| ((p.coded[0] + 1.0) / 2.0 * 9.0).floor() as usize)
        .collect();
    strata.sort();
    assert_eq!(strata, (0..9).collect::<Vec<_>>());
    // Only text factors: the full factorial of their levels.
    let words = text_study(
        "  - {name: model, levels: [hertz, hooke]}\n  - {name: mesh, levels: [a, b, c]}\n",
        "{type: full_factorial, levels: 3}",
        &["model", "mesh"],
    )
    .unwrap();
    assert_eq!(words.points.len(), 6);
    // A next round keeps every level whatever box the numbers shrink to.
    let narrow = vec![
        FactorRange { min: 0.5, max: 1.0 },
        FactorRange { min: 0.2, max: 0.4 },
        FactorRange { min: 1.0, max: 1.0 },
    ];
    assert_eq!(
        ccd.text_kept_whole(narrow)[2],
        FactorRange { min: 0.0, max: 1.0 }
    );
    // The crossed design's size is checked: 3^4 numeric points × 2 × 3 × … levels.
    let many = format!(
        "{}  - {{name: a, levels: [{}]}}\n",
        factors,
        (0..100)
            .map(|i| format!("l{i}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let error = text_study(
        &many,
        "{type: full_factorial, levels: 40}",
        &["x", "y", "model", "a"],
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("more than the limit of 100000"), "{error}");
}

#[test]
fn a_text_factor_cannot_carry_a_unit_or_a_spread() {
    let error = text_study(
        "  - {name: x, min: 0, max: 2}\n  - {name: model, levels: [hertz, hooke], unit: m}\n",
        "{type: full_factorial, levels: 2}",
        &["x", "model"],
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("factors[1].unit: `model` is a text factor and has no unit"),
        "{error}"
    );
    let error = text_study(
        "  - {name: x, min: 0, max: 2}\n  - {name: model, levels: [hertz, hooke]}\nuncertainty:\n  parameters:\n    - {name: model, distribution: normal, mean: 0.5, std: 0.1}\n",
        "{type: full_factorial, levels: 2}",
        &["x", "model"],
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("`model` is a text factor (hertz, hooke)"),
        "{error}"
    );
    let error = text_study(
        "  - {name: x, min: 0}\n",
        "{type: full_factorial, levels: 2}",
        &["x"],
    )
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("`x` needs a range (min and max, SI units) or, for text, `levels: [a, b]`"),
        "{error}"
    );
}

/// A time step the native kernel would refuse fails the study at load, naming the
/// design point and the largest safe step; the same study on LIGGGHTS, which orch
/// cannot read ahead, loads. Fine spheres (0.8 mm) at 20 µs: far above 0.3 of their
/// Rayleigh time.
#[test]
fn a_time_step_the_kernel_would_refuse_fails_the_study_at_load() {
    let fine = VALID.replace(
        "  valve_diameter: 0.012\n",
        "  valve_diameter: 0.012\n  fine_diameter: 0.0008\n  timestep: 0.00002\n",
    );
    assert!(load(&fine).is_ok(), "LIGGGHTS's deck is not read ahead");
    let native = fine.replace("solver: liggghts", "solver: native");
    let message = error(&native);
    assert!(
        message.contains("design point 0")
            && message.contains("`timestep`")
            && message.contains("above the largest safe time step")
            && message.contains("give at most"),
        "{message}"
    );
    let safe = native.replace("timestep: 0.00002", "timestep: 0.000002");
    assert!(load(&safe).is_ok(), "{}", error(&safe));
}
