//! Fitting reflection models to samples by nonlinear least squares.
//!
//! The pipeline for one data set (and one channel, or several with `shared` parameters):
//! [`fit`] (`run`) hands each channel, or the joint fit, to `group`, which calls one file a
//! stage, in order:
//! 1. `setup`: samples are converted to f_r and filtered (finite values, `max_theta`); the
//!    geometry of each sample is computed once ([`problem::Rows`]); the solver variables are
//!    laid out and the data checked;
//! 2. `init`: **global initialisation** (variable projection): the linear parameters (each
//!    lobe's ps, and pd) enter the model linearly, so a grid over the nonlinear parameters with
//!    a weighted non-negative linear solve at each point finds the basin; on a subsample;
//! 3. `solve`: the local method (Levenberg–Marquardt by default) from the best grid points and
//!    the user's `start`, first on a subsample of at most 2,000 rows per channel, then on all
//!    rows;
//! 4. `checks`: first-order conditions, absurd values, random-start verification (and
//!    [`physical`]: only physical fits in use);
//! 5. `stats`: statistics in natural parameters from JᵀJ at the solution: standard errors,
//!    correlations, and honest warnings (with a profiled range) for parameters the data do not
//!    determine;
//! 6. `format`: ranking by BIC and the terminal tables.
//!
//! Beside them: `options` and `result` (what a fit is asked and returns), `residuals` (each
//! sample's residual at a fit), `read` (a fit read back from JSON), `models` (several models at once, `--model all`), `progress`, and the
//! solvers: `lsq` (brdfit's own), `argmin_peer` (argmin's), `dispatch` (the choice between
//! them), over the `problem` they solve.

mod argmin_peer;
mod checks;
pub mod conserve;
mod dispatch;
mod fitfile;
mod format;
mod group;
mod init;
mod json;
mod models;
mod options;
pub mod physical;
mod progress;
mod quantile;
mod read;
mod residuals;
mod result;
mod run;
mod seed;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod lsq;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod problem;
mod setup;
mod solve;
mod stats;

pub use fitfile::{
    Colour, FitFileError, Picked, PickedChannel, Want, is_unnamed_channel, parse_strict, pick,
    pick_one, read_fit_file, same_channel,
};
pub use format::{
    all_models, format_channels, format_fit, format_ranking, format_ranking_line, interval_text,
    rank,
};
pub use lsq::{Limits, Method};
pub use models::{fit_models, fit_models_with_progress, options_per_model};
pub use options::{FitError, FitOptions, RESOLUTION, RobustKind, Weighting};
pub use problem::Loss;
pub use progress::{TICK, Watch, ticking, with_count};
pub use quantile::t_quantile;
pub use residuals::{
    Residual, check_fitted_to, residual_definition, residuals, write_residuals_csv,
};
pub use result::{FitResult, KKT_TOLERANCE, SAME_MINIMUM, Verification, fits_json};
pub use run::{fit, fit_timed};
pub use setup::solid_angle_weights;
pub use solve::random_start;
pub use stats::{INTERVAL_LEVEL, describe_range};
