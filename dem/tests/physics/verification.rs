//! The verification set `dem/verification/` (what `orch-dem verify` runs) passes, and
//! each file's reference is what theory gives for the file's own inputs, so a case
//! edited without its reference (or the reverse) fails here.

use std::path::{Path, PathBuf};

use orch_dem::case::Case;
use orch_dem::force::hertz_contact_time_s;
use orch_dem::material::PairConstants;
use orch_dem::verify::{self, Quantity};
use orch_dem::Simulation;

use crate::hertz_largest_overlap_m;
use crate::impact_reference::{self, Rebound, Sphere, Target};

fn folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("verification")
}

/// Every case file of the set, parsed and built with its meshes.
fn cases() -> Vec<(String, Case, Simulation)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(folder())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|file| {
            let name = file.file_stem().unwrap().to_string_lossy().into_owned();
            let case = Case::parse(&std::fs::read_to_string(&file).unwrap())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let walls = (0..case.meshes.len())
                .map(|k| {
                    let stl = std::fs::read(folder().join(&case.meshes[k].file)).unwrap();
                    case.wall_mesh(k, &stl).unwrap()
                })
                .collect();
            let simulation = case.build(walls).unwrap();
            (name, case, simulation)
        })
        .collect()
}

#[test]
fn every_verification_case_passes() {
    let all = cases();
    assert!(all.len() >= 9, "found only {} cases", all.len());
    for (name, case, mut simulation) in all {
        let table = case.verify.as_ref().expect("a [verify] table");
        let outcomes = verify::run(&mut simulation, table, case.run.end_time).unwrap();
        assert_eq!(outcomes.len(), table.check.len());
        for o in outcomes {
            assert!(
                o.passed(),
                "{name}: {} measured {:?}, reference {}, tolerance {} ({:?})",
                o.quantity.name(),
                o.measured,
                o.reference,
                o.tolerance,
                o.note
            );
        }
    }
}

/// Particle 1 is measured wherever the stepper keeps it: a second sphere falling
/// freely under the rolling one's floor sorts first in the Morton order, and would
/// give its acceleration (g sin θ, not 5/7 g sin θ) to a measure taken by index.
#[test]
fn particle_1_is_measured_by_id_not_by_its_place_in_memory() {
    let text = std::fs::read_to_string(folder().join("incline_rolling.toml")).unwrap();
    let with_a_second = text.replace(
        "\n[verify]",
        "\n[[particles]]\ntype = \"glass\"\nposition = [-0.019, -0.019, -0.009]\n\n[verify]",
    );
    assert_ne!(with_a_second, text);
    let case = Case::parse(&with_a_second).unwrap();
    let stl = std::fs::read(folder().join(&case.meshes[0].file)).unwrap();
    let mut simulation = case.build(vec![case.wall_mesh(0, &stl).unwrap()]).unwrap();
    assert_eq!(
        simulation.particles.index_of(1),
        Some(1),
        "particle 1 sorts second"
    );
    let table = case.verify.as_ref().unwrap();
    for o in verify::run(&mut simulation, table, case.run.end_time).unwrap() {
        assert!(
            o.passed(),
            "{} measured {:?}",
            o.quantity.name(),
            o.measured
        );
    }
}

#[test]
fn each_reference_follows_from_the_case_inputs() {
    for (name, case, simulation) in cases() {
        let table = case.verify.as_ref().unwrap();
        let kind = &simulation.types()[simulation.particles.kind[0] as usize];
        let wall = &simulation.config().wall_material;
        let g = simulation.config().gravity_m_per_s2;
        let two = simulation.particles.len() == 2;
        let pair = if two {
            PairConstants::between(&kind.material, &kind.material)
        } else {
            PairConstants::between(&kind.material, wall)
        };
        let v = &simulation.particles.velocity_m_per_s;
        let speed = if two {
            (v[0] - v[1]).norm()
        } else {
            v[0].norm()
        };
        let (vn, vt) = (-v[0].z, v[0].x);
        let e = kind.material.restitution.min(wall.restitution);
        // Hertz's effective mass and radius: half of each for two equal spheres; the
        // sphere's own against a wall.
        let (m_star, r_star) = if two {
            (kind.mass_kg() / 2.0, kind.radius_m / 2.0)
        } else {
            (kind.mass_kg(), kind.radius_m)
        };
        let e_star = pair.effective_youngs_pa;
        let hertz_overlap_m = || hertz_largest_overlap_m(m_star, r_star, e_star, speed);
        let mu = pair.friction;
        let tan_theta = g.x / -g.z;
        let signed = table.check.iter().any(|c| {
            matches!(
                c.quantity,
                Quantity::ReboundVelocity | Quantity::ReboundAngularVelocity
            )
        });
        let planar = signed.then(|| planar_rebound(&name, &case, &simulation));
        for check in &table.check {
            let expected = match check.quantity {
                Quantity::Restitution => e,
                Quantity::ContactDuration => hertz_contact_time_s(m_star, r_star, e_star, speed),
                Quantity::MaxOverlap => hertz_overlap_m(),
                Quantity::MaxNormalForce => {
                    4.0 / 3.0 * e_star * r_star.sqrt() * hertz_overlap_m().powf(1.5)
                }
                Quantity::TangentialSpeedLoss => {
                    assert!(
                        vt > 3.5 * mu * (1.0 + e) * vn,
                        "{name} must slide throughout"
                    );
                    mu * (1.0 + e) * vn
                }
                Quantity::ReboundSpin => 2.5 * mu * (1.0 + e) * vn / kind.radius_m,
                Quantity::ReboundVelocity => {
                    let d = check.direction.unwrap();
                    assert_eq!(d[1], 0.0, "{name}: the reference is planar (x–z)");
                    let v = planar.unwrap().velocity_m_per_s;
                    (v[0] * d[0] + v[1] * d[2]) / (d[0].hypot(d[2]))
                }
                Quantity::ReboundAngularVelocity => {
                    let axis = check.spin_axis.unwrap();
                    assert!(
                        axis[0] == 0.0 && axis[2] == 0.0,
                        "{name}: the reference spins about y"
                    );
                    planar.unwrap().spin_rad_per_s * axis[1].signum()
                }
                Quantity::Acceleration if tan_theta <= 3.5 * mu => 5.0 / 7.0 * g.x,
                Quantity::Acceleration => g.x + mu * g.z,
                Quantity::RollingRatio if tan_theta <= 3.5 * mu => 1.0,
                Quantity::RollingRatio => 2.5 * mu / (tan_theta - mu),
            };
            assert!(
                (check.reference - expected).abs() <= 1e-6 * expected.abs(),
                "{name}: {} reference {} but theory gives {expected}",
                check.quantity.name(),
                check.reference
            );
        }
    }
}

/// Particle 1's rebound from the planar reference (`impact_reference`), at a step ten
/// times finer than the case's, after checking that halving that step moves it little.
fn planar_rebound(name: &str, case: &Case, simulation: &Simulation) -> Rebound {
    let p = &simulation.particles;
    let sphere = |index: usize| {
        let kind = &simulation.types()[p.kind[index] as usize];
        let (x, v, w) = (
            p.position_m[index],
            p.velocity_m_per_s[index],
            p.angular_velocity[index],
        );
        assert!(
            x.y == 0.0 && v.y == 0.0 && w.x == 0.0 && w.z == 0.0,
            "{name}: the reference moves in x–z and spins about y"
        );
        let m = &kind.material;
        Sphere {
            radius_m: p.radius_m[index],
            mass_kg: p.mass_kg[index],
            position_m: [x.x, x.z],
            velocity_m_per_s: [v.x, v.z],
            spin_rad_per_s: w.y,
            material: impact_reference::Material {
                youngs_modulus_pa: m.youngs_modulus_pa,
                poisson_ratio: m.poisson_ratio,
                restitution: m.restitution,
                friction: m.friction,
            },
        }
    };
    let first = p.index_of(1).unwrap();
    let target = match p.len() {
        1 => {
            let w = &simulation.config().wall_material;
            Target::Floor(impact_reference::Material {
                youngs_modulus_pa: w.youngs_modulus_pa,
                poisson_ratio: w.poisson_ratio,
                restitution: w.restitution,
                friction: w.friction,
            })
        }
        2 => Target::Sphere(sphere(1 - first)),
        n => panic!("{name}: the planar reference takes one or two particles, not {n}"),
    };
    let step = simulation.config().timestep_s / 10.0;
    let [best, coarse, fine] =
        impact_reference::rebound(&sphere(first), &target, step, case.run.end_time);
    // The two integrations agree to well within the checks' tolerances.
    let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-3 * scale;
    let speed = coarse.velocity_m_per_s[0].hypot(coarse.velocity_m_per_s[1]);
    for k in 0..2 {
        assert!(
            close(coarse.velocity_m_per_s[k], fine.velocity_m_per_s[k], speed),
            "{name}: the reference has not converged: {coarse:?} against {fine:?}"
        );
    }
    assert!(
        close(
            coarse.spin_rad_per_s,
            fine.spin_rad_per_s,
            fine.spin_rad_per_s.abs().max(speed / p.radius_m[first])
        ),
        "{name}: the reference has not converged: {coarse:?} against {fine:?}"
    );
    best
}
