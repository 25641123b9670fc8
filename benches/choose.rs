//! Render cost of the Figure 7 front-lit sphere at 512² with each candidate model and with a
//! measured material (MERL alumina-oxide, green, resampled onto its half/difference table):
//! the tie-break order of `choose` (`RENDER_COST_ORDER`) and the README's "a measured material
//! costs no more than 3× a fitted model".
//!
//! Run: `cargo bench --bench choose`.

use brdfit::choose::{RENDER_COST_ORDER, fig7_cases, model_name};
use brdfit::fit::{self, FitOptions};
use brdfit::render::measured::{Dims, Tabulated};
use criterion::{Criterion, criterion_group, criterion_main};
use std::sync::Arc;
use std::time::Duration;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn bench(c: &mut Criterion) {
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

criterion_group!(benches, bench);
criterion_main!(benches);
