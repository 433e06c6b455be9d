//! Narration decodes: every narration file that an exhibit's graph names is decoded by the same
//! path the kiosk and the authoring tool play it through (kira with symphonia's codecs).

use kiosk::windows::audio::{Narrator, decode};

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
        let (graph, problems) = kiosk::exhibit::open_graph(&dir).expect("read graph.xml").expect("a graph");
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
