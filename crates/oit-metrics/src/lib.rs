//! oit-metrics
