//! Reading a whole study's time series at once, for `orch export --series` and reports.

use super::{query_error, Store, StoreError};

impl Store {
    /// Every series point of every job of a study as `(job id, series, t, value)`, in
    /// job, series and time order.
    pub async fn study_series(
        &self,
        study_id: i64,
    ) -> Result<Vec<(i64, String, f64, f64)>, StoreError> {
        sqlx::query_as(
            "SELECT s.job_id, s.name, s.t, s.value FROM series s JOIN jobs j ON j.id = s.job_id
             WHERE j.study_id = ? ORDER BY s.job_id, s.name, s.t",
        )
        .bind(study_id)
        .fetch_all(&self.pool)
        .await
        .map_err(query_error("read a study's time series"))
    }
}
