//! Evaluation: dataset readers, protocols and metrics.

pub mod dataset;
