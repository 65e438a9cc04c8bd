//! Helpers: find the binary, make a project, run `orch`, read its status and store.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime};

use serde_json::Value;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Newest modification time of the files under `dir` that go into the binary (test
/// modules and snapshots do not).
fn newest_source(dir: &Path) -> SystemTime {
    let mut newest = SystemTime::UNIX_EPOCH;
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if name == "tests.rs" || name.ends_with("_tests.rs") || name == "snapshots" {
            continue;
        }
        let time = if path.is_dir() {
            newest_source(&path)
        } else {
            entry
                .metadata()
                .and_then(|m| m.modified())
                .unwrap_or(SystemTime::UNIX_EPOCH)
        };
        newest = newest.max(time);
    }
    newest
}

/// The `orch` binary under test; refuses one older than the sources.
pub fn orch_bin() -> PathBuf {
    if let Some(path) = std::env::var_os("ORCH_BIN") {
        return PathBuf::from(path);
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"));
    let bin = target.join("debug/orch");
    let built = std::fs::metadata(&bin)
        .and_then(|m| m.modified())
        .unwrap_or_else(|_| {
            panic!(
                "no orch binary at {}: build it with `cargo build --bin orch` (scripts/test does)",
                bin.display()
            )
        });
    for dir in [
        "orchestrator/src",
        "adapters/src",
        "compare/src",
        "executor/src",
        "page/src",
        "store/src",
        "store/migrations",
        "study/src",
        "dem/src",
        "granular/src",
        "metamodel/src",
        "templates",
    ] {
        assert!(
            newest_source(&root().join(dir)) <= built,
            "the orch binary at {} is older than {dir}: rebuild it with `cargo build --bin orch` (scripts/test does)",
            bin.display()
        );
    }
    bin
}

/// True when `program` (of Debian package `package`, named `solver` in messages) is
/// on PATH. Missing under CI=true is a failure, not a skip.
pub fn require_program(solver: &str, program: &str, package: &str) -> bool {
    let found = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).any(|d| d.join(program).is_file()))
        .unwrap_or(false);
    if !found {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "{solver} is not installed but CI=true: scripts/test must install it (apt-get install -y {package})"
        );
        eprintln!("SKIPPED: {solver} is not installed (apt-get install -y {package}); this test did not run");
    }
    found
}

/// True when LIGGGHTS is installed (see [`require_program`]).
pub fn require_liggghts() -> bool {
    require_program("LIGGGHTS", "liggghts", "liggghts")
}

/// True when YADE is installed (see [`require_program`]).
pub fn require_yade() -> bool {
    require_program("YADE", "yade", "yade")
}

/// True when OpenFOAM is installed (see [`require_program`]).
pub fn require_openfoam() -> bool {
    require_program("OpenFOAM", "pimpleFoam", "openfoam")
}

static SOLVER_LOCK: Mutex<()> = Mutex::new(());

/// Serialises tests that run solvers, so each gets the machine's cores.
pub fn solver_lock() -> MutexGuard<'static, ()> {
    SOLVER_LOCK
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

static SLURM_LOCK: Mutex<()> = Mutex::new(());

/// Serialises tests that use the Slurm test cluster: one of them takes a node down.
pub fn slurm_lock() -> MutexGuard<'static, ()> {
    SLURM_LOCK
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A temporary project directory and the files of one test.
pub struct Project {
    /// Holds study files and templates.
    pub dir: tempfile::TempDir,
    /// Extra environment of every `orch` it runs (`SLURM_CONF`, `PATH`).
    pub env: Vec<(String, std::ffi::OsString)>,
}

impl Project {
    /// A fresh, empty project.
    pub fn new() -> Project {
        Project {
            dir: tempfile::tempdir().unwrap(),
            env: Vec::new(),
        }
    }

    /// A fresh project whose `orch` talks to the Slurm cluster of `slurm_conf`.
    pub fn on_slurm(slurm_conf: &Path) -> Project {
        let mut project = Project::new();
        project
            .env
            .push(("SLURM_CONF".into(), slurm_conf.as_os_str().to_owned()));
        project
    }

    /// Puts a fake program `name` (a shell script of `body`) first on the PATH of every
    /// `orch` this project runs. For tests of supervision only: fakes never stand in
    /// for a solver's results.
    pub fn fake_program(&mut self, name: &str, body: &str) {
        use std::os::unix::fs::PermissionsExt;
        let bin = self.dir.path().join("fake-bin");
        std::fs::create_dir_all(&bin).unwrap();
        let path = bin.join(name);
        std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
        if !self.env.iter().any(|(k, _)| k == "PATH") {
            let mut paths = vec![bin];
            paths.extend(std::env::split_paths(
                &std::env::var_os("PATH").unwrap_or_default(),
            ));
            self.env
                .push(("PATH".into(), std::env::join_paths(paths).unwrap()));
        }
    }

    /// The project directory `orch` uses.
    pub fn project_dir(&self) -> PathBuf {
        self.dir.path().join(".orch")
    }

    /// Writes a file into the test directory and returns its path.
    pub fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    /// `orch --project-dir <project> ARGS`, run in the test directory.
    pub fn orch(&self, args: &[&str]) -> Command {
        let mut command = Command::new(orch_bin());
        command
            .arg("--project-dir")
            .arg(self.project_dir())
            .args(args)
            .envs(self.env.iter().map(|(k, v)| (k, v)))
            .current_dir(self.dir.path());
        command
    }

    /// Runs `orch ARGS` to the end.
    pub fn run(&self, args: &[&str]) -> Output {
        self.orch(args).output().unwrap()
    }

    /// `orch status STUDY --json`.
    pub fn status(&self, study: &str) -> Value {
        let output = self.run(&["status", study, "--json"]);
        assert!(
            output.status.success(),
            "orch status failed: {}",
            text(&output.stderr)
        );
        serde_json::from_slice(&output.stdout).unwrap()
    }

    /// Polls `orch status STUDY --json` until `done` holds or `limit` passes.
    pub fn wait_for(&self, study: &str, limit: Duration, done: impl Fn(&Value) -> bool) -> Value {
        let deadline = Instant::now() + limit;
        loop {
            let output = self.run(&["status", study, "--json"]);
            if output.status.success() {
                let status: Value = serde_json::from_slice(&output.stdout).unwrap();
                if done(&status) {
                    return status;
                }
            }
            assert!(
                Instant::now() < deadline,
                "gave up waiting for study {study} after {limit:?}"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// Runs one statement that writes against the project's store with its CHECK
    /// constraints off, to make it look damaged or written by another version; no
    /// `orch` may be running.
    pub fn execute(&self, sql: &str) {
        let url = format!("sqlite://{}", self.project_dir().join("orch.db").display());
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        runtime.block_on(async {
            use sqlx::Connection;
            let mut connection = sqlx::SqliteConnection::connect(&url).await.unwrap();
            // The schema's CHECKs would refuse the damage this method exists to cause.
            sqlx::query("PRAGMA ignore_check_constraints = ON")
                .execute(&mut connection)
                .await
                .unwrap();
            sqlx::query(sql).execute(&mut connection).await.unwrap();
            connection.close().await.unwrap();
        });
    }

    /// The run directories of the jobs of `study`, in job order.
    pub fn run_dirs(&self, study: &str) -> Vec<PathBuf> {
        self.try_run_dirs(study).unwrap()
    }

    /// The run directories of a study's jobs, or the store's error: for polling a
    /// store that another process is still creating (its file exists before its tables).
    pub fn try_run_dirs(&self, study: &str) -> Result<Vec<PathBuf>, sqlx::Error> {
        Ok(self
            .try_query(&format!(
            "SELECT j.run_dir FROM jobs j JOIN studies s ON s.id = j.study_id WHERE s.name = '{study}' ORDER BY j.id"
        ))?
        .into_iter()
        .map(|row| PathBuf::from(&row[0]))
        .collect())
    }

    /// Rows of a query against the project's store.
    pub fn query(&self, sql: &str) -> Vec<Vec<String>> {
        self.try_query(sql).unwrap()
    }

    /// Rows of a query against the project's store, or the store's error.
    pub fn try_query(&self, sql: &str) -> Result<Vec<Vec<String>>, sqlx::Error> {
        let url = format!(
            "sqlite://{}?mode=ro",
            self.project_dir().join("orch.db").display()
        );
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        runtime.block_on(async {
            use sqlx::Row;
            let pool = sqlx::SqlitePool::connect(&url).await?;
            let rows = sqlx::query(sql).fetch_all(&pool).await;
            pool.close().await;
            let rows = rows?;
            let out = rows
                .iter()
                .map(|row| {
                    (0..row.columns().len())
                        .map(|i| {
                            row.try_get::<String, _>(i)
                                .or_else(|_| row.try_get::<f64, _>(i).map(|v| format!("{v:e}")))
                                .or_else(|_| row.try_get::<i64, _>(i).map(|v| v.to_string()))
                                .unwrap_or_else(|_| "NULL".into())
                        })
                        .collect()
                })
                .collect();
            Ok(out)
        })
    }
}

/// Lossy UTF-8 of process output.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Runs `program` with `args` in `dir`, as a solver is run by hand; fails the test with
/// its output unless it succeeds, and returns its standard output.
pub fn run_in(dir: &Path, program: &str, args: &[&str]) -> String {
    let output = Command::new(program)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot start {program}: {e}"));
    assert!(
        output.status.success(),
        "{program} {} failed in {}:\n{}\n{}",
        args.join(" "),
        dir.display(),
        text(&output.stdout),
        text(&output.stderr)
    );
    text(&output.stdout)
}

/// Number of jobs of a status JSON in `state`.
pub fn count(status: &Value, state: &str) -> usize {
    status["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|j| j["state"] == state)
        .count()
}

/// The default LIGGGHTS template's text.
pub fn default_liggghts_template() -> String {
    std::fs::read_to_string(root().join("templates/liggghts/hopper.in.tera")).unwrap()
}

/// Beverloo with the usual constants for the study's spheres: bulk density 0.6 ρ_p,
/// mass-weighted mean diameter of the 4 mm / 2 mm 50/50 mixture (3 mm).
pub fn beverloo(outlet_diameter_m: f64) -> f64 {
    orch_granular::reference::beverloo_rate_kg_per_s(
        0.6 * 2500.0,
        outlet_diameter_m,
        0.003,
        0.58,
        1.5,
    )
}

/// The `slurm.conf` of the test cluster `scripts/slurm up` starts (once per test
/// process; it is left running). None when Slurm cannot be had and CI is not set;
/// under CI=true a cluster that does not come up is a failure, not a skip.
pub fn require_slurm() -> Option<PathBuf> {
    static CLUSTER: std::sync::OnceLock<Result<PathBuf, String>> = std::sync::OnceLock::new();
    let cluster = CLUSTER.get_or_init(|| {
        let output = Command::new(root().join("scripts/slurm"))
            .arg("up")
            .output()
            .map_err(|e| format!("cannot run scripts/slurm: {e}"))?;
        if !output.status.success() {
            return Err(text(&output.stderr));
        }
        let conf = Command::new(root().join("scripts/slurm"))
            .arg("conf")
            .output()
            .map_err(|e| e.to_string())?;
        Ok(PathBuf::from(text(&conf.stdout).trim()))
    });
    match cluster {
        Ok(conf) => Some(conf.clone()),
        Err(why) => {
            assert!(
                std::env::var("CI").as_deref() != Ok("true"),
                "Slurm did not come up but CI=true: scripts/slurm up said:\n{why}"
            );
            eprintln!("SKIPPED: no Slurm test cluster (scripts/slurm up said: {why}); this test did not run");
            None
        }
    }
}

/// `chromium --headless` with the flags that keep it off the network and quiet, its
/// profile in `user_data`.
pub fn headless(user_data: &Path) -> Command {
    let mut command = Command::new("chromium");
    command.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ]);
    command.arg(format!("--user-data-dir={}", user_data.display()));
    command
}

/// The DOM headless Chromium renders from the HTML file `page` (a profile kept in
/// `scratch`), or `None` when Chromium is not installed (a failure under CI=true).
pub fn rendered_dom(page: &Path, scratch: &Path) -> Option<String> {
    if !require_program("Chromium", "chromium", "chromium") {
        return None;
    }
    let dom = headless(&scratch.join("chromium-profile"))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    assert!(dom.status.success(), "{}", text(&dom.stderr));
    Some(text(&dom.stdout))
}
