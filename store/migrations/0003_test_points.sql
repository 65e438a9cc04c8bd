-- Held-out test points: run like design points, left out of the fit, used to measure
-- the surface's prediction error (σ_test_rel and its R²).
ALTER TABLE points ADD COLUMN purpose TEXT NOT NULL DEFAULT 'design' CHECK (purpose IN ('design', 'test'));
ALTER TABLE fits ADD COLUMN test_runs INTEGER NOT NULL DEFAULT 0;
ALTER TABLE fits ADD COLUMN sigma_test REAL;
ALTER TABLE fits ADD COLUMN r2_test REAL;
