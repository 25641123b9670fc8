//! Fuzz the merl reader: any bytes give a dataset or an error, never a panic or a hang.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("brdfit-fuzz-merl-{}", std::process::id()));
    std::fs::write(&path, data).expect("temp file");
    let opts = brdfit::data::LoadOptions { format: Some(brdfit::data::Format::Merl), ..Default::default() };
    if let Ok(ds) = brdfit::data::load(&path, &opts) {
        let _ = brdfit::data::summary(&ds);
    }
});
