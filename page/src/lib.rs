//! What a person reads, without a store: numbers as people read them, HTML pieces
//! (escaping, tables, the page around them) and figures as inline SVG.
//!
//! `orch report` and `orch compare`'s history page both build on it; neither the
//! store nor a study is needed to draw a table or a chart.

pub mod html;
pub mod numbers;
pub mod plots;
