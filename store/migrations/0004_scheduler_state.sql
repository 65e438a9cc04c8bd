-- orch store, version 4: what a batch scheduler last said about a job's current attempt
-- (e.g. "PENDING (Priority)", "RUNNING on n1"), shown by `orch status`. NULL for local jobs.
ALTER TABLE jobs ADD COLUMN scheduler_state TEXT;
