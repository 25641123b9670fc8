//! Fuzz the scene reader: any text gives a scene or an error; small scenes are also rendered.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(mut s) = brdfit::render::scene::parse_scene(&text, std::path::Path::new("/nonexistent")) {
        s.camera.width = s.camera.width.min(8);
        s.camera.height = s.camera.height.min(8);
        s.max_depth = s.max_depth.min(4);
        let _ = s.render(&|| {});
    }
});
