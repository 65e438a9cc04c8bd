//! What `orch status` and `orch fit` say of a study's rounds: each response's fit and
//! its verdict, the recommendation with its intervals, the Pareto front, and the
//! per-model lines (Kriging's length scales, the model choice's candidates).

use super::*;

/// The text summary's lines on a round's Pareto front: its size and the compromise
/// point's objective and factor values; empty without a front.
pub(super) fn front_lines(round: &StoredRound, names: &[String]) -> String {
    if round.front.is_empty() {
        return String::new();
    }
    let Some(point) = round.front.iter().find(|p| p.compromise) else {
        return format!(
            "  Pareto front of {}
",
            points(round.front.len())
        );
    };
    let objectives: Vec<String> = point
        .objectives
        .iter()
        .map(|(r, g, v)| format!("{r} = {v:.6} ({g})"))
        .collect();
    let factors: Vec<String> = names
        .iter()
        .zip(&point.natural)
        .map(|(n, v)| format!("{n} = {v:.6}"))
        .collect();
    format!(
        "  Pareto front of {}; compromise point: {} at {}
",
        points(round.front.len()),
        objectives.join(", "),
        factors.join(", ")
    )
}

/// The verdict on one stored fit of a round, from the round's runs: constant, does not
/// predict, σ_cross missing (and why), or predicts.
pub fn verdict_of(fit: &StoredFit, factors: &[String], runs: &[Run]) -> Verdict {
    let observed = surfaces::observed(runs, &fit.response);
    let leverages = surfaces::refit(fit, factors, &observed)
        .and_then(|s| s.polynomial().map(|f| f.leverages.clone()));
    verdict::judge(fit, &observed.y, leverages.as_deref())
}

/// What a finished study recommends, for the end of `orch submit`: the last round's
/// optimum in natural units, the objective's predicted value, its spread under the
/// uncertain inputs (95 % interval), and the warnings that qualify it. `None` when no
/// round found an optimum.
pub fn recommendation(
    study: &crate::study::Study,
    rounds: &[StoredRound],
    factors: &[FactorRow],
    runs: &BTreeMap<i64, Vec<Run>>,
) -> Option<String> {
    let round = rounds.iter().rev().find(|r| r.optimum.is_some())?;
    let runs = runs.get(&round.round).map(Vec::as_slice).unwrap_or(&[]);
    let (response, goal, value, natural) = round.optimum.as_ref()?;
    let unit = |name: &str| study.response_unit(name).unwrap_or("").to_string();
    let design: Vec<String> = factors
        .iter()
        .zip(natural)
        .map(|(f, v)| {
            let value = f.show(*v, crate::report::html::number);
            match f.unit.is_empty() {
                true => format!("{} = {value}", f.name),
                false => format!("{} = {value} {}", f.name, f.unit),
            }
        })
        .collect();
    let compromise = round.front.iter().find(|p| p.compromise);
    let predicted = match compromise {
        Some(point) => format!(
            "compromise point of a Pareto front of {}: {} predicted there",
            points(round.front.len()),
            point
                .objectives
                .iter()
                .map(|(r, g, v)| format!(
                    "{r} {} {} ({g})",
                    crate::report::html::number(*v),
                    unit(r)
                ))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        None => format!(
            "{goal} {response}: {} {} predicted there",
            crate::report::html::number(*value),
            unit(response)
        ),
    };
    // The spread is of the objective, or of a compromise point's first objective.
    let response = compromise
        .and_then(|p| p.objectives.first())
        .map_or(response, |(r, _, _)| r);
    let mut out = format!(
        "recommended design (round {}): {}\n  {predicted}",
        round.round,
        design.join(", "),
    );
    if let Some((low, high)) = round.optimum_interval {
        out.push_str(&format!(
            " (a new run there: 95 % prediction interval [{}, {}])",
            crate::report::html::number(low),
            crate::report::html::number(high)
        ));
    }
    if let (Some(spread), Some(uncertainty)) = (&round.uncertainty, &study.uncertainty) {
        let inputs: Vec<String> = uncertainty
            .parameters
            .iter()
            .map(|(index, distribution)| {
                use orch_metamodel::Distribution;
                let n = crate::report::html::number;
                let law = match distribution {
                    Distribution::Normal { mean, std } => format!("N({}, {})", n(*mean), n(*std)),
                    Distribution::Uniform { low, high } => format!("U({}, {})", n(*low), n(*high)),
                    Distribution::LogNormal { mu, sigma } => {
                        format!("lognormal(μ {}, σ {})", n(*mu), n(*sigma))
                    }
                };
                format!("{} ~ {law}", study.factors[*index].name)
            })
            .collect();
        out.push_str(&format!(
            "; under the uncertain {} ({} samples): mean {} {u}, 95 % interval [{}, {}] {u}",
            inputs.join(", "),
            spread.samples,
            crate::report::html::number(spread.mean),
            crate::report::html::number(spread.q025),
            crate::report::html::number(spread.q975),
            u = unit(response)
        ));
        if let Some(total) = &round.uncertainty_total {
            out.push_str(&format!(
                ", with the surrogate's own error [{}, {}] {}",
                crate::report::html::number(total.q025),
                crate::report::html::number(total.q975),
                unit(response)
            ));
        }
    }
    out.push('\n');
    for warning in verdict::optimum_warnings(round, factors, runs) {
        out.push_str(&format!("  warning: {warning}\n"));
    }
    Some(out)
}

/// Lines on each analysed round: fit quality, optimum, 95 % bounds, decision, and
/// warnings where a surface does not predict, a response is constant, σ_cross is
/// missing or the optimum lies on a limit of the study file.
pub fn rounds_summary(
    rounds: &[StoredRound],
    factors: &[FactorRow],
    runs: &BTreeMap<i64, Vec<Run>>,
) -> String {
    let names: Vec<String> = factors.iter().map(|f| f.name.clone()).collect();
    let mut out = String::new();
    for round in rounds {
        let round_runs: &[Run] = runs.get(&round.round).map(Vec::as_slice).unwrap_or(&[]);
        let boxed: Vec<String> = factors
            .iter()
            .zip(&round.ranges)
            .map(|(f, r)| match f.levels.is_some() {
                true => format!("{} {{{}}}", f.name, f.levels().join(", ")),
                false => format!("{} [{:.6}, {:.6}]", f.name, r.min, r.max),
            })
            .collect();
        out.push_str(&format!(
            "round {}: box {}\n",
            round.round,
            boxed.join(", ")
        ));
        for fit in &round.fits {
            if let Some(error) = &fit.error {
                out.push_str(&format!("  {}: no surface: {error}\n", fit.response));
                continue;
            }
            let verdict = verdict_of(fit, &names, round_runs);
            match &verdict {
                Verdict::Constant { value } => out.push_str(&format!(
                    "  {}: constant: {value} in every run; nothing to fit\n",
                    fit.response
                )),
                _ => out.push_str(&format!(
                    "  {}: σ_cross {} %, R² {}, R²(σ_cross) {} ({} runs, {}){}\n",
                    fit.response,
                    fit.sigma_cross
                        .map(|v| format!("{v:.1}"))
                        .unwrap_or_else(|| "–".into()),
                    fit.r2
                        .map(|v| format!("{v:.4}"))
                        .unwrap_or_else(|| "-".into()),
                    fit.r2_cross
                        .map(|v| format!("{v:.4}"))
                        .unwrap_or_else(|| "–".into()),
                    fit.runs,
                    model_name(fit),
                    if matches!(verdict, Verdict::DoesNotPredict { .. }) {
                        ": does not predict"
                    } else {
                        ""
                    }
                )),
            }
            if let Some(warning) = verdict
                .warning(&fit.response)
                .filter(|_| !verdict.is_constant())
            {
                out.push_str(&format!("    warning: {warning}\n"));
            }
            if let (Some(sigma), Some(r2)) = (fit.sigma_test, fit.r2_test) {
                out.push_str(&format!(
                    "    on {} held-out test runs: σ_test {sigma:.1} %, R²(test) {r2:.4}\n",
                    fit.test_runs
                ));
            }
        }
        out.push_str(&front_lines(round, &names));
        if let Some((response, goal, value, natural)) = &round.optimum {
            let at: Vec<String> = factors
                .iter()
                .zip(natural)
                .map(|(f, v)| format!("{} = {}", f.name, f.show(*v, |v| format!("{v:.6}"))))
                .collect();
            let warnings = verdict::optimum_warnings(round, factors, round_runs);
            let answer = !warnings
                .iter()
                .any(|w| w.starts_with(verdict::NOT_AN_ANSWER));
            let what = match (answer, goal.as_str()) {
                (true, "pareto") => "compromise point",
                (true, _) => "optimum",
                (false, _) => "best point of the surface, not an answer",
            };
            // A compromise point's value is its first objective's.
            let value = match round.front.iter().find(|p| p.compromise) {
                Some(point) if goal == "pareto" => point
                    .objectives
                    .first()
                    .map(|(r, _, v)| format!("{r} = {v:.6}"))
                    .unwrap_or_else(|| format!("{value:.6}")),
                _ => format!("{value:.6}"),
            };
            out.push_str(&format!(
                "  {what} ({goal} {response}): {value} at {}\n",
                at.join(", ")
            ));
            if let Some((low, high)) = round.optimum_interval {
                out.push_str(&format!(
                    "    a new run there: 95 % prediction interval [{low:.6}, {high:.6}] (surrogate error and run-to-run noise)\n"
                ));
            }
            for warning in warnings {
                out.push_str(&format!("    warning: {warning}\n"));
            }
        }
        if let Some(u) = &round.uncertainty {
            out.push_str(&format!(
                "  uncertainty at the optimum ({} samples): mean {:.6}, std {:.6}, 95 % interval [{:.6}, {:.6}], one-sided 95 % bounds {:.6} / {:.6}\n",
                u.samples, u.mean, u.std, u.q025, u.q975, u.q05, u.q95
            ));
            if let Some(t) = &round.uncertainty_total {
                out.push_str(&format!(
                    "    with the surrogate's own error: mean {:.6}, std {:.6}, 95 % interval [{:.6}, {:.6}], one-sided 95 % bounds {:.6} / {:.6}\n",
                    t.mean, t.std, t.q025, t.q975, t.q05, t.q95
                ));
            }
        }
        if let Some((decision, note)) = &round.decision {
            out.push_str(&format!("  decision: {decision}: {note}\n"));
        }
    }
    out
}

/// `1 point` or `n points`.
pub fn points(n: usize) -> String {
    if n == 1 {
        "1 point".into()
    } else {
        format!("{n} points")
    }
}

/// The surrogate's name, or (fits stored before the model choice) its basis and order.
pub(super) fn model_name(fit: &StoredFit) -> String {
    fit.model
        .clone()
        .unwrap_or_else(|| format!("polynomial of order {}", fit.order))
}

/// `orch fit`: every surface of one round, term by term, with the verdict on each
/// (`factors` name the terms; `runs` are the round's design runs).
pub fn fits_report(round: &StoredRound, factors: &[String], runs: &[Run]) -> String {
    let mut out = String::new();
    for fit in &round.fits {
        // A polynomial's terms are named in its basis; Kriging has none.
        let basis = if fit.terms.is_empty() && fit.error.is_none() {
            String::new()
        } else {
            format!("{} basis, ", fit.basis)
        };
        out.push_str(&format!(
            "round {}, {} ({}, {basis}{} runs)\n",
            round.round,
            fit.response,
            model_name(fit),
            fit.runs
        ));
        if let Some(error) = &fit.error {
            out.push_str(&format!("  no surface: {error}\n\n"));
            continue;
        }
        let verdict = verdict_of(fit, factors, runs);
        if let Some(warning) = verdict.warning(&fit.response) {
            out.push_str(&format!("  warning: {warning}\n"));
        }
        if verdict.is_constant() {
            out.push('\n');
            continue;
        }
        let fmt = |v: Option<f64>, digits: usize| {
            v.map(|v| format!("{v:.digits$}"))
                .unwrap_or_else(|| "-".into())
        };
        out.push_str(&format!(
            "  σ_cross {} %, R² {}, adjusted R² {}, R²(σ_cross) {}, PRESS {}\n",
            fit.sigma_cross
                .map(|v| format!("{v:.2}"))
                .unwrap_or_else(|| "–".into()),
            fmt(fit.r2, 4),
            fmt(fit.adjusted_r2, 4),
            fit.r2_cross
                .map(|v| format!("{v:.4}"))
                .unwrap_or_else(|| "–".into()),
            fit.press
                .map(|v| format!("{v:.4e}"))
                .unwrap_or_else(|| "-".into())
        ));
        let mut ranks: Vec<(usize, f64)> = fit
            .terms
            .iter()
            .enumerate()
            .skip(1)
            .filter_map(|(i, t)| t.3.map(|t| (i, t.abs())))
            .collect();
        ranks.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut rows = vec![["TERM", "COEFFICIENT", "STD ERROR", "t", "PARETO RANK"]
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>()];
        for (i, (name, b, se, t)) in fit.terms.iter().enumerate() {
            let rank = ranks
                .iter()
                .position(|(j, _)| *j == i)
                .map(|r| (r + 1).to_string())
                .unwrap_or_else(|| "-".into());
            rows.push(vec![
                name.clone(),
                format!("{b:.6e}"),
                se.map(|v| format!("{v:.3e}")).unwrap_or_else(|| "-".into()),
                t.map(|v| format!("{v:.2}")).unwrap_or_else(|| "-".into()),
                rank,
            ]);
        }
        if fit.terms.is_empty() {
            out.push_str(&kriging_lines(fit, factors));
        } else {
            for line in table(&rows).lines() {
                out.push_str("  ");
                out.push_str(line);
                out.push('\n');
            }
        }
        out.push_str(&choice_lines(fit, factors));
        out.push('\n');
    }
    out
}

/// A Kriging surface's hyperparameters, from its stored spec: one model's, or each
/// combination of levels' for a surface with text factors.
pub(super) fn kriging_lines(fit: &StoredFit, factors: &[String]) -> String {
    use orch_metamodel::surrogate::ModelSpec;
    let one = |spec: &ModelSpec, numeric: &[&String], indent: &str| -> String {
        let ModelSpec::Kriging {
            length_scales,
            process_variance,
            noise_variance,
            ..
        } = spec
        else {
            return String::new();
        };
        let scales: Vec<String> = numeric
            .iter()
            .zip(length_scales)
            .map(|(name, l)| format!("{name} {l:.3}"))
            .collect();
        format!(
            "{indent}length scales (coded units; small = the response changes fast along it): {}\n{indent}process std {:.4e}, noise std {:.4e}\n",
            scales.join(", "),
            process_variance.sqrt(),
            noise_variance.sqrt()
        )
    };
    match fit.spec.as_deref().and_then(surfaces::spec_from_json) {
        Some(spec @ ModelSpec::Kriging { .. }) => {
            one(&spec, &factors.iter().collect::<Vec<_>>(), "  ")
        }
        Some(ModelSpec::KrigingPerLevel { levels, models }) => {
            let numeric: Vec<&String> = factors
                .iter()
                .enumerate()
                .filter(|(i, _)| levels.get(*i).is_none_or(|&l| l == 0))
                .map(|(_, f)| f)
                .collect();
            models
                .iter()
                .map(|(combination, spec)| {
                    format!(
                        "  at {}:\n{}",
                        orch_metamodel::per_level::combination_name(combination),
                        one(spec, &numeric, "    ")
                    )
                })
                .collect()
        }
        Some(ModelSpec::CoKriging {
            kernel,
            trend,
            levels,
        }) => {
            let names: Vec<&String> = factors.iter().collect();
            levels
                .iter()
                .enumerate()
                .map(|(t, level)| {
                    let spec = ModelSpec::Kriging {
                        kernel,
                        trend,
                        length_scales: level.length_scales.clone(),
                        process_variance: level.process_variance,
                        noise_variance: level.noise_variance,
                    };
                    let what = if t == 0 {
                        "its own Kriging"
                    } else {
                        "ρ times the level below plus its own Kriging"
                    };
                    format!(
                        "  fidelity level {t} ({what}):\n{}",
                        one(&spec, &names, "    ")
                    )
                })
                .collect()
        }
        _ => String::new(),
    }
}

/// The candidates of the model choice, the lack-of-fit test and the Sobol indices.
pub(super) fn choice_lines(fit: &StoredFit, factors: &[String]) -> String {
    let mut out = String::new();
    if fit.candidates.len() > 1 {
        out.push_str(
            "  model choice (smallest leave-one-out RMSE; a simpler one within 5 % or one standard error preferred):\n",
        );
        for c in &fit.candidates {
            out.push_str(&format!(
                "    {} {:<40} {:>3} parameter{}, leave-one-out RMSE {}{}\n",
                if c.chosen { "*" } else { " " },
                c.model,
                c.parameters,
                if c.parameters == 1 { " " } else { "s" },
                c.loo_rmse
                    .map(|v| format!("{v:.4e}"))
                    .unwrap_or_else(|| "–".into()),
                c.note
                    .as_ref()
                    .map(|n| format!(" ({n})"))
                    .unwrap_or_default()
            ));
        }
    }
    if let Some(l) = fit.lack_of_fit {
        out.push_str(&format!(
            "  lack of fit against replicates: F = {:.3} ({}, {} dof), p = {:.4}{}\n",
            l.f,
            l.lack_of_fit_dof,
            l.pure_error_dof,
            l.p,
            if l.p < 0.05 {
                ": the form misses a real trend; try a higher order or Kriging"
            } else {
                ""
            }
        ));
    }
    if !fit.sensitivities.is_empty() {
        let parts: Vec<String> = fit
            .sensitivities
            .iter()
            .map(|s| {
                let name = factors.get(s.factor).map_or("?", String::as_str);
                format!("{name} {:.3} / {:.3}", s.first.0, s.total.0)
            })
            .collect();
        out.push_str(&format!(
            "  Sobol indices over the box (first order / total, {}): {}\n",
            fit.sensitivities[0].method,
            parts.join(", ")
        ));
    }
    out
}
