//! The kiosk's behaviour on the demo exhibits, through the core's own replay of the kiosk (the
//! same path the windows take): gallery swipes and taps, buttons, the attract loop and the reset,
//! with an accelerated (simulated) clock.

use kiosk_content::MappedStore;
use kiosk_core::gesture::TouchKind;
use kiosk_core::graph::InfoGraph;
use kiosk_core::kiosk::{KioskEffect, KioskFrame, KioskSettings, Mode, ModelRef, run_session};
use kiosk_core::session::Script;
use std::path::Path;

struct Demo {
    models: Vec<(MappedStore, InfoGraph)>,
}

fn demo() -> Demo {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("content");
    let models = ["demosthenes", "nefertiti"]
        .iter()
        .map(|name| {
            let dir = root.join(name);
            let store = kiosk_content::exhibit::open_model_in(&dir, &crate::common::cache()).expect("model");
            let (graph, problems) =
                kiosk_content::exhibit::open_graph(&dir).expect("graph").expect("graph.xml");
            assert!(problems.is_empty(), "{problems:?}");
            (store, graph)
        })
        .collect();
    Demo { models }
}

impl Demo {
    fn run(&self, script: &Script, settings: &KioskSettings, extra: f64) -> Vec<KioskFrame> {
        let refs: Vec<ModelRef<'_, memmap2::Mmap>> = self
            .models
            .iter()
            .map(|(s, g)| ModelRef { store: s, graph: Some(g), up: glam::DVec3::Y, front: None })
            .collect();
        run_session(&refs, &script.session(), settings, extra)
    }
}

fn fast() -> KioskSettings {
    KioskSettings { attract_after_secs: 20.0, reset_after_secs: 400.0, ..KioskSettings::default() }
}

/// Modes in order, without repeats.
fn modes(frames: &[KioskFrame]) -> Vec<Mode> {
    let mut v = Vec::new();
    for f in frames {
        if v.last() != Some(&f.mode) {
            v.push(f.mode);
        }
    }
    v
}

/// The overlays displayed in `frames`, in order, each once per display.
fn overlays_shown<'a>(frames: impl IntoIterator<Item = &'a KioskFrame>) -> Vec<String> {
    let mut shown: Vec<String> = Vec::new();
    for f in frames {
        if let Some(o) = f.explore.as_ref().and_then(|e| e.overlay.clone())
            && shown.last() != Some(&o)
        {
            shown.push(o);
        }
    }
    shown
}

fn at(frames: &[KioskFrame], t: f64) -> &KioskFrame {
    frames.iter().find(|f| f.t + 1e-9 >= t).expect("frame at t")
}

#[test]
fn gallery_swipes_and_taps() {
    let d = demo();
    // Swipe left (next), swipe right (previous), swipe left again, tap the card: explore model 1.
    let script = Script::new()
        .wait(0.5)
        .swipe(5, (0.8, 0.5), (0.3, 0.52), 0.3)
        .wait(0.5)
        .swipe(5, (0.3, 0.5), (0.8, 0.5), 0.3)
        .wait(0.5)
        .swipe(5, (0.7, 0.5), (0.2, 0.5), 0.3)
        .wait(0.5)
        .down(9, 0.5, 0.5)
        .wait(0.1)
        .up(9, 0.5, 0.5)
        .wait(1.0)
        .cancel(99);
    let frames = d.run(&script, &fast(), 0.5);
    let models: Vec<usize> = frames.iter().map(|f| f.model).collect();
    let mut seen = models.clone();
    seen.dedup();
    assert_eq!(seen, [0, 1, 0, 1], "gallery pages");
    assert_eq!(modes(&frames), [Mode::Gallery, Mode::Explore]);
    let last = frames.last().expect("frames");
    assert_eq!(last.model, 1);
    assert!(last.explore.is_some(), "exploring the Nefertiti bust");
}

#[test]
fn buttons_language_help_back() {
    let d = demo();
    let tap = |s: Script, x: f64, y: f64| s.tap(1, x, y).wait(0.5);
    let mut s = Script::new().wait(0.2);
    s = tap(s, 0.5, 0.86); // Explore
    s = tap(s, 0.9, 0.07); // Help
    s = tap(s, 0.74, 0.07); // Language → it
    let s_help = s.clone();
    s = tap(s, 0.08, 0.07); // Back
    let frames = d.run(&s.cancel(99), &fast(), 0.5);
    let mid = at(&frames, s_help.session().duration() + 0.2);
    assert_eq!(mid.mode, Mode::Explore);
    assert!(mid.help, "help shown");
    assert_eq!(mid.lang, "it");
    let last = frames.last().expect("frames");
    assert_eq!(last.mode, Mode::Gallery, "back to the gallery");
    assert!(!last.help, "help closes with the gallery");
    assert_eq!(last.lang, "it", "the language stays until the reset");
}

#[test]
fn a_drag_starting_on_a_button_is_not_a_press_and_a_drag_elsewhere_moves_the_camera() {
    let d = demo();
    let s = Script::new()
        .wait(0.2)
        .tap(1, 0.5, 0.86)
        .wait(0.5)
        // Slides off the back button before lifting: no press.
        .swipe(5, (0.08, 0.07), (0.5, 0.5), 0.4)
        .wait(0.3)
        .joystick(2, (0.2, 0.0), 1.5)
        .wait(0.5)
        .cancel(99);
    let frames = d.run(&s, &fast(), 0.2);
    assert_eq!(
        modes(&frames),
        [Mode::Gallery, Mode::Explore],
        "still exploring: the slide off the button is no press"
    );
    let eyes: Vec<[f64; 3]> = frames.iter().filter_map(|f| f.explore.as_ref().map(|e| e.eye)).collect();
    assert!(eyes.first() != eyes.last(), "the joystick moved the camera");
}

#[test]
fn attract_loop_tours_the_model_and_a_touch_takes_over_then_the_reset() {
    let d = demo();
    let settings =
        KioskSettings { attract_after_secs: 20.0, reset_after_secs: 300.0, ..KioskSettings::default() };
    // Explore, switch to Italian, then nobody touches for 200 s; a touch; then nobody for 400 s.
    let s = Script::new()
        .wait(0.2)
        .tap(1, 0.5, 0.86)
        .wait(0.5)
        .tap(1, 0.74, 0.07)
        .wait(200.0)
        .down(3, 0.5, 0.5)
        .wait(0.1)
        .up(3, 0.5, 0.5)
        .wait(1.0)
        .cancel(99);
    let touch_t = 0.2 + 0.05 + 0.5 + 0.05 + 200.0;
    // The last input is the script's closing event (a cancel counts as input too).
    let last_input = s.session().duration();
    let frames = d.run(&s, &settings, 400.0);
    assert_eq!(
        modes(&frames),
        [Mode::Gallery, Mode::Explore, Mode::Attract, Mode::Explore, Mode::Attract, Mode::Gallery]
    );
    let first_attract = frames.iter().find(|f| f.mode == Mode::Attract).expect("attract");
    assert!((first_attract.t - (0.8 + 20.0)).abs() < 0.1, "attract after 20 s idle: {}", first_attract.t);
    // The tour: the engine goes to and displays several different nodes on its own.
    let shown = overlays_shown(frames.iter().filter(|f| f.t < touch_t));
    let mut distinct = shown.clone();
    distinct.sort();
    distinct.dedup();
    assert!(distinct.len() >= 3, "the tour shows several nodes: {shown:?}");
    assert!(
        frames.iter().filter(|f| f.t < touch_t).any(|f| f
            .effects
            .iter()
            .any(|e| matches!(e, KioskEffect::PlayNarration { lang, .. } if lang == "it"))),
        "narration in the visitor's language"
    );
    // The touch takes over: exploring again, and the autopilot is off.
    let after = at(&frames, touch_t + 0.5);
    assert_eq!(after.mode, Mode::Explore);
    // The countdown runs during the attract loop and the reset happens on time.
    let reset = frames.iter().rev().find(|f| f.mode != Mode::Gallery).expect("before reset");
    assert!((reset.t - (last_input + 300.0)).abs() < 0.05, "reset 300 s after the last touch: {}", reset.t);
    assert!(reset.countdown.is_some_and(|c| c < 0.1), "{:?}", reset.countdown);
    let last = frames.last().expect("frames");
    assert_eq!(
        (last.mode, last.model, last.lang.as_str()),
        (Mode::Gallery, 0, "en"),
        "reset to gallery, model and language"
    );
    assert!(
        frames.iter().any(|f| f.effects.contains(&KioskEffect::StopNarration) && f.t >= touch_t),
        "narration stops"
    );
}

#[test]
fn same_session_same_seed_same_frames() {
    let d = demo();
    let s = Script::new().wait(0.2).tap(1, 0.5, 0.86).joystick(2, (0.1, 0.05), 2.0).wait(40.0).cancel(99);
    let a = serde_json::to_string(&d.run(&s, &fast(), 1.0)).expect("json");
    let b = serde_json::to_string(&d.run(&s, &fast(), 1.0)).expect("json");
    assert_eq!(a, b);
}

#[test]
fn a_view_chosen_in_the_radial_menu_does_not_stop_the_attract_tour() {
    let d = demo();
    // Explore, long press, choose the top candidate, then nobody: its display would last until
    // the visitor moves away; the attract loop must go on touring.
    let s = Script::new()
        .wait(0.2)
        .tap(1, 0.5, 0.86)
        .wait(0.5)
        .radial_pick(2, (0.5, 0.5), 1.0, (0.5, 0.3))
        .wait(150.0)
        .cancel(99);
    let frames = d.run(&s, &fast(), 0.0);
    let shown = overlays_shown(&frames);
    assert!(frames.iter().any(|f| f.mode == Mode::Attract), "the attract loop started");
    assert!(shown.len() >= 3, "the tour went on after the menu's choice: {shown:?}");
}

/// Drives a kiosk through a script like `run_session`, and hands the kiosk back.
fn drive<'a>(
    d: &'a Demo,
    script: &Script,
    settings: &KioskSettings,
    extra: f64,
) -> (Vec<KioskFrame>, kiosk_core::kiosk::Kiosk<'a, memmap2::Mmap>) {
    let refs: Vec<ModelRef<'a, memmap2::Mmap>> = d
        .models
        .iter()
        .map(|(s, g)| ModelRef { store: s, graph: Some(g), up: glam::DVec3::Y, front: None })
        .collect();
    let session = script.session();
    let mut kiosk = kiosk_core::kiosk::Kiosk::new(settings.clone(), refs, 0.0);
    let dt = 1.0 / settings.explore.fps;
    let (mut next, mut frames) = (0, Vec::new());
    for k in 0..=((session.duration() + extra) * settings.explore.fps).ceil() as u64 {
        let t = k as f64 * dt;
        while next < session.events.len() && session.events[next].t <= t + 1e-9 {
            kiosk.touch(&session.events[next]);
            next += 1;
        }
        frames.push(kiosk.step(t));
    }
    (frames, kiosk)
}

#[test]
fn visits_are_recorded_and_the_statistics_outlive_the_reset() {
    use kiosk_core::stats::VisitEnd;
    let d = demo();
    let settings =
        KioskSettings { attract_after_secs: 20.0, reset_after_secs: 60.0, ..KioskSettings::default() };
    // A visitor explores, picks the menu's top candidate, switches language, leaves; the attract
    // loop starts; a second visitor takes over and leaves; the reset.
    let s = Script::new()
        .wait(0.2)
        .tap(1, 0.5, 0.86)
        .wait(0.5)
        .radial_pick(2, (0.5, 0.5), 1.0, (0.5, 0.3))
        .wait(1.0)
        .tap(1, 0.74, 0.07)
        .wait(40.0)
        .tap(3, 0.5, 0.5)
        .wait(5.0)
        .cancel(99);
    let (frames, mut kiosk) = drive(&d, &s, &settings, 70.0);
    let visits = kiosk.take_visits();
    assert_eq!(visits.iter().map(|v| v.ended).collect::<Vec<_>>(), [VisitEnd::NewVisitor, VisitEnd::Reset]);
    let first = &visits[0];
    assert!((first.start - 0.2).abs() < 1e-9, "{}", first.start);
    assert_eq!(first.languages, ["en", "it"]);
    assert_eq!(first.models.len(), 1);
    let m = &first.models[0];
    assert_eq!((m.model, m.menu_opens, m.menu_picks.len()), (0, 1, 1));
    // The pick was displayed (a menu display holds until the attract loop, 20 s after the last
    // touch, so its dwell is about that long).
    let picked = &m.displayed.first().expect("the pick was displayed").node;
    let dwell = m.displayed[0].dwell_secs;
    assert!(dwell > 15.0 && dwell < 25.0, "dwell {dwell}");
    // The second visit starts at the takeover and ends at the reset, 60 s after the kiosk's last
    // input (the session's last event, a cancel, which is not a touch of the visitor's).
    let last_input = s.session().duration();
    assert!(
        visits[1].start > first.start + 40.0
            && visits[1].last_touch <= last_input
            && (visits[1].end - (last_input + 60.0)).abs() < 0.05,
        "second visit: start {}, end {}, last touch {}",
        visits[1].start,
        visits[1].end,
        visits[1].last_touch
    );
    assert_eq!(frames.last().map(|f| f.mode), Some(Mode::Gallery));
    // The long-run counts survived the reset.
    let stats = &kiosk.stats()[0];
    assert_eq!(stats.visits, 2);
    let n = stats.get(picked);
    assert_eq!((n.menu_picks, n.displays), (1, 1));
    assert!((n.dwell_secs - dwell).abs() < 1e-9);
    assert_eq!(kiosk.stats()[1].visits, 0);
    assert!(kiosk.visit().is_none());
}

#[test]
fn popularity_without_data_changes_no_frame() {
    let d = demo();
    let s = Script::new().wait(0.2).tap(1, 0.5, 0.86).joystick(2, (0.1, 0.05), 2.0).wait(40.0).cancel(99);
    let mut on = fast();
    on.popularity.enabled = true;
    let a = serde_json::to_string(&d.run(&s, &fast(), 1.0)).expect("json");
    let b = serde_json::to_string(&d.run(&s, &on, 1.0)).expect("json");
    assert_eq!(a, b);
}

#[test]
fn a_z_up_model_starts_upright_and_stays_upright() {
    let d = demo();
    let (store, graph) = &d.models[0];
    let script = Script::new().wait(0.2).tap(1, 0.5, 0.86).wait(0.5).joystick(2, (0.2, 0.0), 1.5).wait(0.5);
    // The two axes and a scan standing tilted in its file (exhibit.toml's `up = [x, y, z]`).
    for up in [glam::DVec3::Y, glam::DVec3::Z, glam::DVec3::new(0.2, 1.0, -0.1).normalize()] {
        let refs = [ModelRef { store, graph: Some(graph), up, front: None }];
        let frames = run_session(&refs, &script.session(), &fast(), 1.0);
        let explored: Vec<_> = frames.iter().filter_map(|f| f.explore.as_ref()).collect();
        assert!(!explored.is_empty(), "the visitor explores");
        for f in &explored {
            let cam_up = glam::DVec3::from_array(f.up);
            assert!(cam_up.dot(up) > 0.7, "up {up}: the camera's up {cam_up} leans away from the model's");
        }
        let first = glam::DVec3::from_array(explored[0].up);
        assert!(first.dot(up) > 0.99, "up {up}: the exploration starts upright ({first})");
        // The start view itself is level: it looks across the model's up, not down or up at it.
        let start = kiosk_core::camera::start_camera(store, 0.8, up, None);
        assert!(
            start.forward().dot(up).abs() < 1e-12 && start.up.dot(up) > 1.0 - 1e-12,
            "up {up}: {start:?}"
        );
    }
}

#[test]
fn a_model_turned_to_its_front_is_first_seen_from_it() {
    let d = demo();
    let (store, graph) = &d.models[0];
    let script = Script::new().wait(0.2).tap(1, 0.5, 0.86).wait(0.3);
    let first_view = |up: glam::DVec3, front: Option<glam::DVec3>| {
        let refs = [ModelRef { store, graph: Some(graph), up, front }];
        let frames = run_session(&refs, &script.session(), &fast(), 1.0);
        let e = frames.iter().find_map(|f| f.explore.as_ref()).expect("the visitor explores").clone();
        (glam::DVec3::from_array(e.eye) - glam::DVec3::from_array(e.target)).normalize()
    };
    assert!(first_view(glam::DVec3::Y, None).dot(glam::DVec3::Z) > 0.99, "default: from +Z");
    for (up, front) in [
        (glam::DVec3::Y, glam::DVec3::NEG_Z),
        (glam::DVec3::Y, glam::DVec3::X),
        (glam::DVec3::Z, glam::DVec3::X),
        // Any rotation: a tilted up and a front perpendicular to it.
        (glam::DVec3::new(0.0, 0.96, 0.28), glam::DVec3::new(0.6, -0.224, 0.768)),
    ] {
        let from = first_view(up, Some(front));
        assert!(from.dot(front) > 0.99, "up {up}, front {front}: the visit starts looking at it from {from}");
    }
}

/// The light button's place on the controller (centre).
const LIGHT_BUTTON: (f64, f64) = (0.56, 0.07);

fn light_of(f: &KioskFrame) -> glam::DVec3 {
    glam::DVec3::from_array(f.explore.as_ref().expect("exploring").light)
}

fn eye_of(f: &KioskFrame) -> [f64; 3] {
    f.explore.as_ref().expect("exploring").eye
}

/// The frame's view axes: toward the viewer and to the right.
fn view_axes(f: &KioskFrame) -> (glam::DVec3, glam::DVec3) {
    let e = f.explore.as_ref().expect("exploring");
    let (eye, target, up) =
        (glam::DVec3::from_array(e.eye), glam::DVec3::from_array(e.target), glam::DVec3::from_array(e.up));
    let back = (eye - target).normalize_or_zero();
    (back, (-back).cross(up).normalize_or_zero())
}

/// A visitor steers the light: a drag from the Light button, then the button tapped on and a
/// one-finger drag (a second finger ignored), then off again (drags move the camera); nobody
/// touches and the attract loop brings the start light back.
fn light_script() -> Script {
    let (bx, by) = LIGHT_BUTTON;
    Script::new()
        .wait(0.2)
        .tap(1, 0.5, 0.86)
        .wait(0.5)
        // From the button, far to the right and a little down: a raking light from the right.
        .swipe(2, (bx, by), (0.95, 0.3), 0.6)
        .wait(0.5)
        .tap(3, bx, by)
        .wait(0.3)
        .down(4, 0.5, 0.5)
        .down(5, 0.7, 0.6)
        .drag(&[(4, (0.5, 0.5), (0.3, 0.3)), (5, (0.7, 0.6), (0.9, 0.6))], 0.5)
        .up(4, 0.3, 0.3)
        .up(5, 0.9, 0.6)
        .wait(0.3)
        .tap(3, bx, by)
        .wait(0.3)
        .joystick(6, (0.2, 0.0), 1.0)
        .wait(0.5)
        .cancel(99)
}

#[test]
fn the_light_button_steers_the_light_and_the_attract_loop_brings_it_back() {
    use kiosk_core::light::{ACTIVE_MIX, DEFAULT_MIX};
    let d = demo();
    let settings =
        KioskSettings { attract_after_secs: 5.0, reset_after_secs: 400.0, ..KioskSettings::default() };
    let script = light_script();
    let frames = d.run(&script, &settings, 12.0);
    let times: Vec<f64> = script.events.iter().filter(|e| e.ev != TouchKind::Move).map(|e| e.t).collect();
    // Downs and ups: explore tap (0, 1), swipe (2, 3), tap on (4, 5), two fingers (6–9), tap off
    // (10, 11), joystick (12, 13).
    let before = at(&frames, times[2] - 0.05);
    let start = light_of(before);
    assert_eq!(before.explore.as_ref().map(|e| e.light_mix), Some(DEFAULT_MIX));
    assert!((start.length() - 1.0).abs() < 1e-12);
    // The drag from the button: the light grazes the view from the right; the camera stayed.
    let swiped = at(&frames, times[3] + 0.05);
    let raking = light_of(swiped);
    let (back, right) = view_axes(swiped);
    assert!(raking.dot(back).abs() < 1e-9, "a grazing light: {raking} · {back} = {}", raking.dot(back));
    assert!(raking.dot(right) > 0.8, "from the right: {raking}");
    assert_eq!(eye_of(swiped), eye_of(before), "the drag from the button moved the camera");
    assert!(!swiped.light_on, "a drag from the button does not switch the light on");
    // Tapped: on. One finger steers the light; the second is ignored (the camera stays).
    let on = at(&frames, times[5] + 0.1);
    assert!(on.light_on);
    assert_eq!(light_of(on), raking, "a tap does not move the light");
    let dragged = at(&frames, times[9] + 0.05);
    assert!(dragged.light_on);
    let up_left = light_of(dragged);
    assert!((up_left - raking).length() > 0.5, "the one-finger drag moved the light: {up_left}");
    let (back, right) = view_axes(dragged);
    let up = back.cross(right);
    assert!(up_left.dot(up) > 0.0 && up_left.dot(right) < raking.dot(right), "{up_left}");
    assert_eq!(eye_of(dragged), eye_of(on), "with the light on, fingers do not move the camera");
    assert!((dragged.explore.as_ref().expect("exploring").light_mix - ACTIVE_MIX).abs() < 1e-3);
    // Off again: the joystick moves the camera; the light stays where the visitor put it.
    let off = at(&frames, times[11] + 0.05);
    assert!(!off.light_on);
    let moved = at(&frames, times[13]);
    assert_ne!(eye_of(moved), eye_of(off), "the joystick moves the camera again");
    assert_eq!(light_of(moved), up_left, "the light stays in the model's axes");
    // Nobody: the attract loop eases the start light back, the headlight dominating again.
    let last = frames.last().expect("frames");
    assert_eq!(last.mode, Mode::Attract);
    assert!(!last.light_on);
    let attract = frames.iter().position(|f| f.mode == Mode::Attract).expect("attract");
    for w in frames[attract..].windows(2) {
        let step = light_of(&w[1]).angle_between(light_of(&w[0]));
        assert!(step < 0.05, "the light eases back (jumped {step} rad at {})", w[1].t);
    }
    assert!(light_of(last).angle_between(start) < 1e-9, "the start light is back: {}", light_of(last));
    assert_eq!(last.explore.as_ref().map(|e| e.light_mix), Some(DEFAULT_MIX));
}

#[test]
fn a_session_with_light_drags_replays_byte_for_byte_and_traces_the_light() {
    let d = demo();
    let settings =
        KioskSettings { attract_after_secs: 5.0, reset_after_secs: 400.0, ..KioskSettings::default() };
    // Through the session file format, as `--record` writes it and `--session` reads it.
    let session = kiosk_core::session::Session::parse(&light_script().session().to_jsonl()).expect("session");
    let refs: Vec<ModelRef<'_, memmap2::Mmap>> = d
        .models
        .iter()
        .map(|(s, g)| ModelRef { store: s, graph: Some(g), up: glam::DVec3::Y, front: None })
        .collect();
    let trace = || -> String {
        run_session(&refs, &session, &settings, 3.0)
            .iter()
            .map(|f| serde_json::to_string(f).expect("json") + "\n")
            .collect()
    };
    let (a, b) = (trace(), trace());
    assert!(a == b, "two replays of the same session differ");
    let lines: Vec<serde_json::Value> = a.lines().map(|l| serde_json::from_str(l).expect("json")).collect();
    let lights: Vec<&serde_json::Value> = lines.iter().filter_map(|l| l["explore"].get("light")).collect();
    assert!(!lights.is_empty() && lights.iter().all(|l| l.as_array().is_some_and(|a| a.len() == 3)));
    let mut distinct: Vec<String> = lights.iter().map(|l| l.to_string()).collect();
    distinct.dedup();
    assert!(distinct.len() > 10, "the trace follows the light as it moves: {} values", distinct.len());
    assert!(lines.iter().any(|l| l["light_on"] == true), "the light button's state is traced");
    assert!(lines.iter().all(|l| l["explore"].is_null() || l["explore"]["light_mix"].is_f64()));
}

#[test]
fn a_recorded_visit_without_light_still_replays_with_the_start_light() {
    // tests/sessions/kiosk-visit.jsonl was recorded before the light button existed.
    let d = demo();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sessions/kiosk-visit.jsonl");
    let session = kiosk_core::session::Session::parse(&std::fs::read_to_string(&path).expect("read"))
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut settings = KioskSettings::default();
    settings.explore.seed = session.header.as_ref().and_then(|h| h.seed).unwrap_or(0);
    let refs: Vec<ModelRef<'_, memmap2::Mmap>> = d
        .models
        .iter()
        .map(|(s, g)| ModelRef { store: s, graph: Some(g), up: glam::DVec3::Y, front: None })
        .collect();
    let frames = run_session(&refs, &session, &settings, 1.0);
    let a = serde_json::to_string(&frames).expect("json");
    assert_eq!(a, serde_json::to_string(&run_session(&refs, &session, &settings, 1.0)).expect("json"));
    assert!(frames.iter().all(|f| !f.light_on), "nobody touched the light");
    let explored: Vec<&KioskFrame> = frames.iter().filter(|f| f.explore.is_some()).collect();
    assert!(explored.len() > 1000, "the visit explores");
    assert!(
        frames.iter().any(|f| f.explore.as_ref().and_then(|e| e.overlay.as_ref()).is_some()),
        "the visit still reaches its views"
    );
    // Every exploration keeps the light it started with (the demo views store none).
    for w in explored.windows(2) {
        if w[0].model == w[1].model {
            assert_eq!(light_of(w[0]), light_of(w[1]), "the light moved at {}", w[1].t);
            assert_eq!(w[1].explore.as_ref().map(|e| e.light_mix), Some(kiosk_core::light::DEFAULT_MIX));
        }
    }
}

#[test]
fn the_mouse_menu_closes_on_a_second_right_click_and_when_the_attract_tour_starts() {
    let d = demo();
    // Explore; the right button opens the menu and again closes it; a third right click opens
    // it and the visitor walks away: the attract tour starts 20 s later, closes the menu and
    // tours. A right click during the tour takes over with the menu open, a touch closes it
    // without a pick. Recorded in the session, so it replays like any touch.
    let s = Script::new()
        .wait(0.2)
        .tap(1, 0.5, 0.86)
        .wait(0.5)
        .menu(0.5, 0.5)
        .wait(0.5)
        .menu(0.5, 0.5)
        .wait(0.5)
        .menu(0.4, 0.5)
        .wait(120.0)
        .menu(0.5, 0.5)
        .wait(0.5)
        .tap(2, 0.5, 0.5)
        .wait(1.0)
        .cancel(99);
    let settings = fast();
    let frames = d.run(&s, &settings, 0.0);
    let open = |t: f64| at(&frames, t).explore.as_ref().and_then(|e| e.menu.as_ref()).is_some();
    assert!(!open(0.7), "closed before the right click");
    assert!(open(1.0), "the right button opens the menu");
    assert!(!open(1.5), "and a second right click closes it");
    assert!(open(2.0), "a third opens it again");
    let attract = frames.iter().find(|f| f.mode == Mode::Attract).expect("the attract loop starts");
    assert!((attract.t - (1.75 + settings.attract_after_secs)).abs() < 0.1, "{}", attract.t);
    assert!(!open(attract.t + 0.1), "the tour closes the menu left open");
    let shown = overlays_shown(frames.iter().filter(|f| f.mode == Mode::Attract));
    assert!(shown.len() >= 2, "the tour goes on with the menu closed: {shown:?}");
    let click = 121.75;
    assert_eq!(at(&frames, click + 0.1).mode, Mode::Explore, "a right click takes over the tour");
    assert!(open(click + 0.1), "with the menu open");
    assert!(!open(click + 0.7), "a tap at its centre closes it");
    assert_eq!(
        frames.last().expect("frames").explore.as_ref().expect("explore").overlay,
        None,
        "and picks nothing"
    );
}

#[test]
fn a_mouse_menu_takes_the_next_press_even_on_a_button() {
    let d = demo();
    // The right button opens the menu at the middle; the mouse then presses on the Back button's
    // place (top left) and releases there. No finger was down to own the menu, but that press
    // picks from it (up and left of its centre): it does not leave the model.
    let s = Script::new().wait(0.2).tap(1, 0.5, 0.86).wait(0.5).menu(0.5, 0.5).wait(0.3).tap(2, 0.08, 0.07);
    let pick = s.t;
    let s = s.wait(4.0).cancel(99);
    let frames = d.run(&s, &fast(), 0.0);
    assert!(
        at(&frames, pick - 0.1).explore.as_ref().expect("explore").menu.is_some(),
        "open before the press"
    );
    let after = at(&frames, pick + 0.1);
    assert_eq!(after.mode, Mode::Explore, "the press on Back's place picked, it did not press Back");
    assert!(after.explore.as_ref().expect("explore").menu.is_none(), "the menu closed with the pick");
    assert!(
        frames.iter().filter(|f| f.t > pick).any(|f| f.explore.as_ref().is_some_and(|e| e.overlay.is_some())),
        "the picked view is displayed"
    );
}
