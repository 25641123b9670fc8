//! A choice's files: each case's renders, error map, contact sheet and chart, then
//! `choose.json` and `choose.md`.

use super::chart::TradeoffChart;
use super::markdown::markdown;
use super::sheet::{contact_sheet, magma};
use super::{CaseImages, CaseResult, ChooseResult, ThresholdJson, Verdict};
use rayon::prelude::*;

/// Write each case's renders (`DIR/<case>/measured.{exr,png}` and `DIR/<case>/<model>.{exr,png}`,
/// one exposure), its contact sheet (`sheet.png`) and chart (`chart.{svg,png}`), then
/// `DIR/choose.json` and `DIR/choose.md`; returns the paths written, in order.
pub fn write(
    dir: &std::path::Path,
    result: &ChooseResult,
    images: &[CaseImages],
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    // Staged and renamed whole: two runs, or a killed run, never mix their files.
    crate::support::output::write_dir_atomic(dir, |stage| write_into(stage, result, images))
}

/// [`write`]'s files, into `dir` directly.
fn write_into(
    dir: &std::path::Path,
    result: &ChooseResult,
    images: &[CaseImages],
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use crate::support::output::write_bytes_atomic;
    // The cases' directories in order (the list of directories created stays in case
    // order), then each case's files in parallel; the paths in case order.
    for case in &result.cases {
        crate::support::output::create_dir(&dir.join(&case.case))?;
    }
    let per_case = result
        .cases
        .par_iter()
        .zip(images.par_iter())
        .map(|(case, imgs)| write_case(&dir.join(&case.case), case, imgs, &result.threshold))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut wrote: Vec<std::path::PathBuf> = per_case.into_iter().flatten().collect();
    let json = dir.join("choose.json");
    let mut text = serde_json::to_string_pretty(result)?;
    text.push('\n');
    write_bytes_atomic(&json, text.as_bytes())?;
    wrote.push(json);
    let md = dir.join("choose.md");
    write_bytes_atomic(&md, markdown(result).as_bytes())?;
    wrote.push(md);
    Ok(wrote)
}

/// One case's files in `sub` (renders, the reference's error map when undetermined, sheet,
/// chart); the paths written, in order.
fn write_case(
    sub: &std::path::Path,
    case: &CaseResult,
    imgs: &CaseImages,
    threshold: &ThresholdJson,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use crate::support::output::write_bytes_atomic;
    // The renders' PNG and EXR encodings in parallel, beside the error map, the sheet and
    // the chart (each file is written whole, so the order of work is free); the paths in
    // render order, then the others.
    let (saved, others) = rayon::join(
        || {
            imgs.renders
                .par_iter()
                .enumerate()
                .map(|(k, (name, img))| {
                    crate::render::save(
                        img,
                        &sub.join(if k == 0 { "measured" } else { name.as_str() }),
                    )
                })
                .collect::<anyhow::Result<Vec<_>>>()
        },
        || -> anyhow::Result<Vec<std::path::PathBuf>> {
            let mut wrote = Vec::new();
            if case.verdict == Verdict::Undetermined {
                let path = sub.join("reference-error.png");
                write_bytes_atomic(&path, &reference_error_png(imgs, threshold)?)?;
                wrote.push(path);
            }
            let sheet = sub.join("sheet.png");
            write_bytes_atomic(&sheet, &contact_sheet(case, imgs, threshold)?)?;
            wrote.push(sheet);
            let (svg, png) = crate::plot::save(
                &TradeoffChart {
                    case: case.clone(),
                    threshold: threshold.clone(),
                },
                &sub.join("chart"),
            )?;
            wrote.push(svg);
            wrote.push(png);
            Ok(wrote)
        },
    );
    let mut wrote: Vec<std::path::PathBuf> = saved?.into_iter().flatten().collect();
    wrote.extend(others?);
    Ok(wrote)
}

/// The reference's own error per pixel as an sRGB PNG: magma from 0 to twice the threshold
/// (ꟻLIP), the object's pixels only (others black).
fn reference_error_png(imgs: &CaseImages, th: &ThresholdJson) -> anyhow::Result<Vec<u8>> {
    let lut = nv_flip::magma_lut().to_vec();
    let top = if th.metric.starts_with("flip") {
        2.0 * th.value
    } else {
        0.1
    } as f32;
    let img = &imgs.renders[0].1;
    let rgb: Vec<u8> = imgs
        .reference_error_map
        .iter()
        .zip(&imgs.mask)
        .flat_map(|(&e, &m)| if m { magma(&lut, e, top) } else { [0, 0, 0] })
        .collect();
    crate::plot::encode_png(img.width, img.height, &rgb)
}
