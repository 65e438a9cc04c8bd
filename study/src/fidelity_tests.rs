use std::path::Path;

use super::*;

/// Two levels of the native hopper: 300 particles, then a nested 4 of the 9 points
/// with 1000.
const LEVELS: &str = "\
name: levels
solver: native
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
  - {name: friction, min: 0.4, max: 0.6}
fixed: {n_particles: 300}
design: {type: full_factorial, levels: 3}
fidelity:
  - {name: coarse, cost: 1}
  - {name: fine, cost: 4, runs: 4, fixed: {n_particles: 1000}}
objective: {response: discharge_rate, goal: maximise}
";

fn load(text: &str) -> Result<Study, StudyError> {
    Study::from_text(Path::new("jobs/study.yaml"), text, None)
}

fn error(text: &str) -> String {
    load(text).unwrap_err().to_string()
}

#[test]
fn a_higher_level_runs_a_nested_subset_with_its_own_parameters() {
    let study = load(LEVELS).unwrap();
    assert_eq!(study.fidelities.len(), 2);
    assert_eq!(study.points.len(), 9 + 4);
    let (coarse, fine): (Vec<&DesignPoint>, Vec<&DesignPoint>) =
        study.points.iter().partition(|p| p.fidelity == 0);
    assert_eq!((coarse.len(), fine.len()), (9, 4));
    // Every fine point is a coarse point, the first the centre, then corners.
    for point in &fine {
        assert!(coarse.iter().any(|c| c.coded == point.coded), "{point:?}");
    }
    assert_eq!(fine[0].coded, vec![0.0, 0.0]);
    assert!(fine[1..]
        .iter()
        .all(|p| p.coded.iter().all(|c| c.abs() == 1.0)));
    // Each level's case: the study's fixed value, then the level's over it.
    assert_eq!(study.case(coarse[0], 0).get("n_particles"), 300.0);
    assert_eq!(study.case(fine[0], 0).get("n_particles"), 1000.0);
    // 13 design runs and the 4 held-out test points a full factorial gets.
    assert_eq!(study.job_count(), 17);
    // Held-out test points run at the top level.
    let tests = study.test_points(0, &[study.factors[0].range, study.factors[1].range]);
    assert!(tests.iter().all(|p| p.fidelity == 1));
}

#[test]
fn a_twin_at_a_higher_level_is_another_run_with_its_own_seed() {
    use crate::plan::{plan_points, PointPurpose};
    // The levels differ by their solver alone, so the case key must tell them apart.
    let text = LEVELS.replace(", fixed: {n_particles: 1000}", "");
    let study = load(&text).unwrap();
    let planned = plan_points(&study, 0, &study.points, PointPurpose::Design);
    let seed_of = |i: usize| planned[i].jobs[0].seed;
    let twin = study
        .points
        .iter()
        .position(|p| p.fidelity == 0 && p.coded == study.points[9].coded)
        .unwrap();
    assert_ne!(seed_of(twin), seed_of(9));
    // Named after its twin: the first fine run is the centre's, p004's.
    assert_eq!(twin, 4);
    assert_eq!(planned[9].jobs[0].name, "p004r0-fine");
    assert_eq!(planned[twin].jobs[0].name, "p004r0");
    // The first level's seeds are those of the same study without levels.
    let single = load(&text.replace(
        "fidelity:\n  - {name: coarse, cost: 1}\n  - {name: fine, cost: 4, runs: 4}\n",
        "",
    ))
    .unwrap();
    let alone = plan_points(&single, 0, &single.points, PointPurpose::Design);
    for (i, point) in alone.iter().enumerate() {
        assert_eq!(seed_of(i), point.jobs[0].seed, "point {i}");
    }
}

#[test]
fn a_level_may_run_another_solver() {
    let text = LEVELS.replace(
        "{name: fine, cost: 4, runs: 4, fixed: {n_particles: 1000}}",
        "{name: liggghts, solver: liggghts, cost: 4, runs: 4}",
    );
    let study = load(&text).unwrap();
    assert_eq!(study.simulation_at(0).solver_name(), "native");
    assert_eq!(study.simulation_at(1).solver_name(), "liggghts");
    let fine = study.points.iter().find(|p| p.fidelity == 1).unwrap();
    assert_eq!(study.case(fine, 0).get("n_particles"), 300.0);
}

#[test]
fn bad_levels_are_refused_naming_the_field_and_what_to_do() {
    let cases: &[(&str, &str, &str)] = &[
        (
            "  - {name: fine, cost: 4, runs: 4, fixed: {n_particles: 1000}}\n",
            "",
            "jobs/study.yaml:9:3: fidelity: expected two levels or more",
        ),
        (
            "{name: fine, cost: 4,",
            "{name: fine, cost: 1,",
            "fidelity[1].cost: expected a finite cost above 1",
        ),
        (
            "{name: coarse, cost: 1}",
            "{name: coarse, cost: 1, runs: 3}",
            "fidelity[0].runs: the first (cheapest) level runs every design point",
        ),
        (
            " runs: 4,",
            "",
            "fidelity[1].runs: expected `runs:`, how many of the 9 points",
        ),
        (
            " runs: 4,",
            " runs: 10,",
            "fidelity[1].runs: expected 3 to 9 runs",
        ),
        (" runs: 4,", " runs: 2,", "expected 3 to 9 runs"),
        (
            "{name: fine,",
            "{name: coarse,",
            "fidelity[1].name: `coarse` names two levels",
        ),
        (
            "{name: fine,",
            "{name: 'fine level',",
            "fidelity[1].name: expected 1 to 64 letters",
        ),
        (
            "{n_particles: 1000}",
            "{n_particles: 0.5}",
            "fidelity[1].fixed.n_particles: `n_particles` must lie within",
        ),
        (
            "{n_particles: 1000}",
            "{friction: 0.5}",
            "fidelity[1].fixed.friction: `friction` is a factor",
        ),
        (
            "{n_particles: 1000}",
            "{grip: 1}",
            "fidelity[1].fixed.grip: `grip` is not a parameter of the hopper equipment on native",
        ),
        (
            "{name: fine, cost: 4,",
            "{name: fine, solver: edem, cost: 4,",
            "fidelity[1].solver: unknown solver `edem`",
        ),
        (
            "objective:",
            "metamodel: {model: polynomial}\nobjective:",
            "`metamodel.model` cannot be combined with `fidelity:`",
        ),
    ];
    for (from, to, expected) in cases {
        assert!(LEVELS.contains(from), "{from}");
        let message = error(&LEVELS.replacen(from, to, 1));
        assert!(message.contains(expected), "{from} → {to}:\n{message}");
    }
}
