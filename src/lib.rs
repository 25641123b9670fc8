//! # brdfit
//!
//! Fit reflection models to measured reflectance and analyse the result.
//!
//! The data flows through the modules in order: [`data`] (samples and loaders) →
//! [`model`] (the BRDFs of Phong 1975 and Blinn 1977, with analytic gradients) → fit, plot,
//! render and report. [`simulate`] makes synthetic samples; [`output`] writes files atomically.

#![warn(missing_docs)]
// Numeric code indexes parallel arrays (struct-of-arrays); index loops are the clear form.
#![allow(clippy::needless_range_loop)]
// `!(x <= limit)` is deliberate: it is true for NaN, which must count as failing a test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod data;
pub mod export;
pub mod fit;
pub mod inverse;
pub mod lanes;
pub mod model;
pub mod output;
pub mod plot;
pub mod render;
pub mod report;
pub mod simulate;
pub mod study;
