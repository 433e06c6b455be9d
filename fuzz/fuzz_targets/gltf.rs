//! glTF/GLB: the reader (accessors, buffers, embedded images, texture sampling) returns samples or
//! an error, never panics or hangs. The input is written to a file: the reader takes a path, as
//! a glTF's external buffers and images are relative to it.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("kiosk-fuzz-{}.glb", std::process::id()));
    if std::fs::write(&path, data).is_err() {
        return;
    }
    // A low density keeps a valid file with a huge texture footprint from taking minutes.
    let opts = kiosk_import::ReadOptions { texel_density: 0.05, ..Default::default() };
    let mut points = 0usize;
    let _ = kiosk_import::source::read_file(&path, &opts, &mut |_| {
        points += 1;
        Ok(())
    });
});
