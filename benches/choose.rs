//! Render cost of the Figure 7 front-lit sphere at 512² with each candidate model and with a
//! measured material (MERL alumina-oxide, green, resampled onto its half/difference table):
//! the tie-break order of `choose` (`RENDER_COST_ORDER`) and the README's "a measured material
//! costs no more than 3× a fitted model". Also LDR-ꟻLIP of one candidate's render against the
//! reference at 512² (`flip_512`): NVIDIA's C++ through `nv-flip` (both images converted and
//! filtered on every call, as `choose` did before), the Rust port preparing the reference on
//! each call, and against a reference prepared once (what `choose` does now).
//!
//! `render_fig7_512_shared` renders as `choose` does: reading the case's geometry pass
//! (`Scene::corners`, itself timed as `corners`), with the Torrance–Sparrow D3 fit and with the
//! measurement reconstructed on its goniometer grid (`reconstruct`, `GonioGrid` lookups).
//!
//! Run: `cargo bench --bench choose` (`-- flip` for the ꟻLIP group alone, `-- shared` for the
//! renders as `choose` makes them).

use brdfit::choose::{RENDER_COST_ORDER, fig7_cases, model_name};
use brdfit::fit::{self, FitOptions};
use brdfit::render::measured::{Dims, Tabulated};
use criterion::{Criterion, criterion_group, criterion_main};
use std::sync::Arc;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    // The allocator set as the `brdfit` binary sets it, so the figures are the binary's (the
    // first group runs first).
    brdfit::keep_freed_memory();
    let ds = brdfit::load(
        std::path::Path::new("data/merl-alumina-oxide.csv"),
        &Default::default(),
    )
    .unwrap();
    let ds = brdfit::data::representative_channel(&ds).unwrap().0;
    let mut g = c.benchmark_group("render_fig7_512");
    g.sample_size(10).measurement_time(Duration::from_secs(6));
    for case in fig7_cases(512) {
        let mut best = None;
        for &(kind, dist) in &RENDER_COST_ORDER {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            let model = fit::fit(&ds, &o).unwrap().remove(0).model_for(0);
            if model_name(kind, dist) == "torrance-sparrow-d3" {
                best = Some(model);
            }
            let mut s = case.scene.clone();
            s.materials[0].model = model;
            g.bench_function(format!("{}/{}", case.name, model_name(kind, dist)), |b| {
                b.iter(|| s.render(&|| {}))
            });
        }
        let fill = best.unwrap();
        let table = Arc::new(Tabulated::resample(&ds, Dims::for_samples(ds.len()), fill));
        let mut s = case.scene.clone();
        s.materials[0].model = fill;
        s.materials[0].measured = Some(table);
        g.bench_function(format!("{}/measured", case.name), |b| {
            b.iter(|| s.render(&|| {}))
        });
    }
    g.finish();
}

fn bench_flip(c: &mut Criterion) {
    use brdfit::render::compare::{FlipReference, PIXELS_PER_DEGREE};
    use brdfit::render::to_srgb8;
    let ds = brdfit::load(
        std::path::Path::new("data/merl-alumina-oxide.csv"),
        &Default::default(),
    )
    .unwrap();
    let ds = brdfit::data::representative_channel(&ds).unwrap().0;
    let mut g = c.benchmark_group("flip_512");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for case in fig7_cases(512) {
        let fitted = |kind, dist| {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            fit::fit(&ds, &o).unwrap().remove(0).model_for(0)
        };
        let fill = fitted(
            brdfit::model::ModelKind::TorranceSparrow,
            brdfit::model::Distribution::D3,
        );
        let table = Arc::new(Tabulated::resample(&ds, Dims::for_samples(ds.len()), fill));
        let mut s = case.scene.clone();
        s.materials[0].model = fill;
        s.materials[0].measured = Some(table);
        let reference = s.render(&|| {});
        s.materials[0].measured = None;
        s.materials[0].model = fitted(
            brdfit::model::ModelKind::Phong,
            brdfit::model::Distribution::D3,
        );
        let test = s.render(&|| {});
        let (r, t) = (to_srgb8(&reference), to_srgb8(&test));
        let (w, h) = (reference.width, reference.height);
        g.bench_function(format!("{}/nv-flip", case.name), |b| {
            b.iter(|| {
                let ri = nv_flip::FlipImageRgb8::with_data(w, h, &r);
                let ti = nv_flip::FlipImageRgb8::with_data(w, h, &t);
                nv_flip::flip(ri, ti, PIXELS_PER_DEGREE).to_vec()
            })
        });
        g.bench_function(format!("{}/port", case.name), |b| {
            b.iter(|| brdfit::render::compare::flip(&r, &t, w, h))
        });
        let prepared = FlipReference::new(&r, w, h, PIXELS_PER_DEGREE);
        g.bench_function(format!("{}/prepared", case.name), |b| {
            b.iter(|| prepared.against(&t))
        });
    }
    g.finish();
}

fn bench_shared(c: &mut Criterion) {
    let ds = brdfit::load(
        std::path::Path::new("data/merl-alumina-oxide.csv"),
        &Default::default(),
    )
    .unwrap();
    let ds = brdfit::data::representative_channel(&ds).unwrap().0;
    let mut o = FitOptions::new(brdfit::model::ModelKind::TorranceSparrow);
    o.dist = brdfit::model::Distribution::D3;
    let fill = fit::fit(&ds, &o).unwrap().remove(0).model_for(0);
    let table = Arc::new(brdfit::render::reconstruct::reconstruct(
        &ds,
        Dims::for_samples(ds.len()),
        fill,
    ));
    let mut g = c.benchmark_group("render_fig7_512_shared");
    g.sample_size(10).measurement_time(Duration::from_secs(6));
    for case in fig7_cases(512) {
        g.bench_function(format!("{}/corners", case.name), |b| {
            b.iter(|| case.scene.corners())
        });
        let corners = case.scene.corners();
        let mut s = case.scene.clone();
        s.materials[0].model = fill;
        g.bench_function(format!("{}/torrance-sparrow-d3", case.name), |b| {
            b.iter(|| s.render_with_corners(Some(&corners), &|| {}))
        });
        s.materials[0].measured = Some(table.clone());
        g.bench_function(format!("{}/measured-grid", case.name), |b| {
            b.iter(|| s.render_with_corners(Some(&corners), &|| {}))
        });
        g.bench_function(format!("{}/measured-grid-unshared", case.name), |b| {
            b.iter(|| s.render(&|| {}))
        });
    }
    g.finish();
}

criterion_group!(benches, bench, bench_flip, bench_shared);
criterion_main!(benches);
