//! The commands that read a study without running it: `orch logs`, `orch fit`,
//! `orch export` and `orch report`, and the files they write.

use super::*;

pub(super) async fn logs(
    project_dir: Option<&Path>,
    reference: &str,
    tail: usize,
) -> anyhow::Result<i32> {
    let dirs = project::discover(project_dir);
    let (study_name, job_name) = match reference.split_once('/') {
        Some((s, j)) => (Some(s), j),
        None => (None, reference),
    };
    let mut matches = Vec::new();
    for (_, store) in project::open_all(&dirs).await? {
        for study in store.studies().await? {
            if study_name.is_some_and(|s| s != study.name) {
                continue;
            }
            for job in store.jobs(study.id).await? {
                if job.name == job_name {
                    matches.push((store.clone(), study.clone(), job));
                }
            }
        }
    }
    let (store, study, job) = match matches.len() {
        1 => matches.remove(0),
        0 => {
            return Err(input_error(format!(
                "no job `{reference}`; `orch status STUDY` lists a study's jobs"
            )))
        }
        _ => {
            return Err(input_error(format!(
                "`{job_name}` is in several studies; name it as STUDY/{job_name}"
            )))
        }
    };
    // The log a job's solver writes: a built-in stage's, its DEM solver's, or the one a
    // user's own deck or script declares (`log:`), read from the stored study.
    let stage = job.stage_kind();
    // A built-in stage's own log, `Some(None)` for one that reruns the design; `None`
    // for a design job or a stage the study file configures (a script).
    let built_in = stage
        .and_then(orch_adapters::stage_for)
        .map(|stage| stage.log_file());
    let configured_stage = stage.is_some() && built_in.is_none();
    let solver = orch_adapters::solver_for(&study.solver).filter(|_| !configured_stage);
    let log_file: Option<String> = match (built_in.flatten(), solver) {
        (Some(log), _) => Some(log.to_string()),
        (None, Some(solver)) => Some(solver.log_file.to_string()),
        (None, None) => stored_study(&store, &study).await?.ok().map(|stored| {
            match stage
                .and_then(|kind| stored.stage(kind))
                .and_then(|config| config.stage.log_file())
            {
                Some(log) => log.to_string(),
                None => stored.simulation.command().log_file,
            }
        }),
    };
    outln!(
        "job {}/{}: {} after {} attempt(s){}",
        study.name,
        job.name,
        job.state,
        job.attempts,
        job.error
            .as_ref()
            .map(|e| format!("; {e}"))
            .unwrap_or_default()
    )?;
    let run_dir = PathBuf::from(&job.run_dir);
    let mut files = vec![
        crate::executor::STDOUT_FILE.to_string(),
        crate::executor::STDERR_FILE.to_string(),
    ];
    match log_file {
        Some(log) if !files.contains(&log) => files.push(log),
        Some(_) => {}
        None => outln!(
            "(the study's solver log is unknown to this orch: `orch status {}` shows its run directory)",
            study.name
        )?,
    }
    for file in &files {
        let path = run_dir.join(file);
        outln!("==> {} <==", path.display())?;
        if let Err(e) = show_lines(&path, tail) {
            outln!("(cannot read: {e})")?;
        }
    }
    Ok(exit_codes::SUCCESS)
}

/// Prints the last `tail` lines of the file at `path` (all with 0), holding at most a
/// line at a time for the whole file and the tail window for its end: a solver's log
/// may be gigabytes.
pub(super) fn show_lines(path: &Path, tail: usize) -> std::io::Result<()> {
    use std::io::BufRead;
    if tail == 0 {
        let reader = std::io::BufReader::new(std::fs::File::open(path)?);
        for line in reader.split(b'\n') {
            outln!("{}", String::from_utf8_lossy(&line?))?;
        }
        return Ok(());
    }
    let windows = crate::tail::Windows::read(path, crate::tail::WINDOW)?;
    let lines: Vec<&str> = match &windows.tail {
        Some(end) => end.lines().collect(),
        None => windows.head.lines().collect(),
    };
    for line in &lines[lines.len().saturating_sub(tail)..] {
        outln!("{line}")?;
    }
    Ok(())
}

pub(super) async fn show_fits(
    project_dir: Option<&Path>,
    name: &str,
    round: Option<i64>,
) -> anyhow::Result<i32> {
    let (store, row) = find(project_dir, name).await?;
    let rounds = store.rounds(row.id).await?;
    let analysed: Vec<_> = rounds.iter().filter(|r| !r.fits.is_empty()).collect();
    let chosen = match round {
        Some(n) => analysed.iter().find(|r| r.round == n).copied(),
        None => analysed.last().copied(),
    };
    let Some(chosen) = chosen else {
        return Err(input_error(format!(
            "study `{name}` has no fitted round{}; surfaces are fitted when a round's jobs are all final",
            round.map(|n| format!(" {n}")).unwrap_or_default()
        )));
    };
    let names: Vec<String> = store
        .factors(row.id)
        .await?
        .into_iter()
        .map(|f| f.name)
        .collect();
    // The report judges each fit from its own response's runs: only those are read.
    let fitted = crate::surfaces::fitted_names(std::slice::from_ref(chosen));
    let runs = crate::surfaces::design_runs_named(&store, row.id, &fitted).await?;
    let round_runs = runs.get(&chosen.round).map(Vec::as_slice).unwrap_or(&[]);
    out!("{}", status::fits_report(chosen, &names, round_runs))?;
    Ok(exit_codes::SUCCESS)
}

/// `orch export`: the runs (or series) table to a file or standard output.
pub(super) async fn export(
    project_dir: Option<&Path>,
    name: &str,
    format: crate::export::Format,
    series: bool,
    output: Option<&Path>,
) -> anyhow::Result<i32> {
    let (store, row) = find(project_dir, name).await?;
    let study = stored_study_to_read(&store, &row).await?.ok();
    if series {
        // Streamed: a study's series can be far larger than its runs.
        let study = study.as_ref();
        match output {
            Some(path) => {
                let file = std::io::BufWriter::new(create_output(path)?);
                let rows = crate::export::write_series(&store, &row, study, format, file)
                    .await
                    .with_context(|| format!("cannot export to {}", path.display()))?;
                errln!("orch: {rows} rows written to {}", path.display());
            }
            None => {
                let stdout = std::io::BufWriter::new(std::io::stdout().lock());
                match crate::export::write_series(&store, &row, study, format, stdout).await {
                    // The reader has gone (`| head`): nobody wants the rest.
                    Err(crate::export::ExportError::Write(e))
                        if e.kind() == std::io::ErrorKind::BrokenPipe => {}
                    other => {
                        other?;
                    }
                }
            }
        }
        return Ok(exit_codes::SUCCESS);
    }
    // Written a row at a time, as the series are.
    let study = study.as_ref();
    match output {
        Some(path) => {
            let file = std::io::BufWriter::new(create_output(path)?);
            let rows = crate::export::write_runs(&store, &row, study, format, file)
                .await
                .with_context(|| format!("cannot export to {}", path.display()))?;
            errln!("orch: {rows} rows written to {}", path.display());
        }
        None => {
            let stdout = std::io::BufWriter::new(std::io::stdout().lock());
            match crate::export::write_runs(&store, &row, study, format, stdout).await {
                Err(crate::export::ExportError::Write(e))
                    if e.kind() == std::io::ErrorKind::BrokenPipe => {}
                other => {
                    other?;
                }
            }
        }
    }
    Ok(exit_codes::SUCCESS)
}

/// `orch report`: writes the HTML report and prints its path.
pub(super) async fn report(
    project_dir: Option<&Path>,
    name: &str,
    output: Option<PathBuf>,
) -> anyhow::Result<i32> {
    let (store, row) = find(project_dir, name).await?;
    let study = stored_study_to_read(&store, &row).await?.ok();
    let html = crate::report::render(&store, &row, study.as_ref()).await?;
    let path = output.unwrap_or_else(|| {
        store
            .path()
            .parent()
            .unwrap_or(Path::new("."))
            .join("reports")
            .join(format!("{name}.html"))
    });
    write_output(&path, html.as_bytes())?;
    let path = std::path::absolute(&path).unwrap_or(path);
    outln!("{}", path.display())?;
    Ok(exit_codes::SUCCESS)
}

/// Writes `bytes` to `path`, creating its folder; a failure says what to do.
pub(super) fn write_output(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    use std::io::Write;
    create_output(path)?.write_all(bytes).with_context(|| {
        format!(
            "cannot write {}; check its folder's permissions or choose another path with -o",
            path.display()
        )
    })
}

/// Creates (or empties) the file `path`, creating its folder; a failure says what to do.
pub(super) fn create_output(path: &Path) -> anyhow::Result<std::fs::File> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| {
            format!(
                "cannot create the folder {}; choose another path with -o",
                dir.display()
            )
        })?;
    }
    std::fs::File::create(path).with_context(|| {
        format!(
            "cannot write {}; check its folder's permissions or choose another path with -o",
            path.display()
        )
    })
}
