//! Imports that share an output, are interrupted, or point at the wrong file: the output is
//! never corrupted, nothing is left behind, and a wrong command is refused before it writes.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn kiosk() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_kiosk"));
    c.env("RUST_BACKTRACE", "0");
    c
}

fn dragon() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scans/stanford-dragon/dragon_vrip_res2.ply.gz")
}

/// The names in a directory, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("read dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn two_imports_to_one_output_take_turns_and_leave_one_good_store() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("dragon.kstore");
    let spawn = || {
        kiosk()
            .args(["import", "--quiet"])
            .arg(dragon())
            .arg("-o")
            .arg(&out)
            .stderr(Stdio::piped())
            .spawn()
            .expect("run kiosk")
    };
    let (a, b) = (spawn(), spawn());
    for child in [a, b] {
        let o = child.wait_with_output().expect("wait");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let v = kiosk().arg("verify").arg(&out).output().expect("verify");
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stderr));
    assert_eq!(names(dir.path()), [".dragon.kstore.lock", "dragon.kstore"]);
}

#[cfg(unix)]
#[test]
fn an_import_stopped_by_sigterm_leaves_nothing_and_the_next_one_cleans_up() {
    use std::io::Write;
    let dir = tempfile::tempdir().expect("temp dir");
    // The scan is a FIFO: the import blocks reading it, in the middle of its work, until the
    // test has sent the signal.
    let fifo = dir.path().join("slow.ply");
    assert!(Command::new("mkfifo").arg(&fifo).status().expect("mkfifo").success());
    let out = dir.path().join("slow.kstore");
    let child = kiosk().args(["import", "--quiet"]).arg(&fifo).arg("-o").arg(&out).spawn().expect("run");
    let mut w = std::fs::OpenOptions::new().write(true).open(&fifo).expect("open the FIFO");
    let n = 200_000;
    write!(w, "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
        .expect("header");
    for i in 0..n / 2 {
        let t = f64::from(i) * 1e-3;
        writeln!(w, "{} {} {}", t.cos(), t.sin(), t * 1e-2).expect("row");
    }
    w.flush().expect("flush");
    let work = dir.path().join(format!(".slow.kstore.import-{}", child.id()));
    for _ in 0..500 {
        if work.exists() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert!(work.exists(), "the import works in {}", work.display());
    assert!(Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().expect("kill").success());
    let status = child.wait_with_output().expect("wait").status;
    drop(w);
    assert!(!status.success());
    assert_eq!(names(dir.path()), [".slow.kstore.lock", "slow.ply"], "nothing left behind");
    // A killed import (SIGKILL cannot be caught) leaves its directory; the next import to the
    // same output removes it.
    let stale = dir.path().join(".slow.kstore.import-4000000");
    std::fs::create_dir(&stale).expect("stale dir");
    std::fs::write(stale.join("cell"), vec![0u8; 1 << 20]).expect("stale cell");
    std::fs::remove_file(&fifo).expect("remove FIFO");
    let o = kiosk().args(["import", "--quiet"]).arg(dragon()).arg("-o").arg(&out).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(names(dir.path()), [".slow.kstore.lock", "slow.kstore"]);
}

#[test]
fn an_import_onto_its_input_or_of_a_store_is_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scan = dir.path().join("dragon.ply.gz");
    std::fs::copy(dragon(), &scan).expect("copy");
    let before = std::fs::read(&scan).expect("read");
    let o = kiosk().args(["import", "--quiet"]).arg(&scan).arg("-o").arg(&scan).output().expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("the output is the input"), "{err}");
    assert_eq!(std::fs::read(&scan).expect("read"), before, "the scan is untouched");
    let store = dir.path().join("dragon.kstore");
    let o = kiosk().args(["import", "--quiet"]).arg(&scan).arg("-o").arg(&store).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = kiosk()
        .args(["import", "--quiet"])
        .arg(&store)
        .arg("-o")
        .arg(dir.path().join("again.kstore"))
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("is already a store"), "{err}");
}

#[test]
fn an_import_onto_a_file_that_is_not_a_store_is_refused_and_leaves_it_untouched() {
    let dir = tempfile::tempdir().expect("temp dir");
    let notes = dir.path().join("notes.txt");
    std::fs::write(&notes, "the curator's notes\n").expect("write");
    let o = kiosk().args(["import", "--quiet"]).arg(dragon()).arg("-o").arg(&notes).output().expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("notes.txt: exists and is not an IsoKiosk store"), "{err}");
    assert_eq!(std::fs::read_to_string(&notes).expect("read"), "the curator's notes\n");
    // Refused before anything is written: no lock, no work directory.
    assert_eq!(names(dir.path()), ["notes.txt"]);
    // An empty file (made by `mktemp` or `touch` for the store) has nothing to lose: replaced.
    let empty = dir.path().join("empty.kstore");
    std::fs::write(&empty, b"").expect("write");
    let o = kiosk().args(["import", "--quiet"]).arg(dragon()).arg("-o").arg(&empty).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A directory is refused too; a store is replaced (see the first test).
    let o =
        kiosk().args(["import", "--quiet"]).arg(dragon()).arg("-o").arg(dir.path()).output().expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("exists and is not a file"), "{err}");
}

#[cfg(target_os = "linux")]
#[test]
fn an_output_directory_the_import_cannot_write_in_is_named() {
    // Nothing can be made in /proc, not even by root (for whom a read-only directory is writable).
    let o = kiosk().args(["import", "--quiet"]).arg(dragon()).args(["-o", "/proc/isokiosk.kstore"]).output();
    let err = String::from_utf8_lossy(&o.expect("run").stderr).into_owned();
    assert!(err.contains("cannot write in /proc, the output's directory"), "{err}");
}

#[test]
fn a_scan_with_a_non_finite_coordinate_names_the_row_and_the_flag_that_skips_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scan = dir.path().join("nan.ply");
    std::fs::write(
        &scan,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         end_header\n0 0 0\n1 nan 0\n0 1 0\n",
    )
    .expect("write");
    let out = dir.path().join("nan.kstore");
    let o = kiosk().args(["import", "--quiet"]).arg(&scan).arg("-o").arg(&out).output().expect("run kiosk");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("nan.ply") && err.contains("row 2 (line 9): non-finite coordinate"), "{err}");
    assert!(err.contains("--drop-invalid skips samples with non-finite coordinates"), "{err}");
    // With the flag, the other two samples make a store.
    let o = kiosk()
        .args(["import", "--quiet", "--drop-invalid"])
        .arg(&scan)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("run kiosk");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // When every row is dropped, the error says so, not only that the model is empty.
    std::fs::write(
        &scan,
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
         end_header\nnan 0 0\n0 inf 0\n",
    )
    .expect("write");
    let o = kiosk().args(["import", "--quiet", "--drop-invalid"]).arg(&scan).arg("-o").arg(&out).output();
    let err = String::from_utf8_lossy(&o.as_ref().expect("run kiosk").stderr).into_owned();
    assert!(
        err.contains("2 vertex row(s) with non-finite coordinates dropped") && err.contains("no samples"),
        "{err}"
    );
}

#[test]
fn import_errors_say_each_cause_once_and_name_the_file_and_the_place() {
    let dir = tempfile::tempdir().expect("temp dir");
    let formats = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats");
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).expect("write");
        p
    };
    let laz = std::fs::read(formats.join("simple.laz")).expect("laz");
    let mut huge = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
        property float z\nend_header\n"
        .to_vec();
    huge.extend_from_slice(b"-1e30 0 0\n1e30 0 0\n0 1 0\n");
    let cases = [
        (dir.path().join("missing.ply"), "No such file or directory"),
        (
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/glb-header-length-1.glb"),
            "GLB header: length 2 is shorter than the 12-byte header",
        ),
        (write("cut.laz", &laz[..laz.len() / 2]), "LAS: the file ends before the data its header announces"),
        (formats.join("empty.e57"), "E57: the file holds no point cloud"),
        (formats.join("InvalidCVHeader.e57"), "E57: scan 1: Invalid E57 content"),
        (
            write("ahead.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
            "line 4: a face refers to vertex 9 but the file has 3 vertices (counted from 1)",
        ),
        (
            write("zero.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n"),
            "line 4: vertex index 0: OBJ counts vertices from 1 (or back from -1), and 3 'v' lines come before it",
        ),
        (
            write("huge.ply", &huge),
            "the samples reach from (-1e30, 0, 0) to (1e30, 1, 0); a store holds a model",
        ),
    ];
    for (scan, expected) in &cases {
        let out = dir.path().join("out.kstore");
        let o =
            kiosk().args(["import", "--quiet"]).arg(scan).arg("-o").arg(&out).output().expect("run kiosk");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{}: {err}", scan.display());
        assert!(err.contains(&scan.display().to_string()), "the error names the file: {err}");
        assert_eq!(err.matches(expected).count(), 1, "{}: the cause once: {err}", scan.display());
        assert!(!out.exists(), "{}: no store is written", scan.display());
    }
    // A face may name a vertex read after it.
    let ahead = write("forward.obj", b"v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n");
    let o =
        kiosk().args(["import", "--quiet"]).arg(&ahead).arg("-o").arg(dir.path().join("f.kstore")).output();
    let o = o.expect("run kiosk");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // An impossible setting is refused as a usage error, in the option's own name.
    let o = kiosk()
        .args(["import", "--quiet", "--node-points", "0"])
        .arg(&ahead)
        .arg("-o")
        .arg(dir.path().join("n.kstore"))
        .output()
        .expect("run kiosk");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--node-points") && err.contains("16..=1000000"), "{err}");
}

#[test]
fn a_store_made_from_a_survey_scan_says_its_exhibit_must_stand_it_on_z() {
    // The kiosk stands a LAS, LAZ or E57 scan on Z; a store made from one keeps no format, so
    // the import says what its exhibit needs. A PLY store needs nothing.
    let dir = tempfile::tempdir().expect("temp dir");
    let formats = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats");
    let run = |scan: &Path, name: &str| {
        let out = dir.path().join(name);
        let o = kiosk().arg("import").arg("--quiet").arg(scan).arg("-o").arg(&out).output().expect("kiosk");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let said = run(&formats.join("simple.laz"), "simple.kstore");
    let note = format!(
        "note: the kiosk stands a LAZ scan on Z, but a store does not keep its scan's format: an exhibit showing {} \
         needs up = \"z\" in its exhibit.toml",
        dir.path().join("simple.kstore").display()
    );
    assert!(said.contains(&note), "{said}");
    assert!(!run(&dragon(), "dragon.kstore").contains("note:"));
}
