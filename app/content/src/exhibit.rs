//! Exhibits on disk: a directory holding a model, as a store (`*.kstore`) or a scan
//! (`*.ply`, `*.ply.gz`, `*.obj`, `*.glb`, `*.gltf`, `*.las`, `*.laz`, `*.e57`) that is imported
//! on first use into a cache.

use crate::MappedStore;
use crate::import::{ImportOptions, OutputLock, import_locked};
use anyhow::Context;
use std::path::{Path, PathBuf};

/// The endings of the scans an exhibit may hold instead of a store.
const SCANS: [&str; 9] = [".ply", ".ply.gz", ".obj", ".obj.gz", ".glb", ".gltf", ".las", ".laz", ".e57"];

/// The endings of the survey scans among [`SCANS`] (Z-up by default: [`default_up`]).
const SURVEYS: [&str; 3] = [".las", ".laz", ".e57"];

/// A file's name in lower case ("" without one).
fn lower_name(p: &Path) -> String {
    p.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase()
}

/// A file's name as it is (its whole path without one).
fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// A file's modification time in nanoseconds since the epoch, where the system gives one.
fn modified_nanos(meta: &std::fs::Metadata) -> Option<u128> {
    Some(meta.modified().ok()?.duration_since(std::time::UNIX_EPOCH).ok()?.as_nanos())
}

/// Whether `p` names a scan an exhibit can show (not a hidden file: `._bust.obj`, left by macOS
/// on a USB stick, is not a model).
fn is_scan(p: &Path) -> bool {
    let name = lower_name(p);
    !name.starts_with('.') && SCANS.iter().any(|e| name.ends_with(e))
}

/// Finds the model of an exhibit directory: its store if it has one (a store beside the scan it
/// was made from comes first), else its scan. Two stores, or two scans and no store, are an error
/// that names them: the kiosk would not know which to show.
pub fn model_file(dir: &Path) -> anyhow::Result<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read exhibit directory {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    let name = |p: &PathBuf| lower_name(p);
    // Hidden files (`._bust.obj`, left by macOS on a USB stick) are not models.
    let entries: Vec<&PathBuf> = entries.iter().filter(|p| !name(p).starts_with('.')).collect();
    let stores: Vec<&PathBuf> = entries.iter().copied().filter(|p| name(p).ends_with(".kstore")).collect();
    let scans: Vec<&PathBuf> = entries.iter().copied().filter(|p| is_scan(p)).collect();
    let (found, what) = if stores.is_empty() { (scans, "scans") } else { (stores, "stores") };
    match found[..] {
        [one] => Ok(one.clone()),
        [] => anyhow::bail!(
            "{}: no model (*.kstore, *.ply, *.ply.gz, *.obj, *.obj.gz, *.glb, *.gltf, *.las, *.laz or *.e57)",
            dir.display()
        ),
        _ => anyhow::bail!(
            "{}: {} {what} ({}): an exhibit shows one model; move the others out",
            dir.display(),
            found.len(),
            found.iter().map(|p| name(p)).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// A warning when a scan beside the exhibit's `store` was changed after it: the kiosk shows the
/// store (an older import), not the scan a curator just edited.
fn stale_store(dir: &Path, store: &Path) -> Vec<String> {
    let modified = |p: &Path| std::fs::metadata(p).ok().as_ref().and_then(modified_nanos);
    let Some(made) = modified(store) else { return Vec::new() };
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut newer: Vec<String> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| is_scan(p))
        .filter(|p| modified(p).is_some_and(|m| m > made))
        .map(|p| file_name(&p))
        .collect();
    newer.sort();
    newer
        .into_iter()
        .map(|scan| {
            format!(
                "{}: older than the scan {scan} beside it, which the kiosk does not show: import the scan \
                 again into the store (kiosk import), or remove the store",
                file_name(store)
            )
        })
        .collect()
}

/// Opens an exhibit's model, importing a scan into the cache ([`cache_dir`]) when needed (see
/// [`cache_name`]: an edited scan, other settings or a new builder import it again).
pub fn open_model(dir: &Path) -> anyhow::Result<MappedStore> {
    open_model_in(dir, &cache_dir())
}

/// [`open_model`] with the cache in `cache`. The store made from a scan replaces the cache's
/// stores of earlier versions of that scan ([`sweep_cache`]). The reader's warnings of the scan
/// are logged, whether it was imported now or before.
pub fn open_model_in(dir: &Path, cache: &Path) -> anyhow::Result<MappedStore> {
    let (store, warnings) = open_model_warned(dir, cache, &mut |_| {})?;
    log_warnings(dir, &warnings);
    Ok(store)
}

/// Logs the reader's `warnings` of the exhibit `dir`'s scan ([`open_model_warned`]).
pub fn log_warnings(dir: &Path, warnings: &[String]) {
    for warning in warnings {
        tracing::warn!("exhibit {}: {warning}", dir.display());
    }
}

/// [`open_model_in`] without logging the reader's warnings: the store, and what the reader warned
/// of when it imported the scan, a line each starting with the scan's file name (kept beside the
/// cached store: every start and `kiosk check` name them, not only the first; none for a store,
/// or for a scan an older kiosk cached). Each line the import logs is also given to `progress`
/// (the kiosk shows the last one while it prepares).
pub fn open_model_warned(
    dir: &Path,
    cache: &Path,
    progress: &mut dyn FnMut(&str),
) -> anyhow::Result<(MappedStore, Vec<String>)> {
    open_model_or_not(dir, cache, Some(progress))?
        .ok_or_else(|| anyhow::anyhow!("exhibit {}: its scan was not imported", dir.display()))
}

/// [`open_model_warned`] when the model opens at once (a store, or a scan whose cached store is
/// up to date); `None` when its scan has to be imported first. The kiosk opens its gallery with
/// these while it imports the others.
pub fn open_model_cached(dir: &Path, cache: &Path) -> anyhow::Result<Option<(MappedStore, Vec<String>)>> {
    open_model_or_not(dir, cache, None)
}

/// [`open_model_warned`], importing only when given where the import's lines go.
fn open_model_or_not(
    dir: &Path,
    cache: &Path,
    import: Option<&mut dyn FnMut(&str)>,
) -> anyhow::Result<Option<(MappedStore, Vec<String>)>> {
    let file = model_file(dir)?;
    if file.extension().is_some_and(|e| e.eq_ignore_ascii_case("kstore")) {
        return Ok(Some((crate::open_store(&file)?, stale_store(dir, &file))));
    }
    // Whatever the working directory, so that the files it names are noted by the same paths by
    // every program sharing the cache (the kiosk, `kiosk check`, the authoring tool).
    let file = file.canonicalize().unwrap_or(file);
    // What the exhibit's file could give; the kiosk and the checker name its problems.
    let options = exhibit_settings(dir).import_options();
    let name = cache_name(&file, &options, kiosk_import::BUILDER_REVISION)?;
    std::fs::create_dir_all(cache).with_context(|| format!("cannot create the cache {}", cache.display()))?;
    let store = cache.join(name);
    // A cached store is used while the files its scan names (textures, material libraries,
    // buffers) are as they were.
    let cached = || {
        crate::open_store(&store)
            .ok()
            .filter(|_| Inputs::unchanged(&store))
            .map(|s| (s, read_warnings(&store)))
    };
    let opened = match cached() {
        Some(s) => s,
        None => {
            let Some(progress) = import else { return Ok(None) };
            // Another kiosk or replay may be importing the same scan: wait for it, then use its
            // store.
            let lock = match OutputLock::try_acquire(&store)? {
                Some(lock) => lock,
                None => {
                    // The lock logs that it waits; the kiosk's window says it too.
                    progress(&format!(
                        "exhibit {}: another program (a kiosk, `kiosk check`, the authoring tool) is importing \
                         {} into the cache; waiting for it",
                        dir.display(),
                        file.display()
                    ));
                    OutputLock::acquire(&store)?
                }
            };
            match cached() {
                Some(s) => s,
                None => {
                    let started = std::time::SystemTime::now();
                    let report = import_logged(dir, &file, cache, &lock, &options, progress)?;
                    // Before the note that makes the store count as cached.
                    write_warnings(&store, &report.warnings);
                    Inputs::note(&store, &report.inputs, started);
                    (crate::open_store(&store)?, report.warnings)
                }
            }
        }
    };
    let source = file;
    if let Err(e) = std::fs::write(store.with_extension(SOURCE), source.to_string_lossy().as_bytes()) {
        tracing::warn!("cannot note the scan of {} in the cache: {e}", store.display());
    }
    sweep_cache(cache, &store, &source);
    let (opened, warnings) = opened;
    let name = file_name(&source);
    Ok(Some((opened, warnings.into_iter().map(|w| format!("{name}: {w}")).collect())))
}

/// Imports the scan `file` of the exhibit `dir` into the store of `cache` that `lock` holds,
/// logging what it does (a large scan takes minutes), each line also given to `also`.
fn import_logged(
    dir: &Path,
    file: &Path,
    cache: &Path,
    lock: &OutputLock,
    options: &ImportOptions,
    also: &mut dyn FnMut(&str),
) -> anyhow::Result<crate::import::ImportReport> {
    let label = format!("exhibit {}: importing {}", dir.display(), file_name(file));
    tracing::info!(
        "exhibit {}: importing {} into the cache {} (not in the cache or unreadable there, or the scan, a \
         file it names, its settings or the kiosk changed; a large scan takes minutes)",
        dir.display(),
        file.display(),
        cache.display()
    );
    also(&label);
    let report = {
        let mut progress = crate::import::logged(label.clone(), std::time::Duration::from_secs(10), also);
        import_locked(file, lock, options, &mut progress)?
    };
    let done = format!("{label}: done, {report}");
    tracing::info!("{done}");
    also(&done);
    Ok(report)
}

/// Ending of the note beside each cached store of its reader's warnings (JSON, a string each).
const WARNINGS: &str = "warnings";

/// Notes the reader's `warnings` beside the cached `store` (no note when there are none).
fn write_warnings(store: &Path, warnings: &[String]) {
    let path = store.with_extension(WARNINGS);
    let _ = std::fs::remove_file(&path);
    if warnings.is_empty() {
        return;
    }
    let written =
        serde_json::to_string(warnings).map_err(std::io::Error::other).and_then(|t| std::fs::write(&path, t));
    if let Err(e) = written {
        tracing::warn!("cannot note the reader's warnings of {} in the cache: {e}", store.display());
    }
}

/// The reader's warnings noted beside the cached `store` (none without a note; an unreadable
/// note is one warning that says so).
fn read_warnings(store: &Path) -> Vec<String> {
    let path = store.with_extension(WARNINGS);
    match std::fs::read_to_string(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => vec![format!("the note of the reader's warnings {} cannot be read: {e}", path.display())],
        Ok(text) => serde_json::from_str(&text).unwrap_or_else(|e| {
            vec![format!("the note of the reader's warnings {} cannot be read: {e}", path.display())]
        }),
    }
}

/// Ending of the note beside each cached store that names the scan it was made from.
const SOURCE: &str = "source";

/// The note beside each cached store (`NAME.inputs`) of the other files its scan named when it
/// was imported: each one's size and modification time, or that it was missing. The scan's own
/// are in the store's name ([`cache_name`]).
#[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
struct Inputs(Vec<(PathBuf, Option<(u64, u128)>)>);

impl Inputs {
    const ENDING: &str = "inputs";

    fn of(paths: &[PathBuf]) -> Self {
        let stamp = |p: &Path| {
            let meta = std::fs::metadata(p).ok()?;
            Some((meta.len(), modified_nanos(&meta)?))
        };
        Self(paths.iter().map(|p| (p.clone(), stamp(p))).collect())
    }

    /// Writes the note of the store `store`, imported from `started` on. A file changed since
    /// then may have been read before or after its change: no note, so the next start imports
    /// again.
    fn note(store: &Path, paths: &[PathBuf], started: std::time::SystemTime) {
        let noted = Self::of(paths);
        let since = started.duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        let path = store.with_extension(Self::ENDING);
        let _ = std::fs::remove_file(&path);
        if let Some((p, _)) = noted.0.iter().find(|(_, s)| s.is_some_and(|(_, t)| t >= since)) {
            tracing::info!(
                "cache: {} changed during the import of {}; it is imported again next time",
                p.display(),
                store.display()
            );
            return;
        }
        let written = serde_json::to_string(&noted)
            .map_err(std::io::Error::other)
            .and_then(|t| std::fs::write(&path, t));
        if let Err(e) = written {
            tracing::warn!(
                "cannot note the inputs of {} in the cache ({e}): it is imported again next time",
                store.display()
            );
        }
    }

    /// Whether every file the note beside `store` lists is as it was (a store without a note,
    /// from an older kiosk, counts as changed).
    fn unchanged(store: &Path) -> bool {
        let Ok(text) = std::fs::read_to_string(store.with_extension(Self::ENDING)) else { return false };
        let Ok(noted) = serde_json::from_str::<Self>(&text) else { return false };
        let paths: Vec<PathBuf> = noted.0.iter().map(|(p, _)| p.clone()).collect();
        let same = Self::of(&paths) == noted;
        if !same {
            tracing::info!("cache: a file {} was made from has changed; importing again", store.display());
        }
        same
    }
}

/// Removes from `cache` the stores made from earlier versions of the scan `source` (edited, other
/// settings, an older builder) and from scans that no longer exist, with their notes and locks;
/// `keep` stays. Without it, every edit of a billion-point scan would leave its old store on the
/// disk for good. A store whose lock another process holds (it is being imported) is left, as
/// are stores without a note (made by an older kiosk: the technician may remove them).
pub fn sweep_cache(cache: &Path, keep: &Path, source: &Path) {
    let source = source.to_string_lossy();
    for entry in std::fs::read_dir(cache).into_iter().flatten().flatten() {
        let note = entry.path();
        if note.extension().is_none_or(|e| e != SOURCE) {
            continue;
        }
        let store = note.with_extension("kstore");
        let Ok(named) = std::fs::read_to_string(&note) else { continue };
        let stale = named == source || !Path::new(&named).exists();
        if store == keep || !stale {
            continue;
        }
        let Ok(Some(lock)) = OutputLock::try_acquire(&store) else { continue };
        match std::fs::remove_file(&store) {
            Ok(()) => {
                tracing::info!("cache: removed {} (made from {named}, now replaced or gone)", store.display())
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => {
                tracing::warn!("cache: cannot remove {}: {e}", store.display());
                continue;
            }
        }
        let _ = std::fs::remove_file(&note);
        let _ = std::fs::remove_file(store.with_extension(Inputs::ENDING));
        let _ = std::fs::remove_file(store.with_extension(WARNINGS));
        let _ = std::fs::remove_file(lock.lock_file());
    }
}

/// Where stores imported from scans are kept across restarts (a reboot must not cost a
/// billion-point import): `$ISOKIOSK_CACHE`, else `$XDG_CACHE_HOME/isokiosk`, else
/// `~/.cache/isokiosk`, else the temporary directory.
pub fn cache_dir() -> PathBuf {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("ISOKIOSK_CACHE")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("isokiosk")))
        .or_else(|| var("HOME").map(|d| d.join(".cache/isokiosk")))
        .unwrap_or_else(|| {
            let temp = std::env::temp_dir().join("isokiosk-cache");
            tracing::warn!(
                "no ISOKIOSK_CACHE, XDG_CACHE_HOME or HOME: scans are imported into {}, which a \
                 reboot may clear (set ISOKIOSK_CACHE for a lasting cache)",
                temp.display()
            );
            temp
        })
}

/// The file name of the store cached from the scan `file` (canonical: every program sharing the
/// cache finds the same name): its name and a hash of its path, size
/// and modification time, the readers' and the builder's settings, the importer's `revision`
/// and the store format's version — a store made otherwise is not reused.
fn cache_name(file: &Path, options: &ImportOptions, revision: u32) -> anyhow::Result<String> {
    let meta = std::fs::metadata(file).with_context(|| format!("cannot read {}", file.display()))?;
    let key = format!(
        "{}-{}-{}-{:?}-{:?}-{revision}-{}",
        file.display(),
        meta.len(),
        modified_nanos(&meta).unwrap_or(0),
        options.build,
        options.read,
        kiosk_core::scene::store::VERSION
    );
    let hash = crc32fast::hash(key.as_bytes());
    let stem = file.file_name().and_then(|n| n.to_str()).unwrap_or("model").replace('.', "_");
    Ok(format!("{stem}-{hash:08x}.kstore"))
}

/// How an exhibit's model stands, from `exhibit.toml` beside it:
///
/// ```toml
/// up = "z"          # its up axis: x, y, z, -x, -y or -z, or [x, y, z] (default z for LAS,
///                   # LAZ and E57 scans, else y)
/// front = "-y"      # the side the kiosk's start view looks at: an axis or [x, y, z]
/// ```
///
/// Together they are the model's rotation, any rotation: `up` says which way is up (a vector for
/// a scan that stands tilted in its file; the authoring tool tilts it degree by degree), `front`
/// turns it about that axis. `up` is made unit, `front` perpendicular to `up` and unit (default:
/// [`kiosk_core::camera::default_front`]). No file, or no `up`: +Z up for a LAS, LAZ or E57
/// scan, +Y for the rest, and the default front. A key that cannot be taken is that default,
/// beside a problem naming the file and the key ([`exhibit_settings`]). The store is not turned:
/// the kiosk's camera, its start view and IsoCam's up vector follow the pose, so a changed pose
/// needs no new import.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelPose {
    /// The model's up direction (unit).
    pub up: glam::DVec3,
    /// The side the start view looks at (unit, perpendicular to `up`), if the exhibit says.
    pub front: Option<glam::DVec3>,
}

impl ModelPose {
    /// `exhibit.toml`'s text for this pose (an axis by its name, another direction as a vector
    /// that reads back exactly).
    pub fn to_toml(&self) -> String {
        let direction = |d: glam::DVec3| match named_axis(d) {
            Some((n, _)) => format!("\"{n}\""),
            None => format!("[{}, {}, {}]", d.x, d.y, d.z),
        };
        let mut text = format!(
            "# The model's up direction: x, y, z, -x, -y, -z or [x, y, z].\nup = {}\n",
            direction(self.up)
        );
        if let Some(f) = self.front {
            text += "# The side the kiosk's start view looks at (an axis, or [x, y, z]).\n";
            text += &format!("front = {}\n", direction(f));
        }
        text
    }

    /// The up direction `up` unit, or an axis when it is one to within rounding (a file's
    /// decimals): `None` for a zero or non-finite vector. A vector unit to within rounding is
    /// kept as it is, so that a pose written and read back is the same, bit for bit.
    pub fn unit_up(up: glam::DVec3) -> Option<glam::DVec3> {
        let u = if up.is_finite() && (up.length_squared() - 1.0).abs() < 1e-12 {
            up
        } else {
            scaled(up).try_normalize()?
        };
        Some(named_axis(u).map_or(u, |(_, a)| a))
    }

    /// `front` made perpendicular to `up` and unit; `None` when it is (nearly) along `up`.
    pub fn level(up: glam::DVec3, front: glam::DVec3) -> Option<glam::DVec3> {
        let f = front - up * front.dot(up);
        (f.length() > 0.1 * front.length()).then(|| f.normalize())
    }
}

/// What an exhibit's `exhibit.toml` says: the model's pose and the samples per texel of its
/// import. The file is read key by key: a key that cannot be taken (a misspelt key, a value out
/// of range, an axis that is not one) is left at its default with a problem naming the file and
/// the key, and the other keys still count, so that a curator's typo costs that key alone (a
/// file that is not TOML at all costs every key). No file: every default, no problem.
#[derive(Debug)]
pub struct ExhibitSettings {
    /// The model's pose ([`ModelPose`]).
    pub pose: ModelPose,
    /// Samples per texel of a textured model's import, if the file sets them (see
    /// [`import_options`]).
    pub texel_density: Option<f32>,
    /// What could not be taken: what each problem is about, and why (naming the file and the
    /// key).
    pub problems: Vec<(Setting, anyhow::Error)>,
}

/// What a problem of `exhibit.toml` is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setting {
    /// The file as a whole (unreadable, or not TOML): every key at its default.
    File,
    /// A key it does not know: ignored.
    Unknown,
    /// `up`.
    Up,
    /// `front`.
    Front,
    /// `texel_density`.
    TexelDensity,
}

impl ExhibitSettings {
    /// How the kiosk imports the exhibit's scan with these settings.
    pub fn import_options(&self) -> ImportOptions {
        let mut options = ImportOptions::default();
        if let Some(d) = self.texel_density {
            options.read.texel_density = d;
        }
        options
    }

    /// Each problem with what the kiosk does about it, for a log or a list.
    pub fn messages(&self) -> Vec<String> {
        let up = up_label(self.pose.up);
        let message = |(about, e): &(Setting, anyhow::Error)| match about {
            Setting::File => format!("{e:#}; every setting at its default ({up} up)"),
            Setting::Unknown => format!("{e:#}"),
            Setting::Up | Setting::Front => format!("{e:#}; the model is shown with {up} up"),
            Setting::TexelDensity => format!("{e:#}; imported at the default samples per texel"),
        };
        self.problems.iter().map(message).collect()
    }

    /// The settings, or the first problem of the file that is about one of `settings` (or the
    /// file, or a key it does not know).
    fn strict(self, settings: &[Setting]) -> anyhow::Result<Self> {
        let relevant =
            |about: &Setting| matches!(about, Setting::File | Setting::Unknown) || settings.contains(about);
        match self.problems.into_iter().find(|(about, _)| relevant(about)) {
            Some((_, e)) => Err(e),
            None => Ok(Self { problems: Vec::new(), ..self }),
        }
    }
}

/// A direction as `exhibit.toml` writes it.
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum Direction {
    Axis(String),
    Vector([f64; 3]),
}

/// The keys `exhibit.toml` may hold.
const KEYS: [&str; 3] = ["up", "front", "texel_density"];

/// Reads an exhibit directory's `exhibit.toml` ([`ExhibitSettings`]).
pub fn exhibit_settings(dir: &Path) -> ExhibitSettings {
    let path = dir.join("exhibit.toml");
    let (table, unread) = read_table(&path);
    let mut problems: Vec<_> = unread.into_iter().map(|e| (Setting::File, e)).collect();
    for key in table.keys().filter(|k| !KEYS.contains(&k.as_str())) {
        problems.push((
            Setting::Unknown,
            anyhow::anyhow!(
                "{}: unknown key `{key}` (the keys are up, front and texel_density); ignored",
                path.display()
            ),
        ));
    }
    let given = |key: &str| table.get(key);
    let up = taken(Setting::Up, given("up").map(|v| up_of(&path, v)), &mut problems)
        .unwrap_or_else(|| default_up(dir));
    let front = taken(Setting::Front, given("front").map(|v| front_of(&path, v, up)), &mut problems);
    let density = given("texel_density").map(|v| density_of(&path, v));
    let texel_density = taken(Setting::TexelDensity, density, &mut problems);
    ExhibitSettings { pose: ModelPose { up, front }, texel_density, problems }
}

/// The keys of the TOML file `path`: none when it is missing, none beside the error when it
/// cannot be read or is not TOML.
fn read_table(path: &Path) -> (toml::Table, Option<anyhow::Error>) {
    let parsed = match std::fs::read_to_string(path) {
        Ok(text) => toml::from_str::<toml::Table>(&text)
            .map_err(|e| anyhow::Error::new(e).context(format!("{}", path.display()))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(toml::Table::new()),
        Err(e) => Err(anyhow::Error::new(e).context(format!("cannot read {}", path.display()))),
    };
    match parsed {
        Ok(table) => (table, None),
        Err(e) => (toml::Table::new(), Some(e)),
    }
}

/// The value of a key that was given and could be taken; a problem for one that could not.
fn taken<T>(
    about: Setting,
    given: Option<anyhow::Result<T>>,
    problems: &mut Vec<(Setting, anyhow::Error)>,
) -> Option<T> {
    given?.map_err(|e| problems.push((about, e))).ok()
}

/// An axis by its name in `exhibit.toml`.
fn axis(path: &Path, key: &str, name: &str) -> anyhow::Result<glam::DVec3> {
    // `Z` as `z`: spreadsheets and scanners' software write axes in capitals.
    match UP_AXES.iter().find(|(n, _)| n.eq_ignore_ascii_case(name.trim())) {
        Some((_, axis)) => Ok(*axis),
        None => {
            anyhow::bail!("{}: {key} = {name:?}: must be x, y, z, -x, -y, -z or [x, y, z]", path.display())
        }
    }
}

/// A direction of `exhibit.toml`, as written: an axis, or a vector.
fn direction(path: &Path, key: &str, value: &toml::Value) -> anyhow::Result<glam::DVec3> {
    match value.clone().try_into::<Direction>() {
        Ok(Direction::Axis(name)) => axis(path, key, &name),
        Ok(Direction::Vector(v)) => Ok(glam::DVec3::from_array(v)),
        Err(_) => {
            anyhow::bail!("{}: {key} = {value}: must be x, y, z, -x, -y, -z or [x, y, z]", path.display())
        }
    }
}

/// `up` of `exhibit.toml`, unit.
fn up_of(path: &Path, value: &toml::Value) -> anyhow::Result<glam::DVec3> {
    let v = direction(path, "up", value)?;
    ModelPose::unit_up(v)
        .with_context(|| format!("{}: up = {v}: a direction, not zero or infinite", path.display()))
}

/// `front` of `exhibit.toml`, levelled to `up`.
fn front_of(path: &Path, value: &toml::Value, up: glam::DVec3) -> anyhow::Result<glam::DVec3> {
    let v = direction(path, "front", value)?;
    let scaled = scaled(v);
    anyhow::ensure!(
        scaled.is_finite() && scaled.length() > 0.0,
        "{}: front = {v}: a direction, not zero or infinite",
        path.display()
    );
    ModelPose::level(up, scaled).with_context(|| {
        format!("{}: front = {v}: along the up axis; the front is a side of the model", path.display())
    })
}

/// `texel_density` of `exhibit.toml`.
fn density_of(path: &Path, value: &toml::Value) -> anyhow::Result<f32> {
    let d = match value {
        toml::Value::Float(f) => *f as f32,
        toml::Value::Integer(i) => *i as f32,
        _ => f32::NAN,
    };
    anyhow::ensure!(
        kiosk_import::ReadOptions::texel_density_ok(d),
        "{}: texel_density = {value}: samples per texel, more than 0 and at most 64",
        path.display()
    );
    Ok(d)
}

/// How the kiosk imports an exhibit's scan: the default settings of `kiosk import`, but for the
/// samples per texel of a textured model, which `exhibit.toml` may set (`texel_density = 0.5`:
/// one sample per 2 × 2 texels, for an atlas finer than the kiosk needs; more than 0, at most
/// 64). A changed setting imports the scan again. A problem of the file that is about the
/// density (or the file, or a key it does not know) is an error (the kiosk itself imports with
/// what [`exhibit_settings`] could take).
pub fn import_options(dir: &Path) -> anyhow::Result<ImportOptions> {
    Ok(exhibit_settings(dir).strict(&[Setting::TexelDensity])?.import_options())
}

/// `exhibit.toml`'s text for `pose`, keeping every other key the exhibit's file has as it has it
/// (the authoring tool rewrites the pose alone; a key the kiosk cannot take stays for the curator
/// to mend). A file that is not TOML keeps nothing but the pose.
pub fn exhibit_toml(dir: &Path, pose: &ModelPose) -> String {
    let mut text = pose.to_toml();
    let (mut rest, _) = read_table(&dir.join("exhibit.toml"));
    rest.retain(|key, _| key != "up" && key != "front");
    if let Some(rest) = toml::to_string(&rest).ok().filter(|r| !r.is_empty()) {
        text += "# The exhibit's other settings (texel_density: samples per texel of its textures).\n";
        text += &rest;
    }
    text
}

/// Reads [`ModelPose`] from an exhibit directory's `exhibit.toml`; a problem of the file that is
/// about the pose (or the file, or a key it does not know) is an error (the kiosk and the
/// authoring tool show the model in [`exhibit_settings`]'s pose, with what the file could give,
/// beside the problems).
pub fn model_pose(dir: &Path) -> anyhow::Result<ModelPose> {
    Ok(exhibit_settings(dir).strict(&[Setting::Up, Setting::Front])?.pose)
}

/// The named axis `d` is, to within rounding.
fn named_axis(d: glam::DVec3) -> Option<(&'static str, glam::DVec3)> {
    UP_AXES.iter().copied().find(|(_, a)| a.abs_diff_eq(d, 1e-12))
}

/// `v` divided by its largest component, so that a long vector's length does not overflow (zero
/// and non-finite vectors come out non-finite).
fn scaled(v: glam::DVec3) -> glam::DVec3 {
    v / v.abs().max_element()
}

/// The up axis of a model whose `exhibit.toml` does not say: +Z for a survey scan (LAS, LAZ,
/// E57: their Z is the height, by their specifications and in practice), +Y for the rest (glTF's
/// own convention, and most mesh exports).
fn default_up(dir: &Path) -> glam::DVec3 {
    if model_file(dir).is_ok_and(|p| stands_on_z(&p)) { glam::DVec3::Z } else { glam::DVec3::Y }
}

/// Whether a scan stands on Z when its exhibit does not say (LAS, LAZ, E57). A store does not
/// keep its scan's format: an exhibit showing a store made from one needs `up = "z"`.
pub fn stands_on_z(scan: &Path) -> bool {
    SURVEYS.iter().any(|e| lower_name(scan).ends_with(e))
}

/// The name of an up axis in messages: "+Z", "-Y"; other directions as vectors.
pub fn up_label(up: glam::DVec3) -> String {
    match named_axis(up) {
        Some((name, _)) if name.starts_with('-') => name.to_uppercase(),
        Some((name, _)) => format!("+{}", name.to_uppercase()),
        None => format!("{up}"),
    }
}

/// The up direction of an exhibit's model ([`model_pose`]'s `up`).
pub fn model_up(dir: &Path) -> anyhow::Result<glam::DVec3> {
    Ok(model_pose(dir)?.up)
}

/// The axes a model's up (and front) may be named by in `exhibit.toml`.
pub const UP_AXES: [(&str, glam::DVec3); 6] = [
    ("y", glam::DVec3::Y),
    ("z", glam::DVec3::Z),
    ("x", glam::DVec3::X),
    ("-y", glam::DVec3::NEG_Y),
    ("-z", glam::DVec3::NEG_Z),
    ("-x", glam::DVec3::NEG_X),
];

/// Reads an exhibit's information graph (`graph.xml`), if it has one. Problems are returned
/// alongside (the kiosk logs them and shows the rest); an unreadable graph is an error.
pub fn open_graph(
    dir: &Path,
) -> anyhow::Result<Option<(kiosk_core::graph::InfoGraph, Vec<kiosk_core::graph::Problem>)>> {
    let path = dir.join("graph.xml");
    if !path.exists() {
        return Ok(None);
    }
    let text = read_story(&path)?;
    let (graph, mut problems) =
        kiosk_core::graph::InfoGraph::from_xml(&text).with_context(|| format!("{}", path.display()))?;
    problems.extend(graph.check_files(VIEW_ASPECT, &|p: &str| probe_media(dir, p)));
    let mut graph = graph;
    load_roi_masks(dir, &mut graph);
    Ok(Some((graph, problems)))
}

/// A story file's text: UTF-8 (a byte-order mark allowed), and not empty; otherwise an error
/// that says what the file is and what to do (an editor's "Unicode" is UTF-16, an old one's
/// default Latin-1).
pub fn read_story(path: &Path) -> anyhow::Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    if bytes.iter().all(u8::is_ascii_whitespace) {
        anyhow::bail!(
            "{}: the file is empty; a story is an <infograph> element (see content/*/graph.xml)",
            path.display()
        );
    }
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        anyhow::bail!("{}: the file is UTF-16; save it as UTF-8", path.display());
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        anyhow::anyhow!(
            "{}: line {line}: not UTF-8 (byte {at}; a Latin-1 or Windows-1252 accent?): save the file as UTF-8",
            path.display()
        )
    })
}

/// The narration files `paths` name: a file stands for itself, an exhibit directory for every
/// narration its graph.xml names (each language, resolved inside the exhibit), in order, once.
pub fn narration_files(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for p in paths {
        if !p.is_dir() {
            files.push(p.clone());
            continue;
        }
        let (graph, _) = open_graph(p)?.with_context(|| format!("{}: no graph.xml", p.display()))?;
        let mut names = std::collections::BTreeSet::new();
        for node in &graph.nodes {
            for rel in node.narration.0.values() {
                let f = crate::media::resolve(p, rel).map_err(|e| {
                    anyhow::anyhow!("{}: node {}: narration {rel}: {e}", p.display(), node.id)
                })?;
                names.insert(f);
            }
        }
        files.extend(names);
    }
    Ok(files)
}

/// Aspect ratio (width / height) of the projection the views are authored for: overlays and ROI
/// masks are stretched over a view at it.
pub const VIEW_ASPECT: f64 = 16.0 / 9.0;

/// Reads the ROI mask each node names into its [`kiosk_core::graph::Node::roi_bitmap`] (set where
/// luminance > 127 and not transparent, as the authoring tool paints it; downsampled, see
/// [`RoiMask::from_fn`](kiosk_core::graph::RoiMask::from_fn)). A mask that cannot be read leaves
/// the node with its box alone; `check_files` has already reported why.
pub fn load_roi_masks(dir: &Path, graph: &mut kiosk_core::graph::InfoGraph) {
    for n in &mut graph.nodes {
        n.roi_bitmap = n.roi_mask.as_deref().and_then(|rel| {
            let img = crate::media::resolve(dir, rel).and_then(|f| crate::media::read_image(&f)).ok()?;
            roi_bitmap(&img)
        });
    }
}

/// An ROI mask image as the core's bitmap (set where luminance > 127 and alpha > 127).
pub fn roi_bitmap(img: &image::RgbaImage) -> Option<kiosk_core::graph::RoiMask> {
    kiosk_core::graph::RoiMask::from_fn(img.width(), img.height(), VIEW_ASPECT, |x, y| {
        let [r, g, b, a] = img.get_pixel(x, y).0;
        let luma = (299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b)) / 1000;
        luma > 127 && a > 127
    })
}

/// Checks one media file a graph names (see [`crate::media::resolve`]): `Ok(Some((w, h)))` for
/// an image (SVG drawings are drawn at 1280×720), `Ok(None)` for another file, or the reason it
/// cannot be used.
pub fn probe_media(dir: &Path, rel: &str) -> Result<Option<(u32, u32)>, String> {
    let f = crate::media::resolve(dir, rel)?;
    let lower = rel.to_ascii_lowercase();
    if lower.ends_with(".png") || lower.ends_with(".jpg") || lower.ends_with(".jpeg") {
        let (w, h) = image::image_dimensions(&f).map_err(|e| e.to_string())?;
        let max = crate::media::MAX_IMAGE_SIDE;
        if w > max || h > max {
            return Err(format!("{w}×{h} pixels, larger than {max} a side"));
        }
        return Ok(Some((w, h)));
    }
    if crate::media::is_svg(&f) {
        return Ok(Some((1280, 720)));
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_story_saved_empty_or_in_another_encoding_says_what_to_do() {
        let dir = tempfile::tempdir().expect("temp dir");
        let graph = dir.path().join("graph.xml");
        let said = |bytes: &[u8]| {
            std::fs::write(&graph, bytes).expect("write");
            format!("{:#}", open_graph(dir.path()).expect_err("refused"))
        };
        assert!(said(b"").contains("graph.xml: the file is empty"));
        assert!(said(b"\xFF\xFE<\0i\0").contains("graph.xml: the file is UTF-16; save it as UTF-8"));
        let latin1 = b"<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<infograph>\n<title>Caf\xE9</title>";
        assert!(said(latin1).contains("graph.xml: line 3: not UTF-8 (byte 66;"), "{}", said(latin1));
    }

    #[test]
    fn an_exhibit_states_its_models_up_axis() {
        let dir = tempfile::tempdir().expect("temp dir");
        assert_eq!(model_up(dir.path()).expect("no file"), glam::DVec3::Y);
        std::fs::write(dir.path().join("exhibit.toml"), "up = \"z\"\n").expect("write");
        assert_eq!(model_up(dir.path()).expect("z"), glam::DVec3::Z);
        std::fs::write(dir.path().join("exhibit.toml"), "up = \"-Z\"\n").expect("write");
        assert_eq!(model_up(dir.path()).expect("capital Z"), glam::DVec3::NEG_Z);
        std::fs::write(dir.path().join("exhibit.toml"), "up = \"sideways\"\n").expect("write");
        let e = model_up(dir.path()).expect_err("bad axis").to_string();
        assert!(e.contains("exhibit.toml") && e.contains("sideways"), "{e}");
        std::fs::write(dir.path().join("exhibit.toml"), "upp = \"z\"\n").expect("write");
        let e = format!("{:#}", model_up(dir.path()).expect_err("unknown key"));
        assert!(e.contains("exhibit.toml") && e.contains("upp"), "{e}");
    }

    #[test]
    fn an_exhibit_states_the_side_its_start_view_looks_at() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("exhibit.toml");
        assert_eq!(model_pose(dir.path()).expect("no file").front, None);
        std::fs::write(&file, "front = \"-z\"\n").expect("write");
        assert_eq!(model_pose(dir.path()).expect("axis").front, Some(glam::DVec3::NEG_Z));
        // A vector is levelled (made perpendicular to up) and made unit.
        std::fs::write(&file, "up = \"z\"\nfront = [3.0, 0.0, 4.0]\n").expect("write");
        let pose = model_pose(dir.path()).expect("vector");
        assert_eq!((pose.up, pose.front), (glam::DVec3::Z, Some(glam::DVec3::X)));
        // Written back and read again: the same pose.
        let turned = ModelPose { up: glam::DVec3::Y, front: Some(glam::DVec3::new(0.6, 0.0, -0.8)) };
        std::fs::write(&file, turned.to_toml()).expect("write");
        let back = model_pose(dir.path()).expect("read back");
        assert!(back.front.expect("front").abs_diff_eq(turned.front.expect("front"), 1e-12), "{back:?}");
        for (text, says) in [
            ("front = \"y\"\n", "along the up axis"),
            ("front = [0.0, 0.0, 0.0]\n", "not zero"),
            ("front = \"north\"\n", "north"),
        ] {
            std::fs::write(&file, text).expect("write");
            let e = format!("{:#}", model_pose(dir.path()).expect_err(text));
            assert!(e.contains("exhibit.toml") && e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn a_tilted_scan_states_its_up_as_a_vector() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("exhibit.toml");
        // A scan standing 10° off Z: the vector is made unit, the front levelled to it.
        let (s, c) = 10f64.to_radians().sin_cos();
        std::fs::write(&file, format!("up = [{}, 0.0, {}]\nfront = \"-y\"\n", 2.0 * s, 2.0 * c))
            .expect("write");
        let pose = model_pose(dir.path()).expect("a vector up");
        assert!(pose.up.abs_diff_eq(glam::DVec3::new(s, 0.0, c), 1e-12), "{pose:?}");
        assert!(pose.front.expect("front").abs_diff_eq(glam::DVec3::NEG_Y, 1e-12), "{pose:?}");
        // Written back: a vector that reads back exactly; an axis stays an axis by name.
        let tilted = ModelPose { up: glam::DVec3::new(0.1, 0.2, 0.3).normalize(), front: None };
        std::fs::write(&file, tilted.to_toml()).expect("write");
        assert_eq!(model_pose(dir.path()).expect("read back"), tilted);
        assert!(ModelPose { up: glam::DVec3::Z, front: None }.to_toml().contains("up = \"z\""));
        // A vector along an axis to within a file's decimals is that axis; a long one is a
        // direction all the same.
        std::fs::write(&file, "up = [1e-14, 0.0, 1.0]\n").expect("write");
        assert_eq!(model_pose(dir.path()).expect("axis").up, glam::DVec3::Z);
        std::fs::write(&file, "up = [0.0, 0.0, 2.0]\n").expect("write");
        assert_eq!(model_pose(dir.path()).expect("axis").up, glam::DVec3::Z);
        std::fs::write(&file, "up = [0.0, 1e300, 1e300]\nfront = [1e300, 0.0, 0.0]\n").expect("write");
        let pose = model_pose(dir.path()).expect("long vectors");
        assert!(pose.up.abs_diff_eq(glam::DVec3::new(0.0, 1.0, 1.0).normalize(), 1e-12), "{pose:?}");
        assert_eq!(pose.front, Some(glam::DVec3::X));
        for (text, says) in [("up = [0.0, 0.0, 0.0]\n", "not zero"), ("up = [nan, 1.0, 0.0]\n", "not zero")] {
            std::fs::write(&file, text).expect("write");
            let e = format!("{:#}", model_pose(dir.path()).expect_err(text));
            assert!(e.contains("exhibit.toml") && e.contains("up = ") && e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn a_gltf_scan_is_an_exhibits_model_and_a_store_comes_first() {
        let dir = tempfile::tempdir().expect("temp dir");
        let e = model_file(dir.path()).expect_err("empty").to_string();
        assert!(e.contains("*.glb"), "{e}");
        std::fs::write(dir.path().join("scene.bin"), b"").expect("write");
        std::fs::write(dir.path().join("vase.glb"), b"").expect("write");
        // A hidden file beside it (macOS leaves `._NAME` on a USB stick) is not a second model.
        std::fs::write(dir.path().join("._vase.glb"), b"").expect("write");
        assert_eq!(model_file(dir.path()).expect("a glb"), dir.path().join("vase.glb"));
        std::fs::write(dir.path().join("vase.kstore"), b"").expect("write");
        assert_eq!(model_file(dir.path()).expect("a store"), dir.path().join("vase.kstore"));
        // Two stores, or two scans: which one the kiosk would show is not for it to guess.
        std::fs::write(dir.path().join("bust.kstore"), b"").expect("write");
        let e = model_file(dir.path()).expect_err("two stores").to_string();
        assert!(e.contains("2 stores (bust.kstore, vase.kstore)") && e.contains("one model"), "{e}");
        for store in ["bust.kstore", "vase.kstore"] {
            std::fs::remove_file(dir.path().join(store)).expect("remove");
        }
        std::fs::write(dir.path().join("bust.obj"), b"").expect("write");
        let e = model_file(dir.path()).expect_err("two scans").to_string();
        assert!(e.contains("2 scans (bust.obj, vase.glb)"), "{e}");
    }

    #[test]
    fn a_cached_store_is_not_reused_by_other_settings_or_another_builder() {
        let dir = tempfile::tempdir().expect("temp dir");
        let scan = dir.path().join("bust.obj");
        std::fs::write(&scan, "v 0 0 0\nv 1 0 0\n").expect("write");
        let options = ImportOptions::default();
        let name = |o: &ImportOptions, revision| cache_name(&scan, o, revision).expect("a scan");
        let base = name(&options, 2);
        assert!(base.starts_with("bust_obj-") && base.ends_with(".kstore"), "{base}");
        assert_eq!(base, name(&options, 2), "the same scan, settings and builder");
        assert_ne!(base, name(&options, 1), "an earlier builder");
        let mut other = options.clone();
        other.build.node_points *= 2;
        assert_ne!(base, name(&other, 2), "other builder settings");
        let mut other = options.clone();
        other.read.texel_density *= 2.0;
        assert_ne!(base, name(&other, 2), "other reader settings");
        std::fs::write(&scan, "v 0 0 0\nv 1 0 0\nv 0 1 0\n").expect("edit");
        assert_ne!(base, name(&options, 2), "an edited scan");
        let e = cache_name(&dir.path().join("gone.obj"), &options, 2).expect_err("no file");
        assert!(e.to_string().contains("gone.obj"), "{e}");
    }

    /// An exhibit of the textured box (OBJ, MTL, PNG) under `root`, and a cache beside it.
    fn box_exhibit(root: &Path) -> (PathBuf, PathBuf) {
        let (dir, cache) = (root.join("box"), root.join("cache"));
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/formats/box-textured");
        std::fs::create_dir_all(&dir).expect("exhibit dir");
        for f in ["box textured.obj", "box textured.mtl", "Cesium Logo Flat.png"] {
            std::fs::copy(data.join(f), dir.join(f)).expect("copy");
        }
        (dir, cache)
    }

    #[test]
    fn an_exhibit_sets_the_texel_density_of_its_import() {
        let root = tempfile::tempdir().expect("temp dir");
        let (dir, cache) = box_exhibit(root.path());
        let samples = || {
            let store = open_model_in(&dir, &cache).expect("open");
            store.nodes().iter().filter(|n| n.is_leaf()).map(|n| u64::from(n.point_count)).sum::<u64>()
        };
        let default = samples();
        // One sample per 2 × 2 texels: about a quarter of the samples, imported again.
        std::fs::write(dir.join("exhibit.toml"), "texel_density = 0.25\n").expect("write");
        let quarter = samples();
        assert!(quarter * 3 < default && quarter * 5 > default, "{quarter} against {default}");
        // TOML's integers are numbers too; anything out of range is an error naming the key.
        std::fs::write(dir.join("exhibit.toml"), "texel_density = 2\n").expect("write");
        assert_eq!(import_options(&dir).expect("an integer").read.texel_density, 2.0);
        for bad in ["texel_density = 0", "texel_density = 100", "texel_density = \"fine\""] {
            std::fs::write(dir.join("exhibit.toml"), format!("{bad}\n")).expect("write");
            let e = format!("{:#}", import_options(&dir).expect_err(bad));
            assert!(e.contains("exhibit.toml") && e.contains("texel_density"), "{bad}: {e}");
        }
    }

    #[test]
    fn an_edited_texture_or_material_library_imports_the_scan_again() {
        let root = tempfile::tempdir().expect("temp dir");
        let (dir, cache) = box_exhibit(root.path());
        let mean_colour = || {
            let store = open_model_in(&dir, &cache).expect("open");
            let splats: Vec<_> =
                (0..store.nodes().len() as u32).flat_map(|id| store.splats(id).to_vec()).collect();
            let sum = splats.iter().fold([0.0; 3], |a, s| [0, 1, 2].map(|c| a[c] + f64::from(s.color[c])));
            sum.map(|c| c / splats.len() as f64)
        };
        let store_file = || {
            let stores: Vec<_> = std::fs::read_dir(&cache)
                .expect("cache")
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == "kstore"))
                .collect();
            assert_eq!(stores.len(), 1, "{stores:?}");
            std::fs::metadata(&stores[0]).and_then(|m| m.modified()).expect("store's time")
        };
        let logo = mean_colour();
        let made = store_file();
        assert!(logo[0] < 250.0 && logo[2] > 5.0, "the logo's colours: {logo:?}");
        // Opened again: the cached store, not a new import.
        assert_eq!(mean_colour(), logo);
        assert_eq!(store_file(), made, "nothing changed: the cached store is used");
        // The curator corrects the texture: the model takes its new colours.
        image::RgbaImage::from_pixel(64, 64, image::Rgba([200, 20, 20, 255]))
            .save(dir.join("Cesium Logo Flat.png"))
            .expect("new texture");
        let red = mean_colour();
        assert!(red[0] > 190.0 && red[1] < 30.0 && red[2] < 30.0, "the new texture's red: {red:?}");
        assert_ne!(store_file(), made);
        // The material library loses its texture: the mesh comes in plain.
        std::fs::write(dir.join("box textured.mtl"), "newmtl Cesium logo\nKd 0.2 0.2 0.9\n").expect("mtl");
        let blue = mean_colour();
        assert!(blue[2] > blue[0] + 100.0 && blue[0] == blue[1], "the library's plain blue: {blue:?}");
    }

    #[test]
    fn an_edit_of_the_same_size_within_the_same_second_is_imported_again() {
        // A curator's tool that rewrites a scan in place, quickly: the size is the same and the
        // modification time differs by less than a second.
        let root = tempfile::tempdir().expect("temp dir");
        let (dir, cache) = (root.path().join("ex"), root.path().join("cache"));
        std::fs::create_dir_all(&dir).expect("exhibit dir");
        let scan = dir.join("cloud.ply");
        let ply = |z: &str| {
            let rows: String = (0..16).map(|i| format!("{} {} {z}\n", i % 4, i / 4)).collect();
            format!(
                "ply\nformat ascii 1.0\nelement vertex 16\nproperty float x\nproperty float y\nproperty float z\nend_header\n{rows}"
            )
        };
        let second = std::time::UNIX_EPOCH + std::time::Duration::from_secs(1_800_000_000);
        let write = |text: String, millis: u64| {
            std::fs::write(&scan, text).expect("write");
            let f = std::fs::File::options().write(true).open(&scan).expect("open");
            f.set_modified(second + std::time::Duration::from_millis(millis)).expect("set the time");
        };
        write(ply("0"), 100);
        let first = open_model_in(&dir, &cache).expect("first");
        write(ply("5"), 600);
        let edited = open_model_in(&dir, &cache).expect("edited");
        let z = |s: &MappedStore| s.to_model(s.bbox().center()).z;
        assert!(
            (z(&first) - 0.0).abs() < 1e-6 && (z(&edited) - 5.0).abs() < 1e-6,
            "{} {}",
            z(&first),
            z(&edited)
        );
    }

    #[test]
    fn a_key_that_cannot_be_taken_costs_that_key_alone() {
        let root = tempfile::tempdir().expect("temp dir");
        let (dir, _) = box_exhibit(root.path());
        let file = dir.join("exhibit.toml");
        let settings = |text: &str| {
            std::fs::write(&file, text).expect("write");
            let s = exhibit_settings(&dir);
            let problems = s.messages();
            (s.pose, s.texel_density, problems)
        };
        // A misspelt key beside a stated up and density: both kept, the key named.
        let (pose, density, problems) = settings("up = \"z\"\nfrnt = \"-y\"\ntexel_density = 0.5\n");
        assert_eq!((pose, density), (ModelPose { up: glam::DVec3::Z, front: None }, Some(0.5)));
        assert!(problems.len() == 1 && problems[0].contains("unknown key `frnt`"), "{problems:?}");
        assert!(problems[0].contains("exhibit.toml"), "{problems:?}");
        // A broken front keeps the stated up; a density out of range keeps the pose.
        let (pose, density, problems) = settings("up = \"z\"\nfront = \"north\"\ntexel_density = 100\n");
        assert_eq!((pose, density), (ModelPose { up: glam::DVec3::Z, front: None }, None));
        assert!(problems.len() == 2, "{problems:?}");
        assert!(problems[0].contains("front = \"north\"") && problems[1].contains("texel_density = 100"));
        // A broken up: the default up, and a front stated beside it levelled to that.
        let (pose, _, problems) = settings("up = [0.0, 0.0, 0.0]\nfront = \"z\"\n");
        assert_eq!(pose, ModelPose { up: glam::DVec3::Y, front: Some(glam::DVec3::Z) });
        assert!(problems.len() == 1 && problems[0].contains("up = [0, 0, 0]"), "{problems:?}");
        // Each message says what is done about it.
        assert!(problems[0].ends_with("the model is shown with +Y up"), "{problems:?}");
        let (_, _, problems) = settings("texel_density = 0\n");
        assert!(problems[0].ends_with("imported at the default samples per texel"), "{problems:?}");
        // The strict readers fail on their own keys, a key they do not know, or the file; the
        // kiosk imports with what could be taken.
        assert!(model_pose(&dir).is_ok() && import_options(&dir).is_err());
        settings("up = \"north\"\ntexel_density = 2\n");
        assert!(model_pose(&dir).is_err() && import_options(&dir).is_ok());
        settings("frnt = 1\ntexel_density = 0.25\n");
        assert!(model_pose(&dir).is_err() && import_options(&dir).is_err());
        assert_eq!(exhibit_settings(&dir).import_options().read.texel_density, 0.25);
        // The authoring tool's rewrite of the pose keeps every other key as the file has it.
        let rewritten = exhibit_toml(&dir, &ModelPose { up: glam::DVec3::Z, front: None });
        assert!(rewritten.contains("texel_density = 0.25") && rewritten.contains("frnt = 1"), "{rewritten}");
        std::fs::write(&file, &rewritten).expect("write");
        assert_eq!(exhibit_settings(&dir).pose.up, glam::DVec3::Z, "{rewritten}");
    }

    #[test]
    fn a_survey_scan_stands_on_z_unless_its_exhibit_says_otherwise() {
        let root = tempfile::tempdir().expect("temp dir");
        for (name, up) in [
            ("scan.las", glam::DVec3::Z),
            ("scan.E57", glam::DVec3::Z),
            ("scan.laz", glam::DVec3::Z),
            ("scan.glb", glam::DVec3::Y),
            ("scan.ply", glam::DVec3::Y),
        ] {
            let dir = root.path().join(name.replace('.', "-"));
            std::fs::create_dir_all(&dir).expect("dir");
            std::fs::write(dir.join(name), b"").expect("scan");
            assert_eq!(model_pose(&dir).expect("pose").up, up, "{name}");
            std::fs::write(dir.join("exhibit.toml"), "up = \"x\"\n").expect("toml");
            assert_eq!(model_pose(&dir).expect("pose").up, glam::DVec3::X, "{name}: stated");
            // A broken up: the kiosk shows the scan as if it said nothing, and says why.
            std::fs::write(dir.join("exhibit.toml"), "up = \"sideways\"\n").expect("toml");
            assert!(model_pose(&dir).is_err(), "{name}: broken");
            let settings = exhibit_settings(&dir);
            assert_eq!(settings.pose, ModelPose { up, front: None }, "{name}: broken");
            assert_eq!(settings.problems.len(), 1, "{name}: {:?}", settings.problems);
            // A file that is not TOML: every default, one problem.
            std::fs::write(dir.join("exhibit.toml"), "up = \"x\n").expect("toml");
            let settings = exhibit_settings(&dir);
            assert_eq!((settings.pose.up, settings.problems.len()), (up, 1), "{name}: not TOML");
        }
        assert_eq!(up_label(glam::DVec3::Z), "+Z");
        assert_eq!(up_label(glam::DVec3::NEG_Y), "-Y");
        assert_eq!(up_label(glam::DVec3::new(0.0, 0.6, 0.8)), "[0, 0.6, 0.8]");
    }

    #[test]
    fn an_edited_scan_replaces_its_cached_store_and_other_exhibits_keep_theirs() {
        let root = tempfile::tempdir().expect("temp dir");
        let cache = root.path().join("cache");
        let exhibit = |name: &str| {
            let dir = root.path().join(name);
            std::fs::create_dir_all(&dir).expect("exhibit dir");
            std::fs::copy(
                Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../../tests/data/scans/demosthenes/demosthenes-low-res.obj"),
                dir.join("bust.obj"),
            )
            .expect("copy the scan");
            dir
        };
        let (a, b) = (exhibit("a"), exhibit("b"));
        let stores = || {
            let mut v: Vec<String> = std::fs::read_dir(&cache)
                .expect("cache")
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| !n.starts_with(".bust"))
                .collect();
            v.sort();
            v
        };
        open_model_in(&a, &cache).expect("a");
        open_model_in(&b, &cache).expect("b");
        let before = stores();
        assert_eq!(before.len(), 6, "a store and its two notes for each exhibit: {before:?}");
        let endings = [".kstore", ".source", ".inputs"];
        assert!(before.iter().all(|n| endings.iter().any(|e| n.ends_with(e))), "{before:?}");
        // An edit of a's scan: its new store replaces its old one; b's stays.
        let mut text = std::fs::read_to_string(a.join("bust.obj")).expect("read");
        text.push_str("# edited\n");
        std::fs::write(a.join("bust.obj"), text).expect("edit");
        open_model_in(&a, &cache).expect("a edited");
        let after = stores();
        assert_eq!(after.len(), 6, "{after:?}");
        let gone: Vec<_> = before.iter().filter(|n| !after.contains(n)).collect();
        assert_eq!(gone.len(), 3, "a's old store and notes: {gone:?}");
        assert!(after.iter().filter(|n| before.contains(n)).count() == 3, "b's store and notes stay");
        // b is deleted: the next sweep removes its store, note and lock.
        std::fs::remove_dir_all(&b).expect("remove b");
        open_model_in(&a, &cache).expect("a again");
        let last = stores();
        assert_eq!(last.len(), 3, "{last:?}");
        let locks = std::fs::read_dir(&cache)
            .expect("cache")
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(".bust"))
            .count();
        assert_eq!(locks, 1, "only the kept store's lock");
    }
}
