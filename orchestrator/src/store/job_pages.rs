//! Reading a whole study's jobs with their points and responses a page at a time, for
//! the commands that write every job (`orch status`, `status --json`, `export`): what is
//! held in memory is one page, whatever the study's size.

use std::collections::{BTreeMap, HashMap};

use super::{JobRow, PointRow, ResponseValues, Store, StoreError, PAGE_LEN};

/// Some of a study's jobs (in id order) with their design points and responses, each
/// read in one query.
#[derive(Debug, Clone, Default)]
pub struct JobPage {
    /// The jobs, in id order.
    pub jobs: Vec<JobRow>,
    /// Their design points, by point id.
    pub points: HashMap<i64, PointRow>,
    /// Their responses, by job id (a job without any is left out).
    pub responses: BTreeMap<i64, ResponseValues>,
}

impl JobPage {
    /// `jobs` with their points and responses read from `store`.
    pub async fn of_jobs(store: &Store, jobs: Vec<JobRow>) -> Result<JobPage, StoreError> {
        let job_ids: Vec<i64> = jobs.iter().map(|job| job.id).collect();
        let point_ids: Vec<i64> = jobs.iter().map(|job| job.point_id).collect();
        let responses = store.responses_of_jobs(&job_ids).await?;
        let points = store.points_by_id(&point_ids).await?;
        Ok(JobPage {
            jobs,
            points: points.into_iter().map(|p| (p.id, p)).collect(),
            responses,
        })
    }

    /// Each job with its point and its responses, which are moved out of the page.
    pub fn drain(&mut self) -> impl Iterator<Item = (JobRow, &PointRow, ResponseValues)> + '_ {
        let (points, responses) = (&self.points, &mut self.responses);
        self.jobs.drain(..).map(move |job| {
            let values = responses.remove(&job.id).unwrap_or_default();
            // A job's point is deleted only with its study (the foreign key), so it
            // is always there.
            let point = &points[&job.point_id];
            (job, point, values)
        })
    }
}

/// A study's jobs read as [`JobPage`]s of [`super::ROWS_PER_PAGE`] jobs, in id order
/// (the index `jobs_by_study`). Reading them again from the start (a second pass) is
/// [`JobPages::of`] once more.
#[derive(Debug, Clone)]
pub struct JobPages {
    study_id: i64,
    /// The last job id of the page read before.
    after: i64,
    done: bool,
}

impl JobPages {
    /// The pages of `study_id`, from its first job.
    pub fn of(study_id: i64) -> JobPages {
        JobPages {
            study_id,
            after: i64::MIN,
            done: false,
        }
    }

    /// The next page, or `None` after the last job.
    pub async fn next(&mut self, store: &Store) -> Result<Option<JobPage>, StoreError> {
        if self.done {
            return Ok(None);
        }
        let jobs = store.jobs_after(self.study_id, self.after).await?;
        self.done = jobs.len() < PAGE_LEN;
        let Some(last) = jobs.last() else {
            return Ok(None);
        };
        self.after = last.id;
        Ok(Some(JobPage::of_jobs(store, jobs).await?))
    }
}
