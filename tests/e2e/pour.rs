//! Filling by pouring (issue 15): the same 3000-particle bidisperse mixture poured
//! through a central inlet on the native kernel and on LIGGGHTS, against the same
//! mixture placed at random, each bed dumped at the end of filling.
//!
//! What is asserted is what was found to hold: every particle is poured, the bed has
//! settled, the fines have sunk below the coarse particles, and the two codes agree on
//! the bed's radial profile. What was expected and not found is printed, not asserted:
//! at this scale a poured bed does not gather its fines at the axis (fines' mean radial
//! distance over the coarse particles' is ~1.06 poured against ~1.04 at random on both
//! codes; docs/thesis-replication.md).

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use orch_adapters::dump::read_dump;
use orch_granular::bed::BedRadialProfile;
use orch_granular::Sighting;

use crate::support::{require_liggghts, solver_lock, text, Project};

const FILL_STEPS: u64 = 50_000;

fn study(solver: &str) -> String {
    format!(
        r#"
name: pour-{solver}
solver: {solver}
executor: {{max_parallel: 2}}
factors:
  - {{name: pour_rate, min: 0.0, max: 0.1, unit: kg/s}}
fixed:
  n_particles: 3000
  pour_diameter: 0.02
  pour_speed: 1.0
  fill_time: 1.0
  discharge_time: 0.01
  dump_every: {FILL_STEPS}
design: {{type: full_factorial, levels: 2}}
seed: 5
responses: [discharged_count]
"#
    )
}

/// The bed at the end of filling.
fn settled_bed(run_dir: &Path) -> Vec<Sighting> {
    let path = run_dir.join(format!("post/dump{FILL_STEPS}.liggghts"));
    let file = File::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut bed = Vec::new();
    read_dump(BufReader::new(file), &path, |snapshot| {
        bed = snapshot
            .sightings()
            .map_err(|missing| format!("{missing:?}"))?;
        Ok(())
    })
    .unwrap();
    bed
}

/// Mean height of the particles smaller (`fine`) or not than the midpoint radius, m.
fn mean_height(bed: &[Sighting], fine: bool) -> f64 {
    let cut = 0.5 * (0.001 + 0.002);
    let heights: Vec<f64> = bed
        .iter()
        .filter(|p| (p.radius_m < cut) == fine)
        .map(|p| p.position_m[2])
        .collect();
    heights.iter().sum::<f64>() / heights.len() as f64
}

/// Runs the study on `solver`; returns (random bed, poured bed).
fn beds(solver: &str) -> (Vec<Sighting>, Vec<Sighting>) {
    let project = Project::new();
    let file = project.write("pour.yaml", &study(solver));
    let output = project.run(&["submit", file.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let status = project.status(&format!("pour-{solver}"));
    let mut beds = Vec::new();
    for job in status["jobs"].as_array().unwrap() {
        let rate = job["factors"]["pour_rate"].as_f64().unwrap();
        // Both solvers say what the pour had placed when the fill ended: all of it,
        // here (LIGGGHTS inserts a count of particles, so its mass is the asked one
        // only up to the random draw of types); a bed filled at random has no inflow
        // and no such figure.
        let placed = job["responses"]["solver_inflow_placed_fraction"].as_f64();
        if rate > 0.0 {
            let placed = placed.unwrap_or_else(|| panic!("no inflow figure in {job:#}"));
            let within = if solver == "native" { 0.001 } else { 0.02 };
            assert!((placed - 1.0).abs() < within, "{solver}: {placed}");
            let note = job["error"].as_str().unwrap_or_default();
            assert!(!note.contains("inflow placed"), "{note}");
        } else {
            assert_eq!(placed, None, "{job:#}");
        }
        beds.push((
            rate,
            settled_bed(Path::new(job["run_dir"].as_str().unwrap())),
        ));
    }
    beds.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(beds.len(), 2);
    let poured = beds.pop().unwrap().1;
    let random = beds.pop().unwrap().1;
    (random, poured)
}

fn check(solver: &str, random: &[Sighting], poured: &[Sighting]) -> BedRadialProfile {
    // insert/rate/region and the native inflow both stop within one particle's mass.
    assert!(
        (2995..=3005).contains(&poured.len()),
        "{solver}: {} particles poured of 3000",
        poured.len()
    );
    let fastest = poured
        .iter()
        .map(|p| p.velocity_m_per_s.iter().map(|v| v * v).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    assert!(
        fastest < 0.05,
        "{solver}: the bed is still moving at {fastest} m/s"
    );
    let (fine_z, coarse_z) = (mean_height(poured, true), mean_height(poured, false));
    assert!(
        fine_z < coarse_z - 2e-4,
        "{solver}: poured fines at {fine_z} m, coarse at {coarse_z} m"
    );
    let poured_profile = BedRadialProfile::of(poured).unwrap();
    let random_profile = BedRadialProfile::of(random).unwrap();
    eprintln!(
        "{solver}: radial ratio fines/coarse poured {:.4}, random {:.4}; mean height fines {:.4} m, coarse {:.4} m",
        poured_profile.ratio(),
        random_profile.ratio(),
        fine_z,
        coarse_z
    );
    poured_profile
}

#[test]
fn a_poured_bed_settles_fines_low_and_native_and_liggghts_agree_on_its_radial_profile() {
    if !require_liggghts() {
        return;
    }
    let _lock = solver_lock();
    let (random, poured) = beds("native");
    let native = check("native", &random, &poured);
    let (random, poured) = beds("liggghts");
    let liggghts = check("liggghts", &random, &poured);
    let gap = (native.ratio() / liggghts.ratio() - 1.0).abs();
    assert!(
        gap < 0.03,
        "radial ratio native {} vs LIGGGHTS {}",
        native.ratio(),
        liggghts.ratio()
    );
}
