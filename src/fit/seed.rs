//! The start of a fit whose model has too many shape parameters for the global grid: the
//! tabulated-NDF model (`tabulated-ndf`, its table of 32 values) starts from the `ggx-smith`
//! fit of the same rows, the GGX distribution sampled into the table, and is polished from
//! there by the same local method. The polish never ends above its start, so the tabulated
//! fit is never worse (in the fit's loss) than the GGX–Smith one; Dupuy et al. 2015 start their
//! power iteration from a smooth lobe the same way.

use super::group::fit_group;
use super::options::{FitError, FitOptions};
use super::result::FitResult;
use super::setup::ChannelRows;
use crate::model::ModelKind;
use crate::model::tabulated_ndf::ggx_table;

/// True when a fit of `opts` starts from a `ggx-smith` fit (tabulated-ndf with neither a start
/// given nor `--local-only`).
pub(super) fn seeded(opts: &FitOptions) -> bool {
    opts.kind == ModelKind::TabulatedNdf && opts.start.is_empty() && !opts.local_only
}

/// Fit tabulated-ndf to `chans`: first ggx-smith (the same options; parameters held or
/// shared that ggx-smith has stay so), then tabulated-ndf from the GGX start, local only,
/// without random-start verification or profiles: random tables in 32 dimensions certify
/// nothing, and a profile of each weakly determined node (those where θh is far beyond the
/// lobe) refits 34 parameters at every point.
pub(super) fn fit_seeded(
    chans: Vec<ChannelRows>,
    opts: &FitOptions,
    geometry_seconds: f64,
) -> Result<FitResult, FitError> {
    let ggx_names = ModelKind::GgxSmith.param_names(opts.dist);
    let keep = |n: &str| ggx_names.contains(&n);
    let mut g = opts.clone();
    g.kind = ModelKind::GgxSmith;
    g.profile = false;
    g.verify = 0;
    g.fix.retain(|(n, _)| keep(n));
    g.shared.retain(|n| keep(n));
    let ggx = fit_group(chans.clone(), &g, geometry_seconds)?;
    let alpha = ggx
        .params
        .iter()
        .find(|(n, _)| n == "alpha" || n.starts_with("alpha_"))
        .map_or(0.3, |(_, v)| *v);
    let mut o = opts.clone();
    o.start = ggx
        .params
        .iter()
        .filter(|(n, _)| !n.starts_with("alpha"))
        .cloned()
        .collect();
    let table = ggx_table(alpha);
    let names = ModelKind::TabulatedNdf.param_names(opts.dist);
    o.start
        .extend(names.iter().zip(table).map(|(n, v)| (n.to_string(), v)));
    o.local_only = true;
    o.verify = 0;
    o.profile = false;
    fit_group(chans, &o, geometry_seconds)
}
