-- orch store, version 1. Every state of a study and its jobs lives here.
CREATE TABLE studies (
    id              INTEGER PRIMARY KEY,
    name            TEXT NOT NULL UNIQUE,
    solver          TEXT NOT NULL,
    file_path       TEXT NOT NULL,
    file_text       TEXT NOT NULL,
    file_sha256     TEXT NOT NULL,
    template_name   TEXT NOT NULL,
    template_text   TEXT NOT NULL,
    state           TEXT NOT NULL CHECK (state IN ('active', 'interrupted', 'cancelled', 'finished')),
    -- The orch process driving the study (pid and its start time), if any.
    driver_pid      INTEGER,
    driver_started  INTEGER,
    created_at      REAL NOT NULL,
    updated_at      REAL NOT NULL
);

CREATE TABLE factors (
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    idx         INTEGER NOT NULL,
    name        TEXT NOT NULL,
    min         REAL NOT NULL,
    max         REAL NOT NULL,
    unit        TEXT NOT NULL,
    PRIMARY KEY (study_id, idx)
);

CREATE TABLE points (
    id          INTEGER PRIMARY KEY,
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    round       INTEGER NOT NULL,
    idx         INTEGER NOT NULL,
    UNIQUE (study_id, round, idx)
);

CREATE TABLE point_values (
    point_id    INTEGER NOT NULL REFERENCES points(id) ON DELETE CASCADE,
    factor_idx  INTEGER NOT NULL,
    coded       REAL NOT NULL,
    natural     REAL NOT NULL,
    PRIMARY KEY (point_id, factor_idx)
);

CREATE TABLE jobs (
    id              INTEGER PRIMARY KEY,
    study_id        INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    point_id        INTEGER NOT NULL REFERENCES points(id) ON DELETE CASCADE,
    replicate       INTEGER NOT NULL,
    name            TEXT NOT NULL,
    seed            INTEGER NOT NULL,
    state           TEXT NOT NULL CHECK (state IN
                        ('pending', 'rendered', 'submitted', 'running', 'succeeded', 'failed', 'cancelled')),
    attempts        INTEGER NOT NULL DEFAULT 0,
    executor_handle TEXT,
    run_dir         TEXT NOT NULL,
    started_at      REAL,
    finished_at     REAL,
    exit_code       INTEGER,
    error           TEXT,
    UNIQUE (study_id, name)
);
CREATE INDEX jobs_by_state ON jobs (study_id, state);

-- Every transition of every job, for audits ("did anything run twice?").
CREATE TABLE job_events (
    id          INTEGER PRIMARY KEY,
    job_id      INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
    at          REAL NOT NULL,
    from_state  TEXT NOT NULL,
    to_state    TEXT NOT NULL,
    note        TEXT
);

CREATE TABLE responses (
    job_id  INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
    name    TEXT NOT NULL,
    value   REAL NOT NULL,
    PRIMARY KEY (job_id, name)
);

CREATE TABLE series (
    job_id  INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
    name    TEXT NOT NULL,
    t       REAL NOT NULL,
    value   REAL NOT NULL
);
CREATE INDEX series_by_job ON series (job_id, name, t);
