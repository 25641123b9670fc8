//! `brdfit plan`: where to measure next.

use super::*;
use anyhow::{Result, anyhow, bail};
use brdfit::plan::{DEFAULT_NOISE, MAX_BUDGET, PlanOptions, Target};
use brdfit::prior::{Posterior, PosteriorOptions};

/// Arguments of `brdfit plan`.
#[derive(clap::Args, Debug)]
pub(crate) struct PlanArgs {
    /// Measurements of the material so far (several files of one material are merged:
    /// duplicates averaged, the same channels required); none for a first measurement.
    pub(crate) data: Vec<PathBuf>,
    /// `fig7` (Blinn's Figure 7 front- and edge-lit spheres) or a scene TOML: plan for the
    /// lit pixels of its test object. Without it the plan serves the whole table alike.
    #[arg(long)]
    pub(crate) scene: Option<String>,
    /// Image resolution (square) of the fig7 cases, which sets how finely their pixels'
    /// configurations are sampled.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(16..=1024))]
    pub(crate) res: u32,
    /// Configurations to plan (the first k of a plan are the best k it found).
    #[arg(long, default_value_t = 100, value_parser = parse_budget)]
    pub(crate) budget: usize,
    /// What real materials are like: `bundled` (principal components of the 100 MERL
    /// networks, built on first use and cached) or a file from `brdfit prior build`.
    #[arg(long, default_value = "bundled", value_name = "PRIOR")]
    pub(crate) prior: String,
    /// Largest θi and θo the goniometer reaches (degrees).
    #[arg(long, default_value_t = 85.0, value_parser = parse_max_theta_plan)]
    pub(crate) max_theta: f64,
    /// Smallest angle between source and detector (degrees).
    #[arg(long, default_value_t = 5.0)]
    pub(crate) min_separation: f64,
    /// Only configurations in the plane of incidence.
    #[arg(long)]
    pub(crate) in_plane: bool,
    /// The plan: a brdfit CSV with an empty `brdf` column to fill in.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    #[command(flatten)]
    pub(crate) load: LoadArgs,
}

fn parse_budget(s: &str) -> std::result::Result<usize, String> {
    s.trim()
        .parse::<usize>()
        .ok()
        .filter(|&n| (1..=MAX_BUDGET).contains(&n))
        .ok_or_else(|| {
            format!("'{s}' is not a budget\n  fix: give 1 to {MAX_BUDGET} configurations")
        })
}

fn parse_max_theta_plan(s: &str) -> std::result::Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|t| *t > 0.0 && *t <= 90.0)
        .ok_or_else(|| format!("'{s}' is not an angle in (0, 90]\n  fix: e.g. --max-theta 80"))
}

pub(crate) fn run_plan(a: PlanArgs) -> Result<()> {
    let inputs: Vec<&Path> = a.data.iter().map(|p| p.as_path()).collect();
    refuse_input(&a.output, &inputs)?;
    if !(a.min_separation >= 0.0 && a.min_separation < 180.0) {
        bail!(
            "--min-separation {}: not an angle in [0, 180)\n  fix: e.g. --min-separation 5",
            a.min_separation
        );
    }
    let sets = a
        .data
        .iter()
        .map(|p| study_input(p, &a.load))
        .collect::<Result<Vec<_>>>()?;
    let data = if sets.is_empty() {
        None
    } else {
        Some(brdfit::data::Dataset::merge(&sets).map_err(|e| anyhow!("{e}"))?)
    };
    let target = match a.scene.as_deref() {
        None => Target::Table,
        Some("fig7") => Target::scene(&brdfit::choose::fig7_cases(a.res)),
        Some(path) => {
            let path = Path::new(path);
            let scene = load_scene(path)?;
            let case =
                brdfit::choose::scene_case(path, scene, false).map_err(|e| anyhow!("{e}"))?;
            Target::scene(&[case])
        }
    };
    let prior = PriorArg {
        prior: a.prior.clone(),
    }
    .load()?
    .ok_or_else(|| anyhow!("--prior none: a plan needs a prior\n  fix: give --prior bundled or a file from `brdfit prior build`"))?;
    // The noise the samples show under the prior (cross-validated), else a 10 % error.
    let noise = data
        .as_ref()
        .and_then(|d| Posterior::condition(prior.clone(), d, &PosteriorOptions::default()))
        .map_or(DEFAULT_NOISE, |p| p.noise);
    let opts = PlanOptions {
        budget: a.budget,
        max_theta_deg: a.max_theta,
        min_separation_deg: a.min_separation,
        in_plane: a.in_plane,
    };
    let plan = brdfit::plan::plan(&prior, data.as_ref(), noise, &target, &opts)
        .map_err(|e| anyhow!("{e}"))?;
    let what = match a.scene.as_deref() {
        None => "every cell of the table alike".to_string(),
        Some(s) => format!("the lit pixels of {s}"),
    };
    let from = if a.data.is_empty() {
        "no measurement".to_string()
    } else {
        format!(
            "{} ({} samples)",
            sets.iter()
                .map(|d| d.meta.source.clone())
                .collect::<Vec<_>>()
                .join(" + "),
            data.as_ref().map_or(0, |d| d.len())
        )
    };
    let rms = |v: f64| v.max(0.0).sqrt();
    let notes = vec![
        format!(
            "brdfit plan: {} configurations for {what}, from {from}",
            plan.rows.len()
        ),
        format!(
            "prior: {} materials, {} components; noise variance {:.3e} (ln² units)",
            prior.materials.len(),
            prior.components(),
            noise
        ),
        format!(
            "predicted rms uncertainty of ln(f cosθi cosθo + 1e-3) there: {:.4} now, {:.4} after \
             the plan ({} candidates within θ ≤ {}°, separation ≥ {}°{})",
            rms(plan.before),
            rms(plan.after(plan.rows.len())),
            plan.candidates,
            a.max_theta,
            a.min_separation,
            if a.in_plane { ", in plane" } else { "" }
        ),
        "measure each row (θi, φi, θo, φo in degrees) and write f_r in the brdf column; \
         plan_share is the share of the remaining uncertainty each removes"
            .to_string(),
    ];
    let text = brdfit::plan::to_csv(&plan, &notes);
    brdfit::support::output::write_atomic(&a.output, |w| w.write_all(text.as_bytes()))
        .map_err(|e| brdfit::support::output::write_error(&a.output, &e))?;
    for n in &notes[..3] {
        print(&format!("{n}\n"))?;
    }
    wrote(&a.output);
    Ok(())
}
