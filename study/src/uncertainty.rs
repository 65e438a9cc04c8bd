//! `uncertainty:` of a study: the material properties that vary, their
//! distributions, the Monte Carlo that carries them through the fitted surfaces and
//! the noise design around the optimum, as the study file asks for them.

use super::*;

/// Monte Carlo at the optimum over uncertain factors.
#[derive(Debug, Clone, PartialEq)]
pub struct UncertaintyConfig {
    /// Samples.
    pub samples: usize,
    /// Seed.
    pub seed: u64,
    /// Factors held at their mean while optimising: `(factor index, distribution in
    /// natural units)`.
    pub parameters: Vec<(usize, Distribution)>,
    /// The design over materials and tolerances run around the optimum, if any.
    pub noise: Option<NoiseDesign>,
}

/// A design over uncertain parameters, run around the optimum after the rounds as a
/// study of its own (`<study>-noise`), whose surrogates carry the distributions to the
/// bounds of the responses there.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseDesign {
    /// Parameters that are not factors, with their distributions.
    pub materials: Vec<Material>,
    /// Factors with a manufacturing tolerance: `(factor index, standard deviation in
    /// natural units)`, normal around the optimum.
    pub tolerances: Vec<(usize, f64)>,
    /// The design over the materials and tolerances (in that order; default a
    /// central composite with orthogonal α and one centre point, or 5 levels of one).
    pub design: DesignKind,
    /// Standard deviations either side of the mean the design spans.
    pub half_width: f64,
    /// Its runs (points).
    pub runs: usize,
}

/// An uncertain parameter that is not a design factor (a material property).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// The template parameter.
    pub name: String,
    /// Its distribution in natural units.
    pub distribution: Distribution,
    /// Its unit.
    pub unit: String,
}

/// The range a noise design spans for `distribution`: `mean ± half_width·std` for a
/// normal, the support of a uniform, `exp(mu ± half_width·sigma)` for a log-normal.
pub fn noise_range(distribution: &Distribution, half_width: f64) -> (f64, f64) {
    match *distribution {
        Distribution::Normal { mean, std } => (mean - half_width * std, mean + half_width * std),
        Distribution::Uniform { low, high } => (low, high),
        Distribution::LogNormal { mu, sigma } => (
            (mu - half_width * sigma).exp(),
            (mu + half_width * sigma).exp(),
        ),
    }
}

/// `v` to six significant digits, without trailing zeros.
fn short(v: f64) -> String {
    let text = format!(
        "{:.*}",
        5usize.saturating_sub(v.abs().log10().floor().max(-10.0) as usize),
        v
    );
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    };
    if text == "-0" {
        "0".into()
    } else {
        text
    }
}

/// The mean of `distribution`.
pub fn mean_of(distribution: &Distribution) -> f64 {
    match *distribution {
        Distribution::Normal { mean, .. } => mean,
        Distribution::Uniform { low, high } => 0.5 * (low + high),
        Distribution::LogNormal { mu, sigma } => (mu + 0.5 * sigma * sigma).exp(),
    }
}

impl Checker<'_> {
    pub(super) fn uncertainty(
        &self,
        file: &file::UncertaintyFile,
        factors: &[Factor],
        known: &dyn Fn(&str) -> Option<ParameterRange>,
        fixed: &BTreeMap<String, FixedValue>,
        study_seed: u64,
    ) -> Result<UncertaintyConfig, StudyError> {
        if file.samples < 100 {
            return Err(self.error(
                "uncertainty.samples",
                format!("expected at least 100 samples, got {}", file.samples),
            ));
        }
        if file.samples > MAX_UNCERTAINTY_SAMPLES {
            return Err(self.error(
                "uncertainty.samples",
                format!(
                    "expected at most {MAX_UNCERTAINTY_SAMPLES} samples (10^7), got {}",
                    file.samples
                ),
            ));
        }
        let half_width = file.noise_design.as_ref().map_or(3.0, |n| n.half_width);
        if !(half_width.is_finite() && half_width > 0.0 && half_width <= 10.0) {
            return Err(self.error(
                "uncertainty.noise_design.half_width",
                format!("expected a number of standard deviations in (0, 10], got {half_width}"),
            ));
        }
        let mut parameters = Vec::new();
        let mut materials = Vec::new();
        let mut tolerances = Vec::new();
        for (i, p) in file.parameters.iter().enumerate() {
            let at = |field: &str| format!("uncertainty.parameters[{i}].{field}");
            if file.parameters[..i].iter().any(|q| q.name == p.name) {
                return Err(self.error(&at("name"), format!("`{}` is listed twice", p.name)));
            }
            let factor = factors.iter().position(|f| f.name == p.name);
            if let Some(text) = factor.map(|i| &factors[i]).filter(|f| f.is_text()) {
                return Err(self.error(
                    &at("name"),
                    format!(
                        "`{}` is a text factor ({}): it has no spread of numbers to be uncertain in; remove it from `uncertainty.parameters`",
                        text.name,
                        text.levels.join(", ")
                    ),
                ));
            }
            // A factor with a normal spread and no mean: a tolerance around the optimum.
            if let (Some(index), DistributionFile::Normal, None) = (factor, p.distribution, p.mean)
            {
                let std = p.std.ok_or_else(|| {
                    self.error(
                        &at("std"),
                        "a tolerance (a factor without `mean:`) needs `std:`",
                    )
                })?;
                if !(std.is_finite() && std > 0.0) {
                    return Err(self.error(
                        &at("std"),
                        format!("std must be positive and finite, got {std}"),
                    ));
                }
                tolerances.push((index, std));
                continue;
            }
            let need = |value: Option<f64>, field: &str| {
                value.ok_or_else(|| {
                    self.error(
                        &at(field),
                        format!("a {:?} distribution needs `{field}:`", p.distribution)
                            .to_lowercase(),
                    )
                })
            };
            let distribution = match p.distribution {
                DistributionFile::Normal => Distribution::Normal {
                    mean: need(p.mean, "mean")?,
                    std: need(p.std, "std")?,
                },
                DistributionFile::Uniform => Distribution::Uniform {
                    low: need(p.low, "low")?,
                    high: need(p.high, "high")?,
                },
                DistributionFile::Lognormal => Distribution::LogNormal {
                    mu: need(p.mu, "mu")?,
                    sigma: need(p.sigma, "sigma")?,
                },
            };
            orch_metamodel::propagate(&|x| x[0], &[distribution], 2, 0).map_err(|e| {
                self.error(
                    &at("distribution"),
                    e.to_string().trim_start_matches("input 0: ").to_string(),
                )
            })?;
            if let Some(index) = factor {
                parameters.push((index, distribution));
                continue;
            }
            // Not a factor: a material the noise design varies around the optimum.
            let Some((min, max, unit)) = known(&p.name) else {
                return Err(self.error(
                    &at("name"),
                    format!("`{}` is neither a factor nor a parameter of the equipment; name a factor (held at its mean while optimising, or with `std:` only, a tolerance) or a parameter (varied by the noise design around the optimum)", p.name),
                ));
            };
            if fixed.contains_key(&p.name) {
                return Err(self.error(
                    &at("name"),
                    format!("`{}` is both fixed and uncertain; remove it from `fixed:` (its mean is its value while the design is optimised)", p.name),
                ));
            }
            let (low, high) = noise_range(&distribution, half_width);
            if low < min || high > max {
                return Err(self.error(
                    &at("name"),
                    format!(
                        "the noise design would run `{}` over [{}, {}]{}, outside its range [{min}, {max}]; narrow the distribution or `noise_design.half_width`",
                        p.name,
                        short(low),
                        short(high),
                        if unit.is_empty() || unit == "-" { String::new() } else { format!(" {unit}") }
                    ),
                ));
            }
            materials.push(Material {
                name: p.name.clone(),
                distribution,
                unit,
            });
        }
        if file.parameters.is_empty() {
            return Err(self.error(
                "uncertainty.parameters",
                "expected at least one uncertain parameter",
            ));
        }
        let noise = self.noise_design(file, materials, tolerances, half_width, study_seed)?;
        Ok(UncertaintyConfig {
            samples: file.samples,
            seed: file.seed,
            parameters,
            noise,
        })
    }
}

impl Checker<'_> {
    /// `uncertainty:` against the simulation's parameters (any name on a user's own
    /// deck); the noise design's materials are rendered at their mean meanwhile, so
    /// they join `fixed`.
    pub(super) fn uncertainty_of(
        &self,
        file: &StudyFile,
        simulation: &dyn Simulation,
        factors: &[Factor],
        fixed: &mut BTreeMap<String, f64>,
    ) -> Result<Option<UncertaintyConfig>, StudyError> {
        let specs = simulation.parameters();
        let spec_of = |name: &str| specs.iter().find(|s| s.name == name);
        let custom_template = simulation.accepts_undeclared_parameters();
        let uncertainty = match &file.uncertainty {
            None => None,
            Some(u) => {
                let known = |name: &str| -> Option<ParameterRange> {
                    match spec_of(name) {
                        Some(spec) => Some((spec.min, spec.max, spec.unit.to_string())),
                        None if custom_template => {
                            Some((f64::NEG_INFINITY, f64::INFINITY, String::new()))
                        }
                        None => None,
                    }
                };
                let config = self.uncertainty(u, factors, &known, &file.fixed, file.seed)?;
                // Materials are rendered at their mean while the design is optimised.
                for material in config.noise.iter().flat_map(|n| &n.materials) {
                    fixed.insert(material.name.clone(), mean_of(&material.distribution));
                }
                Some(config)
            }
        };
        Ok(uncertainty)
    }
}

impl Checker<'_> {
    /// The noise design around the optimum over `materials` (parameters that are not
    /// factors) and factors' `tolerances` (index, std), when there are any.
    fn noise_design(
        &self,
        file: &file::UncertaintyFile,
        materials: Vec<Material>,
        tolerances: Vec<(usize, f64)>,
        half_width: f64,
        study_seed: u64,
    ) -> Result<Option<NoiseDesign>, StudyError> {
        let noise = if materials.is_empty() && tolerances.is_empty() {
            if file.noise_design.is_some() {
                return Err(self.error(
                    "uncertainty.noise_design",
                    "a noise design varies parameters that are not factors, or factors' tolerances (`std:` without `mean:`); the study has neither",
                ));
            }
            None
        } else {
            let at = "uncertainty.noise_design.design";
            let design = match file.noise_design.as_ref().and_then(|n| n.design.as_ref()) {
                Some(design) => self.design_kind(at, design, study_seed)?,
                None if materials.len() + tolerances.len() == 1 => {
                    DesignKind::FullFactorial { levels: 5 }
                }
                None => DesignKind::CentralComposite {
                    alpha: CentralCompositeAlpha::Orthogonal,
                    center_points: 1,
                },
            };
            let dimensions = materials.len() + tolerances.len();
            let runs = Design::build(&design, dimensions)
                .map_err(|e| {
                    self.error(
                        at,
                        format!("{e} (over the {dimensions} uncertain parameters)"),
                    )
                })?
                .len();
            Some(NoiseDesign {
                materials,
                tolerances,
                design,
                half_width,
                runs,
            })
        };
        Ok(noise)
    }
}
