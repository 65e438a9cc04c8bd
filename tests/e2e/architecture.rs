//! Architecture invariants that a test can check (docs/architecture.md).

use crate::support::root;

/// The `[dependencies]` names of a crate's manifest.
fn dependencies(crate_dir: &str) -> Vec<String> {
    let manifest = std::fs::read_to_string(root().join(crate_dir).join("Cargo.toml")).unwrap();
    let mut in_dependencies = false;
    let mut names = Vec::new();
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            in_dependencies = line == "[dependencies]";
        } else if in_dependencies && !line.is_empty() && !line.starts_with('#') {
            names.push(line.split(['=', '.']).next().unwrap().trim().to_string());
        }
    }
    names
}

#[test]
fn the_pure_crates_know_nothing_of_io_runtimes_databases_or_templates() {
    for (crate_dir, allowed) in [
        (
            "dem",
            &[
                "nalgebra",
                "rand",
                "rand_chacha",
                "rayon",
                "serde",
                "thiserror",
                "toml",
            ][..],
        ),
        ("granular", &["thiserror"][..]),
        (
            "metamodel",
            &["nalgebra", "rand", "rand_chacha", "rand_distr", "thiserror"][..],
        ),
    ] {
        for dependency in dependencies(crate_dir) {
            assert!(
                allowed.contains(&dependency.as_str()),
                "{crate_dir} depends on {dependency}, which a pure crate must not"
            );
        }
    }
}

#[test]
fn adapters_do_not_depend_on_the_orchestrator_or_its_runtime() {
    for dependency in dependencies("adapters") {
        assert!(
            !["orch", "tokio", "sqlx"].contains(&dependency.as_str()),
            "orch-adapters depends on {dependency}"
        );
    }
}
