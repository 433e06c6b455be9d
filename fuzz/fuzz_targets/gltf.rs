//! glTF/GLB: the reader (accessors, buffers, embedded images, texture sampling) returns samples or
//! an error, never panics or hangs. The input is written to a file: the reader takes a path, as
//! a glTF's external buffers and images are relative to it.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("kiosk-fuzz-{}.glb", std::process::id()));
    if std::fs::write(&path, data).is_err() {
        return;
    }
    // A low density and a sample cap keep a valid file with a huge texture footprint (texture
    // coordinates spanning thousands of repeats: a legitimate, if slow, import) from taking
    // minutes; the cap is an error like any other.
    let opts = kiosk_import::ReadOptions { texel_density: 0.05, max_samples: 5_000_000, ..Default::default() };
    let mut points = 0usize;
    let _ = kiosk_import::read_file(&path, &opts, &mut |_| {
        points += 1;
        Ok(())
    });
});
