//! Reading a fit back from its JSON object: checked against the schema first, and the JSON of
//! earlier versions read as far as it goes.

use super::fitfile::{self, FitFileError};
use super::lsq::Method;
use super::options::Weighting;
use super::problem::Loss;
use super::result::{FitResult, Verification};
use crate::model::{Distribution, ModelKind};

impl FitResult {
    /// Read a fit back from its JSON object, checked first: only known keys, a known model and
    /// distribution, and every parameter of the model present once, finite and within its declared
    /// bounds ([`ParamSpec::admits`](crate::model::ParamSpec::admits)); the error names the key and
    /// the fix. The JSON of earlier versions (standard errors as an object, no certificate) is read
    /// as far as it goes. Duplicate keys are lost in a `Value`: read text with
    /// [`read_fit_file`](crate::fit::read_fit_file).
    pub fn from_json(v: &serde_json::Value) -> Result<FitResult, FitFileError> {
        fitfile::check_fit_object(v)?;
        match serde_json::from_value::<FitResult>(v.clone()) {
            Ok(f) => Ok(f),
            Err(e) => Self::from_lenient_json(v).map_err(|m| FitFileError {
                message: format!("{m} ({e})"),
                fix: "give a file written by brdfit fit --json".into(),
            }),
        }
    }

    /// The reader of earlier versions' fit JSON: the model, its parameters and the figures;
    /// what it lacks is left empty.
    fn from_lenient_json(v: &serde_json::Value) -> Result<FitResult, String> {
        let s = |k: &str| v.get(k).and_then(|x| x.as_str()).map(str::to_string);
        let model = s("model")
            .and_then(|m| ModelKind::parse(&m))
            .ok_or("the fit JSON has no known 'model'")?;
        let dist = s("distribution")
            .and_then(|d| Distribution::parse(&d))
            .unwrap_or_default();
        let obj = v
            .get("params")
            .and_then(|p| p.as_object())
            .ok_or("the fit JSON has no 'params' object")?;
        let params: Vec<(String, f64)> = obj
            .iter()
            .map(|(k, x)| (k.clone(), x.as_f64().unwrap_or(f64::NAN)))
            .collect();
        if params.iter().any(|(_, x)| !x.is_finite()) {
            return Err("a parameter in the fit JSON is not a number".into());
        }
        let n = params.len();
        let f = |k: &str| v.get(k).and_then(|x| x.as_f64()).unwrap_or(f64::NAN);
        Ok(FitResult {
            model,
            dist,
            loss: s("loss").and_then(|l| Loss::parse(&l)).unwrap_or_default(),
            method: s("method")
                .and_then(|m| Method::parse(&m))
                .unwrap_or_default(),
            channel: s("channel").unwrap_or_default(),
            weights: Weighting::default(),
            weighted: v.get("weighted").and_then(|x| x.as_bool()).unwrap_or(false),
            stderr: vec![0.0; n],
            correlation: vec![],
            free: vec![true; n],
            params,
            cost: f("cost"),
            rmse: f("rmse"),
            samples_used: f("samples_used") as usize,
            iterations: 0,
            evaluations: 0,
            termination: s("termination").unwrap_or_default(),
            seconds: f("seconds"),
            geometry_seconds: f("geometry_seconds"),
            solve_seconds: f("solve_seconds"),
            statistics_seconds: f("statistics_seconds"),
            warnings: vec![],
            bic: f("bic"),
            aic: f("aic"),
            n_free: n,
            ranges: vec![],
            interval_level: 0.0,
            at_bound: v
                .get("at_bound")
                .and_then(|x| x.as_object())
                .map(|o| {
                    o.iter()
                        .map(|(k, x)| (k.clone(), x.as_str().unwrap_or("").to_string()))
                        .collect()
                })
                .unwrap_or_default(),
            kkt_violation: f("kkt_violation"),
            verification: v.get("verified").and_then(|x| x.as_bool()).map(|verified| {
                Verification {
                    starts: f("verify_starts") as usize,
                    best_cost: f("verify_best_cost"),
                    robust: v
                        .get("verify_loss")
                        .and_then(|x| x.as_str())
                        .unwrap_or("")
                        .to_string(),
                    verified,
                }
            }),
            unusable: v
                .get("unusable")
                .and_then(|x| x.as_array())
                .map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_str().map(str::to_string))
                        .collect()
                })
                .unwrap_or_default(),
        })
    }
}
