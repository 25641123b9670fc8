//! brdfit's fits of MERL materials against an independent truth (the Neural-BRDF networks,
//! symmetrised) beside the published ABC fits of Löw et al. 2012.
//!
//! Training data: each network on the goniometer grid (θi 10–80°, θo 0–85°, φo every 15°; the
//! tables of the Neural-BRDF networks, github.com/asztr/Neural-BRDF), green channel, every model fitted with the default
//! options. Test set per material, from seeded streams: 50,000 configurations uniform in solid
//! angle with θi, θo ≤ 80° (five streams of 10,000: a 10,000-configuration half moved with the
//! seed by more than the gaps it had to settle); 10,000 near the mirror, θh log-uniform in
//! 0.01°–30°, φh, φd uniform, θd uniform in 0°–80°, kept where θi, θo ≤ 80°. Error: the RMSE of
//! ln(1 + f cosθi) − ln(1 + f_truth cosθi) over each half, and over the whole set with the two
//! halves weighing equally (as in a set of 10,000 + 10,000).
//! `cargo test --release --test it truth:: -- --nocapture` prints every model's error on the whole
//! set and on its uniform half for the 8 materials, with the default weights and with
//! `--weights solid-angle`.

use super::truth_two_abc::fit_two_abc;
use crate::common::sphere;

use brdfit::data::nbrdf::Nbrdf;
use brdfit::data::{Dataset, Quantity};
use brdfit::fit::Weighting;
use brdfit::model::{Geometry, fresnel, geometric_attenuation};
use brdfit::{FitOptions, fit};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) const MATERIALS: [&str; 8] = [
    "alumina-oxide",
    "aluminium",
    "blue-acrylic",
    "chrome",
    "silver-paint",
    "steel",
    "white-diffuse-bball",
    "white-paint",
];

/// Löw et al. 2012's ABC model as published: (kD, A, B, C, ior), green channel.
#[derive(Clone, Copy)]
pub(crate) struct Abc(pub(crate) [f64; 5]);

impl Abc {
    /// f = kD/π + F(ior, E·H) D G/(π cosθi cosθo), D = A/(1 + B(1 − cosθh))^C.
    pub(crate) fn brdf(&self, g: &Geometry) -> f64 {
        let [kd, a, b, c, ior] = self.0;
        if !g.visible() {
            return 0.0;
        }
        let d = a / (1.0 + b * (1.0 - g.nh)).powf(c);
        kd / std::f64::consts::PI
            + fresnel(ior, g.eh) * d * geometric_attenuation(g)
                / (std::f64::consts::PI * g.nl * g.ne)
    }
}

pub(crate) fn abc(name: &str) -> Abc {
    let text = std::fs::read_to_string(
        crate::common::root().join("tests/data/nbrdf/merl_abc_low2012-merl8.csv"),
    )
    .unwrap();
    let row: Vec<f64> = text
        .lines()
        .find(|l| l.split(',').next() == Some(name))
        .unwrap()
        .split(',')
        .skip(1)
        .map(|x| x.parse().unwrap())
        .collect();
    // name,kD_r,kD_g,kD_b,A_r,A_g,A_b,B,C,ior: green.
    Abc([row[1], row[4], row[6], row[7], row[8]])
}

/// The test set: (angles, uniform half?). The 10,000 uniform and 10,000 near-mirror
/// configurations of stream `seed` ([`draws`]), and the uniform halves of streams `seed + 1` to
/// `seed + 4` (those of `uniform_half_across_test_seeds`): 50,000 uniform configurations. A
/// uniform half of 10,000 moved with the seed by more than the few percent it had to settle
/// (the grid's fit at or below ABC on 3, 4, 5, 2, 2 of 8 over seeds 22–26); the near-mirror
/// half stays the first 10,000, and [`log_error`] weighs the halves equally, so the whole set means
/// what it meant.
pub(crate) fn test_set(seed: u64) -> Vec<([f64; 4], bool)> {
    let mut set = draws(seed, 10_000, 10_000);
    for s in seed + 1..=seed + 4 {
        set.extend(draws(s, 10_000, 0));
    }
    set
}

/// `uniform` configurations uniform in solid angle with θi, θo ≤ 80°, then `mirror` near the
/// mirror (θh log-uniform in 0.01°–30°, φh, φd uniform, θd uniform in 0°–80°, kept where θi,
/// θo ≤ 80°), from a ChaCha8 stream seeded with `seed`: (angles, uniform?).
pub(crate) fn draws(seed: u64, uniform: usize, mirror: usize) -> Vec<([f64; 4], bool)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let max = 80f64.to_radians();
    let mut out = Vec::with_capacity(uniform + mirror);
    while out.len() < uniform {
        let ci: f64 = rng.random_range(max.cos()..=1.0);
        let co: f64 = rng.random_range(max.cos()..=1.0);
        let pi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let po: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        out.push(([ci.acos(), pi, co.acos(), po], true));
    }
    let (lo, hi) = (0.01f64.to_radians().ln(), 30f64.to_radians().ln());
    while out.len() < uniform + mirror {
        let th = rng.random_range(lo..hi).exp();
        let ph: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let td: f64 = rng.random_range(0.0..max);
        let pd: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let a = brdfit::data::merl::half_diff_to_std(th, ph, td, pd);
        if a[0] <= max && a[2] <= max {
            out.push((a, false));
        }
    }
    out
}

/// RMSE of ln(1 + f cosθi) against the truth: (whole set, uniform half). The whole set's mean
/// square is the mean of the two halves' (each half weighs ½ however many configurations it
/// has; a set with one half only is that half).
pub(crate) fn log_error(
    set: &[([f64; 4], bool)],
    truth: &[f64],
    f: &dyn Fn(&Geometry) -> f64,
) -> (f64, f64) {
    // Σr² and count of the near-mirror half [0] and the uniform half [1].
    let (mut sum, mut n) = ([0.0; 2], [0.0; 2]);
    for ((a, uniform), t) in set.iter().zip(truth) {
        let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
        let c = a[0].cos();
        let r = (1.0 + f(&g) * c).ln() - (1.0 + t * c).ln();
        sum[usize::from(*uniform)] += r * r;
        n[usize::from(*uniform)] += 1.0;
    }
    let ms: Vec<f64> = (0..2)
        .filter(|&h| n[h] > 0.0)
        .map(|h| sum[h] / n[h])
        .collect();
    let all = ms.iter().sum::<f64>() / ms.len() as f64;
    (all.sqrt(), (sum[1] / n[1]).sqrt())
}

/// One material: the network, the test set's truth and every catalogue model fitted to the
/// network's goniometer samples (green), with each fit's error.
struct Fitted {
    net: Nbrdf,
    fits: Vec<brdfit::FitResult>,
    /// (whole set, uniform half) per fit.
    errors: Vec<(f64, f64)>,
    /// The published ABC fit's (whole set, uniform half).
    e_abc: (f64, f64),
    /// The usable fit with the lowest BIC.
    best: Option<usize>,
    /// The best fit's Σr²/n over the uniform half, split by θh: < 5°, 5–20°, ≥ 20°.
    parts: Vec<f64>,
    /// The same for the published ABC fit.
    parts_abc: Vec<f64>,
}

/// Σr²/n of the log residual of [`log_error`] over the test set (`half`: `Some(true)` the
/// uniform half, `Some(false)` the near-mirror half, `None` the whole set, its halves weighing
/// equally as in [`log_error`]; n counts that half), split into bins of θh at `edges` (degrees,
/// ascending): `edges.len() + 1` bins, summing to that part's mean square.
fn loss_by_theta_h(
    set: &[([f64; 4], bool)],
    truth: &[f64],
    half: Option<bool>,
    edges: &[f64],
    f: &dyn Fn(&Geometry) -> f64,
) -> Vec<f64> {
    // Each sample's weight: 1/n of its half, halved where both halves count.
    let mut n = [0.0; 2];
    for (_, u) in set.iter().filter(|(_, u)| half.is_none_or(|h| h == *u)) {
        n[usize::from(*u)] += 1.0;
    }
    let halves = n.iter().filter(|&&x| x > 0.0).count() as f64;
    let mut acc = vec![0.0; edges.len() + 1];
    for ((a, u), t) in set.iter().zip(truth) {
        if half.is_some_and(|h| h != *u) {
            continue;
        }
        let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
        let c = a[0].cos();
        let r = (1.0 + f(&g) * c).ln() - (1.0 + t * c).ln();
        acc[theta_h_bin(&g, edges)] += r * r / (n[usize::from(*u)] * halves);
    }
    acc
}

/// The bin of θh (degrees) among `edges` (ascending): the number of edges at or below it.
fn theta_h_bin(g: &Geometry, edges: &[f64]) -> usize {
    let th = g.nh.clamp(-1.0, 1.0).acos().to_degrees();
    edges.iter().filter(|&&e| th >= e).count()
}

/// How many of `dirs` fall in each bin of θh at `edges` (degrees).
fn count_by_theta_h(dirs: &[[f64; 4]], edges: &[f64]) -> Vec<usize> {
    let mut n = vec![0; edges.len() + 1];
    for a in dirs {
        n[theta_h_bin(&Geometry::from_angles(a[0], a[1], a[2], a[3]), edges)] += 1;
    }
    n
}

/// The goniometer's grid of the training data (θi 10–80° step 10°, θo 0–85° step 1°, φo
/// every 15°; 16,512 configurations).
pub(crate) fn goniometer() -> Vec<[f64; 4]> {
    brdfit::simulate::Grid::Goniometer.directions(0)
}

/// A goniometer's grid four times finer in each angle: θi 2.5–85° and θo 0–85° in 2.5° steps,
/// φi = 0, φo every 5° (85,680 configurations).
fn fine_goniometer() -> Vec<[f64; 4]> {
    let mut out = Vec::with_capacity(34 * 35 * 72);
    for ti in 1..=34 {
        for to in 0..35 {
            for po in 0..72 {
                let d = [2.5 * ti as f64, 0.0, 2.5 * to as f64, 5.0 * po as f64];
                out.push(d.map(f64::to_radians));
            }
        }
    }
    out
}

/// A dense sampling in the geometry of the MERL tables Löw et al. 2012 fitted: the centres of
/// the MERL 90 × 90 × 180 cells (Matusik et al. 2003; θh on MERL's square-root scale, so its
/// first cells sit 0.003°, 0.025°, 0.07° from the mirror) taking every θh, every third θd and
/// every sixth φd, light and eye above the horizon.
pub(crate) fn dense() -> Vec<[f64; 4]> {
    use brdfit::data::merl::{CELLS, PHI_D, THETA_D, cell_center};
    (0..CELLS)
        .filter(|c| (c / PHI_D) % THETA_D % 3 == 1 && c % PHI_D % 6 == 2)
        .map(cell_center)
        .filter(|a| a[0] < std::f64::consts::FRAC_PI_2 && a[2] < std::f64::consts::FRAC_PI_2)
        .collect()
}

/// The network of `name` and its samples (green) at `dirs` as a data set: the network as it is
/// (as a goniometer measures it), or with `symmetric` the test's truth ([`Nbrdf::eval_symmetric`]).
pub(crate) fn training(name: &str, dirs: &[[f64; 4]], symmetric: bool) -> (Nbrdf, Dataset) {
    let weights = crate::common::root().join("tests/data/nbrdf/weights-merl8.json");
    let net = Nbrdf::load(&weights, &format!("merl/{name}")).unwrap();
    let rgb = brdfit::simulate::simulate_nbrdf(&net, dirs, symmetric);
    let mut ds = Dataset::new(Quantity::Brdf, vec![("g".into(), None)]);
    for k in 0..rgb.len() {
        ds.push(rgb.angles(k), &[rgb.channels[1].values[k]]);
    }
    (net, ds)
}

/// Every catalogue model fitted to the network of `name` sampled at `dirs` ([`fitted_to`]).
fn fitted(name: &str, set: &[([f64; 4], bool)], weights: Weighting, dirs: &[[f64; 4]]) -> Fitted {
    let (net, ds) = training(name, dirs, false);
    fitted_to(name, net, &ds, set, weights)
}

/// Every catalogue model fitted to `ds` (samples of `net`, the network of `name`) with
/// `weights`, judged on the test set `set`.
fn fitted_to(
    name: &str,
    net: Nbrdf,
    ds: &Dataset,
    set: &[([f64; 4], bool)],
    weights: Weighting,
) -> Fitted {
    let truth: Vec<f64> = set.iter().map(|(a, _)| net.eval_symmetric(*a)[1]).collect();
    let fits: Vec<_> = brdfit::model::catalogue()
        .into_iter()
        .map(|(kind, dist)| {
            let mut o = FitOptions::new(kind);
            o.dist = dist;
            o.profile = false;
            o.weights = weights;
            fit(ds, &o).unwrap().remove(0)
        })
        .collect();
    let errors: Vec<(f64, f64)> = fits
        .iter()
        .map(|f| {
            let m = f.model_for(0);
            log_error(set, &truth, &|g| m.brdf(g))
        })
        .collect();
    let published = abc(name);
    let e_abc = log_error(set, &truth, &|g| published.brdf(g));
    let best = (0..fits.len())
        .filter(|&i| fits[i].usable())
        .min_by(|&a, &b| fits[a].bic.total_cmp(&fits[b].bic));
    Fitted {
        net,
        fits,
        errors,
        e_abc,
        best,
        parts: vec![0.0; 3],
        parts_abc: vec![0.0; 3],
    }
    .with_parts(set, &truth, name)
}

impl Fitted {
    /// The uniform half's Σr²/n split by θh (< 5°, 5–20°, ≥ 20°), for the best fit and ABC.
    fn with_parts(mut self, set: &[([f64; 4], bool)], truth: &[f64], name: &str) -> Self {
        let parts =
            |f: &dyn Fn(&Geometry) -> f64| loss_by_theta_h(set, truth, Some(true), &[5.0, 20.0], f);
        if let Some(i) = self.best {
            let m = self.fits[i].model_for(0);
            self.parts = parts(&|g| m.brdf(g));
        }
        let published = abc(name);
        self.parts_abc = parts(&|g| published.brdf(g));
        self
    }
}

/// One weighting's table: every model's errors, the best usable model's and ABC's, and where
/// on the uniform half each loses (Σr²/n by θh). Returns the wins (whole set, uniform half).
fn table(set: &[([f64; 4], bool)], weights: Weighting) -> (usize, usize) {
    let (mut wins, mut wins_uniform) = (0, 0);
    println!("weights: {weights:?}");
    println!(
        "| material | best usable (BIC) | its error, all / uniform | ABC 2012, all / uniform | uniform Σr²/n ×1e5 by θh <5° / 5–20° / ≥20°: best; ABC | every model: all / uniform |"
    );
    println!("|---|---|---|---|---|---|");
    for name in MATERIALS {
        let Fitted {
            fits,
            errors,
            e_abc,
            best,
            parts,
            parts_abc,
            ..
        } = fitted(name, set, weights, &goniometer());
        let every: Vec<String> = fits
            .iter()
            .zip(&errors)
            .map(|(f, e)| {
                format!(
                    "{}{} {:.4}/{:.4}",
                    f.model.label(f.dist),
                    if f.usable() { "" } else { " (not usable)" },
                    e.0,
                    e.1
                )
            })
            .collect();
        let (label, e_best) = match best {
            Some(i) => (fits[i].model.label(fits[i].dist), errors[i]),
            None => ("none".into(), (f64::INFINITY, f64::INFINITY)),
        };
        let p = |x: Vec<f64>| format!("{:.1} / {:.1} / {:.1}", x[0] * 1e5, x[1] * 1e5, x[2] * 1e5);
        println!(
            "| {name} | {label} | {:.4} / {:.4} | {:.4} / {:.4} | {}; {} | {} |",
            e_best.0,
            e_best.1,
            e_abc.0,
            e_abc.1,
            p(parts),
            p(parts_abc),
            every.join("; ")
        );
        if e_best.0 <= e_abc.0 {
            wins += 1;
        }
        if e_best.1 <= e_abc.1 {
            wins_uniform += 1;
        }
    }
    println!(
        "best usable model at or below ABC ({weights:?} weights): {wins} of 8 on the whole set, {wins_uniform} of 8 on the uniform half"
    );
    (wins, wins_uniform)
}

/// brdfit's best usable model (lowest BIC among the usable fits) against the published ABC fit
/// on the independent test set, by default and with `--weights solid-angle`. Measured here
/// (uniform half of 50,000): by default 6 of 8 on the whole set and 4 of 8 on the uniform half
/// (alumina-oxide, aluminium, chrome, steel); solid-angle weights 6 and 3 (silver-paint gains
/// the uniform half, chrome and steel lose it, and the whole set of most materials is worse).
#[test]
fn best_usable_model_against_published_abc() {
    let set = test_set(22);
    let (wins, wins_uniform) = table(&set, Weighting::File);
    let (sa, sa_uniform) = table(&set, Weighting::SolidAngle);
    assert!(
        wins >= 6 && wins_uniform >= 4,
        "default weights: brdfit's best usable model at or below ABC on {wins} of 8 (whole set) and {wins_uniform} of 8 (uniform half); measured 6 and 4"
    );
    assert!(
        sa >= 6 && sa_uniform >= 3,
        "solid-angle weights: at or below ABC on {sa} of 8 (whole set) and {sa_uniform} of 8 (uniform half); measured 6 and 3"
    );
}

/// Chrome's loss is not the fitter's and not a bound's: the TS-abc fit's b is far inside its
/// bounds and pinned by the training samples (holding it at ½× or 2× and refitting the rest
/// costs at least 10 % more), and on the near-mirror half it loses to ABC only at θh < 0.5°,
/// where fewer than 1 in 1000 training samples lie (θh = 0 in the plane of incidence): Σr²/n
/// by θh (< 0.5°, 0.5–5°, ≥ 5°) for the fit and for ABC.
#[test]
fn chrome_highlight_is_pinned_but_unresolved() {
    let set = test_set(22);
    let (net, ds) = training("chrome", &goniometer(), false);
    let truth: Vec<f64> = set.iter().map(|(a, _)| net.eval_symmetric(*a)[1]).collect();
    let mut o = FitOptions::new(brdfit::ModelKind::TorranceSparrow);
    o.dist = brdfit::model::Distribution::Abc;
    o.profile = false;
    let free = fit(&ds, &o).unwrap().remove(0);
    let b = free.get("b").unwrap();
    assert!(b > 1e3 && b < 1e8, "b = {b} sits near a bound (1e-3, 1e9)");
    for mult in [0.5, 2.0] {
        let mut held = o.clone();
        held.fix = vec![("b".into(), b * mult)];
        let f = fit(&ds, &held).unwrap().remove(0);
        println!("b × {mult}: cost {:.3} against {:.3}", f.cost, free.cost);
        assert!(
            f.cost > 1.1 * free.cost,
            "b × {mult}: cost {} against {}",
            f.cost,
            free.cost
        );
    }
    let m = free.model_for(0);
    let published = abc("chrome");
    let bins =
        |f: &dyn Fn(&Geometry) -> f64| loss_by_theta_h(&set, &truth, Some(false), &[0.5, 5.0], f);
    let (ours, theirs) = (bins(&|g| m.brdf(g)), bins(&|g| published.brdf(g)));
    let train = count_by_theta_h(&goniometer(), &[0.5, 5.0]);
    println!(
        "chrome near-mirror half, Σr²/n by θh < 0.5° / 0.5–5° / ≥ 5°: TS-abc {:.4} / {:.4} / {:.4}; ABC {:.4} / {:.4} / {:.4}; training samples {} / {} / {}",
        ours[0], ours[1], ours[2], theirs[0], theirs[1], theirs[2], train[0], train[1], train[2]
    );
    // The loss lies inside 0.5° of the mirror, where the grid has next to no samples; outside
    // it the fit is at least as close as ABC.
    assert!(ours[0] > theirs[0], "{ours:?} {theirs:?}");
    assert!(
        ours[1] <= theirs[1] && ours[2] <= theirs[2] + 1e-4,
        "{ours:?} {theirs:?}"
    );
    assert!(train[0] * 1000 < ds.len(), "{train:?}");
}

/// Ladder or data? Every model fitted to ten samplings of each network, all judged on the
/// same test set against the published ABC fit: the [`goniometer`] grid, as measured and
/// symmetrised, and a [`fine_goniometer`]; the [`dense`] MERL geometry Löw et al. fitted; 60,000 fresh [`draws`] from the
/// test set's own distribution (another seed; with this loss, the fit aimed at the whole set);
/// 30,000 from its uniform half only (aimed at the uniform half); and that uniform draw with
/// 1,500, 3,000, 6,000 or 15,000 near-mirror draws added (one fit for both halves). The draws
/// and the MERL geometry are of the symmetrised network (the test's truth), the goniometers of
/// the network as it is (as measured) unless said. Per sampling, the best usable model
/// (BIC), its errors (whole set / uniform half) and the wins; where the goniometer grid's fit
/// loses against the fit to the test distribution and ABC: Σr²/n by θh (< 0.5°, 0.5–5°,
/// 5–20°, ≥ 20°) on the whole set and on the uniform half; each sampling's training samples
/// per bin. A measurement (about 1.5 min): `cargo test --release --test it truth::dense --
/// --ignored --nocapture`.
#[test]
#[ignore]
fn dense_sampling_against_goniometer_grid() {
    let set = test_set(22);
    let angles = |d: Vec<([f64; 4], bool)>| d.into_iter().map(|(a, _)| a).collect::<Vec<_>>();
    let grids = [
        ("goniometer", goniometer(), false),
        ("goniometer, symmetrised", goniometer(), true),
        ("MERL geometry", dense(), true),
        ("test distribution", angles(draws(7, 30_000, 30_000)), true),
        ("uniform half", angles(draws(7, 30_000, 0)), true),
        ("fine goniometer", fine_goniometer(), false),
        (
            "uniform + 1.5k near-mirror",
            angles(draws(7, 30_000, 1_500)),
            true,
        ),
        (
            "uniform + 3k near-mirror",
            angles(draws(7, 30_000, 3_000)),
            true,
        ),
        (
            "uniform + 6k near-mirror",
            angles(draws(7, 30_000, 6_000)),
            true,
        ),
        (
            "uniform + 15k near-mirror",
            angles(draws(7, 30_000, 15_000)),
            true,
        ),
    ];
    let edges = [0.5, 5.0, 20.0];
    for (label, dirs, _) in &grids {
        println!(
            "{label}: {} training samples, by θh < 0.5° / 0.5–5° / 5–20° / ≥ 20°: {:?}",
            dirs.len(),
            count_by_theta_h(dirs, &edges)
        );
    }
    println!(
        "| material | ABC 2012 | {} | whole set Σr²/n ×1e4 by θh <0.5° / 0.5–5° / 5–20° / ≥20°: goniometer; test distribution; ABC | uniform half, ×1e5: the same |",
        grids.each_ref().map(|(l, _, _)| *l).join(" | ")
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut wins = [[0; 2]; 10];
    for name in MATERIALS {
        let fits: Vec<Fitted> = grids
            .iter()
            .map(|(_, dirs, symmetric)| {
                let (net, ds) = training(name, dirs, *symmetric);
                fitted_to(name, net, &ds, &set, Weighting::File)
            })
            .collect();
        let truth: Vec<f64> = set
            .iter()
            .map(|(a, _)| fits[0].net.eval_symmetric(*a)[1])
            .collect();
        let e_abc = fits[0].e_abc;
        let mut cells = Vec::new();
        for (k, f) in fits.iter().enumerate() {
            let Some(i) = f.best else {
                cells.push("no usable fit".to_string());
                continue;
            };
            let e = f.errors[i];
            wins[k][0] += usize::from(e.0 <= e_abc.0);
            wins[k][1] += usize::from(e.1 <= e_abc.1);
            cells.push(format!("{} {:.4} / {:.4}", f.fits[i].label(), e.0, e.1));
        }
        let published = abc(name);
        let model = |f: &Fitted| f.best.map(|i| f.fits[i].model_for(0));
        let (Some(mg), Some(mt)) = (model(&fits[0]), model(&fits[3])) else {
            println!("| {name} | | {} | | |", cells.join(" | "));
            continue;
        };
        let bins = |half: Option<bool>, scale: f64| {
            [
                loss_by_theta_h(&set, &truth, half, &edges, &|x| mg.brdf(x)),
                loss_by_theta_h(&set, &truth, half, &edges, &|x| mt.brdf(x)),
                loss_by_theta_h(&set, &truth, half, &edges, &|x| published.brdf(x)),
            ]
            .map(|v| {
                v.iter()
                    .map(|x| format!("{:.1}", x * scale))
                    .collect::<Vec<_>>()
                    .join(" / ")
            })
            .join("; ")
        };
        println!(
            "| {name} | {:.4} / {:.4} | {} | {} | {} |",
            e_abc.0,
            e_abc.1,
            cells.join(" | "),
            bins(None, 1e4),
            bins(Some(true), 1e5)
        );
        for (f, (label, _, _)) in fits.iter().zip(&grids) {
            let every: Vec<String> = f
                .fits
                .iter()
                .zip(&f.errors)
                .map(|(m, e)| {
                    let flag = if m.usable() { "" } else { " (not usable)" };
                    format!("{}{flag} {:.4}/{:.4}", m.label(), e.0, e.1)
                })
                .collect();
            println!("  {name}, {label}: {}", every.join("; "));
        }
    }
    for ((label, _, _), w) in grids.iter().zip(wins) {
        println!(
            "{label}: best usable model at or below ABC on {} of 8 (whole set), {} of 8 (uniform half)",
            w[0], w[1]
        );
    }
}

/// How firmly the test set decides the uniform half: the goniometer grid's best usable model
/// (BIC) and the published ABC fit on the uniform halves of five test sets (seeds 22–26,
/// 10,000 configurations each; together the uniform half of [`test_set`]), and the uniform
/// half's best model fitted to 150,000 draws from that half (seed 7). A measurement: `cargo test --release --test it truth::seeds -- --ignored
/// --nocapture`.
#[test]
#[ignore]
fn uniform_half_across_test_seeds() {
    let seeds = [22, 23, 24, 25, 26];
    let sets: Vec<_> = seeds.iter().map(|&s| draws(s, 10_000, 0)).collect();
    let big: Vec<[f64; 4]> = draws(7, 150_000, 0).into_iter().map(|(a, _)| a).collect();
    let mut wins = vec![0; seeds.len()];
    let mut wins_big = vec![0; seeds.len()];
    let mut wins_pooled = [0; 2];
    for name in MATERIALS {
        let published = abc(name);
        let g = fitted(name, &sets[0], Weighting::File, &goniometer());
        let (net, ds) = training(name, &big, true);
        let u = fitted_to(name, net, &ds, &sets[0], Weighting::File);
        let (Some(ig), Some(iu)) = (g.best, u.best) else {
            continue;
        };
        let (mg, mu) = (g.fits[ig].model_for(0), u.fits[iu].model_for(0));
        let (mut cells, mut pooled) = (Vec::new(), [0.0; 3]);
        for (k, set) in sets.iter().enumerate() {
            let truth: Vec<f64> = set
                .iter()
                .map(|(a, _)| g.net.eval_symmetric(*a)[1])
                .collect();
            let e = [
                log_error(set, &truth, &|x| mg.brdf(x)).1,
                log_error(set, &truth, &|x| mu.brdf(x)).1,
                log_error(set, &truth, &|x| published.brdf(x)).1,
            ];
            wins[k] += usize::from(e[0] <= e[2]);
            wins_big[k] += usize::from(e[1] <= e[2]);
            cells.push(format!("{:.4}/{:.4}/{:.4}", e[0], e[1], e[2]));
            for (p, e) in pooled.iter_mut().zip(e) {
                *p += e * e / sets.len() as f64;
            }
        }
        let pooled = pooled.map(f64::sqrt);
        wins_pooled[0] += usize::from(pooled[0] <= pooled[2]);
        wins_pooled[1] += usize::from(pooled[1] <= pooled[2]);
        println!(
            "{name} ({}; {}), uniform half by seed, goniometer/150k uniform/ABC: {}; pooled (50,000): {:.4}/{:.4}/{:.4}",
            g.fits[ig].label(),
            u.fits[iu].label(),
            cells.join("  "),
            pooled[0],
            pooled[1],
            pooled[2]
        );
    }
    println!(
        "wins on the uniform half by seed {seeds:?}: goniometer {wins:?}, 150k uniform draws {wins_big:?}; pooled: {wins_pooled:?}"
    );
}

/// The whole-set losses of the goniometer grid's fits (chrome, white-paint) are the grid's,
/// not the ladder's: torrance-sparrow-abc fitted to 60,000 fresh draws from the test set's own
/// distribution (seed 7, the symmetrised network) is closer than the published ABC fit on the
/// whole test set, while the same model fitted to the goniometer grid is not.
#[test]
fn whole_set_losses_are_the_goniometer_grids() {
    let dense = draws(7, 30_000, 30_000);
    for name in ["chrome", "white-paint"] {
        let [e_gon, e_den, e_abc] = ts_abc_from_grid_and_draws(name, &dense, 1.0).map(|e| e.0);
        println!(
            "{name}, whole set: TS-abc from the goniometer grid {e_gon:.4}, from the test distribution {e_den:.4}, ABC 2012 {e_abc:.4}"
        );
        assert!(
            e_gon > e_abc && e_den < 0.9 * e_abc,
            "{name}: goniometer {e_gon}, dense {e_den}, ABC {e_abc}"
        );
    }
}

/// One fit for both halves, where the goniometer grid's fits lose the uniform half on every
/// test seed (silver-paint and white-diffuse-bball, in the lobe's shoulder): torrance-sparrow-abc
/// fitted to 30,000 uniform and 30,000 near-mirror draws (seed 7, the symmetrised network)
/// with the near-mirror ones weighted 0.003 (the one w at which a usable fit of the ladder
/// wins both halves on 7 of 8 materials in [`one_fit_for_both_halves_by_near_mirror_weight`])
/// is at or below the published ABC fit on the whole test set and on its uniform half at
/// once, while the same model fitted to the goniometer grid is not.
#[test]
fn one_fit_wins_both_halves_from_weighted_draws() {
    let train = draws(7, 30_000, 30_000);
    for name in ["silver-paint", "white-diffuse-bball"] {
        let [gon, den, abc] = ts_abc_from_grid_and_draws(name, &train, 0.003);
        println!(
            "{name}, whole set / uniform half: TS-abc from the goniometer grid {:.4} / {:.4}, from weighted draws {:.4} / {:.4}, ABC 2012 {:.4} / {:.4}",
            gon.0, gon.1, den.0, den.1, abc.0, abc.1
        );
        assert!(
            den.0 <= abc.0 && den.1 <= abc.1,
            "{name}: weighted draws {den:?} against ABC {abc:?}"
        );
        assert!(
            gon.0 > abc.0 || gon.1 > abc.1,
            "{name}: goniometer {gon:?} against ABC {abc:?}"
        );
    }
}

/// torrance-sparrow-abc's log error on test set 22 (`log_error`'s whole set, uniform half)
/// fitted to `name`'s goniometer grid and to `draws` of its symmetrised network (the
/// near-mirror ones weighted `w`, [`weigh_near_mirror`]; unweighted where `w` = 1), and the
/// published ABC fit's: [grid, draws, ABC].
fn ts_abc_from_grid_and_draws(name: &str, draws: &[([f64; 4], bool)], w: f64) -> [(f64, f64); 3] {
    let set = test_set(22);
    let mut o = FitOptions::new(brdfit::ModelKind::TorranceSparrow);
    o.dist = brdfit::model::Distribution::Abc;
    o.profile = false;
    let published = abc(name);
    let (net, gon) = training(name, &goniometer(), false);
    let dirs: Vec<[f64; 4]> = draws.iter().map(|(a, _)| *a).collect();
    let (_, mut den) = training(name, &dirs, true);
    if w != 1.0 {
        weigh_near_mirror(&mut den, draws, w);
    }
    let truth: Vec<f64> = set.iter().map(|(a, _)| net.eval_symmetric(*a)[1]).collect();
    let error = |ds: &Dataset| {
        let m = fit(ds, &o).unwrap().remove(0).model_for(0);
        log_error(&set, &truth, &|g| m.brdf(g))
    };
    let e_abc = log_error(&set, &truth, &|g| published.brdf(g));
    [error(&gon), error(&den), e_abc]
}

/// The uniform half's steady losses (silver-paint's and white-diffuse-bball's lobe shoulder,
/// behind ABC on all five test seeds of `uniform_half_across_test_seeds`) are the goniometer
/// grid's, not the ladder's: torrance-sparrow-abc fitted to 30,000 draws from the uniform half
/// (seed 7, the symmetrised network) is closer than the published ABC fit on the uniform half
/// of the test set, while the same model fitted to the goniometer grid is not.
#[test]
fn uniform_half_shoulder_losses_are_the_goniometer_grids() {
    let uniform = draws(7, 30_000, 0);
    for name in ["silver-paint", "white-diffuse-bball"] {
        let [e_gon, e_uni, e_abc] = ts_abc_from_grid_and_draws(name, &uniform, 1.0).map(|e| e.1);
        println!(
            "{name}, uniform half: TS-abc from the goniometer grid {e_gon:.4}, from the uniform half's distribution {e_uni:.4}, ABC 2012 {e_abc:.4}"
        );
        assert!(
            e_gon > e_abc && e_uni < e_abc,
            "{name}: goniometer {e_gon}, uniform draws {e_uni}, ABC {e_abc}"
        );
    }
}

/// A probe of the loss's weights on the goniometer grid, each of mean-1 solid-angle weight
/// `sa` (`fit --weights solid-angle`) and θh: the blend (1 − β) + β sa for several β, and sa
/// times (1 + c/max(θh, 0.5°)²) (θh in degrees), which approaches the test set's measure (half
/// of it log-uniform in θh) for some c. The best usable model's wins against ABC (whole set,
/// uniform half) for each. `cargo test --release --test it truth::blend -- --ignored --nocapture`.
#[test]
#[ignore]
fn weight_blends_on_the_goniometer_grid() {
    let set = test_set(22);
    let gon = goniometer();
    let blend = |beta: f64| move |sa: f64, _: f64| 1.0 - beta + beta * sa;
    let mirror = |c: f64| move |sa: f64, th: f64| sa * (1.0 + c / th.max(0.5).powi(2));
    // A weight from (solid-angle weight, θh in degrees).
    type Rule = Box<dyn Fn(f64, f64) -> f64>;
    let probes: Vec<(String, Rule)> = vec![
        ("β = 0.25".into(), Box::new(blend(0.25))),
        ("β = 0.5".into(), Box::new(blend(0.5))),
        ("β = 0.75".into(), Box::new(blend(0.75))),
        ("c = 1".into(), Box::new(mirror(1.0))),
        ("c = 10".into(), Box::new(mirror(10.0))),
        ("c = 100".into(), Box::new(mirror(100.0))),
    ];
    for (label, w) in &probes {
        let (mut wins, mut line) = ([0; 2], Vec::new());
        for name in MATERIALS {
            let (net, mut ds) = training(name, &gon, false);
            let sa = brdfit::fit::solid_angle_weights(&ds);
            ds.weights = Some(
                (0..ds.len())
                    .map(|k| {
                        let a = ds.angles(k);
                        let g = Geometry::from_angles(a[0], a[1], a[2], a[3]);
                        w(sa[k], g.nh.clamp(-1.0, 1.0).acos().to_degrees())
                    })
                    .collect(),
            );
            let f = fitted_to(name, net, &ds, &set, Weighting::File);
            let Some(i) = f.best else { continue };
            let e = f.errors[i];
            wins[0] += usize::from(e.0 <= f.e_abc.0);
            wins[1] += usize::from(e.1 <= f.e_abc.1);
            line.push(format!(
                "{name} {} {:.4}/{:.4} (ABC {:.4}/{:.4})",
                f.fits[i].label(),
                e.0,
                e.1,
                f.e_abc.0,
                f.e_abc.1
            ));
        }
        println!("{label}: wins {wins:?} of 8; {}", line.join("; "));
    }
}

/// The near-mirror weights of [`one_fit_for_both_halves_by_near_mirror_weight`].
const MIRROR_WEIGHTS: [f64; 9] = [0.0, 0.0003, 0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0];

/// Weights `train`'s samples (those of `ds`, in the same order): 1 on a uniform draw, `w` on a
/// near-mirror one.
fn weigh_near_mirror(ds: &mut Dataset, train: &[([f64; 4], bool)], w: f64) {
    ds.weights = Some(
        train
            .iter()
            .map(|(_, uniform)| if *uniform { 1.0 } else { w })
            .collect(),
    );
}

/// One fit in [`one_fit_for_both_halves_by_near_mirror_weight`]: (model, w, errors (whole set,
/// uniform half), why it is not usable (empty when it is), the two-lobe prototype).
type Candidate = (String, f64, (f64, f64), String, bool);

/// How far below ABC (e_abc) a fit's errors e are on both halves at once: the smaller of the
/// two relative margins 1 − e/e_abc (whole set, uniform half); ≥ 0 where it wins both.
fn margin(e: (f64, f64), e_abc: (f64, f64)) -> f64 {
    (1.0 - e.0 / e_abc.0).min(1.0 - e.1 / e_abc.1)
}

/// Ladder or data, one fit for both halves: every model of the ladder and the [`TwoAbc`]
/// prototype fitted to 30,000 uniform and 30,000 near-mirror [`draws`] of the symmetrised
/// network (seed 7, not one of the test set's 22–26), the near-mirror rows weighted w (each of
/// [`MIRROR_WEIGHTS`]; uniform rows 1; w = 0 is the uniform draws alone), all judged on the
/// test set. Per material: the best (model, w) on the whole set and on the uniform half, and
/// the (model, w) with the largest [`margin`] below ABC on both halves at once (usable fits of
/// the ladder, and the prototype apart); per w, the materials where some model of the ladder
/// wins both. A measurement (about 4 min of one core; 8 min wall under load): `cargo test
/// --release --test it truth::near_mirror_weight -- --ignored --nocapture`.
#[test]
#[ignore]
fn one_fit_for_both_halves_by_near_mirror_weight() {
    let set = test_set(22);
    let train = draws(7, 30_000, 30_000);
    let dirs: Vec<[f64; 4]> = train.iter().map(|(a, _)| *a).collect();
    // Per w: materials where a usable fit of the ladder wins both halves; the same with the
    // prototype.
    let mut serves = [[0; 2]; MIRROR_WEIGHTS.len()];
    let mut table = Vec::new();
    for name in MATERIALS {
        let (net, mut ds) = training(name, &dirs, true);
        let truth: Vec<f64> = set.iter().map(|(a, _)| net.eval_symmetric(*a)[1]).collect();
        let published = abc(name);
        let e_abc = log_error(&set, &truth, &|g| published.brdf(g));
        let mut all: Vec<Candidate> = Vec::new();
        for (k, &w) in MIRROR_WEIGHTS.iter().enumerate() {
            weigh_near_mirror(&mut ds, &train, w);
            let f = fitted_to(name, net.clone(), &ds, &set, Weighting::File);
            let two = fit_two_abc(&ds, name);
            let e_two = log_error(&set, &truth, &|g| two.eval(g, None));
            let row: Vec<Candidate> = f
                .fits
                .iter()
                .zip(&f.errors)
                .map(|(m, e)| (m.label(), w, *e, m.unusable.join("; "), false))
                .chain([("two ABC lobes".to_string(), w, e_two, String::new(), true)])
                .collect();
            let wins = |proto: bool| {
                row.iter()
                    .any(|r| r.3.is_empty() && (proto || !r.4) && margin(r.2, e_abc) >= 0.0)
            };
            serves[k][0] += usize::from(wins(false));
            serves[k][1] += usize::from(wins(true));
            let cells: Vec<String> = row
                .iter()
                .map(|(l, _, e, why, _)| {
                    let flag = if why.is_empty() { "" } else { " (not usable)" };
                    format!("{l}{flag} {:.4}/{:.4}", e.0, e.1)
                })
                .collect();
            println!("  {name}, w = {w}: {}", cells.join("; "));
            all.extend(row);
        }
        let usable = |proto: bool| {
            all.iter()
                .filter(move |r| r.3.is_empty() && r.4 == proto)
                .collect::<Vec<_>>()
        };
        let cell = |r: &&Candidate| format!("{}, w {}: {:.4} / {:.4}", r.0, r.1, r.2.0, r.2.1);
        let ladder = usable(false);
        let best_all = ladder
            .iter()
            .min_by(|a, b| a.2.0.total_cmp(&b.2.0))
            .unwrap();
        let best_uni = ladder
            .iter()
            .min_by(|a, b| a.2.1.total_cmp(&b.2.1))
            .unwrap();
        let best_both = |rows: &[&Candidate]| {
            let r = rows
                .iter()
                .max_by(|a, b| margin(a.2, e_abc).total_cmp(&margin(b.2, e_abc)))
                .unwrap();
            format!("{} ({:+.1} %)", cell(r), 100.0 * margin(r.2, e_abc))
        };
        // Where no usable fit wins both halves: the not-usable fit of the ladder closest to
        // winning both, and why it is not usable.
        let unusable: Vec<&Candidate> = all.iter().filter(|r| !r.3.is_empty()).collect();
        if !unusable.is_empty() && !ladder.iter().any(|r| margin(r.2, e_abc) >= 0.0) {
            let r = unusable
                .iter()
                .max_by(|a, b| margin(a.2, e_abc).total_cmp(&margin(b.2, e_abc)))
                .unwrap();
            println!(
                "{name}: no usable fit wins both; the closest not usable one: {} ({:+.1} %): {}",
                cell(r),
                100.0 * margin(r.2, e_abc),
                r.3
            );
        }
        table.push(format!(
            "| {name} | {:.4} / {:.4} | {} | {} | {} | {} |",
            e_abc.0,
            e_abc.1,
            cell(best_all),
            cell(best_uni),
            best_both(&ladder),
            best_both(&usable(true)),
        ));
    }
    println!(
        "| material | ABC 2012, whole / uniform | best on the whole set (model, w) | best on the uniform half | best on both (smaller margin below ABC) | two ABC lobes, best on both |"
    );
    println!("|---|---|---|---|---|---|");
    for row in table {
        println!("{row}");
    }
    for (w, [ladder, proto]) in MIRROR_WEIGHTS.iter().zip(serves) {
        println!(
            "w = {w}: a usable fit of the ladder wins both halves on {ladder} of 8 ({proto} with the two-lobe prototype)"
        );
    }
}

/// Figure 7 in the image: ꟻLIP p99 over the sphere (front lit 15°, edge lit 95°, 512², the
/// scene of tests/it/reference.rs) of the best usable model's render and of the published ABC
/// fit's, each against the exact render of the network. Prints the table (a measurement, no
/// threshold): `cargo test --release --test it truth:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn figure7_flip_of_the_best_model_against_the_network() {
    let set = test_set(22);
    println!(
        "| material | best usable (BIC) | front lit: best / ABC 2012 | edge lit: best / ABC 2012 |"
    );
    println!("|---|---|---|---|");
    for name in MATERIALS {
        let f = fitted(name, &set, Weighting::File, &goniometer());
        let Some(best) = f.best else {
            println!("| {name} | none | | |");
            continue;
        };
        let model = f.fits[best].model_for(0);
        let published = abc(name);
        let mut cells = Vec::new();
        for angle in [15.0, 95.0] {
            let scene = sphere::scene(angle, 512);
            let mask = sphere::mask(&scene);
            let truth = sphere::exact(&scene, &f.net);
            let ours = sphere::render_model(&scene, model);
            let theirs = sphere::render_exact(&scene, move |g| published.brdf(g));
            cells.push(format!(
                "{:.3} / {:.3}",
                sphere::flip_p99(&truth, &ours, &mask),
                sphere::flip_p99(&truth, &theirs, &mask)
            ));
        }
        println!(
            "| {name} | {} | {} | {} |",
            f.fits[best].label(),
            cells[0],
            cells[1]
        );
    }
}

/// `fit --weights solid-angle`: on a small grid (θi 20°, 40°; θo 0°, 30°, 60°; φo 0°, 90°,
/// 180°, 270°, φi 0), worked by hand. Cells: θi 10–30°, 30–50°; θo 0–15°, 15–45°, 45–75°;
/// |Δφ| folded into 0–180° is 0, 90, 180, 90: cells 0–45°, 45–135° (shared by the two 90°
/// samples) and 135–180°, π/4 each. Scaled to mean 1: w = 6 Δcosθi Δcosθo /
/// ((cos 10° − cos 50°)(1 − cos 75°)).
#[test]
fn solid_angle_weights_by_hand() {
    let c = |d: f64| d.to_radians().cos();
    let mut ds = Dataset::new(Quantity::Brdf, vec![("g".into(), None)]);
    let mut want = Vec::new();
    for (ti, dci) in [(20.0, c(10.0) - c(30.0)), (40.0, c(30.0) - c(50.0))] {
        for (to, dco) in [
            (0.0, 1.0 - c(15.0)),
            (30.0, c(15.0) - c(45.0)),
            (60.0, c(45.0) - c(75.0)),
        ] {
            for po in [0.0, 90.0, 180.0, 270.0f64] {
                ds.push(
                    [
                        f64::to_radians(ti),
                        0.0,
                        f64::to_radians(to),
                        po.to_radians(),
                    ],
                    &[0.1],
                );
                want.push(6.0 * dci * dco / ((c(10.0) - c(50.0)) * (1.0 - c(75.0))));
            }
        }
    }
    let w = brdfit::fit::solid_angle_weights(&ds);
    for (k, (a, b)) in w.iter().zip(&want).enumerate() {
        assert!((a - b).abs() < 1e-12 * b, "sample {k}: {a} against {b}");
    }
    // The pole's cell (θo 0–15°) is about a fifteenth of the 45–75° ring's.
    assert!(w[0] < 0.1 * w[8], "{} {}", w[0], w[8]);
}
