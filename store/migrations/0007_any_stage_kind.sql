-- orch store, version 7: a job's stage is any stage kind orch knows (the registry in
-- orch-adapters decides; 'dem' for a design job), no longer only 'dem' or 'cfd', so a
-- new kind of stage needs no migration. SQLite cannot drop a CHECK constraint, but it
-- can drop a column together with its own CHECK: the column is copied, dropped and the
-- copy renamed, which keeps every row and every reference to the table.
ALTER TABLE jobs ADD COLUMN stage_kind TEXT NOT NULL DEFAULT 'dem' CHECK (stage_kind <> '');
UPDATE jobs SET stage_kind = stage;
ALTER TABLE jobs DROP COLUMN stage;
ALTER TABLE jobs RENAME COLUMN stage_kind TO stage;
