//! What a job's run directory keeps from one attempt to the next so that its solver
//! continues where a stopped attempt left off: the paths its restart list
//! ([`RESTART_LIST`]) names. A new attempt starts from a clean directory, freshly
//! rendered, so that the run's identity is taken from its inputs alone; the kept paths
//! wait in a folder beside the run directory meanwhile and are put back just before
//! the launch. The solver decides whether they fit its case (`orch-dem` checks a
//! SHA-256 of the case, its files and itself) and starts over when they do not.

use std::path::{Component, Path, PathBuf};

use orch_executor::RESTART_LIST;

/// Paths set aside from a run directory, waiting in [`Kept::holding`].
#[derive(Debug)]
pub struct Kept {
    holding: PathBuf,
    paths: Vec<PathBuf>,
}

impl Kept {
    /// Moves the restart list of `run_dir` and the paths it names into a folder beside
    /// `run_dir`; `None` when there is no list. A folder left by an earlier attempt
    /// that never put its paths back is taken as it is when `run_dir` has no list of
    /// its own, and replaced otherwise.
    pub fn set_aside(run_dir: &Path) -> std::io::Result<Option<Self>> {
        let holding = holding_of(run_dir);
        let list = run_dir.join(RESTART_LIST);
        if !list.exists() {
            if !holding.join(RESTART_LIST).exists() {
                return Ok(None);
            }
            let mut paths = read_list(&holding.join(RESTART_LIST))?;
            paths.push(PathBuf::from(RESTART_LIST));
            return Ok(Some(Self { holding, paths }));
        }
        if holding.exists() {
            std::fs::remove_dir_all(&holding)?;
        }
        let mut paths = read_list(&list)?;
        paths.retain(|p| run_dir.join(p).exists());
        paths.push(PathBuf::from(RESTART_LIST));
        for path in &paths {
            let to = holding.join(path);
            if let Some(parent) = to.parent() {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::rename(run_dir.join(path), to)?;
        }
        Ok(Some(Self { holding, paths }))
    }

    /// Puts the kept paths back into `run_dir` over what a render wrote there (a
    /// folder it created empty, or the same input files).
    pub fn put_back(self, run_dir: &Path) -> std::io::Result<()> {
        for path in &self.paths {
            let from = self.holding.join(path);
            if !from.exists() {
                continue;
            }
            let to = run_dir.join(path);
            match std::fs::symlink_metadata(&to) {
                Ok(meta) if meta.is_dir() => std::fs::remove_dir_all(&to)?,
                Ok(_) => std::fs::remove_file(&to)?,
                Err(_) => {}
            }
            if let Some(parent) = to.parent() {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::rename(from, to)?;
        }
        std::fs::remove_dir_all(&self.holding)
    }

    /// Drops the kept paths (the job will not be run again from them).
    pub fn discard(self) -> std::io::Result<()> {
        std::fs::remove_dir_all(&self.holding)
    }
}

/// The folder beside `run_dir` where its kept paths wait: `<run_dir>.kept`.
fn holding_of(run_dir: &Path) -> PathBuf {
    let mut name = run_dir.file_name().unwrap_or_default().to_os_string();
    name.push(".kept");
    run_dir.with_file_name(name)
}

/// The paths a restart list names: relative paths that stay inside the run directory
/// (no `..`, no root); other lines are ignored.
fn read_list(list: &Path) -> std::io::Result<Vec<PathBuf>> {
    let text = std::fs::read_to_string(list)?;
    Ok(text
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty())
        .map(PathBuf::from)
        .filter(|p| p.components().all(|c| matches!(c, Component::Normal(_))))
        .filter(|p| p != Path::new(RESTART_LIST))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, text: &str) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }

    #[test]
    fn listed_paths_wait_beside_the_run_directory_and_come_back_over_a_fresh_render() {
        let root = tempfile::tempdir().unwrap();
        let run_dir = root.path().join("p001r0");
        write(
            &run_dir.join(RESTART_LIST),
            "post\nlog.native\n../escape\n/abs\n",
        );
        write(&run_dir.join("post/restart.orch-dem"), "state");
        write(&run_dir.join("post/crossings.csv"), "rows");
        write(&run_dir.join("log.native"), "log");
        write(&run_dir.join("hopper.toml"), "deck");
        let kept = Kept::set_aside(&run_dir).unwrap().unwrap();
        assert!(!run_dir.join("post").exists());
        assert!(!run_dir.join(RESTART_LIST).exists());
        assert!(root
            .path()
            .join("p001r0.kept/post/restart.orch-dem")
            .exists());
        // A fresh render: the directory emptied, the deck and an empty post/ written.
        std::fs::remove_dir_all(&run_dir).unwrap();
        write(&run_dir.join("hopper.toml"), "deck");
        std::fs::create_dir_all(run_dir.join("post")).unwrap();
        kept.put_back(&run_dir).unwrap();
        let read = |p: &str| std::fs::read_to_string(run_dir.join(p)).unwrap();
        assert_eq!(read("post/restart.orch-dem"), "state");
        assert_eq!(read("post/crossings.csv"), "rows");
        assert_eq!(read("log.native"), "log");
        assert_eq!(read("hopper.toml"), "deck");
        assert!(run_dir.join(RESTART_LIST).exists());
        assert!(!root.path().join("p001r0.kept").exists());
    }

    #[test]
    fn without_a_restart_list_nothing_is_kept_and_a_left_holding_folder_is_taken_up() {
        let root = tempfile::tempdir().unwrap();
        let run_dir = root.path().join("p002r1");
        write(&run_dir.join("log.native"), "log");
        assert!(Kept::set_aside(&run_dir).unwrap().is_none());
        assert!(run_dir.join("log.native").exists());
        // An attempt that set its paths aside and died before putting them back.
        write(
            &root.path().join("p002r1.kept").join(RESTART_LIST),
            "log.native\n",
        );
        write(&root.path().join("p002r1.kept/log.native"), "kept log");
        let kept = Kept::set_aside(&run_dir).unwrap().unwrap();
        kept.put_back(&run_dir).unwrap();
        assert_eq!(
            std::fs::read_to_string(run_dir.join("log.native")).unwrap(),
            "kept log"
        );
    }
}
