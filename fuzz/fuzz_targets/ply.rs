//! PLY in any encoding: the reader returns points or an error, never panics or hangs.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let opts = kiosk_import::ReadOptions::default();
    let _ = kiosk_import::formats::read_ply_bytes(data, &opts);
});
