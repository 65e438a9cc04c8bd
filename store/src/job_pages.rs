//! Reading a whole study's jobs with their points and responses a page at a time, for
//! the commands that write every job (`orch status`, `status --json`, `export`): what is
//! held in memory is one page, whatever the study's size. A table that aligns its
//! columns learns their widths beforehand from [`Store::job_extents`], a few aggregate
//! rows, rather than from a first pass over the jobs.

use std::collections::{BTreeMap, HashMap};

use super::{query_error, JobRow, PointRow, ResponseValues, Store, StoreError, PAGE_LEN};

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
        let responses = store.responses_of_jobs(&job_ids).await?;
        JobPage::with_responses(store, jobs, responses).await
    }

    /// `jobs` with `responses` (theirs, by job id) and their points read from `store`.
    async fn with_responses(
        store: &Store,
        jobs: Vec<JobRow>,
        responses: BTreeMap<i64, ResponseValues>,
    ) -> Result<JobPage, StoreError> {
        let point_ids: Vec<i64> = jobs.iter().map(|job| job.point_id).collect();
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
/// (the index `jobs_by_study`).
#[derive(Debug, Clone)]
pub struct JobPages {
    study_id: i64,
    /// The last job id of the page read before.
    after: i64,
    done: bool,
    /// The responses read: `None` for every one.
    names: Option<Vec<String>>,
}

impl JobPages {
    /// The pages of `study_id`, from its first job, with every response.
    pub fn of(study_id: i64) -> JobPages {
        JobPages {
            study_id,
            after: i64::MIN,
            done: false,
            names: None,
        }
    }

    /// The pages of `study_id` with only the responses `names` (distinct), for a
    /// command that shows those: a page's values then come in one query through the
    /// primary key, one row per job with a column per name (each row crosses from
    /// SQLite's thread on its own, so a study with many more responses than it shows
    /// reads an order of magnitude fewer rows).
    pub fn with_responses(study_id: i64, names: &[String]) -> JobPages {
        JobPages {
            names: Some(names.to_vec()),
            ..JobPages::of(study_id)
        }
    }

    /// The next page, or `None` after the last job.
    pub async fn next(&mut self, store: &Store) -> Result<Option<JobPage>, StoreError> {
        if self.done {
            return Ok(None);
        }
        let jobs = store.jobs_after(self.study_id, self.after).await?;
        self.done = jobs.len() < PAGE_LEN;
        let Some(last) = jobs.last().map(|job| job.id) else {
            return Ok(None);
        };
        let after = std::mem::replace(&mut self.after, last);
        let Some(names) = &self.names else {
            return Ok(Some(JobPage::of_jobs(store, jobs).await?));
        };
        let responses = store
            .responses_by_job_in(self.study_id, names, true, after, last)
            .await?;
        Ok(Some(JobPage::with_responses(store, jobs, responses).await?))
    }
}

/// The smallest and largest of some values, among all of them and among the finite
/// ones: the values whose text is the longest, when each is written to fixed decimals,
/// are among these four (see [`Extremes::candidates`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Extremes {
    /// The smallest value (−∞ when there is one).
    pub min: Option<f64>,
    /// The largest value (+∞ when there is one).
    pub max: Option<f64>,
    /// The smallest finite value.
    pub min_finite: Option<f64>,
    /// The largest finite value.
    pub max_finite: Option<f64>,
}

impl Extremes {
    /// The extremes of `values`.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Extremes {
        let mut out = Extremes::default();
        let lower = |a: Option<f64>, v: f64| Some(a.map_or(v, |a| a.min(v)));
        let upper = |a: Option<f64>, v: f64| Some(a.map_or(v, |a| a.max(v)));
        for v in values {
            out.min = lower(out.min, v);
            out.max = upper(out.max, v);
            if v.is_finite() {
                out.min_finite = lower(out.min_finite, v);
                out.max_finite = upper(out.max_finite, v);
            }
        }
        out
    }

    /// The values among which the longest text is, for a format to fixed decimals
    /// (`{:.6}`): a finite value's text grows with the digits before the point, which
    /// grow with its magnitude, and with its sign, so the widest finite negative value
    /// is the smallest and the widest other finite value the largest; `inf` and
    /// `-inf` are the two others.
    pub fn candidates(&self) -> impl Iterator<Item = f64> {
        [self.min, self.max, self.min_finite, self.max_finite]
            .into_iter()
            .flatten()
    }
}

/// What the widths of a table of a study's jobs depend on, read with a few aggregate
/// queries instead of every job ([`Store::job_extents`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JobExtents {
    /// Characters of the longest job name.
    pub name_chars: usize,
    /// The most attempts of a job.
    pub attempts: i64,
    /// Characters of the longest executor handle, `-` for none.
    pub handle_chars: usize,
    /// Characters of the longest scheduler state (`-` for none), or `None` when no job
    /// has one.
    pub scheduler_chars: Option<usize>,
    /// The natural values of the jobs' points, by factor index.
    pub natural: Vec<Extremes>,
    /// The jobs' values of each response asked for that some job has, by name.
    pub responses: BTreeMap<String, Extremes>,
}

/// A row of an aggregate over values grouped by `K`: min, max, finite min, finite max.
type ExtremesRow<K> = (K, f64, f64, Option<f64>, Option<f64>);

impl Store {
    /// The extents of the study's jobs (names, attempts, handles, scheduler states,
    /// their points' natural values and the responses `names`): what the columns of a
    /// table of every job need to be as wide as, known before its first row is
    /// written. SQLite's `length` counts characters as `str::chars` does (the texts
    /// are orch's own: job names, handles and scheduler states hold no NUL).
    pub async fn job_extents(
        &self,
        study_id: i64,
        names: &[String],
    ) -> Result<JobExtents, StoreError> {
        let (name_chars, attempts, handle_chars, scheduled, scheduler_chars): (
            Option<i64>,
            Option<i64>,
            Option<i64>,
            i64,
            Option<i64>,
        ) = sqlx::query_as(
            "SELECT MAX(length(name)), MAX(attempts), MAX(length(COALESCE(executor_handle, '-'))),
                    COUNT(scheduler_state), MAX(length(COALESCE(scheduler_state, '-')))
               FROM jobs WHERE study_id = ?",
        )
        .bind(study_id)
        .fetch_one(&self.pool)
        .await
        .map_err(query_error("measure a study's jobs"))?;
        // `abs(v) < 9e999` (SQLite reads 9e999 as +∞) keeps the finite values.
        let natural: Vec<ExtremesRow<i64>> = sqlx::query_as(
            "SELECT v.factor_idx, MIN(v.natural), MAX(v.natural),
                    MIN(CASE WHEN abs(v.natural) < 9e999 THEN v.natural END),
                    MAX(CASE WHEN abs(v.natural) < 9e999 THEN v.natural END)
               FROM jobs j JOIN point_values v ON v.point_id = j.point_id
              WHERE j.study_id = ? GROUP BY v.factor_idx ORDER BY v.factor_idx",
        )
        .bind(study_id)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("measure a study's design points"))?;
        let names = serde_json::to_string(names).expect("JSON of strings");
        let responses: Vec<ExtremesRow<String>> = sqlx::query_as(
            "SELECT r.name, MIN(r.value), MAX(r.value),
                    MIN(CASE WHEN abs(r.value) < 9e999 THEN r.value END),
                    MAX(CASE WHEN abs(r.value) < 9e999 THEN r.value END)
               FROM jobs j JOIN responses r ON r.job_id = j.id
              WHERE j.study_id = ? AND r.name IN (SELECT value FROM json_each(?))
              GROUP BY r.name",
        )
        .bind(study_id)
        .bind(names)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("measure a study's responses"))?;
        let chars = |n: Option<i64>| n.and_then(|n| usize::try_from(n).ok()).unwrap_or(0);
        let extremes = |min, max, min_finite, max_finite| Extremes {
            min: Some(min),
            max: Some(max),
            min_finite,
            max_finite,
        };
        Ok(JobExtents {
            name_chars: chars(name_chars),
            attempts: attempts.unwrap_or(0),
            handle_chars: chars(handle_chars),
            scheduler_chars: (scheduled > 0).then(|| chars(scheduler_chars)),
            natural: natural
                .into_iter()
                .map(|(_, min, max, lo, hi)| extremes(min, max, lo, hi))
                .collect(),
            responses: responses
                .into_iter()
                .map(|(name, min, max, lo, hi)| (name, extremes(min, max, lo, hi)))
                .collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Any number a store can hold: no NaN (a response is never NaN: the column is
    /// NOT NULL and SQLite binds NaN as NULL), and no −0, which SQLite reads back as
    /// +0 (a REAL without a fraction is written as an integer).
    fn value() -> impl Strategy<Value = f64> {
        let stored = |v: f64| if v == 0.0 { 0.0 } else { v };
        prop_oneof![
            -1e3..1e3f64,
            -1e-6..1e-6f64,
            any::<f64>().prop_filter("a number", |v| !v.is_nan()),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(9.9999995),
            Just(-9.9999995),
        ]
        .prop_map(stored)
    }

    proptest! {
        /// The longest text of a set of values written to fixed decimals is the
        /// longest of its extremes' texts: a column's width needs only the extremes.
        #[test]
        fn the_widest_value_is_one_of_the_extremes(values in prop::collection::vec(value(), 1..40)) {
            let widest = |vs: &mut dyn Iterator<Item = f64>, decimals: usize| {
                vs.map(|v| format!("{v:.decimals$}").chars().count()).max().unwrap()
            };
            let extremes = Extremes::of(values.iter().copied());
            for decimals in [5, 6] {
                prop_assert_eq!(
                    widest(&mut values.iter().copied(), decimals),
                    widest(&mut extremes.candidates(), decimals)
                );
            }
        }
    }

    #[test]
    fn extremes_keep_the_infinities_apart_from_the_finite_values() {
        let e = Extremes::of([2.0, f64::INFINITY, -3.0]);
        assert_eq!(e.min, Some(-3.0));
        assert_eq!(e.max, Some(f64::INFINITY));
        assert_eq!((e.min_finite, e.max_finite), (Some(-3.0), Some(2.0)));
        assert_eq!(Extremes::of([]), Extremes::default());
    }
}
