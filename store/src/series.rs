//! Reading a whole study's time series, for `orch export --series` and reports: a page
//! of jobs at a time, so that what is held in memory does not grow with the study.

use std::collections::BTreeMap;

use super::{query_error, Store, StoreError, PAGE_LEN, ROWS_PER_PAGE};

/// One point of a stored series.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesPoint {
    /// The job's id.
    pub job_id: i64,
    /// The job's name within its study (`p000r0`).
    pub job: String,
    /// The series' name.
    pub series: String,
    /// The abscissa (time or radius).
    pub x: f64,
    /// The value.
    pub value: f64,
}

/// Jobs whose series one page holds.
pub const JOBS_PER_PAGE: usize = 200;

/// A study's series read in pages of [`JOBS_PER_PAGE`] jobs, in job id order; each page
/// in job, series and abscissa order (the index `series_by_job`).
#[derive(Debug, Clone)]
pub struct SeriesPages {
    study_id: i64,
    /// The last job id of the page read before.
    after: i64,
    jobs_per_page: usize,
    done: bool,
}

impl SeriesPages {
    /// The pages of `study_id`, from its first job.
    pub fn of(study_id: i64) -> SeriesPages {
        SeriesPages::with_page_size(study_id, JOBS_PER_PAGE)
    }

    /// The pages of `study_id`, `jobs_per_page` jobs each (at least one).
    pub fn with_page_size(study_id: i64, jobs_per_page: usize) -> SeriesPages {
        SeriesPages {
            study_id,
            after: i64::MIN,
            jobs_per_page: jobs_per_page.max(1),
            done: false,
        }
    }

    /// The series points of the next page of jobs (empty for a page of jobs without
    /// series), or `None` after the last job.
    pub async fn next(&mut self, store: &Store) -> Result<Option<Vec<SeriesPoint>>, StoreError> {
        if self.done {
            return Ok(None);
        }
        let ids: Vec<(i64,)> =
            sqlx::query_as("SELECT id FROM jobs WHERE study_id = ? AND id > ? ORDER BY id LIMIT ?")
                .bind(self.study_id)
                .bind(self.after)
                .bind(i64::try_from(self.jobs_per_page).unwrap_or(i64::MAX))
                .fetch_all(&store.pool)
                .await
                .map_err(query_error("list a page of jobs"))?;
        let (Some(&(first,)), Some(&(last,))) = (ids.first(), ids.last()) else {
            self.done = true;
            return Ok(None);
        };
        self.after = last;
        let rows: Vec<(i64, String, String, f64, f64)> = sqlx::query_as(
            "SELECT s.job_id, j.name, s.name, s.t, s.value FROM series s JOIN jobs j ON j.id = s.job_id
             WHERE j.study_id = ? AND s.job_id BETWEEN ? AND ? ORDER BY s.job_id, s.name, s.t",
        )
        .bind(self.study_id)
        .bind(first)
        .bind(last)
        .fetch_all(&store.pool)
        .await
        .map_err(query_error("read a study's time series"))?;
        Ok(Some(
            rows.into_iter()
                .map(|(job_id, job, series, x, value)| SeriesPoint {
                    job_id,
                    job,
                    series,
                    x,
                    value,
                })
                .collect(),
        ))
    }
}

impl Store {
    /// For each series name a study's jobs stored (in name order), those jobs' ids in
    /// id order: what a report chooses the lines it draws from, read from the index
    /// `series_by_job` in its order (no temporary table, a page at a time) without
    /// reading the series themselves.
    pub async fn series_job_ids(
        &self,
        study_id: i64,
    ) -> Result<BTreeMap<String, Vec<i64>>, StoreError> {
        let mut out: BTreeMap<String, Vec<i64>> = BTreeMap::new();
        let (mut job, mut series) = (i64::MIN, String::new());
        loop {
            let page: Vec<(i64, String)> = sqlx::query_as(
                "SELECT j.id, s.name FROM jobs j JOIN series s ON s.job_id = j.id
                  WHERE j.study_id = ?1 AND (j.id, s.name) > (?2, ?3)
                  GROUP BY j.id, s.name ORDER BY j.id, s.name LIMIT ?4",
            )
            .bind(study_id)
            .bind(job)
            .bind(&series)
            .bind(ROWS_PER_PAGE)
            .fetch_all(&self.pool)
            .await
            .map_err(query_error("list the jobs with series"))?;
            let whole = page.len() < PAGE_LEN;
            for (id, name) in page {
                job = id;
                series.clone_from(&name);
                out.entry(name).or_default().push(id);
            }
            if whole {
                return Ok(out);
            }
        }
    }
}
