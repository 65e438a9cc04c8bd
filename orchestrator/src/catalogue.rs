//! What a user can put in a study, from the same tables validation uses: equipment,
//! their parameters and responses, solvers and their templates, stages
//! (`orch params`, `orch template show`, `docs/parameters.md`).

use std::fmt::Write;

use orch_adapters::{
    DemSolver, Equipment, EquipmentOnSolver, ParameterSpec, ResponseSpec, Simulation, Stage,
    EQUIPMENT, SOLVERS, STAGES,
};

/// What a user's own deck is, for the lists.
const CUSTOM: &str = "your own deck: a `case:` section with Tera templates, side files, the command and the responses to read (docs/custom-decks.md)";

/// One line per equipment, solver and stage: what `orch params` prints without a name.
pub fn overview() -> String {
    let mut out = String::from(
        "Equipment (`equipment:` in a study; `orch params NAME` lists its parameters):\n",
    );
    for equipment in EQUIPMENT {
        let _ = writeln!(
            out,
            "  {:<10} {}",
            equipment.name(),
            equipment.description()
        );
    }
    let _ = writeln!(out, "  {:<10} {CUSTOM}", orch_adapters::custom::EQUIPMENT);
    out.push_str("\nSolvers (`solver:`; `orch template show EQUIPMENT --solver NAME` prints a default deck):\n");
    for solver in SOLVERS {
        let equipment: Vec<&str> = solver.templates.iter().map(|t| t.equipment).collect();
        let _ = writeln!(
            out,
            "  {:<10} templates for: {}; program `{}` (install: {})",
            solver.name,
            equipment.join(", "),
            solver.program(),
            solver.install_hint
        );
    }
    out.push_str(
        "\nStages (`stages: {KIND: {fixed: …}}`, run after each design job; or chained by `coupling:`):\n",
    );
    for stage in STAGES {
        let _ = writeln!(out, "  {:<10} {}", stage.kind(), stage.description());
    }
    out
}

/// An equipment's parameters, responses and series as aligned text; with a solver, the
/// template, deck and command too.
pub fn equipment_text(equipment: &dyn Equipment, solver: Option<&EquipmentOnSolver>) -> String {
    let mut out = format!("{}: {}\n\n", equipment.name(), equipment.description());
    parameters_text(&mut out, equipment.parameters());
    responses_text(&mut out, "Responses", equipment.responses());
    responses_text(&mut out, "Series", equipment.series());
    let headline = equipment.headline_responses().join(", ");
    let _ = writeln!(
        out,
        "Shown and fitted when a study names no responses: {headline}"
    );
    if let Some(simulation) = solver {
        let command = simulation.command();
        let _ = writeln!(
            out,
            "\nOn {}: template {}, rendered as {}, run as `{} {}`, log {}",
            simulation.solver.name,
            simulation.template().name,
            simulation.deck_file(),
            command.program,
            command.args.join(" "),
            command.log_file
        );
    }
    out
}

/// What `orch params custom` says: the parameters and responses are the study's.
pub fn custom_text() -> String {
    format!(
        "{}: {CUSTOM}\n\nIts parameters are the template's variables (declare them under case.parameters for defaults, units and ranges); its responses are declared under case.responses: a column of a table file, a regular expression over a log or a JSON value, reduced by {} over a window. Example: jobs/inclined-plane.yaml.\n",
        orch_adapters::custom::EQUIPMENT,
        orch_adapters::custom::Reduction::ALL
            .iter()
            .map(|(name, _)| *name)
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// A stage's parameters, responses and what it reads upstream, as aligned text.
pub fn stage_text(stage: &dyn Stage) -> String {
    let mut out = format!("{} stage: {}\n\n", stage.kind(), stage.description());
    parameters_text(&mut out, stage.parameters());
    responses_text(&mut out, "Responses", stage.responses());
    let _ = writeln!(
        out,
        "Reads of its upstream job: responses {}; parameters {}",
        stage.upstream_responses().join(", "),
        stage.upstream_parameters().join(", ")
    );
    let _ = writeln!(
        out,
        "Needs on PATH: {} (install: {})",
        stage.programs().join(", "),
        stage.install_hint()
    );
    out
}

fn parameters_text(out: &mut String, parameters: &[ParameterSpec]) {
    out.push_str("Parameters (SI units; set under `fixed:` or vary as `factors:`):\n");
    let _ = writeln!(
        out,
        "  {:<20} {:>10} {:<8} {:<22} DESCRIPTION",
        "NAME", "DEFAULT", "UNIT", "RANGE"
    );
    for p in parameters {
        let _ = writeln!(
            out,
            "  {:<20} {:>10} {:<8} {:<22} {}",
            p.name,
            p.default,
            p.unit,
            format!("[{}, {}]", p.min, p.max),
            p.description
        );
    }
    out.push('\n');
}

fn responses_text(out: &mut String, title: &str, responses: &[ResponseSpec]) {
    if responses.is_empty() {
        return;
    }
    let _ = writeln!(out, "{title}:");
    for r in responses {
        let _ = writeln!(
            out,
            "  {:<24} {:<8} {}{}",
            r.name,
            r.unit,
            r.description,
            interval_note(r)
        );
    }
    out.push('\n');
}

/// `docs/parameters.md`: every equipment, solver and stage with its tables, from the
/// same tables validation uses (a test keeps the file equal to this).
pub fn markdown() -> String {
    let mut out = String::from(
        "# Parameters and responses\n\n\
         Generated by `orch params --markdown` from the tables `orch` validates studies \
         against; a test keeps this file equal to them. Units are SI.\n",
    );
    for equipment in EQUIPMENT {
        let _ = write!(
            out,
            "\n## Equipment `{}`\n\n{}.\n\n",
            equipment.name(),
            equipment.description()
        );
        parameters_markdown(&mut out, equipment.parameters());
        responses_markdown(&mut out, "Responses", equipment.responses());
        responses_markdown(&mut out, "Series", equipment.series());
        let able: Vec<String> = SOLVERS
            .iter()
            .filter_map(|s| s.template_for(equipment.name()))
            .map(|t| format!("`{}`", t.path))
            .collect();
        let _ = writeln!(out, "Default templates: {}.", able.join(", "));
    }
    let _ = write!(
        out,
        "\n## Equipment `{}`\n\nIts parameters and responses are the study's: {CUSTOM}.\n",
        orch_adapters::custom::EQUIPMENT
    );
    out.push_str("\n## Solvers\n\n| solver | deck | log | install |\n|---|---|---|---|\n");
    for solver in SOLVERS {
        let _ = writeln!(
            out,
            "| `{}` | `<equipment>.{}` | `{}` | `{}` |",
            solver.name, solver.deck_extension, solver.log_file, solver.install_hint
        );
    }
    for stage in STAGES {
        let _ = write!(
            out,
            "\n## Stage `{}`\n\n{}. Reads of its upstream job the responses {} and the parameters {}.\n\n",
            stage.kind(),
            stage.description(),
            code_list(stage.upstream_responses()),
            code_list(stage.upstream_parameters())
        );
        parameters_markdown(&mut out, stage.parameters());
        responses_markdown(&mut out, "Responses", stage.responses());
    }
    out
}

fn code_list(names: &[&str]) -> String {
    if names.is_empty() {
        return "(none)".to_string();
    }
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn parameters_markdown(out: &mut String, parameters: &[ParameterSpec]) {
    if parameters.is_empty() {
        out.push_str("No parameters of its own.\n");
        return;
    }
    out.push_str("| parameter | default | unit | range | description |\n|---|---|---|---|---|\n");
    for p in parameters {
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | [{}, {}] | {} |",
            p.name, p.default, p.unit, p.min, p.max, p.description
        );
    }
    out.push('\n');
}

/// ` (95 % interval: <name>)` for a response whose runs report its interval.
fn interval_note(response: &ResponseSpec) -> String {
    response
        .interval
        .as_ref()
        .map(|name| format!(" (95 % interval: {name})"))
        .unwrap_or_default()
}

fn responses_markdown(out: &mut String, title: &str, responses: &[ResponseSpec]) {
    if responses.is_empty() {
        return;
    }
    let _ = write!(
        out,
        "{title}:\n\n| name | unit | description |\n|---|---|---|\n"
    );
    for r in responses {
        let _ = writeln!(
            out,
            "| `{}` | {} | {}{} |",
            r.name,
            r.unit,
            r.description,
            interval_note(r)
        );
    }
    out.push('\n');
}

/// The solver's default template of `equipment`, or what to ask instead.
pub fn template<'a>(equipment: &str, solver: &'a DemSolver) -> Result<&'a str, String> {
    solver
        .template_for(equipment)
        .map(|t| t.text)
        .ok_or_else(|| {
            format!(
                "the {} solver has no template for `{equipment}`; `orch params` lists equipment and solvers",
                solver.name
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn docs_parameters_md_is_generated_from_the_tables() {
        let committed = include_str!("../../docs/parameters.md");
        assert!(
            committed == markdown(),
            "docs/parameters.md is out of date; regenerate it with `orch params --markdown > docs/parameters.md`"
        );
    }

    #[test]
    fn every_equipment_parameter_and_response_is_listed() {
        let text = overview();
        for equipment in EQUIPMENT {
            assert!(text.contains(equipment.name()));
            let table = equipment_text(*equipment, None);
            for p in equipment.parameters() {
                assert!(table.contains(p.name.as_ref()), "{}", p.name);
            }
            for r in equipment.responses() {
                assert!(table.contains(r.name.as_ref()), "{}", r.name);
            }
        }
    }
}
