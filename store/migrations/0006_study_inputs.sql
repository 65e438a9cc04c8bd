-- Files a study names relative to itself (a custom case's templates and side files),
-- kept as submitted: resume and status use these, never the files on disk.
CREATE TABLE study_inputs (
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    path        TEXT NOT NULL,
    content     BLOB NOT NULL,
    PRIMARY KEY (study_id, path)
);
