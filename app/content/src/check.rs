//! `kiosk check`: everything the kiosk would load of an exhibit, checked without a window, a GPU
//! or an audio device — the model (imported into the cache if it is a scan, as at the kiosk's
//! first start; every node's checksum with `full`), its pose, its story and its media, and
//! every narration decoded. The kiosk logs the same problems when it loads the exhibit, and
//! leaves out what they name; here a technician or a curator sees them all before a visitor does.

use crate::exhibit;
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
    match exhibit::open_model_in(dir, cache) {
        Ok(store) => {
            let h = *store.header();
            let name = exhibit::model_file(dir)
                .ok()
                .and_then(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()));
            c.sound.push(format!(
                "model {}: {} samples at full resolution, {} nodes, {} levels",
                name.unwrap_or_default(),
                h.leaf_point_count,
                h.node_count,
                store.levels()
            ));
            if full {
                let bad: Vec<String> = (0..store.nodes().len() as u32)
                    .filter_map(|id| store.verify_node(id).err().map(|e| e.to_string()))
                    .collect();
                match bad.first() {
                    None => c.sound.push(format!("every node's checksum matches ({} nodes)", h.node_count)),
                    Some(first) => c.problems.push((
                        true,
                        format!(
                            "model: {first} ({} node(s) fail their check; the kiosk draws their ancestors)",
                            bad.len()
                        ),
                    )),
                }
            }
        }
        Err(e) => c.problems.push((true, format!("model: {e:#}"))),
    }
    match exhibit::model_pose(dir) {
        Ok(pose) => c.sound.push(format!(
            "pose: {}",
            pose.to_toml().lines().filter(|l| !l.starts_with('#')).collect::<Vec<_>>().join(", ")
        )),
        Err(e) => c.problems.push((true, format!("{e:#}"))),
    }
    let graph_file = dir.join("graph.xml");
    match exhibit::open_graph(dir) {
        Ok(None) => c.sound.push("no graph.xml: the model without a story".into()),
        Ok(Some((graph, problems))) => {
            let mut langs = std::collections::BTreeSet::new();
            for n in &graph.nodes {
                langs.extend(n.title.0.keys().cloned());
            }
            c.sound.push(format!(
                "story: {} nodes, {} edges, languages {}",
                graph.nodes.len(),
                graph.edges.len(),
                langs.into_iter().collect::<Vec<_>>().join(", ")
            ));
            for p in problems {
                c.problems.push((p.dropped, format!("{}: {p}", graph_file.display())));
            }
            let mut decoded = 0;
            for n in &graph.nodes {
                for rel in n.narration.0.values() {
                    // A path that cannot be used is among the problems above already.
                    let Ok(path) = crate::media::resolve(dir, rel) else { continue };
                    match crate::audio::decode(&path) {
                        Ok(_) => decoded += 1,
                        Err(e) => {
                            c.problems.push((true, format!("{}: node '{}': {e}", graph_file.display(), n.id)))
                        }
                    }
                }
            }
            c.sound.push(format!("{decoded} narration(s) decode"));
        }
        Err(e) => c.problems.push((true, format!("{e:#}; the kiosk shows the model without its story"))),
    }
    c
}
