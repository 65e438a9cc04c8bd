-- Text factors (`levels: [hertz, hooke]`): a factor's values in the study's order, as a
-- JSON array of strings; NULL for a numeric factor. A text factor's `min` and `max`
-- are 0 and L − 1, and a point's natural value for it is the index of its level.
ALTER TABLE factors ADD COLUMN levels TEXT;
