//! `kiosk check`: an exhibit checked as the kiosk would load it, each problem named.

use crate::common;
use std::path::Path;
use std::process::Command;

fn check(args: &[&Path], full: bool) -> (bool, String) {
    check_with_cache(&common::cache(), args, full)
}

/// `kiosk check` with its cache in `cache`: whether it passed, and its output (stdout, then the
/// log).
fn check_with_cache(cache: &Path, args: &[&Path], full: bool) -> (bool, String) {
    let mut c = Command::new(env!("CARGO_BIN_EXE_kiosk"));
    c.env("ISOKIOSK_CACHE", cache).env("RUST_BACKTRACE", "0").env_remove("RUST_LOG").arg("check");
    if full {
        c.arg("--full");
    }
    let o = c.args(args).output().expect("run kiosk");
    (
        o.status.success(),
        format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr)),
    )
}

#[test]
fn kiosk_check_lists_what_the_kiosk_would_leave_out_naming_file_and_node() {
    let content = Path::new(env!("CARGO_MANIFEST_DIR")).join("content");
    let dir = tempfile::tempdir().expect("temp dir");
    let good = dir.path().join("demosthenes");
    common::copy_dir(&content.join("demosthenes"), &good);
    let (ok, out) = check(&[&good], false);
    assert!(ok, "{out}");
    for line in [
        "model demosthenes-low-res.obj: 9571 samples",
        "story: 9 nodes, 9 edges, languages en, it",
        "36 image(s) and 18 narration(s) open",
    ] {
        assert!(out.contains(line), "{line}: {out}");
    }
    assert!(!out.contains("error") && !out.contains("warning"), "{out}");

    // A narration that does not decode, a truncated overlay, a node whose view is broken (and
    // the edges to it), a misspelt key in exhibit.toml: each named with its file and node; the
    // kiosk would leave them out (the key: ignored), so the check fails.
    let broken = dir.path().join("broken");
    common::copy_dir(&content.join("demosthenes"), &broken);
    std::fs::write(broken.join("audio/brow-it.wav"), b"RIFF not really a wave").expect("write");
    let graph = std::fs::read_to_string(broken.join("graph.xml")).expect("graph");
    let graph = graph.replacen(r#"<view eye="0.13 1.55 2.9""#, r#"<view eye="0.13 1.55""#, 1);
    // A misspelt tag: the title it holds would be lost without a word.
    let graph = graph.replacen("<title", "<titel", 1).replacen("</title>", "</titel>", 1);
    std::fs::write(broken.join("graph.xml"), graph).expect("write");
    std::fs::write(broken.join("exhibit.toml"), "frnt = \"-z\"\n").expect("write");
    let overlay = broken.join("overlays/intro-en.png");
    let png = std::fs::read(&overlay).expect("overlay");
    std::fs::write(&overlay, &png[..png.len() / 2]).expect("write");
    let (ok, out) = check(&[&good, &broken], false);
    assert!(!ok, "{out}");
    let g = broken.join("graph.xml").display().to_string();
    for line in [
        format!("error: {g}: node 'face': view eye/target/up must be three finite numbers each; dropped"),
        format!("error: {g}: node 'face': edge intro → face names a node dropped above; dropped"),
        format!(
            "error: {g}: node 'brow': narration audio/brow-it.wav: not a sound the kiosk can play (WAV with \
             PCM, Ogg Vorbis, MP3 or FLAC)"
        ),
        format!("error: {g}: node 'intro': line "),
        "unknown element <titel> in <node>".to_string(),
        format!("error: {g}: node 'intro': image overlays/intro-en.png: "),
        format!("error: {}: unknown key `frnt`", broken.join("exhibit.toml").display()),
        "1 of 2 exhibit(s) have errors".to_string(),
    ] {
        assert!(out.contains(&line), "{line}\n{out}");
    }
    // The model's extent, in the coordinates of the views a curator writes.
    let model = out.lines().find(|l| l.contains("model demosthenes-low-res.obj")).expect("model line");
    let extent: Vec<f64> = model
        .split_once("levels; ")
        .expect("extent")
        .1
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter_map(|w| w.parse().ok())
        .collect();
    assert!(extent.len() == 6 && extent.chunks(2).all(|r| r[0] < r[1]), "{model}");

    // A mandatory edge back to the first node: a cycle, and the nodes behind it are never shown.
    let cycle = dir.path().join("cycle");
    common::copy_dir(&content.join("demosthenes"), &cycle);
    let graph = std::fs::read_to_string(cycle.join("graph.xml")).expect("graph");
    let graph =
        graph.replacen("</infograph>", "  <edge from=\"face\" to=\"intro\" weight=\"1\"/>\n</infograph>", 1);
    std::fs::write(cycle.join("graph.xml"), graph).expect("write");
    let (ok, out) = check(&[&cycle], false);
    let g = cycle.join("graph.xml").display().to_string();
    assert!(!ok && out.contains(&format!("error: {g}: node 'intro': can never be shown")), "{out}");

    // The folder of exhibits given for one, or a directory that is not there: said so.
    let (ok, out) = check(&[dir.path()], false);
    assert!(!ok && out.contains("holds exhibits: ") && out.contains("demosthenes"), "{out}");
    assert!(out.contains("the kiosk leaves this exhibit out"), "{out}");
    let (ok, out) = check(&[&dir.path().join("missing")], false);
    assert!(!ok && out.contains("missing: no such directory") && !out.contains("pose:"), "{out}");

    // --full reads every node: a store with a flipped byte fails, naming the node.
    let stored = dir.path().join("stored");
    std::fs::create_dir_all(&stored).expect("mkdir");
    let store = stored.join("bust.kstore");
    let o = Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .args(["import", "--quiet"])
        .arg(content.join("demosthenes/demosthenes-low-res.obj"))
        .arg("-o")
        .arg(&store)
        .output()
        .expect("import");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (ok, out) = check(&[&stored], true);
    assert!(ok && out.contains("every node's checksum matches (3 nodes)"), "{out}");
    let opened = kiosk_content::open_store(&store).expect("store");
    let at = opened.node(opened.root()).points_offset as usize + 4;
    drop(opened);
    let mut bytes = std::fs::read(&store).expect("read");
    bytes[at] ^= 0x40;
    std::fs::write(&store, bytes).expect("write");
    let (ok, out) = check(&[&stored], false);
    assert!(ok, "without --full only the index is read: {out}");
    let (ok, out) = check(&[&stored], true);
    let root = kiosk_content::open_store(&store).expect("store").root();
    assert!(
        !ok && out.contains(&format!(
            "error: model bust.kstore: store corrupted: node {root} data checksum mismatch"
        )),
        "{out}"
    );
}

#[test]
fn importing_into_the_cache_is_logged_with_its_progress() {
    // A kiosk fills its cache at start, its windows saying it prepares; a large scan takes
    // minutes, so the log says what it is doing, and `kiosk check` (which fills the same cache)
    // shows it too.
    let content = Path::new(env!("CARGO_MANIFEST_DIR")).join("content");
    let dir = tempfile::tempdir().expect("temp dir");
    let exhibit = dir.path().join("bust");
    common::copy_dir(&content.join("demosthenes"), &exhibit);
    let cache = dir.path().join("cache");
    let run = || {
        let (ok, out) = check_with_cache(&cache, &[&exhibit], false);
        assert!(ok, "{out}");
        out
    };
    let first = run();
    let scan = exhibit.join("demosthenes-low-res.obj").canonicalize().expect("scan");
    let label = format!("exhibit {}: importing demosthenes-low-res.obj", exhibit.display());
    for line in [
        format!(
            "exhibit {}: importing {} into the cache {}",
            exhibit.display(),
            scan.display(),
            cache.display()
        ),
        format!("{label}: reading\n"),
        format!("{label}: reading 9571 of 9571 samples (100 %)"),
        format!("{label}: building 0 of 9571 samples (0 %)"),
        format!("{label}: building 9571 of 9571 samples (100 %)"),
        format!("{label}: done, 9571 samples read → 9571 distinct"),
    ] {
        assert!(first.contains(&line), "{line}: {first}");
    }
    // The second time the store is in the cache: nothing to import, nothing said of it.
    let second = run();
    assert!(!second.contains("importing"), "{second}");
}

#[test]
fn the_readers_warnings_are_listed_at_every_check_not_only_the_first_import() {
    // A scan the reader takes with a warning (an unknown header keyword): the kiosk shows it,
    // and `kiosk check` lists the warning, also once the store is cached (the warning is noted
    // beside it).
    let dir = tempfile::tempdir().expect("temp dir");
    let exhibit = dir.path().join("grid");
    std::fs::create_dir(&exhibit).expect("exhibit dir");
    let mut ply = String::from("ply\nformat ascii 1.0\nelement vertex 400\nproperty float x\n");
    ply += "property float y\nproperty float z\nscanner_angle 12\nend_header\n";
    for i in 0..400 {
        ply += &format!("{} {} {}\n", (i % 20) as f32 * 0.01, (i / 20) as f32 * 0.01, 0.002 * (i % 3) as f32);
    }
    std::fs::write(exhibit.join("grid.ply"), ply).expect("write");
    let cache = dir.path().join("cache");
    let warning = "warning: model grid.ply: header line 7: unknown keyword 'scanner_angle' ignored";
    for run in ["first", "cached"] {
        let (ok, out) = check_with_cache(&cache, &[&exhibit], false);
        assert!(ok, "{run}: a warning is not an error: {out}");
        assert!(out.contains("model grid.ply: 400 samples"), "{run}: {out}");
        assert_eq!(out.matches(warning).count(), 1, "{run}: {out}");
        assert_eq!(out.contains("importing"), run == "first", "{run}: {out}");
    }
    // Its note goes with the store when the scan changes.
    let notes = |ending: &str| {
        std::fs::read_dir(&cache)
            .expect("cache")
            .flatten()
            .filter(|e| e.path().extension().is_some_and(|x| x == ending))
            .count()
    };
    assert_eq!(notes("warnings"), 1);
    let text = std::fs::read_to_string(exhibit.join("grid.ply")).expect("read");
    std::fs::write(exhibit.join("grid.ply"), text.replace("scanner_angle 12\n", "")).expect("write");
    let (ok, out) = check_with_cache(&cache, &[&exhibit], false);
    assert!(ok && !out.contains("warning"), "{out}");
    assert_eq!((notes("kstore"), notes("warnings")), (1, 0), "{out}");

    // A store beside its scan is shown instead of it: once the scan is edited after the store
    // was made, the check says the kiosk shows the older import.
    let o = Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .args(["import", "--quiet"])
        .arg(exhibit.join("grid.ply"))
        .arg("-o")
        .arg(exhibit.join("grid.kstore"))
        .output()
        .expect("import");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (ok, out) = check_with_cache(&cache, &[&exhibit], false);
    assert!(ok && out.contains("model grid.kstore: 400 samples") && !out.contains("warning"), "{out}");
    let text = std::fs::read_to_string(exhibit.join("grid.ply")).expect("read");
    std::fs::write(exhibit.join("grid.ply"), text).expect("write");
    let (ok, out) = check_with_cache(&cache, &[&exhibit], false);
    let stale =
        "warning: model grid.kstore: older than the scan grid.ply beside it, which the kiosk does not show";
    assert!(ok && out.contains(stale), "{out}");
}

#[test]
fn a_check_that_finds_the_scan_being_imported_says_it_waits_and_imports_nothing() {
    // Two programs sharing a cache open the same new scan (a kiosk starting while the
    // technician's `kiosk check` imports it): one imports, the other says it waits, then uses
    // that store.
    let dir = tempfile::tempdir().expect("temp dir");
    let exhibit = dir.path().join("relief");
    std::fs::create_dir(&exhibit).expect("exhibit dir");
    common::write_relief_ply(&exhibit.join("relief.ply"), 1400);
    let cache = dir.path().join("cache");
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(|| check_with_cache(&cache, &[&exhibit], false));
        let b = s.spawn(|| check_with_cache(&cache, &[&exhibit], false));
        (a.join().expect("first"), b.join().expect("second"))
    });
    for (ok, out) in [&a, &b] {
        assert!(*ok && out.contains("model relief.ply: 1960000 samples"), "{out}");
    }
    let imported = |out: &str| out.contains("importing relief.ply: done");
    let waited = |out: &str| out.contains("another import is writing it; waiting");
    assert!(imported(&a.1) != imported(&b.1), "one imports:\n{}\n---\n{}", a.1, b.1);
    let (importer, waiter) = if imported(&a.1) { (&a.1, &b.1) } else { (&b.1, &a.1) };
    assert!(waited(waiter) && !waited(importer), "the other waits:\n{waiter}");
}
