//! The report's fidelity levels of a co-Kriging surface: what each level ran, what the
//! levels learned of each other, and each level's prediction.

use orch_metamodel::{CoKriging, FactorRange};

use super::html::{escape, figure, svg_label, table};
use super::{optimum_point, plots, runs_along_one_factor, slice, Data};
use crate::store::{StoredFit, StoredRound};
use crate::surfaces::{Observed, Run};

/// The response in which every built-in solver reports its loop's wall time, s.
pub(super) use orch_adapters::simulation::SOLVER_LOOP_TIME as LOOP_TIME;

/// The fidelity levels of a co-Kriging surface: per level its solver, cost, runs, the
/// learned scale `ρ` and correlation with the level below and its noise; and each
/// level's prediction along every factor through the optimum, with the runs of each
/// level when there is one factor.
pub(super) fn section(
    data: &Data<'_>,
    round: &StoredRound,
    fit: &StoredFit,
    unit: &str,
    model: &CoKriging,
    observed: &Observed,
    runs: &[Run],
) -> String {
    // What a run of each level took, to set against the cost the study declares.
    let measured = |t: usize| -> Option<f64> {
        let times: Vec<f64> = runs
            .iter()
            .filter(|r| r.fidelity as usize == t)
            .filter_map(|r| r.response(LOOP_TIME))
            .collect();
        (!times.is_empty()).then(|| times.iter().sum::<f64>() / times.len() as f64)
    };
    let level_name = |t: usize| -> String {
        data.study
            .and_then(|s| s.fidelities.get(t))
            .map_or_else(|| format!("level {t}"), |f| f.name.clone())
    };
    let headers: Vec<String> = [
        "level",
        "name",
        "solver",
        "cost of a run",
        "measured loop time of a run [s]",
        "runs",
        "ρ (scale on the level below)",
        "correlation with the level below",
        &format!("noise σ [{unit}]"),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let fmt = |v: Option<f64>| v.map_or_else(|| "–".to_string(), |v| format!("{v:.3}"));
    let rows: Vec<Vec<String>> = (0..model.n_levels())
        .map(|t| {
            let fidelity = data.study.and_then(|s| s.fidelities.get(t));
            vec![
                t.to_string(),
                escape(&level_name(t)),
                escape(fidelity.map_or("–", |f| f.simulation.solver_name())),
                fidelity.map_or_else(|| "–".into(), |f| format!("{}", f.cost)),
                fmt(measured(t)),
                observed
                    .fidelity
                    .iter()
                    .filter(|&&l| l as usize == t)
                    .count()
                    .to_string(),
                fmt(model.scale_factor(t)),
                fmt(model.correlation(t)),
                format!("{:.3e}", model.level_model(t).noise_variance().sqrt()),
            ]
        })
        .collect();
    let mut out = format!(
        "<h4>Fidelity levels</h4>\n<p>Co-Kriging: each level is the one below scaled by ρ plus its own Gaussian process; the surface above is the top level's.</p>\n{}",
        table(&headers, &rows)
    );
    let ranges: &[FactorRange] = &round.ranges;
    let f = &data.factors;
    if ranges.len() != f.len() {
        return out;
    }
    let through = optimum_point(data, round)
        .unwrap_or_else(|| ranges.iter().map(|r| 0.5 * (r.min + r.max)).collect());
    for (i, factor) in f.iter().enumerate() {
        let curves: Vec<(String, Vec<(f64, f64)>)> = (0..model.n_levels())
            .map(|t| {
                let curve = slice(ranges, &through, i, |c| model.predict_level(t, c).0);
                (level_name(t), curve)
            })
            .collect();
        let points = runs_along_one_factor(observed, f.len());
        out.push_str(&figure(
            &plots::lines(
                &format!("Fidelity levels: {} along {}", fit.response, factor.name),
                &svg_label(&factor.name, &factor.unit),
                &svg_label(&fit.response, unit),
                &curves,
                &points,
                Some(through[i]),
                if f.len() == 1 { plots::WIDE } else { plots::HALF },
            ),
            "Each fidelity level's prediction along one factor, the others held at the optimum (or the box's centre); red line: that point.",
        ));
    }
    out
}
