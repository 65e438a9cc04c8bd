//! Run identity: the SHA-256 of everything that decides a run's result, taken once a
//! job is rendered and before it is launched.
//!
//! What goes in, each length-prefixed so that no two inputs write the same bytes:
//! - every file of the rendered run directory (deck, meshes, side files, an upstream
//!   job's air field), by relative path and content, in path order; a symbolic link by
//!   its target's text;
//! - the program: its resolved path, the SHA-256 of its file and, for a file a Debian
//!   package installed, the package and its version (LIGGGHTS's physics is in
//!   `libliggghts.so`, not in the 700 kB `/usr/bin/liggghts`);
//! - the command's environment, and its arguments and cores unless the program gives
//!   the same result on any number of cores ([`CommandSpec::same_result_on_any_cores`]:
//!   the native kernel, whose thread count is only in its arguments);
//! - the run's conditions outside the deck that change what it stores (`stop_when:`).
//!
//! The seed is in the deck, so it is in the identity through the files. Two jobs with
//! the same identity are the same run: the second is not run again but reused, and a
//! statistic counts the two once.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{LazyLock, Mutex};

use orch_adapters::CommandSpec;
use sha2::{Digest, Sha256};

use orch_executor::ATTEMPTS_LOG;

/// The identity of the run rendered into `run_dir` to be run by `command` under
/// `conditions` (text of the study's settings that change the result), in hex. Files
/// of orch's own that a run directory keeps across attempts ([`ATTEMPTS_LOG`]) are
/// left out.
pub fn of_run(run_dir: &Path, command: &CommandSpec, conditions: &str) -> std::io::Result<String> {
    let mut hash = Sha256::new();
    field(&mut hash, b"orch run identity v1");
    let mut files = Vec::new();
    list_files(run_dir, run_dir, &mut files)?;
    files.retain(|f| f != ATTEMPTS_LOG);
    files.sort();
    for relative in &files {
        let path = run_dir.join(relative);
        field(&mut hash, relative.as_bytes());
        let meta = std::fs::symlink_metadata(&path)?;
        if meta.file_type().is_symlink() {
            field(&mut hash, b"link");
            field(
                &mut hash,
                std::fs::read_link(&path)?.as_os_str().as_encoded_bytes(),
            );
        } else {
            field(&mut hash, b"file");
            hash.update(meta.len().to_le_bytes());
            hash_file(&mut hash, &path)?;
        }
    }
    field(&mut hash, b"program");
    field(&mut hash, program_fingerprint(&command.program).as_bytes());
    for (name, value) in &command.env {
        field(&mut hash, name.as_bytes());
        field(&mut hash, value.as_bytes());
    }
    if !command.same_result_on_any_cores {
        field(&mut hash, b"args");
        for arg in &command.args {
            field(&mut hash, arg.as_bytes());
        }
        field(&mut hash, &(command.cores as u64).to_le_bytes());
    }
    field(&mut hash, b"conditions");
    field(&mut hash, conditions.as_bytes());
    Ok(format!("{:x}", hash.finalize()))
}

/// Adds the content of the file at `path` to `hash`, 64 KiB at a time: a mesh or a
/// program may be large, and what orch holds must not grow with it.
pub fn hash_file(hash: &mut Sha256, path: &Path) -> std::io::Result<()> {
    use std::io::Read;
    let mut file = std::fs::File::open(path)?;
    let mut buffer = vec![0_u8; 64 * 1024];
    loop {
        let n = file.read(&mut buffer)?;
        if n == 0 {
            return Ok(());
        }
        hash.update(&buffer[..n]);
    }
}

/// Adds `bytes` to `hash` after their length.
fn field(hash: &mut Sha256, bytes: &[u8]) {
    hash.update((bytes.len() as u64).to_le_bytes());
    hash.update(bytes);
}

/// Every file and symbolic link under `dir`, as paths relative to `root` with `/`.
fn list_files(root: &Path, dir: &Path, out: &mut Vec<String>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let kind = entry.file_type()?;
        let path = entry.path();
        if kind.is_dir() {
            list_files(root, &path, out)?;
        } else {
            let relative = path.strip_prefix(root).unwrap_or(&path);
            let words: Vec<String> = relative
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            out.push(words.join("/"));
        }
    }
    Ok(())
}

/// Fills `to` (a reusing job's run directory, rendered with the same inputs) with the
/// files of the run `from`, as hard links where the file system allows, else copies;
/// [`ATTEMPTS_LOG`] stays the job's own. A run's files are not written once it has
/// succeeded, so the two directories may share them.
pub fn link_run(from: &Path, to: &Path) -> std::io::Result<()> {
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let kind = entry.file_type()?;
        let target = to.join(entry.file_name());
        if kind.is_dir() {
            std::fs::create_dir_all(&target)?;
            link_run(&entry.path(), &target)?;
            continue;
        }
        if entry.file_name() == ATTEMPTS_LOG {
            continue;
        }
        if std::fs::symlink_metadata(&target).is_ok() {
            std::fs::remove_file(&target)?;
        }
        if kind.is_symlink() {
            std::os::unix::fs::symlink(std::fs::read_link(entry.path())?, &target)?;
        } else if std::fs::hard_link(entry.path(), &target).is_err() {
            std::fs::copy(entry.path(), &target)?;
        }
    }
    Ok(())
}

/// What a program is, as far as its results go: its resolved path, its file's SHA-256
/// and its Debian package's version, or `unresolved <name>` for a program not on PATH
/// (whose launch fails anyway). Kept per process, keyed by path, size and mtime, so a
/// study hashes each program once.
pub fn program_fingerprint(program: &str) -> String {
    let Some(path) = resolve(program) else {
        return format!("unresolved {program}");
    };
    let Ok(meta) = std::fs::metadata(&path) else {
        return format!("unreadable {}", path.display());
    };
    let key = (path.clone(), meta.len(), meta.modified().ok());
    static SEEN: LazyLock<Mutex<HashMap<FingerprintKey, String>>> = LazyLock::new(Default::default);
    if let Some(known) = SEEN.lock().expect("not poisoned").get(&key) {
        return known.clone();
    }
    let mut digest = Sha256::new();
    let content = match hash_file(&mut digest, &path) {
        Ok(()) => format!("{:x}", digest.finalize()),
        Err(e) => format!("unreadable ({e})"),
    };
    let package = debian_package(&path).unwrap_or_default();
    let fingerprint = format!("{} sha256 {content} {package}", path.display());
    SEEN.lock()
        .expect("not poisoned")
        .insert(key, fingerprint.clone());
    fingerprint
}

type FingerprintKey = (PathBuf, u64, Option<std::time::SystemTime>);

/// `program` as a path: itself when it names a path, else the first match on PATH.
fn resolve(program: &str) -> Option<PathBuf> {
    if program.contains('/') {
        let path = PathBuf::from(program);
        return path.is_file().then(|| path.canonicalize().unwrap_or(path));
    }
    let paths = std::env::var_os("PATH")?;
    std::env::split_paths(&paths)
        .map(|dir| dir.join(program))
        .find(|candidate| candidate.is_file())
        .map(|path| path.canonicalize().unwrap_or(path))
}

/// `package version` of the Debian package that installed `path`, when `dpkg-query`
/// knows it. Only paths where packages install programs are asked about: `dpkg-query
/// -S` reads every package's file list (33 MB, 70 ms here), which a program built in
/// the user's tree (`orch-dem`) need not pay for.
fn debian_package(path: &Path) -> Option<String> {
    let packaged = ["/usr/", "/bin/", "/sbin/", "/lib/", "/opt/"];
    if !packaged.iter().any(|dir| path.starts_with(dir)) || path.starts_with("/usr/local/") {
        return None;
    }
    let owner = std::process::Command::new("dpkg-query")
        .arg("-S")
        .arg(path)
        .stderr(std::process::Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())?;
    let owner = String::from_utf8_lossy(&owner.stdout);
    let package = owner.lines().next()?.split(':').next()?.trim().to_string();
    let version = std::process::Command::new("dpkg-query")
        .args(["-W", "-f", "${Version}", &package])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())?;
    Some(format!(
        "{package} {}",
        String::from_utf8_lossy(&version.stdout).trim()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn command(program: &str, cores: usize, same_on_any_cores: bool) -> CommandSpec {
        let mut args = vec!["run".to_string(), "deck".to_string()];
        if cores > 1 {
            args.extend(["--threads".to_string(), cores.to_string()]);
        }
        CommandSpec {
            program: program.to_string(),
            args,
            env: Default::default(),
            cores,
            mpi: false,
            same_result_on_any_cores: same_on_any_cores,
            log_file: "log".to_string(),
        }
    }

    fn run_dir(files: &[(&str, &str)]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in files {
            let path = dir.path().join(name);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, text).unwrap();
        }
        dir
    }

    fn identity(files: &[(&str, &str)], command: &CommandSpec, conditions: &str) -> String {
        of_run(run_dir(files).path(), command, conditions).unwrap()
    }

    #[test]
    fn the_same_files_program_and_conditions_are_the_same_run_wherever_they_lie() {
        let sh = command("sh", 1, false);
        let files = [("deck.in", "seed 10007\n"), ("meshes/a.stl", "solid a")];
        let a = identity(&files, &sh, "");
        assert_eq!(a.len(), 64);
        assert_eq!(a, identity(&files, &sh, ""));
    }

    #[test]
    fn a_byte_a_path_a_seed_a_program_or_a_condition_makes_another_run() {
        let sh = command("sh", 1, false);
        let base = identity(&[("deck.in", "seed 10007\n")], &sh, "");
        let others = [
            identity(&[("deck.in", "seed 10009\n")], &sh, ""),
            identity(&[("deck2.in", "seed 10007\n")], &sh, ""),
            identity(&[("deck.in", "seed 10007\n"), ("extra", "")], &sh, ""),
            identity(
                &[("deck.in", "seed 10007\n")],
                &command("true", 1, false),
                "",
            ),
            identity(&[("deck.in", "seed 10007\n")], &sh, "stop_when 0.03"),
        ];
        for other in others {
            assert_ne!(base, other);
        }
    }

    #[test]
    fn cores_count_only_for_a_program_whose_result_depends_on_them() {
        let files = [("case.toml", "seed = 10007\n")];
        assert_ne!(
            identity(&files, &command("sh", 1, false), ""),
            identity(&files, &command("sh", 2, false), ""),
            "two MPI ranks decompose the domain: another run"
        );
        assert_eq!(
            identity(&files, &command("sh", 1, true), ""),
            identity(&files, &command("sh", 2, true), ""),
            "the native kernel is bit-for-bit the same on any threads"
        );
    }

    #[test]
    fn orchs_attempts_log_is_not_part_of_a_run() {
        let sh = command("sh", 1, false);
        let files = [("deck.in", "x")];
        let with_log = [("deck.in", "x"), (ATTEMPTS_LOG, "attempt 1 started")];
        assert_eq!(identity(&files, &sh, ""), identity(&with_log, &sh, ""));
    }

    #[test]
    fn a_linked_run_has_the_sources_files_and_keeps_its_own_attempts_log() {
        let from = run_dir(&[
            ("deck.in", "x"),
            ("post/dump.1", "1 2 3"),
            (ATTEMPTS_LOG, "theirs"),
        ]);
        let to = run_dir(&[("deck.in", "x"), (ATTEMPTS_LOG, "mine")]);
        link_run(from.path(), to.path()).unwrap();
        let read = |f: &str| std::fs::read_to_string(to.path().join(f)).unwrap();
        assert_eq!(read("post/dump.1"), "1 2 3");
        assert_eq!(read("deck.in"), "x");
        assert_eq!(read(ATTEMPTS_LOG), "mine");
    }

    #[test]
    fn a_program_is_known_by_its_content_not_only_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let program = dir.path().join("solver");
        std::fs::write(&program, "#!/bin/sh\necho 1\n").unwrap();
        let first = program_fingerprint(program.to_str().unwrap());
        std::fs::write(&program, "#!/bin/sh\necho 22\n").unwrap();
        let second = program_fingerprint(program.to_str().unwrap());
        assert_ne!(first, second);
        assert!(program_fingerprint("no-such-program-anywhere").starts_with("unresolved"));
    }
}
