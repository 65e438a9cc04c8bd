-- Run identity and reuse. A job's identity is the SHA-256 of everything that decides
-- its result (rendered files, program and version, seed, cores where they matter),
-- recorded when it is rendered. A job whose identity already succeeded in the project
-- is not run again: it is recorded as reused from that run (`reused_from_job`, and the
-- run's `study/job` name, kept when that study is deleted), with a copy of its results.
-- Jobs of earlier versions have no identity: they are never reused, and each counts as
-- a run of its own.
ALTER TABLE jobs ADD COLUMN identity TEXT;
ALTER TABLE jobs ADD COLUMN reused_from_job INTEGER REFERENCES jobs(id) ON DELETE SET NULL;
ALTER TABLE jobs ADD COLUMN reused_from TEXT;
CREATE INDEX jobs_by_identity ON jobs (identity, state) WHERE identity IS NOT NULL;

-- The runs `orch compare` made, by identity, with their responses as JSON: a later
-- comparison takes them instead of running the same deck again.
CREATE TABLE comparison_runs (
    identity    TEXT PRIMARY KEY,
    responses   TEXT NOT NULL,
    created_at  REAL NOT NULL
);
