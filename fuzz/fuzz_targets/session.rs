//! Session JSONL: a session or an error naming a line; what is read writes back identically.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(session) = kiosk_core::session::Session::parse(text) else { return };
    let again = kiosk_core::session::Session::parse(&session.to_jsonl()).expect("own output reads back");
    assert_eq!(again.events.len(), session.events.len());
});
