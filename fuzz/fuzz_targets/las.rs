//! LAS and LAZ: the reader (its header checks, the LAZ decoder with its chunk table, the point
//! records, the colour range) returns points or an error, never panics, aborts or hangs. The
//! input is written to a file: the reader takes a path, as the importer calls it.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("kiosk-fuzz-{}.las", std::process::id()));
    if std::fs::write(&path, data).is_err() {
        return;
    }
    let mut points = 0usize;
    let _ = kiosk_import::formats::las::read(&path, &mut |_| {
        points += 1;
        Ok(())
    });
});
