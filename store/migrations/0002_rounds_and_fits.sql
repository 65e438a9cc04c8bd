-- Rounds of a study and the metamodel stage's results.

-- The factor box of every round (round 0 is the study file's).
CREATE TABLE round_factors (
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    round       INTEGER NOT NULL,
    idx         INTEGER NOT NULL,
    min         REAL NOT NULL,
    max         REAL NOT NULL,
    PRIMARY KEY (study_id, round, idx)
);
INSERT INTO round_factors (study_id, round, idx, min, max)
    SELECT study_id, 0, idx, min, max FROM factors;

-- One response surface per round and response; `error` when it could not be fitted.
CREATE TABLE fits (
    id              INTEGER PRIMARY KEY,
    study_id        INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    round           INTEGER NOT NULL,
    response        TEXT NOT NULL,
    basis           TEXT NOT NULL,
    ord             INTEGER NOT NULL,
    runs            INTEGER NOT NULL,
    terms           INTEGER NOT NULL,
    r2              REAL,
    adjusted_r2     REAL,
    sigma_cross     REAL,
    r2_cross        REAL,
    press           REAL,
    residual_std    REAL,
    error           TEXT,
    UNIQUE (study_id, round, response)
);

CREATE TABLE fit_terms (
    fit_id      INTEGER NOT NULL REFERENCES fits(id) ON DELETE CASCADE,
    idx         INTEGER NOT NULL,
    name        TEXT NOT NULL,
    coefficient REAL NOT NULL,
    std_error   REAL,
    t_value     REAL,
    PRIMARY KEY (fit_id, idx)
);

-- The optimum of the objective's surface in a round's box, and what it predicts.
CREATE TABLE optima (
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    round       INTEGER NOT NULL,
    response    TEXT NOT NULL,
    goal        TEXT NOT NULL,
    value       REAL NOT NULL,
    exact       INTEGER NOT NULL,
    PRIMARY KEY (study_id, round)
);

CREATE TABLE optimum_values (
    study_id    INTEGER NOT NULL,
    round       INTEGER NOT NULL,
    factor_idx  INTEGER NOT NULL,
    coded       REAL NOT NULL,
    natural     REAL NOT NULL,
    PRIMARY KEY (study_id, round, factor_idx),
    FOREIGN KEY (study_id, round) REFERENCES optima(study_id, round) ON DELETE CASCADE
);

-- Monte Carlo spread of the objective at the optimum under uncertain parameters.
CREATE TABLE uncertainty (
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    round       INTEGER NOT NULL,
    response    TEXT NOT NULL,
    samples     INTEGER NOT NULL,
    seed        INTEGER NOT NULL,
    mean        REAL NOT NULL,
    std         REAL NOT NULL,
    q025        REAL NOT NULL,
    q975        REAL NOT NULL,
    q05         REAL NOT NULL,
    q95         REAL NOT NULL,
    PRIMARY KEY (study_id, round)
);

-- What the analysis of a round decided: the next round, or why the study stops.
CREATE TABLE proposals (
    study_id    INTEGER NOT NULL REFERENCES studies(id) ON DELETE CASCADE,
    round       INTEGER NOT NULL,
    decision    TEXT NOT NULL CHECK (decision IN ('next_round', 'converged', 'last_round', 'no_optimum')),
    note        TEXT NOT NULL,
    PRIMARY KEY (study_id, round)
);
