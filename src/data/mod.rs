//! Reflectance samples and the loaders that fill them.
//!
//! A [`Dataset`] is struct-of-arrays: four angle columns (radians), one or more value
//! channels, the measured [`Quantity`], optional per-sample weights and metadata. Loaders fill
//! it through one validating [`RowSink`], so every format gets the same checks and messages;
//! nothing downstream knows the file format. A missing value (an empty CSV field, a MERL cell
//! marked negative, or a negative value under `--negative mask`) is stored as NaN and skipped
//! by every consumer; NaN in an input file is an error, never a missing value.

mod astm;
mod cornell;
mod csvfmt;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod merl;
pub mod nbrdf;
pub mod rgl;

use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt;
use std::io::Read;
use std::path::Path;

pub use crate::support::input::{DataError, io_error};
pub(crate) use csvfmt::degrees;
pub use csvfmt::{load_directions, write_csv, write_csv_to};

/// Unit direction for polar angle `theta` and azimuth `phi` (radians), N = +z.
pub fn direction(theta: f64, phi: f64) -> [f64; 3] {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [st * cp, st * sp, ct]
}

/// What the values in a file measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// f_r, the BRDF in 1/sr (column prefix `brdf`).
    Brdf,
    /// f_r cosθi (column prefix `brdf_cos`).
    BrdfCos,
    /// Reflectance factor π f_r (column prefix `rfactor`).
    RFactor,
}

impl Quantity {
    /// Column prefix in brdfit CSV.
    pub fn column(self) -> &'static str {
        match self {
            Quantity::Brdf => "brdf",
            Quantity::BrdfCos => "brdf_cos",
            Quantity::RFactor => "rfactor",
        }
    }

    /// Multiply a stored value by this to get f_r, for incidence cosine `cos_i`.
    #[inline]
    pub fn to_brdf_factor(self, cos_i: f64) -> f64 {
        match self {
            Quantity::Brdf => 1.0,
            Quantity::BrdfCos => 1.0 / cos_i,
            Quantity::RFactor => 1.0 / PI,
        }
    }
}

impl fmt::Display for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Quantity::Brdf => "brdf (f_r, 1/sr)",
            Quantity::BrdfCos => "brdf_cos (f_r cosθi, 1/sr)",
            Quantity::RFactor => "rfactor (reflectance factor π f_r)",
        })
    }
}

/// File formats brdfit reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// brdfit CSV (header with unit-carrying angle columns).
    Csv,
    /// ASTM E1392 text.
    Astm,
    /// Cornell / pbrt-v2 spectral text.
    #[value(alias = "brdf", alias = "pbrt")]
    Cornell,
    /// MERL `.binary` table.
    #[value(alias = "binary")]
    Merl,
}

impl Format {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Astm => "astm",
            Format::Cornell => "cornell",
            Format::Merl => "merl",
        }
    }

    /// Parse a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        <Self as clap::ValueEnum>::from_str(s, true).ok()
    }

    /// Format implied by a file extension, if any.
    pub fn from_extension(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "csv" => Some(Format::Csv),
            "astm" => Some(Format::Astm),
            "brdf" => Some(Format::Cornell),
            "binary" => Some(Format::Merl),
            _ => None,
        }
    }
}

/// What to do with negative values (a real wart of spectral→RGB conversions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum NegativePolicy {
    /// Treat them as missing (the default).
    #[default]
    Mask,
    /// Replace them with 0.
    Clamp,
    /// Refuse the file.
    Error,
}

impl NegativePolicy {
    /// Parse `mask`, `clamp` or `error`.
    pub fn parse(s: &str) -> Option<Self> {
        <Self as clap::ValueEnum>::from_str(s, true).ok()
    }
}

/// One value channel: a name (`r`, `550nm`, `y`, or empty for a single channel), an optional
/// wavelength and one value per sample (NaN = missing).
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// Channel name as written in column suffixes (`""` for a single unnamed channel).
    pub name: String,
    /// Wavelength in nm, for spectral channels.
    pub wavelength_nm: Option<f64>,
    /// Values in the dataset's quantity; NaN marks a missing value.
    pub values: Vec<f64>,
}

/// Where a dataset came from.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Metadata {
    /// The file it was read from.
    pub source: String,
    /// Format name.
    pub format: String,
    /// Material or sample name, if the file gives one.
    pub material: Option<String>,
    /// Comment and header lines kept from the file.
    pub comments: Vec<String>,
    /// What looked wrong while loading but was not an error (e.g. degree columns holding
    /// radians), each naming the file and the fix.
    pub warnings: Vec<String>,
}

/// The angles of a sample to 1e-9 rad: samples with the same key are at the same
/// configuration ([`Dataset::duplicates`], [`Dataset::merge`]).
fn angle_key(a: [f64; 4]) -> [i64; 4] {
    a.map(|x| (x * 1e9).round() as i64)
}

/// Reflectance samples, struct-of-arrays, angles in radians.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// Incidence polar angle θi.
    pub theta_i: Vec<f64>,
    /// Incidence azimuth φi.
    pub phi_i: Vec<f64>,
    /// Outgoing polar angle θo.
    pub theta_o: Vec<f64>,
    /// Outgoing azimuth φo.
    pub phi_o: Vec<f64>,
    /// Value channels.
    pub channels: Vec<Channel>,
    /// What the values measure.
    pub quantity: Quantity,
    /// Optional per-sample weights (≥ 0).
    pub weights: Option<Vec<f64>>,
    /// Provenance.
    pub meta: Metadata,
    /// Negative values met while loading, and what was done with them.
    pub negatives: usize,
    /// Policy applied to negatives.
    pub negative_policy: NegativePolicy,
}

impl Dataset {
    /// Empty dataset with the given channels.
    pub fn new(quantity: Quantity, channels: Vec<(String, Option<f64>)>) -> Self {
        Dataset {
            theta_i: Vec::new(),
            phi_i: Vec::new(),
            theta_o: Vec::new(),
            phi_o: Vec::new(),
            channels: channels
                .into_iter()
                .map(|(name, wavelength_nm)| Channel {
                    name,
                    wavelength_nm,
                    values: Vec::new(),
                })
                .collect(),
            quantity,
            weights: None,
            meta: Metadata::default(),
            negatives: 0,
            negative_policy: NegativePolicy::Mask,
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.theta_i.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.theta_i.is_empty()
    }

    /// Append one sample (no validation; loaders go through [`RowSink`]).
    pub fn push(&mut self, angles: [f64; 4], values: &[f64]) {
        self.theta_i.push(angles[0]);
        self.phi_i.push(angles[1]);
        self.theta_o.push(angles[2]);
        self.phi_o.push(angles[3]);
        for (c, v) in self.channels.iter_mut().zip(values) {
            c.values.push(*v);
        }
    }

    /// The four angles of sample `k`.
    pub fn angles(&self, k: usize) -> [f64; 4] {
        [
            self.theta_i[k],
            self.phi_i[k],
            self.theta_o[k],
            self.phi_o[k],
        ]
    }

    /// Values of channel `c` converted to f_r (1/sr); NaN stays NaN.
    pub fn brdf_values(&self, c: usize) -> Vec<f64> {
        self.channels[c]
            .values
            .iter()
            .zip(&self.theta_i)
            .map(|(v, t)| v * self.quantity.to_brdf_factor(t.cos()))
            .collect()
    }

    /// The same samples with every channel converted to f_r.
    pub fn into_brdf(mut self) -> Self {
        if self.quantity != Quantity::Brdf {
            for c in 0..self.channels.len() {
                self.channels[c].values = self.brdf_values(c);
            }
            self.quantity = Quantity::Brdf;
        }
        self
    }

    /// Number of missing (NaN) values over all channels.
    pub fn missing(&self) -> usize {
        self.channels
            .iter()
            .map(|c| c.values.iter().filter(|v| v.is_nan()).count())
            .sum()
    }

    /// Number of samples whose four angles repeat an earlier sample's (to 1e-9 rad).
    pub fn duplicates(&self) -> usize {
        let mut seen = std::collections::HashSet::with_capacity(self.len());
        (0..self.len())
            .filter(|&k| !seen.insert(angle_key(self.angles(k))))
            .count()
    }

    /// Several measurements of one material as one dataset (`sets` in order, each converted to
    /// f_r): the channels must be the same (names, in order); samples at the same angles (to
    /// 1e-9 rad) are averaged, channel by channel over the values present, the average
    /// weighing as the sum of their weights (1 each where a file gives none). The error
    /// names the files whose channels differ.
    pub fn merge(sets: &[Dataset]) -> Result<Dataset, String> {
        let Some(first) = sets.first() else {
            return Err("no data to merge".into());
        };
        let names =
            |d: &Dataset| -> Vec<String> { d.channels.iter().map(|c| c.name.clone()).collect() };
        for d in &sets[1..] {
            if names(d) != names(first) {
                return Err(format!(
                    "{} has the channels [{}] and {} has [{}]: merged files need the same \
                     channels; select one with --channel",
                    first.meta.source,
                    names(first).join(", "),
                    d.meta.source,
                    names(d).join(", ")
                ));
            }
        }
        let nch = first.channels.len();
        // Per distinct configuration: angles, Σ w·value and Σ w per channel, Σ w.
        let mut index = std::collections::HashMap::new();
        type Sums = ([f64; 4], Vec<(f64, f64)>, f64);
        let mut rows: Vec<Sums> = Vec::new();
        let mut weighted = false;
        for d in sets {
            let d = d.clone().into_brdf();
            weighted |= d.weights.is_some();
            for k in 0..d.len() {
                let a = d.angles(k);
                let w = d.weights.as_ref().map_or(1.0, |w| w[k]);
                let i = *index.entry(angle_key(a)).or_insert_with(|| {
                    rows.push((a, vec![(0.0, 0.0); nch], 0.0));
                    rows.len() - 1
                });
                for c in 0..nch {
                    let v = d.channels[c].values[k];
                    if v.is_finite() {
                        rows[i].1[c].0 += w * v;
                        rows[i].1[c].1 += w;
                    }
                }
                rows[i].2 += w;
            }
        }
        let channels = first
            .channels
            .iter()
            .map(|c| (c.name.clone(), c.wavelength_nm))
            .collect();
        let mut out = Dataset::new(Quantity::Brdf, channels);
        let mut weights = Vec::with_capacity(rows.len());
        let mut merged = false;
        for (a, sums, w) in &rows {
            let v: Vec<f64> = sums
                .iter()
                .map(|&(s, n)| if n > 0.0 { s / n } else { f64::NAN })
                .collect();
            out.push(*a, &v);
            merged |= *w != 1.0;
            weights.push(*w);
        }
        if weighted || merged {
            out.weights = Some(weights);
        }
        out.meta = first.meta.clone();
        out.meta.source = sets
            .iter()
            .map(|d| d.meta.source.as_str())
            .collect::<Vec<_>>()
            .join(" + ");
        Ok(out)
    }

    /// Reduce to one channel as `select` says (by name, index, wavelength, or CIE Y).
    pub fn select(&self, select: &ChannelSelect) -> Result<Dataset, String> {
        let values: Vec<f64>;
        let (name, wl) = match select {
            ChannelSelect::Index(i) => {
                let c = self.channels.get(*i).ok_or_else(|| {
                    format!(
                        "channel index {i} is out of range: the file has {} channel(s) ({})",
                        self.channels.len(),
                        self.channel_names()
                    )
                })?;
                values = c.values.clone();
                (c.name.clone(), c.wavelength_nm)
            }
            ChannelSelect::Name(n) => {
                let c = self
                    .channels
                    .iter()
                    .find(|c| c.name.eq_ignore_ascii_case(n))
                    .ok_or_else(|| {
                        format!(
                            "no channel named '{n}': the channels are {}",
                            self.channel_names()
                        )
                    })?;
                values = c.values.clone();
                (c.name.clone(), c.wavelength_nm)
            }
            ChannelSelect::Wavelength(w) => {
                values = self.interpolate_wavelength(*w)?;
                (format!("{w}nm"), Some(*w))
            }
            ChannelSelect::CieY => {
                values = self.cie_y()?;
                ("y".to_string(), None)
            }
        };
        let mut out = Dataset {
            channels: vec![Channel {
                name,
                wavelength_nm: wl,
                values,
            }],
            ..self.clone_geometry()
        };
        out.meta.comments.push(format!("channel: {select:?}"));
        Ok(out)
    }

    /// The name shown for channel `c`: its own, or for the one unnamed channel of a file the
    /// quantity's column name (`brdf`, `brdf_cos` or `rfactor`), as the file calls it. The one
    /// rule for every output (summary, fit tables and JSON, plots, choose).
    pub fn channel_label(&self, c: usize) -> String {
        match self.channels.get(c) {
            Some(ch) if !ch.name.is_empty() => ch.name.clone(),
            _ => self.quantity.column().to_string(),
        }
    }

    /// Comma-separated channel names ([`Dataset::channel_label`]).
    pub fn channel_names(&self) -> String {
        (0..self.channels.len())
            .map(|c| self.channel_label(c))
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn clone_geometry(&self) -> Dataset {
        Dataset {
            theta_i: self.theta_i.clone(),
            phi_i: self.phi_i.clone(),
            theta_o: self.theta_o.clone(),
            phi_o: self.phi_o.clone(),
            channels: Vec::new(),
            quantity: self.quantity,
            weights: self.weights.clone(),
            meta: self.meta.clone(),
            negatives: self.negatives,
            negative_policy: self.negative_policy,
        }
    }

    fn spectral(&self) -> Result<Vec<(f64, &Vec<f64>)>, String> {
        let mut s: Vec<(f64, &Vec<f64>)> = self
            .channels
            .iter()
            .filter_map(|c| c.wavelength_nm.map(|w| (w, &c.values)))
            .collect();
        if s.is_empty() {
            return Err(format!(
                "the data has no wavelength channels (channels: {})",
                self.channel_names()
            ));
        }
        s.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(s)
    }

    fn interpolate_wavelength(&self, w: f64) -> Result<Vec<f64>, String> {
        let s = self.spectral()?;
        let (lo, hi) = (s[0].0, s[s.len() - 1].0);
        if !(lo..=hi).contains(&w) {
            return Err(format!(
                "wavelength {w} nm is outside the data's range {lo}–{hi} nm"
            ));
        }
        let j = s.iter().position(|(l, _)| *l >= w).unwrap_or(s.len() - 1);
        if s[j].0 == w || j == 0 {
            return Ok(s[j].1.clone());
        }
        let (l0, v0) = s[j - 1];
        let (l1, v1) = s[j];
        let t = (w - l0) / (l1 - l0);
        Ok(v0.iter().zip(v1).map(|(a, b)| a + t * (b - a)).collect())
    }

    /// Luminance-weighted channel: Σ ȳ(λ) v(λ) / Σ ȳ(λ) with the CIE 1931 2° ȳ.
    fn cie_y(&self) -> Result<Vec<f64>, String> {
        let s = self.spectral()?;
        let w: Vec<f64> = s.iter().map(|(l, _)| cie_ybar(*l)).collect();
        let total: f64 = w.iter().sum();
        if total <= 0.0 {
            return Err("the wavelengths lie outside 360–830 nm, where CIE Y is defined".into());
        }
        let n = self.len();
        Ok((0..n)
            .map(|k| s.iter().zip(&w).map(|((_, v), wt)| v[k] * wt).sum::<f64>() / total)
            .collect())
    }
}

/// How to reduce many channels to one.
#[derive(Clone, Debug, PartialEq)]
pub enum ChannelSelect {
    /// By 0-based index.
    Index(usize),
    /// By name (`r`, `g`, `b`, `550nm`, …).
    Name(String),
    /// A wavelength in nm, linearly interpolated between neighbouring channels.
    Wavelength(f64),
    /// CIE 1931 luminance Y.
    CieY,
}

impl ChannelSelect {
    /// Parse `y`/`cie-y`, a wavelength like `550nm`, an index, or a name.
    pub fn parse(s: &str) -> Self {
        let t = s.trim();
        if t.eq_ignore_ascii_case("cie-y") || t.eq_ignore_ascii_case("ciey") {
            return ChannelSelect::CieY;
        }
        if let Some(w) = t.strip_suffix("nm").and_then(|w| w.parse::<f64>().ok()) {
            return ChannelSelect::Wavelength(w);
        }
        if let Ok(i) = t.parse::<usize>() {
            return ChannelSelect::Index(i);
        }
        ChannelSelect::Name(t.to_string())
    }
}

/// CIE 1931 2° colour-matching function ȳ(λ), 10 nm table 360–830 nm, linearly interpolated.
pub fn cie_ybar(lambda: f64) -> f64 {
    // CIE 15:2004 Table T.4 (1931 standard observer), ȳ at 360, 370, …, 830 nm.
    const Y: [f64; 48] = [
        0.000003917,
        0.00001239,
        0.000039,
        0.00012,
        0.000396,
        0.00121,
        0.004,
        0.0116,
        0.023,
        0.038,
        0.06,
        0.09098,
        0.13902,
        0.20802,
        0.323,
        0.503,
        0.71,
        0.862,
        0.954,
        0.9949501,
        0.995,
        0.952,
        0.87,
        0.757,
        0.631,
        0.503,
        0.381,
        0.265,
        0.175,
        0.107,
        0.061,
        0.032,
        0.017,
        0.00821,
        0.004102,
        0.002091,
        0.001047,
        0.00052,
        0.0002492,
        0.00012,
        0.00006,
        0.00003,
        0.000014996,
        0.0000075,
        0.0000037,
        0.0000018,
        0.0000009,
        0.0000004,
    ];
    let x = (lambda - 360.0) / 10.0;
    if !(0.0..=47.0).contains(&x) {
        return 0.0;
    }
    let i = (x.floor() as usize).min(46);
    let t = x - i as f64;
    Y[i] + t * (Y[i + 1] - Y[i])
}

/// Options for [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Force a format instead of detecting it.
    pub format: Option<Format>,
    /// Policy for negative values.
    pub negative: NegativePolicy,
}

/// The single validating entry point for rows: checks angles, values and weights, applies the
/// negative policy, and stores the row. Every loader feeds rows through it.
pub struct RowSink<'a> {
    path: &'a Path,
    policy: NegativePolicy,
    /// The dataset being filled.
    pub ds: Dataset,
    buf: Vec<f64>,
}

const ANGLE_TOL: f64 = 1e-6;

impl<'a> RowSink<'a> {
    /// New sink filling `ds` for file `path`.
    pub fn new(path: &'a Path, policy: NegativePolicy, mut ds: Dataset) -> Self {
        ds.negative_policy = policy;
        RowSink {
            path,
            policy,
            ds,
            buf: Vec::new(),
        }
    }

    fn err(&self, line: u64, msg: String, fix: &str) -> DataError {
        DataError::new(self.path, Some(line), msg, fix)
    }

    /// Validate and store one row: angles in radians, values (NaN = explicitly missing),
    /// optional weight.
    pub fn push(
        &mut self,
        line: u64,
        angles: [f64; 4],
        values: &[f64],
        weight: Option<f64>,
    ) -> Result<(), DataError> {
        const NAMES: [&str; 4] = ["θi", "φi", "θo", "φo"];
        for (k, &a) in angles.iter().enumerate() {
            if !a.is_finite() {
                return Err(self.err(
                    line,
                    format!("{} is {a}", NAMES[k]),
                    "every angle must be a finite number",
                ));
            }
            if k % 2 == 0 && !(-ANGLE_TOL..=FRAC_PI_2 + ANGLE_TOL).contains(&a) {
                return Err(self.err(
                    line,
                    format!("{} = {:.4}° is outside [0°, 90°]", NAMES[k], a.to_degrees()),
                    "θ is measured from the surface normal and must lie in [0°, 90°]; \
                     check that the column's unit (_deg or _rad) matches its values",
                ));
            }
            if k % 2 == 1 && a.abs() > 2.0 * PI + ANGLE_TOL {
                return Err(self.err(
                    line,
                    format!(
                        "{} = {:.4}° is outside [−360°, 360°]",
                        NAMES[k],
                        a.to_degrees()
                    ),
                    "azimuths must lie in [−360°, 360°]; check the column's unit (_deg or _rad)",
                ));
            }
        }
        let mut a = angles;
        a[0] = a[0].clamp(0.0, FRAC_PI_2);
        a[2] = a[2].clamp(0.0, FRAC_PI_2);
        self.buf.clear();
        for &v in values {
            if v.is_infinite() {
                return Err(self.err(
                    line,
                    format!("value is {v}"),
                    "values must be finite; remove the row or leave the field empty to mark it missing",
                ));
            }
            if v < 0.0 {
                self.ds.negatives += 1;
                match self.policy {
                    NegativePolicy::Mask => {
                        self.buf.push(f64::NAN);
                        continue;
                    }
                    NegativePolicy::Clamp => {
                        self.buf.push(0.0);
                        continue;
                    }
                    NegativePolicy::Error => {
                        return Err(self
                            .err(
                                line,
                                format!("negative value {v}"),
                                "reflectance cannot be negative; treat negative values as missing \
                                 (mask) or set them to 0 (clamp)",
                            )
                            .with_setting(crate::support::setting::Setting::NegativePolicy));
                    }
                }
            }
            self.buf.push(v);
        }
        if let Some(w) = weight {
            if !(w.is_finite() && w >= 0.0) {
                return Err(self.err(
                    line,
                    format!("weight {w} is not a finite number ≥ 0"),
                    "weights must be finite and non-negative",
                ));
            }
            self.ds.weights.get_or_insert_with(Vec::new).push(w);
        }
        let buf = std::mem::take(&mut self.buf);
        self.ds.push(a, &buf);
        self.buf = buf;
        Ok(())
    }

    /// Finish: an empty result is an error.
    pub fn finish(self) -> Result<Dataset, DataError> {
        if self.ds.is_empty() {
            return Err(DataError::new(
                self.path,
                None,
                "the file holds no samples",
                "give a file with at least one data row",
            ));
        }
        Ok(self.ds)
    }
}

/// Parse a float field, with an error naming the line, the column and the fix.
pub(crate) fn parse_number(
    path: &Path,
    line: u64,
    column: &str,
    field: &str,
) -> Result<f64, DataError> {
    let t = field.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_nan() => Err(DataError::new(
            path,
            Some(line),
            format!("column {column}: value is NaN"),
            "brdfit never guesses a missing measurement: leave the field empty (CSV) or remove the row",
        )),
        Ok(v) => Ok(v),
        Err(_) => {
            let fix = if t.contains(',') || (t.contains(';')) {
                "use '.' as the decimal separator and ',' between fields"
            } else {
                "every field in this column must be a number"
            };
            let shown: String = t.chars().take(40).collect();
            Err(DataError::new(
                path,
                Some(line),
                format!("column {column}: '{shown}' is not a number"),
                fix,
            ))
        }
    }
}

/// Detect the format of `path` from its extension and first bytes.
pub fn detect_format(path: &Path, head: &[u8]) -> Result<Format, DataError> {
    if head.starts_with(&[0x1f, 0x8b]) {
        return Err(DataError::new(
            path,
            None,
            "the file is gzip-compressed",
            "decompress it first (gunzip -k FILE) and load the result",
        ));
    }
    if head.len() >= 12 && merl::looks_like_merl(head) {
        return Ok(Format::Merl);
    }
    if let Some(f) = Format::from_extension(path) {
        return Ok(f);
    }
    let text = String::from_utf8_lossy(&head[..head.len().min(4096)]);
    for line in text.lines() {
        let l = line.trim_start_matches('\u{feff}').trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        if l.starts_with("theta_") || l.contains(",theta_") {
            return Ok(Format::Csv);
        }
        if l.split_whitespace().next().is_some_and(|w| {
            w.chars()
                .all(|c| c.is_ascii_uppercase() || c == '_' || c.is_ascii_digit())
        }) && l.split_whitespace().count() >= 2
        {
            return Ok(Format::Astm);
        }
        if l.split_whitespace().all(|w| w.parse::<f64>().is_ok()) {
            return Ok(Format::Cornell);
        }
        break;
    }
    Err(DataError::new(
        path,
        None,
        "unknown file format",
        "name the file .csv, .astm, .brdf or .binary, or choose the format (csv, astm, cornell, merl)",
    )
    .with_setting(crate::support::setting::Setting::Format))
}

/// Open a data file for reading within the data size limit ([`crate::support::input`]), with errors
/// that say what to do.
pub(crate) fn open(
    path: &Path,
) -> Result<crate::support::input::Limited<std::fs::File>, DataError> {
    crate::support::input::open_limited(path, crate::support::input::Input::Data)
}

/// Load a data file in any supported format.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Dataset, DataError> {
    let mut f = open(path)?;
    let mut head = Vec::with_capacity(4096);
    (&mut f)
        .take(4096)
        .read_to_end(&mut head)
        .map_err(|e| io_error(path, &e))?;
    if head.is_empty() {
        return Err(DataError::new(
            path,
            None,
            "the file is empty",
            "give a file with a header and data rows",
        ));
    }
    let format = match opts.format {
        Some(f) => f,
        None => detect_format(path, &head)?,
    };
    drop(f);
    let mut ds = match format {
        Format::Csv => csvfmt::load_csv(path, opts.negative, true)?,
        Format::Astm => astm::load_astm(path, opts.negative)?,
        Format::Cornell => cornell::load_cornell(path, opts.negative)?,
        Format::Merl => merl::load_merl(path)?,
    };
    ds.meta.source = path.display().to_string();
    ds.meta.format = format.name().to_string();
    Ok(ds)
}

/// Read a whole text file, accepting a UTF-8 BOM; invalid UTF-8 is an error with a fix.
pub(crate) fn read_text(path: &Path) -> Result<String, DataError> {
    crate::support::input::read_to_string_limited(path, crate::support::input::Input::Data)
}

/// Summary statistics for `brdfit info`.
pub fn summary(ds: &Dataset) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let deg = |x: f64| x.to_degrees();
    let _ = writeln!(s, "file:        {}", ds.meta.source);
    let _ = writeln!(s, "format:      {}", ds.meta.format);
    if let Some(m) = &ds.meta.material {
        let _ = writeln!(s, "material:    {m}");
    }
    let _ = writeln!(s, "samples:     {}", ds.len());
    let _ = writeln!(
        s,
        "channels:    {} ({})",
        ds.channels.len(),
        ds.channel_names()
    );
    let _ = writeln!(s, "quantity:    {}", ds.quantity);
    let mut ti: BTreeMap<i64, usize> = BTreeMap::new();
    for &t in &ds.theta_i {
        *ti.entry((deg(t) * 100.0).round() as i64).or_default() += 1;
    }
    let list: Vec<String> = ti
        .keys()
        .take(20)
        .map(|k| format!("{}", *k as f64 / 100.0))
        .collect();
    let more = if ti.len() > 20 {
        format!(" … ({} distinct)", ti.len())
    } else {
        String::new()
    };
    let _ = writeln!(s, "θi values:   {}°{more}", list.join(", "));
    let range = |v: &[f64]| {
        v.iter()
            .filter(|x| x.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            })
    };
    let (a, b) = range(&ds.theta_o);
    let _ = writeln!(s, "θo range:    {:.2}° … {:.2}°", deg(a), deg(b));
    let mut po: Vec<i64> = ds
        .phi_o
        .iter()
        .map(|p| (deg(p.rem_euclid(2.0 * PI)) * 100.0).round() as i64 % 36000)
        .collect();
    po.sort_unstable();
    po.dedup();
    let (a, b) = range(&ds.phi_o);
    let _ = writeln!(
        s,
        "φo coverage: {:.2}° … {:.2}° ({} distinct)",
        deg(a),
        deg(b),
        po.len()
    );
    for (k, c) in ds.channels.iter().enumerate() {
        let (a, b) = range(&c.values);
        let name = ds.channel_label(k);
        if a > b {
            // No finite value: an empty range, said in words (not `inf … -inf`).
            let _ = writeln!(s, "range {name:<6} no values (every sample missing)");
        } else {
            let _ = writeln!(s, "range {name:<6} {a:.6e} … {b:.6e}");
        }
    }
    let policy = match ds.negative_policy {
        NegativePolicy::Mask => "masked as missing",
        NegativePolicy::Clamp => "clamped to 0",
        NegativePolicy::Error => "refused",
    };
    let _ = writeln!(s, "negatives:   {} ({policy})", ds.negatives);
    let _ = writeln!(s, "missing:     {}", ds.missing());
    let _ = writeln!(s, "duplicates:  {}", ds.duplicates());
    if let Some(w) = &ds.weights {
        let (a, b) = range(w);
        let _ = writeln!(s, "weights:     {a} … {b}");
    }
    s
}

/// The one channel a multi-channel data set is summarised by when none is chosen (the report,
/// the studies): CIE 1931 luminance Y of spectral data, the green channel of RGB (else the
/// first), or the only channel. Returns it with a phrase saying which.
pub fn representative_channel(ds: &Dataset) -> Result<(Dataset, String), String> {
    if ds.channels.len() <= 1 {
        return Ok((ds.clone(), "the single channel".into()));
    }
    if ds.channels.iter().any(|c| c.wavelength_nm.is_some()) {
        return Ok((
            ds.select(&ChannelSelect::CieY)?,
            "CIE 1931 luminance Y of the spectral channels".into(),
        ));
    }
    match ds.channels.iter().position(|c| c.name == "g") {
        Some(g) => Ok((
            ds.select(&ChannelSelect::Index(g))?,
            "the green channel".into(),
        )),
        None => Ok((
            ds.select(&ChannelSelect::Index(0))?,
            format!("the first channel ({})", ds.channels[0].name),
        )),
    }
}
