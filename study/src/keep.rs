//! `keep:` of a study: what a succeeded job's run directory keeps once its results are
//! stored in the database.
//!
//! - `all` (the default): everything the job wrote.
//! - `results`: everything but the bulky particle snapshots — `dump_every`'s
//!   `dump<step>.liggghts` files and `vtk_every`'s VTK files (`.vtk`, `.vtu`, `.vtp`,
//!   `.vtm`, `.vtr`, `.pvd`, `.pvtu`) and folders holding only those. Decks, geometry,
//!   logs and the files the parsers read (crossings, the sensor dump) stay, so a run can
//!   be parsed again.
//! - `none`: only a small record: the exit status, the attempts log, the last
//!   [`TAIL_BYTES`] of the solver's stdout, stderr and log (what `orch logs` shows), and
//!   [`RECORD_FILE`], which says what was removed.
//!
//! Failed jobs keep everything: the driver prunes only after a job's results are
//! stored as succeeded, and never below what a stage that follows the job reads there
//! ([`Keep::at_least`]) until every such follower has succeeded; then to `keep:`.

use std::io::{self, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use orch_adapters::UpstreamFiles;
use serde::Deserialize;

use orch_executor::{ATTEMPTS_LOG, EXIT_STATUS_FILE, STDERR_FILE, STDOUT_FILE};

/// What a succeeded job's run directory keeps after its results are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Keep {
    /// Everything the job wrote.
    #[default]
    All,
    /// Everything but particle snapshots (full dumps and VTK files).
    Results,
    /// The exit status, the attempts log, output tails and [`RECORD_FILE`].
    None,
}

impl Keep {
    /// The name a study file uses.
    pub fn name(self) -> &'static str {
        match self {
            Keep::All => "all",
            Keep::Results => "results",
            Keep::None => "none",
        }
    }

    /// This, or more where a later job reads `needed` of the run directory.
    pub fn at_least(self, needed: UpstreamFiles) -> Keep {
        match (self, needed) {
            (_, UpstreamFiles::Everything) => Keep::All,
            (Keep::None, UpstreamFiles::Results) => Keep::Results,
            (keep, _) => keep,
        }
    }
}

/// The file `keep: results` and `keep: none` leave, naming what they removed.
pub const RECORD_FILE: &str = "orch-kept.txt";

/// Bytes of the end of stdout, stderr and the solver's log that `keep: none` keeps.
pub const TAIL_BYTES: u64 = 16 * 1024;

/// Extensions of VTK files (ParaView's formats), removed by `keep: results`.
pub const VTK_EXTENSIONS: [&str; 7] = ["vtk", "vtu", "vtp", "vtm", "vtr", "pvd", "pvtu"];

/// What pruning removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pruned {
    /// Files removed (a file cut down to its tail is not counted).
    pub files: u64,
    /// Bytes freed, removed files and cut tails together.
    pub bytes: u64,
}

/// True for a particle snapshot `keep: results` removes: a `dump_every` dump
/// (`dump<step>.liggghts`) or a VTK file.
pub fn is_snapshot(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    (name.starts_with("dump") && extension == "liggghts")
        || VTK_EXTENSIONS
            .iter()
            .any(|vtk| extension.eq_ignore_ascii_case(vtk))
}

/// Prunes the run directory `run_dir` of a job whose results are stored, as `keep`
/// says; `log_file` is the solver's log, relative to `run_dir`, whose tail `none`
/// keeps. Writes [`RECORD_FILE`] unless nothing was removed. Symbolic links are
/// removed, never followed.
pub fn prune(run_dir: &Path, keep: Keep, log_file: &str) -> io::Result<Pruned> {
    let mut pruned = Pruned::default();
    match keep {
        Keep::All => return Ok(pruned),
        Keep::Results => remove_snapshots(run_dir, &mut pruned)?,
        Keep::None => {
            let tails = [STDOUT_FILE, STDERR_FILE, log_file];
            for entry in std::fs::read_dir(run_dir)? {
                let entry = entry?;
                let name = entry.file_name();
                let name = name.to_string_lossy();
                if name == EXIT_STATUS_FILE || name == ATTEMPTS_LOG || name == RECORD_FILE {
                    continue;
                }
                if tails.contains(&name.as_ref()) && entry.file_type()?.is_file() {
                    pruned.bytes += cut_to_tail(&entry.path(), TAIL_BYTES)?;
                    continue;
                }
                remove(&entry.path(), &mut pruned)?;
            }
        }
    }
    if pruned.bytes > 0 || pruned.files > 0 {
        let record = match keep {
            Keep::None => format!(
                "keep: none removed {} files ({} bytes) once the results were stored; \
                 stdout, stderr and the log keep their last {} bytes\n",
                pruned.files, pruned.bytes, TAIL_BYTES
            ),
            _ => format!(
                "keep: {} removed {} particle snapshot files ({} bytes) once the results were stored\n",
                keep.name(),
                pruned.files,
                pruned.bytes
            ),
        };
        std::fs::write(run_dir.join(RECORD_FILE), record)?;
    }
    Ok(pruned)
}

/// Removes the snapshots under `dir`, and folders they leave empty.
fn remove_snapshots(dir: &Path, pruned: &mut Pruned) -> io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let path = entry.path();
        let kind = entry.file_type()?;
        if kind.is_dir() {
            remove_snapshots(&path, pruned)?;
            if snapshots_only_left_it_empty(&path, pruned)? {
                std::fs::remove_dir(&path)?;
            }
        } else if is_snapshot(&path) {
            remove(&path, pruned)?;
        }
    }
    Ok(())
}

/// True when `dir` is empty now and pruning removed something (a folder that was
/// empty before, such as `post/` of a run without output yet, stays).
fn snapshots_only_left_it_empty(dir: &Path, pruned: &Pruned) -> io::Result<bool> {
    Ok(pruned.files > 0 && std::fs::read_dir(dir)?.next().is_none())
}

/// Removes a file, link or folder, counting its files and bytes.
fn remove(path: &Path, pruned: &mut Pruned) -> io::Result<()> {
    let meta = std::fs::symlink_metadata(path)?;
    if meta.is_dir() {
        let entries: Vec<PathBuf> = std::fs::read_dir(path)?
            .map(|e| e.map(|e| e.path()))
            .collect::<io::Result<_>>()?;
        for entry in entries {
            remove(&entry, pruned)?;
        }
        std::fs::remove_dir(path)?;
    } else {
        std::fs::remove_file(path)?;
        pruned.files += 1;
        pruned.bytes += meta.len();
    }
    Ok(())
}

/// Cuts the file at `path` down to its last `tail` bytes (from the start of a line
/// where one begins inside them); returns the bytes freed.
fn cut_to_tail(path: &Path, tail: u64) -> io::Result<u64> {
    let len = std::fs::metadata(path)?.len();
    if len <= tail {
        return Ok(0);
    }
    let mut file = std::fs::File::open(path)?;
    file.seek(SeekFrom::Start(len - tail))?;
    let mut kept = Vec::with_capacity(tail as usize);
    file.read_to_end(&mut kept)?;
    if let Some(newline) = kept.iter().position(|&b| b == b'\n') {
        if newline + 1 < kept.len() {
            kept.drain(..=newline);
        }
    }
    let freed = len - kept.len() as u64;
    std::fs::write(path, kept)?;
    Ok(freed)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A succeeded LIGGGHTS run's directory: deck, geometry, logs, the sensor dump the
    /// parser reads, two full dumps, VTK files in `post/` and in a `vtk/` folder.
    fn run_dir() -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        let files: [(&str, usize); 14] = [
            ("deck.in", 100),
            ("hopper.stl", 200),
            ("log.liggghts", 40_000),
            (STDOUT_FILE, 30_000),
            (STDERR_FILE, 10),
            (EXIT_STATUS_FILE, 2),
            (ATTEMPTS_LOG, 50),
            ("post/sensor.liggghts", 5000),
            ("post/crossings.csv", 300),
            ("post/dump1000.liggghts", 700),
            ("post/dump2000.liggghts", 700),
            ("post/particles_1000.vtk", 900),
            ("vtk/part_1000.vtu", 800),
            ("vtk/partboundingBox_1000.vtr", 80),
        ];
        for (name, size) in files {
            let path = dir.path().join(name);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            let line = format!("{name} line\n");
            let text: String = line.repeat(size / line.len() + 1);
            std::fs::write(path, &text.as_bytes()[..size]).unwrap();
        }
        dir
    }

    /// The files under `dir`, relative, sorted.
    fn listing(dir: &Path) -> Vec<String> {
        fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
            for entry in std::fs::read_dir(dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    out.push(format!("{}/", path.strip_prefix(root).unwrap().display()));
                    walk(root, &path, out);
                } else {
                    out.push(path.strip_prefix(root).unwrap().display().to_string());
                }
            }
        }
        let mut out = Vec::new();
        walk(dir, dir, &mut out);
        out.sort();
        out
    }

    #[test]
    fn a_run_directory_keeps_at_least_what_a_following_stage_reads() {
        use UpstreamFiles as Needs;
        assert_eq!(Keep::None.at_least(Needs::None), Keep::None);
        assert_eq!(Keep::None.at_least(Needs::Results), Keep::Results);
        assert_eq!(Keep::Results.at_least(Needs::Results), Keep::Results);
        assert_eq!(Keep::All.at_least(Needs::Results), Keep::All);
        for keep in [Keep::None, Keep::Results, Keep::All] {
            assert_eq!(keep.at_least(Needs::Everything), Keep::All);
        }
    }

    #[test]
    fn all_keeps_everything_and_writes_no_record() {
        let dir = run_dir();
        let before = listing(dir.path());
        assert_eq!(
            prune(dir.path(), Keep::All, "log.liggghts").unwrap(),
            Pruned::default()
        );
        assert_eq!(listing(dir.path()), before);
    }

    #[test]
    fn results_removes_dumps_and_vtk_but_keeps_what_parsers_read() {
        let dir = run_dir();
        let pruned = prune(dir.path(), Keep::Results, "log.liggghts").unwrap();
        assert_eq!(
            pruned,
            Pruned {
                files: 5,
                bytes: 700 + 700 + 900 + 800 + 80
            }
        );
        assert_eq!(
            listing(dir.path()),
            [
                ATTEMPTS_LOG,
                "deck.in",
                EXIT_STATUS_FILE,
                "hopper.stl",
                "log.liggghts",
                "orch-kept.txt",
                "post/",
                "post/crossings.csv",
                "post/sensor.liggghts",
                STDERR_FILE,
                STDOUT_FILE,
            ]
            .map(String::from)
            .into_iter()
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect::<Vec<_>>()
        );
        let record = std::fs::read_to_string(dir.path().join(RECORD_FILE)).unwrap();
        assert_eq!(
            record,
            "keep: results removed 5 particle snapshot files (3180 bytes) once the results were stored\n"
        );
        // Pruning again finds nothing more and leaves the record alone.
        assert_eq!(
            prune(dir.path(), Keep::Results, "log.liggghts").unwrap(),
            Pruned::default()
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join(RECORD_FILE)).unwrap(),
            record
        );
    }

    #[test]
    fn results_leaves_an_empty_folder_it_did_not_empty() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("post")).unwrap();
        std::fs::write(dir.path().join("log.native"), "log\n").unwrap();
        assert_eq!(
            prune(dir.path(), Keep::Results, "log.native").unwrap(),
            Pruned::default()
        );
        assert!(dir.path().join("post").is_dir());
        assert!(!dir.path().join(RECORD_FILE).exists());
    }

    #[test]
    fn none_keeps_the_exit_status_attempts_and_tails() {
        let dir = run_dir();
        let log_end = {
            let log = std::fs::read(dir.path().join("log.liggghts")).unwrap();
            String::from_utf8(log[log.len() - 100..].to_vec()).unwrap()
        };
        let pruned = prune(dir.path(), Keep::None, "log.liggghts").unwrap();
        assert_eq!(
            listing(dir.path()),
            [
                EXIT_STATUS_FILE,
                "log.liggghts",
                ATTEMPTS_LOG,
                "orch-kept.txt",
                STDERR_FILE,
                STDOUT_FILE
            ]
            .map(String::from)
            .into_iter()
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect::<Vec<_>>()
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join(EXIT_STATUS_FILE)).unwrap(),
            "ex"
        );
        let log = std::fs::read_to_string(dir.path().join("log.liggghts")).unwrap();
        assert!(log.len() as u64 <= TAIL_BYTES, "{}", log.len());
        assert!(log.len() as u64 > TAIL_BYTES - 20, "{}", log.len());
        assert!(
            log.starts_with("log.liggghts line\n"),
            "cut at a line start"
        );
        assert!(log.ends_with(&log_end));
        // A short stderr is kept whole.
        assert_eq!(
            std::fs::read(dir.path().join(STDERR_FILE)).unwrap().len(),
            10
        );
        assert_eq!(pruned.files, 9);
        let total_before: u64 =
            100 + 200 + 40_000 + 30_000 + 10 + 2 + 50 + 5000 + 300 + 700 + 700 + 900 + 800 + 80;
        let left: u64 = listing(dir.path())
            .iter()
            .filter(|name| name.as_str() != RECORD_FILE)
            .map(|name| std::fs::metadata(dir.path().join(name)).unwrap().len())
            .sum();
        assert_eq!(pruned.bytes, total_before - left);
    }

    #[test]
    fn snapshots_are_dumps_and_vtk_files_only() {
        for name in [
            "post/dump1000.liggghts",
            "post/particles_20.vtk",
            "vtk/hop-spheres.100.vtu",
            "post/part.PVD",
        ] {
            assert!(is_snapshot(Path::new(name)), "{name}");
        }
        for name in [
            "post/sensor.liggghts",
            "post/crossings.csv",
            "hopper.in",
            "hopper.stl",
            "log.liggghts",
            "post/dump.txt",
        ] {
            assert!(!is_snapshot(Path::new(name)), "{name}");
        }
    }
}
