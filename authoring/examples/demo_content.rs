//! Builds the demo exhibits' stories (`content/*/graph.xml` with thumbnails, overlays, ROI masks
//! and narration) through the authoring API — the way a curator would, scripted. Each exhibit is
//! data (the tables below); one function builds any of them.
//!
//! `cargo run -p kiosk-author --example demo_content [-- EXHIBIT…]` (all exhibits by default;
//! needs a GPU adapter — lavapipe — for the thumbnails and `espeak-ng` for the narration; the
//! files it writes are committed data).

use anyhow::Context;
use glam::DVec3;
use kiosk_author::Project;
use kiosk_core::camera::{Camera, orthonormal_up};
use kiosk_render::{Gpu, Renderer};
use std::path::Path;

/// (id, eye, target, fov°, importance, en title, en text, it title, it text)
type Spec =
    (&'static str, [f64; 3], [f64; 3], f64, f64, &'static str, &'static str, &'static str, &'static str);

/// (from, to, weight): `to` depends on `from` (ω: 1 mandatory, 0.8 strong, 0.2 weak).
type Edge = (&'static str, &'static str, f64);

/// One exhibit: its directory under `content/`, its scan (the model file in that directory, copied
/// there unchanged), its views and its dependencies.
struct Exhibit {
    dir: &'static str,
    scan: &'static str,
    nodes: &'static [Spec],
    edges: &'static [Edge],
}

const EXHIBITS: &[Exhibit] = &[
    Exhibit {
        dir: "demosthenes",
        scan: "demosthenes-low-res.obj",
        nodes: DEMOSTHENES,
        edges: DEMOSTHENES_EDGES,
    },
    Exhibit { dir: "nefertiti", scan: "nefertiti-lowres.obj", nodes: NEFERTITI, edges: NEFERTITI_EDGES },
];

/// The Demosthenes bust (`content/demosthenes/`): model units of about 2.7 for its height, +Y up,
/// the face toward +Z.
const DEMOSTHENES: &[Spec] = &[
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
const DEMOSTHENES_EDGES: &[Edge] = &[
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

/// The Nefertiti bust (`content/nefertiti/`): millimetres, about 494 high, +Y up (flat base at
/// y ≈ −247, crown top y ≈ 247), the face toward +Z (nose tip z ≈ 181), her left side toward +X.
const NEFERTITI: &[Spec] = &[
    (
        "intro",
        [260.0, 60.0, 930.0],
        [0.0, 10.0, 10.0],
        35.0,
        1.0,
        "Nefertiti",
        "A painted limestone and stucco bust of Queen Nefertiti, wife of the pharaoh Akhenaten, made around 1345 BC and attributed to the sculptor Thutmose. It was found in his workshop at Amarna in 1912 and is now in the Neues Museum, Berlin. This model comes from scan data released by two artists in 2016.",
        "Nefertiti",
        "Busto in calcare e stucco dipinti della regina Nefertiti, moglie del faraone Akhenaton, realizzato verso il 1345 a.C. e attribuito allo scultore Thutmose. Fu trovato nella sua bottega ad Amarna nel 1912 ed è oggi al Neues Museum di Berlino. Il modello deriva da dati di scansione diffusi da due artisti nel 2016.",
    ),
    (
        "crown",
        [650.0, 300.0, 450.0],
        [0.0, 120.0, 20.0],
        36.0,
        0.8,
        "The blue crown",
        "Nefertiti wears a tall, flat-topped cap crown, painted blue and ringed by a golden diadem band. The crown is so closely linked to her that it is often called the Nefertiti cap crown.",
        "La corona blu",
        "Nefertiti porta un'alta corona a calotta dalla sommità piatta, dipinta di blu e cinta da una fascia dorata. È così legata a lei da essere spesso chiamata la corona di Nefertiti.",
    ),
    (
        "uraeus",
        [70.0, 230.0, 430.0],
        [0.0, 160.0, 115.0],
        25.0,
        0.5,
        "The broken cobra",
        "Above the brow rose the uraeus, the rearing cobra that protected Egyptian kings and queens. Its head has broken off; the loops of its body remain on the front of the crown.",
        "Il cobra spezzato",
        "Sopra la fronte si ergeva l'ureo, il cobra che proteggeva re e regine d'Egitto. La testa è spezzata; sul davanti della corona restano le spire del suo corpo.",
    ),
    (
        "face",
        [0.0, 5.0, 620.0],
        [0.0, 5.0, 150.0],
        28.0,
        0.9,
        "A calm face",
        "Fine arched brows, high cheekbones and full lips make this one of the most famous faces of antiquity. Computed tomography has shown that under the stucco the limestone core has a slightly different face, with creases at the corners of the mouth.",
        "Un volto sereno",
        "Sopracciglia sottili e arcuate, zigomi alti e labbra piene ne fanno uno dei volti più celebri dell'antichità. La tomografia ha mostrato che sotto lo stucco il nucleo in calcare ha un volto un po' diverso, con pieghe agli angoli della bocca.",
    ),
    (
        "eyes",
        [0.0, 30.0, 400.0],
        [0.0, 28.0, 150.0],
        20.0,
        0.7,
        "The missing eye",
        "Her right eye is inlaid with quartz, its pupil painted black. The left eye, on your right, has no inlay: only the bare limestone of the socket. The excavators searched the workshop rubble for it in 1912 without success, and it may never have been made.",
        "L'occhio mancante",
        "L'occhio destro è intarsiato di quarzo, con la pupilla dipinta di nero. L'occhio sinistro, alla vostra destra, non ha l'intarsio: resta solo il calcare nudo dell'orbita. Nel 1912 gli scavatori lo cercarono invano tra le macerie della bottega, e forse non fu mai realizzato.",
    ),
    (
        "neck",
        [220.0, -110.0, 640.0],
        [0.0, -130.0, 60.0],
        32.0,
        0.5,
        "Neck and collar",
        "A long, slender neck leans forward, balancing the tall crown. Across the shoulders lies a broad collar, painted with a floral pattern.",
        "Collo e collare",
        "Un collo lungo e sottile si protende in avanti, bilanciando l'alta corona. Sulle spalle poggia un ampio collare, dipinto con un motivo floreale.",
    ),
    (
        "profile-left",
        [950.0, 0.0, 30.0],
        [0.0, 0.0, 0.0],
        33.0,
        0.7,
        "Left profile",
        "From her left side the bust shows its famous outline: the crown sweeps back while the neck and face lean forward. This is also the side of the eye without inlay.",
        "Profilo sinistro",
        "Dal suo lato sinistro il busto mostra il suo celebre profilo: la corona si slancia all'indietro mentre collo e volto si protendono in avanti. È anche il lato dell'occhio senza intarsio.",
    ),
    (
        "profile-right",
        [-950.0, 0.0, 30.0],
        [0.0, 0.0, 0.0],
        33.0,
        0.4,
        "Right profile",
        "The right side mirrors the left almost exactly. Look at the ears: their edges are chipped, some of the little damage the bust has suffered.",
        "Profilo destro",
        "Il lato destro rispecchia quasi esattamente il sinistro. Guardate le orecchie: i bordi sono scheggiati, tra i pochi danni subiti dal busto.",
    ),
    (
        "back",
        [-150.0, 330.0, -1000.0],
        [0.0, 20.0, -30.0],
        33.0,
        0.3,
        "Behind the crown",
        "From behind, the flat top of the crown tilts toward you and overhangs the nape. The bust stands on a flat base; it probably served in the workshop as a model for other portraits of the queen.",
        "Dietro la corona",
        "Da dietro, la sommità piatta della corona si inclina verso di voi e sporge sopra la nuca. Il busto poggia su una base piatta; nella bottega serviva probabilmente da modello per altri ritratti della regina.",
    ),
];

/// (from, to, weight): the introduction opens the face, the crown and the profile; details
/// follow strongly; weak links suggest a tour around the bust.
const NEFERTITI_EDGES: &[Edge] = &[
    ("intro", "face", 1.0),
    ("intro", "crown", 1.0),
    ("intro", "profile-left", 1.0),
    ("face", "eyes", 0.8),
    ("face", "neck", 0.8),
    ("crown", "uraeus", 0.8),
    ("profile-left", "profile-right", 0.8),
    ("profile-right", "back", 0.8),
    ("crown", "back", 0.2),
    ("neck", "profile-left", 0.2),
];

fn main() -> anyhow::Result<()> {
    let wanted: Vec<String> = std::env::args().skip(1).collect();
    for w in &wanted {
        anyhow::ensure!(
            EXHIBITS.iter().any(|e| e.dir == w),
            "unknown exhibit '{w}' (known: {})",
            EXHIBITS.iter().map(|e| e.dir).collect::<Vec<_>>().join(", ")
        );
    }
    let (gpu, mut renderer) = kiosk::snapshot::offscreen()?;
    for ex in EXHIBITS.iter().filter(|e| wanted.is_empty() || wanted.iter().any(|w| w == e.dir)) {
        build(ex, &gpu, &mut renderer)?;
    }
    Ok(())
}

/// Builds one exhibit's story from scratch: every node of its graph is replaced by the table's.
fn build(ex: &Exhibit, gpu: &Gpu, renderer: &mut Renderer) -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../content").join(ex.dir);
    let model = kiosk::exhibit::model_file(&dir)?;
    anyhow::ensure!(
        model.file_name().is_some_and(|n| n == ex.scan),
        "{}: the exhibit's model is {}, expected {} (copy the scan there unchanged)",
        dir.display(),
        model.display(),
        ex.scan
    );
    let (mut p, _) = Project::open(&dir)?;
    for id in p.graph.nodes.iter().map(|n| n.id.clone()).collect::<Vec<_>>() {
        p.remove_node(&id)?;
    }
    let tmp = tempfile::tempdir()?;
    for &(id, eye, target, fov, importance, t_en, x_en, t_it, x_it) in ex.nodes {
        let mut cam = Camera {
            eye: DVec3::from(eye),
            target: DVec3::from(target),
            up: DVec3::Y,
            fov_y: fov.to_radians(),
        };
        cam.up = orthonormal_up(cam.forward(), DVec3::Y, DVec3::Z);
        p.capture(cam, Some(id), Some((gpu, &mut *renderer)))?;
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
    for &(from, to, w) in ex.edges {
        p.set_dependency(from, to, w)?;
    }
    let problems = p.validate();
    anyhow::ensure!(problems.is_empty(), "{}: {problems:?}", ex.dir);
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
