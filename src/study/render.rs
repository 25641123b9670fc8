//! The render study: image error against time and rays per pixel, uniform against adaptive
//! anti-aliasing, on the Figure 7 scenes.

use crate::model::Model;
use crate::plot::{LobeSeries, XyChart};
use std::fmt::Write;

/// One row of the render study.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderRow {
    /// `uniform` or `adaptive`.
    pub mode: String,
    /// Samples per axis (uniform) or threshold (adaptive).
    pub setting: f64,
    /// Primary rays per pixel, averaged over the scenes.
    pub rays_per_pixel: f64,
    /// All rays (primary and shadow) per pixel, averaged over the scenes.
    pub all_rays_per_pixel: f64,
    /// Render time summed over the scenes.
    pub seconds: f64,
    /// RMSE on linear values against the 16×16-supersampled reference, averaged over scenes.
    pub rmse: f64,
}

/// Image error against time and rays per pixel, uniform against adaptive anti-aliasing, on the
/// Figure 7 scenes (Blinn's aluminium and MgO, front and edge lit, Torrance–Sparrow) at
/// `res`×`res`, against a 16×16-supersampled reference of each.
pub fn render_study(res: u32) -> Vec<RenderRow> {
    render_study_with_progress(res, &|_, _, _| {})
}

/// [`render_study`] with progress as [`render_study_scenes_with_progress`] gives it.
pub fn render_study_with_progress(
    res: u32,
    progress: &(dyn Fn(usize, usize, &str) + Sync),
) -> Vec<RenderRow> {
    use crate::render::{Lighting, fig7_scene};
    let scenes: Vec<crate::render::Scene> = [Model::blinn_aluminium(), Model::blinn_mgo()]
        .iter()
        .flat_map(|m| [Lighting::Front, Lighting::Edge].map(|l| fig7_scene(*m, l, res)))
        .collect();
    render_study_scenes_with_progress(&scenes, progress)
}

/// [`render_study`] on any scenes (each at its own resolution).
pub fn render_study_scenes(scenes: &[crate::render::Scene]) -> Vec<RenderRow> {
    render_study_scenes_with_progress(scenes, &|_, _, _| {})
}

/// The anti-aliasing settings the render study compares: uniform n×n for n = 1…6, and
/// Whitted's adaptive corner sampling (4 levels) at six thresholds.
fn render_study_settings() -> Vec<(String, f64, crate::render::AntiAlias)> {
    use crate::render::AntiAlias;
    let mut settings: Vec<(String, f64, AntiAlias)> = (1..=6)
        .map(|n| ("uniform".to_string(), n as f64, AntiAlias::Uniform(n)))
        .collect();
    for th in [0.2, 0.1, 0.05, 0.02, 0.01, 0.005] {
        settings.push((
            "adaptive".into(),
            th,
            AntiAlias::Adaptive {
                threshold: th,
                max_level: 4,
                block: 1,
                jitter: false,
            },
        ));
    }
    settings
}

/// [`render_study_scenes`], calling `progress(done, total, what)` as each image row is
/// rendered and once at the end (`done == total`); `what` names the render under way, e.g.
/// `adaptive 0.05, scene 2 of 4`. A row counts its samples per pixel (256 for the reference,
/// n² for uniform n×n, 2 for adaptive: what its rays cost), so a bar's estimate of the time
/// left holds through the references (about 70 % of the time). A study at 1024 × 1024
/// renders for minutes.
pub fn render_study_scenes_with_progress(
    scenes: &[crate::render::Scene],
    progress: &(dyn Fn(usize, usize, &str) + Sync),
) -> Vec<RenderRow> {
    use crate::render::{self, AntiAlias};
    let settings = render_study_settings();
    let weight = |aa: AntiAlias| match aa {
        AntiAlias::Uniform(n) | AntiAlias::Stratified(n) => (n * n) as usize,
        AntiAlias::None => 1,
        AntiAlias::Adaptive { .. } => 2,
    };
    let rows: usize = scenes.iter().map(|s| s.camera.height as usize).sum();
    let per_row =
        weight(AntiAlias::Uniform(16)) + settings.iter().map(|s| weight(s.2)).sum::<usize>();
    let total = rows * per_row;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let with = |k: usize, s: &render::Scene, aa: AntiAlias, what: &str| {
        let what = format!("{what}, scene {} of {}", k + 1, scenes.len());
        progress(
            done.load(std::sync::atomic::Ordering::Relaxed),
            total,
            &what,
        );
        let mut s = s.clone();
        s.antialias = aa;
        let w = weight(aa);
        let t = std::time::Instant::now();
        let img = s.render(&|| {
            let d = done.fetch_add(w, std::sync::atomic::Ordering::Relaxed) + w;
            progress(d, total, &what);
        });
        (img, t.elapsed().as_secs_f64())
    };
    let refs: Vec<render::Image> = scenes
        .iter()
        .enumerate()
        .map(|(k, s)| with(k, s, AntiAlias::Uniform(16), "16×16 reference").0)
        .collect();
    let px = |s: &render::Scene| (s.camera.width as f64) * (s.camera.height as f64);
    let out = settings
        .into_iter()
        .map(|(mode, setting, aa)| {
            let what = match aa {
                AntiAlias::Uniform(n) => format!("uniform {n}×{n}"),
                _ => format!("{mode} {setting}"),
            };
            let (mut rays, mut all, mut secs, mut err) = (0.0, 0.0, 0.0, 0.0);
            for (k, (s, r)) in scenes.iter().zip(&refs).enumerate() {
                let (img, t) = with(k, s, aa, &what);
                rays += img.rays[0] as f64 / px(s);
                all += img.total_rays() as f64 / px(s);
                secs += t;
                err += render::rmse(&img, r);
            }
            let k = scenes.len() as f64;
            RenderRow {
                mode,
                setting,
                rays_per_pixel: rays / k,
                all_rays_per_pixel: all / k,
                seconds: secs,
                rmse: err / k,
            }
        })
        .collect();
    progress(total, total, "done");
    out
}

/// Chart of the render study: RMSE against primary rays per pixel (or time).
pub fn render_chart(title: &str, rows: &[RenderRow], by_time: bool) -> XyChart {
    let series = ["uniform", "adaptive"]
        .iter()
        .map(|m| LobeSeries {
            label: if *m == "uniform" {
                "uniform n×n supersampling".into()
            } else {
                "Whitted adaptive corner sampling".into()
            },
            points: rows
                .iter()
                .filter(|r| r.mode == *m)
                .map(|r| (if by_time { r.seconds } else { r.rays_per_pixel }, r.rmse))
                .collect(),
            markers: false,
        })
        .collect();
    XyChart {
        title: title.to_string(),
        x_label: if by_time {
            "render time, 4 scenes (s)".into()
        } else {
            "primary rays per pixel".into()
        },
        y_label: "RMSE against 16×16 reference (linear)".into(),
        series,
        log_x: true,
        log_y: true,
        hline: None,
    }
}

/// Markdown and CSV tables of the render study; times only when `with_times`.
pub fn render_tables(rows: &[RenderRow], with_times: bool) -> (String, String) {
    let mut md = format!(
        "| mode | setting | primary rays/pixel | all rays/pixel |{} RMSE |\n|---|---:|---:|---:|{}---:|\n",
        if with_times { " time (s) |" } else { "" },
        if with_times { "---:|" } else { "" }
    );
    let mut csv = format!(
        "mode,setting,rays_per_pixel,all_rays_per_pixel,{}rmse\n",
        if with_times { "seconds," } else { "" }
    );
    for r in rows {
        let t = if with_times {
            format!(" {:.3} |", r.seconds)
        } else {
            String::new()
        };
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} |{t} {:.3e} |",
            r.mode, r.setting, r.rays_per_pixel, r.all_rays_per_pixel, r.rmse
        );
        let t = if with_times {
            format!("{},", r.seconds)
        } else {
            String::new()
        };
        let _ = writeln!(
            csv,
            "{},{},{},{},{t}{}",
            r.mode, r.setting, r.rays_per_pixel, r.all_rays_per_pixel, r.rmse
        );
    }
    (md, csv)
}

/// The cheapest uniform and adaptive settings reaching `target` RMSE: (uniform rays/pixel,
/// adaptive rays/pixel).
pub fn rays_at_error(rows: &[RenderRow], target: f64) -> (Option<f64>, Option<f64>) {
    let best = |m: &str| {
        rows.iter()
            .filter(|r| r.mode == m && r.rmse <= target)
            .map(|r| r.rays_per_pixel)
            .fold(None, |a: Option<f64>, b| Some(a.map_or(b, |a| a.min(b))))
    };
    (best("uniform"), best("adaptive"))
}
