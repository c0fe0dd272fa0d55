//! The interactive window (winit, X11): the model drawn live, with the seed's MD/R2 controls
//! mapped to a mouse and keyboard — orbit (left drag), pan (right or middle drag, or shift +
//! left drag), zoom (wheel), pick (left click: object, link and polygon, as Starbase's pick
//! returned segment, label and offset), and the knob box as keys: `1`–`9` choose a joint,
//! `Tab` the next robot, `←`/`→` turn the chosen joint by 2° (`Shift`: 10°), `E` toggles the
//! edge overlay, `G` the ground grid and world axes, `O` perspective/orthographic, `F` frames
//! everything, `Esc` quits. The host's status (the simulator's time and joint values when one
//! runs) is drawn in the top-left corner and put in the title.
//!
//! What a window shows comes from a [`Host`]: the session (or local model) it draws, which
//! moves joints through the Instance Space like any other writer.

use crate::camera::{Camera, Projection};
use crate::renderer::{Gpu, Hit, Renderer, Style, instance_descriptor};
use crate::{DisplayError, Result};
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, ModifiersState, NamedKey};
use winit::window::{Window, WindowId};

/// What the window draws and how its controls act on the model.
pub trait Host {
    /// Brings `renderer` up to the newest model; true when something changed.
    fn update(&mut self, renderer: &mut Renderer) -> std::result::Result<bool, String>;
    /// The robots the knob keys can move: name and number of joints.
    fn robots(&self) -> Vec<(String, usize)>;
    /// Turns joint `joint` (0-based) of robot `robot` by `delta` (rad or m); a status line.
    fn jog(
        &mut self,
        robot: usize,
        joint: usize,
        delta: f64,
    ) -> std::result::Result<String, String>;
    /// "object … (link …), polygon …" for a pick.
    fn describe(&self, hit: &Hit) -> String;
    /// Makes a pick the session's selection (the object and polygon hit; `None`, a click on
    /// nothing, clears it) — one transaction, so the editor and every other process see it.
    /// The new version, or why it could not be written.
    fn select(&mut self, hit: Option<&Hit>) -> std::result::Result<u64, String>;
    /// Text drawn over the frame's top-left corner (lines separated by `\n`), if any.
    fn status(&self) -> Option<String> {
        None
    }
}

#[derive(Debug, Clone)]
pub struct WindowOptions {
    pub size: (u32, u32),
    pub title: String,
    /// Close after this many presented frames (for tests under Xvfb); `None`: run until closed.
    pub exit_after_frames: Option<u64>,
    /// How often to look for model changes.
    pub poll: Duration,
    /// Input replayed through the same handlers as the user's, one per poll after the first
    /// frame (for tests under Xvfb): `left`, `right`, `tab`, `1`–`9`, `e`, `o`, `f`, `g`,
    /// `click:X,Y`.
    pub script: Vec<String>,
    /// When the window opens on a model with nothing to draw (an empty session), frame the
    /// camera on the first bodies that appear — unless the user moved it first.
    pub frame_first_bodies: bool,
}

impl Default for WindowOptions {
    fn default() -> Self {
        WindowOptions {
            size: (1280, 800),
            title: "robosim".into(),
            exit_after_frames: None,
            poll: Duration::from_millis(16),
            script: Vec::new(),
            frame_first_bodies: true,
        }
    }
}

struct Live {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    renderer: Renderer,
}

struct App {
    host: Box<dyn Host>,
    opts: WindowOptions,
    camera: Option<Camera>,
    style: Style,
    live: Option<Live>,
    error: Option<DisplayError>,
    cursor: (f64, f64),
    pressed: Option<(MouseButton, (f64, f64))>,
    dragged: bool,
    modifiers: ModifiersState,
    robot: usize,
    joint: usize,
    status: String,
    frames: u64,
    script_at: usize,
    next_poll: Instant,
    /// Waiting for the first bodies to frame them (see [`WindowOptions::frame_first_bodies`]).
    frame_pending: bool,
    /// Framing the bodies added to the model shown (an instance, an imported robot) until the
    /// user moves the camera (with [`WindowOptions::frame_first_bodies`]); the bodies shown.
    frame_added: bool,
    shown: std::collections::BTreeSet<robosim_instance_space::Id>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: DisplayError) {
        self.error = Some(e);
        event_loop.exit();
    }

    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let attrs = Window::default_attributes()
            .with_title(self.opts.title.clone())
            .with_inner_size(winit::dpi::PhysicalSize::new(
                self.opts.size.0,
                self.opts.size.1,
            ));
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .map_err(window_err("create the window"))?,
        );
        let instance = wgpu::Instance::new(instance_descriptor(None));
        let surface = instance
            .create_surface(window.clone())
            .map_err(window_err("surface"))?;
        let gpu = Gpu::with_instance(instance, Some(&surface))?;
        let caps = surface.get_capabilities(&gpu.adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| DisplayError::Window("the surface offers no format".into()))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: Default::default(),
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        let mut renderer = Renderer::new(gpu, format);
        renderer.style = self.style;
        self.host
            .update(&mut renderer)
            .map_err(DisplayError::Window)?;
        match self.camera {
            Some(c) => renderer.camera = c,
            None => renderer.frame_all(),
        }
        self.frame_pending = self.opts.frame_first_bodies && renderer.body_count() == 0;
        self.shown = renderer.body_ids();
        renderer.set_status(self.host.status().as_deref());
        eprintln!("display: window on {}", renderer.gpu().describe());
        self.live = Some(Live {
            window,
            surface,
            config,
            renderer,
        });
        self.update_title();
        Ok(())
    }

    fn update_title(&self) {
        if let Some(l) = &self.live {
            let robots = self.host.robots();
            let knob = robots
                .get(self.robot)
                .map(|(n, _)| format!(" — {n} joint {}", self.joint + 1))
                .unwrap_or_default();
            l.window
                .set_title(&format!("{}{knob} — {}", self.opts.title, self.status));
        }
    }

    fn draw(&mut self, event_loop: &ActiveEventLoop) {
        let Some(l) = &mut self.live else { return };
        let frame = match l.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                l.surface.configure(&l.renderer.gpu().device, &l.config);
                l.window.request_redraw();
                return;
            }
            _ => {
                l.window.request_redraw();
                return;
            }
        };
        let view = frame.texture.create_view(&Default::default());
        l.renderer.render_to(&view, l.config.width, l.config.height);
        l.window.pre_present_notify();
        l.renderer.gpu().queue.present(frame);
        self.frames += 1;
        if let Some(n) = self.opts.exit_after_frames {
            if self.frames >= n && self.script_at >= self.opts.script.len() {
                eprintln!("display: {} frames presented, closing", self.frames);
                event_loop.exit();
            } else {
                // A frame budget (tests): draw continuously until it is spent.
                l.window.request_redraw();
            }
        }
    }

    /// A pick: described, and committed as the session's selection.
    fn click(&mut self, x: f64, y: f64) {
        let Some(l) = &self.live else { return };
        let hit = l.renderer.pick(x, y, l.config.width, l.config.height);
        let what = match &hit {
            Some(h) => self.host.describe(h),
            None => "nothing there".into(),
        };
        self.status = match self.host.select(hit.as_ref()) {
            Ok(v) => format!("{what} — selected (version {v})"),
            Err(e) => format!("{what} — not selected: {e}"),
        };
        println!("pick: {}", self.status);
        self.update_title();
    }

    fn scripted(&mut self, step: &str) {
        println!("script: {step}");
        if let Some((x, y)) = step
            .strip_prefix("click:")
            .and_then(|xy| xy.split_once(','))
            .and_then(|(x, y)| Some((x.trim().parse().ok()?, y.trim().parse().ok()?)))
        {
            self.click(x, y);
            return;
        }
        let key = match step {
            "left" => Key::Named(NamedKey::ArrowLeft),
            "right" => Key::Named(NamedKey::ArrowRight),
            "tab" => Key::Named(NamedKey::Tab),
            other => Key::Character(other.into()),
        };
        self.key(&key);
        println!("status: {}", self.status);
    }

    fn key(&mut self, key: &Key) {
        let Some(l) = &mut self.live else { return };
        let step = if self.modifiers.shift_key() {
            10f64
        } else {
            2f64
        }
        .to_radians();
        let robots = self.host.robots();
        match key {
            Key::Named(NamedKey::ArrowLeft) | Key::Named(NamedKey::ArrowRight) => {
                let sign = if matches!(key, Key::Named(NamedKey::ArrowLeft)) {
                    -1.0
                } else {
                    1.0
                };
                self.status = match self.host.jog(self.robot, self.joint, sign * step) {
                    Ok(s) | Err(s) => s,
                };
            }
            Key::Named(NamedKey::Tab) if !robots.is_empty() => {
                self.robot = (self.robot + 1) % robots.len();
                self.joint = 0;
            }
            Key::Character(c) => match c.as_str() {
                d @ ("1" | "2" | "3" | "4" | "5" | "6" | "7" | "8" | "9") => {
                    let j = d.parse::<usize>().unwrap_or(1) - 1;
                    if robots.get(self.robot).is_some_and(|(_, n)| j < *n) {
                        self.joint = j;
                    }
                }
                "e" | "E" => l.renderer.style.edges = !l.renderer.style.edges,
                "o" | "O" => {
                    l.renderer.camera.projection = match l.renderer.camera.projection {
                        Projection::Perspective => Projection::Orthographic,
                        Projection::Orthographic => Projection::Perspective,
                    }
                }
                "f" | "F" => l.renderer.frame_all(),
                "g" | "G" => l.renderer.style.grid = !l.renderer.style.grid,
                _ => {}
            },
            _ => {}
        }
        l.window.request_redraw();
        self.update_title();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.live.is_none()
            && let Err(e) = self.start(event_loop)
        {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.frames > 0 && self.script_at < self.opts.script.len() {
            let step = self.opts.script[self.script_at].clone();
            self.script_at += 1;
            self.scripted(&step);
        }
        if Instant::now() >= self.next_poll {
            self.next_poll = Instant::now() + self.opts.poll;
            let mut title = None;
            if let Some(l) = &mut self.live {
                match self.host.update(&mut l.renderer) {
                    Ok(true) => {
                        if self.frame_pending && l.renderer.body_count() > 0 {
                            l.renderer.frame_all();
                            self.frame_pending = false;
                        } else if self.frame_added
                            && let Some(added) = l.renderer.added_since(&self.shown)
                        {
                            l.renderer.frame_on(&added);
                        }
                        self.shown = l.renderer.body_ids();
                        let status = self.host.status();
                        if status.as_deref() != l.renderer.status() {
                            l.renderer.set_status(status.as_deref());
                            // The title carries the first line too.
                            title = status.and_then(|s| s.lines().next().map(str::to_owned));
                        }
                        l.window.request_redraw();
                    }
                    Ok(false) => {}
                    Err(e) => title = Some(e),
                }
            }
            if let Some(t) = title {
                self.status = t;
                self.update_title();
            }
        }
        event_loop.set_control_flow(ControlFlow::WaitUntil(self.next_poll));
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(l) = &mut self.live {
                    l.config.width = size.width.max(1);
                    l.config.height = size.height.max(1);
                    l.surface.configure(&l.renderer.gpu().device, &l.config);
                    l.window.request_redraw();
                }
            }
            WindowEvent::RedrawRequested => self.draw(event_loop),
            WindowEvent::ModifiersChanged(m) => self.modifiers = m.state(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                if event.logical_key == Key::Named(NamedKey::Escape) {
                    event_loop.exit();
                } else {
                    self.key(&event.logical_key);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => match state {
                ElementState::Pressed => {
                    self.pressed = Some((button, self.cursor));
                    self.dragged = false;
                }
                ElementState::Released => {
                    if let Some((MouseButton::Left, at)) = self.pressed
                        && !self.dragged
                    {
                        self.click(at.0, at.1);
                    }
                    self.pressed = None;
                }
            },
            WindowEvent::CursorMoved { position, .. } => {
                let (dx, dy) = (position.x - self.cursor.0, position.y - self.cursor.1);
                self.cursor = (position.x, position.y);
                if let (Some((button, start)), Some(l)) = (self.pressed, &mut self.live) {
                    if (position.x - start.0).abs() + (position.y - start.1).abs() > 3.0 {
                        self.dragged = true;
                        self.frame_pending = false;
                        self.frame_added = false;
                    }
                    if !self.dragged {
                        return;
                    }
                    let h = l.config.height.max(1) as f64;
                    let pan = button != MouseButton::Left || self.modifiers.shift_key();
                    if pan {
                        l.renderer.camera.pan(dx / h, dy / h);
                    } else {
                        l.renderer.camera.orbit(-dx / h * 3.0, -dy / h * 3.0);
                    }
                    l.window.request_redraw();
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.frame_pending = false;
                self.frame_added = false;
                if let Some(l) = &mut self.live {
                    l.renderer.camera.zoom(0.9f64.powf(lines));
                    l.window.request_redraw();
                }
            }
            _ => {}
        }
    }
}

/// Opens the window and runs until it is closed (or `exit_after_frames`). Needs a display
/// server (`DISPLAY`); the error says so when there is none.
pub fn run(
    host: Box<dyn Host>,
    camera: Option<Camera>,
    style: Style,
    opts: WindowOptions,
) -> Result<()> {
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        return Err(DisplayError::Window(
            "no display server (DISPLAY is not set); use `robosim render` or `robosim display --headless` for images"
                .into(),
        ));
    }
    let event_loop = EventLoop::new().map_err(window_err("event loop"))?;
    let frame_added = opts.frame_first_bodies;
    let mut app = App {
        host,
        opts,
        camera,
        style,
        live: None,
        error: None,
        cursor: (0.0, 0.0),
        pressed: None,
        dragged: false,
        modifiers: ModifiersState::empty(),
        robot: 0,
        joint: 0,
        status: "click an object to pick it".into(),
        frames: 0,
        script_at: 0,
        next_poll: Instant::now(),
        frame_pending: false,
        frame_added,
        shown: std::collections::BTreeSet::new(),
    };
    event_loop
        .run_app(&mut app)
        .map_err(window_err("event loop"))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// A [`DisplayError::WindowSystem`] for `what`, keeping winit's or wgpu's error.
fn window_err<E: Into<robosim_instance_space::Cause>>(
    what: &'static str,
) -> impl FnOnce(E) -> DisplayError {
    move |e| DisplayError::WindowSystem {
        what,
        source: e.into(),
    }
}
