//! Project directories: where the store and run directories of studies live.
//!
//! `orch submit path/study.yaml` keeps its project in `path/.orch/` (or
//! `--project-dir`). Commands that name a study rather than a file look in
//! `--project-dir` if given, else in `./.orch` and in `./*/.orch`, so that
//! `orch submit jobs/quickstart.yaml` followed by `orch status` works from the
//! repository root.

use std::path::{Path, PathBuf};

use crate::store::{Store, StoreError, StudyRow};

/// Name of a project directory beside a study file.
pub const PROJECT_DIR_NAME: &str = ".orch";
/// Run directories live under this folder of the project directory.
pub const RUNS_DIR_NAME: &str = "runs";

/// The project directory of a study file, as an absolute path (run directories are
/// stored by absolute path, so any working directory finds them).
pub fn for_study_file(study_file: &Path, project_dir: Option<&Path>) -> std::io::Result<PathBuf> {
    let dir = match project_dir {
        Some(dir) => dir.to_path_buf(),
        None => {
            let parent = study_file.parent().filter(|p| !p.as_os_str().is_empty());
            parent.unwrap_or(Path::new(".")).join(PROJECT_DIR_NAME)
        }
    };
    std::path::absolute(dir)
}

/// Project directories to look in when a command names no study file.
pub fn discover(project_dir: Option<&Path>) -> Vec<PathBuf> {
    if let Some(dir) = project_dir {
        return vec![dir.to_path_buf()];
    }
    let mut found = Vec::new();
    let here = Path::new(PROJECT_DIR_NAME);
    if here.is_dir() {
        found.push(here.to_path_buf());
    }
    if let Ok(entries) = std::fs::read_dir(".") {
        let mut nested: Vec<PathBuf> = entries
            .filter_map(Result::ok)
            .map(|e| e.path().join(PROJECT_DIR_NAME))
            .filter(|p| p.is_dir())
            .collect();
        nested.sort();
        found.extend(nested);
    }
    found
}

/// Opens every existing store among `dirs`.
pub async fn open_all(dirs: &[PathBuf]) -> Result<Vec<(PathBuf, Store)>, StoreError> {
    let mut stores = Vec::new();
    for dir in dirs {
        if let Some(store) = Store::open_existing(dir).await? {
            stores.push((dir.clone(), store));
        }
    }
    Ok(stores)
}

/// The store and row of the study called `name` among `dirs`.
pub async fn find_study(
    dirs: &[PathBuf],
    name: &str,
) -> Result<Option<(Store, StudyRow)>, StoreError> {
    for (_, store) in open_all(dirs).await? {
        if let Some(row) = store.study_by_name(name).await? {
            return Ok(Some((store, row)));
        }
    }
    Ok(None)
}
