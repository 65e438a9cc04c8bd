//! A user's own deck as the equipment (`equipment: custom` with a `case:` section): any
//! Tera templates rendered into each run, side files copied beside them, the command
//! that runs them, and the responses the study declares ([`DeclaredResponse`]).
//!
//! Templates see the case's values and nothing else: parameters (numbers and text),
//! `seed`, `seed_prime` (a prime above 10000 from the seed, as LIGGGHTS' random
//! seeds must be) and `cores`. Tera's `get_env` is refused and a template can include only the
//! case's other templates (there is no file loader), so nothing from orch's environment
//! or from outside the study folder reaches a run directory.

mod declared;
pub mod vtk;

use std::collections::BTreeMap;
use std::path::Path;

pub use declared::{glob_error, is_glob, Column, DeclaredResponse, Pick, Reduction, Source};

use crate::simulation::{context_of, locked_tera, write, write_bytes};
use crate::{
    Case, CommandSpec, ParameterSpec, ParseError, RenderError, ResponseSpec, RunResults,
    Simulation, TemplateText,
};

/// The equipment name of a user's own deck in study files.
pub const EQUIPMENT: &str = "custom";

/// What the store keeps as a custom study's template (its files are kept apart).
pub const TEMPLATE_NAME: &str = "(custom case: templates and files kept with the study)";

/// A template of the case, rendered into the run directory under `output`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaseTemplate {
    /// Its path as the study names it (relative to the study file), for messages.
    pub source: String,
    /// The file it becomes in the run directory: its file name without `.tera`.
    pub output: String,
    /// Its text.
    pub text: String,
}

/// A side file copied unchanged into every run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SideFile {
    /// Its path in the run directory: its path relative to the study file's folder.
    pub name: String,
    /// Its bytes.
    pub bytes: Vec<u8>,
}

/// How a user's deck runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeckCommand {
    /// The program and its arguments, one word each.
    pub words: Vec<String>,
    /// Cores it uses (the executor counts them; templates see `cores`).
    pub cores: usize,
    /// The program's log in the run directory, for failure reasons and `orch logs`.
    pub log_file: String,
}

/// The command's words, each rendered with Tera where it uses `{{ cores }}`; the error
/// names the word.
pub fn render_command(words: &[String], cores: usize) -> Result<Vec<String>, String> {
    let mut context = tera::Context::new();
    context.insert("cores", &cores);
    words
        .iter()
        .map(|word| {
            if !word.contains("{{") {
                return Ok(word.clone());
            }
            locked_tera().render_str(word, &context).map_err(|e| {
                format!("cannot render `{word}`: {e}; a command word sees only `cores`")
            })
        })
        .collect()
}

/// What a declared response's series is over: a table's time column (by its name, or
/// its number), the match number of a regular expression, the index of a JSON array.
fn axis_of(source: &Source) -> String {
    match source {
        Source::Table { time_column, .. } => match time_column {
            Column::Name(name) => name.clone(),
            Column::Index(index) => format!("column {index}"),
        },
        Source::Regex { .. } => "match [-]".to_string(),
        Source::Json { .. } => "index [-]".to_string(),
        Source::Vtk { field, .. } => match field.at {
            Some(vtk::Attribute::Point) => "point [-]".to_string(),
            Some(vtk::Attribute::Cell) => "cell [-]".to_string(),
            None => "point or cell [-]".to_string(),
        },
    }
}

/// A user's own deck.
#[derive(Debug, Clone)]
pub struct CustomDeck {
    templates: Vec<CaseTemplate>,
    files: Vec<SideFile>,
    /// Folders made in every run directory before the deck starts: those the study
    /// declares and those its responses' files are in.
    folders: Vec<String>,
    command: DeckCommand,
    parameters: Vec<ParameterSpec>,
    responses: Vec<DeclaredResponse>,
    response_specs: Vec<ResponseSpec>,
    tera: tera::Tera,
}

impl CustomDeck {
    /// The deck, its templates compiled once; the error names the template and line.
    pub fn new(
        templates: Vec<CaseTemplate>,
        files: Vec<SideFile>,
        mut folders: Vec<String>,
        command: DeckCommand,
        parameters: Vec<ParameterSpec>,
        responses: Vec<DeclaredResponse>,
    ) -> Result<CustomDeck, RenderError> {
        let mut tera = locked_tera();
        for template in &templates {
            tera.add_raw_template(&template.source, &template.text)
                .map_err(|e| RenderError::template(&template.source, &template.text, &e))?;
        }
        let response_specs = responses
            .iter()
            .map(|r| ResponseSpec {
                name: r.name.clone().into(),
                unit: r.unit.clone().into(),
                description: format!("declared: {} of {}", r.reduce.name(), r.source).into(),
                over: axis_of(&r.source).into(),
                interval: r.interval.clone().map(Into::into),
            })
            .collect();
        for response in &responses {
            let file = response.source.file();
            // The folder of the file, up to the first part that is a glob.
            let parts: Vec<&str> = file.split('/').collect();
            let folder: Vec<&str> = parts[..parts.len() - 1]
                .iter()
                .take_while(|part| !is_glob(part))
                .copied()
                .collect();
            if !folder.is_empty() {
                folders.push(folder.join("/"));
            }
        }
        folders.sort();
        folders.dedup();
        Ok(CustomDeck {
            templates,
            files,
            folders,
            command,
            parameters,
            responses,
            response_specs,
            tera,
        })
    }

    /// The templates, for messages.
    pub fn templates(&self) -> &[CaseTemplate] {
        &self.templates
    }

    /// The command's log in the run directory.
    pub fn log_file(&self) -> &str {
        &self.command.log_file
    }
}

impl Simulation for CustomDeck {
    fn equipment_name(&self) -> &str {
        EQUIPMENT
    }

    fn solver_name(&self) -> &str {
        &self.command.words[0]
    }

    fn parameters(&self) -> &[ParameterSpec] {
        &self.parameters
    }

    fn accepts_undeclared_parameters(&self) -> bool {
        true
    }

    fn responses(&self) -> &[ResponseSpec] {
        &self.response_specs
    }

    /// Each declared response's values over time are stored under its name.
    fn series(&self) -> &[ResponseSpec] {
        &self.response_specs
    }

    fn headline_responses(&self) -> Vec<String> {
        self.responses.iter().map(|r| r.name.clone()).collect()
    }

    fn template(&self) -> TemplateText {
        TemplateText {
            name: TEMPLATE_NAME.to_string(),
            text: String::new(),
        }
    }

    fn check(&self, _case: &Case) -> Result<(), RenderError> {
        Ok(())
    }

    /// Every template rendered for `case`, as `(output file, text)`.
    fn render_texts(&self, case: &Case) -> Result<Vec<(String, String)>, RenderError> {
        let context = context_of(case, self.command.cores);
        self.templates
            .iter()
            .map(|template| {
                self.tera
                    .render(&template.source, &context)
                    .map(|text| (template.output.clone(), text))
                    .map_err(|e| RenderError::template(&template.source, &template.text, &e))
            })
            .collect()
    }

    fn render(&self, case: &Case, run_dir: &Path) -> Result<(), RenderError> {
        for (output, text) in self.render_texts(case)? {
            write(run_dir, &output, &text)?;
        }
        for file in &self.files {
            write_bytes(run_dir, &file.name, &file.bytes)?;
        }
        for folder in &self.folders {
            let path = run_dir.join(folder);
            std::fs::create_dir_all(&path).map_err(|source| RenderError::Write { path, source })?;
        }
        Ok(())
    }

    fn command(&self) -> CommandSpec {
        CommandSpec {
            program: self.command.words[0].clone(),
            args: self.command.words[1..].to_vec(),
            env: BTreeMap::new(),
            cores: self.command.cores,
            mpi: false,
            same_result_on_any_cores: false,
            log_file: self.command.log_file.clone(),
        }
    }

    fn install_hint(&self) -> String {
        "install it, or give its full path as the first word of `case.command`".to_string()
    }

    fn results(&self, _case: &Case, run_dir: &Path) -> Result<RunResults, ParseError> {
        let mut results = RunResults::default();
        // Each response stands alone: one that cannot be read is recorded with why
        // (the study's `missing_response:` says whether the job then fails), and the
        // others are kept.
        for response in &self.responses {
            match response.read(run_dir) {
                Ok(read) => {
                    results.responses.push((response.name.clone(), read.value));
                    results.series.push(read.series);
                    results.notes.extend(read.note);
                }
                Err(why) => results
                    .missing
                    .push((response.name.clone(), why.to_string())),
            }
        }
        Ok(results)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn response(name: &str, source: Source) -> DeclaredResponse {
        DeclaredResponse {
            name: name.into(),
            unit: "kg".into(),
            source,
            reduce: Reduction::Last,
            from: None,
            to: None,
            pick: Pick::Last,
            interval: None,
        }
    }

    #[test]
    fn series_are_over_their_real_axis_and_response_folders_are_made() {
        let deck = CustomDeck::new(
            vec![CaseTemplate {
                source: "deck.sh.tera".into(),
                output: "deck.sh".into(),
                text: "echo {{ x }}".into(),
            }],
            vec![],
            vec!["dumps".into()],
            DeckCommand {
                words: vec!["sh".into(), "deck.sh".into()],
                cores: 1,
                log_file: "stdout.txt".into(),
            },
            vec![],
            vec![
                response(
                    "a",
                    Source::Table {
                        file: "post/a.txt".into(),
                        column: Column::Index(2),
                        time_column: Column::Name("TimeStep".into()),
                    },
                ),
                response(
                    "b",
                    Source::regex("log/run.log".into(), "b = (\\S+)").unwrap(),
                ),
                response(
                    "c",
                    Source::Json {
                        file: "out/*/c.json".into(),
                        key: "c".into(),
                    },
                ),
            ],
        )
        .unwrap();
        let over: Vec<&str> = deck.series().iter().map(|s| s.over.as_ref()).collect();
        assert_eq!(over, ["TimeStep", "match [-]", "index [-]"]);
        let run = tempfile::tempdir().unwrap();
        let mut parameters = crate::ResolvedParameters::defaults(&[]);
        parameters.set("x", 1.0);
        let case = Case {
            parameters,
            text: Default::default(),
            seed: 1,
        };
        deck.render(&case, run.path()).unwrap();
        for folder in ["post", "log", "out", "dumps"] {
            assert!(run.path().join(folder).is_dir(), "{folder}");
        }
    }
}
