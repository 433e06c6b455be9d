//! Narration decodes: every narration file that an exhibit's graph names is decoded by the same
//! path the kiosk and the authoring tool play it through (kira with symphonia's codecs).

use kiosk_content::audio::{Narrator, decode};

/// Every narration of every demo exhibit (each directory of `content/`), as its graph names them.
fn narrations() -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    let mut dirs: Vec<_> = std::fs::read_dir(super::content())
        .expect("content/")
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    assert!(dirs.len() >= 3, "the demo exhibits: {dirs:?}");
    for dir in dirs {
        let (graph, problems) =
            kiosk_content::exhibit::open_graph(&dir).expect("read graph.xml").expect("a graph");
        assert!(problems.is_empty(), "{}: {problems:?}", dir.display());
        for node in &graph.nodes {
            files.extend(node.narration.0.values().map(|rel| dir.join(rel)));
        }
    }
    files
}

#[test]
fn every_narration_of_the_demo_exhibits_decodes() {
    let files = narrations();
    assert!(files.len() >= 48, "expected the demo exhibits' narrations, found {}", files.len());
    for f in &files {
        let data = decode(f).unwrap_or_else(|e| panic!("{e}"));
        let seconds = data.frames.len() as f64 / f64::from(data.sample_rate);
        assert!(seconds > 0.5, "{}: only {seconds:.2} s of sound", f.display());
        let peak = data.frames.iter().map(|f| f.left.abs().max(f.right.abs())).fold(0.0f32, f32::max);
        assert!(peak > 0.01, "{}: silent (peak {peak})", f.display());
    }
}

#[test]
fn a_broken_narration_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let bad = dir.path().join("broken.wav");
    std::fs::write(&bad, b"RIFF\x24\0\0\0WAVEfmt garbage").expect("write");
    let e = decode(&bad).expect_err("a broken WAV must not decode");
    assert!(e.contains("broken.wav"), "{e}");
    let mut narrator = Narrator::new(1.0, true);
    let e = narrator.play(&bad).expect_err("play reports the broken file");
    assert!(e.contains("broken.wav"), "{e}");
    assert!(narrator.current.is_none());
    narrator.play(&narrations()[0]).expect("a good narration plays after a broken one");
    assert!(narrator.current.is_some());
}

/// An ALSA configuration whose default device is `device` (written as `~/.asoundrc` of a
/// temporary home): the `kiosk` command run with it opens that device through kira's backend.
fn alsa_home(device: &str) -> tempfile::TempDir {
    let home = tempfile::tempdir().expect("temp dir");
    std::fs::write(home.path().join(".asoundrc"), device).expect("write .asoundrc");
    home
}

fn kiosk_with_alsa(home: &std::path::Path, args: &[&std::ffi::OsStr]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .args(args)
        .env("HOME", home)
        .env("ISOKIOSK_CACHE", crate::common::cache())
        .env_remove("XDG_CONFIG_HOME")
        .env_remove("ALSA_CONFIG_PATH")
        .output()
        .expect("run kiosk")
}

/// Narration reaches a real audio device: ALSA's default device is a `file` plugin (in front of
/// ALSA's `null` device, 16-bit stereo at 48 kHz through `plug`), so what kira's backend plays is
/// written to a file. `kiosk sound-check` must play the narration to its end, and the file must
/// hold it: at least as long as the narration and as loud as its decoded samples.
#[test]
fn sound_check_plays_a_narration_through_an_alsa_device() {
    let narration = narrations().into_iter().next().expect("a narration");
    let decoded = decode(&narration).expect("decodes");
    let seconds = decoded.frames.len() as f64 / f64::from(decoded.sample_rate);
    let rms_in = (decoded.frames.iter().map(|f| f64::from(f.left).powi(2)).sum::<f64>()
        / decoded.frames.len() as f64)
        .sqrt();
    let dir = tempfile::tempdir().expect("temp dir");
    let raw = dir.path().join("played.raw");
    let home = alsa_home(&format!(
        "pcm.!default {{\n  type plug\n  slave {{ pcm \"played\"; format S16_LE; rate 48000; channels 2 }}\n}}\n\
         pcm.played {{\n  type file\n  slave.pcm \"null\"\n  file \"{}\"\n  format \"raw\"\n}}\n",
        raw.display()
    ));
    let out = kiosk_with_alsa(home.path(), &["sound-check".as_ref(), narration.as_os_str()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "sound-check failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("1 narration(s) played"), "{stdout}");
    let bytes = std::fs::read(&raw).expect("ALSA's file device wrote what was played");
    let left: Vec<f64> =
        bytes.chunks_exact(4).map(|c| f64::from(i16::from_le_bytes([c[0], c[1]])) / 32768.0).collect();
    let played = left.len() as f64 / 48_000.0;
    assert!(played >= 0.95 * seconds, "{played:.2} s reached the device, the narration is {seconds:.2} s");
    // The sound itself: from its first to its last audible sample it spans the narration, and it is
    // as loud (RMS over that span) as the decoded file, within the volume's tween and resampling.
    let audible: Vec<usize> = (0..left.len()).filter(|&i| left[i].abs() > 0.01).collect();
    let (first, last) = (audible.first().copied().unwrap_or(0), audible.last().copied().unwrap_or(0));
    let span = (last - first) as f64 / 48_000.0;
    assert!(span >= 0.8 * seconds && span <= 1.05 * seconds, "audible for {span:.2} s of {seconds:.2} s");
    let rms_out = (left[first..=last].iter().map(|s| s * s).sum::<f64>() / (last - first + 1) as f64).sqrt();
    assert!(
        rms_out > 0.5 * rms_in && rms_out < 2.0 * rms_in,
        "RMS {rms_out:.4} played against {rms_in:.4} decoded"
    );
}

/// Without a device (ALSA's default names a card that does not exist), `sound-check` fails and
/// says so instead of pretending.
#[test]
fn sound_check_without_a_device_says_the_kiosk_would_be_silent() {
    let home = alsa_home("pcm.!default { type hw; card 97 }\nctl.!default { type hw; card 97 }\n");
    let narration = narrations().into_iter().next().expect("a narration");
    let out = kiosk_with_alsa(home.path(), &["sound-check".as_ref(), narration.as_os_str()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "sound-check must fail without a device");
    assert!(stderr.contains("no audio device"), "{stderr}");
    // The log's warning, written to a pipe, carries no terminal colour codes.
    assert!(stderr.contains("WARN") && !stderr.contains('\x1b'), "{stderr:?}");
}
