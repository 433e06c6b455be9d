//! `kiosk.toml`: the kiosk's configuration parser (TOML into the configuration, then its checks:
//! rotations, window sizes, field of view, real scale, timeouts, volume, popularity, splat mode)
//! returns a configuration or an error, never panics or hangs; a configuration it accepts gives
//! the renderer a field of view it can project with, strictly between 0 and 180 degrees.
#![no_main]
use kiosk::windows::config::Config;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(c) = Config::parse(text) else { return };
    // What the kiosk derives from an accepted configuration at start-up.
    let _ = c.render_settings();
    let fov = c.fov_y();
    assert!(fov > 0.0 && fov < std::f64::consts::PI, "{text:?}: a field of view of {fov} rad");
});
