-- orch store, version 10: the Pareto front of a multi-objective round.
-- * pareto_points: one row per point of the front of the round's surrogates, idx 0
--   at the first objective's best end, in order along the front. compromise = 1 marks
--   the point recorded in optima (the one closest to the utopia point, each
--   objective scaled by its range over the front).
-- * pareto_objectives: each objective's predicted value at a point, objective_idx in
--   the order of the study file's `objectives:`, with its response and goal.
-- * pareto_factors: the point's factor values, coded in the round's box and natural,
--   factor_idx in the order of the study's factors (as optimum_values).
-- Rounds of single-objective studies, and rounds written before version 10, have no
-- rows here.
CREATE TABLE pareto_points (
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    round       INTEGER NOT NULL,
    idx         INTEGER NOT NULL,
    compromise  INTEGER NOT NULL CHECK (compromise IN (0, 1)),
    PRIMARY KEY (study_id, round, idx)
);

CREATE TABLE pareto_objectives (
    study_id       INTEGER NOT NULL,
    round          INTEGER NOT NULL,
    idx            INTEGER NOT NULL,
    objective_idx  INTEGER NOT NULL,
    response       TEXT NOT NULL,
    goal           TEXT NOT NULL CHECK (goal IN ('minimise', 'maximise')),
    value          REAL NOT NULL,
    PRIMARY KEY (study_id, round, idx, objective_idx),
    FOREIGN KEY (study_id, round, idx) REFERENCES pareto_points(study_id, round, idx) ON DELETE CASCADE
);

CREATE TABLE pareto_factors (
    study_id    INTEGER NOT NULL,
    round       INTEGER NOT NULL,
    idx         INTEGER NOT NULL,
    factor_idx  INTEGER NOT NULL,
    coded       REAL NOT NULL,
    natural     REAL NOT NULL,
    PRIMARY KEY (study_id, round, idx, factor_idx),
    FOREIGN KEY (study_id, round, idx) REFERENCES pareto_points(study_id, round, idx) ON DELETE CASCADE
);
