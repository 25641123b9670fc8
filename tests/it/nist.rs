//! The generic least-squares core on the NIST StRD nonlinear regression problems (all 27, both
//! starts), scored by LRE = −log10(|estimate − certified| / |certified|) against the certified
//! values. Jacobians are exact (forward-mode dual numbers), not finite differences.

#![allow(clippy::needless_range_loop)]

use brdfit::fit::lsq::{self, Limits, Problem, Robust};
use std::ops::{Add, Div, Mul, Neg, Sub};
use std::path::PathBuf;

const N: usize = 9;

/// A forward-mode dual number with up to 9 partial derivatives.
#[derive(Clone, Copy, Debug)]
struct D {
    v: f64,
    d: [f64; N],
}

impl D {
    fn c(v: f64) -> D {
        D { v, d: [0.0; N] }
    }
    fn var(v: f64, i: usize) -> D {
        let mut d = [0.0; N];
        d[i] = 1.0;
        D { v, d }
    }
    fn map(self, v: f64, dv: f64) -> D {
        let mut d = self.d;
        d.iter_mut().for_each(|x| *x *= dv);
        D { v, d }
    }
    fn exp(self) -> D {
        let e = self.v.exp();
        self.map(e, e)
    }
    fn ln(self) -> D {
        self.map(self.v.ln(), 1.0 / self.v)
    }
    fn powd(self, p: D) -> D {
        (self.ln() * p).exp()
    }
    fn powf(self, p: f64) -> D {
        self.map(self.v.powf(p), p * self.v.powf(p - 1.0))
    }
    fn cos(self) -> D {
        self.map(self.v.cos(), -self.v.sin())
    }
    fn sin(self) -> D {
        self.map(self.v.sin(), self.v.cos())
    }
    fn atan(self) -> D {
        self.map(self.v.atan(), 1.0 / (1.0 + self.v * self.v))
    }
}

impl Add for D {
    type Output = D;
    fn add(self, o: D) -> D {
        let mut d = self.d;
        for i in 0..N {
            d[i] += o.d[i];
        }
        D { v: self.v + o.v, d }
    }
}
impl Sub for D {
    type Output = D;
    fn sub(self, o: D) -> D {
        self + (-o)
    }
}
impl Neg for D {
    type Output = D;
    fn neg(self) -> D {
        self.map(-self.v, -1.0)
    }
}
impl Mul for D {
    type Output = D;
    fn mul(self, o: D) -> D {
        let mut d = [0.0; N];
        for i in 0..N {
            d[i] = self.d[i] * o.v + self.v * o.d[i];
        }
        D { v: self.v * o.v, d }
    }
}
impl Div for D {
    type Output = D;
    fn div(self, o: D) -> D {
        let mut d = [0.0; N];
        for i in 0..N {
            d[i] = (self.d[i] * o.v - self.v * o.d[i]) / (o.v * o.v);
        }
        D { v: self.v / o.v, d }
    }
}
impl Add<f64> for D {
    type Output = D;
    fn add(self, o: f64) -> D {
        self + D::c(o)
    }
}
impl Mul<f64> for D {
    type Output = D;
    fn mul(self, o: f64) -> D {
        self * D::c(o)
    }
}

fn k(v: f64) -> D {
    D::c(v)
}

/// The model of each problem (NIST `Models`), f(x; b).
fn model(name: &str, x: &[f64], b: &[D]) -> D {
    let xv = k(x[0]);
    let pi = std::f64::consts::PI;
    match name {
        "Misra1a" | "BoxBOD" => b[0] * (k(1.0) - (-(b[1] * xv)).exp()),
        "Chwirut1" | "Chwirut2" => (-(b[0] * xv)).exp() / (b[1] + b[2] * xv),
        "Lanczos1" | "Lanczos2" | "Lanczos3" => {
            b[0] * (-(b[1] * xv)).exp() + b[2] * (-(b[3] * xv)).exp() + b[4] * (-(b[5] * xv)).exp()
        }
        "Gauss1" | "Gauss2" | "Gauss3" => {
            let g = |a: D, m: D, s: D| a * (-((xv - m) * (xv - m)) / (s * s)).exp();
            b[0] * (-(b[1] * xv)).exp() + g(b[2], b[3], b[4]) + g(b[5], b[6], b[7])
        }
        "DanWood" => b[0] * xv.powd(b[1]),
        "Misra1b" => b[0] * (k(1.0) - (k(1.0) + b[1] * xv * 0.5).powf(-2.0)),
        "Kirby2" => (b[0] + b[1] * xv + b[2] * xv * xv) / (k(1.0) + b[3] * xv + b[4] * xv * xv),
        "Hahn1" | "Thurber" => {
            let (x2, x3) = (xv * xv, xv * xv * xv);
            (b[0] + b[1] * xv + b[2] * x2 + b[3] * x3)
                / (k(1.0) + b[4] * xv + b[5] * x2 + b[6] * x3)
        }
        "Nelson" => b[0] - b[1] * xv * (-(b[2] * k(x[1]))).exp(),
        "MGH17" => b[0] + b[1] * (-(xv * b[3])).exp() + b[2] * (-(xv * b[4])).exp(),
        "Misra1c" => b[0] * (k(1.0) - (k(1.0) + b[1] * xv * 2.0).powf(-0.5)),
        "Misra1d" => b[0] * b[1] * xv / (k(1.0) + b[1] * xv),
        "Roszman1" => b[0] - b[1] * xv - (b[2] / (xv - b[3])).atan() * (1.0 / pi),
        "ENSO" => {
            let w = k(2.0 * pi * x[0]);
            b[0] + b[1] * (w * (1.0 / 12.0)).cos()
                + b[2] * (w * (1.0 / 12.0)).sin()
                + b[4] * (w / b[3]).cos()
                + b[5] * (w / b[3]).sin()
                + b[7] * (w / b[6]).cos()
                + b[8] * (w / b[6]).sin()
        }
        "MGH09" => b[0] * (xv * xv + xv * b[1]) / (xv * xv + xv * b[2] + b[3]),
        "Rat42" => b[0] / (k(1.0) + (b[1] - b[2] * xv).exp()),
        "MGH10" => b[0] * (b[1] / (xv + b[2])).exp(),
        "Eckerle4" => (b[0] / b[1]) * (-(((xv - b[2]) / b[1]) * ((xv - b[2]) / b[1])) * 0.5).exp(),
        "Rat43" => b[0] / (k(1.0) + (b[1] - b[2] * xv).exp()).powd(k(1.0) / b[3]),
        "Bennett5" => b[0] * (b[1] + xv).powd(-(k(1.0) / b[2])),
        _ => panic!("unknown problem {name}"),
    }
}

struct Nist {
    name: String,
    xs: Vec<Vec<f64>>,
    ys: Vec<f64>,
    starts: [Vec<f64>; 2],
    certified: Vec<f64>,
    rss: f64,
}

fn read(name: &str) -> Nist {
    let p =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/nist-strd/{name}.dat"));
    let text = std::fs::read_to_string(p).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let (mut s1, mut s2, mut cert) = (vec![], vec![], vec![]);
    for l in &lines[40..] {
        let t = l.trim();
        if !t.starts_with('b') {
            break;
        }
        let nums: Vec<f64> = t
            .split('=')
            .nth(1)
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        s1.push(nums[0]);
        s2.push(nums[1]);
        cert.push(nums[2]);
    }
    let rss = lines
        .iter()
        .find(|l| l.contains("Residual Sum of Squares:"))
        .and_then(|l| l.split_whitespace().last())
        .unwrap()
        .parse()
        .unwrap();
    let (mut xs, mut ys) = (vec![], vec![]);
    for l in &lines[60..] {
        let v: Vec<f64> = l.split_whitespace().map(|v| v.parse().unwrap()).collect();
        if v.is_empty() {
            continue;
        }
        ys.push(if name == "Nelson" { v[0].ln() } else { v[0] });
        xs.push(v[1..].to_vec());
    }
    Nist {
        name: name.into(),
        xs,
        ys,
        starts: [s1, s2],
        certified: cert,
        rss,
    }
}

impl Problem for Nist {
    type Prepared = Vec<f64>;
    fn dim(&self) -> usize {
        self.certified.len()
    }
    fn n_residuals(&self) -> usize {
        self.ys.len()
    }
    fn prepare(&self, x: &[f64]) -> Option<Vec<f64>> {
        Some(x.to_vec())
    }
    fn residual_grad(&self, b: &Vec<f64>, i: usize, row: &mut [f64]) -> f64 {
        let bd: Vec<D> = b.iter().enumerate().map(|(j, v)| D::var(*v, j)).collect();
        let f = model(&self.name, &self.xs[i], &bd);
        row.copy_from_slice(&f.d[..b.len()]);
        f.v - self.ys[i]
    }
}

fn lre(est: f64, cert: f64) -> f64 {
    if est == cert {
        return 11.0;
    }
    (-((est - cert).abs() / cert.abs()).log10()).min(11.0)
}

const PROBLEMS: [&str; 27] = [
    "Misra1a", "Chwirut2", "Chwirut1", "Lanczos3", "Gauss1", "Gauss2", "DanWood", "Misra1b",
    "Kirby2", "Hahn1", "Nelson", "MGH17", "Lanczos1", "Lanczos2", "Gauss3", "Misra1c", "Misra1d",
    "Roszman1", "ENSO", "MGH09", "Thurber", "BoxBOD", "Rat42", "MGH10", "Eckerle4", "Rat43",
    "Bennett5",
];

#[test]
fn nist_strd_all_problems_both_starts() {
    let limits = Limits {
        max_iter: 20_000,
        max_eval: 100_000,
        ftol: 1e-16,
        xtol: 1e-16,
        gtol: 1e-15,
        ..Limits::default()
    };
    let mut worst: f64 = 11.0;
    let mut failures = Vec::new();
    println!(
        "{:<10} {:>5} {:>8} {:>8} {:>7} {:>7}  termination",
        "problem", "start", "LRE(b)", "LRE(RSS)", "iter", "evals"
    );
    for name in PROBLEMS {
        let p = read(name);
        for (s, start) in p.starts.iter().enumerate() {
            let sol = lsq::levenberg_marquardt(&p, start, Robust::None, &limits);
            let lre_b = sol
                .x
                .iter()
                .zip(&p.certified)
                .map(|(e, c)| lre(*e, *c))
                .fold(11.0, f64::min);
            let lre_rss = lre(2.0 * sol.cost, p.rss);
            println!(
                "{:<10} {:>5} {:>8.2} {:>8.2} {:>7} {:>7}  {}",
                name,
                s + 1,
                lre_b,
                lre_rss,
                sol.iterations,
                sol.evaluations,
                sol.termination
            );
            // Lanczos1's certified RSS (1.4e-25) is at the level of rounding: compare parameters only.
            let score = if name == "Lanczos1" {
                lre_b
            } else {
                lre_b.min(lre_rss)
            };
            worst = worst.min(score);
            if score < 4.0 {
                failures.push(format!("{name} start {}: LRE {score:.2}", s + 1));
            }
        }
    }
    println!("worst LRE over all 54 runs: {worst:.2}");
    assert!(
        failures.is_empty(),
        "fewer than 4 correct digits: {failures:?}"
    );
}
