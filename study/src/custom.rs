//! What runs for each design point, validated: a built-in equipment on a solver (its
//! template or the user's), or the user's own deck (`equipment: custom`, `case:`).
//!
//! Files a study names (templates, side files) are read relative to the study file,
//! must stay inside its folder, and are kept in the store: on resume they come from
//! there, not from the disk ([`super::Stored`]).

use std::path::{Component, Path};

use orch_adapters::custom::vtk::{Attribute as VtkAttribute, VtkField};
use orch_adapters::custom::{
    render_command, CaseTemplate, Column, CustomDeck, DeckCommand, DeclaredResponse, Pick,
    Reduction, SideFile, Source,
};
use orch_adapters::ParameterSpec;

use super::file::{ColumnFile, DeclaredResponseFile};
use super::*;

/// The equipment name of a user's own deck.
pub const EQUIPMENT: &str = orch_adapters::custom::EQUIPMENT;

/// The most cores one job may ask for (`executor.cores_per_job`, `case.cores`).
pub const MAX_CORES_PER_JOB: usize = 4096;

/// The last component of a relative path: what a template is called in the run
/// directory.
fn file_name(relative: &str) -> &str {
    relative.rsplit('/').next().unwrap_or(relative)
}

/// A relative path as it lands in a run directory: `/`-separated, without `.` parts.
fn normal_path(relative: &str) -> String {
    relative
        .split('/')
        .filter(|part| !part.is_empty() && *part != ".")
        .collect::<Vec<_>>()
        .join("/")
}

impl Checker<'_> {
    /// A built-in equipment on the study's solver, with the stored, the user's or the
    /// solver's default template.
    /// `executor.cores_per_job`: 1 to [`MAX_CORES_PER_JOB`], 1 when not given.
    fn cores_per_job(&self, executor: &super::file::ExecutorFile) -> Result<usize, StudyError> {
        match executor.cores_per_job {
            None => Ok(1),
            Some(n @ 1..=MAX_CORES_PER_JOB) => Ok(n),
            Some(n) => Err(self.error(
                "executor.cores_per_job",
                format!("expected 1 to {MAX_CORES_PER_JOB} cores (threads or MPI ranks of one job), got {n}; leave it out for one core"),
            )),
        }
    }

    pub(super) fn builtin_simulation(
        &self,
        file: &StudyFile,
    ) -> Result<EquipmentOnSolver, StudyError> {
        self.builtin_simulation_on(file, file.solver.as_deref(), "solver")
    }

    /// The study's equipment on the solver `solver` (`field` names where it is
    /// written, for errors).
    pub(super) fn builtin_simulation_on(
        &self,
        file: &StudyFile,
        solver: Option<&str>,
        field: &str,
    ) -> Result<EquipmentOnSolver, StudyError> {
        if file.case.is_some() {
            return Err(self.error(
                "case",
                "a `case:` section describes your own deck; add `equipment: custom`, or remove it",
            ));
        }
        let equipment_name = file.equipment.as_deref().unwrap_or(DEFAULT_EQUIPMENT);
        let equipment = equipment_for(equipment_name).ok_or_else(|| {
            self.error(
                "equipment",
                format!(
                    "unknown equipment `{equipment_name}`; expected one of: {}, {EQUIPMENT}",
                    equipment_names().join(", ")
                ),
            )
        })?;
        let Some(solver_name) = solver else {
            // The key is absent, so the error points at the top of the file.
            let mut error = self.error(
                field,
                format!("expected `solver:`, one of: {}", solver_names().join(", ")),
            );
            error
                .location
                .get_or_insert(Location { line: 1, column: 1 });
            return Err(error);
        };
        let solver = solver_for(solver_name).ok_or_else(|| {
            self.error(
                field,
                format!(
                    "unknown solver `{solver_name}`; expected one of: {}",
                    solver_names().join(", ")
                ),
            )
        })?;
        let simulation = EquipmentOnSolver::new(equipment, solver).ok_or_else(|| {
            let able: Vec<&str> = orch_adapters::SOLVERS
                .iter()
                .filter(|s| s.template_for(equipment_name).is_some())
                .map(|s| s.name)
                .collect();
            self.error(
                field,
                format!(
                    "the {} solver has no template for the {equipment_name} equipment; expected one of: {}",
                    solver.name,
                    able.join(", ")
                ),
            )
        })?;
        let simulation = simulation.with_cores(self.cores_per_job(&file.executor)?);
        let stored = self.stored.as_ref().and_then(|s| s.template.clone());
        Ok(match (stored, &file.template) {
            (Some(stored), Some(_)) => simulation.with_template(stored),
            (_, None) => simulation,
            (None, Some(relative)) => {
                let bytes = self.read_input("template", relative)?;
                let text = String::from_utf8(bytes).map_err(|_| {
                    self.error(
                        "template",
                        format!("{relative} is not UTF-8 text; expected a Tera template"),
                    )
                })?;
                simulation.with_template(Template {
                    name: self.base().join(relative).display().to_string(),
                    text,
                })
            }
        })
    }

    /// The user's own deck: templates (compiled), side files, command, declared
    /// parameters and responses. Every file read is added to `inputs`.
    pub(super) fn custom_deck(
        &self,
        file: &StudyFile,
        inputs: &mut Vec<(String, Vec<u8>)>,
    ) -> Result<CustomDeck, StudyError> {
        let Some(case) = &file.case else {
            return Err(self.error(
                "equipment",
                "`equipment: custom` needs a `case:` section: templates, command and responses (see docs/custom-decks.md)",
            ));
        };
        if file.executor.cores_per_job.is_some() {
            return Err(self.error(
                "executor.cores_per_job",
                "sets the cores of a built-in equipment's solver; a custom case sets its own with `case.cores` (and `{{ cores }}` in its command)",
            ));
        }
        if file.solver.is_some() {
            return Err(self.error(
                "solver",
                "a custom case runs `case.command`; remove `solver:`",
            ));
        }
        if file.template.is_some() {
            return Err(self.error(
                "template",
                "a custom case lists its templates under `case.templates`; remove `template:`",
            ));
        }
        self.deck_of(case, "case", inputs)
    }

    /// A deck from a `case:` section at field `at` (`case`, or a script stage's
    /// `stages.script.case`): templates (compiled), side files, command, declared
    /// parameters and responses. Every file read is added to `inputs`.
    pub(super) fn deck_of(
        &self,
        case: &file::CaseFile,
        at: &str,
        inputs: &mut Vec<(String, Vec<u8>)>,
    ) -> Result<CustomDeck, StudyError> {
        if case.templates.is_empty() {
            return Err(self.error(&format!("{at}.templates"), "expected at least one template"));
        }
        let mut templates = Vec::new();
        let mut outputs: Vec<String> = Vec::new();
        for (i, relative) in case.templates.iter().enumerate() {
            let field = format!("{at}.templates[{i}]");
            let bytes = self.read_input(&field, relative)?;
            let text = String::from_utf8(bytes.clone()).map_err(|_| {
                self.error(
                    &field,
                    format!("{relative} is not UTF-8 text; expected a Tera template"),
                )
            })?;
            inputs.push((relative.clone(), bytes));
            let name = file_name(relative);
            let output = name.strip_suffix(".tera").unwrap_or(name).to_string();
            self.unique_in_run_dir(&field, &output, &outputs)?;
            outputs.push(output.clone());
            templates.push(CaseTemplate {
                source: relative.clone(),
                output,
                text,
            });
        }
        let mut files = Vec::new();
        for (i, relative) in case.files.iter().enumerate() {
            let field = format!("{at}.files[{i}]");
            // A file lands at its path relative to the study file's folder; a folder's
            // files each at theirs.
            for (path, bytes) in self.read_inputs(&field, relative)? {
                inputs.push((path.clone(), bytes.clone()));
                self.unique_in_run_dir(&field, &path, &outputs)?;
                outputs.push(path.clone());
                files.push(SideFile { name: path, bytes });
            }
        }
        let mut folders = Vec::new();
        for (i, folder) in case.folders.iter().enumerate() {
            let field = format!("{at}.folders[{i}]");
            self.relative_path(&field, folder)?;
            folders.push(normal_path(folder));
        }
        let cores = case.cores.unwrap_or(1);
        if cores == 0 || cores > MAX_CORES_PER_JOB {
            return Err(self.error(
                &format!("{at}.cores"),
                format!("expected 1 to {MAX_CORES_PER_JOB} cores, got {cores}"),
            ));
        }
        let command = self.command(&format!("{at}.command"), &case.command, cores)?;
        let log_file = match &case.log {
            Some(log) => {
                self.relative_path(&format!("{at}.log"), log)?;
                log.clone()
            }
            None => orch_executor::STDOUT_FILE.to_string(),
        };
        let mut parameters = Vec::new();
        for (name, declared) in &case.parameters {
            let at = format!("{at}.parameters.{name}");
            let (min, max) = (
                declared.min.unwrap_or(f64::NEG_INFINITY),
                declared.max.unwrap_or(f64::INFINITY),
            );
            if !(min <= declared.default && declared.default <= max) {
                return Err(self.error(
                    &format!("{at}.default"),
                    format!(
                        "expected a default within [{min}, {max}], got {}",
                        declared.default
                    ),
                ));
            }
            parameters.push(ParameterSpec {
                name: name.clone().into(),
                default: declared.default,
                unit: declared.unit.clone().unwrap_or_default().into(),
                min,
                max,
                description: declared.description.clone().unwrap_or_default().into(),
            });
        }
        if case.responses.is_empty() {
            return Err(self.error(
                &format!("{at}.responses"),
                "expected at least one response to read from each run",
            ));
        }
        let mut responses = Vec::new();
        for (i, declared) in case.responses.iter().enumerate() {
            let response =
                self.declared_response(&format!("{at}.responses[{i}]"), declared, &log_file)?;
            if responses
                .iter()
                .any(|r: &DeclaredResponse| r.name == response.name)
            {
                return Err(self.error(
                    &format!("{at}.responses[{i}].name"),
                    format!("response `{}` is declared twice", response.name),
                ));
            }
            responses.push(response);
        }
        for (i, response) in responses.iter().enumerate() {
            let Some(interval) = &response.interval else {
                continue;
            };
            if interval == &response.name || !responses.iter().any(|r| &r.name == interval) {
                return Err(self.error(
                    &format!("{at}.responses[{i}].interval"),
                    format!(
                        "expected another declared response holding the half-width of `{}`'s 95 % interval, got `{interval}`",
                        response.name
                    ),
                ));
            }
        }
        CustomDeck::new(
            templates,
            files,
            folders,
            DeckCommand {
                words: command,
                cores,
                log_file,
            },
            parameters,
            responses,
        )
        .map_err(|e| self.error(&format!("{at}.templates"), e.to_string()))
    }

    /// The command's words, each rendered with `cores`.
    fn command(&self, at: &str, words: &[String], cores: usize) -> Result<Vec<String>, StudyError> {
        if words.is_empty() || words[0].trim().is_empty() {
            return Err(self.error(
                at,
                "expected the program and its arguments, one word each: [liggghts, -in, in.deck]",
            ));
        }
        if let Some(i) = words.iter().position(|w| w.chars().any(char::is_control)) {
            return Err(self.error(
                &format!("{at}[{i}]"),
                "expected a word without control characters",
            ));
        }
        render_command(words, cores).map_err(|e| self.error(at, e))
    }

    /// One declared response: exactly one source, a known reduction.
    fn declared_response(
        &self,
        at: &str,
        declared: &DeclaredResponseFile,
        log_file: &str,
    ) -> Result<DeclaredResponse, StudyError> {
        let field = |name: &str| format!("{at}.{name}");
        let name = &declared.name;
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(self.error(
                &field("name"),
                format!("expected letters, digits and `_`, got `{name}`"),
            ));
        }
        if name.starts_with("solver_") {
            return Err(self.error(
                &field("name"),
                "names starting with `solver_` are orch's own",
            ));
        }
        let column = |value: &Option<ColumnFile>, default: Option<Column>, which: &str| match value
        {
            Some(ColumnFile::Number(0)) => {
                Err(self.error(&field(which), "columns are numbered from 1"))
            }
            Some(ColumnFile::Number(n)) => Ok(Column::Index(*n)),
            Some(ColumnFile::Name(n)) => Ok(Column::Name(n.clone())),
            None => default.ok_or_else(|| {
                self.error(
                    &field(which),
                    "a `table:` response needs `column:` (its header name or number)",
                )
            }),
        };
        let sources = [
            declared.table.is_some(),
            declared.regex.is_some(),
            declared.json.is_some(),
            declared.vtk.is_some(),
        ];
        if sources.iter().filter(|s| **s).count() != 1 {
            return Err(self.error(
                at,
                "expected exactly one source: `table:` (with `column:`), `regex:` (over `file:`, default the log), `json:` (with `key:`) or `vtk:` (with `field:`)",
            ));
        }
        if let Some(vtk) = &declared.vtk {
            self.relative_path(&field("vtk"), vtk)?;
        }
        let vtk_source = |vtk: &String| -> Result<Source, StudyError> {
            let name = declared.field.clone().ok_or_else(|| {
                self.error(
                    at,
                    "a `vtk:` response needs `field:` (the name of a point or cell array)",
                )
            })?;
            let where_ = match declared.at.as_deref() {
                None => None,
                Some("point") => Some(VtkAttribute::Point),
                Some("cell") => Some(VtkAttribute::Cell),
                Some(other) => {
                    return Err(self.error(
                        &field("at"),
                        format!("expected `point` or `cell`, got `{other}`"),
                    ))
                }
            };
            Ok(Source::Vtk {
                file: vtk.clone(),
                field: VtkField {
                    name,
                    at: where_,
                    component: declared.component,
                },
            })
        };
        let source = match (&declared.table, &declared.regex, &declared.json) {
            (None, None, None) => vtk_source(declared.vtk.as_ref().expect("one source is set"))?,
            (Some(table), _, _) => {
                self.relative_path(&field("table"), table)?;
                Source::Table {
                    file: table.clone(),
                    column: column(&declared.column, None, "column")?,
                    time_column: column(
                        &declared.time_column,
                        Some(Column::Index(1)),
                        "time_column",
                    )?,
                }
            }
            (_, Some(pattern), _) => {
                let file = declared
                    .file
                    .clone()
                    .unwrap_or_else(|| log_file.to_string());
                self.relative_path(&field("file"), &file)?;
                Source::regex(file, pattern).map_err(|e| self.error(&field("regex"), e))?
            }
            (_, _, Some(json)) => {
                self.relative_path(&field("json"), json)?;
                let key = declared.key.clone().ok_or_else(|| {
                    self.error(
                        at,
                        "a `json:` response needs `key:` (a dotted path, e.g. `flow.rate`)",
                    )
                })?;
                Source::Json {
                    file: json.clone(),
                    key,
                }
            }
        };
        self.fields_fit_the_source(at, declared, &source)?;
        let (pick, reduce) = self.pick_and_reduction(at, declared)?;
        if let (Some(from), Some(to)) = (declared.from, declared.to) {
            if from > to {
                return Err(self.error(
                    &field("to"),
                    format!("expected `to` ≥ `from` ({from}), got {to}"),
                ));
            }
        }
        Ok(DeclaredResponse {
            name: name.clone(),
            unit: declared.unit.clone().unwrap_or_default(),
            source,
            reduce,
            from: declared.from,
            to: declared.to,
            pick,
            interval: declared.interval.clone(),
        })
    }

    /// Refuses a key that does not apply to the response's source (`column:` without
    /// `table:`, `pick:` on one file, …) and a glob that cannot match.
    fn fields_fit_the_source(
        &self,
        at: &str,
        declared: &DeclaredResponseFile,
        source: &Source,
    ) -> Result<(), StudyError> {
        let field = |name: &str| format!("{at}.{name}");
        let misplaced = [
            (
                "column",
                declared.column.is_some() && declared.table.is_none(),
            ),
            (
                "time_column",
                declared.time_column.is_some() && declared.table.is_none(),
            ),
            ("file", declared.file.is_some() && declared.regex.is_none()),
            ("key", declared.key.is_some() && declared.json.is_none()),
            ("field", declared.field.is_some() && declared.vtk.is_none()),
            ("at", declared.at.is_some() && declared.vtk.is_none()),
            (
                "component",
                declared.component.is_some() && declared.vtk.is_none(),
            ),
            (
                "pick",
                declared.pick.is_some() && !orch_adapters::custom::is_glob(source.file()),
            ),
        ];
        if let Some((name, _)) = misplaced.iter().find(|(_, wrong)| *wrong) {
            let why = if *name == "pick" {
                "`pick` chooses among the files of a glob (`post/dump_*.txt`); this source names one file".to_string()
            } else {
                format!("`{name}` does not apply to this source")
            };
            return Err(self.error(&field(name), why));
        }
        if let Some(pattern) = orch_adapters::custom::is_glob(source.file()).then(|| source.file())
        {
            if let Some(why) = orch_adapters::custom::glob_error(pattern) {
                let which = match source {
                    Source::Table { .. } => "table",
                    Source::Regex { .. } => "file",
                    Source::Json { .. } => "json",
                    Source::Vtk { .. } => "vtk",
                };
                return Err(self.error(&field(which), why));
            }
        }
        Ok(())
    }

    /// The response's `pick:` among a glob's files and its `reduce:`, by name.
    fn pick_and_reduction(
        &self,
        at: &str,
        declared: &DeclaredResponseFile,
    ) -> Result<(Pick, Reduction), StudyError> {
        let field = |name: &str| format!("{at}.{name}");
        let pick = match &declared.pick {
            None => Pick::default(),
            Some(name) => Pick::from_name(name).ok_or_else(|| {
                let names: Vec<&str> = Pick::ALL.iter().map(|(n, _)| *n).collect();
                self.error(
                    &field("pick"),
                    format!(
                        "unknown pick `{name}`; expected one of: {}",
                        names.join(", ")
                    ),
                )
            })?,
        };
        let reduce = match &declared.reduce {
            None => Reduction::Last,
            Some(name) => Reduction::from_name(name).ok_or_else(|| {
                let names: Vec<&str> = Reduction::ALL.iter().map(|(n, _)| *n).collect();
                self.error(
                    &field("reduce"),
                    format!(
                        "unknown reduction `{name}`; expected one of: {}",
                        names.join(", ")
                    ),
                )
            })?,
        };
        Ok((pick, reduce))
    }

    /// Refuses a second file of the same name in the run directory.
    fn unique_in_run_dir(
        &self,
        field: &str,
        name: &str,
        taken: &[String],
    ) -> Result<(), StudyError> {
        if taken.iter().any(|t| t == name) {
            return Err(self.error(
                field,
                format!("two files would be `{name}` in the run directory; rename one"),
            ));
        }
        Ok(())
    }

    /// Refuses a path that could leave the folder it is relative to.
    fn relative_path(&self, field: &str, relative: &str) -> Result<(), StudyError> {
        let path = Path::new(relative);
        let escapes = path
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
        if relative.is_empty() || escapes || relative.chars().any(char::is_control) {
            return Err(self.error(
                field,
                format!("expected a path inside the study's folder (relative, no `..`), got `{relative}`"),
            ));
        }
        Ok(())
    }

    /// The study file's folder.
    fn base(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new("."))
    }

    /// The files under `relative` (a file, or a folder read whole), each as its path
    /// relative to the study file's folder with its bytes, in path order: from the
    /// store when it was stored, else from the disk.
    fn read_inputs(
        &self,
        field: &str,
        relative: &str,
    ) -> Result<Vec<(String, Vec<u8>)>, StudyError> {
        self.relative_path(field, relative)?;
        let path = normal_path(relative);
        if let Some(stored) = &self.stored {
            if let Some(bytes) = stored
                .inputs
                .get(&path)
                .or_else(|| stored.inputs.get(relative))
            {
                return Ok(vec![(path, bytes.clone())]);
            }
            let prefix = format!("{path}/");
            let under: Vec<(String, Vec<u8>)> = stored
                .inputs
                .iter()
                .filter(|(p, _)| p.starts_with(&prefix))
                .map(|(p, b)| (p.clone(), b.clone()))
                .collect();
            if !under.is_empty() {
                return Ok(under);
            }
        }
        let resolved = self.inside_study_folder(field, relative)?;
        if !resolved.is_dir() {
            return Ok(vec![(path, self.read_input(field, relative)?)]);
        }
        let mut found = Vec::new();
        let mut stack = vec![(resolved, path)];
        while let Some((dir, at)) = stack.pop() {
            let entries = std::fs::read_dir(&dir).map_err(|e| {
                self.error(
                    field,
                    format!("cannot read the folder {}: {e}", dir.display()),
                )
            })?;
            for entry in entries {
                let entry = entry.map_err(|e| {
                    self.error(
                        field,
                        format!("cannot read the folder {}: {e}", dir.display()),
                    )
                })?;
                let name = entry.file_name().to_string_lossy().into_owned();
                let inner = format!("{at}/{name}");
                let real = self.inside_study_folder(field, &inner)?;
                if real.is_dir() {
                    stack.push((real, inner));
                } else {
                    let bytes = self.read_input(field, &inner)?;
                    found.push((inner, bytes));
                }
            }
        }
        found.sort_by(|a, b| a.0.cmp(&b.0));
        if found.is_empty() {
            return Err(self.error(
                field,
                format!(
                    "the folder {relative} holds no files; name files or a folder that has some"
                ),
            ));
        }
        Ok(found)
    }

    /// `relative` resolved on disk, links followed, refused when it leaves the study
    /// file's folder (a link to a system file would be copied into every run and the
    /// store).
    fn inside_study_folder(
        &self,
        field: &str,
        relative: &str,
    ) -> Result<std::path::PathBuf, StudyError> {
        let base = self.base();
        let base = if base.as_os_str().is_empty() {
            Path::new(".")
        } else {
            base
        };
        let resolved = base.join(relative);
        let (Ok(real), Ok(real_base)) = (resolved.canonicalize(), base.canonicalize()) else {
            return Ok(resolved); // a missing file is reported by the read, with its path
        };
        if !real.starts_with(&real_base) {
            return Err(self.error(
                field,
                format!(
                    "{relative} is a link to {}, outside the study's folder; copy the file into the folder instead",
                    real.display()
                ),
            ));
        }
        Ok(real)
    }

    /// A file the study names, from the store when it was stored, else from the disk
    /// relative to the study file (a link leaving the study's folder is refused).
    fn read_input(&self, field: &str, relative: &str) -> Result<Vec<u8>, StudyError> {
        self.relative_path(field, relative)?;
        if let Some(stored) = &self.stored {
            if let Some(bytes) = stored.inputs.get(relative) {
                return Ok(bytes.clone());
            }
        }
        let resolved = self.inside_study_folder(field, relative)?;
        std::fs::read(&resolved).map_err(|e| {
            self.error(
                field,
                format!(
                    "cannot read {}: {e}; expected a file relative to the study file",
                    resolved.display()
                ),
            )
        })
    }

    /// Each factor must change what the templates render: at its minimum, centre and
    /// maximum, with the others at their centre, not every rendering may be the same
    /// (a switch `{% if x > 0 %}` over [0, 1] changes only between 0 and 0.5). A
    /// `fixed:` value the deck does not declare must change them too, or it is a
    /// misspelling, refused with the nearest name the study knows.
    pub(super) fn every_factor_is_used(&self, study: &Study) -> Result<(), StudyError> {
        let limits: Vec<_> = study.factors.iter().map(|f| f.range).collect();
        let centre = study.point(vec![0.0; limits.len()], &limits).natural;
        let render = |case: &orch_adapters::Case| study.simulation.render_texts(case);
        let Ok(base) = render(&study.case_at(&centre, 0)) else {
            return Ok(()); // every design point rendered; the centre's error shows there
        };
        for (i, factor) in study.factors.iter().enumerate() {
            let levels: Vec<f64> = match factor.is_text() {
                true => (0..factor.levels.len()).map(|l| l as f64).collect(),
                false => vec![factor.range.min, factor.range.max],
            };
            let used = levels.iter().any(|&level| {
                let mut moved = centre.clone();
                moved[i] = level;
                render(&study.case_at(&moved, 0)).is_ok_and(|texts| texts != base)
            });
            if !used && factor.is_text() {
                return Err(self.error(
                    &format!("factors[{i}].name"),
                    format!(
                        "factor `{}` is not used by the templates: they render the same at each of its levels ({}); use it in a template (`{{{{ {} }}}}`) or remove the factor",
                        factor.name,
                        factor.levels.join(", "),
                        factor.name
                    ),
                ));
            }
            if !used {
                return Err(self.error(
                    &format!("factors[{i}].name"),
                    format!(
                        "factor `{}` is not used by the templates: they render the same with {} = {}, {} and {}; use it in a template (`{{{{ {} }}}}`) or remove the factor",
                        factor.name,
                        factor.name,
                        factor.range.min,
                        centre[i],
                        factor.range.max,
                        factor.name
                    ),
                ));
            }
        }
        let declared: Vec<&str> = study
            .simulation
            .parameters()
            .iter()
            .map(|p| p.name.as_ref())
            .collect();
        let numbers = study.fixed.keys();
        let texts = study.fixed_text.keys();
        for name in numbers.chain(texts) {
            if declared.contains(&name.as_str()) {
                continue;
            }
            let mut case = study.case_at(&centre, 0);
            if let Some(value) = case.parameters.0.get_mut(name) {
                *value = 2.0 * *value + 1.0;
            }
            if let Some(text) = case.text.get_mut(name) {
                text.push_str("-orch-probe");
            }
            if render(&case).is_ok_and(|texts| texts == base) {
                let others = study.fixed.keys().chain(study.fixed_text.keys());
                let known: Vec<&str> = declared
                    .iter()
                    .copied()
                    .chain(study.factors.iter().map(|f| f.name.as_str()))
                    .chain(others.map(String::as_str).filter(|other| *other != name))
                    .collect();
                let hint = match nearest(name, &known) {
                    Some(near) => format!("did you mean `{near}`?"),
                    None => format!("use it in a template (`{{{{ {name} }}}}`) or remove it"),
                };
                return Err(self.error(
                    &format!("fixed.{name}"),
                    format!("`{name}` is not used by the templates and the deck declares no such parameter; {hint}"),
                ));
            }
        }
        Ok(())
    }
}

/// The name of `known` closest to `name` by edit distance, if a misspelling could
/// explain it (at most a third of its letters, and 3, differ).
fn nearest<'a>(name: &str, known: &[&'a str]) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).clamp(1, 3);
    known
        .iter()
        .map(|k| (levenshtein(name, k), *k))
        .filter(|(d, _)| *d <= limit)
        .min()
        .map(|(_, k)| k)
}

/// The optimal-string-alignment edit distance: insertions, deletions, substitutions and
/// swaps of two neighbouring characters (`lable` is one edit from `label`).
fn levenshtein(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut rows = vec![vec![0_usize; b.len() + 1]; a.len() + 1];
    for (i, row) in rows.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in rows[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (rows[i - 1][j] + 1)
                .min(rows[i][j - 1] + 1)
                .min(rows[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(rows[i - 2][j - 2] + 1);
            }
            rows[i][j] = best;
        }
    }
    rows[a.len()][b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_misspelling_finds_its_name_and_a_stranger_finds_none() {
        assert_eq!(levenshtein("kitten", "sitting"), 3);
        assert_eq!(levenshtein("", "ab"), 2);
        assert_eq!(levenshtein("lable", "label"), 1);
        let known = ["contact_model", "youngs_modulus", "density"];
        assert_eq!(nearest("contct_model", &known), Some("contact_model"));
        assert_eq!(nearest("densty", &known), Some("density"));
        assert_eq!(nearest("gravity", &known), None);
    }
}
