//! `orch status --json`: schema 1, written as it is read (pages of jobs), and the
//! JSON of rounds and fronts.

use super::*;

/// The `factors` array of the JSON.
pub(super) fn factors_json(factors: &[FactorRow]) -> Value {
    Value::Array(
        factors
            .iter()
            .map(|f| match f.levels.is_some() {
                true => json!({"name": f.name, "levels": f.levels()}),
                false => json!({"name": f.name, "min": f.min, "max": f.max, "unit": f.unit}),
            })
            .collect(),
    )
}

/// One job of `orch status --json`.
pub(super) fn job_json(d: &JobDetail, factors: &[FactorRow]) -> Value {
    let names: Vec<&str> = factors.iter().map(|f| f.name.as_str()).collect();
    let levels: Vec<Vec<String>> = factors.iter().map(FactorRow::levels).collect();
    let natural = natural_by_factor(&names, &levels, &d.natural);
    json!({
        "name": d.job.name,
        "id": d.job.id,
        "state": d.job.state.as_str(),
        "attempts": d.job.attempts,
        "handle": d.job.executor_handle,
        "scheduler_state": d.job.scheduler_state,
        "run_dir": d.job.run_dir,
        "point": d.point,
        "fidelity": d.fidelity,
        "replicate": d.job.replicate,
        "seed": d.job.seed,
        "identity": d.job.identity,
        "reused_from": d.job.reused_from,
        "coded": by_factor(&names, &d.coded),
        "factors": natural,
        "responses": d.responses,
        "exit_code": d.job.exit_code,
        "error": d.job.error,
        "started_at": d.job.started_at,
        "finished_at": d.job.finished_at,
    })
}

/// Writes `orch status --json` as `serde_json::to_writer_pretty` writes
/// [`StudyDetail::json`] (keys in sorted order, two-space indents), a job at a time:
/// the jobs may come from memory ([`StudyDetail::write_json`]) or a page at a time from
/// the store ([`write_json_paged`]). JSON strings hold no raw line breaks, so a value
/// printed pretty on its own is placed at a depth by indenting its lines.
pub(super) struct JsonWriter<'a, W> {
    out: W,
    factors: &'a [FactorRow],
    counts: BTreeMap<JobState, usize>,
}

impl<'a, W: Write> JsonWriter<'a, W> {
    /// Writes the object's opening, its `factors` and the opening of `jobs`.
    pub(super) fn begin(mut out: W, factors: &'a [FactorRow]) -> io::Result<Self> {
        write!(
            out,
            "{{\n  \"factors\": {},\n  \"jobs\": [",
            indented(&factors_json(factors), 2)
        )?;
        Ok(JsonWriter {
            out,
            factors,
            counts: BTreeMap::new(),
        })
    }

    /// Writes one element of `jobs`.
    pub(super) fn job(&mut self, detail: &JobDetail) -> io::Result<()> {
        let separator = if self.counts.is_empty() { "\n" } else { ",\n" };
        *self.counts.entry(detail.job.state).or_insert(0) += 1;
        let job = indented(&job_json(detail, self.factors), 4);
        write!(self.out, "{separator}    {job}")
    }

    /// Closes `jobs` and writes the rest of `head` (whose own jobs are not read: the
    /// counts are those of the jobs written).
    pub(super) fn end(mut self, head: &StudyDetail, project_dir: &Path) -> io::Result<W> {
        let close = if self.counts.is_empty() { "]" } else { "\n  ]" };
        write!(
            self.out,
            "{close},\n  \"noise_design\": {},\n  \"rounds\": {},\n  \"schema\": {JSON_SCHEMA},\n  \"study\": {}\n}}",
            indented(&head.noise_json(), 2),
            indented(&head.rounds_json(&head.factor_names()), 2),
            indented(&head.study_json_counted(project_dir, &self.counts), 2),
        )?;
        Ok(self.out)
    }
}

/// `value` printed pretty, its lines after the first indented by `depth` spaces.
pub(super) fn indented(value: &Value, depth: usize) -> String {
    let text = serde_json::to_string_pretty(value).expect("a JSON value prints");
    text.replace('\n', &format!("\n{:depth$}", ""))
}

/// Writes `orch status --json` of `study` to `out`, the same text as
/// [`StudyDetail::write_json`], reading its jobs a page at a time
/// ([`JobPages`]) with their points and responses, so that memory does not
/// grow with the study. Returns `out`.
pub async fn write_json_paged<W: Write>(
    store: &Store,
    study: StudyRow,
    project_dir: &Path,
    out: W,
) -> Result<W, WriteStatusError> {
    // Every job's state is checked before a byte is written (one counting query): a
    // store with a state this orch does not know is refused with nothing printed.
    store.job_counts(study.id).await?;
    let head = StudyDetail::head(store, study).await?;
    let mut writer = JsonWriter::begin(out, &head.factors)?;
    let mut pages = JobPages::of(head.study.id);
    while let Some(mut page) = pages.next(store).await? {
        for (job, point, responses) in page.drain() {
            writer.job(&JobDetail::of(job, point, responses))?;
        }
    }
    Ok(writer.end(&head, project_dir)?)
}

/// Natural values by factor name: a text factor's (one with `levels`, by position)
/// as its level's text.
pub(super) fn natural_by_factor(
    names: &[&str],
    levels: &[Vec<String>],
    values: &[f64],
) -> BTreeMap<String, Value> {
    names
        .iter()
        .zip(values)
        .enumerate()
        .map(|(i, (n, v))| {
            let level = levels
                .get(i)
                .filter(|l| !l.is_empty())
                .and_then(|l| l.get(v.round().max(0.0) as usize));
            let value = match level {
                Some(text) => json!(text),
                None => json!(v),
            };
            (n.to_string(), value)
        })
        .collect()
}

/// Values keyed by factor name.
pub(super) fn by_factor(names: &[&str], values: &[f64]) -> BTreeMap<String, f64> {
    names
        .iter()
        .zip(values)
        .map(|(n, v)| (n.to_string(), *v))
        .collect()
}

/// A round in `orch status --json`; `levels` are the text factors' levels by
/// position (empty for numeric factors, or for none).
pub(super) fn round_json(round: &StoredRound, names: &[&str], levels: &[Vec<String>]) -> Value {
    let by_factor = |values: &[f64]| natural_by_factor(names, levels, values);
    json!({
        "round": round.round,
        "box": names.iter().zip(&round.ranges).map(|(n, r)| (n.to_string(), json!({"min": r.min, "max": r.max}))).collect::<BTreeMap<_, _>>(),
        "fits": round.fits.iter().map(|f| json!({
            "response": f.response,
            "basis": f.basis,
            "order": f.order,
            "runs": f.runs,
            "r2": f.r2,
            "adjusted_r2": f.adjusted_r2,
            "sigma_cross_percent": f.sigma_cross,
            "r2_cross": f.r2_cross,
            "press": f.press,
            "test_runs": f.test_runs,
            "sigma_test_percent": f.sigma_test,
            "r2_test": f.r2_test,
            "error": f.error,
            "model": f.model,
            "candidates": f.candidates.iter().map(|c| json!({
                "model": c.model, "parameters": c.parameters, "loo_rmse": c.loo_rmse,
                "chosen": c.chosen, "note": c.note,
            })).collect::<Vec<_>>(),
            "lack_of_fit": f.lack_of_fit.map(|l| json!({
                "f": l.f, "p": l.p, "lack_of_fit_dof": l.lack_of_fit_dof, "pure_error_dof": l.pure_error_dof,
            })),
            "sobol": f.sensitivities.iter().map(|s| (
                names.get(s.factor).map_or_else(|| s.factor.to_string(), |n| n.to_string()),
                json!({
                    "method": s.method,
                    "first": s.first.0, "first_95": [s.first.1, s.first.2],
                    "total": s.total.0, "total_95": [s.total.1, s.total.2],
                }),
            )).collect::<BTreeMap<_, _>>(),
            "terms": f.terms.iter().map(|(name, b, se, t)| json!({"name": name, "coefficient": b, "std_error": se, "t": t})).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "optimum": round.optimum.as_ref().map(|(response, goal, value, natural)| json!({
            "response": response, "goal": goal, "value": value, "factors": by_factor(natural),
            "prediction_interval_95": round.optimum_interval.map(|(low, high)| [low, high]),
        })),
        "uncertainty": round.uncertainty.map(|u| json!({
            "samples": u.samples, "mean": u.mean, "std": u.std,
            "interval_95": [u.q025, u.q975], "lower_bound_95": u.q05, "upper_bound_95": u.q95,
            "with_surrogate_error": round.uncertainty_total.map(|t| json!({
                "mean": t.mean, "std": t.std,
                "interval_95": [t.q025, t.q975], "lower_bound_95": t.q05, "upper_bound_95": t.q95,
            })),
        })),
        "pareto_front": round.front.iter().map(|p| json!({
            "objectives": p.objectives.iter().map(|(r, _, v)| (r.clone(), json!(v))).collect::<BTreeMap<_, _>>(),
            "factors": by_factor(&p.natural),
            "compromise": p.compromise,
        })).collect::<Vec<_>>(),
        "decision": round.decision.as_ref().map(|(d, note)| json!({"decision": d.as_str(), "note": note})),
    })
}
