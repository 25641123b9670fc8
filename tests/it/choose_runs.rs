//! Runs of `choose` into one folder: two at once end with one run's folder whole, and a run
//! killed (SIGKILL) over an earlier run's folder leaves that folder whole. Each run's own
//! folder, written alone, is the reference: the outcome must equal one of them file for file
//! (renders, maps and sheets byte for byte; choose.json and choose.md but for the measured
//! times; the charts, which plot the times, left out).

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Child, Command};

fn start(res: &str, out: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_brdfit"))
        .args(["choose", "data/blinn-mgo.csv", "--res", res, "-q", "-o"])
        .arg(out)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("run brdfit")
}

/// Drop the measured times (`*_seconds`), the only part of a run that varies.
fn drop_times(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|k, _| !k.ends_with("_seconds"));
            m.values_mut().for_each(drop_times);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(drop_times),
        _ => {}
    }
}

/// Every file of `dir` by relative path, `choose.json` without its times.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
            let mut bytes = std::fs::read(&p).unwrap();
            // The charts plot the measured times; the Markdown table's last two columns are
            // times: left out of the comparison.
            if rel.ends_with("chart.svg") || rel.ends_with("chart.png") {
                continue;
            }
            if rel == "choose.md" {
                let text = String::from_utf8(bytes).unwrap();
                let rows: Vec<String> = text
                    .lines()
                    .map(|l| match l.starts_with('|') {
                        true => {
                            let cells: Vec<&str> = l.split('|').collect();
                            cells[..cells.len().saturating_sub(3)].join("|")
                        }
                        false => l.to_string(),
                    })
                    .collect();
                bytes = rows.join("\n").into_bytes();
            }
            if rel == "choose.json" {
                let mut v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
                drop_times(&mut v);
                bytes = serde_json::to_vec(&v).unwrap();
            }
            out.insert(rel, bytes);
        }
    }
    out
}

fn which(got: &BTreeMap<String, Vec<u8>>, refs: &[&BTreeMap<String, Vec<u8>>]) -> Option<usize> {
    refs.iter().position(|r| *r == got)
}

#[test]
fn concurrent_and_killed_choose_runs_leave_one_whole_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The references: each resolution alone in its own folder (two at once, different folders).
    let (ra, rb) = (d.join("ref24"), d.join("ref32"));
    let (mut a, mut b) = (start("24", &ra), start("32", &rb));
    assert!(a.wait().unwrap().success() && b.wait().unwrap().success());
    let refs = [snapshot(&ra), snapshot(&rb)];
    assert_ne!(refs[0], refs[1]);
    assert!(refs[0].contains_key("choose.json") && refs[0].len() > 10);
    // Two runs started at once into one folder, twice: one run's folder, whole.
    let same = d.join("same");
    for trial in 0..2 {
        let (mut a, mut b) = (start("24", &same), start("32", &same));
        assert!(a.wait().unwrap().success() && b.wait().unwrap().success());
        let got = snapshot(&same);
        let names: Vec<&String> = got.keys().collect();
        assert!(
            which(&got, &[&refs[0], &refs[1]]).is_some(),
            "trial {trial}: a mixed folder: {names:?}"
        );
    }
    // A run killed over that folder (while its staging folder is being written, if it is
    // met; else wherever it is) leaves it whole: the earlier run's, or its own if it ended.
    let before = snapshot(&same);
    let mut c = start("32", &same);
    let stage = format!(".same.brdfit-tmp-{}", c.id());
    let t = std::time::Instant::now();
    while !d.join(&stage).exists() && t.elapsed().as_secs() < 120 {
        if c.try_wait().unwrap().is_some() {
            break;
        }
    }
    let _ = c.kill();
    let _ = c.wait();
    let after = snapshot(&same);
    assert!(
        after == before || after == refs[1],
        "the killed run left a mixed folder: {:?}",
        after.keys().collect::<Vec<_>>()
    );
}
