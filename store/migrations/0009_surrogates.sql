-- orch store, version 9: which surrogate each fit is and why, and what it says about
-- its own error.
-- * fits.model names the chosen surrogate for people ('quadratic, 5 of 6 terms',
--   'kriging, Matérn 5/2, constant trend'); fits.spec rebuilds it without a search
--   (JSON: the polynomial's kept terms, or the Kriging's kernel, trend and fitted
--   hyperparameters). Fits written before version 9 keep NULL there and are the full
--   polynomial their basis and order name.
-- * fits.lack_of_fit_*: the F test of the fit against the pure error of replicates.
-- * fit_candidates: every surrogate the automatic model choice compared, with its
--   leave-one-out RMSE (response units) and whether it was chosen.
-- * sensitivities: first-order and total Sobol indices of each factor over the round's
--   box, with their 95 % intervals.
-- * optima.interval_*: the 95 % prediction interval of the objective at the optimum
--   (surrogate error and run-to-run noise).
-- * uncertainty.total_*: the spread at the optimum when the surrogate's own error is
--   sampled within the Monte Carlo, beside the input-only spread of version 2.
ALTER TABLE fits ADD COLUMN model TEXT;
ALTER TABLE fits ADD COLUMN spec TEXT;
ALTER TABLE fits ADD COLUMN lack_of_fit_f REAL;
ALTER TABLE fits ADD COLUMN lack_of_fit_p REAL;
ALTER TABLE fits ADD COLUMN lack_of_fit_dof INTEGER;
ALTER TABLE fits ADD COLUMN pure_error_dof INTEGER;

CREATE TABLE fit_candidates (
    fit_id      INTEGER NOT NULL REFERENCES fits(id) ON DELETE CASCADE,
    idx         INTEGER NOT NULL,
    model       TEXT NOT NULL,
    parameters  INTEGER NOT NULL,
    loo_rmse    REAL,
    chosen      INTEGER NOT NULL CHECK (chosen IN (0, 1)),
    note        TEXT,
    PRIMARY KEY (fit_id, idx)
);

CREATE TABLE sensitivities (
    fit_id      INTEGER NOT NULL REFERENCES fits(id) ON DELETE CASCADE,
    factor_idx  INTEGER NOT NULL,
    method      TEXT NOT NULL,
    first       REAL NOT NULL,
    first_low   REAL NOT NULL,
    first_high  REAL NOT NULL,
    total       REAL NOT NULL,
    total_low   REAL NOT NULL,
    total_high  REAL NOT NULL,
    PRIMARY KEY (fit_id, factor_idx)
);

ALTER TABLE optima ADD COLUMN interval_low REAL;
ALTER TABLE optima ADD COLUMN interval_high REAL;

ALTER TABLE uncertainty ADD COLUMN total_mean REAL;
ALTER TABLE uncertainty ADD COLUMN total_std REAL;
ALTER TABLE uncertainty ADD COLUMN total_q025 REAL;
ALTER TABLE uncertainty ADD COLUMN total_q975 REAL;
ALTER TABLE uncertainty ADD COLUMN total_q05 REAL;
ALTER TABLE uncertainty ADD COLUMN total_q95 REAL;
