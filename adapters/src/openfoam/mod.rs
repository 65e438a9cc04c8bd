//! OpenFOAM (Debian `openfoam` v1912): the air a design point's particle stream drags
//! along under the hopper outlet. This is the CFD stage chained after a DEM stage.
//!
//! The case (`templates/openfoam/stream/`) is a box under the outlet meshed by
//! `blockMesh`; `topoSet` marks the cylinder the stream falls through; `pimpleFoam`
//! (transient, incompressible, laminar) solves the air with the particles' drag as a
//! semi-implicit momentum source there (`fvOptions`, rate from [`orch_granular::air`],
//! fed by the DEM stage's discharge rate, exit speed and stream radius). The sides and
//! the bottom are open to the still room; the hopper's underside is a wall. Two function
//! objects write what a study reads back: `ring` (probes of the air velocity on a
//! ring around the stream) and `entrained` (volume flow of air out through the bottom).
//!
//! Facts this relies on (`shared/solvers/README.md`): the programs are in /usr/bin and
//! need only `WM_PROJECT_DIR=/usr/share/openfoam` (the package's bashrc fails), the
//! tutorials' Allrun scripts do not work (ours is rendered with the case), and function
//! objects write `postProcessing/<name>/<startTime>/<file>`.

mod post;

use std::path::Path;

use orch_granular::air::{drag_rate_per_s, mean_fall_speed, StreamFraction};
use tera::Context;

pub use post::{
    read_probe_positions, read_probes, read_surface_field_value, read_time_series_dirs,
};

use crate::equipment::response;
use crate::params::spec;
use crate::simulation::{render_template, write};
use crate::{
    Case, CommandSpec, ParameterSpec, ParseError, RenderError, ResponseSpec, RunResults, Series,
    Stage, StageError, Upstream,
};

/// The stream-air stage: OpenFOAM after each DEM job (`stages: {cfd: …}`, or `cfd:`).
#[derive(Debug, Clone, Copy, Default)]
pub struct StreamAir;

/// The stage's kind in study files and the store.
pub const KIND: &str = "cfd";

impl Stage for StreamAir {
    fn kind(&self) -> &'static str {
        KIND
    }

    fn description(&self) -> &'static str {
        "OpenFOAM (pimpleFoam) case of the air the DEM job's particle stream drags under the outlet"
    }

    fn parameters(&self) -> &[ParameterSpec] {
        PARAMETERS
    }

    fn responses(&self) -> &[ResponseSpec] {
        RESPONSE_SPECS
    }

    fn upstream_responses(&self) -> &'static [&'static str] {
        UPSTREAM_RESPONSES
    }

    fn upstream_parameters(&self) -> &'static [&'static str] {
        UPSTREAM_PARAMETERS
    }

    fn programs(&self) -> Vec<&str> {
        vec!["blockMesh", "topoSet", "pimpleFoam"]
    }

    fn install_hint(&self) -> &'static str {
        "apt-get install -y openfoam (or scripts/setup)"
    }

    fn log_file(&self) -> Option<&str> {
        Some(LOG_FILE)
    }

    fn render(
        &self,
        case: &Case,
        upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<CommandSpec, StageError> {
        let stream = StreamInputs::from_upstream(upstream)?;
        render(case, &stream, run_dir)?;
        Ok(command(case))
    }

    fn results(
        &self,
        _case: &Case,
        _upstream: &Upstream<'_>,
        run_dir: &Path,
    ) -> Result<RunResults, ParseError> {
        parse(run_dir)
    }
}

/// The case's files: path in the case directory and template text.
const FILES: &[(&str, &str)] = &[
    (
        "Allrun",
        include_str!("../../../templates/openfoam/stream/Allrun"),
    ),
    (
        "0/U",
        include_str!("../../../templates/openfoam/stream/0/U"),
    ),
    (
        "0/p",
        include_str!("../../../templates/openfoam/stream/0/p"),
    ),
    (
        "constant/fvOptions",
        include_str!("../../../templates/openfoam/stream/constant/fvOptions"),
    ),
    (
        "constant/transportProperties",
        include_str!("../../../templates/openfoam/stream/constant/transportProperties"),
    ),
    (
        "constant/turbulenceProperties",
        include_str!("../../../templates/openfoam/stream/constant/turbulenceProperties"),
    ),
    (
        "system/blockMeshDict",
        include_str!("../../../templates/openfoam/stream/system/blockMeshDict"),
    ),
    (
        "system/controlDict",
        include_str!("../../../templates/openfoam/stream/system/controlDict"),
    ),
    (
        "system/decomposeParDict",
        include_str!("../../../templates/openfoam/stream/system/decomposeParDict"),
    ),
    (
        "system/fvSchemes",
        include_str!("../../../templates/openfoam/stream/system/fvSchemes"),
    ),
    (
        "system/fvSolution",
        include_str!("../../../templates/openfoam/stream/system/fvSolution"),
    ),
    (
        "system/topoSetDict",
        include_str!("../../../templates/openfoam/stream/system/topoSetDict"),
    ),
];

/// Where the templates live, for messages.
pub const TEMPLATE_DIR: &str = "templates/openfoam/stream";
/// The solver's log in the case directory.
pub const LOG_FILE: &str = "log.pimpleFoam";
/// Probes of the air velocity on the ring around the stream.
pub const RING_PROBES: &str = "postProcessing/ring";
/// Volume flow of air through the bottom of the domain.
pub const ENTRAINED_FLOW: &str = "postProcessing/entrained";
/// Probes on the ring.
pub const RING_POINTS: usize = 8;
/// Probes of the air velocity on a grid through the domain, written at the end.
pub const GRID_PROBES: &str = "postProcessing/airGrid";
/// Grid points across the domain (each horizontal direction) for [`GRID_PROBES`].
pub const GRID_ACROSS: usize = 9;
/// Grid points down the domain for [`GRID_PROBES`].
pub const GRID_DOWN: usize = 11;
/// Responses are averaged over this last fraction of the simulated time.
pub const AVERAGE_OVER: f64 = 0.25;

/// Parameters of the CFD stage (set under `cfd: fixed:` in a study file).
pub static PARAMETERS: &[ParameterSpec] = &[
    spec("air_density", 1.2, "kg/m^3", 0.01, 100.0, "air density"),
    spec(
        "air_viscosity",
        1.5e-5,
        "m^2/s",
        1e-7,
        1e-2,
        "kinematic viscosity of the air",
    ),
    spec(
        "domain_depth",
        0.1,
        "m",
        0.005,
        10.0,
        "height of the air domain under the outlet",
    ),
    spec(
        "domain_half_width",
        0.04,
        "m",
        0.005,
        10.0,
        "half-width of the square air domain",
    ),
    spec(
        "cells_across",
        16.0,
        "-",
        4.0,
        400.0,
        "cells across the domain",
    ),
    spec("cells_down", 24.0, "-", 4.0, 400.0, "cells along the fall"),
    spec("end_time", 0.3, "s", 0.001, 100.0, "simulated time"),
    spec(
        "ring_radius_factor",
        2.0,
        "-",
        1.0,
        10.0,
        "probe ring radius in stream radii",
    ),
    spec(
        "cores",
        1.0,
        "-",
        1.0,
        64.0,
        "MPI ranks (decomposePar + mpirun)",
    ),
];

/// What the CFD stage takes from its DEM stage: the stream leaving the outlet.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamInputs {
    /// Particle mass flow, kg/s (DEM response `discharge_rate`).
    pub discharge_rate_kg_per_s: f64,
    /// Mean downward speed at the sensor plane, m/s (`exit_speed`).
    pub exit_speed_m_per_s: f64,
    /// Radius of the stream at the sensor plane, m (`stream_radius_95`: the 95 % mass
    /// quantile of the particles' surface distances from the axis). Not the largest
    /// centre distance (`stream_radius`), which one particle knocked sideways sets: the
    /// drag acts where the mass is.
    pub stream_radius_m: f64,
    /// Coarse particle diameter, m (DEM parameter).
    pub coarse_diameter_m: f64,
    /// Fine particle diameter, m.
    pub fine_diameter_m: f64,
    /// Mass fraction of fines.
    pub fine_mass_fraction: f64,
    /// Particle density, kg/m³.
    pub particle_density: f64,
}

/// Responses of the CFD stage.
pub static RESPONSE_SPECS: &[ResponseSpec] = &[
    response(
        "air_entrained_flow",
        "m^3/s",
        "volume flow of air out through the bottom of the domain, mean over the last quarter of the run",
    ),
    response(
        "air_ring_speed",
        "m/s",
        "mean air speed on the probe ring around the stream, mean over the last quarter of the run",
    ),
];

/// The upstream job's responses the stream is built from: its mass flow, mean downward
/// speed and radius at the sensor plane.
pub const UPSTREAM_RESPONSES: &[&str] = &["discharge_rate", "exit_speed", "stream_radius_95"];

/// The upstream case's parameters the drag is built from: the two particle sizes,
/// their mass fractions and density.
pub const UPSTREAM_PARAMETERS: &[&str] = &[
    "coarse_diameter",
    "fine_diameter",
    "fine_mass_fraction",
    "density",
];

impl StreamInputs {
    /// The inputs from the upstream DEM job's case and stored responses; the error
    /// names the first missing response.
    pub fn from_upstream(upstream: &Upstream<'_>) -> Result<StreamInputs, StageError> {
        let response = |index: usize| {
            let name = UPSTREAM_RESPONSES[index];
            upstream
                .responses
                .get(name)
                .copied()
                .filter(|v| v.is_finite())
                .ok_or(StageError::MissingResponse(name))
        };
        let parameter = |index: usize| upstream.case.get(UPSTREAM_PARAMETERS[index]);
        Ok(StreamInputs {
            discharge_rate_kg_per_s: response(0)?,
            exit_speed_m_per_s: response(1)?,
            stream_radius_m: response(2)?,
            coarse_diameter_m: parameter(0),
            fine_diameter_m: parameter(1),
            fine_mass_fraction: parameter(2),
            particle_density: parameter(3),
        })
    }
}

/// Every value the case templates see.
pub fn context(case: &Case, stream: &StreamInputs) -> Context {
    let mut context = Context::new();
    for (name, value) in &case.parameters.0 {
        context.insert(name.as_str(), value);
    }
    let depth = case.get("domain_depth");
    let speed = mean_fall_speed(stream.exit_speed_m_per_s, depth);
    let fractions = [
        StreamFraction {
            diameter_m: stream.coarse_diameter_m,
            mass_flow_kg_per_s: stream.discharge_rate_kg_per_s * (1.0 - stream.fine_mass_fraction),
        },
        StreamFraction {
            diameter_m: stream.fine_diameter_m,
            mass_flow_kg_per_s: stream.discharge_rate_kg_per_s * stream.fine_mass_fraction,
        },
    ];
    let drag_rate = drag_rate_per_s(
        &fractions,
        stream.particle_density,
        stream.stream_radius_m,
        speed,
        case.get("air_viscosity"),
    );
    let ring_radius = case.get("ring_radius_factor") * stream.stream_radius_m;
    let probes: Vec<[f64; 3]> = (0..RING_POINTS)
        .map(|k| {
            let phi = std::f64::consts::TAU * k as f64 / RING_POINTS as f64;
            [
                ring_radius * phi.cos(),
                ring_radius * phi.sin(),
                -0.5 * depth,
            ]
        })
        .collect();
    let cells = (case.get("domain_half_width") * 2.0 / case.get("cells_across"))
        .min(depth / case.get("cells_down"));
    context.insert("half_width", &case.get("domain_half_width"));
    context.insert("depth", &depth);
    context.insert("cells_across", &(case.get("cells_across").round() as u64));
    context.insert("cells_down", &(case.get("cells_down").round() as u64));
    context.insert("cores_int", &(case.get("cores").round() as u64));
    context.insert("stream_radius", &stream.stream_radius_m);
    context.insert("particle_speed", &speed);
    context.insert("drag_rate", &drag_rate);
    context.insert("ring_probes", &probes);
    context.insert(
        "grid_probes",
        &grid_points(case.get("domain_half_width"), depth),
    );
    // A first step that keeps the Courant number below 0.1 at the particles' speed.
    context.insert("initial_timestep", &(0.1 * cells / speed.max(0.1)));
    context
}

/// The points of the air-velocity grid: [`GRID_ACROSS`] × [`GRID_ACROSS`] ×
/// [`GRID_DOWN`] points evenly spaced over the box `[-half_width, half_width]² ×
/// [-depth, 0]`, each kept half a spacing inside its faces (so every point lies in a
/// cell), x fastest, then y, then z.
pub fn grid_points(half_width_m: f64, depth_m: f64) -> Vec<[f64; 3]> {
    let axis = |low: f64, high: f64, n: usize| -> Vec<f64> {
        let step = (high - low) / n as f64;
        (0..n).map(|i| low + (i as f64 + 0.5) * step).collect()
    };
    let across = axis(-half_width_m, half_width_m, GRID_ACROSS);
    let down = axis(-depth_m, 0.0, GRID_DOWN);
    let mut points = Vec::with_capacity(across.len() * across.len() * down.len());
    for &z in &down {
        for &y in &across {
            for &x in &across {
                points.push([x, y, z]);
            }
        }
    }
    points
}

/// The air velocity a finished case wrote on its grid ([`GRID_PROBES`], the last
/// time), as the CSV the native kernel's `[air] velocity_field` reads: a header
/// `x,y,z,ux,uy,uz`, then one row per grid point (m, m/s). The probe positions come
/// from the file's header, so the grid is the one the case was run with.
pub fn air_field_csv(run_dir: &Path) -> Result<String, ParseError> {
    let dir = run_dir.join(GRID_PROBES);
    let rows = read_time_series_dirs(&dir, "U", |mut reader, path| {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut reader, &mut text).map_err(ParseError::read(path))?;
        let positions = read_probe_positions(std::io::Cursor::new(&text), path)?;
        let rows = read_probes(std::io::Cursor::new(&text), path)?;
        Ok(rows
            .into_iter()
            .map(|(t, velocities)| (t, (positions.clone(), velocities)))
            .collect())
    })?;
    let Some((_, (positions, velocities))) = rows.last() else {
        return Err(ParseError::malformed(
            &dir.join("U"),
            1,
            "no time step in the air grid's probes",
        ));
    };
    if velocities.len() != positions.len() {
        return Err(ParseError::malformed(
            &dir.join("U"),
            1,
            format!(
                "{} probe positions in the header but {} velocities in the last row",
                positions.len(),
                velocities.len()
            ),
        ));
    }
    let mut csv = String::from("x,y,z,ux,uy,uz\n");
    for (p, u) in positions.iter().zip(velocities) {
        csv.push_str(&format!(
            "{:e},{:e},{:e},{:e},{:e},{:e}\n",
            p[0], p[1], p[2], u[0], u[1], u[2]
        ));
    }
    Ok(csv)
}

/// Checks a CFD case: the stream and its probe ring fit inside the domain.
pub fn check(case: &Case, stream: &StreamInputs) -> Result<(), RenderError> {
    let ring = case.get("ring_radius_factor") * stream.stream_radius_m;
    let half_width = case.get("domain_half_width");
    if ring >= half_width {
        return Err(RenderError::InvalidCase(format!(
            "the probe ring (radius {ring:.4} m = ring_radius_factor × stream radius) does not fit in the domain (domain_half_width {half_width} m); widen the domain"
        )));
    }
    if !(stream.discharge_rate_kg_per_s > 0.0 && stream.stream_radius_m > 0.0) {
        return Err(RenderError::InvalidCase(format!(
            "the DEM stage gave no stream to drive the air (discharge_rate {} kg/s, stream_radius_95 {} m)",
            stream.discharge_rate_kg_per_s, stream.stream_radius_m
        )));
    }
    Ok(())
}

/// Writes the case into `run_dir`: every template rendered, `Allrun` executable.
pub fn render(case: &Case, stream: &StreamInputs, run_dir: &Path) -> Result<(), RenderError> {
    check(case, stream)?;
    let context = context(case, stream);
    for (file, template) in FILES {
        let name = format!("{TEMPLATE_DIR}/{file}");
        let text = render_template(&name, template, &context)?;
        write(run_dir, file, &text)?;
    }
    Ok(())
}

/// The command: the rendered `Allrun` (blockMesh, topoSet, pimpleFoam; with
/// decomposePar, mpirun and reconstructPar when `cores` > 1).
pub fn command(case: &Case) -> CommandSpec {
    CommandSpec {
        program: "/bin/sh".to_string(),
        args: vec!["Allrun".to_string()],
        env: Default::default(),
        cores: case.get("cores").round() as usize,
        // Its ranks are started by Allrun's own mpirun; submitted as one task.
        mpi: false,
        same_result_on_any_cores: false,
        log_file: LOG_FILE.to_string(),
    }
}

/// Reads the function objects' output of a finished case: `air_entrained_flow` (m³/s
/// out through the bottom) and `air_ring_speed` (m/s, mean air speed on the probe
/// ring), averaged over the last [`AVERAGE_OVER`] of the run, and both over time.
pub fn parse(run_dir: &Path) -> Result<RunResults, ParseError> {
    let entrained = read_time_series_dirs(
        &run_dir.join(ENTRAINED_FLOW),
        "surfaceFieldValue.dat",
        read_surface_field_value,
    )?;
    let ring = read_time_series_dirs(&run_dir.join(RING_PROBES), "U", |r, p| {
        read_probes(r, p).map(|rows| {
            rows.into_iter()
                .map(|(t, vectors)| {
                    let speeds: f64 = vectors
                        .iter()
                        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
                        .sum();
                    (t, speeds / vectors.len().max(1) as f64)
                })
                .collect()
        })
    })?;
    let responses = vec![
        (RESPONSE_SPECS[0].name.to_string(), late_mean(&entrained)),
        (RESPONSE_SPECS[1].name.to_string(), late_mean(&ring)),
    ];
    Ok(RunResults {
        responses,
        series: vec![
            Series {
                name: RESPONSE_SPECS[0].name.to_string(),
                points: entrained,
            },
            Series {
                name: RESPONSE_SPECS[1].name.to_string(),
                points: ring,
            },
        ],
        missing: Vec::new(),
        notes: Vec::new(),
    })
}

/// Mean of a series' values over its last [`AVERAGE_OVER`] of time (the last value
/// when that window holds none).
fn late_mean(series: &[(f64, f64)]) -> f64 {
    let end = series.last().map_or(0.0, |p| p.0);
    let from = end * (1.0 - AVERAGE_OVER);
    let late: Vec<f64> = series.iter().filter(|p| p.0 >= from).map(|p| p.1).collect();
    late.iter().sum::<f64>() / late.len().max(1) as f64
}

#[cfg(test)]
mod tests;
