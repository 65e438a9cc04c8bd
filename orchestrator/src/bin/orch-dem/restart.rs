//! Restart files of `orch-dem run`, as LIGGGHTS's `restart` command writes them: every
//! so often (wall time) the run saves the kernel's whole state to `post/restart.orch-dem`,
//! and a run started where one lies continues from it instead of from t = 0. The
//! continued run is the same, bit for bit, as one that never stopped: the kernel's
//! saved state holds everything a step carries over, the log and the crossings file are
//! cut back to what they held when the state was saved, and the dumps written after it
//! are written again with the same content.
//!
//! A restart file belongs to one case and one build of `orch-dem`: it records the
//! SHA-256 of the case file, every file the case names (meshes, packing, air velocity
//! field) and the program itself. A file that belongs to anything else is set aside
//! (the run starts from t = 0 and says why), never continued from: a run of one build
//! continued by another would match neither.
//!
//! The file is written beside its final name and renamed over it, so a run killed while
//! writing leaves the previous one whole.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use orch_dem::case::Case;
use orch_dem::simulation::SavedState;
use orch_study::identity::hash_file;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// The restart file's name in the run's `post/` folder.
pub const RESTART_FILE: &str = "restart.orch-dem";

/// The first field of every restart file; a file of another layout is not read on.
const FORMAT: &str = "orch-dem restart file, layout 1";

/// What a restart file says of the run besides the kernel's state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    format: String,
    /// SHA-256 of the case, the files it names and the program ([`fingerprint`]).
    pub fingerprint: [u8; 32],
    /// The log's length when the state was saved, bytes.
    pub log_bytes: u64,
    /// The crossings file's length when the state was saved, bytes.
    pub crossings_bytes: u64,
    /// Wall time of the time loop up to the save, over every leg of the run, s.
    pub loop_s: f64,
}

impl Header {
    /// A header for the run of `fingerprint` whose log and crossings file hold
    /// `log_bytes` and `crossings_bytes` after `loop_s` seconds of time loop.
    pub fn new(fingerprint: [u8; 32], log_bytes: u64, crossings_bytes: u64, loop_s: f64) -> Self {
        Self {
            format: FORMAT.to_string(),
            fingerprint,
            log_bytes,
            crossings_bytes,
            loop_s,
        }
    }
}

/// What lies at a run's restart path.
#[derive(Debug)]
pub enum Found {
    /// No restart file: the run starts from t = 0.
    Nothing,
    /// A restart file of this case and program, to continue from.
    Usable(Header, Box<SavedState>),
    /// A restart file that cannot be continued from, and why (it has been removed).
    SetAside(String),
}

/// The restart file of a run whose outputs go to `post`.
pub fn path_in(post: &Path) -> PathBuf {
    post.join(RESTART_FILE)
}

/// SHA-256 of the case file at `case_path`, of every file `case` names (relative to
/// the case's folder, in the order the case names them) and of the running program:
/// what decides whether a restart file belongs to this run. It reads the program
/// (115 MB in a debug build), so a run takes it only when it reads or first writes a
/// restart file.
pub fn fingerprint(case_path: &Path, case: &Case) -> anyhow::Result<[u8; 32]> {
    let dir = case_path.parent().unwrap_or(Path::new("."));
    let mut files = vec![case_path.to_path_buf()];
    files.extend(case.meshes.iter().map(|m| dir.join(&m.file)));
    files.extend(case.packing_file().map(|f| dir.join(f)));
    files.extend(case.air_field_file().map(|f| dir.join(f)));
    files.push(std::env::current_exe().context("cannot find the running program")?);
    let mut hash = Sha256::new();
    for path in files {
        hash.update(path.file_name().unwrap_or_default().as_encoded_bytes());
        hash_file(&mut hash, &path).with_context(|| format!("cannot read {}", path.display()))?;
    }
    Ok(hash.finalize().into())
}

/// Writes `header` and `state` to `path`, through a file beside it renamed over it.
pub fn write(path: &Path, header: &Header, state: &SavedState) -> anyhow::Result<()> {
    let partial = path.with_extension("partial");
    let write = || -> anyhow::Result<()> {
        let mut bytes = postcard::to_stdvec(header)?;
        bytes.extend(postcard::to_stdvec(state)?);
        let mut file = File::create(&partial)?;
        file.write_all(&bytes)?;
        file.sync_all()?;
        std::fs::rename(&partial, path)?;
        Ok(())
    };
    write().with_context(|| format!("cannot write the restart file {}", path.display()))
}

/// Reads the restart file at `path`, if any, for the run whose fingerprint
/// `fingerprint` gives (asked only when there is a file); one that cannot be read or
/// belongs to another run is removed and reported as set aside.
pub fn read(
    path: &Path,
    fingerprint: impl FnOnce() -> anyhow::Result<[u8; 32]>,
) -> anyhow::Result<Found> {
    let bytes = match std::fs::read(path) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Found::Nothing),
        Err(e) => return Ok(set_aside(path, format!("it cannot be read ({e})"))),
    };
    let fingerprint = fingerprint()?;
    Ok(read_bytes(path, &bytes, &fingerprint))
}

/// [`read`] of the file's `bytes`.
fn read_bytes(path: &Path, bytes: &[u8], fingerprint: &[u8; 32]) -> Found {
    let (header, rest) = match postcard::take_from_bytes::<Header>(bytes) {
        Ok((header, rest)) if header.format == FORMAT => (header, rest),
        _ => return set_aside(path, "it is not a restart file of this layout".into()),
    };
    if header.fingerprint != *fingerprint {
        return set_aside(
            path,
            "it was written for another case or input file, or by another build of orch-dem".into(),
        );
    }
    match postcard::from_bytes::<SavedState>(rest) {
        Ok(state) => Found::Usable(header, Box::new(state)),
        Err(e) => set_aside(path, format!("its state cannot be read ({e})")),
    }
}

fn set_aside(path: &Path, why: String) -> Found {
    // Removing it is best effort: the run starts from t = 0 either way, and a later
    // save replaces it.
    let _ = std::fs::remove_file(path);
    Found::SetAside(why)
}
