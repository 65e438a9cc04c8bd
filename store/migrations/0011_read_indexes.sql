-- orch store, version 11: an index for the commands that read a whole study.
-- * jobs_by_study: a study's jobs in id order. `orch status`, `export`, `fit`, the
--   report and the round analysis read the jobs and their responses (joined on the
--   jobs) in that order; with only jobs_by_state (study_id, state) SQLite sorted
--   every row it read in a temporary B-tree.
CREATE INDEX jobs_by_study ON jobs (study_id);
