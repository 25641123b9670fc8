//! A measurement as a material: f_r on a regular half/difference-angle table.
//!
//! The table is indexed by Rusinkiewicz's (1998) half/difference angles (θh, θd, φd), as MERL's
//! tables are (Matusik et al. 2003): θh on MERL's square-root scale (u = √(θh / 90°), so the
//! narrow highlight near θh = 0 gets most cells), θd linear over [0°, 90°], and φd folded onto
//! [0°, 90°] by reciprocity (φd ~ φd + 180°) and isotropy (φd ~ −φd). Lookups interpolate
//! trilinearly between cell centres.
//!
//! Samples (CSV, ASTM, Cornell, RGL, or a MERL table's cells) are resampled onto the table
//! once, as residuals from a model (the best fit): each cell takes the inverse-distance-weighted
//! mean (Shepard 1968) of the residuals f_data − f_model of the samples within 1.5 cells of its
//! centre, in index units. A lookup is f_model at the exact configuration plus the residual
//! interpolated trilinearly, so the model carries the shape between samples (a sharp highlight
//! is not smeared over a cell) while the samples set the values: at a sample's cell centre the
//! lookup returns the sample. A cell with no sample that near is marked and takes residual 0
//! (the model), and the share of such cells is reported.

use super::gonio::GonioGrid;
use crate::data::Dataset;
use crate::model::{Geometry, Model};
use std::f64::consts::FRAC_PI_2;

/// Table size: cells in θh (square-root scale), θd, and folded φd.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Dims(pub [usize; 3]);

impl Dims {
    /// MERL's resolution, with φd folded onto [0°, 90°] (90 × 90 × 90).
    pub const MERL: Dims = Dims([90, 90, 90]);

    /// A size for `samples` scattered samples: about two samples a cell, n × n × n/2 with n in
    /// [8, 90]; the full MERL size for a whole MERL table.
    pub fn for_samples(samples: usize) -> Dims {
        if samples >= 1_000_000 {
            return Dims::MERL;
        }
        let n = ((samples as f64 / 2.0).cbrt().round() as usize).clamp(8, 90);
        Dims([n, n, (n / 2).max(4)])
    }

    fn cells(self) -> usize {
        self.0.iter().product()
    }
}

pub use crate::prior::coordinates;

/// How a table's cell values combine with the fill model at a lookup.
#[derive(Clone)]
pub enum Lookup {
    /// f = f_fill + residual (the cells hold f_data − f_fill).
    Residual,
    /// f = (f_fill + δ)·e^v − δ, at least 0 (the cells hold v = ln((f_data + δ)/(f_fill + δ)),
    /// the reconstruction of a measurement as a BRDF).
    Ratio {
        /// The floor δ added to both f_data and f_fill (f_r units).
        delta: f64,
    },
    /// f = (f_fill + δ)·e^v − δ, at least 0, with v interpolated on a goniometer's own grid
    /// (see [`GonioGrid`]); the cells hold the table's log ratios
    /// (for `filled` and the measured share only).
    Grid {
        /// The floor δ added to both f_data and f_fill (f_r units).
        delta: f64,
        /// The grid of log ratios.
        grid: std::sync::Arc<GonioGrid>,
    },
    /// An exact BRDF evaluated at every lookup (a truth such as a Neural-BRDF network); the
    /// cells are unused.
    Exact(std::sync::Arc<dyn Fn(&Geometry) -> f64 + Send + Sync>),
}

impl std::fmt::Debug for Lookup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Lookup::Residual => write!(f, "Residual"),
            Lookup::Ratio { delta } => write!(f, "Ratio {{ delta: {delta} }}"),
            Lookup::Grid { delta, .. } => write!(f, "Grid {{ delta: {delta} }}"),
            Lookup::Exact(_) => write!(f, "Exact"),
        }
    }
}

/// A measured BRDF (one channel) on a half/difference table, ready for rendering.
#[derive(Clone, Debug)]
pub struct Tabulated {
    /// Table size.
    pub dims: Dims,
    /// How cell values combine with the fill model.
    pub lookup: Lookup,
    /// Residual f_data − f_fill (or log ratio, by `lookup`) at each cell centre, φd fastest,
    /// then θd, then θh.
    values: Vec<f32>,
    /// Cells with no sample near enough (residual 0: the model).
    filled: Vec<bool>,
    /// Cells whose centre has light or eye below the horizon: no sample can fall there.
    outside: Vec<bool>,
    /// The model the residuals are taken from, and which fills the empty cells.
    pub fill: Model,
    /// A base the ratios multiply in place of `fill` (a reconstruction under a prior,
    /// [`crate::prior::Posterior`]); `fill` still gives the ambient term's pd.
    pub base: Option<Base>,
}

/// A BRDF a table's ratios multiply: f_r at a configuration.
#[derive(Clone)]
pub struct Base(pub std::sync::Arc<dyn Fn(&Geometry) -> f64 + Send + Sync>);

impl Base {
    /// The posterior mean of a measurement under a prior as a base.
    pub fn posterior(p: crate::prior::Posterior) -> Base {
        Base(std::sync::Arc::new(move |g| p.brdf(g)))
    }
}

impl std::fmt::Debug for Base {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Base")
    }
}

impl Tabulated {
    /// Resample the first channel of `ds` onto a table of size `dims`, as residuals from
    /// `fill`, which also fills the cells with no sample within 1.5 cells.
    pub fn resample(ds: &Dataset, dims: Dims, fill: Model) -> Tabulated {
        let [nh, nd, np] = dims.0;
        let n = [nh as f64, nd as f64, np as f64];
        let values = ds.channels.first().map(|c| &c.values[..]).unwrap_or(&[]);
        // Sample positions in index units, and cell lists (counting sort, so no allocation
        // per cell and the order within a cell is the file's order: deterministic).
        let mut pos = Vec::with_capacity(ds.len());
        let mut val = Vec::with_capacity(ds.len());
        for k in 0..ds.len().min(values.len()) {
            let g = Geometry::from_angles(ds.theta_i[k], ds.phi_i[k], ds.theta_o[k], ds.phi_o[k]);
            let y = values[k] * ds.quantity.to_brdf_factor(g.nl);
            if !g.visible() || !y.is_finite() {
                continue;
            }
            let c = coordinates(&g);
            pos.push([c[0] * n[0], c[1] * n[1], c[2] * n[2]]);
            val.push(y - fill.brdf(&g));
        }
        let cell_of = |p: &[f64; 3]| {
            let i = |a: f64, m: usize| (a as usize).min(m - 1);
            (i(p[0], nh) * nd + i(p[1], nd)) * np + i(p[2], np)
        };
        let mut start = vec![0usize; dims.cells() + 1];
        for p in &pos {
            start[cell_of(p) + 1] += 1;
        }
        for c in 0..dims.cells() {
            start[c + 1] += start[c];
        }
        let mut next = start.clone();
        let mut order = vec![0usize; pos.len()];
        for (k, p) in pos.iter().enumerate() {
            let c = cell_of(p);
            order[next[c]] = k;
            next[c] += 1;
        }
        const RADIUS2: f64 = 1.5 * 1.5;
        let mut out = vec![0f32; dims.cells()];
        let mut filled = vec![false; dims.cells()];
        let mut outside = vec![false; dims.cells()];
        for ih in 0..nh {
            for id in 0..nd {
                for ip in 0..np {
                    let centre = [ih as f64 + 0.5, id as f64 + 0.5, ip as f64 + 0.5];
                    let (mut sw, mut sy) = (0.0, 0.0);
                    for jh in ih.saturating_sub(1)..(ih + 2).min(nh) {
                        for jd in id.saturating_sub(1)..(id + 2).min(nd) {
                            for jp in ip.saturating_sub(1)..(ip + 2).min(np) {
                                let c = (jh * nd + jd) * np + jp;
                                for &k in &order[start[c]..start[c + 1]] {
                                    let d2: f64 =
                                        (0..3).map(|a| (pos[k][a] - centre[a]).powi(2)).sum();
                                    if d2 <= RADIUS2 {
                                        let w = 1.0 / (d2 + 1e-9);
                                        sw += w;
                                        sy += w * val[k];
                                    }
                                }
                            }
                        }
                    }
                    let cell = (ih * nd + id) * np + ip;
                    outside[cell] = !centre_geometry(dims, centre).visible();
                    if sw > 0.0 {
                        out[cell] = (sy / sw) as f32;
                    } else {
                        filled[cell] = true;
                    }
                }
            }
        }
        Tabulated {
            dims,
            lookup: Lookup::Residual,
            values: out,
            filled,
            outside,
            fill,
            base: None,
        }
    }

    /// A table from its parts (cells φd fastest, then θd, then θh): `filled` marks cells with
    /// no sample near, `outside` cells whose centre has light or eye below the horizon.
    pub(crate) fn from_parts(
        dims: Dims,
        lookup: Lookup,
        values: Vec<f32>,
        filled: Vec<bool>,
        fill: Model,
    ) -> Tabulated {
        let [nh, nd, np] = dims.0;
        let mut outside = vec![false; dims.cells()];
        for ih in 0..nh {
            for id in 0..nd {
                for ip in 0..np {
                    let centre = [ih as f64 + 0.5, id as f64 + 0.5, ip as f64 + 0.5];
                    outside[(ih * nd + id) * np + ip] = !centre_geometry(dims, centre).visible();
                }
            }
        }
        Tabulated {
            dims,
            lookup,
            values,
            filled,
            outside,
            fill,
            base: None,
        }
    }

    /// An exact BRDF as a material (for rendering a truth): every lookup evaluates `f`, at
    /// least 0; no cell is filled. `fill` gives only the ambient term's pd.
    pub fn exact(
        f: std::sync::Arc<dyn Fn(&Geometry) -> f64 + Send + Sync>,
        fill: Model,
    ) -> Tabulated {
        Tabulated {
            dims: Dims([1, 1, 1]),
            lookup: Lookup::Exact(f),
            values: vec![0.0],
            filled: vec![false],
            outside: vec![false],
            fill,
            base: None,
        }
    }

    /// The cell values (residuals or log ratios by `lookup`), φd fastest.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Share of the table's physical cells (centre with light and eye above the horizon)
    /// filled from the model, having no sample within 1.5 cells.
    pub fn fill_share(&self) -> f64 {
        let inside = self.outside.iter().filter(|&&o| !o).count();
        let filled = (0..self.filled.len())
            .filter(|&c| self.filled[c] && !self.outside[c])
            .count();
        filled as f64 / inside.max(1) as f64
    }

    /// True when the cell nearest to a configuration holds measured samples (not the fill).
    pub fn is_measured(&self, g: &Geometry) -> bool {
        let c = coordinates(g);
        let [nh, nd, np] = self.dims.0;
        let i = |u: f64, m: usize| ((u * m as f64) as usize).min(m - 1);
        !self.filled[(i(c[0], nh) * nd + i(c[1], nd)) * np + i(c[2], np)]
    }

    /// f_r at a configuration: the model there plus the residual interpolated trilinearly
    /// between cell centres, at least 0 (0 where light or eye is below the surface).
    #[inline]
    pub fn brdf(&self, g: &Geometry) -> f64 {
        if !g.visible() {
            return 0.0;
        }
        match &self.lookup {
            Lookup::Exact(f) => return f(g).max(0.0),
            Lookup::Grid { delta, grid } => {
                let v = grid.log_ratio(g);
                return ((self.base_brdf(g) + delta) * v.exp() - delta).max(0.0);
            }
            _ => {}
        }
        let v = self.table_value(g);
        match self.lookup {
            Lookup::Ratio { delta } => ((self.base_brdf(g) + delta) * v.exp() - delta).max(0.0),
            _ => (self.fill.brdf(g) + v).max(0.0),
        }
    }

    /// f_r of what the table's ratios multiply: the base, else the fill model.
    #[inline]
    pub fn base_brdf(&self, g: &Geometry) -> f64 {
        match &self.base {
            Some(b) => (b.0)(g),
            None => self.fill.brdf(g),
        }
    }

    /// The cell values interpolated at a configuration: Catmull–Rom along θh for log ratios,
    /// else trilinear.
    #[inline]
    fn table_value(&self, g: &Geometry) -> f64 {
        let c = coordinates(g);
        let [nh, nd, np] = self.dims.0;
        let axis = |u: f64, m: usize| {
            let x = (u * m as f64 - 0.5).clamp(0.0, (m - 1) as f64);
            let i = (x as usize).min(m.saturating_sub(2));
            (i, (i + 1).min(m - 1), x - i as f64)
        };
        let (h0, h1, fh) = axis(c[0], nh);
        let (d0, d1, fd) = axis(c[1], nd);
        let (p0, p1, fp) = axis(c[2], np);
        let at = |h: usize, d: usize, p: usize| self.values[(h * nd + d) * np + p] as f64;
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let plane = |h: usize| {
            lerp(
                lerp(at(h, d0, p0), at(h, d0, p1), fp),
                lerp(at(h, d1, p0), at(h, d1, p1), fp),
                fd,
            )
        };
        match self.lookup {
            // Catmull–Rom (cubic, through the cell centres) along θh, where a lobe's ratio to
            // its model curves most; linear in θd and φd. The values are log ratios, so an
            // overshoot cannot make f_r negative.
            Lookup::Ratio { .. } if nh >= 4 => {
                let hm = h0.saturating_sub(1);
                let hp = (h1 + 1).min(nh - 1);
                let (a, b, c, d) = (plane(hm), plane(h0), plane(h1), plane(hp));
                let t = fh;
                b + 0.5
                    * t
                    * (c - a + t * (2.0 * a - 5.0 * b + 4.0 * c - d + t * (3.0 * (b - c) + d - a)))
            }
            _ => lerp(plane(h0), plane(h1), fh),
        }
    }
}

/// The geometry at a cell centre given in index units.
pub(crate) fn centre_geometry(dims: Dims, centre: [f64; 3]) -> Geometry {
    let [nh, nd, np] = dims.0;
    let u = centre[0] / nh as f64;
    let th = u * u * FRAC_PI_2;
    let td = centre[1] / nd as f64 * FRAC_PI_2;
    let pd = centre[2] / np as f64 * FRAC_PI_2;
    let a = crate::data::merl::half_diff_to_std(th, 0.0, td, pd);
    Geometry::from_angles(a[0], a[1], a[2], a[3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Distribution, ModelKind};

    /// The coordinates from cosines agree with MERL's rotation-based half/difference angles.
    #[test]
    fn coordinates_match_rotations() {
        for &(ti, to, dphi) in &[
            (0.3, 0.9, 2.0),
            (1.2, 0.4, 0.5),
            (0.7, 0.7, 3.0),
            (1.4, 1.3, 1.0),
        ] {
            let g = Geometry::from_angles(ti, 0.0, to, dphi);
            let [th, _, td, pd] = crate::data::merl::std_to_half_diff([ti, 0.0, to, dphi]);
            let mut p = pd.rem_euclid(std::f64::consts::PI);
            if p > FRAC_PI_2 {
                p = std::f64::consts::PI - p;
            }
            let c = coordinates(&g);
            assert!((c[0] - (th / FRAC_PI_2).sqrt()).abs() < 1e-9, "{c:?} {th}");
            assert!((c[1] - td / FRAC_PI_2).abs() < 1e-9);
            assert!((c[2] - p / FRAC_PI_2).abs() < 1e-7, "{c:?} {p}");
        }
    }

    /// A table filled entirely from a model returns that model at the cell centres and close
    /// to it between them.
    #[test]
    fn empty_table_is_the_fill_model() {
        let m = Model::new(
            ModelKind::TorranceSparrow,
            Distribution::D3,
            &[1.8, 0.35, 0.667, 0.333],
        )
        .unwrap();
        let ds = Dataset::new(crate::data::Quantity::Brdf, vec![("v".into(), None)]);
        let t = Tabulated::resample(&ds, Dims([32, 32, 16]), m);
        assert_eq!(t.fill_share(), 1.0);
        assert!(t.outside.iter().any(|&o| o) && t.outside.iter().any(|&o| !o));
        for g in [
            centre_geometry(t.dims, [10.5, 5.5, 3.5]),
            Geometry::from_angles(0.5, 0.0, 0.6, 2.9),
        ] {
            assert!((t.brdf(&g) - m.brdf(&g)).abs() < 1e-12);
        }
    }
}
