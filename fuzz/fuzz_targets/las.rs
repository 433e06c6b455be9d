//! LAS and LAZ: the reader (its header checks, the LAZ decoder with its chunk table, the point
//! records, the colour range) returns points or an error, never panics, aborts or hangs. The
//! input is written to a file: the reader takes a path, as the importer calls it.
//!
//! The LAZ decoder (the laz crate) asserts on its arithmetic coder's state, so corrupted
//! compressed points make it panic; the reader turns such a panic into an error naming it
//! (`formats::guarded`). A panic from the laz crate is therefore not a crash here, while one from
//! anywhere else (the reader, the las crate) still is: libFuzzer's abort-on-panic hook is kept
//! for every other place.
#![no_main]
use std::sync::Once;

static HOOK: Once = Once::new();

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    HOOK.call_once(|| {
        let abort = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !info.location().is_some_and(|l| l.file().contains("/laz-")) {
                abort(info);
            }
        }));
    });
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
