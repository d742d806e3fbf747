//! The walkthrough window: winit 0.30 event loop, wgpu surface, the five-pass renderer and an
//! egui 0.37 side panel (stats, camera, display and debug-view controls).
//!
//! Controls: WASD move, Q/E down/up, Shift 4× faster, drag with the left or right mouse button
//! over the scene to look around, F1 hides/shows the panel, F12 saves a screenshot (PNG,
//! without the panel), Esc quits.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context as _;
use vlf_core::image::Tonemap;
use vlf_core::lightfield::LightField;
use vlf_gpu::GpuContext;
use vlf_gpu::render::{CameraView, Pass, Renderer, TIMED_PASSES};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::cli::Cli;
use crate::fly::{FlyCamera, Held};

/// Frames over which fps and frame time are averaged.
const STATS_FRAMES: usize = 60;

/// Settings the window starts with (from the command line).
#[derive(Clone, Debug)]
struct Options {
    title: String,
    size: (u32, u32),
    exposure: f32,
    tonemap: Tonemap,
    debug_view: Pass,
    mirror_tracing: bool,
    /// Exit after this many frames.
    frames: Option<u64>,
    /// Screenshot to save before exiting after `frames`.
    screenshot: Option<PathBuf>,
}

/// Opens the window and runs until it is closed (or `--frames` frames were shown).
pub fn run_window(lf: LightField, camera: CameraView, cli: &Cli) -> anyhow::Result<()> {
    let source = cli
        .file
        .as_ref()
        .or(cli.bake_preview.as_ref())
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    if let Some(path) = &cli.screenshot {
        crate::image_kind(path)?;
    }
    let opts = Options {
        title: format!("vlf-view — {source}"),
        size: cli.size.unwrap_or((1024, 768)),
        exposure: cli.exposure,
        tonemap: cli.tonemap.into(),
        debug_view: cli.debug_view.into(),
        mirror_tracing: cli.mirror_tracing.into(),
        frames: cli.frames,
        screenshot: cli.screenshot.clone(),
    };
    let event_loop = EventLoop::new().context(
        "cannot open a window (no display?); run under a display (e.g. xvfb-run) or render \
         headless with --still",
    )?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut desc = wgpu::InstanceDescriptor::new_with_display_handle(Box::new(
        event_loop.owned_display_handle(),
    ));
    // Like GpuContext::new: no silent fallback to GL (it lacks the float formats we need).
    desc.backends = wgpu::Backends::PRIMARY;
    let instance = wgpu::Instance::new(desc.with_env());
    let mut app = App {
        lf,
        start: camera,
        opts,
        instance: Some(instance),
        gfx: None,
        error: None,
    };
    event_loop.run_app(&mut app).context("window event loop")?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App {
    lf: LightField,
    start: CameraView,
    opts: Options,
    /// Taken when the window is created (the GPU context owns it then).
    instance: Option<wgpu::Instance>,
    gfx: Option<Gfx>,
    error: Option<anyhow::Error>,
}

/// User-adjustable state shown in the panel.
struct UiState {
    exposure: f32,
    tonemap: Tonemap,
    debug_view: Pass,
    /// Whether mirror pixels trace their reflections (pass 5's traced branch).
    mirror_tracing: bool,
    /// Index of the glTF camera chosen in the panel.
    camera: usize,
    screenshot: bool,
    panel: bool,
    message: String,
}

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    ctx: GpuContext,
    renderer: Renderer,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    ui: UiState,
    cam: FlyCamera,
    held: Held,
    looking: bool,
    cursor: Option<(f64, f64)>,
    last: Instant,
    frame_ms: VecDeque<f64>,
    frames: u64,
    screenshots: u32,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        let Some(instance) = self.instance.take() else {
            return;
        };
        match Gfx::new(event_loop, instance, &self.lf, self.start, &self.opts) {
            Ok(g) => {
                g.window.request_redraw();
                self.gfx = Some(g);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(g) = self.gfx.as_mut() else { return };
        let response = g.egui_state.on_window_event(&g.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => g.resize(size),
            WindowEvent::Focused(false) => {
                g.held = Held::default();
                g.looking = false;
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        physical_key: PhysicalKey::Code(code),
                        state,
                        ..
                    },
                ..
            } => {
                if response.consumed && state == ElementState::Pressed {
                    return;
                }
                let down = state == ElementState::Pressed;
                match code {
                    KeyCode::KeyW | KeyCode::ArrowUp => g.held.forward = down,
                    KeyCode::KeyS | KeyCode::ArrowDown => g.held.back = down,
                    KeyCode::KeyA | KeyCode::ArrowLeft => g.held.left = down,
                    KeyCode::KeyD | KeyCode::ArrowRight => g.held.right = down,
                    KeyCode::KeyE | KeyCode::PageUp => g.held.up = down,
                    KeyCode::KeyQ | KeyCode::PageDown => g.held.down = down,
                    KeyCode::ShiftLeft | KeyCode::ShiftRight => g.held.fast = down,
                    KeyCode::F12 if down => g.ui.screenshot = true,
                    KeyCode::F1 if down => g.ui.panel = !g.ui.panel,
                    KeyCode::Escape if down => event_loop.exit(),
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                if matches!(button, MouseButton::Left | MouseButton::Right) {
                    g.looking = state == ElementState::Pressed
                        && !response.consumed
                        && !g.egui_ctx.egui_wants_pointer_input();
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some((x, y)) = g.cursor
                    && g.looking
                {
                    g.cam.look((position.x - x) as f32, (position.y - y) as f32);
                }
                g.cursor = Some((position.x, position.y));
            }
            WindowEvent::CursorLeft { .. } => g.cursor = None,
            WindowEvent::RedrawRequested => match g.frame(&self.lf, &self.opts) {
                Ok(done) => {
                    if done {
                        event_loop.exit();
                    }
                }
                Err(e) => {
                    self.error = Some(e);
                    event_loop.exit();
                }
            },
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(g) = &self.gfx {
            g.window.request_redraw();
        }
    }
}

impl Gfx {
    fn new(
        event_loop: &ActiveEventLoop,
        instance: wgpu::Instance,
        lf: &LightField,
        start: CameraView,
        opts: &Options,
    ) -> anyhow::Result<Self> {
        let attrs = Window::default_attributes()
            .with_title(opts.title.clone())
            .with_inner_size(PhysicalSize::new(opts.size.0, opts.size.1));
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .context("cannot create the window")?,
        );
        let surface = instance
            .create_surface(Arc::clone(&window))
            .context("cannot create a wgpu surface for the window")?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            apply_limit_buckets: false,
        }))
        .map_err(|e| vlf_gpu::DeviceError::NoAdapter {
            backends: format!("{:?} ({e})", wgpu::Backends::PRIMARY),
        })?;
        let ctx = GpuContext::from_adapter(instance, adapter)?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&ctx.adapter, size.width.max(1), size.height.max(1))
            .context("the window surface is not supported by the adapter")?;
        // egui-wgpu prefers a non-sRGB 8-bit surface (Vulkan/X11 offers Bgra8Unorm and
        // Bgra8UnormSrgb); the scene shaders then apply the sRGB transfer function themselves.
        let caps = surface.get_capabilities(&ctx.adapter);
        let preferred = [
            wgpu::TextureFormat::Bgra8Unorm,
            wgpu::TextureFormat::Rgba8Unorm,
        ];
        if let Some(f) = caps.formats.iter().find(|f| preferred.contains(f)) {
            config.format = *f;
        }
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&ctx.device, &config);
        let mut renderer = Renderer::new(&ctx, lf)?;
        renderer.set_debug_view(opts.debug_view);
        renderer.set_mirror_tracing(opts.mirror_tracing);
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(ctx.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(
            &ctx.device,
            config.format,
            egui_wgpu::RendererOptions::default(),
        );
        log::info!(
            "window {}×{} ({:?}) on {}",
            config.width,
            config.height,
            config.format,
            ctx.summary
        );
        Ok(Self {
            window,
            surface,
            config,
            ctx,
            renderer,
            egui_ctx,
            egui_state,
            egui_renderer,
            ui: UiState {
                exposure: opts.exposure,
                tonemap: opts.tonemap,
                debug_view: opts.debug_view,
                mirror_tracing: opts.mirror_tracing,
                camera: 0,
                screenshot: false,
                panel: true,
                message: String::new(),
            },
            cam: FlyCamera::new(start),
            held: Held::default(),
            looking: false,
            cursor: None,
            last: Instant::now(),
            frame_ms: VecDeque::new(),
            frames: 0,
            screenshots: 0,
        })
    }

    fn resize(&mut self, size: PhysicalSize<u32>) {
        if size.width == 0 || size.height == 0 {
            return;
        }
        self.config.width = size.width;
        self.config.height = size.height;
        self.surface.configure(&self.ctx.device, &self.config);
    }

    /// Draws one frame. Returns true when the `--frames` limit is reached.
    fn frame(&mut self, lf: &LightField, opts: &Options) -> anyhow::Result<bool> {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        if self.frames > 0 {
            self.frame_ms.push_back(dt * 1e3);
            if self.frame_ms.len() > STATS_FRAMES {
                self.frame_ms.pop_front();
            }
        }
        // Clamp the step so a stall (window drag, screenshot) does not teleport the camera.
        self.cam.update(&self.held, dt.min(0.1) as f32);

        // UI first: it may change what is rendered.
        let raw_input = self.egui_state.take_egui_input(&self.window);
        let egui_ctx = self.egui_ctx.clone();
        let stats = Stats::new(self);
        let mut jump = None;
        let mut full_output = egui_ctx.run_ui(raw_input, |ui| {
            panel(ui, &mut self.ui, &mut self.cam, lf, &stats, &mut jump);
        });
        if let Some(i) = jump {
            self.cam.view = CameraView::from_gltf(&lf.cameras[i], &lf.to_vlf);
        }
        self.renderer.set_debug_view(self.ui.debug_view);
        self.renderer.set_mirror_tracing(self.ui.mirror_tracing);
        self.egui_state
            .handle_platform_output(&self.window, full_output.platform_output);
        // egui's texture changes must all be applied (its debug builds panic otherwise): new
        // and changed textures now, freed ones once this frame no longer uses them.
        let mut delta = std::mem::take(&mut full_output.textures_delta);
        for (id, deltas) in delta.set.drain() {
            for d in &deltas {
                self.egui_renderer
                    .update_texture(&self.ctx.device, &self.ctx.queue, id, d);
            }
        }
        let freed: Vec<egui::TextureId> = delta.free.drain().collect();

        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                self.free_textures(&freed);
                return Ok(false);
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.free_textures(&freed);
                self.surface.configure(&self.ctx.device, &self.config);
                return Ok(false);
            }
            other => anyhow::bail!("cannot acquire the window's surface texture: {other:?}"),
        };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("Window::surface_view"),
            ..Default::default()
        });
        let (w, h) = (self.config.width, self.config.height);
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("Window::encoder"),
            });
        self.renderer.render_to_view(
            &self.ctx,
            &mut encoder,
            &self.cam.view,
            &view,
            self.config.format,
            w,
            h,
            self.ui.exposure.exp2(),
            crate::gpu_tonemap(self.ui.tonemap),
        )?;

        // egui on top of the scene.
        let jobs = self
            .egui_ctx
            .tessellate(full_output.shapes, full_output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [w, h],
            pixels_per_point: full_output.pixels_per_point,
        };
        let mut commands = self.egui_renderer.update_buffers(
            &self.ctx.device,
            &self.ctx.queue,
            &mut encoder,
            &jobs,
            &screen,
        );
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("Window::egui_pass"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Load,
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            self.egui_renderer.render(&mut pass, &jobs, &screen);
        }
        commands.push(encoder.finish());
        self.ctx.queue.submit(commands);
        self.window.pre_present_notify();
        self.ctx.queue.present(frame);
        self.free_textures(&freed);
        self.renderer.frame_submitted(&self.ctx);
        self.frames += 1;

        if std::mem::take(&mut self.ui.screenshot) {
            self.screenshots += 1;
            let secs = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            let path = PathBuf::from(format!("vlf-screenshot-{secs}-{}.png", self.screenshots));
            self.ui.message = match self.screenshot(&path) {
                Ok(()) => format!("saved {}", path.display()),
                Err(e) => format!("screenshot failed: {e:#}"),
            };
            log::info!("{}", self.ui.message);
        }
        if opts.frames.is_some_and(|n| self.frames >= n) {
            if let Some(path) = &opts.screenshot {
                self.screenshot(path)?;
                println!("wrote {} after {} frames", path.display(), self.frames);
            }
            return Ok(true);
        }
        Ok(false)
    }

    fn free_textures(&mut self, ids: &[egui::TextureId]) {
        for id in ids {
            self.egui_renderer.free_texture(id);
        }
    }

    /// Saves the current view (without the panel) as a PNG, as displayed: final radiance with
    /// the panel's exposure and tonemap, or the selected debug view.
    fn screenshot(&mut self, path: &std::path::Path) -> anyhow::Result<()> {
        let (w, h) = (self.config.width, self.config.height);
        let view = self.renderer.debug_view();
        let img = crate::still_with(&mut self.renderer, &self.ctx, &self.cam.view, w, h, 1, view)?;
        let (exposure, tonemap) = if view == Pass::FinalRadiance {
            (self.ui.exposure, self.ui.tonemap)
        } else {
            (0.0, Tonemap::Clamp)
        };
        crate::write_image(path, &img, exposure, tonemap)
            .with_context(|| format!("screenshot {}", path.display()))
    }
}

/// Numbers shown in the stats panel (collected before the UI borrows the state).
struct Stats {
    fps: f64,
    frame_ms: f64,
    pass_ms: Option<Vec<Option<f64>>>,
    has_timestamps: bool,
    adapter: String,
    size: (u32, u32),
    lf_bytes: u64,
    radiance_bytes: u64,
    texture_bytes: u64,
    target_bytes: u64,
}

impl Stats {
    fn new(g: &Gfx) -> Self {
        let frame_ms = if g.frame_ms.is_empty() {
            0.0
        } else {
            g.frame_ms.iter().sum::<f64>() / g.frame_ms.len() as f64
        };
        Self {
            fps: if frame_ms > 0.0 {
                1000.0 / frame_ms
            } else {
                0.0
            },
            frame_ms,
            pass_ms: g.renderer.pass_times().map(<[Option<f64>]>::to_vec),
            has_timestamps: g.renderer.has_pass_times(),
            adapter: g.ctx.summary.to_string(),
            size: (g.config.width, g.config.height),
            lf_bytes: g.renderer.light_field_bytes(),
            radiance_bytes: g.renderer.radiance_bytes(),
            texture_bytes: g.renderer.texture_bytes(),
            target_bytes: g.renderer.target_bytes(),
        }
    }
}

fn mib(bytes: u64) -> String {
    format!("{:.2} MiB", bytes as f64 / f64::from(1u32 << 20))
}

/// The side panel. Sets `jump` to a glTF camera index to move there.
fn panel(
    ui: &mut egui::Ui,
    state: &mut UiState,
    cam: &mut FlyCamera,
    lf: &LightField,
    stats: &Stats,
    jump: &mut Option<usize>,
) {
    if !state.panel {
        return;
    }
    egui::Panel::left("vlf-view-panel")
        .resizable(false)
        .default_size(250.0)
        .show(ui, |ui| {
            ui.heading("vlf-view");
            ui.label(format!(
                "{:.1} fps, {:.2} ms/frame",
                stats.fps, stats.frame_ms
            ));
            ui.label(format!(
                "{}×{} on {}",
                stats.size.0, stats.size.1, stats.adapter
            ));
            ui.collapsing("GPU pass times", |ui| match &stats.pass_ms {
                Some(p) => {
                    for (name, ms) in TIMED_PASSES.iter().zip(p) {
                        match ms {
                            Some(ms) => ui.label(format!("{name}: {ms:.2} ms")),
                            None => ui.label(format!("{name}: skipped")),
                        };
                    }
                    ui.label(format!("total: {:.2} ms", p.iter().flatten().sum::<f64>()));
                }
                None if stats.has_timestamps => {
                    ui.label("waiting for the first results…");
                }
                None => {
                    ui.label("unavailable (no TIMESTAMP_QUERY)");
                }
            });
            ui.collapsing("Light field", |ui| {
                ui.label(format!(
                    "{} faces, {} triangles, {} atlas texels",
                    lf.faces.len(),
                    lf.triangles.len(),
                    lf.irradiance.len()
                ));
                ui.label(format!("{} directions", lf.directions.len()));
                ui.label(format!("irradiance atlas: {}", mib(stats.radiance_bytes)));
                ui.label(format!(
                    "{} textures: {}",
                    lf.shading.textures.len(),
                    mib(stats.texture_bytes)
                ));
                ui.label(format!(
                    "on the GPU: {} (+ {} targets)",
                    mib(stats.lf_bytes),
                    mib(stats.target_bytes)
                ));
            });
            ui.separator();

            ui.label("Camera");
            ui.add(
                egui::Slider::new(&mut cam.speed, 0.01..=4.0)
                    .logarithmic(true)
                    .text("speed (VLF/s)"),
            );
            if !lf.cameras.is_empty() {
                let name = |i: usize| {
                    format!(
                        "{i}: {}",
                        lf.cameras[i].name.as_deref().unwrap_or("unnamed")
                    )
                };
                egui::ComboBox::from_id_salt("camera")
                    .selected_text(name(state.camera))
                    .show_ui(ui, |ui| {
                        for i in 0..lf.cameras.len() {
                            ui.selectable_value(&mut state.camera, i, name(i));
                        }
                    });
                if ui.button("jump to glTF camera").clicked() {
                    *jump = Some(state.camera);
                }
            }
            let p = cam.view.position;
            ui.label(format!(
                "position (VLF): {:.3}, {:.3}, {:.3}",
                p.x, p.y, p.z
            ));
            ui.separator();

            ui.label("Display");
            ui.add(egui::Slider::new(&mut state.exposure, -10.0..=10.0).text("exposure (stops)"));
            ui.horizontal(|ui| {
                ui.radio_value(&mut state.tonemap, Tonemap::Clamp, "linear");
                ui.radio_value(&mut state.tonemap, Tonemap::Aces, "ACES");
            });
            if vlf_gpu::render::mirror_trace::has_mirrors(lf) {
                // Its cost is in the final-radiance pass time above.
                ui.checkbox(&mut state.mirror_tracing, "trace mirror reflections")
                    .on_hover_text(
                        "on: mirror pixels trace their reflection through the scene; \
                         off: they read the baked mirror tiles (cost: final-radiance time)",
                    );
            }
            ui.separator();

            ui.label("Debug view");
            for pass in Pass::ALL {
                ui.radio_value(&mut state.debug_view, pass, pass.name());
            }
            ui.separator();
            if ui.button("screenshot (F12)").clicked() {
                state.screenshot = true;
            }
            if !state.message.is_empty() {
                ui.label(&state.message);
            }
            ui.separator();
            ui.small("WASD move · Q/E down/up · Shift fast · drag to look · F1 panel · Esc quit");
        });
}
