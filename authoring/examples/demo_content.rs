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
use kiosk_render::{Gpu, RenderSettings, Renderer};
use std::path::Path;

/// (id, eye, target, fov°, importance, en title, en text, it title, it text)
type Spec =
    (&'static str, [f64; 3], [f64; 3], f64, f64, &'static str, &'static str, &'static str, &'static str);

/// (from, to, weight): `to` depends on `from` (ω: 1 mandatory, 0.8 strong, 0.2 weak).
type Edge = (&'static str, &'static str, f64);

/// A labelled point of a view's overlay: (node id, model point, label offset in pixels of the
/// 1280×720 overlay, en label, it label).
type Label = (&'static str, [f64; 3], [f64; 2], &'static str, &'static str);

/// One exhibit: its directory under `content/`, its scan (the model file in that directory, copied
/// there unchanged), its views, its dependencies and the labels of its overlays (an exhibit
/// without labels gets a drawn ring around each view's middle).
struct Exhibit {
    dir: &'static str,
    scan: &'static str,
    nodes: &'static [Spec],
    edges: &'static [Edge],
    labels: &'static [Label],
}

const EXHIBITS: &[Exhibit] = &[
    Exhibit {
        dir: "demosthenes",
        scan: "demosthenes-low-res.obj",
        nodes: DEMOSTHENES,
        edges: DEMOSTHENES_EDGES,
        labels: &[],
    },
    Exhibit {
        dir: "nefertiti",
        scan: "nefertiti-lowres.obj",
        nodes: NEFERTITI,
        edges: NEFERTITI_EDGES,
        labels: &[],
    },
    Exhibit {
        dir: "belweder",
        scan: "belweder-ot-1782.glb",
        nodes: BELWEDER,
        edges: BELWEDER_EDGES,
        labels: BELWEDER_LABELS,
    },
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

/// The Belweder OT 1782 television set (`content/belweder/`): a textured glTF in millimetres,
/// +Y up; the cabinet spans x −465…110, y −468 (feet)…46, z −211…247, the screen toward −Z, the
/// loudspeaker grille on the −X side, the back panel at z ≈ 247. The kiosk starts looking along
/// −Z, at the back: the introduction is that view.
const BELWEDER: &[Spec] = &[
    (
        "intro",
        [-90.5, -210.85, 1528.2],
        [-90.5, -210.85, 76.0],
        35.0,
        1.0,
        "Belweder OT 1782",
        "A Polish black-and-white television set, model OT 1782, sold under the name Belweder. We meet it from behind, the side only a repairer saw: a perforated panel, for inside it worked with vacuum tubes that grew hot. Turn it around to find its screen. The Virtual Museums of Małopolska digitised it in colour.",
        "Belweder OT 1782",
        "Un televisore polacco in bianco e nero, modello OT 1782, venduto con il nome Belweder. Lo incontriamo da dietro, il lato che vedeva solo il tecnico: un pannello forato, perché all'interno funzionava con valvole termoioniche che si scaldavano. Giratelo per trovare lo schermo. I Musei Virtuali della Piccola Polonia lo hanno digitalizzato a colori.",
    ),
    (
        "front",
        [-950.0, 150.0, -1250.0],
        [-177.0, -215.0, 18.0],
        35.0,
        0.9,
        "In the living room",
        "From the front the set is a piece of furniture: a wooden cabinet, a rounded screen and a row of cream keys. It stood in the living room, where the family gathered in front of it.",
        "In soggiorno",
        "Di fronte l'apparecchio è un mobile: una cassa di legno, uno schermo arrotondato e una fila di tasti color crema. Stava in soggiorno, dove la famiglia si riuniva davanti allo schermo.",
    ),
    (
        "screen",
        [-177.0, -165.0, -1000.0],
        [-177.0, -175.0, 0.0],
        35.0,
        0.9,
        "The screen",
        "The picture tube fills most of the front. Its screen bulges and has rounded corners, because the glass had to resist the vacuum inside the tube. Switched off, it is grey-green; the picture it showed was black and white.",
        "Lo schermo",
        "Il tubo catodico occupa gran parte del fronte. Lo schermo è bombato e ha gli angoli arrotondati, perché il vetro doveva resistere al vuoto all'interno del tubo. Spento è grigio-verde; l'immagine che mostrava era in bianco e nero.",
    ),
    (
        "controls",
        [-177.0, -360.0, -700.0],
        [-177.0, -375.0, -190.0],
        30.0,
        0.7,
        "Keys and knobs",
        "Below the screen, a row of cream piano keys sits between two winged knobs. These were the set's controls, worked by hand from the armchair's distance: there was no remote control. Look at the worn edges of the keys.",
        "Tasti e manopole",
        "Sotto lo schermo, una fila di tasti a pianoforte color crema sta tra due manopole ad alette. Erano i comandi dell'apparecchio, azionati a mano: non c'era il telecomando. Osservate i bordi consumati dei tasti.",
    ),
    (
        "cabinet",
        [-1050.0, 650.0, -800.0],
        [-177.0, -180.0, 18.0],
        35.0,
        0.6,
        "A wooden cabinet",
        "The cabinet is covered with a glossy wood veneer and has softly rounded edges. The texture of the scan keeps the grain of the wood and the small marks of decades of use.",
        "Un mobile di legno",
        "Il mobile è rivestito da un'impiallacciatura lucida e ha gli spigoli morbidamente arrotondati. La texture della scansione conserva le venature del legno e i piccoli segni di decenni d'uso.",
    ),
    (
        "speaker",
        [-1350.0, -130.0, 60.0],
        [-465.0, -150.0, 60.0],
        32.0,
        0.5,
        "The side grille",
        "On the side, a ribbed cream grille covers an opening in the cabinet, the likely place of the loudspeaker. The sound came out sideways while the screen faced the room.",
        "La griglia laterale",
        "Sul fianco, una griglia color crema a nervature copre un'apertura nel mobile, probabilmente l'altoparlante. Il suono usciva di lato mentre lo schermo guardava la stanza.",
    ),
    (
        "tube-neck",
        [-177.0, -150.0, 950.0],
        [-177.0, -150.0, 250.0],
        30.0,
        0.4,
        "The tube's neck",
        "The picture tube was longer than the cabinet was deep. Its narrow neck, with the electron gun, pokes out at the back under this diamond-shaped cover.",
        "Il collo del tubo",
        "Il tubo catodico era più lungo della profondità del mobile. Il suo collo stretto, con il cannone elettronico, sporge sul retro sotto questa copertura a forma di rombo.",
    ),
    (
        "label",
        [-200.0, -330.0, 800.0],
        [-200.0, -340.0, 247.0],
        22.0,
        0.6,
        "Odbiornik telewizyjny",
        "The printed label reads ODBIORNIK TELEWIZYJNY, Polish for television receiver. Below come OT and the model number, partly hidden by an orange mark, and made in Poland. Small print at the left gives the electrical data; a lightning sign warns of high voltage inside.",
        "Odbiornik telewizyjny",
        "L'etichetta stampata dice ODBIORNIK TELEWIZYJNY, in polacco ricevitore televisivo. Sotto vengono OT e il numero di modello, in parte coperto da un segno arancione, e made in Poland. Le scritte piccole a sinistra danno i dati elettrici; un fulmine avverte dell'alta tensione all'interno.",
    ),
    (
        "cables",
        [650.0, -200.0, 1250.0],
        [-120.0, -390.0, 250.0],
        35.0,
        0.3,
        "Antenna and mains",
        "Two connections link the set to the world. At the left of the back, a flat brown twin-lead cable runs from the antenna socket; at the bottom, the mains cable ends in its plug. The picture came through the air, from a roof aerial.",
        "Antenna e corrente",
        "Due collegamenti uniscono l'apparecchio al mondo. A sinistra del retro, un cavo piatto marrone parte dalla presa d'antenna; in basso, il cavo di alimentazione termina con la sua spina. L'immagine arrivava via etere, da un'antenna sul tetto.",
    ),
];

/// (from, to, weight): the introduction (the back, where the kiosk starts) opens the front and
/// the back's details; the front's details follow; weak links go around the cabinet.
const BELWEDER_EDGES: &[Edge] = &[
    ("intro", "front", 1.0),
    ("front", "screen", 1.0),
    ("screen", "controls", 0.8),
    ("intro", "tube-neck", 0.8),
    ("intro", "label", 0.8),
    ("label", "cables", 0.2),
    ("front", "cabinet", 0.2),
    ("cabinet", "speaker", 0.8),
    ("controls", "speaker", 0.2),
];

/// The overlays' labels: each points at a feature of its view.
const BELWEDER_LABELS: &[Label] = &[
    ("intro", [-330.0, -40.0, 247.0], [-200.0, -180.0], "ventilation holes", "fori di aerazione"),
    ("intro", [-177.0, -143.0, 260.0], [250.0, -150.0], "picture tube", "tubo catodico"),
    ("intro", [-180.0, -350.0, 247.0], [230.0, 150.0], "label", "etichetta"),
    ("front", [-177.0, -165.0, -175.0], [-330.0, -250.0], "screen", "schermo"),
    ("front", [-465.0, -103.0, 106.0], [150.0, -230.0], "side grille", "griglia laterale"),
    ("front", [-177.0, -378.0, -200.0], [-250.0, 120.0], "keys", "tasti"),
    ("screen", [-177.0, -165.0, -175.0], [-380.0, -220.0], "picture tube", "tubo catodico"),
    ("screen", [-177.0, -378.0, -200.0], [250.0, 110.0], "controls", "comandi"),
    ("controls", [24.0, -381.0, -200.0], [40.0, 150.0], "knob", "manopola"),
    ("controls", [-378.0, -381.0, -200.0], [-40.0, 150.0], "knob", "manopola"),
    ("controls", [-177.0, -378.0, -205.0], [0.0, -170.0], "piano keys", "tasti a pianoforte"),
    ("cabinet", [-177.0, 46.0, 18.0], [200.0, -160.0], "wood veneer", "impiallacciatura"),
    ("speaker", [-465.0, -103.0, 106.0], [230.0, -150.0], "grille", "griglia"),
    ("tube-neck", [-177.0, -143.0, 270.0], [280.0, -160.0], "diamond cover", "copertura a rombo"),
    ("label", [-180.0, -344.0, 247.0], [220.0, -200.0], "television receiver", "ricevitore televisivo"),
    ("label", [-173.0, -356.0, 247.0], [260.0, 130.0], "model number", "numero di modello"),
    ("label", [-301.0, -391.0, 247.0], [60.0, 130.0], "high voltage", "alta tensione"),
    ("cables", [-367.0, -322.0, 250.0], [-150.0, -170.0], "antenna socket", "presa d'antenna"),
    ("cables", [265.0, -430.0, 355.0], [120.0, 150.0], "mains plug", "spina"),
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
    let (gpu, mut renderer) = kiosk_content::snapshot::offscreen()?;
    for ex in EXHIBITS.iter().filter(|e| wanted.is_empty() || wanted.iter().any(|w| w == e.dir)) {
        build(ex, &gpu, &mut renderer)?;
    }
    Ok(())
}

/// Builds one exhibit's story from scratch: every node of its graph is replaced by the table's.
fn build(ex: &Exhibit, gpu: &Gpu, renderer: &mut Renderer) -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../content").join(ex.dir);
    let model = kiosk_content::exhibit::model_file(&dir)?;
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
        let labels: Vec<&Label> = ex.labels.iter().filter(|l| l.0 == id).collect();
        if labels.is_empty() {
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
        } else {
            // Labels pointing at the view's features, as SVG text, one drawing per language.
            for (k, lang) in ["en", "it"].into_iter().enumerate() {
                let svg = label_svg(&cam, &labels, k)?;
                let src = tmp.path().join(format!("{id}-{lang}.svg"));
                std::fs::write(&src, &svg)?;
                if let Some(w) = p.attach_overlay(id, lang, &src)? {
                    anyhow::bail!("{id}: {w}");
                }
                preview(&p, gpu, renderer, ex.dir, id, lang, &cam, &svg)?;
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

/// The overlay of a view as SVG (1280×720, the projection's aspect): for each label a ring on its
/// model point, projected with the view's camera, and a leader line to its text, `lang`: 0 = en,
/// 1 = it.
fn label_svg(cam: &Camera, labels: &[&Label], lang: usize) -> anyhow::Result<String> {
    let (w, h) = (1280.0, 720.0);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">\n"
    );
    for &&(id, point, [dx, dy], en, it) in labels {
        let (x, y, _) =
            cam.ndc(DVec3::from(point), w / h).with_context(|| format!("{id}: a label behind the eye"))?;
        let (px, py) = ((x + 1.0) * 0.5 * w, (1.0 - y) * 0.5 * h);
        anyhow::ensure!(
            (0.0..w).contains(&px) && (0.0..h).contains(&py),
            "{id}: label {en} outside the view"
        );
        let text =
            if lang == 0 { en } else { it }.replace('&', "&amp;").replace('<', "&lt;").replace('\'', "&#39;");
        let (tx, ty) = ((px + dx).clamp(20.0, w - 20.0), (py + dy).clamp(40.0, h - 30.0));
        // The box around the text: about 0.6 em per character at 28 px.
        let bw = 20.0 + 16.8 * text.chars().count() as f64;
        let bx = if dx < 0.0 {
            tx - bw
        } else if dx > 0.0 {
            tx
        } else {
            tx - bw / 2.0
        };
        let bx = bx.clamp(8.0, w - 8.0 - bw);
        svg += &format!(
            "  <circle cx=\"{px:.1}\" cy=\"{py:.1}\" r=\"14\" fill=\"none\" stroke=\"#ffc440\" stroke-width=\"4\"/>\n\
             <line x1=\"{px:.1}\" y1=\"{py:.1}\" x2=\"{:.1}\" y2=\"{ty:.1}\" stroke=\"#ffc440\" stroke-width=\"3\"/>\n\
             <rect x=\"{bx:.1}\" y=\"{:.1}\" width=\"{bw:.1}\" height=\"44\" rx=\"8\" fill=\"#000000\" fill-opacity=\"0.6\" stroke=\"#ffc440\" stroke-width=\"2\"/>\n\
             <text x=\"{:.1}\" y=\"{:.1}\" font-family=\"sans-serif\" font-size=\"28\" fill=\"#ffffff\">{text}</text>\n",
            bx + bw / 2.0,
            ty - 22.0,
            bx + 8.0,
            ty + 10.0,
        );
    }
    svg += "</svg>\n";
    Ok(svg)
}

/// Writes what a visitor sees at a node, its render with the overlay on top, to
/// `target/tmp/demo_content/EXHIBIT-ID-LANG.png` for checking that the labels sit on the model.
#[allow(clippy::too_many_arguments)]
fn preview(
    p: &Project,
    gpu: &Gpu,
    renderer: &mut Renderer,
    exhibit: &str,
    id: &str,
    lang: &str,
    cam: &Camera,
    svg: &str,
) -> anyhow::Result<()> {
    let mut img = kiosk_content::snapshot::snapshot(
        gpu,
        renderer,
        &p.store,
        cam,
        (1280, 720),
        1.0,
        &RenderSettings::default(),
    )?;
    let overlay =
        kiosk_content::media::svg_to_rgba(svg.as_bytes()).map_err(|e| anyhow::anyhow!("{id}: {e}"))?;
    image::imageops::overlay(&mut img, &overlay, 0, 0);
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/tmp/demo_content");
    std::fs::create_dir_all(&dir)?;
    img.save(dir.join(format!("{exhibit}-{id}-{lang}.png")))?;
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
