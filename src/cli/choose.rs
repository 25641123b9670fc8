//! `brdfit choose`: the simplest model whose rendered image a viewer cannot tell from the
//! measurement's, for each lighting case of a scene.

use super::*;
use anyhow::{Result, anyhow, bail};
use brdfit::choose::{self, Metric, Threshold};

/// Arguments of `brdfit choose`.
#[derive(clap::Args, Debug)]
pub(crate) struct ChooseArgs {
    /// The measurement (.csv, .astm, .brdf or MERL .binary); one channel is judged (the
    /// green channel of RGB data, CIE Y of spectral data, or --channel). Several files of one
    /// material are merged (samples at the same angles averaged; the same channels required),
    /// e.g. a goniometer's grid and the samples `brdfit plan` asked for.
    #[arg(required = true)]
    pub(crate) data: Vec<PathBuf>,
    /// `fig7` for Blinn's Figure 7 lighting cases (front lit, edge lit), or a scene TOML whose
    /// test object is the material named by its `test_object` key, else its first material in
    /// file order.
    #[arg(long, default_value = "fig7")]
    pub(crate) scene: String,
    /// METRIC=VALUE: the largest error a chosen model may have; METRIC is one of flip_mean,
    /// flip_p99, delta_e_itp_mean, delta_e_itp_p99, rmse.
    #[arg(long, default_value = "flip_p99=0.05", value_parser = parse_threshold)]
    pub(crate) threshold: Threshold,
    /// Output directory (created; its choose files are replaced).
    #[arg(short, long, default_value = "choose")]
    pub(crate) output: PathBuf,
    /// Image resolution (square) of the fig7 cases.
    #[arg(long, default_value_t = 512)]
    pub(crate) res: u32,
    /// Random starts that must not beat each fit (0 = none).
    #[arg(long, default_value_t = 4, value_parser = parse_verify)]
    pub(crate) verify: usize,
    /// Accept a scene image larger than 8192 on a side or 16 M pixels, or a fig7 --res above
    /// 1024 (about 600 bytes of memory a pixel).
    #[arg(long)]
    pub(crate) allow_large_image: bool,
    #[command(flatten)]
    pub(crate) prior: PriorArg,
    #[command(flatten)]
    pub(crate) load: LoadArgs,
}

/// `--threshold METRIC=VALUE`, parsed by clap, so a misspelt metric is a usage error (exit
/// code 2) like any other misspelt choice.
fn parse_threshold(s: &str) -> std::result::Result<Threshold, String> {
    let keys: Vec<&str> = Metric::ALL.iter().map(|m| m.key()).collect();
    let (k, v) = s.split_once('=').ok_or_else(|| {
        "expected METRIC=VALUE\n  fix: e.g. --threshold flip_p99=0.05".to_string()
    })?;
    let metric = Metric::from_key(k.trim()).ok_or_else(|| {
        // The nearest key by the number of differing characters at the same place, then by
        // length (flip_p98 → flip_p99).
        let near = keys
            .iter()
            .min_by_key(|key| {
                let same = key
                    .chars()
                    .zip(k.trim().chars())
                    .filter(|(a, b)| a == b)
                    .count();
                (
                    key.len().max(k.trim().len()) - same,
                    key.len().abs_diff(k.trim().len()),
                )
            })
            .copied()
            .unwrap_or("flip_p99");
        format!(
            "unknown metric '{}'\n  fix: use one of {} (the nearest: --threshold {near}={})",
            k.trim(),
            keys.join(", "),
            v.trim()
        )
    })?;
    let value: f64 = v
        .trim()
        .parse()
        .ok()
        .filter(|x: &f64| x.is_finite() && *x >= 0.0)
        .ok_or_else(|| {
            format!(
                "'{}' is not a value ≥ 0\n  fix: e.g. --threshold {}=0.05",
                v.trim(),
                k.trim()
            )
        })?;
    Ok(Threshold { metric, value })
}

pub(crate) fn run_choose(a: ChooseArgs) -> Result<()> {
    let threshold = a.threshold;
    if !(16..=4096).contains(&a.res) {
        bail!(
            "--res {} is out of range\n  fix: give a resolution between 16 and 4096",
            a.res
        );
    }
    check_choose_res(a.res, a.allow_large_image)?;
    // The output folder is checked before the work: a file in its place is refused now.
    if a.output.exists() && !a.output.is_dir() {
        bail!(
            "-o {}: is a file, and choose writes a folder\n  fix: give a folder name, e.g. -o {}-choose",
            a.output.display(),
            a.output.with_extension("").display()
        );
    }
    // The channel judged: --channel, else the representative one (green of RGB data).
    let full = {
        let sets = a
            .data
            .iter()
            .map(|p| a.load.load(p))
            .collect::<Result<Vec<_>>>()?;
        if sets.len() == 1 {
            sets.into_iter().next().expect("one set")
        } else {
            data::Dataset::merge(&sets).map_err(|e| anyhow!("{e}"))?
        }
    };
    let ds = match a.load.channel {
        Some(_) => full.clone(),
        None => {
            data::representative_channel(&full)
                .map_err(|m| anyhow!("{m}"))?
                .0
        }
    };
    let cases = if a.scene == "fig7" {
        choose::fig7_cases(a.res)
    } else {
        let path = Path::new(&a.scene);
        let scene = load_scene(path)?;
        vec![choose::scene_case(path, scene, a.allow_large_image).map_err(|e| anyhow!("{e}"))?]
    };
    let quiet = quiet();
    let t = std::time::Instant::now();
    let watch = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let opts = choose::ChooseOptions {
        threshold,
        verify: a.verify,
        watch: Some(watch.clone()),
        prior: a.prior.load()?,
        ..Default::default()
    };
    // One step per progress line (`choose::progress_steps`). On a terminal the lines scroll
    // above a bar with the time left, its message the step last done and, every 0.25 s, the
    // fits' passes over the data so far.
    let steps = choose::progress_steps(&ds, &cases, &opts);
    let bar = progress_bar(steps as u64, "global fits of every model");
    let last = std::sync::Mutex::new(String::from("global fits of every model"));
    let tick = |k: usize| {
        let last = last.lock().expect("no progress hook panics");
        bar.set_message(brdfit::fit::with_count(&last, k));
    };
    let chosen = brdfit::fit::ticking(&watch, &tick, || {
        choose::choose(&ds, &cases, &opts, &|line| {
            if bar.is_hidden() {
                if !quiet {
                    eprintln!("{line}");
                }
            } else {
                let mut last = last.lock().expect("no progress hook panics");
                *last = line.split(':').next().unwrap_or("").to_string();
                bar.println(line);
                bar.inc(1);
                bar.set_message(last.clone());
            }
        })
    });
    let (result, images) = chosen?;
    bar.finish_and_clear();
    let written = choose::write(&a.output, &result, &images)?;
    print(&choose::markdown(&result))?;
    wrote_all(&written);
    // RGB data: the reference in colour beside the judged channel's grey images.
    if a.load.channel.is_none() && choose::rgb_channels(&full).is_some() {
        for case in &cases {
            if let Some(img) = choose::colour_reference(&full, case) {
                let png = brdfit::plot::encode_png(
                    img.width,
                    img.height,
                    &brdfit::render::to_srgb8(&img),
                )?;
                write_file(&a.output.join(&case.name).join("measured-colour.png"), &png)?;
            }
        }
    }
    if !quiet {
        eprintln!("done in {:.1} s", t.elapsed().as_secs_f64());
    }
    Ok(())
}

/// Largest fig7 resolution `choose` renders without `--allow-large-image`: its images,
/// reference tables and error maps keep about 600 bytes a pixel (`--res 2048` reached 2.7 GB,
/// 4096 9.9 GB), so 1024 stays under 1 GB.
const CHOOSE_MAX_RES: u32 = 1024;

/// Refuse a fig7 resolution whose memory would pass 1 GB unless it was asked for.
fn check_choose_res(res: u32, allow_large: bool) -> Result<()> {
    if res > CHOOSE_MAX_RES && !allow_large {
        bail!(
            "--res {res}: choose would keep about {:.1} GB ({res}×{res} pixels at about 600 bytes each), above the 1 GB it uses without asking\n  fix: give --res {CHOOSE_MAX_RES} or less, or allow it with --allow-large-image",
            (res as f64).powi(2) * 600.0 / 1e9
        );
    }
    Ok(())
}
