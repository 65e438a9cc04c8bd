//! LIGGGHTS on the verification set's oblique impacts: where an impact sticks for part
//! of the contact, the kernel's references come from its contact law integrated on its
//! own (`dem/tests/physics/impact_reference.rs`). LIGGGHTS implements the same law
//! (`hertz` + `tangential history`), so the same spheres thrown at its `zplane` wall
//! or at each other must rebound with the same velocity and spin: a check of the law's
//! transcription by another code, not of the law against Maw, Barber & Fawcett.

use std::path::PathBuf;

use orch_dem::case::{Case, TypeRef};
use orch_dem::verify::Quantity;

use crate::support::{require_liggghts, root, run_in, solver_lock};

/// Sticking and sliding cases of each test: against a wall, an equal sphere and a
/// larger one.
const CASES: [&str; 10] = [
    "chung_ooi_4_05deg",
    "chung_ooi_4_15deg",
    "chung_ooi_4_25deg",
    "chung_ooi_5_steel_vt0_5",
    "chung_ooi_5_polyethylene_vt3_0",
    "chung_ooi_6_aluminium_alloy_w2_0",
    "chung_ooi_7_w0_5",
    "chung_ooi_7_w10_0",
    "chung_ooi_8_w0_5",
    "chung_ooi_8_w10_0",
];

/// A LIGGGHTS deck of `case`: its spheres (one material, LIGGGHTS type 1) and, if it
/// has a mesh, the plane z = 0 as a `zplane` wall of the wall material (type 2);
/// prints particle 1's velocity along x and spin about y once the impact is over.
fn deck(case: &Case) -> String {
    let m = &case.types[0].material;
    let wall = &case.wall_material;
    assert!(
        case.types.iter().all(|t| {
            let t = &t.material;
            (t.youngs_modulus, t.poisson_ratio, t.restitution, t.friction)
                == (m.youngs_modulus, m.poisson_ratio, m.restitution, m.friction)
        }),
        "one material for every sphere"
    );
    let timestep = case
        .run
        .timestep
        .expect("a verification case sets its step");
    let steps = (case.run.end_time / timestep).round() as u64;
    let [lo, hi] = [case.domain.min, case.domain.max];
    let mut spheres = String::new();
    for (k, p) in case.particles.iter().enumerate() {
        let kind = match &p.kind {
            TypeRef::Name(name) => case.types.iter().find(|t| &t.name == name).unwrap(),
            TypeRef::Number(n) => &case.types[*n as usize - 1],
        };
        let ([x, y, z], [vx, vy, vz], [wx, wy, wz]) = (p.position, p.velocity, p.angular_velocity);
        let id = k + 1;
        spheres += &format!(
            "create_atoms 1 single {x} {y} {z} units box\n\
             set atom {id} diameter {d} density {rho} vx {vx} vy {vy} vz {vz} omegax {wx} omegay {wy} omegaz {wz}\n",
            d = 2.0 * kind.radius,
            rho = kind.density,
        );
    }
    let wall_fix = if case.meshes.is_empty() {
        String::new()
    } else {
        "fix wall all wall/gran model hertz tangential history primitive type 2 zplane 0.0\n".into()
    };
    let skin = 0.1 * case.types.iter().map(|t| t.radius).fold(0.0, f64::max);
    format!(
        "atom_style granular\n\
         atom_modify map array\n\
         boundary f f f\n\
         newton off\n\
         communicate single vel yes\n\
         units si\n\
         hard_particles yes\n\
         region box block {} {} {} {} {} {} units box\n\
         create_box 2 box\n\
         neighbor {skin} bin\n\
         neigh_modify delay 0\n\
         fix m1 all property/global youngsModulus peratomtype {e1:e} {e2:e}\n\
         fix m2 all property/global poissonsRatio peratomtype {n1} {n2}\n\
         fix m3 all property/global coefficientRestitution peratomtypepair 2 {r1} {r12} {r12} {r2}\n\
         fix m4 all property/global coefficientFriction peratomtypepair 2 {f1} {f12} {f12} {f2}\n\
         pair_style gran model hertz tangential history\n\
         pair_coeff * *\n\
         timestep {timestep:e}\n\
         {wall_fix}\
         {spheres}\
         fix integrate all nve/sphere\n\
         variable vx1 equal vx[1]\n\
         variable wy1 equal omegay[1]\n\
         run {steps}\n\
         print \"REBOUND ${{vx1}} ${{wy1}}\"\n",
        lo[0],
        hi[0],
        lo[1],
        hi[1],
        lo[2],
        hi[2],
        e1 = m.youngs_modulus,
        e2 = wall.youngs_modulus,
        n1 = m.poisson_ratio,
        n2 = wall.poisson_ratio,
        r1 = m.restitution,
        r2 = wall.restitution,
        r12 = m.restitution.min(wall.restitution),
        f1 = m.friction,
        f2 = wall.friction,
        f12 = m.friction.min(wall.friction),
    )
}

#[test]
fn liggghts_rebounds_from_oblique_impacts_as_the_verification_references_say() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let scratch = tempfile::tempdir().unwrap();
    for name in CASES {
        let file: PathBuf = root().join(format!("dem/verification/{name}.toml"));
        let case = Case::parse(&std::fs::read_to_string(&file).unwrap()).unwrap();
        let input = scratch.path().join(format!("in.{name}"));
        std::fs::write(&input, deck(&case)).unwrap();
        let input = input.to_str().unwrap();
        let stdout = run_in(
            scratch.path(),
            "liggghts",
            &["-in", input, "-log", "none", "-echo", "none"],
        );
        let line = stdout
            .lines()
            .find_map(|l| l.strip_prefix("REBOUND "))
            .unwrap_or_else(|| panic!("{name}: no REBOUND line\n{stdout}"));
        let values: Vec<f64> = line
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        let table = case.verify.as_ref().unwrap();
        for check in &table.check {
            let measured = match check.quantity {
                Quantity::ReboundVelocity => values[0],
                Quantity::ReboundAngularVelocity => values[1],
                _ => continue,
            };
            let error = (measured - check.reference).abs() / check.reference.abs();
            eprintln!(
                "{name}: {} LIGGGHTS {measured:.6e}, reference {:.6e}, relative error {error:.2e}",
                check.quantity.name(),
                check.reference
            );
            assert!(
                error <= 0.01,
                "{name}: LIGGGHTS gives {} = {measured}, the reference {}",
                check.quantity.name(),
                check.reference
            );
        }
    }
}
