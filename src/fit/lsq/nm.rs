//! The derivative-free Nelder–Mead simplex method on the cost, projected onto the box.

use super::options::Limits;
use super::pass::cost;
use super::problem::{Problem, Robust, Solution};
use super::step::project;

/// Nelder–Mead on the cost (see the module documentation).
pub fn nelder_mead<P: Problem>(p: &P, x0: &[f64], robust: Robust, limits: &Limits) -> Solution {
    let n = p.dim();
    let bounds = p.bounds();
    let mut evals = 0;
    let f = |x: &mut Vec<f64>, evals: &mut usize| {
        project(x, &bounds);
        *evals += 1;
        cost(p, x, robust).unwrap_or(f64::INFINITY)
    };
    let mut start = x0.to_vec();
    let f0 = f(&mut start, &mut evals);
    let mut simplex: Vec<(Vec<f64>, f64)> = vec![(start.clone(), f0)];
    for i in 0..n {
        let mut v = start.clone();
        v[i] += if v[i].abs() > 1e-3 { 0.1 * v[i] } else { 0.1 };
        let fv = f(&mut v, &mut evals);
        simplex.push((v, fv));
    }
    let mut iter = 0;
    let mut termination = "iteration limit reached".to_string();
    let mut converged = false;
    let max_iter = limits.max_iter * 4;
    while iter < max_iter {
        if evals >= limits.max_eval * 2 {
            termination = "evaluation limit reached".into();
            break;
        }
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        let spread = simplex
            .iter()
            .flat_map(|(v, _)| v.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
            .fold(0.0f64, f64::max);
        if best.is_finite()
            && (worst - best).abs() <= 1e-15 * best.abs().max(1e-300)
            && spread < 1e-10
        {
            termination = "simplex collapsed".into();
            converged = true;
            break;
        }
        iter += 1;
        let centroid: Vec<f64> = (0..n)
            .map(|k| simplex[..n].iter().map(|(v, _)| v[k]).sum::<f64>() / n as f64)
            .collect();
        let towards = |t: f64| -> Vec<f64> {
            centroid
                .iter()
                .zip(&simplex[n].0)
                .map(|(c, w)| c + t * (w - c))
                .collect()
        };
        let mut xr = towards(-1.0);
        let fr = f(&mut xr, &mut evals);
        if fr < simplex[0].1 {
            let mut xe = towards(-2.0);
            let fe = f(&mut xe, &mut evals);
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (mut xc, fc) = if fr < simplex[n].1 {
                let mut xc = towards(-0.5);
                let fc = f(&mut xc, &mut evals);
                (xc, fc)
            } else {
                let mut xc = towards(0.5);
                let fc = f(&mut xc, &mut evals);
                (xc, fc)
            };
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (std::mem::take(&mut xc), fc);
            } else {
                let b = simplex[0].0.clone();
                for item in simplex.iter_mut().skip(1) {
                    let mut v: Vec<f64> = b
                        .iter()
                        .zip(&item.0)
                        .map(|(a, c)| a + 0.5 * (c - a))
                        .collect();
                    let fv = f(&mut v, &mut evals);
                    *item = (v, fv);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, c) = simplex.swap_remove(0);
    Solution {
        x,
        cost: c,
        iterations: iter,
        evaluations: evals,
        termination,
        converged,
        normal: None,
    }
}
