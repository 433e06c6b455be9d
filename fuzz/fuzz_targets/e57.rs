//! E57: the reader (the file's pages and checksums, its XML section, every scan's binary
//! sections, poses and spherical coordinates) returns points or an error, never panics, aborts or
//! hangs. The input is written to a file: the reader takes a path, as the importer calls it.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("kiosk-fuzz-{}.e57", std::process::id()));
    if std::fs::write(&path, data).is_err() {
        return;
    }
    let mut points = 0usize;
    let _ = kiosk_import::formats::e57::read(&path, &mut |_| {
        points += 1;
        Ok(())
    });
});
