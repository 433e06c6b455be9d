//! OBJ: the reader returns points or an error, never panics or hangs.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let opts = kiosk_import::ReadOptions::default();
    let mut reader = std::io::BufReader::new(data);
    let mut points = 0usize;
    let _ = kiosk_import::formats::obj::read_obj(&mut reader, &opts, &mut |_| {
        points += 1;
        Ok(())
    });
});
