//! Experiments: equal-time comparisons with error against run time, their
//! plots and summaries.

pub mod ablation;
pub mod attribution;
mod attribution_report;
pub mod colormap;
pub mod compare;
pub mod cost;
pub mod curves;
pub mod merge;
pub mod pixel_classes;
pub mod plot;
pub mod replot;
pub mod study_folder;
pub mod summary_text;
