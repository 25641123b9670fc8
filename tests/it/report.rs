//! The report: every link and image in index.html points to an existing, valid file; the
//! same inputs give the same files (timings aside); no network, no script.

use std::path::{Path, PathBuf};

/// The report of two bundled files into `out`; with `record`, its progress calls (done, total,
/// message) in the order made.
fn run(out: &Path, record: bool) -> Vec<(u64, u64, String)> {
    use std::sync::{Arc, Mutex};
    let files = vec![
        PathBuf::from("data/blinn-mgo.csv"),
        PathBuf::from("data/cayman.astm"),
    ];
    let calls = Arc::new(Mutex::new(Vec::new()));
    let sink = calls.clone();
    let progress = record.then(|| {
        brdfit::report::Progress(Arc::new(move |done, total, what: &str| {
            sink.lock().unwrap().push((done, total, what.to_string()))
        }))
    });
    brdfit::report::report(
        &files,
        &brdfit::report::ReportOptions {
            out: out.to_path_buf(),
            stability_starts: 1,
            render_res: 32,
            verbose: false,
            progress,
        },
    )
    .unwrap();
    Arc::try_unwrap(calls)
        .expect("the hook went with the report's options")
        .into_inner()
        .unwrap()
}

fn links(html: &str) -> Vec<String> {
    let mut v = Vec::new();
    for attr in ["src=\"", "href=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(attr) {
            rest = &rest[i + attr.len()..];
            let end = rest.find('"').unwrap();
            v.push(rest[..end].to_string());
        }
    }
    v
}

fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn report_links_are_valid_and_output_is_reproducible() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    // The first with a progress hook (the files must not depend on it), the second without.
    let calls = run(a.path(), true);
    run(b.path(), false);
    // The studies' stage in order: the stability study starts where the speed study's steps
    // ended, not back at the stage's start (the bar fell from 79 % to 61 % there).
    for file in ["blinn-mgo", "cayman"] {
        let at = |what: &str| -> Vec<u64> {
            calls
                .iter()
                .filter(|c| c.2.starts_with(&format!("{file}: studies: {what}")))
                .map(|c| c.0)
                .collect()
        };
        let (speed, stability) = (at("speed against accuracy"), at("stability"));
        assert!(
            speed.len() > 10 && !stability.is_empty(),
            "{file}: {calls:?}"
        );
        assert!(
            stability[0] >= *speed.iter().max().unwrap(),
            "{file}: stability starts at {} after the speed study reached {:?}",
            stability[0],
            speed.iter().max()
        );
    }
    let total = calls[0].1;
    assert!(calls.iter().all(|c| c.1 == total && c.0 <= total));
    let html = std::fs::read_to_string(a.path().join("index.html")).unwrap();
    assert!(!html.contains("<script") && !html.contains("http://") && !html.contains("https://"));
    let ls = links(&html);
    assert!(ls.len() > 30, "{} links", ls.len());
    for l in &ls {
        if let Some(anchor) = l.strip_prefix('#') {
            assert!(
                html.contains(&format!("id=\"{anchor}\"")),
                "dangling anchor {l}"
            );
            continue;
        }
        assert!(
            !l.starts_with('/') && !l.contains(".."),
            "not a relative link inside the report: {l}"
        );
        let p = a.path().join(l);
        let bytes = std::fs::read(&p).unwrap_or_else(|_| panic!("missing {l}"));
        match p.extension().and_then(|e| e.to_str()) {
            Some("png") | Some("exr") => {
                image::open(&p).unwrap_or_else(|e| panic!("{l}: {e}"));
            }
            Some("svg") => assert!(bytes.starts_with(b"<svg"), "{l}"),
            Some("json") => {
                serde_json::from_slice::<serde_json::Value>(&bytes)
                    .unwrap_or_else(|e| panic!("{l}: {e}"));
                // The fit files the report offers read back under the strict reader.
                if l.rsplit('/').next().is_some_and(|f| f.starts_with("fit-")) {
                    brdfit::fit::read_fit_file(std::str::from_utf8(&bytes).unwrap())
                        .unwrap_or_else(|e| panic!("{l}: {e}"));
                }
            }
            Some("md") | Some("csv") => assert!(!bytes.is_empty()),
            other => panic!("unexpected link type {other:?}: {l}"),
        }
    }
    let (ta, tb) = (tree(a.path()), tree(b.path()));
    assert_eq!(ta.len(), tb.len());
    for ((pa, ba), (pb, bb)) in ta.iter().zip(&tb) {
        assert_eq!(pa, pb);
        if measures_time(pa) {
            continue;
        }
        assert!(ba == bb, "{} differs between runs", pa.display());
    }
    // choose.json differs only in its times.
    let strip = |p: &Path| {
        let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
        for c in v["cases"].as_array_mut().unwrap() {
            c["reference_render_seconds"] = 0.into();
            for m in c["models"].as_array_mut().unwrap() {
                m["fit_seconds"] = 0.into();
                m["render_seconds"] = 0.into();
            }
        }
        v["resample_seconds"] = 0.into();
        v
    };
    let mut compared = 0;
    for (p, _) in &ta {
        if p.ends_with("choose/choose.json") {
            assert_eq!(
                strip(&a.path().join(p)),
                strip(&b.path().join(p)),
                "{}",
                p.display()
            );
            compared += 1;
        }
    }
    assert_eq!(compared, 2);
    // results.json holds every fit (every model of the catalogue × 2 data sets) and no timing.
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.path().join("results.json")).unwrap()).unwrap();
    let sets = r["data_sets"].as_array().unwrap();
    assert_eq!(sets.len(), 2);
    assert!(
        sets.iter()
            .all(|s| s["fits"].as_array().unwrap().len() == brdfit::model::catalogue().len())
    );
    assert!(
        !std::fs::read_to_string(a.path().join("results.json"))
            .unwrap()
            .contains("\"seconds\"")
    );
    // timings.json: per data set, `fits` is the stage's wall time like every other entry, and
    // each model of the catalogue has its own clock under `fit_seconds_per_model` (they ran in
    // parallel; `fits` used to be their sum).
    let t: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.path().join("timings.json")).unwrap()).unwrap();
    for set in ["blinn-mgo", "cayman"] {
        assert!(t[set]["fits"].as_f64().is_some_and(|s| s >= 0.0), "{t}");
        let per = t[set]["fit_seconds_per_model"].as_object().unwrap();
        assert_eq!(per.len(), brdfit::model::catalogue().len(), "{per:?}");
        assert!(per.values().all(|s| s.as_f64().is_some_and(|s| s >= 0.0)));
    }
}

/// The files that show measured run times and so differ between runs: timings.json, and each
/// `brdfit choose` run's JSON, Markdown table and image-error-against-time chart, and the
/// speed–accuracy chart (x = fit time).
fn measures_time(p: &Path) -> bool {
    let s = p.to_string_lossy();
    s == "timings.json"
        || s.ends_with("choose/choose.json")
        || s.ends_with("choose/choose.md")
        || s.contains("/chart.")
        || s.contains("/speed-accuracy.svg")
        || s.contains("/speed-accuracy.png")
}
