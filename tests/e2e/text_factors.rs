//! Text factors (`levels:`) in a user's own deck: the design crosses the numeric design
//! with every combination of levels, the deck sees each level as text, the surface's
//! indicator terms find the best level and the best number together, the next round
//! keeps every level, and status, export and the report (as Chromium renders it) show
//! the levels' names.
//!
//! The deck is a user's shell script with a known answer: it tests orch's handling of
//! text factors, not a solver's physics.

use std::collections::BTreeMap;

use crate::support::{count, rendered_dom, text, Project};

/// `y = m(mesh) + (x − 0.3)² + [fast] (0.1 x − 0.2)`: at `mode = fast`, `mesh =
/// fine` the minimum is `x = 0.25`, `y = 0.3275`; `slow` is best at `x = 0.3`.
const DECK: &str = r#"mkdir -p post
{% if mode == "fast" %}shift="0.1 * x - 0.2"{% else %}shift=0{% endif %}
{% if mesh == "fine" %}m=0.5{% elif mesh == "coarse" %}m=1.5{% else %}m=1{% endif %}
awk -v x={{ x }} -v m=$m "BEGIN { printf \"y = %.12g\n\", m + (x - 0.3)^2 + $shift }"
echo "mesh {{ mesh }}, mode {{ mode }}"
"#;

const STUDY: &str = "\
name: modes
equipment: custom
case:
  templates: [deck.sh.tera]
  command: [sh, deck.sh]
  responses:
    - {name: y, regex: 'y = (\\S+)'}
executor: {max_parallel: 2, retries: 0}
factors:
  - {name: x, min: 0, max: 1}
  - {name: mode, levels: [slow, fast]}
  - {name: mesh, levels: [fine, medium, coarse]}
design: {type: full_factorial, levels: 3}
metamodel: {model: polynomial, order: 2, test_points: 0}
objective: {response: y, goal: minimise}
rounds: 2
";

#[test]
fn text_factors_are_crossed_rendered_fitted_and_shown_by_name() {
    let project = Project::new();
    project.write("deck.sh.tera", DECK);
    let file = project.write("modes.yaml", STUDY);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));

    let status = project.status("modes");
    let jobs = status["jobs"].as_array().unwrap();
    assert_eq!(count(&status, "succeeded"), jobs.len(), "{status:#}");
    // Round 0: three values of x at each of the 2 × 3 combinations of levels.
    let mut per_combination: BTreeMap<(String, String), Vec<f64>> = BTreeMap::new();
    for job in jobs
        .iter()
        .filter(|j| j["name"].as_str().unwrap().starts_with('p'))
    {
        let factors = &job["factors"];
        let key = (
            factors["mode"].as_str().unwrap().to_string(),
            factors["mesh"].as_str().unwrap().to_string(),
        );
        per_combination
            .entry(key)
            .or_default()
            .push(factors["x"].as_f64().unwrap());
    }
    assert_eq!(per_combination.len(), 6, "{per_combination:?}");
    for xs in per_combination.values() {
        assert!(xs.len() >= 3, "{per_combination:?}");
    }
    // The deck saw the levels as text.
    let first = project.project_dir().join("runs/modes/p000r0");
    let stdout = std::fs::read_to_string(first.join("stdout.log")).unwrap_or_default();
    let deck = std::fs::read_to_string(first.join("deck.sh")).unwrap();
    assert!(
        deck.contains("m=0.5") && deck.contains("shift=0"),
        "{deck}\n{stdout}"
    );

    // The quadratic with indicator terms holds the truth: R² = 1, and the optimum is
    // fast, fine, x = 0.25.
    let round = &status["rounds"][0];
    let fit = &round["fits"][0];
    assert!(fit["r2"].as_f64().unwrap() > 1.0 - 1e-9, "{fit:#}");
    let optimum = &round["optimum"];
    assert_eq!(optimum["factors"]["mode"], "fast", "{optimum:#}");
    assert_eq!(optimum["factors"]["mesh"], "fine", "{optimum:#}");
    let x = optimum["factors"]["x"].as_f64().unwrap();
    assert!((x - 0.25).abs() < 1e-6, "{optimum:#}");
    assert!((optimum["value"].as_f64().unwrap() - 0.3275).abs() < 1e-6);

    // Round 1 narrows x around 0.25 and keeps every level.
    let second: Vec<&serde_json::Value> = jobs
        .iter()
        .filter(|j| j["name"].as_str().unwrap().starts_with("r1"))
        .collect();
    assert!(!second.is_empty(), "{status:#}");
    let modes: std::collections::BTreeSet<&str> = second
        .iter()
        .map(|j| j["factors"]["mode"].as_str().unwrap())
        .collect();
    assert_eq!(modes.len(), 2, "{second:#?}");
    let text_status = text(&project.run(&["status", "modes"]).stdout);
    assert!(
        text_status.contains("mode = fast, mesh = fine"),
        "{text_status}"
    );
    assert!(
        text_status.contains("mesh {fine, medium, coarse}"),
        "{text_status}"
    );
    assert!(!text_status.contains("limit of mode"), "{text_status}");

    // Export: the levels' names in their columns.
    let csv = project.dir.path().join("modes.csv");
    let output = project.run(&["export", "modes", "-o", csv.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let table = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (mode, mesh) = (column("mode"), column("mesh"));
    let second_row: Vec<&str> = table.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(
        (second_row[mode], second_row[mesh]),
        ("slow", "fine"),
        "{table}"
    );

    // The report, as a browser shows it: the design table names levels, the slices
    // have one curve per combination.
    let output = project.run(&["report", "modes"]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let page = std::path::PathBuf::from(text(&output.stdout).trim());
    if let Some(dom) = rendered_dom(&page, project.dir.path()) {
        assert!(
            dom.contains("<td>coarse</td>"),
            "no level in the design table"
        );
        assert!(
            dom.contains("mode = fast, mesh = fine"),
            "no curve per level"
        );
        assert!(
            dom.contains("every level"),
            "no text factor in the box table"
        );
    }
}

#[test]
fn a_latin_hypercube_shares_each_level_equally_and_bad_text_factors_are_refused() {
    let project = Project::new();
    project.write("deck.sh.tera", DECK);
    let hypercube = STUDY
        .replace("name: modes", "name: spread")
        .replace(
            "design: {type: full_factorial, levels: 3}",
            "design: {type: latin_hypercube, samples: 12}",
        )
        .replace("rounds: 2\n", "");
    let file = project.write("spread.yaml", &hypercube);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status("spread");
    let mut meshes: BTreeMap<String, usize> = BTreeMap::new();
    for job in status["jobs"].as_array().unwrap() {
        *meshes
            .entry(job["factors"]["mesh"].as_str().unwrap().to_string())
            .or_default() += 1;
    }
    assert_eq!(
        meshes.values().copied().collect::<Vec<_>>(),
        [4, 4, 4],
        "{meshes:?}"
    );
    assert_eq!(count(&status, "succeeded"), 12);

    for (change, expected) in [
        (
            ("[slow, fast]", "[slow]"),
            "factors[1].levels: `mode` has 1 level; a text factor needs at least two",
        ),
        (
            ("[slow, fast]", "[slow, slow]"),
            "factors[1].levels[1]: `slow` is listed twice",
        ),
        (
            ("{name: mode, levels", "{name: mode, min: 0, levels"),
            "factors[1].min: `mode` has levels and a range",
        ),
    ] {
        let bad = STUDY
            .replace("name: modes", "name: bad")
            .replace(change.0, change.1);
        let file = project.write("bad.yaml", &bad);
        let output = project.run(&["submit", "--dry-run", file.to_str().unwrap()]);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(expected), "{stderr}");
    }
    // A text factor the templates do not use is refused like a numeric one.
    let unused = STUDY
        .replace("name: modes", "name: unused")
        .replace("  - {name: mesh, levels: [fine, medium, coarse]}\n", "  - {name: mesh, levels: [fine, medium, coarse]}\n  - {name: colour, levels: [red, blue]}\n");
    let file = project.write("unused.yaml", &unused);
    let output = project.run(&["submit", "--dry-run", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("factor `colour` is not used by the templates: they render the same at each of its levels (red, blue)"),
        "{stderr}"
    );
    // On a built-in equipment a text factor is refused, saying where text belongs.
    let hopper = "name: hop\nsolver: native\nfactors:\n  - {name: outlet_diameter, levels: [a, b]}\ndesign: {type: full_factorial, levels: 2}\n";
    let file = project.write("hop.yaml", hopper);
    let output = project.run(&["submit", "--dry-run", file.to_str().unwrap()]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("text factors are for your own deck"),
        "{stderr}"
    );
    assert!(!project.project_dir().join("runs/bad").exists());
}

#[test]
fn the_contact_model_is_a_design_variable_of_a_real_liggghts_deck() {
    if !crate::support::require_liggghts() {
        return;
    }
    let _lock = crate::support::solver_lock();
    let project = Project::new();
    let deck = project.dir.path().join("inclined-plane");
    std::fs::create_dir_all(&deck).unwrap();
    for file in ["in.plane.tera", "materials.in"] {
        let from = crate::support::root()
            .join("jobs/inclined-plane")
            .join(file);
        std::fs::copy(from, deck.join(file)).unwrap();
    }
    let study =
        std::fs::read_to_string(crate::support::root().join("jobs/contact-models.yaml")).unwrap();
    let file = project.write("contact-models.yaml", &study);
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));

    let status = project.status("contact-models");
    assert_eq!(count(&status, "succeeded"), 6, "{status:#}");
    let mut models = BTreeMap::new();
    for job in status["jobs"].as_array().unwrap() {
        let angle = job["factors"]["angle"].as_f64().unwrap();
        let model = job["factors"]["contact_model"]
            .as_str()
            .unwrap()
            .to_string();
        let acceleration = job["responses"]["acceleration"].as_f64().unwrap();
        let speed = job["responses"]["mean_speed"].as_f64().unwrap();
        eprintln!(
            "{model} at {angle}°: mean speed {speed:.4} m/s, acceleration {acceleration:.4} m/s²"
        );
        // Rolling spheres accelerate at most at (5/7) g sin θ, whatever the contact.
        let rolling = 5.0 / 7.0 * 9.81 * angle.to_radians().sin();
        assert!(
            acceleration > 0.0 && acceleration < rolling,
            "{model} {angle}: {acceleration}"
        );
        let run = project
            .project_dir()
            .join("runs/contact-models")
            .join(job["name"].as_str().unwrap());
        let rendered = std::fs::read_to_string(run.join("in.plane")).unwrap();
        assert!(rendered.contains(&format!("pair_style      gran model {model} tangential")));
        assert_eq!(
            rendered.contains("characteristicVelocity"),
            model == "hooke"
        );
        models
            .entry(model)
            .or_insert_with(Vec::new)
            .push((angle, speed));
    }
    // Both models: three angles each, the layer faster on a steeper plane.
    assert_eq!(models.len(), 2, "{models:?}");
    for runs in models.values_mut() {
        runs.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(runs.len(), 3);
        assert!(runs[0].1 < runs[1].1 && runs[1].1 < runs[2].1, "{runs:?}");
    }
    // The surface carries the model as an indicator term.
    let fit = &status["rounds"][0]["fits"][0];
    assert!(fit["error"].is_null(), "{fit:#}");
}
