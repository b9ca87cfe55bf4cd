//! `gi view`: the interactive viewer. A winit window with a fly camera, GI-1.0, the path tracer
//! (accumulating while the camera stands still) or the world cache on its own, every technique
//! toggle and debug view, a timing overlay, and scenes and environments loaded by drag and drop.
//!
//! Presentation: each frame is rendered headless by our renderers, read back, tone-mapped exactly
//! as `gi render` writes its PNG, overlaid with text on the CPU, and drawn into the window with
//! softbuffer (X11 `PutImage`). A Vulkan swapchain would need the surface extensions at instance
//! creation, which `Context` does not enable, and a second present path beside the headless one
//! that every test exercises; the read-back costs one copy of an image the renderers read back
//! for their statistics anyway, runs alike on lavapipe under Xvfb and on real drivers, and makes
//! the window's pixels the headless render's, which the CI test checks.

use super::on_off;
use gi_host::gbuffer::scene_camera;
use gi_host::gi::debug_views::DebugView;
use gi_host::gi::probe_debug_views::gi_debug_views;
use gi_host::gi::renderer::GiRenderer;
use gi_host::gi::{CacheView, GiSettings, Preset, SpawnRate, ViewOptions};
use gi_host::image_io::{HdrImage, ToneCurve, ToneMap};
use gi_host::path_tracer::{PathTracerPass, PathTracerSettings};
use gi_host::scene::Scene;
use gi_host::scene::lights::{Environment, LightSet};
use gi_host::scene::upload::GpuScene;
use gi_host::viewer::bindings::{self, Action, movement_axis};
use gi_host::viewer::framebuffer::{to_rgb8, to_window_pixels};
use gi_host::viewer::{FlyCamera, Movement, Overlay};
use gi_host::vulkan::Context;
use std::collections::HashSet;
use std::num::NonZeroU32;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, ModifiersState, PhysicalKey};
use winit::window::{Window, WindowId};

/// Fraction of the scene's bounding-box diagonal the camera flies per second at first.
const SPEED_PER_DIAGONAL: f32 = 0.2;
/// GPU passes per line of the overlay's timing table.
const PASSES_PER_LINE: usize = 4;

/// Which renderer the viewer shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Mode {
    /// GI-1.0: screen probes over the world-space radiance cache, denoised.
    Gi,
    /// The reference path tracer, one path per pixel per frame, accumulated while the camera
    /// stands still.
    Path,
    /// The world-space radiance cache on its own (`gi cache-view`).
    Cache,
}

impl Mode {
    fn next(self) -> Self {
        match self {
            Self::Gi => Self::Path,
            Self::Path => Self::Cache,
            Self::Cache => Self::Gi,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Gi => "GI",
            Self::Path => "path tracer",
            Self::Cache => "cache view",
        }
    }
}

/// The options of `gi view`.
#[derive(clap::Args)]
pub struct ViewerArgs {
    /// The glTF scene (.gltf or .glb). Drop another scene, or an environment (.hdr, .exr), on
    /// the window to load it.
    scene: PathBuf,
    /// Window width in pixels.
    #[arg(long, default_value_t = 640, value_parser = clap::value_parser!(u32).range(1..=8192))]
    width: u32,
    /// Window height in pixels.
    #[arg(long, default_value_t = 480, value_parser = clap::value_parser!(u32).range(1..=8192))]
    height: u32,
    /// Equirectangular environment image lighting the scene: Radiance .hdr or OpenEXR.
    #[arg(long)]
    environment: Option<PathBuf>,
    /// The renderer to start with (Tab switches).
    #[arg(long, value_enum, default_value_t = Mode::Gi)]
    mode: Mode,
    /// The GI preset to start with: fast, balanced or quality (P switches).
    #[arg(long, default_value = "balanced", value_parser = parse_preset)]
    preset: Preset,
    /// Exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Scripted: render this many frames from the scene's camera, then close.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    frames: Option<u32>,
    /// Scripted: after the last frame, read the window's pixels back from the X server and write
    /// them here as a PNG.
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Start with the overlay hidden (H shows it).
    #[arg(long)]
    no_overlay: bool,
    /// Scripted: after the first frame, load these files as if dropped on the window.
    #[arg(long, requires = "frames")]
    drop: Vec<PathBuf>,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    Preset::from_name(s).ok_or_else(|| format!("{s:?} is not one of fast, balanced, quality"))
}

/// Opens the viewer and runs it until its window closes (or its scripted frames are done).
pub fn run_view(ctx: &Context, args: &ViewerArgs) -> Result<(), Box<dyn std::error::Error>> {
    let viewer = Viewer::new(ctx, args)?;
    let event_loop = EventLoop::new().map_err(|e| format!("cannot open a window: {e}"))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        viewer,
        window: None,
        error: None,
    };
    event_loop.run_app(&mut app)?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// The renderer of the current mode, with what it keeps between frames.
enum Renderer {
    Gi(Box<GiRenderer>),
    Cache(Box<CacheView>),
    Path {
        pass: Box<PathTracerPass>,
        sums: Vec<[f64; 3]>,
        samples: u32,
    },
}

/// A frame to show: the image, how to tone-map it, its GPU time and a status line.
struct Shown {
    image: HdrImage,
    radiance: bool,
    gpu_ms: Option<f64>,
    status: String,
    passes: Vec<(String, f64)>,
}

/// The viewer's state, apart from the window.
struct Viewer<'a> {
    ctx: &'a Context,
    // Dropped before the scene it renders.
    renderer: Option<Renderer>,
    gpu: GpuScene,
    lights: LightSet,
    scene: Scene,
    scene_path: PathBuf,
    environment: Option<Environment>,
    mode: Mode,
    preset: Preset,
    settings: GiSettings,
    size: [u32; 2],
    camera: FlyCamera,
    debug_view: Option<usize>,
    /// How many debug views the current mode showed last (0 before the first).
    debug_views: usize,
    exposure: f32,
    overlay: Overlay,
    show_overlay: bool,
    /// The last error (a dropped file that failed to load, a setting refused), shown until the
    /// next one.
    message: Option<String>,
    frames_left: Option<u32>,
    screenshot: Option<PathBuf>,
    /// Files a scripted run drops after its first frame.
    drops: Vec<PathBuf>,
    held: HashSet<KeyCode>,
    modifiers: ModifiersState,
    drag: Option<PhysicalPosition<f64>>,
    dragging: bool,
    last_frame: Option<Instant>,
    frame_ms: f64,
}

impl<'a> Viewer<'a> {
    fn new(ctx: &'a Context, args: &ViewerArgs) -> Result<Self, Box<dyn std::error::Error>> {
        let scene = load(&args.scene)?;
        let environment = args
            .environment
            .as_deref()
            .map(Environment::read)
            .transpose()?;
        let (lights, gpu) = GpuScene::upload_lit(ctx, &scene, environment.clone(), true)?;
        let [w, h] = [args.width, args.height];
        let camera = fly_camera(&scene, w, h);
        Ok(Self {
            ctx,
            renderer: None,
            gpu,
            lights,
            scene,
            scene_path: args.scene.clone(),
            environment,
            mode: args.mode,
            preset: args.preset,
            settings: args.preset.settings(w, h),
            size: [w, h],
            camera,
            debug_view: None,
            debug_views: 0,
            exposure: args.exposure,
            overlay: Overlay::new()?,
            show_overlay: !args.no_overlay,
            message: None,
            frames_left: args.frames,
            screenshot: args.screenshot.clone(),
            drops: args.drop.clone(),
            held: HashSet::new(),
            modifiers: ModifiersState::empty(),
            drag: None,
            dragging: false,
            last_frame: None,
            frame_ms: 0.0,
        })
    }

    /// Whether input moves the camera and changes settings (not in scripted runs).
    fn interactive(&self) -> bool {
        self.frames_left.is_none()
    }

    fn renderer(&mut self) -> gi_host::Result<&mut Renderer> {
        if self.renderer.is_none() {
            let [w, h] = self.size;
            let options = ViewOptions::default();
            self.renderer = Some(match self.mode {
                Mode::Gi => {
                    let mut gi =
                        GiRenderer::new(self.ctx, &self.lights, w, h, self.settings, options)?;
                    // The debug views, one key away, show the irradiance before the denoiser.
                    gi.keep_interpolated_irradiance(self.ctx)?;
                    Renderer::Gi(Box::new(gi))
                }
                Mode::Cache => Renderer::Cache(Box::new(CacheView::new(
                    self.ctx,
                    &self.lights,
                    w,
                    h,
                    self.settings,
                    options,
                )?)),
                Mode::Path => Renderer::Path {
                    pass: Box::new(PathTracerPass::new(self.ctx)?),
                    sums: vec![[0.0; 3]; w as usize * h as usize],
                    samples: 0,
                },
            });
        }
        Ok(self.renderer.as_mut().expect("made above"))
    }

    /// Renders one frame of the current mode (and its debug view, if one is on).
    fn render(&mut self) -> gi_host::Result<Shown> {
        let ctx = self.ctx;
        let camera = *self.camera.params();
        let debug_view = self.debug_view;
        let [w, h] = self.size;
        self.renderer()?;
        let (renderer, gpu) = (self.renderer.as_mut().expect("made above"), &self.gpu);
        let mut shown = match renderer {
            Renderer::Gi(gi) => {
                let stats = gi.render_frame(ctx, gpu, &camera)?;
                let status = format!(
                    "frame {}: probes spawned {} reprojected {} patched {}, cache tiles {}",
                    gi.frames(),
                    stats.spawned,
                    stats.reprojected,
                    stats.patched,
                    stats.cache.live_tiles
                );
                let (image, radiance, status) = match debug_view {
                    None => (gi.image(ctx)?, true, status),
                    Some(i) => {
                        let mut views = gi_debug_views(ctx, gi)?;
                        let i = i % views.len().max(1);
                        self.debug_view = Some(i);
                        self.debug_views = views.len();
                        let n = views.len();
                        let v = views.swap_remove(i);
                        let status = format!("{status} | view {}/{n}: {}", i + 1, v.name);
                        (v.image, v.radiance, status)
                    }
                };
                Shown {
                    image,
                    radiance,
                    gpu_ms: Some(gi.timings().last_total_ms()),
                    status,
                    passes: passes(gi.timings()),
                }
            }
            Renderer::Cache(cache) => {
                let keys_before = match debug_view {
                    Some(_) => cache.read_back_state(ctx)?.keys,
                    None => vec![],
                };
                let o = cache.render_frame(ctx, gpu, &camera)?;
                let status = format!(
                    "{} frames in the mean, live tiles {}, evicted {}",
                    cache.accumulated_frames(),
                    o.live_tiles,
                    o.evicted
                );
                let (image, radiance, status) = match debug_view {
                    None => (cache.image(ctx)?, true, status),
                    Some(i) => {
                        let mut views = cache.debug_views(ctx, &keys_before)?;
                        let i = i % views.len().max(1);
                        self.debug_view = Some(i);
                        self.debug_views = views.len();
                        let n = views.len();
                        let (view, image) = views.swap_remove(i);
                        let status = format!("{status} | view {}/{n}: {}", i + 1, view.name());
                        (image, view == DebugView::Radiance, status)
                    }
                };
                Shown {
                    image,
                    radiance,
                    gpu_ms: Some(cache.timings().last_total_ms()),
                    status,
                    passes: passes(cache.timings()),
                }
            }
            Renderer::Path {
                pass,
                sums,
                samples,
            } => {
                let settings = PathTracerSettings {
                    samples: 1,
                    // A new random stream per frame: the running mean converges.
                    seed: *samples,
                    ..PathTracerSettings::default()
                };
                let r = pass.render(ctx, gpu, &camera, &settings, |_, _| {})?;
                *samples += 1;
                for (s, p) in sums.iter_mut().zip(r.image.pixels()) {
                    for c in 0..3 {
                        s[c] += f64::from(p[c]);
                    }
                }
                let n = f64::from(*samples);
                let image = HdrImage::from_pixels(
                    w,
                    h,
                    sums.iter().map(|s| s.map(|c| (c / n) as f32)).collect(),
                )?;
                Shown {
                    image,
                    radiance: true,
                    gpu_ms: r.gpu_ms,
                    status: format!("{samples} paths per pixel (still camera: accumulating)"),
                    passes: vec![],
                }
            }
        };
        if matches!(self.renderer, Some(Renderer::Path { .. })) && debug_view.is_some() {
            shown
                .status
                .push_str(" | the path tracer has no debug views");
        }
        Ok(shown)
    }

    /// The overlay's lines for a frame.
    fn overlay_lines(&self, shown: &Shown) -> Vec<String> {
        let name = self
            .scene_path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let gpu = shown
            .gpu_ms
            .map_or_else(String::new, |ms| format!(", GPU {ms:.2} ms"));
        let s = &self.settings;
        let mut lines = vec![
            format!(
                "{} | {name} {}x{} | frame {:.1} ms{gpu} | exposure {:+}",
                self.mode.name(),
                self.size[0],
                self.size[1],
                self.frame_ms,
                self.exposure
            ),
            shown.status.clone(),
            format!(
                "preset {}, spawn tile {} px, speed {:.2}/s, ReSTIR {}",
                self.preset,
                s.spawn_rate.tile(),
                self.camera.speed(),
                on_off(s.restir)
            ),
        ];
        for row in shown.passes.chunks(PASSES_PER_LINE) {
            lines.push(
                row.iter()
                    .map(|(name, ms)| format!("{name} {ms:.2}"))
                    .collect::<Vec<_>>()
                    .join("  "),
            );
        }
        if let Some(m) = &self.message {
            lines.push(format!("! {m}"));
        }
        lines.extend(bindings::help(s));
        lines
    }

    /// The frame's window pixels: the image tone-mapped as `gi render`'s PNG, and the overlay.
    fn pixels(&self, shown: &Shown) -> Vec<u32> {
        let tone = if shown.radiance {
            ToneMap {
                exposure: self.exposure,
                ..ToneMap::default()
            }
        } else {
            ToneMap::new(0.0, ToneCurve::Clamp)
        };
        let mut pixels = to_window_pixels(&shown.image, &tone);
        if self.show_overlay {
            let [w, h] = self.size;
            self.overlay
                .draw(&mut pixels, w, h, &self.overlay_lines(shown));
        }
        pixels
    }

    /// The renderer must be rebuilt (settings, mode or size changed); GI and the cache start
    /// their history over, the path tracer its mean.
    fn restart(&mut self) {
        self.renderer = None;
    }

    fn act(&mut self, action: Action) -> bool {
        match action {
            Action::Quit => return false,
            Action::NextMode => {
                self.mode = self.mode.next();
                self.debug_view = None;
                self.debug_views = 0;
                self.restart();
            }
            Action::NextDebugView => {
                self.debug_view = match self.debug_view {
                    None => Some(0),
                    // The renderers wrap the index to their view count; past the last, back to
                    // the image.
                    Some(i) if i + 1 < self.debug_views => Some(i + 1),
                    Some(_) => None,
                };
            }
            Action::NextPreset => {
                let all = Preset::ALL;
                let i = all.iter().position(|&p| p == self.preset).unwrap_or(0);
                self.preset = all[(i + 1) % all.len()];
                self.settings = self.preset.settings(self.size[0], self.size[1]);
                self.restart();
            }
            Action::NextSpawnRate => {
                self.settings.spawn_rate = match self.settings.spawn_rate {
                    SpawnRate::Full => SpawnRate::Quarter,
                    SpawnRate::Quarter => SpawnRate::Sixteenth,
                    SpawnRate::Sixteenth => SpawnRate::Full,
                };
                self.restart();
            }
            Action::ToggleOverlay => self.show_overlay ^= true,
            Action::ResetCamera => {
                self.camera = fly_camera(&self.scene, self.size[0], self.size[1]);
                self.camera_moved();
            }
            Action::ExposureUp => self.exposure += 1.0,
            Action::ExposureDown => self.exposure -= 1.0,
            Action::Toggle(t) => {
                *t.field(&mut self.settings) ^= true;
                self.restart();
            }
        }
        true
    }

    /// The path tracer's mean restarts when the camera moves.
    fn camera_moved(&mut self) {
        if let Some(Renderer::Path { sums, samples, .. }) = &mut self.renderer {
            sums.fill([0.0; 3]);
            *samples = 0;
        }
    }

    /// Moves the camera by the held keys over the time since the last frame.
    fn fly(&mut self, seconds: f32) {
        let mut m = Movement {
            fast: self.modifiers.shift_key(),
            ..Movement::default()
        };
        for &k in &self.held {
            if let Some((axis, sign)) = movement_axis(k) {
                let v = match axis {
                    0 => &mut m.forward,
                    1 => &mut m.right,
                    _ => &mut m.up,
                };
                *v = (*v + sign).clamp(-1.0, 1.0);
            }
        }
        if self.camera.step(m, seconds) {
            self.camera_moved();
        }
    }

    fn resize(&mut self, width: u32, height: u32) {
        if [width, height] == self.size || width == 0 || height == 0 {
            return;
        }
        self.size = [width, height];
        self.camera.resize(width, height);
        // The cache follows the resolution; the toggles stay.
        self.settings = self.settings.with_cache_for(width, height);
        self.restart();
    }

    /// Loads a dropped scene or environment; on failure the current scene stays and the error
    /// shows in the overlay.
    fn drop_file(&mut self, path: &Path) {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let loaded = match ext.as_str() {
            "gltf" | "glb" => load(path).and_then(|scene| {
                let env = self.environment.clone();
                self.upload(scene, env)?;
                self.scene_path = path.to_path_buf();
                self.camera = fly_camera(&self.scene, self.size[0], self.size[1]);
                Ok(())
            }),
            "hdr" | "exr" => Environment::read(path).map_err(Into::into).and_then(|env| {
                let scene = load(&self.scene_path)?;
                self.upload(scene, Some(env))
            }),
            _ => Err(format!(
                "{}: not a scene (.gltf, .glb) or an environment (.hdr, .exr)",
                path.display()
            )
            .into()),
        };
        // The loaders' errors name the file.
        self.message = loaded.err().map(|e| {
            let m = e.to_string();
            eprintln!("{m}");
            m
        });
    }

    /// Puts `scene` lit by `environment` on the device in place of the current one.
    fn upload(
        &mut self,
        scene: Scene,
        environment: Option<Environment>,
    ) -> Result<(), Box<dyn std::error::Error>> {
        let (lights, gpu) = GpuScene::upload_lit(self.ctx, &scene, environment.clone(), true)?;
        self.restart();
        self.gpu = gpu;
        self.lights = lights;
        self.scene = scene;
        self.environment = environment;
        Ok(())
    }
}

/// Per-pass GPU time of the last frame, in the frame's order.
fn passes(timings: &gi_host::vulkan::FrameTimings) -> Vec<(String, f64)> {
    timings
        .passes()
        .iter()
        .map(|p| (p.name.clone(), p.last_ms))
        .collect()
}

fn load(path: &Path) -> Result<Scene, Box<dyn std::error::Error>> {
    let (scene, warnings) = Scene::load(path)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// The scene's camera, flying at [`SPEED_PER_DIAGONAL`] of its size per second.
fn fly_camera(scene: &Scene, width: u32, height: u32) -> FlyCamera {
    let diagonal = scene.bounds.size().length();
    let speed = if diagonal.is_finite() && diagonal > 0.0 {
        SPEED_PER_DIAGONAL * diagonal
    } else {
        1.0
    };
    FlyCamera::new(scene_camera(scene, width, height), speed)
}

/// The window and its softbuffer surface.
struct Presenter {
    window: Rc<Window>,
    surface: softbuffer::Surface<Rc<Window>, Rc<Window>>,
    // The surface's display connection: dropped after it.
    _context: softbuffer::Context<Rc<Window>>,
}

/// The event loop's handler.
struct App<'a> {
    viewer: Viewer<'a>,
    window: Option<Presenter>,
    error: Option<Box<dyn std::error::Error>>,
}

impl App<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: Box<dyn std::error::Error>) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }

    fn open(
        &mut self,
        event_loop: &ActiveEventLoop,
    ) -> Result<Presenter, Box<dyn std::error::Error>> {
        let [w, h] = self.viewer.size;
        let attributes = Window::default_attributes()
            .with_title(format!("gi view: {}", self.viewer.scene_path.display()))
            .with_inner_size(PhysicalSize::new(w, h))
            // A scripted run's screenshot must have the render's size.
            .with_resizable(self.viewer.interactive());
        let window = Rc::new(event_loop.create_window(attributes)?);
        let context = softbuffer::Context::new(window.clone())
            .map_err(|e| format!("cannot present to the window: {e}"))?;
        let surface = softbuffer::Surface::new(&context, window.clone())
            .map_err(|e| format!("cannot present to the window: {e}"))?;
        Ok(Presenter {
            window,
            surface,
            _context: context,
        })
    }

    /// Renders, presents, and in a scripted run counts down and takes the screenshot.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<(), Box<dyn std::error::Error>> {
        let now = Instant::now();
        if self.viewer.last_frame.is_some() {
            for path in std::mem::take(&mut self.viewer.drops) {
                self.viewer.drop_file(&path);
            }
        }
        if let Some(last) = self.viewer.last_frame.replace(now) {
            let seconds = (now - last).as_secs_f32();
            self.viewer.frame_ms = f64::from(seconds) * 1e3;
            if self.viewer.interactive() {
                self.viewer.fly(seconds);
            }
        }
        let shown = match self.viewer.render() {
            Ok(shown) => shown,
            // A refused setting (a technique combination, a size) keeps the viewer open.
            Err(e) if self.viewer.interactive() => {
                self.viewer.message = Some(e.to_string());
                self.viewer.restart();
                return Ok(());
            }
            Err(e) => return Err(e.into()),
        };
        let pixels = self.viewer.pixels(&shown);
        let [w, h] = self.viewer.size;
        let Some(p) = &mut self.window else {
            return Ok(());
        };
        let (nw, nh) = (
            NonZeroU32::new(w).ok_or("zero width")?,
            NonZeroU32::new(h).ok_or("zero height")?,
        );
        p.surface.resize(nw, nh)?;
        let mut buffer = p.surface.buffer_mut()?;
        buffer.copy_from_slice(&pixels);
        buffer.present()?;
        if let Some(left) = &mut self.viewer.frames_left {
            *left -= 1;
            if *left == 0 {
                if let Some(path) = &self.viewer.screenshot {
                    write_screenshot(&mut p.surface, path, w, h)?;
                    println!("wrote                {}", path.display());
                }
                event_loop.exit();
            }
        }
        Ok(())
    }
}

/// Reads the window's pixels back from the X server and writes them as a PNG.
fn write_screenshot(
    surface: &mut softbuffer::Surface<Rc<Window>, Rc<Window>>,
    path: &Path,
    width: u32,
    height: u32,
) -> Result<(), Box<dyn std::error::Error>> {
    let pixels = surface
        .fetch()
        .map_err(|e| format!("screenshot: cannot read the window back: {e}"))?;
    if pixels.len() != width as usize * height as usize {
        return Err(format!(
            "screenshot: the window holds {} pixels, not {width}x{height}",
            pixels.len()
        )
        .into());
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    image::save_buffer_with_format(
        path,
        &to_rgb8(&pixels),
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("{}: cannot write PNG: {e}", path.display()).into())
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            match self.open(event_loop) {
                Ok(p) => {
                    p.window.request_redraw();
                    self.window = Some(p);
                }
                Err(e) => self.fail(event_loop, e),
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let interactive = self.viewer.interactive();
        let v = &mut self.viewer;
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            WindowEvent::Resized(size) if interactive => v.resize(size.width, size.height),
            WindowEvent::ModifiersChanged(m) => v.modifiers = m.state(),
            WindowEvent::KeyboardInput { event, .. } if interactive => {
                let PhysicalKey::Code(key) = event.physical_key else {
                    return;
                };
                match event.state {
                    ElementState::Pressed => {
                        v.held.insert(key);
                        if !event.repeat
                            && let Some(a) = bindings::action(key)
                            && !v.act(a)
                        {
                            event_loop.exit();
                        }
                    }
                    ElementState::Released => {
                        v.held.remove(&key);
                    }
                }
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } if interactive => {
                v.dragging = state == ElementState::Pressed;
            }
            WindowEvent::CursorMoved { position, .. } if interactive => {
                if let Some(last) = v.drag.replace(position)
                    && v.dragging
                    && v.camera
                        .turn((position.x - last.x) as f32, (position.y - last.y) as f32)
                {
                    v.camera_moved();
                }
            }
            WindowEvent::MouseWheel { delta, .. } if interactive => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 50.0) as f32,
                };
                v.camera.scale_speed(steps);
            }
            WindowEvent::DroppedFile(path) if interactive => v.drop_file(&path),
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(p) = &self.window {
            p.window.request_redraw();
        }
    }
}
