//! Fuzz the fit JSON reader (`FitResult::from_json`, as `render --mgo`, `export` and a scene's
//! `fit =` call it): any bytes give a fit or an error, never a panic; a fit read is also turned
//! into its model and exported, as the consumers do.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(data) else {
        return;
    };
    let list: Vec<serde_json::Value> = match v.get("fits").and_then(|f| f.as_array()) {
        Some(a) => a.clone(),
        None => vec![v],
    };
    for f in &list {
        if let Ok(r) = brdfit::fit::FitResult::from_json(f) {
            let m = r.model_for(0);
            let _ = brdfit::export::mitsuba(&m, "fuzz");
            let _ = brdfit::export::pbrt(&m);
        }
    }
});
