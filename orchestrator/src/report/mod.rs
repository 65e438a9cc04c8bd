//! `orch report`: one self-contained HTML file per study — no scripts, no fonts, no
//! links out — with inline SVG figures, from what the store keeps.
//!
//! Per round: the design in natural units, the trust-region box, each response
//! surface (a heat map for two factors, a curve for one, slices through the optimum
//! for more) with its design points, predicted against observed with leave-one-out
//! predictions, the Pareto chart of standardised effects, a multi-objective round's
//! Pareto front (a chart in objective space for two objectives, and a table), the
//! optimum (or compromise point), and the Monte Carlo summary. Per run: the response values and every stored series.
//! A study with more runs than a chart can draw or a page can list shows an even choice
//! of them ([`shown`]) and says so.
//! The surfaces are refitted from the stored runs ([`crate::surfaces`]).

mod fidelity;
pub use orch_page::{html, plots};
pub mod shown;

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write;

use orch_metamodel::surrogate::Surrogate;
use orch_metamodel::FactorRange;

use crate::export::unit_of;
use crate::store::{FactorRow, Store, StoreError, StoredFit, StoredRound, StudyRow};
use crate::study::Study;
use crate::surfaces::{self, Observed, Run};
use html::{escape, figure, label, number, svg_label, table, with_unit};

/// What the report is made from, read from the store at once.
struct Data<'a> {
    row: &'a StudyRow,
    study: Option<&'a Study>,
    factors: Vec<FactorRow>,
    names: Vec<String>,
    rounds: Vec<StoredRound>,
    runs: BTreeMap<i64, Vec<Run>>,
}

impl Data<'_> {
    fn unit(&self, name: &str) -> String {
        unit_of(self.study, name).unwrap_or_default()
    }
}

/// The report of a study as one HTML page.
pub async fn render(
    store: &Store,
    row: &StudyRow,
    study: Option<&Study>,
) -> Result<String, StoreError> {
    let factors = store.factors(row.id).await?;
    let rounds = store.rounds(row.id).await?;
    let data = Data {
        row,
        study,
        names: factors.iter().map(|f| f.name.clone()).collect(),
        factors,
        // The figures and warnings judge each fit from its own response's runs.
        runs: surfaces::design_runs_named(store, row.id, &names_read(study, &rounds)).await?,
        rounds,
    };
    let mut body = String::new();
    // Counted by SQLite (`jobs_by_state`), in the states' names' order.
    let counts: BTreeMap<String, usize> = store
        .job_counts(row.id)
        .await?
        .into_iter()
        .map(|(state, n)| (state.to_string(), n))
        .collect();
    let n_jobs: usize = counts.values().sum();
    let counts: Vec<String> = counts.iter().map(|(s, n)| format!("{n} {s}")).collect();
    let solver = match study.filter(|s| !s.fidelities.is_empty()) {
        Some(study) => study
            .fidelities
            .iter()
            .map(|f| {
                format!(
                    "{} ({}, cost {})",
                    escape(&f.name),
                    escape(f.simulation.solver_name()),
                    f.cost
                )
            })
            .collect::<Vec<_>>()
            .join(" &lt; "),
        None => escape(&row.solver),
    };
    let _ = write!(
        body,
        "<h1>{}: report</h1>\n<p>Solver <b>{}</b>, study {}, {} jobs: {}. Study file {}. Written by orch {}.</p>\n",
        escape(&row.name),
        solver,
        escape(row.state.as_str()),
        n_jobs,
        counts.join(", "),
        escape(&row.file_path),
        env!("CARGO_PKG_VERSION")
    );
    body.push_str(DEFINITIONS);
    for round in &data.rounds {
        body.push_str(&round_section(store, &data, round).await?);
    }
    if let Some(noise) = crate::noise::summary(store, &row.name).await? {
        body.push_str(&noise_section(&data, &noise));
    }
    body.push_str(&runs_section(store, &data).await?);
    Ok(html::page(&format!("{}: report", row.name), &body))
}

/// The responses the report reads for each run: those fitted, and over fidelity
/// levels the solver's loop time, each level's measured cost.
fn names_read(study: Option<&Study>, rounds: &[StoredRound]) -> Vec<String> {
    let mut names = surfaces::fitted_names(rounds);
    let leveled = study.is_some_and(|s| !s.fidelities.is_empty());
    if leveled && !names.iter().any(|n| n == fidelity::LOOP_TIME) {
        names.push(fidelity::LOOP_TIME.to_string());
    }
    names
}

const DEFINITIONS: &str = "<h2>Definitions</h2>\n<dl>\
<dt>Coded units</dt><dd>Each factor scaled to [−1, 1] over its round's box; surfaces are fitted in coded units and drawn in natural (SI) units.</dd>\
<dt>σ_cross</dt><dd>Cross-validation error: the root mean square of the leave-one-out prediction errors (each run predicted by the surface fitted to the other runs), relative to the sample standard deviation of the observed values, in %. 0 % predicts perfectly; 100 % is no better than the mean.</dd>\
<dt>R²(σ_cross)</dt><dd>1 − (σ_cross / 100)². Below 0.5 the surface does not predict new runs, and its optimum is not an answer.</dd>\
<dt>R²</dt><dd>ANOVA R² = 1 − SS_res / SS_tot on the fitted runs themselves; it rises with every term added and says little about prediction.</dd>\
<dt>Standardised effect (t)</dt><dd>A term's coefficient divided by its standard error; the Pareto chart ranks terms by |t|, the red line at |t| = 2 marks about 95 % significance.</dd>\
<dt>Leverage</dt><dd>How much a run fixes its own prediction (the hat matrix's diagonal). A run of leverage 1 (a single centre point, or as many runs as terms) cannot be left out, so σ_cross is not defined: use 3 centre points.</dd>\
<dt>95 % interval</dt><dd>From Monte Carlo samples of the uncertain factors through the surface at the optimum: 2.5 % and 97.5 % quantiles; one-sided bounds are the 5 % and 95 % quantiles. The second row also draws the surrogate's own error at every sample (its standard error there), so a surface that predicts poorly widens the bounds.</dd>\
<dt>Prediction interval</dt><dd>Where a new run at a point falls with 95 % probability: the surrogate's own error and the run-to-run noise (a polynomial's from its coefficients' covariance and residual variance, Kriging's from its posterior and nugget).</dd>\
<dt>Model choice</dt><dd>Each response's surrogate is the candidate (linear, quadratic, cubic polynomials with insignificant terms dropped, and Kriging) with the smallest leave-one-out RMSE (a pruned polynomial's with its pruning repeated without each run); a simpler one within 5 % of it, or within one standard error of its mean squared leave-one-out residual, is preferred.</dd>\
<dt>Sobol indices</dt><dd>The share of a response's variance over the round's box (factors uniform on it) due to each factor alone (first order) and with its interactions (total).</dd>\
</dl>\n";

async fn round_section(
    store: &Store,
    data: &Data<'_>,
    round: &StoredRound,
) -> Result<String, StoreError> {
    let mut out = format!("<h2>Round {}</h2>\n", round.round);
    if let Some((decision, note)) = &round.decision {
        let _ = writeln!(
            out,
            "<p>Decision: <b>{}</b>: {}</p>",
            escape(decision.as_str()),
            escape(note)
        );
    }
    out.push_str(&design_table(store, data, round.round).await?);
    out.push_str(&trust_region(data, round));
    let runs: &[Run] = data
        .runs
        .get(&round.round)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    for fit in &round.fits {
        out.push_str(&surface_section(data, round, fit, runs));
    }
    out.push_str(&front_section(data, round));
    out.push_str(&optimum_section(data, round));
    Ok(out)
}

/// A multi-objective round's Pareto front: a chart in objective space for two
/// objectives, and a table of every point with its factor values; empty without a front.
fn front_section(data: &Data<'_>, round: &StoredRound) -> String {
    let Some(first) = round.front.first() else {
        return String::new();
    };
    let mut out = format!(
        "<h3>Pareto front of round {}</h3>\n<p>{} points of the surfaces' Pareto front in the round's box, each no worse than any other point of the box in every objective; the compromise point, closest to the best value of every objective with each objective scaled by its range over the front, is the round's recommendation.</p>\n",
        round.round,
        round.front.len()
    );
    // Plain text: the chart and the table escape it.
    let objective_label = |(response, goal, _): &(String, String, f64)| {
        format!(
            "{goal} {}",
            orch_page::numbers::header(response, Some(&data.unit(response)))
        )
    };
    if let [a, b] = first.objectives.as_slice() {
        let points: Vec<(f64, f64)> = round
            .front
            .iter()
            .filter(|p| p.objectives.len() == 2)
            .map(|p| (p.objectives[0].2, p.objectives[1].2))
            .collect();
        let compromise = round
            .front
            .iter()
            .find(|p| p.compromise && p.objectives.len() == 2)
            .map(|p| (p.objectives[0].2, p.objectives[1].2));
        out.push_str(&figure(
            &plots::front(
                &format!("Pareto front: {} vs {}", a.0, b.0),
                &objective_label(a),
                &objective_label(b),
                &points,
                compromise,
            ),
            "The front's points (blue) in order along it; red cross: the compromise point.",
        ));
    } else {
        out.push_str("<p class=\"note\">With three or more objectives the front is shown as a table only.</p>\n");
    }
    let mut headers = vec![String::from("point")];
    headers.extend(first.objectives.iter().map(objective_label));
    headers.extend(
        data.factors
            .iter()
            .map(|f| orch_page::numbers::header(&f.name, Some(&f.unit))),
    );
    headers.push(String::new());
    let rows: Vec<Vec<String>> = round
        .front
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut row = vec![i.to_string()];
            row.extend(p.objectives.iter().map(|o| number(o.2)));
            row.extend(shown_values(&data.factors, &p.natural));
            row.push(if p.compromise {
                "compromise".into()
            } else {
                String::new()
            });
            row
        })
        .collect();
    out.push_str(&table(&headers, &rows));
    out
}

async fn design_table(store: &Store, data: &Data<'_>, round: i64) -> Result<String, StoreError> {
    // Only the shown jobs and their points are read: a round of 10^4 jobs lists 500.
    let total = store.round_job_count(data.row.id, round).await?;
    let shown = shown::evenly(total, shown::MAX_TABLE_RUNS);
    let jobs = store.round_jobs_at(data.row.id, round, &shown).await?;
    let point_ids: Vec<i64> = jobs.iter().map(|job| job.point_id).collect();
    let points: HashMap<i64, _> = store
        .points_by_id(&point_ids)
        .await?
        .into_iter()
        .map(|p| (p.id, p))
        .collect();
    let levels: Vec<String> = data
        .study
        .map(|s| s.fidelities.iter().map(|f| f.name.clone()).collect())
        .unwrap_or_default();
    let mut headers: Vec<String> = ["job", "purpose", "point", "replicate", "state"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    if !levels.is_empty() {
        headers.insert(2, "fidelity".to_string());
    }
    headers.extend(
        data.factors
            .iter()
            .map(|f| orch_page::numbers::header(&f.name, Some(&f.unit))),
    );
    let rows: Vec<Vec<String>> = jobs
        .iter()
        .map(|job| {
            let point = &points[&job.point_id];
            let mut row = vec![
                escape(&job.name),
                escape(point.purpose.as_str()),
                point.idx.to_string(),
                job.replicate.to_string(),
                escape(&match &job.reused_from {
                    Some(source) => format!("{} (reused {source}, not run again)", job.state),
                    None => job.state.to_string(),
                }),
            ];
            if !levels.is_empty() {
                let level = levels.get(point.fidelity as usize);
                row.insert(2, escape(level.map_or("?", String::as_str)));
            }
            row.extend(shown_values(&data.factors, &point.natural));
            row
        })
        .collect();
    let capped = shown::note(jobs.len(), total, "orch export");
    Ok(format!(
        "<h3>Design of round {round}</h3>\n{}{capped}",
        table(&headers, &rows)
    ))
}

fn trust_region(data: &Data<'_>, round: &StoredRound) -> String {
    let mut out = format!("<h3>Trust region of round {}</h3>\n", round.round);
    let headers: Vec<String> = ["factor", "min", "max", "limits in the study file"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let rows: Vec<Vec<String>> = data
        .factors
        .iter()
        .zip(&round.ranges)
        .map(|(f, r)| match f.levels.is_some() {
            true => vec![
                escape(&f.name),
                "every level".into(),
                String::new(),
                escape(&f.levels().join(", ")),
            ],
            false => vec![
                escape(&f.name),
                with_unit(r.min, &f.unit),
                with_unit(r.max, &f.unit),
                format!(
                    "[{}, {}]",
                    with_unit(f.min, &f.unit),
                    with_unit(f.max, &f.unit)
                ),
            ],
        })
        .collect();
    out.push_str(&table(&headers, &rows));
    let so_far: Vec<&StoredRound> = data
        .rounds
        .iter()
        .filter(|r| r.round <= round.round && r.ranges.len() == data.factors.len())
        .collect();
    let numeric = data.factors.iter().all(|f| f.levels.is_none());
    if data.factors.len() == 2 && numeric {
        let f = &data.factors;
        let boxes: Vec<_> = so_far
            .iter()
            .map(|r| {
                (
                    format!("round {}", r.round),
                    [
                        (r.ranges[0].min, r.ranges[0].max),
                        (r.ranges[1].min, r.ranges[1].max),
                    ],
                    r.optimum
                        .as_ref()
                        .map(|o| (o.2, o.3[0], o.3[1]))
                        .map(|o| (o.1, o.2)),
                )
            })
            .collect();
        let svg = plots::boxes(
            &svg_label(&f[0].name, &f[0].unit),
            &svg_label(&f[1].name, &f[1].unit),
            [(f[0].min, f[0].max), (f[1].min, f[1].max)],
            &boxes,
        );
        out.push_str(&figure(
            &svg,
            "Each round's box (filled) inside the study file's limits (black), and each round's optimum (cross).",
        ));
    } else {
        // A text factor keeps every level in every round: no range to draw.
        for (i, f) in data.factors.iter().enumerate() {
            if f.levels.is_some() {
                continue;
            }
            let bars: Vec<_> = so_far
                .iter()
                .map(|r| {
                    (
                        (r.ranges[i].min, r.ranges[i].max),
                        r.optimum.as_ref().and_then(|o| o.3.get(i).copied()),
                    )
                })
                .collect();
            let svg = plots::intervals(&svg_label(&f.name, &f.unit), (f.min, f.max), &bars);
            out.push_str(&figure(
                &svg,
                "Each round's range (bar) and optimum (cross).",
            ));
        }
    }
    out
}

/// A point's natural values as table cells: a text factor's level, else the number.
fn shown_values<'a>(
    factors: &'a [FactorRow],
    natural: &'a [f64],
) -> impl Iterator<Item = String> + 'a {
    factors
        .iter()
        .zip(natural)
        .map(|(f, v)| escape(&f.show(*v, number)))
}

/// The optimum's natural values, when the round has one with a value per factor.
fn optimum_point(data: &Data<'_>, round: &StoredRound) -> Option<Vec<f64>> {
    round
        .optimum
        .as_ref()
        .map(|o| o.3.clone())
        .filter(|v| v.len() == data.factors.len())
}

fn surface_section(data: &Data<'_>, round: &StoredRound, fit: &StoredFit, runs: &[Run]) -> String {
    let unit = data.unit(&fit.response);
    let mut out = format!(
        "<h3>Response surface: {}</h3>\n",
        label(&fit.response, &unit)
    );
    if let Some(error) = &fit.error {
        let _ = writeln!(out, "<p class=\"warn\">No surface: {}</p>", escape(error));
        return out;
    }
    let observed = surfaces::observed(runs, &fit.response);
    let verdict = crate::verdict::judge(fit, &observed.y, None);
    if verdict.is_constant() {
        // No R², σ_cross, surface or effects: there is nothing to fit.
        if let Some(warning) = verdict.warning(&fit.response) {
            let _ = writeln!(out, "<p class=\"bad\">{}</p>", escape(&warning));
        }
        return out;
    }
    let fmt =
        |v: Option<f64>, d: usize| v.map(|v| format!("{v:.d$}")).unwrap_or_else(|| "–".into());
    let model = fit
        .model
        .clone()
        .unwrap_or_else(|| format!("{} basis, order {}", fit.basis, fit.order));
    let _ = writeln!(
        out,
        "<p>{}, {} runs: σ_cross {} %, R²(σ_cross) {}, R² {}, adjusted R² {}{}</p>",
        escape(&model),
        fit.runs,
        fmt(fit.sigma_cross, 1),
        fmt(fit.r2_cross, 4),
        fmt(fit.r2, 4),
        fmt(fit.adjusted_r2, 4),
        match (fit.sigma_test, fit.r2_test) {
            (Some(s), Some(r)) => format!(
                "; on {} held-out test runs σ_test {s:.1} %, R²(test) {r:.4}",
                fit.test_runs
            ),
            _ => String::new(),
        }
    );
    out.push_str(&candidates_table(fit, &unit));
    if let Some(l) = fit.lack_of_fit {
        let verdict = if l.p < 0.05 {
            "the surface's form misses a real trend (p < 0.05): try a higher order or Kriging"
        } else {
            "no evidence that the surface's form is wrong"
        };
        let _ = writeln!(
            out,
            "<p>Lack of fit against replicates: F = {:.3} with ({}, {}) degrees of freedom, p = {:.4}: {verdict}.</p>",
            l.f, l.lack_of_fit_dof, l.pure_error_dof, l.p
        );
    }
    let refitted = surfaces::refit(fit, &data.names, &observed);
    let verdict = match refitted.as_ref().and_then(Surrogate::polynomial) {
        Some(f) => crate::verdict::judge(fit, &observed.y, Some(&f.leverages)),
        None => verdict,
    };
    if let Some(warning) = verdict.warning(&fit.response) {
        let _ = writeln!(out, "<p class=\"bad\">{}</p>", escape(&warning));
    }
    let Some(surface) = refitted else {
        out.push_str("<p class=\"note\">The surface could not be refitted from the stored runs (a run was deleted or changed since); only the stored numbers are shown.</p>\n");
        return out;
    };
    out.push_str(&surface_figures(
        data, round, fit, &unit, &surface, &observed,
    ));
    if let Surrogate::CoKriging { model, .. } = &surface {
        out.push_str(&fidelity::section(
            data, round, fit, &unit, model, &observed, runs,
        ));
    }
    let pairs: Option<Vec<(f64, f64)>> = surfaces::loo_predictions(&surface, &observed.y)
        .map(|p| observed.y.iter().copied().zip(p).collect());
    match pairs {
        Some(pairs) => out.push_str(&figure(
            &plots::predicted_observed(
                &format!("Predicted against observed: {}", fit.response),
                &format!("[{}]", unit),
                &pairs,
            ),
            "Each run predicted by the surface fitted without it (leave-one-out); on the grey line the prediction is exact.",
        )),
        None if matches!(surface, Surrogate::CoKriging { .. }) => out.push_str("<p class=\"note\">Predicted against observed: co-Kriging's leave-one-out residuals are of the top level's runs alone (in σ_cross); the levels are compared above.</p>\n"),
        None => out.push_str("<p class=\"note\">Predicted against observed: no leave-one-out predictions, because a run has leverage 1 (see Definitions).</p>\n"),
    }
    match surface.polynomial() {
        Some(polynomial) => {
            let effects = polynomial.effects();
            if !effects.is_empty() {
                out.push_str(&figure(
                    &plots::pareto(&format!("Pareto chart: {}", fit.response), &effects),
                    "Terms ranked by |t|; blue positive, orange negative coefficients.",
                ));
            } else if polynomial.t_values.is_some() {
                out.push_str("<p class=\"note\">Pareto chart: no standardised effects (the surface is the mean alone; no factor's term earned its place).</p>\n");
            } else {
                out.push_str("<p class=\"note\">Pareto chart: no standardised effects (as many runs as terms).</p>\n");
            }
        }
        None => out.push_str("<p class=\"note\">Pareto chart: a Kriging surface has no terms; the Sobol indices beside it rank the factors instead.</p>\n"),
    }
    out.push_str(&sobol_figure(data, fit));
    out
}

/// The candidates of the automatic model choice and their leave-one-out RMSE; empty
/// when only one model was fitted.
fn candidates_table(fit: &StoredFit, unit: &str) -> String {
    if fit.candidates.len() < 2 {
        return String::new();
    }
    let rows: Vec<Vec<String>> = fit
        .candidates
        .iter()
        .map(|c| {
            vec![
                escape(&c.model),
                c.parameters.to_string(),
                c.loo_rmse.map(number).unwrap_or_else(|| "–".into()),
                if c.chosen {
                    "chosen".into()
                } else {
                    String::new()
                },
                escape(c.note.as_deref().unwrap_or("")),
            ]
        })
        .collect();
    format!(
        "<p class=\"note\">Model choice: the candidate with the smallest leave-one-out RMSE, a simpler one within 5 % or one standard error of it preferred.</p>\n{}",
        table(
            &[
                "candidate".to_string(),
                "parameters".to_string(),
                format!("leave-one-out RMSE [{unit}]"),
                String::new(),
                "note".to_string(),
            ],
            &rows
        )
    )
}

/// The Sobol indices of a stored fit as a chart, or why there are none.
fn sobol_figure(data: &Data<'_>, fit: &StoredFit) -> String {
    if fit.sensitivities.is_empty() {
        return "<p class=\"note\">Sobol indices: none (the surface does not vary over the box).</p>\n".into();
    }
    let bars: Vec<plots::SobolBar> = fit
        .sensitivities
        .iter()
        .map(|s| {
            let name = data
                .names
                .get(s.factor)
                .cloned()
                .unwrap_or_else(|| format!("factor {}", s.factor));
            (name, s.first, s.total)
        })
        .collect();
    let how = if fit.sensitivities[0].method == "analytic" {
        "exact, from the Legendre coefficients"
    } else {
        "Saltelli–Jansen Monte Carlo through the surface, with 95 % intervals"
    };
    figure(
        &plots::sobol(&format!("Sobol indices: {}", fit.response), &bars),
        &format!("The share of the response's variance over the round's box (factors uniform on it) due to each factor alone (dark) and with its interactions (light); {how}."),
    )
}

/// The surface drawn over the round's box in natural units.
fn surface_figures(
    data: &Data<'_>,
    round: &StoredRound,
    fit: &StoredFit,
    unit: &str,
    surface: &Surrogate,
    observed: &Observed,
) -> String {
    let ranges: &[FactorRange] = &round.ranges;
    if ranges.len() != data.factors.len() {
        return String::new();
    }
    let coded = |natural: &[f64]| -> Vec<f64> {
        natural
            .iter()
            .zip(ranges)
            .map(|(v, r)| r.to_coded(*v))
            .collect()
    };
    let optimum = optimum_point(data, round);
    let z_label = svg_label(&fit.response, unit);
    let f = &data.factors;
    let text: Vec<u32> = f.iter().map(|f| f.levels().len() as u32).collect();
    let has_text = text.iter().any(|&l| l > 0);
    match f.len() {
        2 if !has_text => {
            let points: Vec<(f64, f64)> = observed.natural.iter().map(|p| (p[0], p[1])).collect();
            let svg = plots::heatmap(
                &format!("Response surface: {}", fit.response),
                &svg_label(&f[0].name, &f[0].unit),
                (ranges[0].min, ranges[0].max),
                &svg_label(&f[1].name, &f[1].unit),
                (ranges[1].min, ranges[1].max),
                &z_label,
                |x, y| surface.predict(&coded(&[x, y])),
                &points,
                optimum.as_ref().map(|o| (o[0], o[1])),
            );
            figure(
                &svg,
                "The fitted surface over the round's box; white circles: design points; red cross: the optimum.",
            )
        }
        _ => {
            let through =
                optimum.unwrap_or_else(|| ranges.iter().map(|r| 0.5 * (r.min + r.max)).collect());
            let mut out = String::new();
            // With text factors, one curve per combination of their levels.
            let combinations = orch_metamodel::levels::combinations(&text);
            let text_factors: Vec<usize> = (0..f.len()).filter(|&j| text[j] > 0).collect();
            for (i, factor) in f.iter().enumerate() {
                if text[i] > 0 {
                    continue;
                }
                let curves: Vec<(String, Vec<(f64, f64)>)> = combinations
                    .iter()
                    .map(|combination| {
                        let mut at = through.clone();
                        for (&j, &level) in text_factors.iter().zip(combination) {
                            at[j] = level as f64;
                        }
                        let curve = slice(ranges, &at, i, |c| surface.predict(c));
                        let name = match has_text {
                            false => fit.response.clone(),
                            true => text_factors
                                .iter()
                                .map(|&j| format!("{} = {}", f[j].name, f[j].show(at[j], number)))
                                .collect::<Vec<_>>()
                                .join(", "),
                        };
                        (name, curve)
                    })
                    .collect();
                let points = runs_along_one_factor(observed, f.len());
                let svg = plots::lines(
                    &format!("Response surface: {} along {}", fit.response, factor.name),
                    &svg_label(&factor.name, &factor.unit),
                    &z_label,
                    &curves,
                    &points,
                    Some(through[i]),
                    if f.len() == 1 {
                        plots::WIDE
                    } else {
                        plots::HALF
                    },
                );
                out.push_str(&figure(
                    &svg,
                    if f.len() == 1 {
                        "The fitted curve with the observed runs (dots); red line: the optimum or the centre."
                    } else if has_text {
                        "A slice of the surface along one factor, one curve per level of the text factors, the other numbers held at the optimum (or the box's centre); red line: that point."
                    } else {
                        "A slice of the surface along one factor, the others held at the optimum (or the box's centre); red line: that point."
                    },
                ));
            }
            out
        }
    }
}

/// A slice of a surface along factor `i` of the box `ranges` through the natural point
/// `through`: 61 evenly spaced `(value, surface(coded point))` pairs.
fn slice(
    ranges: &[FactorRange],
    through: &[f64],
    i: usize,
    surface: impl Fn(&[f64]) -> f64,
) -> Vec<(f64, f64)> {
    (0..=60)
        .map(|s| {
            let x = ranges[i].min + (ranges[i].max - ranges[i].min) * s as f64 / 60.0;
            let coded: Vec<f64> = through
                .iter()
                .zip(ranges)
                .enumerate()
                .map(|(j, (v, r))| r.to_coded(if j == i { x } else { *v }))
                .collect();
            (x, surface(&coded))
        })
        .collect()
}

/// The observed runs as `(factor value, response)` when the study has one factor, so
/// a slice can show them; none otherwise (a slice is not where they lie).
fn runs_along_one_factor(observed: &Observed, factors: usize) -> Vec<(f64, f64)> {
    if factors != 1 {
        return Vec::new();
    }
    observed
        .natural
        .iter()
        .zip(&observed.y)
        .map(|(p, y)| (p[0], *y))
        .collect()
}

fn optimum_section(data: &Data<'_>, round: &StoredRound) -> String {
    let mut out = format!("<h3>Optimum of round {}</h3>\n", round.round);
    let Some((response, goal, value, natural)) = &round.optimum else {
        out.push_str(
            "<p class=\"note\">No optimum: the study has no objective, or no surface of it.</p>\n",
        );
        return out;
    };
    // A compromise point's value and Monte Carlo are its first objective's.
    let unit = data.unit(
        round
            .front
            .iter()
            .find(|p| p.compromise)
            .and_then(|p| p.objectives.first())
            .map_or(response.as_str(), |o| o.0.as_str()),
    );
    let warnings = crate::verdict::optimum_warnings(
        round,
        &data.factors,
        &data.runs.get(&round.round).cloned().unwrap_or_default(),
    );
    for warning in &warnings {
        let _ = writeln!(out, "<p class=\"bad\">{}</p>", escape(warning));
    }
    let answer = !warnings
        .iter()
        .any(|w| w.starts_with(crate::verdict::NOT_AN_ANSWER));
    let compromise = round.front.iter().find(|p| p.compromise);
    let predicted = match compromise {
        // A compromise point: every objective's prediction there.
        Some(point) => point
            .objectives
            .iter()
            .map(|(r, g, v)| {
                format!(
                    "{} {}: predicted {}",
                    escape(g),
                    escape(r),
                    with_unit(*v, &data.unit(r))
                )
            })
            .collect::<Vec<_>>()
            .join("; "),
        None => format!(
            "{} {}: predicted {}",
            escape(goal),
            escape(response),
            with_unit(*value, &unit)
        ),
    };
    let _ = writeln!(
        out,
        "<p>{}{}{predicted}</p>",
        if answer {
            ""
        } else {
            "Best point of the surface, not an answer: "
        },
        if compromise.is_some() {
            "Compromise point of the Pareto front: "
        } else {
            ""
        },
    );
    if let Some((low, high)) = round.optimum_interval {
        let _ = writeln!(
            out,
            "<p>A new run there: 95 % prediction interval [{}, {}] (the surrogate's own error and run-to-run noise).</p>",
            with_unit(low, &unit),
            with_unit(high, &unit)
        );
    }
    let headers: Vec<String> = ["factor", "value", "round's box", "limits in the study file"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let rows: Vec<Vec<String>> = data
        .factors
        .iter()
        .zip(natural)
        .zip(&round.ranges)
        .map(|((f, v), r)| match f.levels.is_some() {
            true => vec![
                escape(&f.name),
                escape(&f.show(*v, number)),
                "every level".into(),
                escape(&f.levels().join(", ")),
            ],
            false => vec![
                escape(&f.name),
                with_unit(*v, &f.unit),
                format!("[{}, {}]", number(r.min), number(r.max)),
                format!("[{}, {}]", number(f.min), number(f.max)),
            ],
        })
        .collect();
    out.push_str(&table(&headers, &rows));
    if let Some(u) = &round.uncertainty {
        let _ = writeln!(
            out,
            "<h3>Monte Carlo at the optimum of round {}</h3>\n<p class=\"note\">The store keeps only these summary numbers of the {} samples, not the samples, so no histogram is drawn.</p>",
            round.round, u.samples
        );
        out.push_str(&spread_table(u, round.uncertainty_total.as_ref(), &unit));
    }
    out
}

/// The spread at an optimum from the uncertain inputs alone, and (when stored) with
/// the surrogate's own error sampled too, one row each.
fn spread_table(
    inputs: &orch_metamodel::Spread,
    total: Option<&orch_metamodel::Spread>,
    unit: &str,
) -> String {
    let headers: Vec<String> = [
        "through the surface",
        "mean",
        "std",
        "95 % interval",
        "one-sided 95 % lower bound",
        "one-sided 95 % upper bound",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let row = |what: &str, u: &orch_metamodel::Spread| {
        vec![
            what.to_string(),
            with_unit(u.mean, unit),
            with_unit(u.std, unit),
            format!("[{}, {}]", with_unit(u.q025, unit), with_unit(u.q975, unit)),
            with_unit(u.q05, unit),
            with_unit(u.q95, unit),
        ]
    };
    let mut rows = vec![row("uncertain inputs only", inputs)];
    if let Some(total) = total {
        rows.push(row("and the surrogate's own error", total));
    }
    table(&headers, &rows)
}

/// The noise design around the optimum: where it ran, its surrogates and the bounds
/// at the optimum under the uncertain parameters.
fn noise_section(data: &Data<'_>, noise: &crate::noise::NoiseSummary) -> String {
    let mut out = format!(
        "<h2>Noise design around the optimum</h2>\n<p>Study <a href=\"{name}.html\">{name}</a> varied {} around the optimum and fitted a surrogate per response; its report has every figure.</p>\n",
        escape(&noise.factors.join(", ")),
        name = escape(&noise.study)
    );
    let rows: Vec<Vec<String>> = noise
        .round
        .fits
        .iter()
        .map(|f| {
            let fmt = |v: Option<f64>, d: usize| {
                v.map(|v| format!("{v:.d$}")).unwrap_or_else(|| "–".into())
            };
            vec![
                escape(&f.response),
                escape(f.model.as_deref().unwrap_or("")),
                f.runs.to_string(),
                fmt(f.sigma_cross, 1),
                fmt(f.r2_cross, 4),
            ]
        })
        .collect();
    out.push_str(&table(
        &["response", "surrogate", "runs", "σ_cross %", "R²(σ_cross)"].map(String::from),
        &rows,
    ));
    if let (Some((response, ..)), Some(u)) = (&noise.round.optimum, &noise.round.uncertainty) {
        let unit = data.unit(response);
        let _ = writeln!(
            out,
            "<p>{} at the optimum under the uncertain parameters ({} samples):</p>",
            escape(response),
            u.samples
        );
        out.push_str(&spread_table(
            u,
            noise.round.uncertainty_total.as_ref(),
            &unit,
        ));
    }
    out
}

/// Points drawn per line of a series chart; longer series are thinned evenly.
const MAX_LINE_POINTS: usize = 400;

/// At most about `max` of `points`, evenly spaced, always with the first and last.
fn decimate(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max < 2 {
        return points.to_vec();
    }
    let step = points.len().div_ceil(max - 1);
    let mut out: Vec<(f64, f64)> = points.iter().step_by(step).copied().collect();
    if out.last() != points.last() {
        out.extend(points.last().copied());
    }
    out
}

async fn runs_section(store: &Store, data: &Data<'_>) -> Result<String, StoreError> {
    let mut out = String::from("<h2>Runs</h2>\n<h3>Response values of every run</h3>\n");
    // At most MAX_TABLE_RUNS rows, only their responses read.
    let (runs, total) = crate::export::RunRows::read_chosen(store, data.row, data.study, |n| {
        shown::evenly(n, shown::MAX_TABLE_RUNS)
    })
    .await?;
    let rows: Vec<Vec<String>> = (0..runs.len())
        .map(|k| {
            runs.row(k)
                .iter()
                .map(|cell| match cell {
                    crate::export::Cell::Text(s) => escape(s),
                    crate::export::Cell::Int(i) => i.to_string(),
                    crate::export::Cell::Real(v) => number(*v),
                    crate::export::Cell::Empty => "–".into(),
                })
                .collect()
        })
        .collect();
    out.push_str(&table(&runs.headers, &rows));
    out.push_str(&shown::note(runs.len(), total, "orch export"));
    drop(runs);

    // Which jobs stored each series comes from the index alone (their ids); only the
    // lines drawn (at most MAX_SERIES_RUNS per series, each thinned to what is drawn)
    // and their jobs' names are read.
    let by_series = store.series_job_ids(data.row.id).await?;
    if by_series.is_empty() {
        out.push_str("<p class=\"note\">No run stored a time series.</p>\n");
        return Ok(out);
    }
    let _ = writeln!(
        out,
        "<h3>Series of every run</h3>\n<p class=\"note\">{} series, each with one line per run.</p>",
        by_series.len()
    );
    for (name, jobs) in &by_series {
        let shown: Vec<i64> = shown::evenly(jobs.len(), shown::MAX_SERIES_RUNS)
            .into_iter()
            .map(|k| jobs[k])
            .collect();
        let mut by_job: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for (id, job) in store.job_names(&shown).await? {
            let points = store.series(id, name).await?;
            by_job.insert(job, decimate(&points, MAX_LINE_POINTS));
        }
        let unit = data.unit(name);
        let lines: Vec<(String, Vec<(f64, f64)>)> = by_job.into_iter().collect();
        let over = crate::export::abscissa_of(data.study, name);
        let svg = plots::lines(
            &format!("Series: {name}"),
            &over,
            &svg_label(name, &unit),
            &lines,
            &[],
            None,
            plots::WIDE,
        );
        out.push_str(&figure(
            &svg,
            &format!("{} over {}, one line per run.", escape(name), escape(&over)),
        ));
        out.push_str(&shown::note(
            shown.len(),
            jobs.len(),
            "orch export --series",
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::JobResults;

    /// Two factors, an objective, Monte Carlo over one factor; one response constant.
    const STUDY: &str = "\
name: known
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
  - {name: amplitude, min: 0.0, max: 0.0008, unit: m}
design: {type: central_composite, alpha: face_centred}
responses: [discharge_rate, fine_fraction_outer_2]
objective: {response: discharge_rate, goal: maximise}
uncertainty:
  samples: 1000
  seed: 1
  parameters: [{name: amplitude, distribution: normal, mean: 0.0004, std: 0.00004}]
";

    /// A known quadratic rate with a little scatter, a constant fraction, and a series.
    fn results(coded: &[f64], k: usize) -> JobResults {
        let noise = [0.01, -0.02, 0.015, -0.005, 0.0, 0.02, -0.01, 0.005, -0.015][k % 9];
        JobResults {
            responses: vec![
                (
                    "discharge_rate".into(),
                    1.0 - (coded[0] - 0.5).powi(2) - coded[1].powi(2) + noise,
                ),
                ("fine_fraction_outer_2".into(), 1.0),
            ],
            series: vec![(
                "mass_flow_rate".into(),
                (0..5).map(|i| (0.1 * i as f64, 0.2 * i as f64)).collect(),
            )],
            note: None,
        }
    }

    #[tokio::test]
    async fn a_report_of_a_known_round_has_every_figure_warning_and_unit() {
        let run = crate::rounds::testing::round_run(STUDY, results).await;
        let (store, id, study) = (&run.store, run.id, &run.study);
        crate::rounds::advance(store, id, study, &run.runs_dir())
            .await
            .unwrap();
        let row = store.study_by_name("known").await.unwrap().unwrap();
        let html = render(store, &row, Some(study)).await.unwrap();

        // A heat map, predicted against observed, a Pareto chart and Sobol indices for
        // the rate; none for the constant fraction; the trust region; one series chart.
        assert_eq!(html.matches("<svg").count(), 4 + 1 + 1, "{html}");
        for text in [
            "<h2>Definitions</h2>",
            "Response surface: discharge_rate [kg/s]",
            "Predicted against observed: discharge_rate",
            "Pareto chart: discharge_rate",
            "Sobol indices: discharge_rate",
            "exact, from the Legendre coefficients",
            // The model choice and its table: the quadratic wins on a quadratic.
            "<p>quadratic, 5 of 6 terms, 9 runs: σ_cross",
            "<th>leave-one-out RMSE [kg/s]</th>",
            "kriging, Matérn 5/2, constant trend",
            "fine_fraction_outer_2 does not vary: it is 1 in every run",
            "Optimum of round 0",
            "Monte Carlo at the optimum of round 0",
            "outlet_diameter [m]",
            "Series: mass_flow_rate",
            "mass_flow_rate [kg/s]",
        ] {
            assert!(html.contains(text), "the report lacks {text}: {html}");
        }
        assert!(!html.contains("Response surface: fine_fraction_outer_2 along"));
        assert!(!html.contains("<script"), "no scripts");
        // The optimum of a well-predicted surface inside the box is an answer.
        assert!(!html.contains(crate::verdict::NOT_AN_ANSWER), "{html}");
        assert!(!html.contains("Best point of the surface"), "{html}");
        assert!(
            html.contains("<p>maximise discharge_rate: predicted"),
            "{html}"
        );
    }

    /// A round of more jobs than a table lists shows an even choice of them, the first
    /// and the last included, and says how many it left out.
    #[tokio::test]
    async fn a_large_round_s_design_table_lists_an_even_choice_of_its_jobs() {
        const MANY: &str = "\
name: many
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
design: {type: full_factorial, levels: 601}
responses: [discharge_rate]
objective: {response: discharge_rate, goal: maximise}
";
        let run = crate::rounds::testing::round_run(MANY, |coded, _| JobResults {
            responses: vec![("discharge_rate".into(), coded[0])],
            series: vec![],
            note: None,
        })
        .await;
        let (store, id) = (&run.store, run.id);
        let row = store.study_by_name("many").await.unwrap().unwrap();
        let factors = store.factors(id).await.unwrap();
        let data = Data {
            row: &row,
            study: Some(&run.study),
            names: factors.iter().map(|f| f.name.clone()).collect(),
            factors,
            rounds: Vec::new(),
            runs: BTreeMap::new(),
        };
        let html = design_table(store, &data, 0).await.unwrap();
        let jobs = store.jobs(id).await.unwrap();
        assert!(jobs.len() > shown::MAX_TABLE_RUNS);
        assert_eq!(html.matches("<tr>").count(), 1 + shown::MAX_TABLE_RUNS);
        let note = format!("Showing 500 of {} runs", jobs.len());
        assert!(html.contains(&note), "{html}");
        let expected = shown::evenly(jobs.len(), shown::MAX_TABLE_RUNS);
        for (k, job) in jobs.iter().enumerate() {
            let listed = html.contains(&format!("<td>{}</td>", job.name));
            assert_eq!(listed, expected.contains(&k), "{}", job.name);
        }
    }

    /// Two objectives in two factors, one round.
    const FRONT: &str = "\
name: front
solver: liggghts
factors:
  - {name: outlet_diameter, min: 0.020, max: 0.028, unit: m}
  - {name: amplitude, min: 0.0, max: 0.0008, unit: m}
design: {type: central_composite, alpha: face_centred}
objective:
  objectives:
    - {response: discharge_rate, goal: maximise}
    - {response: segregation_ratio, goal: minimise}
  front_points: 7
";

    #[tokio::test]
    async fn a_report_of_a_two_objective_round_has_its_front_chart_and_table() {
        let run = crate::rounds::testing::round_run(FRONT, |coded, _| JobResults {
            responses: vec![
                (
                    "discharge_rate".into(),
                    1.0 - (coded[0] - 0.5).powi(2) - coded[1].powi(2),
                ),
                (
                    "segregation_ratio".into(),
                    1.0 + (coded[0] + 0.5).powi(2) + coded[1].powi(2),
                ),
            ],
            series: vec![],
            note: None,
        })
        .await;
        let (store, id, study) = (&run.store, run.id, &run.study);
        crate::rounds::advance(store, id, study, &run.runs_dir())
            .await
            .unwrap();
        let front = &store.rounds(id).await.unwrap()[0].front;
        assert!(front.len() >= 5, "{front:?}");
        let row = store.study_by_name("front").await.unwrap().unwrap();
        let html = render(store, &row, Some(study)).await.unwrap();

        // Four figures per response, the trust region, and the front.
        assert_eq!(html.matches("<svg").count(), 2 * 4 + 1 + 1, "{html}");
        for text in [
            "<h3>Pareto front of round 0</h3>",
            "Pareto front: discharge_rate vs segregation_ratio",
            "<th>maximise discharge_rate [kg/s]</th><th>minimise segregation_ratio [-]</th><th>outlet_diameter [m]</th><th>amplitude [m]</th>",
            "<td>compromise</td>",
            "Compromise point of the Pareto front: maximise discharge_rate: predicted",
            "Pareto chart: discharge_rate",
        ] {
            assert!(html.contains(text), "the report lacks {text}: {html}");
        }
        // One table row per front point, one of them the compromise.
        let section = &html[html.find("<h3>Pareto front of round 0</h3>").unwrap()..];
        let table = &section[..section.find("</table>").unwrap()];
        assert_eq!(table.matches("<tr>").count(), 1 + front.len());
        assert_eq!(table.matches("<td>compromise</td>").count(), 1);
    }

    #[test]
    fn long_series_are_thinned_keeping_both_ends() {
        let points: Vec<(f64, f64)> = (0..1001).map(|i| (i as f64, 2.0 * i as f64)).collect();
        let thin = decimate(&points, 100);
        assert!(thin.len() <= 101, "{}", thin.len());
        assert_eq!(thin.first(), points.first());
        assert_eq!(thin.last(), points.last());
        assert_eq!(decimate(&points[..50], 100).len(), 50);
    }
}
