//! `brdfit render`: scene files and Blinn's Figure 7 through the library's renderer.

use super::*;
use anyhow::{Result, anyhow, bail};
use brdfit::model::{Model, ModelKind};
use std::path::{Path, PathBuf};

/// The Torrance–Sparrow model of a fit file for Figure 7 (`default` without one): the file's
/// torrance-sparrow fit of the channel `pick` and `channel` ask for.
pub(crate) fn ts_model_from(
    fit: Option<&Path>,
    default: Model,
    pick: &PickArgs,
    channel: Option<&str>,
) -> Result<Model> {
    match fit {
        None => Ok(default),
        Some(p) => {
            if pick.model.is_some_and(|m| m != ModelKind::TorranceSparrow) {
                bail!(
                    "fig7 draws Blinn's Torrance–Sparrow objects, not {}\n  fix: leave out --model (or give --model torrance-sparrow)",
                    pick.model.map_or(String::new(), |m| m.to_string())
                );
            }
            let mut want = pick.want(channel);
            want.model = Some(ModelKind::TorranceSparrow);
            let fits = read_fits(p)?;
            if pick.model.is_none() && !quiet() {
                let others: Vec<String> = fits
                    .iter()
                    .filter(|f| f.model != ModelKind::TorranceSparrow)
                    .map(|f| f.label())
                    .fold(Vec::new(), |mut v, l| {
                        if !v.contains(&l) {
                            v.push(l);
                        }
                        v
                    });
                if !others.is_empty() {
                    eprintln!(
                        "note: {}: fig7 draws Blinn's Torrance–Sparrow objects: using the file's torrance-sparrow fit (it also holds {})",
                        p.display(),
                        others.join(", ")
                    );
                }
            }
            if !fits.iter().any(|f| f.model == ModelKind::TorranceSparrow) {
                bail!(
                    "{}: fig7 draws Blinn's Torrance–Sparrow objects, and the file holds no torrance-sparrow fit (it holds {})\n  fix: fit one: brdfit fit DATA --model torrance-sparrow --json OUT",
                    p.display(),
                    fits.iter()
                        .fold(Vec::new(), |mut v, f| {
                            if !v.contains(&f.label()) {
                                v.push(f.label());
                            }
                            v
                        })
                        .join(", ")
                );
            }
            // The pick's own fixes, in fig7's terms: another model is no Torrance–Sparrow object.
            let r = pick_fit_from(p, &fits, &want, None).map_err(|e| {
                anyhow!(
                    "{}",
                    e.to_string().replace(
                        "pick another with --model",
                        "pick another torrance-sparrow distribution with --distribution"
                    )
                )
            })?;
            Ok(r.model)
        }
    }
}

/// fig7's `-o` names a folder (its eight images as PNG + EXR and the contact sheet fig7.png):
/// a name with an extension (`-o x.jpg`, which made a folder named x.jpg) is refused with the
/// fix unless it is an existing folder, and so is an existing file.
fn fig7_folder(output: &Path) -> Result<()> {
    let name = output.display();
    if output.exists() && !output.is_dir() {
        bail!(
            "-o {name}: is a file, and render fig7 writes a folder (eight images as PNG and EXR, and the contact sheet fig7.png)\n  fix: give a folder, e.g. -o {}",
            free_folder(output).display()
        );
    }
    if let Some(e) = output.extension()
        && !output.is_dir()
    {
        bail!(
            "-o {name}: render fig7 writes a folder (eight images as PNG and EXR, and the contact sheet fig7.png), not a .{} file\n  fix: give a folder name without an extension, e.g. -o {} (it writes {})",
            e.to_string_lossy(),
            free_folder(output).display(),
            free_folder(output).join("fig7.png").display()
        );
    }
    Ok(())
}

/// A folder name for fig7's fix that works when followed: `output` without its extension, or
/// with `-fig7` (then `-fig7-2`, …) appended while that names an existing file.
fn free_folder(output: &Path) -> PathBuf {
    let base = output.with_extension("");
    let mut candidate = base.clone();
    let mut k = 1;
    while candidate.exists() && !candidate.is_dir() {
        let suffix = if k == 1 {
            "-fig7".to_string()
        } else {
            format!("-fig7-{k}")
        };
        let mut name = base.as_os_str().to_owned();
        name.push(suffix);
        candidate = PathBuf::from(name);
        k += 1;
    }
    candidate
}

pub(crate) fn run_render(
    scene: &str,
    output: &Path,
    al: Option<&Path>,
    mgo: Option<&Path>,
    (pick, channel): (&PickArgs, Option<&str>),
    (res, allow_large): (u32, bool),
    quiet: bool,
) -> Result<()> {
    use brdfit::render;
    if !(1..=16384).contains(&res) {
        bail!("--res {res} is out of range\n  fix: give a resolution between 1 and 16384");
    }
    if scene == "fig7" {
        fig7_folder(output)?;
        render::check_image_size(res, res, allow_large).map_err(|e| anyhow!("--res {res}: {e}"))?;
        // Eight images and their sheet at about 110 bytes a pixel of one image (`--res 4096`
        // reached 1.8 GB): 2048 stays under 0.5 GB.
        if res > 2048 && !allow_large {
            bail!(
                "--res {res}: render fig7 would keep about {:.1} GB (eight {res}×{res} images), above the 1 GB it uses without asking\n  fix: give --res 2048 or less, or allow it with --allow-large-image",
                (res as f64).powi(2) * 110.0 / 1e9
            );
        }
        let al = ts_model_from(al, Model::blinn_aluminium(), pick, channel)?;
        let mgo = ts_model_from(mgo, Model::blinn_mgo(), pick, channel)?;
        for (m, flag) in [(&al, "--aluminium"), (&mgo, "--mgo")] {
            render::fig7_scene(*m, render::Lighting::Front, res)
                .check_inputs()
                .map_err(|e| anyhow!("{flag}: {e}"))?;
        }
        let bar = if quiet {
            indicatif::ProgressBar::hidden()
        } else {
            progress_bar(8 * res as u64, "rows of 8 images")
        };
        let t = std::time::Instant::now();
        let imgs = render::fig7_images_with_progress(
            &al,
            &mgo,
            res,
            render::AntiAlias::Adaptive {
                threshold: 0.02,
                max_level: 3,
                block: 1,
                jitter: false,
            },
            &|| bar.inc(1),
        );
        bar.finish_and_clear();
        for (name, img) in &imgs {
            save_image(img, &output.join(name))?;
        }
        write_file(&output.join("fig7.png"), &render::contact_sheet(&imgs)?)?;
        if !quiet {
            eprintln!(
                "rendered 8 images {res}×{res} in {:.2} s",
                t.elapsed().as_secs_f64()
            );
        }
        return Ok(());
    }
    let base = output_base(output, &["png", "exr"])?;
    let inputs = [Path::new(scene)];
    for ext in ["png", "exr"] {
        refuse_input(&base.with_extension(ext), &inputs)?;
    }
    let s = load_scene(Path::new(scene))?;
    render::check_image_size(s.camera.width, s.camera.height, allow_large)
        .map_err(|e| anyhow!("{scene}: camera: {e}"))?;
    let bar = if quiet {
        indicatif::ProgressBar::hidden()
    } else {
        progress_bar(s.camera.height as u64, "rows")
    };
    let t = std::time::Instant::now();
    let img = s.render(&|| bar.inc(1));
    let seconds = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if !quiet {
        eprintln!(
            "rendered {}×{} in {seconds:.4} s: {:.2} primary rays per pixel, {} rays in all",
            img.width,
            img.height,
            img.primary_per_pixel(),
            img.total_rays()
        );
    }
    save_image(&img, &base)?;
    Ok(())
}
