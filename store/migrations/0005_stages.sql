-- orch store, version 5: chained stages. A CFD job (stage 'cfd') runs after the DEM job
-- it reads its inputs from (after_job_id); every other job is a DEM job.
ALTER TABLE jobs ADD COLUMN stage TEXT NOT NULL DEFAULT 'dem' CHECK (stage IN ('dem', 'cfd'));
ALTER TABLE jobs ADD COLUMN after_job_id INTEGER REFERENCES jobs(id) ON DELETE CASCADE;
