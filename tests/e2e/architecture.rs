//! Architecture invariants that a test can check (docs/architecture.md).

use std::path::{Path, PathBuf};

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
            // orch-granular: the crossings table's one owner, itself pure.
            &[
                "nalgebra",
                "orch-granular",
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
            // rayon: the Kriging likelihood's starts and the repeated pruning run in
            // parallel; threads, no I/O.
            &[
                "nalgebra",
                "rand",
                "rand_chacha",
                "rand_distr",
                "rayon",
                "thiserror",
            ][..],
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

/// Every `.rs` file under `dir`, with its text cut before its test module: files of
/// tests (`tests.rs`, `*_tests.rs`) are left out, and in other files what follows a
/// `#[cfg(test)]` line.
fn production_sources(dir: &Path) -> Vec<(PathBuf, String)> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap().flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if path.is_dir() {
                stack.push(path);
            } else if name.ends_with(".rs") && name != "tests.rs" && !name.ends_with("_tests.rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                let production = match text.find("\n#[cfg(test)]") {
                    Some(cut) => text[..cut].to_string(),
                    None => text,
                };
                found.push((path, production));
            }
        }
    }
    found
}

/// The pure crates take bytes and give numbers: no file, process, environment, network
/// or clock of their own, whatever their dependencies would allow (the caller reads the
/// files and hands over what they hold).
#[test]
fn the_pure_crates_touch_no_file_process_environment_or_network() {
    let forbidden = [
        "std::fs",
        "std::process",
        "std::env",
        "std::net",
        "File::open",
        "File::create",
        "SystemTime::now",
    ];
    let mut found = Vec::new();
    for crate_dir in ["dem/src", "granular/src", "metamodel/src"] {
        for (path, text) in production_sources(&root().join(crate_dir)) {
            for word in forbidden {
                if text.contains(word) {
                    found.push(format!("{} uses {word}", path.display()));
                }
            }
        }
    }
    assert!(found.is_empty(), "{found:#?}");
}

/// The sources of the crates that run studies around the pure cores and the adapters:
/// the `orch` binary's crate and the crates split from it.
const ORCHESTRATOR_SOURCES: [&str; 5] = [
    "orchestrator/src",
    "study/src",
    "store/src",
    "compare/src",
    "page/src",
];

/// Production files of the orchestrator's crates and `adapters/src`, other than
/// `allowed`, that spell one of `names` as a string literal.
fn spelled_outside(names: &[&str], allowed: &[PathBuf]) -> Vec<String> {
    let mut offenders = Vec::new();
    for dir in ORCHESTRATOR_SOURCES.iter().chain(&["adapters/src"]) {
        for (path, text) in production_sources(&root().join(dir)) {
            if allowed.contains(&path) {
                continue;
            }
            for name in names {
                if text.contains(&format!("\"{name}\"")) {
                    offenders.push(format!("{} spells \"{name}\"", path.display()));
                }
            }
        }
    }
    offenders
}

/// The equipment seam: the driver, study validation, rounds, status and CLI ask the
/// study's equipment for response names, so no hopper response name appears as a
/// string outside the hopper's own module. The exception is a stage's declared
/// contract with its upstream job (`openfoam::UPSTREAM_RESPONSES`), which validation
/// checks against the equipment.
#[test]
fn no_hopper_response_name_is_spelled_outside_the_hopper_module() {
    let names: Vec<&str> = orch_adapters::hopper::RESPONSES
        .iter()
        .map(|r| r.name.as_ref())
        .collect();
    let allowed = [
        root().join("adapters/src/hopper.rs"),
        root().join("adapters/src/openfoam/mod.rs"),
    ];
    let offenders = spelled_outside(&names, &allowed);
    assert!(
        offenders.is_empty(),
        "hopper response names outside the hopper module (ask the study's equipment instead):\n{}",
        offenders.join("\n")
    );
}

/// The same for the chute: its response names live in `adapters/src/chute.rs` only.
#[test]
fn no_chute_response_name_is_spelled_outside_the_chute_module() {
    let names: Vec<&str> = orch_adapters::chute::RESPONSES
        .iter()
        .map(|r| r.name.as_ref())
        .collect();
    let offenders = spelled_outside(&names, &[root().join("adapters/src/chute.rs")]);
    assert!(
        offenders.is_empty(),
        "chute response names outside the chute module (ask the study's equipment instead):\n{}",
        offenders.join("\n")
    );
}

/// The stage seam: the plan, driver, store, status and CLI take every stage kind
/// alike, so the orchestrator spells no kind (as a string or as its module's `KIND`)
/// outside the study file's sections that name one (the `cfd:` shorthand,
/// `coupling:`, `stages: {script: …}`) and the decoding of `jobs.stage`.
#[test]
fn no_job_path_branches_on_a_stage_kind() {
    // The study crate validates those sections, and its `plan::JobKind` decodes
    // `jobs.stage` into a known kind (the registry's, and `script`); what it derives
    // from a run (identity, kept files) is held to the rule.
    let study = root().join("study/src");
    let held = [study.join("identity.rs"), study.join("keep.rs")];
    let mut offenders = Vec::new();
    for dir in ORCHESTRATOR_SOURCES {
        for (path, text) in production_sources(&root().join(dir)) {
            if path.starts_with(&study) && !held.contains(&path) {
                continue;
            }
            for spelled in [
                "\"cfd\"",
                "\"air\"",
                "\"script\"",
                "openfoam::KIND",
                "dem_in_air::KIND",
                "script_stage::KIND",
            ] {
                if text.contains(spelled) {
                    offenders.push(format!("{} spells {spelled}", path.display()));
                }
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "stage kinds outside their modules (ask the stage instead):\n{}",
        offenders.join("\n")
    );
}

/// The orchestrator's top-level modules (`crate::<module>` paths in production code,
/// comments left out) form no import circle: each can be read after the ones it uses.
#[test]
fn the_orchestrator_s_modules_form_no_import_circle() {
    use std::collections::{BTreeMap, BTreeSet};
    let src = root().join("orchestrator/src");
    let mut uses: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (path, text) in production_sources(&src) {
        let relative = path.strip_prefix(&src).unwrap();
        let first = relative.components().next().unwrap().as_os_str();
        let module = first.to_string_lossy().trim_end_matches(".rs").to_string();
        if ["main", "lib", "bin"].contains(&module.as_str()) {
            continue;
        }
        let used = uses.entry(module.clone()).or_default();
        for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for (at, _) in line.match_indices("crate::") {
                let name: String = line[at + 7..]
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() && name != module {
                    used.insert(name);
                }
            }
        }
    }
    // Depth-first search for a path back to where it started.
    fn circle(
        from: &str,
        at: &str,
        uses: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        seen: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        for next in uses.get(at).into_iter().flatten() {
            if next == from {
                let mut found = path.clone();
                found.push(from.to_string());
                return Some(found);
            }
            if uses.contains_key(next) && seen.insert(next.clone()) {
                path.push(next.clone());
                if let Some(found) = circle(from, next, uses, path, seen) {
                    return Some(found);
                }
                path.pop();
            }
        }
        None
    }
    for module in uses.keys() {
        let mut path = vec![module.clone()];
        if let Some(found) = circle(module, module, &uses, &mut path, &mut BTreeSet::new()) {
            panic!("an import circle: {}", found.join(" → "));
        }
    }
}

/// One unit-suffix convention in names: rates per second are `_per_s` (`_m_per_s`,
/// `_kg_per_s`, `_m_per_s2`), never `_m_s` or `_kg_s` (file formats keep their own
/// column names, in their string literals).
#[test]
fn rates_are_named_per_second_everywhere() {
    let mut offenders = Vec::new();
    let others = [
        "adapters/src",
        "dem/src",
        "granular/src",
        "metamodel/src",
        "executor/src",
    ];
    for dir in ORCHESTRATOR_SOURCES.iter().chain(&others) {
        for (path, text) in production_sources(&root().join(dir)) {
            for (number, line) in text.lines().enumerate() {
                if line.contains('"') || line.trim_start().starts_with("//") {
                    continue;
                }
                let words = line.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'));
                if let Some(word) = words
                    .filter(|w| w.len() > 5)
                    .find(|w| w.ends_with("_m_s") || w.ends_with("_kg_s") || w.ends_with("_m_s2"))
                {
                    offenders.push(format!("{}:{}: {word}", path.display(), number + 1));
                }
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "rates named without `_per_s`:\n{}",
        offenders.join("\n")
    );
}
