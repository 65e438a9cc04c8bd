//! `design:` and the factors of a study: the kind of design, centre points, text
//! factors' levels and the held-out test points, checked.

use super::*;

/// The coded points of design `kind` over factors with `levels` (0 for numeric):
/// see [`Study::coded_design`]. The crossed design's size is checked against
/// [`MAX_RUNS`] before it is built.
pub fn coded_design(kind: &DesignKind, levels: &[u32]) -> Result<Vec<Vec<f64>>, DesignError> {
    use orch_metamodel::levels as text;
    let k = levels.len();
    let numeric = text::numeric_factors(levels, k).len();
    let combinations = text::combination_count(levels);
    if let DesignKind::LatinHypercube { samples, seed, .. } = *kind {
        let rows = if numeric == 0 {
            vec![Vec::new(); samples]
        } else {
            Design::build(kind, numeric)?.points
        };
        return Ok(text::stratify(levels, k, &rows, seed));
    }
    let rows = if numeric == 0 {
        vec![Vec::new()]
    } else {
        let runs = orch_metamodel::run_count(kind, numeric)?;
        let crossed = runs.saturating_mul(combinations);
        if crossed > MAX_RUNS {
            return Err(DesignError::TooManyRuns {
                runs: crossed,
                limit: MAX_RUNS,
            });
        }
        Design::build(kind, numeric)?.points
    };
    Ok(text::cross(levels, k, &rows))
}

/// Held-out test points a study gets when it names none: on a full-factorial grid with
/// an objective, `k + 2` off-grid points (at least 4), because on a grid leave-one-out
/// can be exactly zero while the surface is wrong between the grid lines; none
/// otherwise.
pub fn default_test_points(design: &DesignKind, n_factors: usize, has_objective: bool) -> usize {
    match design {
        DesignKind::FullFactorial { .. } if has_objective => (n_factors + 2).max(4),
        _ => 0,
    }
}

impl Checker<'_> {
    /// A design's centre points (default 1), at most [`MAX_RUNS`].
    pub(super) fn center_points(&self, at: &str, design: &DesignFile) -> Result<usize, StudyError> {
        let centre = design.center_points.unwrap_or(1);
        if centre > MAX_RUNS {
            return Err(self.error(
                &format!("{at}.center_points"),
                format!("expected at most {MAX_RUNS} centre points, got {centre}"),
            ));
        }
        Ok(centre)
    }

    /// Factor `index` of the file, a text factor with `levels`: at least two distinct,
    /// non-empty values, no range and no unit, and only for a user's own deck
    /// (`own_deck`), whose templates take text.
    pub(super) fn text_factor(
        &self,
        index: usize,
        factor: &file::FactorFile,
        levels: &[FixedValue],
        own_deck: bool,
        equipment_name: &str,
    ) -> Result<Factor, StudyError> {
        let at = |field: &str| format!("factors[{index}].{field}");
        if !own_deck {
            return Err(self.error(
                &at("levels"),
                format!(
                    "`{}` is a text factor, and the {equipment_name} equipment takes numbers only; text factors are for your own deck (`equipment: custom`). Give min and max instead",
                    factor.name
                ),
            ));
        }
        if factor.min.is_some() || factor.max.is_some() {
            return Err(self.error(
                &at(if factor.min.is_some() { "min" } else { "max" }),
                format!(
                    "`{}` has levels and a range; a factor is either text (`levels:`) or a number (min and max): remove one",
                    factor.name
                ),
            ));
        }
        if factor.unit.is_some() {
            return Err(self.error(
                &at("unit"),
                format!(
                    "`{}` is a text factor and has no unit; remove `unit:`",
                    factor.name
                ),
            ));
        }
        let texts: Vec<String> = levels
            .iter()
            .map(|level| match level {
                FixedValue::Text(text) => text.clone(),
                FixedValue::Number(number) => format!("{number}"),
            })
            .collect();
        if texts.len() < 2 {
            return Err(self.error(
                &at("levels"),
                format!(
                    "`{}` has {} level; a text factor needs at least two (a single value belongs in `fixed:`)",
                    factor.name,
                    texts.len()
                ),
            ));
        }
        for (i, text) in texts.iter().enumerate() {
            if text.trim().is_empty() {
                return Err(self.error(
                    &format!("factors[{index}].levels[{i}]"),
                    "expected a non-empty value",
                ));
            }
            if texts[..i].contains(text) {
                return Err(self.error(
                    &format!("factors[{index}].levels[{i}]"),
                    format!("`{text}` is listed twice; each level must differ"),
                ));
            }
        }
        Ok(Factor {
            name: factor.name.clone(),
            range: FactorRange {
                min: 0.0,
                max: (texts.len() - 1) as f64,
            },
            unit: String::new(),
            levels: texts,
        })
    }

    /// The design `design` describes; `at` is its field path (`design`, or a noise
    /// design's) for errors.
    pub(super) fn design_kind(
        &self,
        at: &str,
        design: &DesignFile,
        study_seed: u64,
    ) -> Result<DesignKind, StudyError> {
        let refuse = |field: &str, present: bool, kind: &str| {
            if present {
                Err(self.error(
                    &format!("{at}.{field}"),
                    format!("`{field}` does not apply to a {kind} design"),
                ))
            } else {
                Ok(())
            }
        };
        Ok(match design.kind {
            DesignType::FullFactorial => {
                refuse("alpha", design.alpha.is_some(), "full_factorial")?;
                refuse(
                    "center_points",
                    design.center_points.is_some(),
                    "full_factorial",
                )?;
                refuse("samples", design.samples.is_some(), "full_factorial")?;
                refuse("seed", design.seed.is_some(), "full_factorial")?;
                DesignKind::FullFactorial {
                    levels: design.levels.unwrap_or(3),
                }
            }
            DesignType::CentralComposite => {
                refuse("levels", design.levels.is_some(), "central_composite")?;
                refuse("samples", design.samples.is_some(), "central_composite")?;
                refuse("seed", design.seed.is_some(), "central_composite")?;
                DesignKind::CentralComposite {
                    alpha: match design.alpha.unwrap_or(AlphaFile::Orthogonal) {
                        AlphaFile::Orthogonal => CentralCompositeAlpha::Orthogonal,
                        AlphaFile::Rotatable => CentralCompositeAlpha::Rotatable,
                        AlphaFile::FaceCentred => CentralCompositeAlpha::FaceCentred,
                    },
                    center_points: self.center_points(at, design)?,
                }
            }
            DesignType::BoxBehnken => {
                refuse("levels", design.levels.is_some(), "box_behnken")?;
                refuse("alpha", design.alpha.is_some(), "box_behnken")?;
                refuse("samples", design.samples.is_some(), "box_behnken")?;
                refuse("seed", design.seed.is_some(), "box_behnken")?;
                DesignKind::BoxBehnken {
                    center_points: self.center_points(at, design)?,
                }
            }
            DesignType::LatinHypercube => {
                refuse("levels", design.levels.is_some(), "latin_hypercube")?;
                refuse("alpha", design.alpha.is_some(), "latin_hypercube")?;
                refuse(
                    "center_points",
                    design.center_points.is_some(),
                    "latin_hypercube",
                )?;
                let samples = design.samples.ok_or_else(|| {
                    self.error(
                        at,
                        "a latin_hypercube design needs `samples:` (number of runs)",
                    )
                })?;
                DesignKind::LatinHypercube {
                    samples,
                    seed: design.seed.unwrap_or(study_seed),
                    candidates: 50,
                }
            }
        })
    }
}

impl Checker<'_> {
    /// The design's kind and its points in the factors' box, every value finite.
    pub(super) fn design_points(
        &self,
        file: &StudyFile,
        factors: &[Factor],
    ) -> Result<(DesignKind, Vec<DesignPoint>), StudyError> {
        let design_kind = self.design_kind("design", &file.design, file.seed)?;
        let levels: Vec<u32> = factors.iter().map(Factor::level_count).collect();
        let design =
            coded_design(&design_kind, &levels).map_err(|e| self.error("design", e.to_string()))?;
        let limits: Vec<FactorRange> = factors.iter().map(|f| f.range).collect();
        let points: Vec<DesignPoint> = design
            .into_iter()
            .map(|coded| DesignPoint::in_box(coded, &limits, &levels))
            .collect();
        for (index, point) in points.iter().enumerate() {
            if let Some((factor, value)) = factors
                .iter()
                .zip(&point.natural)
                .find(|(_, v)| !v.is_finite())
            {
                return Err(self.error(
                    "design",
                    format!(
                        "design point {index} puts `{}` at {value}; every design value must be a finite number: narrow the factor's range",
                        factor.name
                    ),
                ));
            }
        }
        Ok((design_kind, points))
    }
}
