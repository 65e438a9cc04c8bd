-- Fidelity levels (`fidelity:`): the level a point runs at, 0 the cheapest and the only
-- one of a study without levels. A higher level's point is a nested twin of a point of
-- the level below, run by that level's solver and parameters.
ALTER TABLE points ADD COLUMN fidelity INTEGER NOT NULL DEFAULT 0;
