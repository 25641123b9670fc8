//! `brdfit prior build`, and the `--prior` argument of the commands that use a prior.

use super::*;
use anyhow::{Result, bail};
use brdfit::prior::{BuildOptions, Prior};
use std::sync::Arc;

/// Subcommands of `brdfit prior`.
#[derive(Subcommand, Debug)]
pub(crate) enum PriorCmd {
    /// Build a prior (principal components of measured materials, Nielsen et al. 2015) from
    /// Neural-BRDF networks, leaving out named materials.
    #[command(
        after_help = "Example:\n  brdfit prior build --exclude merl/steel,merl/blue-acrylic -o no-steel.prior"
    )]
    Build(PriorBuildArgs),
}

/// Arguments of `brdfit prior build`.
#[derive(clap::Args, Debug)]
pub(crate) struct PriorBuildArgs {
    /// Neural-BRDF weights file (default: the bundled data/nbrdf_weights.json).
    #[arg(long, value_name = "FILE")]
    pub(crate) weights: Option<PathBuf>,
    /// Materials left out, by the weights file's names (merl/steel) or their last part.
    #[arg(long, value_delimiter = ',', value_name = "NAME")]
    pub(crate) exclude: Vec<String>,
    /// Only networks whose name starts with this ("" for all).
    #[arg(long, default_value = "merl/")]
    pub(crate) prefix: String,
    /// Largest number of components kept (1–256).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u16).range(1..=256))]
    pub(crate) components: u16,
    /// Output file.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
}

/// The `--prior` argument: a prior file, `bundled` (built from the bundled MERL networks on
/// first use and cached) or `none`.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct PriorArg {
    /// What real materials are like, for the reference: `bundled` (principal components of the
    /// 100 MERL networks, built on first use and cached), a file from `brdfit prior build`, or
    /// `none` (the samples alone).
    #[arg(long, default_value = "none", value_name = "PRIOR")]
    pub(crate) prior: String,
}

impl PriorArg {
    /// The prior named, built or read (with a progress bar while the bundled one is built).
    pub(crate) fn load(&self) -> Result<Option<Arc<Prior>>> {
        match self.prior.as_str() {
            "none" => Ok(None),
            "bundled" => Ok(Some(Arc::new(bundled_prior()?))),
            path => Ok(Some(Arc::new(brdfit::prior::load(Path::new(path))?))),
        }
    }
}

/// The bundled prior, from the cache or built with a progress bar.
fn bundled_prior() -> Result<Prior> {
    let bar = progress_bar(
        100,
        "prior: tabulating the MERL networks (once; then cached)",
    );
    let (prior, cache) = brdfit::prior::bundled(&BuildOptions::default(), &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    if let Some(c) = cache.filter(|_| VERBOSE.load(std::sync::atomic::Ordering::Relaxed)) {
        eprintln!("prior: {}", c.display());
    }
    Ok(prior)
}

pub(crate) fn run_prior(cmd: PriorCmd) -> Result<()> {
    match cmd {
        PriorCmd::Build(a) => {
            refuse_input(
                &a.output,
                &a.weights.iter().map(|p| p.as_path()).collect::<Vec<_>>(),
            )?;
            let nets = match &a.weights {
                Some(w) => brdfit::data::nbrdf::load_all(w)?,
                None => brdfit::data::nbrdf::parse_all(
                    Path::new("data/nbrdf_weights.json"),
                    brdfit::prior::bundled_weights(),
                )?,
            };
            let opts = BuildOptions {
                exclude: a.exclude.clone(),
                prefix: a.prefix.clone(),
                max_components: a.components as usize,
                ..Default::default()
            };
            for e in &a.exclude {
                if !nets
                    .iter()
                    .any(|n| n.name == *e || n.name.rsplit('/').next() == Some(e.as_str()))
                {
                    bail!(
                        "--exclude {e}: no network of that name\n  fix: use the weights file's names, e.g. merl/steel"
                    );
                }
            }
            let bar = progress_bar(nets.len() as u64, "prior: tabulating the networks");
            let prior = brdfit::prior::build(&nets, &opts, &|done, total| {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            });
            bar.finish_and_clear();
            let Some(prior) = prior else {
                bail!(
                    "fewer than two networks are left (prefix `{}`, {} excluded)\n  fix: exclude fewer materials or give --prefix \"\"",
                    a.prefix,
                    a.exclude.len()
                );
            };
            brdfit::prior::save(&prior, &a.output)
                .map_err(|e| brdfit::support::output::write_error(&a.output, &e))?;
            print(&format!(
                "prior: {} materials, {} components (variance {:.3e} … {:.3e}), table {:?}\n",
                prior.materials.len(),
                prior.components(),
                prior.variance.first().copied().unwrap_or(0.0),
                prior.variance.last().copied().unwrap_or(0.0),
                prior.dims
            ))?;
            wrote(&a.output);
            Ok(())
        }
    }
}
