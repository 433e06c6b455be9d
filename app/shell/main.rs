//! `kiosk`: the IsoKiosk command line.

use anyhow::Context;
use clap::{Parser, Subcommand};
use kiosk::terminal;
use kiosk_content::import::{ImportOptions, import};
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "kiosk", version, about = "IsoKiosk: explore huge 3D scans in a museum")]
#[command(args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: RunArgs,
}

/// Without a command, `kiosk` opens the projection and controller windows.
#[derive(clap::Args)]
struct RunArgs {
    /// Configuration file (TOML); default: kiosk.toml if present, else built-in defaults.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Content directory (overrides the configuration's).
    #[arg(long)]
    content: Option<PathBuf>,
    /// Ordinary windows side by side instead of fullscreen on the configured monitors.
    #[arg(long)]
    windowed: bool,
    /// Record the visitors' touches to this session file (JSON Lines).
    #[arg(long, value_name = "FILE.jsonl")]
    record: Option<PathBuf>,
    /// Play this session through the windows at its own timing, then exit.
    #[arg(long, value_name = "FILE.jsonl")]
    session: Option<PathBuf>,
    /// Session times (seconds) at which to save both windows as PNG.
    #[arg(long, value_delimiter = ',', value_name = "T1,T2,…")]
    screenshot_at: Vec<f64>,
    /// Where the screenshots go.
    #[arg(long, default_value = ".")]
    screenshot_dir: PathBuf,
    /// Clock speed (2 = twice as fast; for tests and soak runs).
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// With --session: replay it over and over until this much kiosk time has passed (soak).
    #[arg(long, value_name = "SECS", requires = "session")]
    run_for: Option<f64>,
    /// With --run-for: kiosk time after which the memory is taken as the reference.
    #[arg(long, default_value_t = 300.0, value_name = "SECS", requires = "run_for")]
    warmup: f64,
    /// No audio device, even if there is one.
    #[arg(long)]
    silent: bool,
    /// Write the kiosk's trace (one JSON line per 60 Hz frame).
    #[arg(long)]
    trace: Option<PathBuf>,
    /// With --record: replace an existing recording.
    #[arg(long, requires = "record")]
    force: bool,
}

/// Refuses to write `out` over one of the command's inputs, or (`--record`) over an existing
/// file: a recording or a session is a museum's data.
fn refuse_overwrite(out: &std::path::Path, inputs: &[&std::path::Path], flag: &str) -> anyhow::Result<()> {
    if let Ok(o) = out.canonicalize() {
        for i in inputs {
            anyhow::ensure!(
                i.canonicalize().is_ok_and(|i| i != o),
                "{flag} {}: that is an input of this command; choose another file",
                out.display()
            );
        }
    }
    Ok(())
}

fn run_kiosk(args: RunArgs) -> anyhow::Result<()> {
    use kiosk::windows::config::Config;
    let mut config = match &args.config {
        Some(p) => Config::load(p)?,
        None if std::path::Path::new("kiosk.toml").exists() => {
            Config::load(std::path::Path::new("kiosk.toml"))?
        }
        None => Config::default(),
    };
    if let Some(c) = args.content {
        config.content = c;
    }
    anyhow::ensure!(args.speed.is_finite() && args.speed > 0.0, "--speed must be positive");
    if let Some(r) = &args.record {
        anyhow::ensure!(
            args.force || !r.exists(),
            "--record {}: the file exists (a recorded visit); choose another name or add --force to replace it",
            r.display()
        );
    }
    if let Some(t) = &args.trace {
        let inputs: Vec<&std::path::Path> =
            args.session.iter().chain(&args.record).map(|p| p.as_path()).collect();
        refuse_overwrite(t, &inputs, "--trace")?;
    }
    let session = match &args.session {
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("cannot read session {}", p.display()))?;
            Some(kiosk_core::session::Session::parse(&text).with_context(|| format!("{}", p.display()))?)
        }
        None => None,
    };
    kiosk::windows::run(kiosk::windows::RunOptions {
        config,
        windowed: args.windowed,
        record: args.record,
        session,
        screenshot_at: args.screenshot_at,
        screenshot_dir: args.screenshot_dir,
        speed: args.speed,
        run_for: args.run_for,
        silent: args.silent,
        warmup: args.warmup,
        trace: args.trace,
    })
}

#[derive(Subcommand)]
enum Command {
    /// Import a scan (PLY in any encoding, .ply.gz, OBJ with MTL, glTF/GLB, LAS/LAZ, E57) into a
    /// multiresolution store.
    Import {
        /// The scan file.
        scan: PathBuf,
        /// The store to write.
        #[arg(short, long)]
        output: PathBuf,
        /// Target samples per node (M), 16 to 1 000 000.
        #[arg(long, default_value_t = kiosk_import::BuildParams::default().node_points as u32,
              value_parser = clap::value_parser!(u32).range(16..=1_000_000))]
        node_points: u32,
        /// Speed against accuracy of the splat radii: samples that come with a normal but no
        /// spacing (point clouds; a mesh's faces give theirs) search their nearest neighbours
        /// for a spacing one in N per group of 8–15 neighbouring samples; the others take the
        /// spacing of the nearest that did (1: every sample; figures in docs/performance.md).
        #[arg(long, default_value_t = kiosk_import::BuildParams::default().spacing_stride as u32,
              value_parser = clap::value_parser!(u32).range(1..=16))]
        spacing_stride: u32,
        /// Speed against accuracy of the normals: samples without a normal (bare point clouds)
        /// search their nearest neighbours one in N per group of 8–15 neighbouring samples;
        /// where the normals found agree within 4°, the others take the normal and spacing of
        /// the nearest that did, elsewhere (carving, edges, noise) they search too (1: every
        /// sample; figures in docs/performance.md).
        #[arg(long, default_value_t = kiosk_import::BuildParams::default().normal_stride as u32,
              value_parser = clap::value_parser!(u32).range(1..=kiosk_import::build::MAX_NORMAL_STRIDE as i64))]
        normal_stride: u32,
        /// Skip samples with NaN/∞ coordinates instead of failing.
        #[arg(long)]
        drop_invalid: bool,
        /// Samples per texel of a textured mesh's texture: each textured triangle is sampled at
        /// its texel footprint (1: the texture's own resolution; 0.25: one sample per 2 × 2
        /// texels; figures in docs/performance.md).
        #[arg(long, default_value_t = kiosk_import::ReadOptions::default().texel_density,
              value_parser = texel_density)]
        texel_density: f32,
        /// Keep a plain mesh (no materials) as its vertices alone: by default its triangles
        /// larger than the model's sample spacing (its bounding box's diagonal / 256) are
        /// sampled on their surface, so that a low-poly mesh has no holes and no giant discs.
        #[arg(long)]
        vertices_only: bool,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Check a store: header, index and every node's checksum.
    Verify {
        /// The store file.
        store: PathBuf,
    },
    /// Render one view of an exhibit's model offscreen to a PNG or JPEG.
    Snapshot {
        /// Exhibit directory.
        #[arg(long)]
        exhibit: PathBuf,
        /// The view: eye x,y,z, target x,y,z, up x,y,z, fov in degrees (default: the kiosk's start).
        #[arg(long, conflicts_with = "node", allow_hyphen_values = true)]
        view: Option<String>,
        /// A node of the exhibit's graph.xml whose view to render (in its light, if it has one).
        #[arg(long)]
        node: Option<String>,
        /// Image size, WxH.
        #[arg(long, default_value = "1280x720")]
        size: String,
        /// The image to write: .png, or .jpg / .jpeg.
        #[arg(short, long)]
        output: PathBuf,
        /// How splats are drawn: blended (smooth), discs or points (faster).
        #[arg(long, default_value = "blended")]
        splats: kiosk_render::SplatMode,
        /// Eye-dome lighting strength, 0 (off) to 4.
        #[arg(long, default_value_t = 0.0, value_parser = edl_strength)]
        edl: f32,
        /// Pixel tolerance of the cut (more than 0; larger is faster and coarser).
        #[arg(long, default_value_t = 1.0, value_parser = tolerance_px)]
        tolerance: f32,
    },
    /// Visit statistics of an exhibit: a table per node and SVG plots.
    Stats {
        /// The exhibit's name (its directory's name).
        exhibit: String,
        /// Only visits since this day (YYYY-MM-DD, UTC), from the visit log.
        #[arg(long, value_name = "DATE")]
        since: Option<String>,
        /// Where the plots go (default: ./stats-EXHIBIT/).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// The state directory (default: the configuration's, else $ISOKIOSK_STATE, else
        /// ~/.local/state/isokiosk).
        #[arg(long, value_name = "DIR")]
        state: Option<PathBuf>,
        /// Configuration file whose state_dir to use.
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Check exhibits as the kiosk would load them, without a window, GPU or audio device: the
    /// model (a scan is imported into the cache, as at the kiosk's first start), its pose, its
    /// story and media, every narration decoded. Lists every problem, naming the file and the
    /// node; fails if the kiosk would leave anything out.
    Check {
        /// Exhibit directories.
        #[arg(required = true)]
        exhibits: Vec<PathBuf>,
        /// Also check every node's checksum (reads the whole store).
        #[arg(long)]
        full: bool,
    },
    /// Play narration files through the default audio device, one after the other, and wait
    /// for each to end: a technician's check that the kiosk will be heard. Fails if there is no
    /// device or a file does not decode.
    SoundCheck {
        /// Narration files (WAV, Ogg Vorbis, MP3, FLAC), or exhibit directories (every narration
        /// their graph.xml names).
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Volume, 0–1.
        #[arg(long, default_value_t = 1.0)]
        volume: f64,
    },
    /// Replay a touch session without window or GPU and write its trace (JSON Lines).
    Replay {
        /// Exhibit directory (a store, or a scan imported on the fly).
        #[arg(long)]
        exhibit: PathBuf,
        /// The session (touch events, JSON Lines).
        #[arg(long)]
        session: PathBuf,
        /// Where to write the trace.
        #[arg(long)]
        trace: PathBuf,
        /// Camera controller.
        #[arg(long, default_value = "isocam")]
        controller: String,
        /// Seed (default: the session header's, else 0).
        #[arg(long)]
        seed: Option<u64>,
    },
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    use std::io::IsTerminal;
    tracing_subscriber::fmt()
        .with_ansi(std::io::stderr().is_terminal())
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
            tracing_subscriber::EnvFilter::new(
                "info,wgpu_core=warn,wgpu_hal=warn,naga=warn,symphonia=off,symphonia_core=off,\
                 symphonia_bundle_mp3=off",
            )
        }))
        .with_writer(std::io::stderr)
        .init();
    let Some(command) = cli.command else { return run_kiosk(cli.run) };
    match command {
        Command::Import {
            scan,
            output,
            node_points,
            spacing_stride,
            normal_stride,
            drop_invalid,
            texel_density,
            vertices_only,
            quiet,
        } => {
            terminal::clean_up_imports_on_signals();
            let mut opts = ImportOptions::default();
            opts.read.texel_density = texel_density;
            opts.read.fill_plain_meshes = !vertices_only;
            opts.build.node_points = node_points as usize;
            opts.build.spacing_stride = spacing_stride as usize;
            opts.build.normal_stride = normal_stride as usize;
            opts.read.drop_invalid = drop_invalid;
            let mut bar = terminal::ImportBar::new(!quiet);
            let report =
                import(&scan, &output, &opts, &mut |phase, done, total| bar.report(phase, done, total));
            drop(bar);
            let report = report.inspect_err(|e| {
                // The readers name no command-line flag; the command says what the user can do.
                let non_finite = e.chain().any(|c| {
                    c.downcast_ref::<kiosk_import::ReadError<kiosk_import::BuildError>>()
                        .is_some_and(kiosk_import::ReadError::is_non_finite)
                });
                if non_finite {
                    eprintln!("hint: --drop-invalid skips samples with non-finite coordinates");
                }
            })?;
            for w in &report.warnings {
                eprintln!("warning: {}: {w}", scan.display());
            }
            println!("{}: {report}", output.display());
            if kiosk_content::exhibit::stands_on_z(&scan) {
                eprintln!(
                    "note: the kiosk stands a {} scan on Z, but a store does not keep its scan's format: \
                     an exhibit showing {} needs up = \"z\" in its exhibit.toml",
                    scan.extension().map_or(String::new(), |e| e.to_string_lossy().to_uppercase()),
                    output.display()
                );
            }
        }
        Command::Verify { store } => {
            let s = kiosk_content::open_store(&store)?;
            if let Some((_, e)) = s.failing_nodes().next() {
                return Err(e).with_context(|| format!("{}", store.display()));
            }
            let h = s.header();
            println!(
                "{}: ok — {} nodes, {} levels, {} samples at full resolution, origin {:?}",
                store.display(),
                h.node_count,
                s.levels(),
                h.leaf_point_count,
                h.origin
            );
        }
        Command::Snapshot { exhibit, view, node, size, output, splats, edl, tolerance } => {
            let format = match image::ImageFormat::from_path(&output) {
                Ok(f @ (image::ImageFormat::Png | image::ImageFormat::Jpeg)) => f,
                _ => anyhow::bail!("--output {}: name a .png or .jpg file", output.display()),
            };
            let store = kiosk_content::exhibit::open_model(&exhibit)?;
            let size = parse_size(&size)?;
            // The view and its light: a node's stored light, else the light a visit starts with.
            let pose = pose_as_the_kiosk_takes_it(&exhibit);
            let start = kiosk_core::camera::start_camera(&store, 0.8, pose.up, pose.front);
            let start_light = kiosk_content::snapshot::start_light(&start);
            let (camera, light) = match (view, node) {
                (Some(v), _) => (parse_view(&v)?, start_light),
                (None, Some(id)) => {
                    let (graph, problems) = kiosk_content::exhibit::open_graph(&exhibit)?
                        .with_context(|| format!("{}: no graph.xml for --node", exhibit.display()))?;
                    let i = graph.index_of(&id).with_context(|| {
                        let graph_file = exhibit.join("graph.xml");
                        match problems.iter().find(|p| p.dropped && p.node.as_deref() == Some(id.as_str())) {
                            Some(p) => format!("{}: {p}", graph_file.display()),
                            None => format!("{}: no node '{id}'", graph_file.display()),
                        }
                    })?;
                    (graph.nodes[i].view, kiosk_content::snapshot::node_light(&graph.nodes[i], start_light))
                }
                (None, None) => (start, start_light),
            };
            let (gpu, mut renderer) = kiosk_content::snapshot::offscreen()?;
            gpu.check_size(size).with_context(|| format!("--size {}x{}", size.0, size.1))?;
            let settings = kiosk_content::snapshot::lit(
                kiosk_render::RenderSettings { mode: splats, edl_strength: edl, ..Default::default() },
                light,
            );
            let image = kiosk_content::snapshot::snapshot(
                &gpu,
                &mut renderer,
                &store,
                &camera,
                size,
                tolerance,
                &settings,
            )
            .map_err(|e| match e.downcast_ref::<kiosk_content::snapshot::CorruptView>() {
                Some(_) => e.context(format!("`kiosk check --full {}` reads every node", exhibit.display())),
                None => e,
            })?;
            let saved = match format {
                image::ImageFormat::Jpeg => image::DynamicImage::ImageRgba8(image).to_rgb8().save(&output),
                _ => image.save(&output),
            };
            saved.with_context(|| format!("cannot write {}", output.display()))?;
            println!(
                "{}: {}x{} on {} ({:?})",
                output.display(),
                size.0,
                size.1,
                gpu.adapter.name,
                gpu.adapter.backend
            );
        }
        Command::Stats { exhibit, since, out, state, config } => {
            let state = match (state, config) {
                (Some(s), _) => s,
                (None, Some(c)) => kiosk::windows::config::Config::load(&c)?.state_dir(),
                (None, None) if std::path::Path::new("kiosk.toml").exists() => {
                    kiosk::windows::config::Config::load(std::path::Path::new("kiosk.toml"))?.state_dir()
                }
                (None, None) => kiosk_content::stats::state_dir(),
            };
            let opts = kiosk::report::StatsOptions {
                since: since.as_deref().map(kiosk::report::parse_date).transpose()?,
                out: out.unwrap_or_else(|| PathBuf::from(format!("stats-{exhibit}"))),
                exhibit,
                state,
            };
            print!("{}", kiosk::report::run(&opts)?);
        }
        Command::Check { exhibits, full } => {
            let mut failed = 0;
            for dir in &exhibits {
                let checked = kiosk_content::check::check(dir, &kiosk_content::exhibit::cache_dir(), full);
                println!("{}", dir.display());
                for line in &checked.sound {
                    println!("  {line}");
                }
                for (error, line) in &checked.problems {
                    println!("  {}: {line}", if *error { "error" } else { "warning" });
                }
                failed += usize::from(checked.has_errors());
            }
            anyhow::ensure!(failed == 0, "{failed} of {} exhibit(s) have errors (above)", exhibits.len());
        }
        Command::SoundCheck { files, volume } => {
            anyhow::ensure!((0.0..=1.0).contains(&volume), "--volume {volume}: between 0 and 1");
            let mut narrator = kiosk_content::audio::Narrator::new(volume, false);
            anyhow::ensure!(
                narrator.audible(),
                "no audio device: the kiosk would be silent (captions still show); check the sound card and ALSA's default device"
            );
            let mut played = 0;
            for path in kiosk_content::exhibit::narration_files(&files)? {
                let secs = narrator.play_to_end(&path).map_err(anyhow::Error::msg)?;
                println!("played {} ({secs:.1} s)", path.display());
                played += 1;
            }
            println!("{played} narration(s) played through the default audio device");
        }
        Command::Replay { exhibit, session, trace, controller, seed } => {
            let store = kiosk_content::exhibit::open_model(&exhibit)?;
            let pose = pose_as_the_kiosk_takes_it(&exhibit);
            let text = std::fs::read_to_string(&session)
                .with_context(|| format!("cannot read session {}", session.display()))?;
            let parsed = kiosk_core::session::Session::parse(&text)
                .with_context(|| format!("{}", session.display()))?;
            let settings = kiosk_core::explore::ExploreSettings {
                controller: controller.parse().map_err(anyhow::Error::msg)?,
                seed: seed.or(parsed.header.as_ref().and_then(|h| h.seed)).unwrap_or(0),
                up: pose.up,
                front: pose.front,
                ..Default::default()
            };
            let graph = match kiosk_content::exhibit::open_graph(&exhibit) {
                Ok(Some((g, problems))) => {
                    for p in &problems {
                        eprintln!("warning: {}: {p}", exhibit.join("graph.xml").display());
                    }
                    Some(g)
                }
                Ok(None) => None,
                Err(e) => {
                    eprintln!("warning: {e:#}; replaying without recommendations");
                    None
                }
            };
            refuse_overwrite(&trace, &[&session], "--trace")?;
            // The trace is streamed to its file: memory stays flat however long the session.
            use std::io::Write;
            let file = std::fs::File::create(&trace)
                .with_context(|| format!("cannot write trace {}", trace.display()))?;
            let mut out = std::io::BufWriter::new(file);
            let mut written = out.write_all(
                kiosk_core::trace::header_line(settings.controller.name(), settings.seed, settings.fps)
                    .as_bytes(),
            );
            let mut min_distance = None;
            let (_, s) =
                kiosk_core::replay::run_story_with(&store, &parsed, &settings, graph.as_ref(), &mut |f| {
                    min_distance.get_or_insert(f.min_distance);
                    if written.is_ok() {
                        written = out.write_all(f.to_line().as_bytes());
                    }
                });
            written
                .and_then(|()| out.write_all(kiosk_core::trace::summary_line(&s).as_bytes()))
                .and_then(|()| out.flush())
                .with_context(|| format!("cannot write trace {}", trace.display()))?;
            println!(
                "{}: {} frames, {} collisions, closest approach {:.4} (minimum {:.4}), {} menu requests",
                trace.display(),
                s.frames,
                s.collisions,
                s.min_surface_distance,
                min_distance.unwrap_or(0.0),
                s.menu_requests
            );
        }
    }
    Ok(())
}

/// A number option `s` that `ok` accepts; `what` says which numbers are, in the error.
fn number_in(s: &str, ok: fn(f32) -> bool, what: &str) -> Result<f32, String> {
    let v: f32 = s.parse().map_err(|e| format!("{e}"))?;
    if ok(v) { Ok(v) } else { Err(format!("{v}: {what}")) }
}

/// `--edl`: as `edl` in kiosk.toml, 0 to 4.
fn edl_strength(s: &str) -> Result<f32, String> {
    number_in(s, kiosk::windows::config::edl_ok, "the strength is between 0 (off) and 4")
}

/// `--tolerance`: as `tolerance_px` in kiosk.toml, a positive number of pixels.
fn tolerance_px(s: &str) -> Result<f32, String> {
    number_in(s, kiosk::windows::config::tolerance_ok, "the tolerance is a positive number of pixels")
}

/// `--texel-density`: a positive number up to 64.
fn texel_density(s: &str) -> Result<f32, String> {
    number_in(
        s,
        kiosk_import::ReadOptions::texel_density_ok,
        "the texel density is more than 0 and at most 64",
    )
}

/// Parses `eye_x,eye_y,eye_z,target_x,target_y,target_z,up_x,up_y,up_z,fov_degrees`.
fn parse_view(s: &str) -> anyhow::Result<kiosk_core::camera::Camera> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().with_context(|| format!("'{x}' is not a number")))
        .collect::<anyhow::Result<_>>()?;
    anyhow::ensure!(
        v.len() == 10,
        "--view needs 10 numbers: eye(3), target(3), up(3), fov in degrees; got {}",
        v.len()
    );
    anyhow::ensure!(v.iter().all(|x| x.is_finite()), "--view numbers must be finite");
    let eye = glam::DVec3::new(v[0], v[1], v[2]);
    let target = glam::DVec3::new(v[3], v[4], v[5]);
    anyhow::ensure!(eye != target, "--view: eye and target coincide");
    anyhow::ensure!(v[9] > 0.0 && v[9] < 180.0, "--view: field of view must be in (0, 180) degrees");
    let mut c = kiosk_core::camera::Camera {
        eye,
        target,
        up: glam::DVec3::new(v[6], v[7], v[8]),
        fov_y: v[9].to_radians(),
    };
    c.up = kiosk_core::camera::orthonormal_up(c.forward(), c.up, glam::DVec3::Y);
    Ok(c)
}

/// Parses `WxH`.
fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = s.split_once(['x', 'X']).with_context(|| format!("size '{s}' is not WxH"))?;
    let (w, h): (u32, u32) = (w.trim().parse()?, h.trim().parse()?);
    anyhow::ensure!((1..=16384).contains(&w) && (1..=16384).contains(&h), "size {w}x{h} outside 1…16384");
    Ok((w, h))
}

/// An exhibit's pose as the kiosk takes it: what `exhibit.toml` could give, a key it could not
/// take at its default, each problem logged (a snapshot or replay shows what the kiosk shows).
fn pose_as_the_kiosk_takes_it(exhibit: &std::path::Path) -> kiosk_content::exhibit::ModelPose {
    let settings = kiosk_content::exhibit::exhibit_settings(exhibit);
    for message in settings.messages() {
        tracing::warn!("{message}");
    }
    settings.pose
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_and_a_size_are_parsed_or_refused_by_their_flag() {
        let c = parse_view("0,0,2, 0,0,0, 0,1,0, 60").expect("a view");
        assert!((c.fov_y - 60f64.to_radians()).abs() < 1e-12 && c.up.y > 0.99);
        for (bad, says) in [
            ("0,0,2,0,0,0,0,1,0", "--view needs 10 numbers"),
            ("0,0,0,0,0,0,0,1,0,60", "coincide"),
            ("0,0,2,0,0,0,0,1,0,180", "field of view"),
            ("0,0,x,0,0,0,0,1,0,60", "'x' is not a number"),
        ] {
            let e = format!("{:#}", parse_view(bad).expect_err(bad));
            assert!(e.contains(says), "{bad}: {e}");
        }
        assert_eq!(parse_size("1280x720").expect("a size"), (1280, 720));
        assert!(parse_size("0x10").is_err() && parse_size("12").is_err());
    }
}
