//! `kiosk check`: everything the kiosk would load of an exhibit, checked without a window, a GPU
//! or an audio device — the model (imported into the cache if it is a scan, as at the kiosk's
//! first start; every node's checksum with `full`), its pose, its story and its media, and
//! every narration decoded. The kiosk logs the same problems when it loads the exhibit, and
//! leaves out what they name; here a technician or a curator sees them all before a visitor does.

use crate::exhibit;
use kiosk_core::graph::InfoGraph;
use std::collections::BTreeMap;
use std::path::Path;

/// What [`check`] found in one exhibit.
#[derive(Debug, Default)]
pub struct Checked {
    /// What is sound, a line each (the model, the pose, the story, the narrations).
    pub sound: Vec<String>,
    /// What is wrong, a line each, naming the file and the node: `(true, …)` for what the
    /// kiosk leaves out (a model it cannot show, a node or an edge it drops, a narration it
    /// cannot play), `(false, …)` for what it shows anyway (a warning).
    pub problems: Vec<(bool, String)>,
}

impl Checked {
    /// Whether the kiosk would leave something of the exhibit out.
    pub fn has_errors(&self) -> bool {
        self.problems.iter().any(|(error, _)| *error)
    }
}

/// Checks the exhibit in `dir`, importing a scan into `cache` if it has no store there yet.
pub fn check(dir: &Path, cache: &Path, full: bool) -> Checked {
    let mut c = Checked::default();
    if !dir.is_dir() {
        c.problems.push((true, format!("{}: no such directory", dir.display())));
        return c;
    }
    match exhibit::open_model_warned(dir, cache, &mut |_| {}) {
        Ok((store, warnings)) => {
            let h = *store.header();
            let name = exhibit::model_file(dir)
                .ok()
                .and_then(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()));
            // What the reader warned of when it imported the scan (now or at an earlier start):
            // the kiosk shows the model anyway.
            c.problems.extend(warnings.iter().map(|w| (false, format!("model {w}"))));
            // In the model's coordinates, those of graph.xml's views.
            let b = store.bbox();
            let (lo, hi) = (store.origin() + b.min.as_dvec3(), store.origin() + b.max.as_dvec3());
            let name = name.unwrap_or_default();
            c.sound.push(format!(
                "model {}: {} samples at full resolution, {} nodes, {} levels; x {:.3} to {:.3}, y {:.3} to \
                 {:.3}, z {:.3} to {:.3}",
                name,
                h.leaf_point_count,
                h.node_count,
                store.levels(),
                lo.x,
                hi.x,
                lo.y,
                hi.y,
                lo.z,
                hi.z
            ));
            if full {
                let bad: Vec<String> = store.failing_nodes().map(|(_, e)| e.to_string()).collect();
                match bad.first() {
                    None => c.sound.push(format!("every node's checksum matches ({} nodes)", h.node_count)),
                    Some(first) => c.problems.push((
                        true,
                        format!(
                            "model {name}: {first} ({} node(s) fail their check; the kiosk draws their ancestors)",
                            bad.len()
                        ),
                    )),
                }
            }
        }
        Err(e) => {
            // A folder of exhibits given for one: say which to check.
            let inside: Vec<String> = std::fs::read_dir(dir)
                .into_iter()
                .flatten()
                .flatten()
                .filter(|d| exhibit::model_file(&d.path()).is_ok())
                .map(|d| d.file_name().to_string_lossy().into_owned())
                .collect();
            let hint = if inside.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} holds exhibits: {}; check them with `kiosk check {}/*`)",
                    dir.display(),
                    inside.join(", "),
                    dir.display()
                )
            };
            c.problems.push((true, format!("model: {e:#}; the kiosk leaves this exhibit out{hint}")));
        }
    }
    // Every problem of exhibit.toml (the kiosk would leave that key at its default), and the pose
    // the kiosk shows the model in.
    let settings = exhibit::exhibit_settings(dir);
    let pose = settings.pose.to_toml();
    c.sound.push(format!(
        "pose: {}",
        pose.lines().filter(|l| !l.starts_with('#')).collect::<Vec<_>>().join(", ")
    ));
    c.problems.extend(settings.messages().into_iter().map(|m| (true, m)));
    let graph_file = dir.join("graph.xml");
    if !graph_file.exists() {
        c.sound.push("no graph.xml: the model without a story".into());
        return c;
    }
    let read = exhibit::read_story(&graph_file).map_err(|e| format!("{e:#}"));
    let parsed =
        read.and_then(|t| InfoGraph::from_xml(&t).map_err(|e| format!("{}: {e}", graph_file.display())));
    let (graph, problems) = match parsed {
        Ok(g) => g,
        Err(e) => {
            let e = format!("{e}; the kiosk shows the model without its story");
            c.problems.push((true, e));
            return c;
        }
    };
    let langs: std::collections::BTreeSet<&String> =
        graph.nodes.iter().flat_map(|n| n.title.0.keys()).collect();
    c.sound.push(format!(
        "story: {} nodes, {} edges, languages {}",
        graph.nodes.len(),
        graph.edges.len(),
        langs.into_iter().map(String::as_str).collect::<Vec<_>>().join(", ")
    ));
    // A dropped node or edge, an ignored light, box or path, and a node that can never be shown
    // (a cycle of mandatory edges) are left out; a clamped importance or a cut text are shown as
    // corrected.
    let never: std::collections::BTreeSet<&str> =
        graph.never_shown().into_iter().map(|i| graph.nodes[i].id.as_str()).collect();
    for p in problems {
        let never_shown = p.node.as_deref().is_some_and(|id| never.contains(id));
        let left_out = p.dropped || p.msg.ends_with("; ignored") || never_shown;
        c.problems.push((left_out, format!("{}: {p}", graph_file.display())));
    }
    // Every media file opened as the kiosk opens it (images decoded, narrations decoded whole):
    // one it cannot use, it leaves out.
    let (mut images, mut narrations) = (BTreeMap::new(), 0);
    for n in &graph.nodes {
        let files = n.overlay.0.values().chain(&n.thumbnail).chain(&n.roi_mask).map(|f| (f, false));
        for (rel, narration) in files.chain(n.narration.0.values().map(|f| (f, true))) {
            // The decoders' errors name the whole path; the exhibit's own path says it here.
            let opened = crate::media::resolve(dir, rel).and_then(|path| {
                let own =
                    |e: String, prefix: String| e.strip_prefix(&prefix).map_or(e.clone(), str::to_string);
                if narration {
                    let decoded = crate::audio::decode(&path);
                    decoded
                        .map(|_| narrations += 1)
                        .map_err(|e| own(e, format!("narration {}: ", path.display())))
                } else {
                    let img = crate::media::read_image(&path)
                        .map_err(|e| own(e, format!("{}: ", path.display())))?;
                    images.insert(rel.clone(), img.dimensions());
                    Ok(())
                }
            });
            if let Err(e) = opened {
                let what = if narration { "narration" } else { "image" };
                c.problems
                    .push((true, format!("{}: node '{}': {what} {rel}: {e}", graph_file.display(), n.id)));
            }
        }
    }
    // What the kiosk shows anyway: an overlay at another aspect than the view's.
    let sized = |rel: &str| Ok(images.get(rel).copied());
    for p in graph.check_files(exhibit::VIEW_ASPECT, &sized) {
        c.problems.push((false, format!("{}: {p}", graph_file.display())));
    }
    c.sound.push(format!("{} image(s) and {narrations} narration(s) open", images.len()));
    c
}
