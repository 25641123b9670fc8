//! The BRDF fitting problem: per-sample geometry computed once, parameters transformed so
//! their bounds hold by construction, residuals of the `log` or `linear` loss.
mod brdf;
mod kernels;
mod lane_terms;
mod loss;
mod passes;
mod rows;
mod select;
mod transform;

pub use brdf::{BrdfProblem, Prepared, SUBSAMPLE_ROWS, Slot};
pub use loss::{Loss, PIXEL_CLIP_WIDTH, pixel};
pub use passes::{abc_shape_rows, brdf_values, ggx_lobe_values};
pub use rows::{GgxTerms, Row, RowWriter, Rows};
pub use transform::Transform;
