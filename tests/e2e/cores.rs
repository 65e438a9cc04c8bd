//! One run on many cores (`executor.cores_per_job`): LIGGGHTS on two MPI ranks (on this
//! machine, and spread over both two-CPU nodes of the Slurm test cluster, one rank per
//! node) and the native kernel on two threads (here, and on one node of the cluster),
//! against the same studies on one core.

use std::path::PathBuf;
use std::time::Instant;

use serde_json::Value;

use crate::support::{require_liggghts, require_slurm, slurm_lock, solver_lock, text, Project};

/// A two-point hopper study on `solver` with `cores` per job, one job at a time (so
/// that the two studies' wall times compare run for run).
fn study(solver: &str, cores: usize, particles: u32) -> String {
    study_on(
        &format!("{solver}-{cores}"),
        solver,
        &format!("{{max_parallel: 1, cores_per_job: {cores}, time_limit: 5min, retries: 0}}"),
        particles,
    )
}

/// The two-point hopper study of [`study`], named `name`, on `executor`.
fn study_on(name: &str, solver: &str, executor: &str, particles: u32) -> String {
    format!(
        "name: {name}\n\
         solver: {solver}\n\
         executor: {executor}\n\
         factors:\n  - {{name: outlet_diameter, min: 0.024, max: 0.028, unit: m}}\n\
         fixed: {{n_particles: {particles}, fill_time: 0.2, discharge_time: 0.6}}\n\
         design: {{type: full_factorial, levels: 2}}\n\
         seed: 7\n\
         responses: [discharge_rate]\n"
    )
}

/// Runs `study(solver, cores)` to the end; returns its status and the wall time, s.
fn run(project: &Project, solver: &str, cores: usize, particles: u32) -> (Value, f64) {
    let name = format!("{solver}-{cores}");
    let file = project.write(&format!("{name}.yaml"), &study(solver, cores, particles));
    let started = Instant::now();
    // `--no-reuse`: the native kernel's result does not depend on its threads, so its
    // 2-thread runs are the 1-thread runs by identity and would be reused, not run.
    let output = project.run(&["submit", "--no-reuse", file.to_str().unwrap()]);
    let wall = started.elapsed().as_secs_f64();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("finished: 2 succeeded, 0 failed"),
        "{stderr}"
    );
    (project.status(&name), wall)
}

/// `(job name, responses)` of every job, by name.
fn responses(status: &Value) -> Vec<(String, serde_json::Map<String, Value>)> {
    let mut jobs: Vec<_> = status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|job| {
            let name = job["name"].as_str().unwrap().to_string();
            (name, job["responses"].as_object().unwrap().clone())
        })
        .collect();
    jobs.sort_by(|a, b| a.0.cmp(&b.0));
    jobs
}

#[test]
fn liggghts_on_two_mpi_ranks_here_and_across_two_slurm_nodes_discharges_like_one_rank() {
    if !require_liggghts() {
        return;
    }
    // The Slurm part's locks first, in the order the Slurm tests take them.
    let slurm = require_slurm();
    let _cluster = slurm.as_ref().map(|_| slurm_lock());
    let _lock = solver_lock();
    let project = Project::new();
    let (one, one_wall) = run(&project, "liggghts", 1, 1000);
    let (two, two_wall) = run(&project, "liggghts", 2, 1000);
    eprintln!(
        "LIGGGHTS, 2 runs of 1000 particles: 1 rank {one_wall:.1} s, 2 ranks {two_wall:.1} s wall"
    );

    for dir in project.run_dirs("liggghts-2") {
        let log = std::fs::read_to_string(dir.join("log.liggghts")).unwrap();
        assert!(log.contains("1 by 1 by 2 MPI processor grid"), "{log}");
        assert!(log.contains(" on 2 procs for "), "{log}");
        let deck = std::fs::read_to_string(dir.join("hopper.in")).unwrap();
        assert!(deck.contains("\nprocessors      1 1 2\n"), "{deck}");
    }
    for dir in project.run_dirs("liggghts-1") {
        let log = std::fs::read_to_string(dir.join("log.liggghts")).unwrap();
        assert!(log.contains(" on 1 procs for "), "{log}");
    }
    for ((name, r1), (_, r2)) in responses(&one).iter().zip(responses(&two)) {
        let (a, b) = (
            r1["discharge_rate"].as_f64().unwrap(),
            r2["discharge_rate"].as_f64().unwrap(),
        );
        let loop_time =
            |r: &serde_json::Map<String, Value>| r["solver_loop_time"].as_f64().unwrap();
        eprintln!(
            "{name}: discharge_rate 1 rank {a:.4} kg/s, 2 ranks {b:.4} kg/s ({:+.1} %); loop time {:.1} s vs {:.1} s",
            100.0 * (b / a - 1.0),
            loop_time(r1),
            loop_time(&r2)
        );
        assert!((b / a - 1.0).abs() <= 0.10, "{name}: {a} vs {b} kg/s");
    }

    // The same two ranks on the Slurm test cluster, one per node (its nodes have two
    // CPUs each, so only `--ntasks-per-node=1` spreads them): each job's ranks run on
    // both nodes, mpirun starting the second through Slurm.
    let Some(conf) = slurm else { return };
    let cluster = Project::on_slurm(&conf);
    let executor = "{kind: slurm, cores_per_job: 2, time_limit: 5min, retries: 0, poll_interval: 1s, extra_sbatch: ['--ntasks-per-node=1']}";
    let file = cluster.write(
        "liggghts-2-slurm.yaml",
        &study_on("liggghts-2-slurm", "liggghts", executor, 1000),
    );
    let output = cluster.run(&["submit", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    let spread = cluster.status("liggghts-2-slurm");
    for job in spread["jobs"].as_array().unwrap() {
        let dir = PathBuf::from(job["run_dir"].as_str().unwrap());
        let attempts = std::fs::read_to_string(dir.join("orch-attempts.log")).unwrap();
        // `start slurm:<id> <time> <host> <nodes>`: the allocation spans both nodes.
        let nodes = attempts.lines().next().unwrap().rsplit(' ').next().unwrap();
        assert_eq!(nodes, "n[1-2]", "{attempts}");
        let log = std::fs::read_to_string(dir.join("log.liggghts")).unwrap();
        assert!(log.contains("1 by 1 by 2 MPI processor grid"), "{log}");
        assert!(log.contains(" on 2 procs for "), "{log}");
    }
    for ((name, r1), (_, r2)) in responses(&one).iter().zip(responses(&spread)) {
        let (a, b) = (
            r1["discharge_rate"].as_f64().unwrap(),
            r2["discharge_rate"].as_f64().unwrap(),
        );
        eprintln!(
            "{name}: discharge_rate 1 rank {a:.4} kg/s, 2 ranks on 2 Slurm nodes {b:.4} kg/s ({:+.1} %)",
            100.0 * (b / a - 1.0)
        );
        assert!((b / a - 1.0).abs() <= 0.10, "{name}: {a} vs {b} kg/s");
    }
}

#[test]
fn the_native_kernel_on_two_threads_gives_the_responses_of_one_bit_for_bit() {
    // The Slurm part's locks first, in the order the Slurm tests take them.
    let slurm = require_slurm();
    let _cluster = slurm.as_ref().map(|_| slurm_lock());
    let _lock = solver_lock();
    let project = Project::new();
    let (one, one_wall) = run(&project, "native", 1, 600);
    let (two, two_wall) = run(&project, "native", 2, 600);
    eprintln!(
        "native, 2 runs of 600 particles: 1 thread {one_wall:.1} s, 2 threads {two_wall:.1} s wall"
    );
    let (one, two) = (responses(&one), responses(&two));
    assert_eq!(one.len(), 2);
    for ((name, r1), (_, r2)) in one.iter().zip(&two) {
        let physical = |r: &serde_json::Map<String, Value>| {
            let mut r = r.clone();
            r.retain(|k, _| !k.starts_with("solver_"));
            r
        };
        assert!(physical(r1).contains_key("discharge_rate"), "{r1:?}");
        assert_eq!(physical(r1), physical(r2), "{name}");
        // The run's deepest overlap is a solver figure, but not a timing: the same
        // on any number of threads, and well inside the kernel's bound of 0.25.
        let overlap =
            |r: &serde_json::Map<String, Value>| r["solver_largest_overlap"].as_f64().unwrap();
        assert_eq!(overlap(r1), overlap(r2), "{name}");
        assert!(
            overlap(r1) > 0.0 && overlap(r1) < 0.25,
            "{name}: {}",
            overlap(r1)
        );
        eprintln!(
            "{name}: loop time 1 thread {:.2} s, 2 threads {:.2} s",
            r1["solver_loop_time"].as_f64().unwrap(),
            r2["solver_loop_time"].as_f64().unwrap()
        );
    }
    for (study, threads) in [("native-1", 1), ("native-2", 2)] {
        for dir in project.run_dirs(study) {
            let log = std::fs::read_to_string(dir.join("log.native")).unwrap();
            assert!(
                log.contains(&format!(" on {threads} threads for ")),
                "{log}"
            );
        }
    }

    // Two threads on one node of the Slurm cluster: one task on two CPUs, the same
    // responses bit for bit.
    let Some(conf) = slurm else { return };
    let cluster = Project::on_slurm(&conf);
    let executor =
        "{kind: slurm, cores_per_job: 2, time_limit: 5min, retries: 0, poll_interval: 1s}";
    let file = cluster.write(
        "native-2-slurm.yaml",
        &study_on("native-2-slurm", "native", executor, 600),
    );
    let output = cluster.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let on_slurm = cluster.status("native-2-slurm");
    for job in on_slurm["jobs"].as_array().unwrap() {
        let dir = PathBuf::from(job["run_dir"].as_str().unwrap());
        let attempts = std::fs::read_to_string(dir.join("orch-attempts.log")).unwrap();
        // `start slurm:<id> <time> <host> <nodes>`: one node.
        let nodes = attempts.lines().next().unwrap().rsplit(' ').next().unwrap();
        assert!(nodes == "n1" || nodes == "n2", "{attempts}");
        let log = std::fs::read_to_string(dir.join("log.native")).unwrap();
        assert!(log.contains(" on 2 threads for "), "{log}");
    }
    for ((name, r1), (_, r2)) in one.iter().zip(responses(&on_slurm)) {
        let physical = |r: &serde_json::Map<String, Value>| {
            let mut r = r.clone();
            r.retain(|k, _| !k.starts_with("solver_"));
            r
        };
        assert_eq!(physical(r1), physical(&r2), "{name} on Slurm");
    }
}
