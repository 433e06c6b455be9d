//! Builds the demo exhibit's story (`content/demosthenes/graph.xml` with thumbnails, overlays,
//! ROI masks and narration) through the authoring API — the way a curator would, scripted.
//!
//! `cargo run -p kiosk-author --example demo_content` (needs a GPU adapter — lavapipe — for the
//! thumbnails and `espeak-ng` for the narration; the files it writes are committed data).

use anyhow::Context;
use glam::DVec3;
use kiosk_author::Project;
use kiosk_core::camera::{Camera, orthonormal_up};
use std::path::Path;

/// (id, eye, target, fov°, importance, en title, en text, it title, it text)
type Spec =
    (&'static str, [f64; 3], [f64; 3], f64, f64, &'static str, &'static str, &'static str, &'static str);

const NODES: &[Spec] = &[
    (
        "intro",
        [0.13, 0.9, 5.0],
        [0.13, 0.85, 0.19],
        35.0,
        1.0,
        "Demosthenes",
        "A Roman marble copy of a Greek portrait of Demosthenes, the Athenian orator (384–322 BC), now in the Louvre. This model comes from photographs taken in the museum.",
        "Demostene",
        "Copia romana in marmo di un ritratto greco di Demostene, l'oratore ateniese (384–322 a.C.), oggi al Louvre. Il modello nasce da fotografie scattate nel museo.",
    ),
    (
        "face",
        [0.13, 1.55, 2.9],
        [0.13, 1.55, 0.6],
        32.0,
        0.9,
        "A tense face",
        "The sculptor shows an orator under strain: a furrowed brow, hollow cheeks and a tight mouth, far from idealised heroic portraits.",
        "Un volto teso",
        "Lo scultore mostra un oratore sotto sforzo: fronte corrugata, guance incavate e bocca serrata, lontano dai ritratti eroici idealizzati.",
    ),
    (
        "brow",
        [0.13, 1.6, 1.7],
        [0.13, 1.55, 0.7],
        25.0,
        0.6,
        "The furrowed brow",
        "Deep lines across the forehead and the knitted eyebrows give the portrait its concentrated, worried expression.",
        "La fronte corrugata",
        "Le rughe profonde sulla fronte e le sopracciglia aggrottate danno al ritratto la sua espressione concentrata e preoccupata.",
    ),
    (
        "mouth",
        [0.13, 1.0, 2.0],
        [0.13, 1.02, 0.75],
        25.0,
        0.6,
        "The closed lips",
        "Ancient writers said Demosthenes trained against a speech defect by talking with pebbles in his mouth. The lips here are pressed shut.",
        "Le labbra chiuse",
        "Gli autori antichi raccontano che Demostene si esercitava contro un difetto di pronuncia parlando con dei sassolini in bocca. Qui le labbra sono serrate.",
    ),
    (
        "hair",
        [-0.6, 2.4, 1.8],
        [0.13, 1.9, 0.3],
        30.0,
        0.5,
        "Short curls",
        "Short, irregular locks frame the head. The drill holes between the curls catch the shadow.",
        "Riccioli corti",
        "Ciocche corte e irregolari incorniciano la testa. I fori di trapano tra i riccioli raccolgono l'ombra.",
    ),
    (
        "profile-left",
        [-2.3, 1.5, 0.4],
        [0.13, 1.5, 0.3],
        30.0,
        0.7,
        "Profile",
        "From the side the receding hairline and the slightly bent neck become visible.",
        "Profilo",
        "Di lato si vedono la stempiatura e il collo leggermente piegato.",
    ),
    (
        "profile-right",
        [2.6, 1.5, 0.4],
        [0.13, 1.5, 0.3],
        30.0,
        0.4,
        "The other side",
        "The right side is less finished: copies were often made to be seen from the front.",
        "L'altro lato",
        "Il lato destro è meno rifinito: le copie erano spesso fatte per essere viste di fronte.",
    ),
    (
        "chest",
        [0.13, 0.3, 2.8],
        [0.13, 0.3, 0.5],
        30.0,
        0.5,
        "The bust",
        "The portrait was cut as a bust from a full statue type, which showed the orator standing with clasped hands.",
        "Il busto",
        "Il ritratto è stato tagliato come busto da un tipo statuario completo, che mostrava l'oratore in piedi con le mani giunte.",
    ),
    (
        "back",
        [0.13, 1.6, -2.6],
        [0.13, 1.5, -0.1],
        30.0,
        0.3,
        "The back of the head",
        "Seen from behind, the carving is summary: this side faced a wall.",
        "La nuca",
        "Vista da dietro, la lavorazione è sommaria: questo lato era rivolto verso una parete.",
    ),
];

/// (from, to, weight): mandatory introductions, strong and weak links.
const EDGES: &[(&str, &str, f64)] = &[
    ("intro", "face", 1.0),
    ("intro", "profile-left", 1.0),
    ("face", "brow", 0.8),
    ("face", "mouth", 0.8),
    ("profile-left", "profile-right", 0.8),
    ("profile-left", "hair", 0.2),
    ("hair", "back", 0.2),
    ("intro", "chest", 0.2),
    ("brow", "hair", 0.2),
];

fn main() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../content/demosthenes");
    let (mut p, _) = Project::open(&dir)?;
    for id in p.graph.nodes.iter().map(|n| n.id.clone()).collect::<Vec<_>>() {
        p.remove_node(&id)?;
    }
    let (gpu, mut renderer) = kiosk::snapshot::offscreen()?;
    let tmp = tempfile::tempdir()?;
    for &(id, eye, target, fov, importance, t_en, x_en, t_it, x_it) in NODES {
        let mut cam = Camera {
            eye: DVec3::from(eye),
            target: DVec3::from(target),
            up: DVec3::Y,
            fov_y: fov.to_radians(),
        };
        cam.up = orthonormal_up(cam.forward(), DVec3::Y, DVec3::Z);
        p.capture(cam, Some(id), Some((&gpu, &mut renderer)))?;
        p.set_text(id, "en", t_en, x_en)?;
        p.set_text(id, "it", t_it, x_it)?;
        p.set_importance(id, importance)?;
        // The region of interest: the middle of the view.
        let mask = image::GrayImage::from_fn(320, 180, |x, y| {
            let (dx, dy) = ((f64::from(x) - 160.0) / 110.0, (f64::from(y) - 90.0) / 70.0);
            image::Luma([if dx * dx + dy * dy <= 1.0 { 255 } else { 0 }])
        });
        p.paint_roi(id, &mask)?;
        // An overlay drawing with alpha: a translucent ring around the region and a frame.
        let overlay = image::RgbaImage::from_fn(1280, 720, |x, y| {
            let (dx, dy) = ((f64::from(x) - 640.0) / 440.0, (f64::from(y) - 360.0) / 280.0);
            let r = (dx * dx + dy * dy).sqrt();
            if (r - 1.0).abs() < 0.012 {
                image::Rgba([255, 196, 64, 220])
            } else if !(24..1256).contains(&x) || !(24..696).contains(&y) {
                image::Rgba([255, 196, 64, 60])
            } else {
                image::Rgba([0, 0, 0, 0])
            }
        });
        let src = tmp.path().join(format!("{id}.png"));
        overlay.save(&src)?;
        for lang in ["en", "it"] {
            if let Some(w) = p.attach_overlay(id, lang, &src)? {
                anyhow::bail!("{id}: {w}");
            }
        }
        narrate(&mut p, id, "en", x_en)?;
        narrate(&mut p, id, "it", x_it)?;
    }
    for &(from, to, w) in EDGES {
        p.set_dependency(from, to, w)?;
    }
    let problems = p.validate();
    anyhow::ensure!(problems.is_empty(), "{problems:?}");
    p.save()?;
    println!(
        "{}: {} nodes, {} edges",
        dir.join("graph.xml").display(),
        p.graph.nodes.len(),
        p.graph.edges.len()
    );
    Ok(())
}

/// Speaks `text` with espeak-ng into `audio/ID-LANG.wav` and attaches it.
fn narrate(p: &mut Project, id: &str, lang: &str, text: &str) -> anyhow::Result<()> {
    let rel = format!("audio/{id}-{lang}.wav");
    let path = p.dir().join(&rel);
    std::fs::create_dir_all(path.parent().unwrap_or(p.dir()))?;
    let status = std::process::Command::new("espeak-ng")
        .args(["-v", lang, "-s", "150", "-w"])
        .arg(&path)
        .arg(text)
        .status()
        .context("espeak-ng is needed to generate the narration (apt-get install espeak-ng)")?;
    anyhow::ensure!(status.success(), "espeak-ng failed for {id} ({lang})");
    p.set_narration(id, lang, &rel)
}
