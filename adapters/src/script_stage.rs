//! The stage `script`: a user's own post-processing run after each design job, in a run
//! directory of its own, with the design job's files to read.
//!
//! It is a user's own deck ([`crate::custom`]: Tera templates, side files, a command,
//! declared responses) whose templates also see the job it follows:
//!
//! - `upstream_dir`: the design job's run directory (absolute), whose files it reads
//!   (that job keeps everything until the script has run, whatever `keep:` says);
//! - `upstream_<name>`: each of the design job's parameters and stored responses
//!   (`upstream_outlet_diameter`, `upstream_discharge_rate`).
//!
//! The script's own parameters (declared under its `case.parameters`, set under
//! `fixed:`), `seed` and `cores` are there as in a custom deck. What it prints or
//! writes is read back through the declared responses and stored with the job.

use std::path::Path;

use crate::custom::CustomDeck;
use crate::stage::{Stage, StageError, Upstream, UpstreamFiles};
use crate::{Case, CommandSpec, ParameterSpec, ParseError, ResponseSpec, RunResults, Simulation};

/// The stage's kind, in study files (`stages: {script: {case: …}}`), the store and job
/// names (`p000r0-script`).
pub const KIND: &str = "script";

/// The text value holding the upstream job's run directory.
pub const UPSTREAM_DIR: &str = "upstream_dir";

/// The prefix of the upstream job's parameters and responses in the templates.
pub const UPSTREAM_PREFIX: &str = "upstream_";

/// A user's post-processing script as a stage.
#[derive(Debug, Clone)]
pub struct ScriptStage {
    deck: CustomDeck,
}

impl ScriptStage {
    /// The stage that runs `deck` after each design job.
    pub fn new(deck: CustomDeck) -> Self {
        ScriptStage { deck }
    }

    /// What the templates see: the stage's `case` (its parameters and seed), the
    /// upstream run directory and the upstream job's parameters and responses.
    fn script_case(case: &Case, upstream: &Upstream<'_>) -> Case {
        let mut script = case.clone();
        let upstream_values = upstream.case.parameters.0.iter().chain(upstream.responses);
        for (name, value) in upstream_values {
            script
                .parameters
                .set(&format!("{UPSTREAM_PREFIX}{name}"), *value);
        }
        for (name, value) in &upstream.case.text {
            script
                .text
                .insert(format!("{UPSTREAM_PREFIX}{name}"), value.clone());
        }
        script.text.insert(
            UPSTREAM_DIR.to_string(),
            upstream.run_dir.display().to_string(),
        );
        script
    }
}

impl Stage for ScriptStage {
    fn kind(&self) -> &'static str {
        KIND
    }

    fn description(&self) -> &'static str {
        "A user's post-processing script (templates, command, declared responses) run after each design job on its run directory"
    }

    fn parameters(&self) -> &[ParameterSpec] {
        self.deck.parameters()
    }

    fn responses(&self) -> &[ResponseSpec] {
        self.deck.responses()
    }

    fn upstream_responses(&self) -> &'static [&'static str] {
        &[]
    }

    fn upstream_parameters(&self) -> &'static [&'static str] {
        &[]
    }

    fn programs(&self) -> Vec<&str> {
        vec![self.deck.solver_name()]
    }

    fn install_hint(&self) -> &'static str {
        "install it, or give its full path as the first word of the script's `case.command`"
    }

    fn log_file(&self) -> Option<&str> {
        Some(self.deck.log_file())
    }

    fn render(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<CommandSpec, StageError> {
        self.deck
            .render(&Self::script_case(case, upstream), run_dir)?;
        Ok(self.deck.command())
    }

    fn results(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<RunResults, ParseError> {
        self.deck
            .results(&Self::script_case(case, upstream), run_dir)
    }

    fn upstream_files(&self) -> UpstreamFiles {
        UpstreamFiles::Everything
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::custom::{CaseTemplate, DeckCommand, DeclaredResponse, Pick, Reduction, Source};

    fn script() -> ScriptStage {
        let deck = CustomDeck::new(
            vec![CaseTemplate {
                source: "post.sh.tera".into(),
                output: "post.sh".into(),
                text: "wc -l < {{ upstream_dir }}/post/crossings.csv\necho d = {{ upstream_outlet_diameter }} r = {{ upstream_discharge_rate }} k = {{ k }}\n".into(),
            }],
            vec![],
            vec![],
            DeckCommand {
                words: vec!["sh".into(), "post.sh".into()],
                cores: 1,
                log_file: "stdout.txt".into(),
            },
            vec![],
            vec![DeclaredResponse {
                name: "lines".into(),
                unit: "-".into(),
                source: Source::regex("stdout.txt".into(), "^(\\d+)").unwrap(),
                reduce: Reduction::Last,
                from: None,
                to: None,
                pick: Pick::Last,
                interval: None,
            }],
        )
        .unwrap();
        ScriptStage::new(deck)
    }

    #[test]
    fn its_templates_see_the_upstream_directory_parameters_and_responses() {
        let stage = script();
        let mut point = Case::default();
        point.parameters.set("outlet_diameter", 0.024);
        let responses = BTreeMap::from([("discharge_rate".to_string(), 0.125)]);
        let simulation = crate::EquipmentOnSolver::new(
            crate::equipment_for("hopper").unwrap(),
            crate::solver_for("native").unwrap(),
        )
        .unwrap();
        let upstream = Upstream {
            case: &point,
            responses: &responses,
            run_dir: Path::new("/runs/p000r0"),
            stage_case: None,
            simulation: &simulation,
        };
        let mut own = Case::default();
        own.parameters.set("k", 3.0);
        let run = tempfile::tempdir().unwrap();
        let command = stage.render(&own, &upstream, run.path()).unwrap();
        assert_eq!(
            (command.program.as_str(), command.args.as_slice()),
            ("sh", &["post.sh".to_string()][..])
        );
        let text = std::fs::read_to_string(run.path().join("post.sh")).unwrap();
        assert_eq!(
            text,
            "wc -l < /runs/p000r0/post/crossings.csv\necho d = 0.024 r = 0.125 k = 3\n"
        );
        assert_eq!(stage.log_file(), Some("stdout.txt"));
        assert_eq!(stage.programs(), ["sh"]);
        assert_eq!(stage.upstream_files(), UpstreamFiles::Everything);
        // Its responses are the declared ones, read from its own run directory.
        std::fs::write(run.path().join("stdout.txt"), "17\nd = 0.024\n").unwrap();
        let results = stage.results(&own, &upstream, run.path()).unwrap();
        assert_eq!(results.responses, [("lines".to_string(), 17.0)]);
    }
}
