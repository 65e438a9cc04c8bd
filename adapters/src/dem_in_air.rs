//! The stage `air`: the design point's DEM run again in the air the `cfd` stage before
//! it computed, the step that `coupling:` repeats.
//!
//! A design job runs the DEM in still air (or vacuum); its `cfd` job computes the air
//! the particle stream drags along. This stage renders the design point's case with
//! that stage's air density and viscosity and `air_field` on, and writes the `cfd`
//! job's velocities on a grid to [`AIR_FIELD_FILE`], which the native kernel reads as
//! `[air] velocity_field`. Then a `cfd` job computes the air of the new stream, and so
//! on, until the coupling has settled:
//!
//! ```text
//! p000r0 → p000r0-cfd → p000r0-air1 → p000r0-cfd2 → p000r0-air2 → …
//! ```
//!
//! It is the same simulation as the design job's, with the same seed (the same
//! particles, so that a change between two runs is the air's), its responses and log
//! are the simulation's ([`Stage::reruns_design`]).

use std::path::Path;

use crate::stage::{Stage, StageError, Upstream, UpstreamFiles};
use crate::{Case, CommandSpec, ParameterSpec, ParseError, RenderError, ResponseSpec, RunResults};

/// The stage's kind, in the store and in job names (`p000r0-air1`).
pub const KIND: &str = "air";

/// The air velocities a DEM job in moving air reads, in its run directory.
pub const AIR_FIELD_FILE: &str = "air-field.csv";

/// Parameters an equipment needs to run in moving air.
pub const AIR_PARAMETERS: &[&str] = &["air_density", "air_viscosity", "air_field"];

/// The stage: the design point's DEM in the air of the `cfd` job it follows.
#[derive(Debug, Clone, Copy)]
pub struct DemInAir;

/// The air of the CFD stage, as the DEM takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AirProperties {
    /// Density, kg/m³.
    pub density_kg_m3: f64,
    /// Dynamic viscosity, Pa·s (the CFD stage's kinematic viscosity times density).
    pub dynamic_viscosity_pa_s: f64,
}

impl Default for AirProperties {
    /// Air at 20 °C.
    fn default() -> Self {
        AirProperties {
            density_kg_m3: 1.2,
            dynamic_viscosity_pa_s: 1.8e-5,
        }
    }
}

impl AirProperties {
    /// The air of a `cfd` stage case (`air_density` kg/m³, `air_viscosity` m²/s).
    pub fn of_cfd(cfd: &Case) -> AirProperties {
        let density = cfd.get("air_density");
        AirProperties {
            density_kg_m3: density,
            dynamic_viscosity_pa_s: cfd.get("air_viscosity") * density,
        }
    }
}

/// `case` run in the air of [`AIR_FIELD_FILE`]: the CFD stage's density and
/// viscosity, `air_field` on.
pub fn in_moving_air(case: &Case, air: &AirProperties) -> Case {
    let mut moving = case.clone();
    moving.parameters.set("air_density", air.density_kg_m3);
    moving
        .parameters
        .set("air_viscosity", air.dynamic_viscosity_pa_s);
    moving.parameters.set("air_field", 1.0);
    moving
}

impl DemInAir {
    /// The DEM case this stage runs: the design point's, with the job's own seed
    /// (`case.seed`), in the air of the `cfd` job upstream.
    fn dem_case(case: &Case, upstream: &Upstream<'_>) -> Option<Case> {
        let cfd = upstream.stage_case?;
        let mut dem = upstream.case.clone();
        dem.seed = case.seed;
        Some(in_moving_air(&dem, &AirProperties::of_cfd(cfd)))
    }
}

impl Stage for DemInAir {
    fn kind(&self) -> &'static str {
        KIND
    }

    fn description(&self) -> &'static str {
        "The design point's DEM run again in the air velocities of the `cfd` job before it (chained by `coupling:`)"
    }

    fn parameters(&self) -> &[ParameterSpec] {
        &[]
    }

    fn responses(&self) -> &[ResponseSpec] {
        // The simulation's own, which `reruns_design` says.
        &[]
    }

    fn upstream_responses(&self) -> &'static [&'static str] {
        &[]
    }

    fn upstream_parameters(&self) -> &'static [&'static str] {
        AIR_PARAMETERS
    }

    fn programs(&self) -> Vec<&str> {
        // The simulation's, which the design jobs need already.
        Vec::new()
    }

    fn install_hint(&self) -> &'static str {
        "the design job's solver runs it"
    }

    fn log_file(&self) -> Option<&str> {
        None
    }

    fn render(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<CommandSpec, StageError> {
        let dem = Self::dem_case(case, upstream).ok_or(StageError::NotAfterStage {
            kind: KIND,
            follows: crate::openfoam::KIND,
        })?;
        upstream.simulation.render(&dem, run_dir)?;
        let field = crate::openfoam::air_field_csv(upstream.run_dir)
            .map_err(|e| StageError::UpstreamFiles(format!("cannot read its air: {e}")))?;
        let path = run_dir.join(AIR_FIELD_FILE);
        std::fs::write(&path, field).map_err(|source| RenderError::Write { path, source })?;
        Ok(upstream.simulation.command())
    }

    fn results(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<RunResults, ParseError> {
        let dem = Self::dem_case(case, upstream).ok_or_else(|| ParseError::Unusable {
            path: run_dir.to_path_buf(),
            message: format!(
                "an `{KIND}` job reads its air from the `{}` job it follows, and this one follows none",
                crate::openfoam::KIND
            ),
        })?;
        upstream.simulation.results(&dem, run_dir)
    }

    fn reruns_design(&self) -> bool {
        true
    }

    fn follows(&self) -> Option<&'static str> {
        Some(crate::openfoam::KIND)
    }

    fn upstream_files(&self) -> UpstreamFiles {
        // The `cfd` job's probes of the air velocity.
        UpstreamFiles::Results
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(specs: &[ParameterSpec], values: &[(&str, f64)]) -> Case {
        let mut parameters = crate::ResolvedParameters::defaults(specs);
        for (name, value) in values {
            parameters.set(name, *value);
        }
        Case {
            parameters,
            seed: 1,
            text: Default::default(),
        }
    }

    #[test]
    fn the_dem_in_air_takes_the_cfd_stage_s_air() {
        let cfd = case(
            crate::openfoam::PARAMETERS,
            &[("air_density", 1.2), ("air_viscosity", 1.5e-5)],
        );
        let air = AirProperties::of_cfd(&cfd);
        assert_eq!(air.density_kg_m3, 1.2);
        assert!((air.dynamic_viscosity_pa_s - 1.8e-5).abs() < 1e-20);
        let still = case(crate::hopper::PARAMETERS, &[]);
        assert_eq!(still.get("air_field"), 0.0);
        let moving = in_moving_air(&still, &air);
        assert_eq!(moving.get("air_field"), 1.0);
        assert_eq!(moving.get("air_density"), 1.2);
    }

    #[test]
    fn its_case_is_the_design_point_s_with_its_own_seed_in_the_cfd_job_s_air() {
        let cfd = case(crate::openfoam::PARAMETERS, &[("air_density", 1.1)]);
        let mut point = case(crate::hopper::PARAMETERS, &[]);
        point.seed = 7;
        let responses = Default::default();
        let simulation = crate::EquipmentOnSolver::new(
            crate::equipment_for("hopper").unwrap(),
            crate::solver_for("native").unwrap(),
        )
        .unwrap();
        let mut upstream = Upstream {
            case: &point,
            responses: &responses,
            run_dir: Path::new("/nonexistent"),
            stage_case: Some(&cfd),
            simulation: &simulation,
        };
        let own = Case {
            seed: 42,
            ..Case::default()
        };
        let dem = DemInAir::dem_case(&own, &upstream).unwrap();
        assert_eq!(dem.seed, 42);
        assert_eq!(dem.get("air_density"), 1.1);
        assert_eq!(dem.get("air_field"), 1.0);
        // After a design job (no stage case) there is no air to run in.
        upstream.stage_case = None;
        assert!(DemInAir::dem_case(&own, &upstream).is_none());
        let error = DemInAir
            .render(&own, &upstream, Path::new("/nonexistent"))
            .unwrap_err();
        assert!(
            error.to_string().contains("runs after a `cfd` job"),
            "{error}"
        );
    }
}
