//! The study parser on odd but valid files, on malformed ones, and on arbitrary text
//! and mutations of the study files in `jobs/` (a property test): it never panics,
//! accepts every valid spelling of a study, and every refusal is a [`StudyError`]
//! naming a field and, when the text is YAML at all, a line and column.

use std::path::{Path, PathBuf};

use orch_study::{Study, StudyError};
use proptest::prelude::*;

/// The workspace root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the orchestrator crate lives in the workspace")
        .to_path_buf()
}

/// Every `*.yaml` of `dir`, by name, with its text.
fn yaml_files(dir: &Path) -> Vec<(PathBuf, String)> {
    let mut files: Vec<(PathBuf, String)> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "yaml"))
        .map(|path| {
            let text = std::fs::read_to_string(&path).unwrap();
            (path, text)
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no study files in {}", dir.display());
    files
}

/// The thesis's studies, ready to run.
fn job_files() -> Vec<(PathBuf, String)> {
    yaml_files(&root().join("jobs"))
}

/// Files that look odd but are valid YAML and valid studies.
fn odd_files() -> Vec<(PathBuf, String)> {
    yaml_files(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/study_parser/odd-but-valid"))
}

/// The same text as written, with CRLF line ends, with a byte order mark, and both.
fn spellings(text: &str) -> [(&'static str, String); 4] {
    let crlf = text.replace('\n', "\r\n");
    [
        ("as written", text.to_string()),
        ("CRLF", crlf.clone()),
        ("BOM", format!("\u{feff}{text}")),
        ("BOM and CRLF", format!("\u{feff}{crlf}")),
    ]
}

#[test]
fn odd_but_valid_study_files_validate_in_every_spelling() {
    let mut refused = Vec::new();
    for (path, text) in odd_files().into_iter().chain(job_files()) {
        let plain = Study::from_text(&path, &text, None);
        for (how, text) in spellings(&text) {
            match Study::from_text(&path, &text, None) {
                Err(e) => refused.push(format!("{how}: {e}")),
                // Every spelling is the same study.
                Ok(study) => {
                    let plain = plain.as_ref().expect("the plain spelling validated");
                    assert_eq!(study.name, plain.name, "{} {how}", path.display());
                    assert_eq!(study.factors, plain.factors, "{} {how}", path.display());
                    assert_eq!(study.points, plain.points, "{} {how}", path.display());
                }
            }
        }
    }
    assert!(refused.is_empty(), "refused:\n{}", refused.join("\n"));
}

#[test]
fn odd_spellings_mean_what_they_say() {
    let files = odd_files();
    let study = |name: &str| {
        let (path, text) = files
            .iter()
            .find(|(p, _)| p.file_name().unwrap() == name)
            .unwrap();
        Study::from_text(path, text, None).unwrap()
    };
    let quoted = study("quoted-scalars.yaml");
    assert_eq!(quoted.name, "2024");
    assert_eq!(quoted.factors[0].unit, "m");
    let anchored = study("anchors-aliases.yaml");
    assert_eq!(anchored.seed, 50);
    assert_eq!(anchored.factors[1].unit, "m");
    assert_eq!(anchored.executor.max_parallel, 2);
    let flowing = study("flow-style.yaml");
    let commented = study("comments-everywhere.yaml");
    assert_eq!(flowing.points, commented.points);
    assert_eq!(study("block-scalars.yaml").points.len(), 4);
}

/// Text that is malformed YAML, or YAML that is not a study: each is refused with
/// the field and a location.
#[test]
fn malformed_study_files_are_refused_with_a_field_and_a_location() {
    let base = "name: odd\nsolver: native\nfactors:\n  - {name: outlet_diameter, min: 0.020, max: 0.028}\ndesign: {type: full_factorial, levels: 3}\n";
    let cases: Vec<(String, &str)> = vec![
        (format!("{base}name: again\n"), "name"),
        (
            format!("{base}fixed: {{frequency: 50, frequency: 60}}\n"),
            "fixed.frequency",
        ),
        (
            base.replace("levels: 3}", "levels: 3, levels: 4}"),
            "design.levels",
        ),
        (
            format!("{base}cfd: {{fixed: {{end_time: 0.3, end_time: 0.4}}}}\n"),
            "cfd.fixed.end_time",
        ),
        (
            format!("{base}stages: {{cfd: {{}}, cfd: {{}}}}\n"),
            "stages.cfd",
        ),
        (format!("{base}---\nname: second\n"), "(file)"),
        (base.replace("  - {", "\t- {"), "factors"),
        (base.replace("levels: 3}", "levels: 3"), "design"),
        (format!("{base}seed: *nowhere\n"), "seed"),
        (format!("{base}\"\": 1\n"), "(file)"),
        (String::new(), "(file)"),
        ("# only a comment\n".to_string(), "(file)"),
        ("just text\n".to_string(), "(file)"),
    ];
    for (text, field) in cases {
        let error = Study::from_text(Path::new("odd.yaml"), &text, None)
            .err()
            .unwrap_or_else(|| panic!("accepted:\n{text}"));
        assert_eq!(error.field, field, "{error}\nfor:\n{text}");
        assert!(
            error.location.is_some(),
            "no location: {error}\nfor:\n{text}"
        );
    }
}

#[test]
fn a_key_given_twice_and_a_second_document_are_refused_where_they_are() {
    let base = "name: odd\nsolver: native\nfactors:\n  - {name: outlet_diameter, min: 0.020, max: 0.028}\ndesign: {type: full_factorial, levels: 3}\n";
    let error = |text: &str| {
        Study::from_text(Path::new("odd.yaml"), text, None)
            .unwrap_err()
            .to_string()
    };
    assert_eq!(
        error(&format!("{base}fixed:\n  frequency: 50\n  frequency: 60\n")),
        "odd.yaml:8:3: fixed.frequency: given twice in one mapping (first on line 7); keep one"
    );
    assert_eq!(
        error(&format!("{base}...\n---\nname: second\n")),
        "odd.yaml:7:1: (file): a second YAML document starts here; a study file holds one study: remove it, or put it in a file of its own"
    );
}

/// What every answer of the parser must be: a study, or a refusal with a field, a
/// message, and a location when the text is YAML (inside the text, or just past it).
fn well_behaved(text: &str) -> Result<(), TestCaseError> {
    let Err(error) = Study::from_text(Path::new("fuzz.yaml"), text, None) else {
        return Ok(());
    };
    let StudyError {
        field,
        message,
        location,
        ..
    } = &error;
    prop_assert!(!field.is_empty(), "no field: {error}");
    prop_assert!(!message.is_empty(), "no message: {error}");
    if serde_yaml_ng::from_str::<serde_yaml_ng::Value>(text).is_ok() {
        prop_assert!(location.is_some(), "no location: {error}");
    }
    if let Some(location) = location {
        // YAML breaks lines at LF, CRLF and a lone CR alike.
        let lines = text.replace("\r\n", "\n").split(['\n', '\r']).count();
        prop_assert!(
            location.line >= 1 && location.line <= lines + 1 && location.column >= 1,
            "location {location:?} outside the {lines} lines: {error}"
        );
    }
    Ok(())
}

/// Pieces that YAML and study files are made of.
const TOKENS: &[&str] = &[
    "name",
    "solver",
    "native",
    "liggghts",
    "factors",
    "fixed",
    "design",
    "type",
    "full_factorial",
    "central_composite",
    "levels",
    "min",
    "max",
    "unit",
    "executor",
    "max_parallel",
    "time_limit",
    "3min",
    "replicates",
    "seed",
    "responses",
    "cfd",
    "stages",
    "objective",
    "rounds",
    "outlet_diameter",
    "amplitude",
    "frequency",
    ":",
    ": ",
    " ",
    "  ",
    "\n",
    "\r\n",
    "\t",
    "- ",
    "-",
    "{",
    "}",
    "[",
    "]",
    ",",
    "&a ",
    "*a",
    "!!str ",
    "!!int ",
    "!custom ",
    "\"",
    "'",
    "# c",
    "---",
    "...",
    "0",
    "0.02",
    "-1",
    "1e308",
    "-1e-308",
    ".nan",
    ".inf",
    "-.inf",
    "~",
    "null",
    "true",
    "18446744073709551616",
    "4294967296",
    "|",
    ">",
    "? ",
    "<<: ",
    "\u{feff}",
    "%YAML 1.2\n",
    "\\",
    "\0",
    "é",
    "😀",
];

/// Text made of [`TOKENS`] and stray characters.
fn yamlish() -> impl Strategy<Value = String> {
    let piece = prop_oneof![
        4 => proptest::sample::select(TOKENS).prop_map(str::to_string),
        1 => any::<char>().prop_map(String::from),
    ];
    proptest::collection::vec(piece, 0..60).prop_map(|pieces| pieces.concat())
}

/// One edit of a text; positions are taken modulo its length.
#[derive(Debug, Clone)]
enum Mutation {
    Delete(prop::sample::Index, usize),
    Insert(prop::sample::Index, String),
    Replace(prop::sample::Index, usize, String),
    DuplicateLine(prop::sample::Index),
    SwapLines(prop::sample::Index, prop::sample::Index),
    DropLine(prop::sample::Index),
    Truncate(prop::sample::Index),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let token = || proptest::sample::select(TOKENS).prop_map(str::to_string);
    prop_oneof![
        (any::<prop::sample::Index>(), 1..8_usize).prop_map(|(i, n)| Mutation::Delete(i, n)),
        (any::<prop::sample::Index>(), token()).prop_map(|(i, t)| Mutation::Insert(i, t)),
        (any::<prop::sample::Index>(), 1..6_usize, token())
            .prop_map(|(i, n, t)| Mutation::Replace(i, n, t)),
        any::<prop::sample::Index>().prop_map(Mutation::DuplicateLine),
        (any::<prop::sample::Index>(), any::<prop::sample::Index>())
            .prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        any::<prop::sample::Index>().prop_map(Mutation::DropLine),
        any::<prop::sample::Index>().prop_map(Mutation::Truncate),
    ]
}

fn mutate(text: &str, mutation: &Mutation) -> String {
    let chars: Vec<char> = text.chars().collect();
    let at = |i: &prop::sample::Index| i.index(chars.len() + 1);
    let joined = |chars: &[char]| chars.iter().collect::<String>();
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    match mutation {
        Mutation::Delete(i, n) => {
            let from = at(i);
            let to = (from + n).min(chars.len());
            joined(&chars[..from]) + &joined(&chars[to..])
        }
        Mutation::Insert(i, token) => {
            let at = at(i);
            joined(&chars[..at]) + token + &joined(&chars[at..])
        }
        Mutation::Replace(i, n, token) => {
            let from = at(i);
            let to = (from + n).min(chars.len());
            joined(&chars[..from]) + token + &joined(&chars[to..])
        }
        Mutation::DuplicateLine(i) if !lines.is_empty() => {
            let line = lines[i.index(lines.len())];
            lines.insert(i.index(lines.len()), line);
            lines.concat()
        }
        Mutation::SwapLines(a, b) if !lines.is_empty() => {
            let (a, b) = (a.index(lines.len()), b.index(lines.len()));
            lines.swap(a, b);
            lines.concat()
        }
        Mutation::DropLine(i) if !lines.is_empty() => {
            lines.remove(i.index(lines.len()));
            lines.concat()
        }
        Mutation::Truncate(i) => joined(&chars[..at(i)]),
        _ => text.to_string(),
    }
}

proptest! {
    // Bounded to a few seconds: every case validates a whole study.
    #![proptest_config(ProptestConfig { cases: 384, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_yamlish_text_never_panics_and_every_refusal_is_located(text in yamlish()) {
        well_behaved(&text)?;
    }

    #[test]
    fn mutated_study_files_never_panic_and_every_refusal_is_located(
        file in any::<prop::sample::Index>(),
        mutations in proptest::collection::vec(mutation(), 1..4),
    ) {
        let files = job_files();
        let (_, text) = &files[file.index(files.len())];
        let mut text = text.clone();
        for mutation in &mutations {
            text = mutate(&text, mutation);
        }
        well_behaved(&text)?;
    }
}
