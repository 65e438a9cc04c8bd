//! The plan: a round's design points turned into jobs, as data — names, seeds, kinds and
//! the chain each job waits on — before anything is written. The store inserts what the
//! plan says and decides nothing; this module reads no file, clock or database.
//!
//! **Seeds.** A job's solver seed is a keyed hash (SHA-256) of the study's `seed:`, the
//! point's purpose, its resolved case (every parameter, rounded to 12 significant
//! digits, and every text value), the point's occurrence among equal cases of its
//! design, the replicate and the job's random stream. Nothing in it wraps or
//! overflows, so two jobs share a seed only when they are the same run:
//!
//! - the same case at the same occurrence and replicate, in any round or study with the
//!   same study seed, gets the same seed, renders the same deck and is reused (one
//!   observation) instead of run again;
//! - replicates and repeated points inside one design (a central composite design's
//!   centre runs) get distinct seeds and are true replicates.
//!
//! The seed is 63 bits wide, so that it fits SQLite's and TOML's signed integers.

use sha2::{Digest, Sha256};

use orch_adapters::Stage;

use crate::{Coupling, DesignPoint, Study};

/// `jobs.stage` of a design job: the simulation of a design point itself.
pub const DESIGN_STAGE: &str = "dem";

/// What a job runs: the design point's simulation, or a stage after another job. It is
/// `jobs.stage` decoded, as states are: a kind this orch does not know is the
/// store's `UnknownState` error naming the row, never taken for a design job.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JobKind {
    /// The design point's own simulation ([`DESIGN_STAGE`] in the store).
    Design,
    /// A stage of this kind ([`orch_adapters::STAGES`], or a user's `script`).
    Stage(&'static str),
}

impl JobKind {
    /// The text `jobs.stage` holds.
    pub fn as_str(self) -> &'static str {
        match self {
            JobKind::Design => DESIGN_STAGE,
            JobKind::Stage(kind) => kind,
        }
    }

    /// The stage kind, `None` for a design job.
    pub fn stage(self) -> Option<&'static str> {
        match self {
            JobKind::Design => None,
            JobKind::Stage(kind) => Some(kind),
        }
    }

    /// The kind `text` names, or `None` when this orch knows no such kind.
    pub fn parse(text: &str) -> Option<JobKind> {
        if text == DESIGN_STAGE {
            return Some(JobKind::Design);
        }
        orch_adapters::STAGES
            .iter()
            .map(|stage| stage.kind())
            .chain([orch_adapters::script_stage::KIND])
            .find(|kind| *kind == text)
            .map(JobKind::Stage)
    }
}

/// What a point is for: fitted, or held out to test the fit (`points.purpose`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PointRole {
    /// A design point: its runs are fitted.
    Design,
    /// A held-out test point: its runs measure the fit's error.
    Test,
}

impl PointRole {
    /// The text `points.purpose` holds.
    pub fn as_str(self) -> &'static str {
        match self {
            PointRole::Design => "design",
            PointRole::Test => "test",
        }
    }
}

impl std::str::FromStr for PointRole {
    type Err = ();

    fn from_str(text: &str) -> Result<Self, ()> {
        match text {
            "design" => Ok(PointRole::Design),
            "test" => Ok(PointRole::Test),
            _ => Err(()),
        }
    }
}

/// Whether points are fitted or held out to test the fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointPurpose {
    /// Design points, fitted; jobs `p<i>r<replicate>`.
    Design,
    /// Test points, held out; jobs `t<i>r<replicate>`, numbered in the round after the
    /// design points from `first_idx`.
    Test {
        /// Index of the first test point within the round.
        first_idx: usize,
    },
}

impl PointPurpose {
    /// What its points are for, as the store keeps it.
    pub fn role(self) -> PointRole {
        match self {
            PointPurpose::Design => PointRole::Design,
            PointPurpose::Test { .. } => PointRole::Test,
        }
    }

    /// `points.purpose` in the store.
    pub fn as_str(self) -> &'static str {
        self.role().as_str()
    }

    /// The letter that starts its jobs' names.
    fn letter(self) -> char {
        match self {
            PointPurpose::Design => 'p',
            PointPurpose::Test { .. } => 't',
        }
    }

    /// Index of its first point within the round.
    fn first_idx(self) -> usize {
        match self {
            PointPurpose::Design => 0,
            PointPurpose::Test { first_idx } => first_idx,
        }
    }
}

/// One design point of a round with the jobs it runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedPoint<'a> {
    /// Index within the round.
    pub idx: usize,
    /// Fitted or held out.
    pub purpose: PointPurpose,
    /// Its coordinates.
    pub point: &'a DesignPoint,
    /// Its jobs: per replicate the design job, then its stages and coupling chain.
    pub jobs: Vec<PlannedJob>,
}

/// One job of a planned point.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlannedJob {
    /// Name within the study (`p000r0`, `r1-p003r2`, `p000r0-cfd`, and
    /// `p007r0-fine` for point p007's run at the fidelity level `fine`).
    pub name: String,
    /// Replicate number of its design job.
    pub replicate: u32,
    /// The solver seed (63 bits).
    pub seed: u64,
    /// A design job, or a stage's of this kind.
    pub kind: JobKind,
    /// The job of the same point it waits for, as an index into [`PlannedPoint::jobs`].
    pub after: Option<usize>,
}

/// The jobs of `points` of `round`, as the study's replicates, stages and coupling ask.
/// Round 0's jobs are `p<point>r<replicate>` (test points `t…`), later rounds'
/// `r<round>-p<point>r<replicate>`.
pub fn plan_points<'a>(
    study: &Study,
    round: i64,
    points: &'a [DesignPoint],
    purpose: PointPurpose,
) -> Vec<PlannedPoint<'a>> {
    let prefix = if round == 0 {
        String::new()
    } else {
        format!("r{round}-")
    };
    let stages = match purpose {
        PointPurpose::Design => study.stages.as_slice(),
        PointPurpose::Test { .. } => &[],
    };
    let coupled = study.coupling.as_ref().filter(|_| !stages.is_empty());
    let mut occurrences: std::collections::HashMap<String, u32> = Default::default();
    let mut planned = Vec::with_capacity(points.len());
    // The first level's points by their coded coordinates (bit for bit), each list in
    // index order: where a higher level's point finds its twin without a scan.
    let mut first_level: std::collections::HashMap<Vec<u64>, Vec<usize>> = Default::default();
    for (i, p) in points.iter().enumerate().filter(|(_, p)| p.fidelity == 0) {
        let bits = p.coded.iter().map(|c| c.to_bits()).collect();
        first_level.entry(bits).or_default().push(i);
    }
    // How many twins of each first-level coordinates each level has named.
    let mut twins_taken: std::collections::HashMap<(u32, Vec<u64>), usize> = Default::default();
    for (number, point) in points.iter().enumerate() {
        let case = case_key(study, point);
        let occurrence = occurrences.entry(case.clone()).or_default();
        let key = SeedKey {
            purpose: purpose.as_str(),
            case: &case,
            occurrence: *occurrence,
            replicate: 0,
            stream: DESIGN_STAGE,
        };
        *occurrence += 1;
        // A higher fidelity level's run is named after its twin at the first level:
        // `p007r0-liggghts` runs p007r0's point on the level called `liggghts`.
        let (twin_of, level) = match study.fidelities.get(point.fidelity as usize) {
            Some(fidelity) if point.fidelity > 0 => {
                // A repeated point's twins take its repeats in turn.
                let bits: Vec<u64> = point.coded.iter().map(|c| c.to_bits()).collect();
                let taken = twins_taken
                    .entry((point.fidelity, bits.clone()))
                    .or_default();
                let twin = first_level
                    .get(&bits)
                    .and_then(|list| list.get(*taken))
                    .copied();
                *taken += 1;
                (twin, format!("-{}", fidelity.name))
            }
            _ => (None, String::new()),
        };
        let mut jobs = Vec::new();
        for replicate in 0..study.replicates {
            let key = SeedKey { replicate, ..key };
            let name = format!(
                "{prefix}{}{:03}r{replicate}{level}",
                purpose.letter(),
                twin_of.unwrap_or(number)
            );
            let design_job = jobs.len();
            jobs.push(PlannedJob {
                name: name.clone(),
                replicate,
                seed: job_seed(study.seed, &key),
                kind: JobKind::Design,
                after: None,
            });
            // Stages follow the design job; a coupling chain follows its first job of
            // the stage the chain's reruns follow (`cfd`), each job the one before it.
            let mut chain_tail = None;
            for stage in stages {
                let kind = stage.stage.kind();
                jobs.push(PlannedJob {
                    name: format!("{name}-{kind}"),
                    replicate,
                    seed: job_seed(
                        study.seed,
                        &SeedKey {
                            stream: kind,
                            ..key
                        },
                    ),
                    kind: JobKind::Stage(kind),
                    after: Some(design_job),
                });
                if coupled.is_some_and(|c| c.feeder.stage.kind() == kind) {
                    chain_tail = Some(jobs.len() - 1);
                }
            }
            if let Some(coupling) = coupled {
                for (chained, stage) in chain(&name, coupling) {
                    // A rerun of the design keeps its design job's seed: the same
                    // particles in another air, so that the change the coupling watches
                    // is the air's, not the insertion's (common random numbers).
                    let stream = if stage.reruns_design() {
                        DESIGN_STAGE
                    } else {
                        stage.kind()
                    };
                    jobs.push(PlannedJob {
                        name: chained,
                        replicate,
                        seed: job_seed(study.seed, &SeedKey { stream, ..key }),
                        kind: JobKind::Stage(stage.kind()),
                        after: Some(chain_tail.unwrap_or(design_job)),
                    });
                    chain_tail = Some(jobs.len() - 1);
                }
            }
        }
        planned.push(PlannedPoint {
            idx: purpose.first_idx() + number,
            purpose,
            point,
            jobs,
        });
    }
    planned
}

/// Names and stages of the jobs `coupling` chains after design job `design` and its
/// first job of the stage the reruns follow (`<design>-cfd`), in order: a rerun of
/// the design and then that stage again, `iterations` reruns in all
/// (`<design>-air1`, `<design>-cfd2`, `<design>-air2`, …).
fn chain<'a>(design: &str, coupling: &'a Coupling) -> Vec<(String, &'a dyn Stage)> {
    let (rerun, feeder): (&dyn Stage, &dyn Stage) =
        (&*coupling.rerun.stage, &*coupling.feeder.stage);
    let mut jobs = Vec::new();
    for k in 1..=coupling.iterations {
        jobs.push((format!("{design}-{}{k}", rerun.kind()), rerun));
        if k < coupling.iterations {
            jobs.push((format!("{design}-{}{}", feeder.kind(), k + 1), feeder));
        }
    }
    jobs
}

/// A round's design points and held-out test points, planned: the design's first,
/// then the tests', numbered after the design's.
pub fn plan_round<'a>(
    study: &Study,
    round: i64,
    design: &'a [DesignPoint],
    tests: &'a [DesignPoint],
) -> [Vec<PlannedPoint<'a>>; 2] {
    let test = PointPurpose::Test {
        first_idx: design.len(),
    };
    [
        plan_points(study, round, design, PointPurpose::Design),
        plan_points(study, round, tests, test),
    ]
}

/// What a job's seed is derived from, besides the study's seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeedKey<'a> {
    /// `design` or `test`: a held-out run is never a design run's copy.
    pub purpose: &'a str,
    /// The resolved case, as [`case_key`] writes it.
    pub case: &'a str,
    /// How many points of the same design came before with the same case.
    pub occurrence: u32,
    /// Replicate number.
    pub replicate: u32,
    /// The random stream: [`DESIGN_STAGE`] or a stage kind.
    pub stream: &'a str,
}

/// The seed of the job `key` of a study seeded `study_seed`: the first 63 bits of
/// SHA-256 over both, each field length-prefixed so that no two keys write the same
/// bytes.
pub fn job_seed(study_seed: u64, key: &SeedKey<'_>) -> u64 {
    let mut hash = Sha256::new();
    hash.update(b"orch job seed v1");
    hash.update(study_seed.to_le_bytes());
    for field in [key.purpose, key.case, key.stream] {
        hash.update((field.len() as u64).to_le_bytes());
        hash.update(field.as_bytes());
    }
    hash.update(key.occurrence.to_le_bytes());
    hash.update(key.replicate.to_le_bytes());
    let digest = hash.finalize();
    let bytes: [u8; 8] = digest[..8].try_into().expect("SHA-256 has 32 bytes");
    u64::from_le_bytes(bytes) >> 1
}

/// The case of `point` as text: every resolved parameter in name order with 12
/// significant digits (so that the same point reached through another round's box,
/// with a different last bit, is the same case), then every text value, then the
/// fidelity level's name above the first level.
pub fn case_key(study: &Study, point: &DesignPoint) -> String {
    use std::fmt::Write;
    let case = study.case(point, 0);
    let mut key = String::new();
    for (name, value) in &case.parameters.0 {
        let _ = write!(key, "{name}={value:.11e};");
    }
    for (name, value) in &case.text {
        let _ = write!(key, "{name}:{value};");
    }
    // A higher fidelity level's run of the same point is another run, whatever
    // parameters the level sets (it may differ by its solver alone).
    if let Some(level) = study
        .fidelities
        .get(point.fidelity as usize)
        .filter(|_| point.fidelity > 0)
    {
        let _ = write!(key, "fidelity:{};", level.name);
    }
    key
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use proptest::prelude::*;

    use super::*;

    fn key<'a>(case: &'a str, occurrence: u32, replicate: u32, stream: &'a str) -> SeedKey<'a> {
        SeedKey {
            purpose: "design",
            case,
            occurrence,
            replicate,
            stream,
        }
    }

    fn a_study(extra: &str) -> Study {
        let text = format!(
            "name: planned\nsolver: native\nfactors:\n  - {{name: outlet_diameter, min: 0.020, max: 0.028}}\ndesign: {{type: full_factorial, levels: 3}}\n{extra}"
        );
        Study::from_text(std::path::Path::new("planned.yaml"), &text, None).unwrap()
    }

    fn point(outlet: f64) -> DesignPoint {
        DesignPoint {
            coded: vec![(outlet - 0.024) / 0.004],
            natural: vec![outlet],
            fidelity: 0,
        }
    }

    fn seeds(planned: &[PlannedPoint<'_>]) -> Vec<Vec<u64>> {
        planned
            .iter()
            .map(|p| p.jobs.iter().map(|j| j.seed).collect())
            .collect()
    }

    #[test]
    fn a_point_a_later_round_revisits_is_the_same_run_as_its_first_and_a_repeat_in_one_design_is_not(
    ) {
        let study = a_study("replicates: 2\nseed: 5\n");
        let first = [point(0.020), point(0.028), point(0.028)];
        let round0 = plan_points(&study, 0, &first, PointPurpose::Design);
        let later = [point(0.026), point(0.028)];
        let round1 = plan_points(&study, 1, &later, PointPurpose::Design);
        let (s0, s1) = (seeds(&round0), seeds(&round1));
        assert_eq!(round1[1].jobs[0].name, "r1-p001r0");
        // 0.028 in round 1 is round 0's first 0.028, replicate by replicate.
        assert_eq!(s1[1], s0[1]);
        // The second 0.028 of round 0 (a repeated run of one design) and the
        // replicates are runs of their own.
        assert!(s0[2].iter().all(|seed| !s0[1].contains(seed)));
        assert_ne!(s0[1][0], s0[1][1]);
        // A held-out test run at a design point is never that design run.
        let tests = plan_points(&study, 0, &first[..1], PointPurpose::Test { first_idx: 3 });
        assert_eq!(tests[0].idx, 3);
        assert_eq!(tests[0].jobs[0].name, "t000r0");
        assert_ne!(seeds(&tests)[0], s0[0]);
        // Another study seed is another run everywhere.
        let other = plan_points(
            &a_study("replicates: 2\nseed: 6\n"),
            0,
            &first,
            PointPurpose::Design,
        );
        assert!(seeds(&other)
            .concat()
            .iter()
            .all(|seed| !s0.concat().contains(seed)));
    }

    #[test]
    fn a_coupling_chain_alternates_reruns_of_the_design_and_the_stage_they_follow() {
        let study =
            a_study("cfd:\n  fixed: {end_time: 0.2}\ncoupling: {iterations: 2, tolerance: 0.01}\n");
        let points = [point(0.024)];
        let planned = plan_points(&study, 0, &points, PointPurpose::Design);
        let jobs = &planned[0].jobs;
        let chain: Vec<(&str, &str, Option<usize>)> = jobs
            .iter()
            .map(|j| (j.name.as_str(), j.kind.as_str(), j.after))
            .collect();
        assert_eq!(
            chain,
            vec![
                ("p000r0", DESIGN_STAGE, None),
                ("p000r0-cfd", "cfd", Some(0)),
                ("p000r0-air1", "air", Some(1)),
                ("p000r0-cfd2", "cfd", Some(2)),
                ("p000r0-air2", "air", Some(3)),
            ]
        );
        // A rerun of the design has its design job's seed (the same particles in
        // another air); every CFD run has its own.
        assert_eq!(jobs[2].seed, jobs[0].seed);
        assert_eq!(jobs[4].seed, jobs[0].seed);
        assert_ne!(jobs[1].seed, jobs[0].seed);
        // One iteration: the chain is the one rerun.
        let once =
            a_study("cfd:\n  fixed: {end_time: 0.2}\ncoupling: {iterations: 1, tolerance: 0.01}\n");
        let planned = plan_points(&once, 0, &points, PointPurpose::Design);
        let names: Vec<&str> = planned[0].jobs.iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["p000r0", "p000r0-cfd", "p000r0-air1"]);
    }

    #[test]
    fn the_same_case_reached_through_another_box_rounds_to_the_same_key() {
        let study = a_study("");
        // 0.1 + 0.2 is 0.30000000000000004: the same point for any user.
        let a = case_key(&study, &point(0.1 + 0.2));
        let b = case_key(&study, &point(0.3));
        assert_eq!(a, b);
        assert_ne!(a, case_key(&study, &point(0.300001)));
        assert!(a.contains("outlet_diameter=3.00000000000e-1;"), "{a}");
    }

    #[test]
    fn a_hundred_thousand_jobs_of_one_project_have_distinct_seeds() {
        // 5 rounds × 200 points × 50 replicates × 2 streams, and a second study seed:
        // the shape of a large project, 2·10^5 jobs.
        let mut seen = HashSet::new();
        let mut jobs = 0;
        for study_seed in [0_u64, 1] {
            for round in 0..5 {
                for point in 0..200 {
                    let case = format!("outlet={:.11e};round={round}", 0.02 + point as f64 * 1e-5);
                    for replicate in 0..50 {
                        for stream in ["dem", "cfd"] {
                            let seed = job_seed(study_seed, &key(&case, 0, replicate, stream));
                            assert!(seed <= i64::MAX as u64);
                            seen.insert(seed);
                            jobs += 1;
                        }
                    }
                }
            }
        }
        assert_eq!(seen.len(), jobs, "two jobs share a seed");
    }

    #[test]
    fn replicates_past_a_thousand_and_rounds_past_a_million_do_not_collide() {
        // The arithmetic seeds of earlier versions wrapped: point 1 replicate 0 was
        // point 0 replicate 1000, and a round's offset vanished modulo 10^6.
        let a = job_seed(7, &key("x=1", 0, 1000, "dem"));
        let b = job_seed(7, &key("x=1", 1, 0, "dem"));
        let c = job_seed(7, &key("x=1", 0, 0, "dem"));
        assert!(a != b && b != c && a != c);
    }

    proptest! {
        #[test]
        fn every_field_of_the_key_changes_the_seed(
            study_seed in any::<u64>(),
            case in "[a-z]{1,8}=[0-9]{1,4}",
            occurrence in 0_u32..100,
            replicate in 0_u32..100,
        ) {
            let base = key(&case, occurrence, replicate, "dem");
            let seed = job_seed(study_seed, &base);
            prop_assert_eq!(seed, job_seed(study_seed, &base));
            prop_assert_ne!(seed, job_seed(study_seed.wrapping_add(1), &base));
            prop_assert_ne!(seed, job_seed(study_seed, &SeedKey { occurrence: occurrence + 1, ..base }));
            prop_assert_ne!(seed, job_seed(study_seed, &SeedKey { replicate: replicate + 1, ..base }));
            prop_assert_ne!(seed, job_seed(study_seed, &SeedKey { stream: "cfd", ..base }));
            prop_assert_ne!(seed, job_seed(study_seed, &SeedKey { purpose: "test", ..base }));
            let longer = format!("{case}0");
            prop_assert_ne!(seed, job_seed(study_seed, &SeedKey { case: &longer, ..base }));
        }
    }
}
