//! The settled bed of `orch-dem bench --case settled-bed`: bidisperse spheres on a
//! jittered lattice, at rest, fall into an open box and settle. One packing file
//! (a LAMMPS data file) is written once per size and read by every code; the decks map
//! the contact law term by term:
//!
//! - native and LIGGGHTS: `hertz` + `tangential history`, damping from the restitution
//!   (the native kernel implements LIGGGHTS's law);
//! - LAMMPS (`pair granular`, 29 Sep 2021): `hertz/material` gives the same elastic
//!   normal force (4/3 E* a δ, a = √(R* δ)); this build has no `coeff_restitution`
//!   damping, so `damping tsuji` (η = α(e') √(m* · 4/3 E* a)) gets the e' whose α
//!   equals LIGGGHTS's √5 |ln e| / √(ln² e + π²) ([`tsuji_restitution`]);
//!   `tangential mindlin` with k_t = 8 G* given explicitly (LIGGGHTS's 8 G* a) and a
//!   tangential damping √(4 G*/E*) times the normal one (LIGGGHTS's √(S_t/S_n));
//!   `fix wall/gran` computes a wall's modulus as E/(2(1−ν)), so it gets E/(1+ν) to
//!   give Hertz's E/(2(1−ν²)) of a wall of the particles' material.
//!
//! Walls: the box's floor and four sides (x, y ∈ [0, L], z ≥ 0), as planes in LIGGGHTS
//! and LAMMPS and as a ten-triangle STL mesh for the native kernel. No rolling friction.

use std::fmt::Write as _;
use std::io::BufRead;
use std::path::Path;

/// Gravity of every deck, m/s² (LIGGGHTS's and the native kernel's 9.81).
pub const GRAVITY_M_S2: f64 = 9.81;

/// The particles' material, SI.
#[derive(Debug, Clone, Copy)]
pub struct Material {
    /// Density, kg/m³.
    pub density_kg_m3: f64,
    /// Young's modulus of particles and walls, Pa.
    pub youngs_modulus_pa: f64,
    /// Poisson ratio.
    pub poisson_ratio: f64,
    /// Coefficient of restitution.
    pub restitution: f64,
    /// Sliding friction coefficient.
    pub friction: f64,
}

/// One settled-bed case: sizes, material and time stepping.
#[derive(Debug, Clone, Copy)]
pub struct Bed {
    /// Radius of the coarse spheres (type 1), m.
    pub coarse_radius_m: f64,
    /// Radius of the fine spheres (type 2), m; at most half the coarse radius.
    pub fine_radius_m: f64,
    /// Mass fraction of the fine spheres.
    pub fine_mass_fraction: f64,
    /// Material of particles and walls.
    pub material: Material,
    /// Time step, s.
    pub timestep_s: f64,
    /// Steps to run.
    pub steps: u64,
    /// Seed of the lattice's jitter and of which blocks hold coarse spheres.
    pub seed: u64,
}

impl Bed {
    /// Neighbour skin of every code, m: half the coarse radius (the hopper decks').
    pub fn skin_m(&self) -> f64 {
        0.5 * self.coarse_radius_m
    }

    /// Side of a lattice block, m: one coarse sphere or eight fine ones, 10 % apart.
    fn block_m(&self) -> f64 {
        2.2 * self.coarse_radius_m
    }
}

/// One sphere of a packing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// 1 coarse, 2 fine.
    pub kind: u8,
    /// Radius, m.
    pub radius_m: f64,
    /// Centre, m.
    pub position_m: [f64; 3],
}

/// The spheres and the box they fall into: x, y ∈ [0, `side_m`], z ∈ [0, `height_m`].
#[derive(Debug, Clone)]
pub struct Packing {
    /// Spheres in id order (id = index + 1).
    pub spheres: Vec<Sphere>,
    /// Side of the square floor, m.
    pub side_m: f64,
    /// Height of the box (and of every code's domain), m.
    pub height_m: f64,
}

/// SplitMix64: a small, fixed generator, so the packing does not depend on a crate's
/// version.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` spheres on a lattice of cubic blocks, each block holding one coarse sphere or
/// eight fine ones (blocks chosen at random so that the mass fractions come out as
/// asked on average), every centre jittered by up to a quarter of its gap to its
/// neighbours; blocks fill a square floor of about twice the column's height, layer by
/// layer from half a block above the floor. Deterministic in `bed.seed`.
pub fn packing(n: usize, bed: &Bed) -> anyhow::Result<Packing> {
    let (rc, rf) = (bed.coarse_radius_m, bed.fine_radius_m);
    if !(rf > 0.0 && rf <= 0.5 * rc) {
        anyhow::bail!("the settled bed needs a fine radius of at most half the coarse radius (coarse {rc} m, fine {rf} m)");
    }
    let block = bed.block_m();
    let mass = |r: f64| r.powi(3);
    // Probability that a block is coarse, for the mass fractions asked.
    let coarse_blocks = (1.0 - bed.fine_mass_fraction) / mass(rc);
    let fine_blocks = bed.fine_mass_fraction / (8.0 * mass(rf));
    let p_coarse = coarse_blocks / (coarse_blocks + fine_blocks);
    let per_block = p_coarse + 8.0 * (1.0 - p_coarse);
    let blocks = (n as f64 / per_block).ceil();
    let across = ((2.0 * blocks).cbrt().ceil() as usize).max(1);
    let mut rng = SplitMix64(bed.seed);
    let mut spheres = Vec::with_capacity(n);
    let jittered = |rng: &mut SplitMix64, centre: [f64; 3], radius: f64, cell: f64| {
        let reach = 0.25 * (cell - 2.0 * radius);
        centre.map(|c| c + reach * (2.0 * rng.unit() - 1.0))
    };
    let mut index = 0usize;
    while spheres.len() < n {
        let (x, y, z) = (
            index % across,
            (index / across) % across,
            index / (across * across),
        );
        index += 1;
        let origin = [x as f64 * block, y as f64 * block, (z as f64 + 0.5) * block];
        if rng.unit() < p_coarse {
            let centre = origin.map(|o| o + 0.5 * block);
            let position_m = jittered(&mut rng, centre, rc, block);
            spheres.push(Sphere {
                kind: 1,
                radius_m: rc,
                position_m,
            });
        } else {
            for sub in 0..8usize {
                if spheres.len() == n {
                    break;
                }
                let offset =
                    [sub & 1, (sub >> 1) & 1, sub >> 2].map(|k| (k as f64 + 0.5) * 0.5 * block);
                let centre = [0, 1, 2].map(|k| origin[k] + offset[k]);
                let position_m = jittered(&mut rng, centre, rf, 0.5 * block);
                spheres.push(Sphere {
                    kind: 2,
                    radius_m: rf,
                    position_m,
                });
            }
        }
    }
    let layers = index.div_ceil(across * across);
    Ok(Packing {
        spheres,
        side_m: across as f64 * block,
        height_m: (layers as f64 + 2.0) * block,
    })
}

/// The packing as a LAMMPS data file (`Atoms # sphere`: id type diameter density x y
/// z), which LAMMPS, LIGGGHTS (`atom_style granular`) and the native kernel's
/// `[packing]` read.
pub fn data_file(packing: &Packing, density_kg_m3: f64) -> String {
    let mut text = String::with_capacity(64 * packing.spheres.len() + 256);
    let (side, height) = (packing.side_m, packing.height_m);
    let _ = write!(
        text,
        "LAMMPS data file: orch-dem bench settled bed, {} spheres\n\n{} atoms\n2 atom types\n0 {side} xlo xhi\n0 {side} ylo yhi\n0 {height} zlo zhi\n\nAtoms # sphere\n\n",
        packing.spheres.len(),
        packing.spheres.len()
    );
    for (k, s) in packing.spheres.iter().enumerate() {
        let [x, y, z] = s.position_m;
        let _ = writeln!(
            text,
            "{} {} {} {density_kg_m3} {x} {y} {z}",
            k + 1,
            s.kind,
            2.0 * s.radius_m
        );
    }
    text
}

/// The open box as an ASCII STL: floor and four sides, two triangles each, normals
/// pointing inwards.
pub fn box_stl(packing: &Packing) -> String {
    let (l, h) = (packing.side_m, packing.height_m);
    let quads: [[[f64; 3]; 4]; 5] = [
        [[0.0, 0.0, 0.0], [l, 0.0, 0.0], [l, l, 0.0], [0.0, l, 0.0]],
        [[0.0, 0.0, 0.0], [0.0, 0.0, h], [l, 0.0, h], [l, 0.0, 0.0]],
        [[0.0, l, 0.0], [l, l, 0.0], [l, l, h], [0.0, l, h]],
        [[0.0, 0.0, 0.0], [0.0, l, 0.0], [0.0, l, h], [0.0, 0.0, h]],
        [[l, 0.0, 0.0], [l, 0.0, h], [l, l, h], [l, l, 0.0]],
    ];
    let mut text = String::from("solid box\n");
    for [a, b, c, d] in quads {
        for [p, q, r] in [[a, b, c], [a, c, d]] {
            text.push_str("  facet normal 0 0 0\n    outer loop\n");
            for v in [p, q, r] {
                let _ = writeln!(text, "      vertex {} {} {}", v[0], v[1], v[2]);
            }
            text.push_str("    endloop\n  endfacet\n");
        }
    }
    text.push_str("endsolid box\n");
    text
}

/// The native kernel's case (TOML): the packing file, the box mesh, a dump at the end.
pub fn native_case(bed: &Bed, packing: &Packing) -> String {
    let m = &bed.material;
    let material = format!(
        "youngs_modulus = {}\npoisson_ratio = {}\nrestitution = {}\nfriction = {}\n",
        m.youngs_modulus_pa, m.poisson_ratio, m.restitution, m.friction
    );
    let margin = bed.block_m();
    format!(
        "# orch-dem bench: settled bed of {n} spheres (written by orch-dem bench).\n\n[run]\ntimestep = {dt}\nend_time = {end}\nseed = {seed}\nthermo_every = 1000\nskin = {skin}\ngravity = [0.0, 0.0, -{GRAVITY_M_S2}]\n\n[domain]\nmin = [-{margin}, -{margin}, -{margin}]\nmax = [{lm}, {lm}, {h}]\n\n[[types]]\nname = \"coarse\"\nradius = {rc}\ndensity = {rho}\n{material}\n[[types]]\nname = \"fine\"\nradius = {rf}\ndensity = {rho}\n{material}\n[wall_material]\n{material}\n[[meshes]]\nname = \"box\"\nfile = \"box.stl\"\n\n[packing]\nfile = \"packing.data\"\n\n[output]\ndump_every = {steps}\n",
        n = packing.spheres.len(),
        dt = bed.timestep_s,
        end = bed.steps as f64 * bed.timestep_s,
        seed = bed.seed,
        skin = bed.skin_m(),
        lm = packing.side_m + margin,
        h = packing.height_m,
        rc = bed.coarse_radius_m,
        rf = bed.fine_radius_m,
        rho = m.density_kg_m3,
        steps = bed.steps,
    )
}

/// LIGGGHTS's deck on `ranks` MPI ranks (the floor split along x when 2 or more).
pub fn liggghts_deck(bed: &Bed, packing: &Packing, ranks: usize) -> String {
    let m = &bed.material;
    let (e, nu, cor, mu) = (
        m.youngs_modulus_pa,
        m.poisson_ratio,
        m.restitution,
        m.friction,
    );
    let wall =
        "fix {id} all wall/gran model hertz tangential history primitive type 1 {plane} {at}";
    let mut walls = String::new();
    for (id, plane, at) in [
        ("xlo", "xplane", 0.0),
        ("xhi", "xplane", packing.side_m),
        ("ylo", "yplane", 0.0),
        ("yhi", "yplane", packing.side_m),
        ("zlo", "zplane", 0.0),
    ] {
        let line = wall
            .replace("{id}", id)
            .replace("{plane}", plane)
            .replace("{at}", &at.to_string());
        walls.push_str(&line);
        walls.push('\n');
    }
    format!(
        "# orch-dem bench: settled bed of {n} spheres on LIGGGHTS (written by orch-dem bench).
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
units           si
processors      {ranks} 1 1
read_data       packing.data
neighbor        {skin} bin
neigh_modify    delay 0

fix m1 all property/global youngsModulus peratomtype {e} {e}
fix m2 all property/global poissonsRatio peratomtype {nu} {nu}
fix m3 all property/global coefficientRestitution peratomtypepair 2 {cor} {cor} {cor} {cor}
fix m4 all property/global coefficientFriction peratomtypepair 2 {mu} {mu} {mu} {mu}
pair_style gran model hertz tangential history
pair_coeff * *
timestep {dt}
fix gravity all gravity {GRAVITY_M_S2} vector 0.0 0.0 -1.0
{walls}fix integrate all nve/sphere
dump final all custom {steps} post/dump*.liggghts id type radius x y z
thermo_style custom step atoms ke cpu
thermo 1000
thermo_modify lost ignore norm no
run {steps}
",
        n = packing.spheres.len(),
        skin = bed.skin_m(),
        dt = bed.timestep_s,
        steps = bed.steps,
    )
}

/// LAMMPS's deck (`pair granular`, mapped as the module docs say); LAMMPS picks its
/// own processor grid.
pub fn lammps_deck(bed: &Bed, packing: &Packing) -> String {
    let m = &bed.material;
    let nu = m.poisson_ratio;
    let e = m.youngs_modulus_pa;
    let e_star = e / (2.0 * (1.0 - nu * nu));
    let g_star = e / (4.0 * (2.0 - nu) * (1.0 + nu));
    let tangential = format!(
        "tangential mindlin {} {} {}",
        8.0 * g_star,
        (4.0 * g_star / e_star).sqrt(),
        m.friction
    );
    let cor = tsuji_restitution(m.restitution);
    let pair = format!("hertz/material {e} {cor} {nu} damping tsuji {tangential}");
    let wall = format!(
        "granular hertz/material {} {cor} {nu} damping tsuji {tangential}",
        e / (1.0 + nu)
    );
    let side = packing.side_m;
    format!(
        "# orch-dem bench: settled bed of {n} spheres on LAMMPS (written by orch-dem bench).
# Restitution {restitution} mapped to Tsuji's {cor}; wall modulus E/(1+nu) (see bench/settled_bed.rs).
units           si
atom_style      sphere
atom_modify     map array
boundary        f f f
newton          off
comm_modify     vel yes
read_data       packing.data
neighbor        {skin} bin
neigh_modify    delay 0

pair_style granular
pair_coeff * * {pair}
timestep {dt}
fix gravity all gravity {GRAVITY_M_S2} vector 0.0 0.0 -1.0
fix xwalls all wall/gran {wall} xplane 0.0 {side}
fix ywalls all wall/gran {wall} yplane 0.0 {side}
fix floor all wall/gran {wall} zplane 0.0 NULL
fix integrate all nve/sphere
dump final all custom {steps} post/dump*.lammps id type radius x y z
thermo_style custom step atoms ke cpu
thermo 1000
thermo_modify lost ignore norm no
run {steps}
",
        n = packing.spheres.len(),
        restitution = m.restitution,
        skin = bed.skin_m(),
        dt = bed.timestep_s,
        steps = bed.steps,
    )
}

/// Tsuji's α(e) as LAMMPS evaluates it for `damping tsuji`.
fn tsuji_alpha(e: f64) -> f64 {
    1.2728 - 4.2783 * e + 11.087 * e.powi(2) - 22.348 * e.powi(3) + 27.467 * e.powi(4)
        - 18.022 * e.powi(5)
        + 4.8218 * e.powi(6)
}

/// The restitution to give LAMMPS's `damping tsuji` so that its damping equals
/// LIGGGHTS's `hertz` damping for restitution `e`: α(e') = √5 |ln e| / √(ln² e + π²),
/// solved by bisection (α falls monotonically over (0, 1]).
pub fn tsuji_restitution(e: f64) -> f64 {
    let ln = e.ln();
    let target = 5f64.sqrt() * ln.abs() / (ln * ln + std::f64::consts::PI.powi(2)).sqrt();
    let (mut low, mut high) = (1e-6, 1.0);
    for _ in 0..100 {
        let mid = 0.5 * (low + high);
        if tsuji_alpha(mid) > target {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

/// Mean height of the particles' centres in the last snapshot of a `dump custom` file
/// with a `z` column, m, and the number of particles in it.
pub fn mean_height(path: &Path) -> anyhow::Result<(f64, usize)> {
    let file = std::fs::File::open(path)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))?;
    mean_height_of(std::io::BufReader::new(file), path)
}

fn mean_height_of(reader: impl BufRead, path: &Path) -> anyhow::Result<(f64, usize)> {
    let mut last = (f64::NAN, 0);
    orch_adapters::dump::read_dump(reader, path, |snapshot| {
        let z = snapshot
            .column("z")
            .ok_or_else(|| "no z column".to_string())?;
        let n = snapshot.len();
        let columns = snapshot.columns.len();
        let sum: f64 = (0..n).map(|row| snapshot.values[row * columns + z]).sum();
        last = (sum / n.max(1) as f64, n);
        Ok(())
    })?;
    Ok(last)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bed() -> Bed {
        Bed {
            coarse_radius_m: 0.002,
            fine_radius_m: 0.001,
            fine_mass_fraction: 0.5,
            material: Material {
                density_kg_m3: 2500.0,
                youngs_modulus_pa: 5e6,
                poisson_ratio: 0.3,
                restitution: 0.6,
                friction: 0.5,
            },
            timestep_s: 2e-5,
            steps: 1000,
            seed: 1,
        }
    }

    #[test]
    fn the_packing_has_n_spheres_without_overlaps_inside_the_box() {
        let packing = packing(3000, &bed()).unwrap();
        assert_eq!(packing.spheres.len(), 3000);
        let coarse = packing.spheres.iter().filter(|s| s.kind == 1).count();
        // Half the mass each: about one coarse sphere per eight fine ones.
        let ratio = (3000 - coarse) as f64 / coarse as f64;
        assert!((6.5..9.5).contains(&ratio), "{ratio}");
        for s in &packing.spheres {
            let [x, y, z] = s.position_m;
            assert!(x > s.radius_m && x < packing.side_m - s.radius_m);
            assert!(y > s.radius_m && y < packing.side_m - s.radius_m);
            assert!(z > s.radius_m && z < packing.height_m - s.radius_m);
        }
        // Neighbours are in the same or an adjacent block: a brute force over a
        // few hundred spheres is enough to find any overlap.
        for (i, a) in packing.spheres.iter().enumerate().take(400) {
            for b in &packing.spheres[i + 1..] {
                let d2: f64 = (0..3usize)
                    .map(|k| (a.position_m[k] - b.position_m[k]).powi(2))
                    .sum();
                assert!(d2.sqrt() > a.radius_m + b.radius_m, "{a:?} {b:?}");
            }
        }
        // Deterministic in the seed.
        assert_eq!(
            super::packing(3000, &bed()).unwrap().spheres,
            packing.spheres
        );
    }

    #[test]
    fn the_data_file_reads_back_through_the_native_kernels_parser() {
        let packing = packing(100, &bed()).unwrap();
        let text = data_file(&packing, 2500.0);
        let read = orch_dem::packing::parse_lammps_data(&text).unwrap();
        assert_eq!(read.len(), 100);
        for (k, (s, r)) in packing.spheres.iter().zip(&read).enumerate() {
            assert_eq!(r.id as usize, k + 1);
            assert_eq!(r.kind, u32::from(s.kind));
            assert_eq!(r.radius_m, s.radius_m);
            assert_eq!(r.position_m, orch_dem::Vec3::from(s.position_m));
        }
    }

    #[test]
    fn the_native_case_parses_and_names_the_packing_and_box() {
        let bed = bed();
        let packing = packing(100, &bed).unwrap();
        let case = orch_dem::case::Case::parse(&native_case(&bed, &packing)).unwrap();
        assert_eq!(case.packing_file(), Some("packing.data"));
        assert_eq!(case.timestep_s(), 2e-5);
        let wall = case.wall_mesh(0, box_stl(&packing).as_bytes()).unwrap();
        assert_eq!(wall.triangle_count(), 10);
        let simulation = case
            .build_from(vec![wall], None, Some(&data_file(&packing, 2500.0)))
            .unwrap();
        assert_eq!(simulation.particles.len(), 100);
    }

    #[test]
    fn tsuji_restitution_reproduces_liggghts_damping() {
        for e in [0.3, 0.6, 0.9] {
            let mapped = tsuji_restitution(e);
            let ln = f64::ln(e);
            let beta = ln.abs() / (ln * ln + std::f64::consts::PI.powi(2)).sqrt();
            assert!((tsuji_alpha(mapped) - 5f64.sqrt() * beta).abs() < 1e-12);
            // Tsuji's damping per unit restitution is weaker, so e' < e.
            assert!(mapped < e, "{e} -> {mapped}");
        }
    }

    #[test]
    fn decks_carry_the_mapped_contact_law() {
        let bed = bed();
        let packing = packing(100, &bed).unwrap();
        let lammps = lammps_deck(&bed, &packing);
        let cor = tsuji_restitution(0.6);
        // E* = 5e6 / (2 (1 - 0.09)), G* = 5e6 / (4 · 1.7 · 1.3).
        let g_star: f64 = 5e6 / (4.0 * 1.7 * 1.3);
        let x_gamma = (4.0 * g_star / (5e6 / 1.82)).sqrt();
        let pair = format!(
            "pair_coeff * * hertz/material 5000000 {cor} 0.3 damping tsuji tangential mindlin {} {x_gamma} 0.5",
            8.0 * g_star
        );
        assert!(lammps.contains(&pair), "{lammps}");
        assert!(lammps.contains(&format!(
            "wall/gran granular hertz/material {} {cor}",
            5e6 / 1.3
        )));
        assert!(lammps.contains("zplane 0.0 NULL"));
        let liggghts = liggghts_deck(&bed, &packing, 2);
        assert!(liggghts.contains("processors      2 1 1"));
        assert!(liggghts.contains("coefficientRestitution peratomtypepair 2 0.6 0.6 0.6 0.6"));
        assert_eq!(liggghts.matches("primitive type 1").count(), 5);
        assert!(liggghts.contains("run 1000"));
    }

    #[test]
    fn the_mean_height_comes_from_the_last_snapshot() {
        let dump = "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS ff ff ff\n0 1\n0 1\n0 1\nITEM: ATOMS id type radius x y z\n1 1 0.002 0 0 0.5\n2 2 0.001 0 0 0.7\nITEM: TIMESTEP\n10\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS ff ff ff\n0 1\n0 1\n0 1\nITEM: ATOMS id type radius x y z\n1 1 0.002 0 0 0.1\n2 2 0.001 0 0 0.3\n";
        let (z, n) = mean_height_of(dump.as_bytes(), Path::new("dump")).unwrap();
        assert_eq!(n, 2);
        assert!((z - 0.2).abs() < 1e-15);
    }
}
