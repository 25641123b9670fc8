//! `brdfit inverse`: arguments and output around the library's inverse Phong.

use super::*;
use anyhow::{Result, anyhow, bail};
use clap::Args;
use std::path::{Path, PathBuf};

/// Arguments of `brdfit inverse`.
#[derive(Args, Debug)]
pub(crate) struct InverseArgs {
    /// The image (PNG is sRGB-decoded unless --linear; EXR is linear).
    pub(crate) image: PathBuf,
    /// The row to invert (left to right).
    #[arg(long, conflicts_with_all = ["from", "to"])]
    pub(crate) row: Option<u32>,
    /// Start pixel X,Y of the line.
    #[arg(long, value_delimiter = ',')]
    pub(crate) from: Vec<u32>,
    /// End pixel X,Y of the line.
    #[arg(long, value_delimiter = ',')]
    pub(crate) to: Vec<u32>,
    /// Light direction x,y,z in view coordinates (x right, y up, z toward the viewer).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(crate) light: Vec<f64>,
    /// Ambient constant Ca (image value of a surface facing away from the light).
    #[arg(long, default_value_t = 0.0)]
    pub(crate) ca: f64,
    /// Diffuse constant Cd (image value added by a surface facing the light).
    #[arg(long)]
    pub(crate) cd: Option<f64>,
    /// Take Cd = pd·E/π and Ca = pd·A from a fit JSON with --irradiance E and --ambient A.
    #[arg(long)]
    pub(crate) fit: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) pick: PickArgs,
    /// With --fit: the channel to take from a fit file of several.
    #[arg(long)]
    pub(crate) channel: Option<String>,
    /// Light irradiance E (with --fit).
    #[arg(long, default_value_t = std::f64::consts::PI)]
    pub(crate) irradiance: f64,
    /// Ambient radiance A (with --fit).
    #[arg(long, default_value_t = 0.0)]
    pub(crate) ambient: f64,
    /// World size of one pixel, for the heights.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) pixel_size: f64,
    /// Shape prior for the first pixel: convex or concave.
    #[arg(long, value_enum, default_value = "convex")]
    pub(crate) prior: brdfit::inverse::Prior,
    /// A second image of the same view under --light2 (photometric stereo along the line).
    #[arg(long)]
    pub(crate) image2: Option<PathBuf>,
    /// The second light direction x,y,z.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub(crate) light2: Vec<f64>,
    /// PNG values are already linear.
    #[arg(long)]
    pub(crate) linear: bool,
    /// A CSV with columns pixel,height: the true profile, drawn with the estimate.
    #[arg(long)]
    pub(crate) truth: Option<PathBuf>,
    /// Output base: BASE.csv and the profile plot BASE.svg/png.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
}

/// Invert a line of an image (see the command's help) and write BASE.csv and the profile plot.
pub(crate) fn run_inverse(args: InverseArgs) -> Result<()> {
    let InverseArgs {
        image,
        row,
        from,
        to,
        light,
        ca,
        cd,
        fit,
        pick,
        channel,
        irradiance,
        ambient,
        pixel_size,
        prior,
        image2,
        light2,
        linear,
        truth,
        output,
    } = args;
    use brdfit::inverse;
    // The three outputs are checked before any work: none may be an input (`-o photo` used to
    // replace photo.png with the chart) or a device.
    let base = output_base(&output, &["csv", "svg", "png"])?;
    let inputs: Vec<&Path> = [Some(&image), image2.as_ref(), fit.as_ref(), truth.as_ref()]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    for ext in ["csv", "svg", "png"] {
        refuse_input(&base.with_extension(ext), &inputs)?;
    }
    let read = |p: &Path| -> Result<(u32, u32, Vec<f64>)> {
        inverse::luminance_image(p, linear).map_err(|e| {
            anyhow!(
                "{}: cannot read the image: {e}\n  fix: give a PNG or EXR",
                p.display()
            )
        })
    };
    let (w, h, lum) = read(&image)?;
    let (a, b) = match (row, from.as_slice(), to.as_slice()) {
        (Some(r), _, _) if r < h => ((0, r), (w - 1, r)),
        (Some(r), _, _) => bail!("--row {r} is outside the image (height {h})"),
        (None, [x0, y0], [x1, y1]) => ((*x0, *y0), (*x1, *y1)),
        _ => bail!("no line given\n  fix: give --row Y, or --from X,Y --to X,Y"),
    };
    let (cd, ca) = match (cd, &fit) {
        (Some(cd), _) => (cd, ca),
        (None, Some(f)) => {
            let m = pick_fit(f, &pick.want(channel.as_deref()), None)?.model;
            let pd = m.pd();
            (pd * irradiance / std::f64::consts::PI, pd * ambient)
        }
        (None, None) => bail!(
            "no diffuse constant\n  fix: give --cd VALUE, or --fit FILE (with --irradiance and --ambient)"
        ),
    };
    check_constants(cd, ca, pixel_size, &light, &light2)?;
    let (dx, dy) = (b.0 as f64 - a.0 as f64, -(b.1 as f64 - a.1 as f64));
    let len = (dx * dx + dy * dy).sqrt().max(1e-12);
    let proj = |l: &[f64]| {
        let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt().max(1e-12);
        [(l[0] * dx + l[1] * dy) / len / n, l[2] / n]
    };
    let samples = inverse::sample_line(w, h, &lum, a, b);
    let pos: Vec<(u32, u32)> = samples.iter().map(|s| s.0).collect();
    let vals: Vec<f64> = samples.iter().map(|s| s.1).collect();
    let px = match image2 {
        Some(p2) => {
            if light2.len() != 3 {
                bail!("--image2 needs --light2 x,y,z");
            }
            let (w2, h2, lum2) = read(&p2)?;
            if (w2, h2) != (w, h) {
                bail!(
                    "{}: the second image is {w2}×{h2}, the first {w}×{h}",
                    p2.display()
                );
            }
            let v2: Vec<f64> = inverse::sample_line(w, h, &lum2, a, b)
                .iter()
                .map(|s| s.1)
                .collect();
            inverse::invert_line_two_lights(
                &vals,
                &v2,
                proj(&light),
                proj(&light2),
                ca,
                cd,
                pixel_size,
            )
        }
        None => inverse::invert_line(&vals, proj(&light), ca, cd, pixel_size, prior),
    };
    write_file(
        &base.with_extension("csv"),
        inverse::to_csv(&px, &pos).as_bytes(),
    )?;
    let mut series = vec![brdfit::plot::LobeSeries {
        label: "estimated height".into(),
        points: px
            .iter()
            .filter(|p| p.height.is_finite())
            .map(|p| (p.t, p.height))
            .collect(),
        markers: false,
    }];
    if let Some(t) = truth {
        let d = brdfit::support::input::read_to_string_limited(
            &t,
            brdfit::support::input::Input::Data,
        )?;
        let pts = inverse::read_truth_csv(&d);
        series.push(brdfit::plot::LobeSeries {
            label: "true height".into(),
            points: pts,
            markers: false,
        });
    }
    let chart = brdfit::plot::XyChart {
        title: format!("Height profile by inverse Phong: {}", image.display()),
        x_label: "pixel along the line".into(),
        y_label: "relative height (world units)".into(),
        series,
        log_x: false,
        log_y: false,
        hline: None,
    };
    save_chart(&chart, &base)?;
    let flagged = px.iter().filter(|p| p.flagged).count();
    if flagged > 0 {
        eprintln!(
            "note: {flagged} of {} pixels have no solution (value outside the model's range) and are flagged",
            px.len()
        );
    }
    Ok(())
}

/// The shading constants, the pixel size and the light directions, checked with the fix.
fn check_constants(cd: f64, ca: f64, pixel_size: f64, light: &[f64], light2: &[f64]) -> Result<()> {
    if !(cd.is_finite() && cd > 0.0) {
        bail!(
            "the diffuse constant Cd = {cd} must be a finite number > 0: the shading cos θ = (I − Ca)/Cd needs it\n  fix: give --cd as the image value a surface facing the light adds above the ambient (e.g. --cd 0.8)"
        );
    }
    if !(ca.is_finite() && ca >= 0.0) {
        bail!(
            "the ambient constant Ca = {ca} must be a finite number ≥ 0\n  fix: give --ca 0 or the image value of a surface facing away from the light"
        );
    }
    if !(pixel_size.is_finite() && pixel_size > 0.0) {
        bail!("--pixel-size {pixel_size} must be a finite number > 0\n  fix: e.g. --pixel-size 1");
    }
    for (flag, l) in [("--light", &light), ("--light2", &light2)] {
        if l.is_empty() && flag == "--light2" {
            continue;
        }
        if l.len() != 3 {
            bail!("{flag} needs x,y,z\n  fix: e.g. {flag} 0,0,1 (toward the viewer)");
        }
        let norm = l.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm.is_finite() && norm > 1e-9) {
            bail!(
                "{flag} {},{},{} is not a direction (it must be finite and not zero)\n  fix: e.g. {flag} 0.5,0,1",
                l[0],
                l[1],
                l[2]
            );
        }
    }
    Ok(())
}
