//! The angle of repose of a poured heap, on the native kernel and on LIGGGHTS from the
//! same case: 3 mm glass-like spheres (E = 5 MPa, e = 0.6, μ = 0.5, rolling friction
//! μr = 0.1 by the constant directional torque of both codes; without it spheres roll
//! off a smooth disk and leave no heap) poured from a central inlet onto a fixed disk 80 mm across, whose edge
//! sheds what does not stay (the "fixed base" method). The heap's angle is measured
//! from the settled bed's free surface (`orch_granular::bed::heap_angle_deg`).

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use orch_adapters::dump::read_dump;
use orch_granular::bed::heap_angle_deg;
use orch_granular::Sighting;

use crate::support::{require_liggghts, run_in, solver_lock};

/// Particle radius, m.
const RADIUS_M: f64 = 0.0015;
/// The disk's radius, m.
const BASE_RADIUS_M: f64 = 0.04;
/// Time step, s (0.1 of the particles' Rayleigh time).
const TIMESTEP_S: f64 = 1.5e-5;
/// Pouring ends, s.
const POUR_END_S: f64 = 1.0;
/// The run ends, settled, s.
const END_S: f64 = 1.4;
/// Mass poured, kg/s (0.06 kg in all, about 1 700 spheres: more than the heap holds).
const POUR_RATE_KG_PER_S: f64 = 0.06;
/// The inlet: a cylinder on the axis, m, roomy enough that LIGGGHTS's insertion
/// places every batch (with a 10 mm tall one it placed 33 of 45 spheres a batch).
const INLET_RADIUS_M: f64 = 0.01;
const INLET_BOTTOM_M: f64 = 0.045;
const INLET_TOP_M: f64 = 0.065;
/// Inlet speed, m/s (downwards).
const INLET_SPEED_M_PER_S: f64 = 0.5;

/// The disk z = 0 as an ASCII STL fan of 64 triangles.
fn disk_stl() -> String {
    let mut stl = String::from("solid base\n");
    let n = 64;
    for k in 0..n {
        let (a, b) = (
            k as f64 * std::f64::consts::TAU / n as f64,
            (k + 1) as f64 * std::f64::consts::TAU / n as f64,
        );
        let r = BASE_RADIUS_M;
        stl += &format!(
            "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex {} {} 0\nvertex {} {} 0\nendloop\nendfacet\n",
            r * a.cos(),
            r * a.sin(),
            r * b.cos(),
            r * b.sin()
        );
    }
    stl + "endsolid base\n"
}

fn steps() -> u64 {
    (END_S / TIMESTEP_S).round() as u64
}

fn native_case() -> String {
    format!(
        r#"[run]
timestep = {TIMESTEP_S}
end_time = {END_S}
seed = 7
thermo_every = 10000

[domain]
min = [-0.06, -0.06, -0.03]
max = [0.06, 0.06, 0.07]

[[types]]
name = "glass"
radius = {RADIUS_M}
density = 2500
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.6
friction = 0.5
rolling_friction = 0.1

[wall_material]
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.6
friction = 0.5
rolling_friction = 0.1

[[meshes]]
name = "base"
file = "base.stl"

[[inflow]]
mass_rate = {POUR_RATE_KG_PER_S}
mass_fractions = [1.0]
velocity = [0.0, 0.0, -{INLET_SPEED_M_PER_S}]
start = 0.0
end = {POUR_END_S}
region = {{ kind = "cylinder", centre = [0.0, 0.0], radius = {INLET_RADIUS_M}, z_min = {INLET_BOTTOM_M}, z_max = {INLET_TOP_M} }}

[sink]
z = -0.02

[output]
dump_every = {}
"#,
        steps()
    )
}

fn liggghts_deck() -> String {
    format!(
        r#"atom_style granular
atom_modify map array
boundary f f f
newton off
communicate single vel yes
units si
region domain block -0.06 0.06 -0.06 0.06 -0.03 0.07 units box
create_box 1 domain
neighbor {skin} bin
neigh_modify delay 0
fix m1 all property/global youngsModulus peratomtype 5e6
fix m2 all property/global poissonsRatio peratomtype 0.3
fix m3 all property/global coefficientRestitution peratomtypepair 1 0.6
fix m4 all property/global coefficientFriction peratomtypepair 1 0.5
fix m5 all property/global coefficientRollingFriction peratomtypepair 1 0.1
pair_style gran model hertz tangential history rolling_friction cdt
pair_coeff * *
timestep {TIMESTEP_S}
fix gravity all gravity 9.81 vector 0.0 0.0 -1.0
fix base all mesh/surface file base.stl type 1
fix walls all wall/gran model hertz tangential history rolling_friction cdt mesh n_meshes 1 meshes base
fix glass all particletemplate/sphere 15485863 atom_type 1 density constant 2500 radius constant {RADIUS_M}
fix mixture all particledistribution/discrete 32452843 1 glass 1.0
region inlet cylinder z 0.0 0.0 {INLET_RADIUS_M} {INLET_BOTTOM_M} {INLET_TOP_M} units box
fix pour all insert/rate/region seed 49979687 distributiontemplate mixture &
    mass {mass} massrate {POUR_RATE_KG_PER_S} insert_every {every} &
    overlapcheck yes all_in yes vel constant 0.0 0.0 -{INLET_SPEED_M_PER_S} region inlet ntry_mc 10000
fix integrate all nve/sphere
region below block INF INF INF INF INF -0.02 units box
thermo 10000
thermo_modify lost ignore norm no
run {pour_steps}
unfix pour
run {settle_steps}
delete_atoms region below
dump final all custom 1 post/dump*.liggghts id type radius mass x y z vx vy vz
run 0
"#,
        skin = RADIUS_M,
        mass = POUR_RATE_KG_PER_S * POUR_END_S,
        every = ((INLET_TOP_M - INLET_BOTTOM_M) / INLET_SPEED_M_PER_S / TIMESTEP_S).round() as u64,
        pour_steps = (POUR_END_S / TIMESTEP_S).round() as u64,
        settle_steps = ((END_S - POUR_END_S) / TIMESTEP_S).round() as u64,
    )
}

/// The particles of the last dump under `dir/post`, above the sink.
fn settled(dir: &Path) -> Vec<Sighting> {
    let mut dumps: Vec<_> = std::fs::read_dir(dir.join("post"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "liggghts"))
        .collect();
    dumps.sort_by_key(|p| {
        let name = p.file_stem().unwrap().to_string_lossy().into_owned();
        name.trim_start_matches("dump").parse::<u64>().unwrap_or(0)
    });
    let path = dumps.last().expect("a dump").clone();
    let mut bed = Vec::new();
    read_dump(
        BufReader::new(File::open(&path).unwrap()),
        &path,
        |snapshot| {
            bed = snapshot
                .sightings()
                .map_err(|missing| format!("{missing:?}"))?;
            Ok(())
        },
    )
    .unwrap();
    bed.retain(|p| p.position_m[2] > 0.0);
    bed
}

/// The heap's angle, degrees, from 10 mm off the axis (clear of the inlet's stream) to
/// 30 mm (a few particles inside the disk's edge), in 4 mm rings.
fn angle(bed: &[Sighting]) -> f64 {
    heap_angle_deg(bed, 0.010, 0.034, 0.004, 3).expect("every ring of the heap holds particles")
}

#[test]
fn a_poured_heap_stands_at_the_same_angle_on_the_native_kernel_and_on_liggghts() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let scratch = tempfile::tempdir().unwrap();
    let (native, liggghts) = (
        scratch.path().join("native"),
        scratch.path().join("liggghts"),
    );
    for dir in [&native, &liggghts] {
        std::fs::create_dir_all(dir.join("post")).unwrap();
        std::fs::write(dir.join("base.stl"), disk_stl()).unwrap();
    }
    std::fs::write(native.join("heap.toml"), native_case()).unwrap();
    std::fs::write(liggghts.join("in.heap"), liggghts_deck()).unwrap();
    let orch_dem = crate::support::orch_bin().with_file_name("orch-dem");
    run_in(&native, orch_dem.to_str().unwrap(), &["run", "heap.toml"]);
    run_in(
        &liggghts,
        "liggghts",
        &["-in", "in.heap", "-log", "log.liggghts", "-echo", "none"],
    );
    let (native_bed, liggghts_bed) = (settled(&native), settled(&liggghts));
    let (native_angle, liggghts_angle) = (angle(&native_bed), angle(&liggghts_bed));
    eprintln!(
        "heap angle: native {native_angle:.2}° ({} spheres on the disk), LIGGGHTS {liggghts_angle:.2}° ({})",
        native_bed.len(),
        liggghts_bed.len()
    );
    // Measured over three seeds each (docs/thesis-replication.md): native 14.0° ± 1.2°
    // and 1 406 ± 12 spheres kept, LIGGGHTS 12.6° ± 0.9° and 1 343 ± 16 (sd): the
    // native heap is steeper by 1.4° and holds 4.7 % more, a difference the seeds do
    // not explain. The bounds below hold that with room for one run's scatter.
    for (code, angle) in [("native", native_angle), ("LIGGGHTS", liggghts_angle)] {
        assert!(
            (8.0..=20.0).contains(&angle),
            "{code}: a heap of {angle:.2}°, outside 8–20°"
        );
    }
    assert!(
        (native_angle - liggghts_angle).abs() <= 5.0,
        "native {native_angle:.2}° against LIGGGHTS {liggghts_angle:.2}°"
    );
    let kept = native_bed.len() as f64 / liggghts_bed.len() as f64;
    assert!(
        (kept - 1.0).abs() <= 0.1,
        "the native heap keeps {} spheres, LIGGGHTS's {}",
        native_bed.len(),
        liggghts_bed.len()
    );
}
