//! Air drag on the particles (issue 15), the same in the native kernel (a case's
//! `[air]`) and in LIGGGHTS (`fix addforce` with atom-style variables of the
//! Schiller–Naumann drag, the deck below): a 1 mm glass sphere dropped from rest in
//! still air crosses a plane 3 m below at the speed the equation of motion
//! `dv/dt = g − (3 ρ_a C_d(Re) / (8 ρ_p r)) v²` gives, integrated here on its own.

use crate::support::{require_liggghts, solver_lock, text, Project};

const RADIUS_M: f64 = 0.0005;
const DENSITY: f64 = 2500.0;
const AIR_DENSITY: f64 = 1.2;
const AIR_VISCOSITY: f64 = 1.8e-5;
const G: f64 = 9.81;
const DROP_M: f64 = 3.0;

/// Schiller–Naumann, written out for the reference.
fn drag_coefficient(re: f64) -> f64 {
    if re < 1000.0 {
        24.0 / re * (1.0 + 0.15 * re.powf(0.687))
    } else {
        0.44
    }
}

/// The speed after falling `drop` from rest, by RK4 in time (step 10 µs), m/s.
fn reference_speed(drop: f64) -> f64 {
    let acceleration = |v: f64| {
        if v == 0.0 {
            return G;
        }
        let re = AIR_DENSITY * v * 2.0 * RADIUS_M / AIR_VISCOSITY;
        G - 3.0 * AIR_DENSITY * drag_coefficient(re) * v * v / (8.0 * DENSITY * RADIUS_M)
    };
    let (mut z, mut v, dt) = (0.0, 0.0, 1e-5);
    loop {
        let (k1v, k1z) = (acceleration(v), v);
        let (k2v, k2z) = (acceleration(v + 0.5 * dt * k1v), v + 0.5 * dt * k1v);
        let (k3v, k3z) = (acceleration(v + 0.5 * dt * k2v), v + 0.5 * dt * k2v);
        let (k4v, k4z) = (acceleration(v + dt * k3v), v + dt * k3v);
        let (v1, z1) = (
            v + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v),
            z + dt / 6.0 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z),
        );
        if z1 >= drop {
            return v + (v1 - v) * (drop - z) / (z1 - z);
        }
        (v, z) = (v1, z1);
    }
}

/// The native case: one sphere at rest at z = 0, a sensor plane `DROP_M` below.
fn native_case() -> String {
    format!(
        r#"
[run]
timestep = 1e-5
end_time = 1.5
seed = 1
skin = 10.0
max_speed = 100.0

[domain]
min = [-0.1, -0.1, -4.0]
max = [0.1, 0.1, 0.1]

[[types]]
name = "glass"
radius = {RADIUS_M}
density = {DENSITY}
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.9
friction = 0.5

[wall_material]
youngs_modulus = 5e6
poisson_ratio = 0.3
restitution = 0.9
friction = 0.5

[[particles]]
type = "glass"
position = [0.0, 0.0, 0.0]

[air]
density = {AIR_DENSITY}
viscosity = {AIR_VISCOSITY}

[sensor]
z = -{DROP_M}
"#
    )
}

/// The LIGGGHTS deck: the same sphere, the drag as an atom-style force, and its height
/// and vertical speed printed every 10 steps.
fn liggghts_deck() -> String {
    format!(
        r#"atom_style granular
atom_modify map array sort 0 0.0
boundary m m m
newton off
communicate single vel yes
units si
processors 1 1 1
region domain block -0.1 0.1 -0.1 0.1 -4.0 0.1 units box
create_box 1 domain
neighbor 0.5 bin
neigh_modify delay 0
fix m1 all property/global youngsModulus peratomtype 5e6
fix m2 all property/global poissonsRatio peratomtype 0.3
fix m3 all property/global coefficientRestitution peratomtypepair 1 0.9
fix m4 all property/global coefficientFriction peratomtypepair 1 0.5
pair_style gran model hertz tangential history
pair_coeff * *
timestep 1e-4
fix gravity all gravity {G} vector 0.0 0.0 -1.0
create_atoms 1 single 0.0 0.0 0.0 units box
set atom 1 diameter {diameter} density {DENSITY}
compute rad all property/atom radius
variable ux atom 0.0-vx
variable uy atom 0.0-vy
variable uz atom 0.0-vz
variable ur atom sqrt(v_ux*v_ux+v_uy*v_uy+v_uz*v_uz)+1e-12
variable re atom {AIR_DENSITY}*v_ur*2.0*c_rad/{AIR_VISCOSITY}
variable cd atom (v_re<1000)*24.0/v_re*(1.0+0.15*v_re^0.687)+(v_re>=1000)*0.44
variable k atom 0.5*{AIR_DENSITY}*v_cd*PI*c_rad*c_rad*v_ur
variable fx atom v_k*v_ux
variable fy atom v_k*v_uy
variable fz atom v_k*v_uz
fix drag all addforce v_fx v_fy v_fz
fix integrate all nve/sphere
variable z1 equal z[1]
variable vz1 equal vz[1]
fix out all print 10 "${{z1}} ${{vz1}}" file fall.txt screen no title none
run 15000
"#,
        diameter = 2.0 * RADIUS_M
    )
}

#[test]
fn a_sphere_falling_in_air_crosses_a_plane_at_the_same_speed_on_both_solvers() {
    let expected = reference_speed(DROP_M);
    let vacuum = (2.0 * G * DROP_M).sqrt();
    assert!(
        expected < 0.9 * vacuum,
        "the drag must matter: {expected} vs {vacuum}"
    );

    // The native kernel: the crossing's recorded velocity.
    let project = Project::new();
    let case = project.write("drop.toml", &native_case());
    let orch_dem = crate::support::orch_bin().with_file_name("orch-dem");
    let output = std::process::Command::new(&orch_dem)
        .arg("run")
        .arg(&case)
        .current_dir(project.dir.path())
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", text(&output.stderr));
    let crossings = std::fs::read_to_string(project.dir.path().join("post/crossings.csv"))
        .unwrap_or_else(|e| panic!("no crossings: {e}; {}", text(&output.stderr)));
    let row: Vec<f64> = crossings
        .lines()
        .nth(1)
        .unwrap_or_else(|| panic!("the sphere did not cross: {crossings}"))
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let native = -row[10];

    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let deck = project.write("drop.in", &liggghts_deck());
    let output = std::process::Command::new("liggghts")
        .args([
            "-in",
            deck.to_str().unwrap(),
            "-log",
            "log.drop",
            "-echo",
            "none",
        ])
        .current_dir(project.dir.path())
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", text(&output.stdout));
    let fall = std::fs::read_to_string(project.dir.path().join("fall.txt")).unwrap();
    let samples: Vec<(f64, f64)> = fall
        .lines()
        .filter_map(|l| {
            let mut parts = l.split_whitespace().map(|v| v.parse::<f64>());
            Some((parts.next()?.ok()?, parts.next()?.ok()?))
        })
        .collect();
    let crossing = samples
        .windows(2)
        .find(|w| w[0].0 > -DROP_M && w[1].0 <= -DROP_M)
        .unwrap_or_else(|| panic!("LIGGGHTS' sphere did not fall {DROP_M} m: {fall}"));
    let ((z0, v0), (z1, v1)) = (crossing[0], crossing[1]);
    let liggghts = -(v0 + (v1 - v0) * (-DROP_M - z0) / (z1 - z0));

    eprintln!(
        "after {DROP_M} m in air: native {native:.4} m/s, LIGGGHTS {liggghts:.4}, equation of motion {expected:.4} (vacuum {vacuum:.4})"
    );
    for (solver, speed) in [("native", native), ("LIGGGHTS", liggghts)] {
        assert!(
            (speed - expected).abs() / expected < 0.01,
            "{solver}: {speed} m/s against {expected}"
        );
    }
    assert!((native - liggghts).abs() / liggghts < 0.01);
}
