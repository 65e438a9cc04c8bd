-- orch store, version 8: the history of `orch compare`, the comparison of the native
-- kernel against reference solvers on a suite of cases. One row per run of the suite,
-- keyed by its time, the git commit and the solvers' versions; per response the means,
-- standard errors, the relative difference with its interval and the verdict; per case
-- and solver the throughput. A missing figure (a run gave no value) is NULL.
CREATE TABLE comparisons (
    id INTEGER PRIMARY KEY,
    started_at REAL NOT NULL,
    wall_time_s REAL NOT NULL,
    git_commit TEXT,
    suite TEXT NOT NULL,
    quick INTEGER NOT NULL CHECK (quick IN (0, 1)),
    perturbation TEXT NOT NULL DEFAULT '',
    solver_versions TEXT NOT NULL,
    confidence REAL NOT NULL,
    verdict TEXT NOT NULL CHECK (verdict IN ('agree', 'inconclusive', 'regression'))
);
CREATE INDEX comparisons_by_time ON comparisons (started_at);

CREATE TABLE comparison_responses (
    comparison_id INTEGER NOT NULL REFERENCES comparisons (id) ON DELETE CASCADE,
    case_name TEXT NOT NULL,
    response TEXT NOT NULL,
    reference_solver TEXT NOT NULL,
    native_mean REAL,
    native_standard_error REAL,
    native_runs INTEGER NOT NULL,
    reference_mean REAL,
    reference_standard_error REAL,
    reference_runs INTEGER NOT NULL,
    relative_difference REAL,
    interval_low REAL,
    interval_high REAL,
    tolerance REAL NOT NULL,
    verdict TEXT NOT NULL CHECK (verdict IN ('agree', 'inconclusive', 'regression')),
    PRIMARY KEY (comparison_id, case_name, response, reference_solver)
);

CREATE TABLE comparison_speeds (
    comparison_id INTEGER NOT NULL REFERENCES comparisons (id) ON DELETE CASCADE,
    case_name TEXT NOT NULL,
    solver TEXT NOT NULL,
    particle_steps_per_s REAL,
    runs INTEGER NOT NULL,
    PRIMARY KEY (comparison_id, case_name, solver)
);
