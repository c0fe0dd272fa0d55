//! The display (seed §2.1–2.2 MD, §3.3 Display Control): draws a session's Instance Space with
//! wgpu — shaded polygons in each object's colour and surface, a depth buffer, one directional
//! light and an ambient term, an optional edge overlay, a LOOK-FROM / LOOK-AT camera — to PNG
//! files on a headless device or to a window; incremental on change notifications (only what
//! changed is uploaded, and the bytes are counted).
//!
//! * [`renderer`] — the GPU device, per-body slots, [`Renderer::sync`], frames, picking.
//! * [`arena`] — space in the shared mesh buffers: ranges, holes, growth, compaction.
//! * [`camera`] — LOOK-FROM / LOOK-AT, perspective / orthographic, orbit / pan / zoom, rays.
//! * [`mesh`] — polygons to triangles and edges; ray casts.
//! * [`guides`] — the ground grid and the world axes.
//! * [`overlay`] — the status text drawn over a frame (bundled font).
//! * [`image`] — PNG and the golden-image comparison.
//! * [`private`] — the session display's files and directories, mode 0600 / 0700.
//! * [`trajectory`] — MD's file mode: joint-angle files played back.
//! * [`window`] — the interactive window (winit).
//! * [`app`] — `robosim render` and `robosim display`: the renderer wired to the Library Space
//!   and to sessions (through robosim-scene).
//! * [`bench`] — `robosim bench display`.
//! * [`vulkan_env`] — what the Vulkan loader sees: no "error" line from Mesa's Wayland probe
//!   on a successful run ([`quiet_vulkan_probe`], called first thing in `main`).
#![deny(unsafe_code)]

pub mod app;
pub mod arena;
pub mod bench;
pub mod camera;
pub mod guides;
pub mod image;
pub mod mesh;
pub mod overlay;
pub mod private;
pub mod render_urdf;
pub mod renderer;
pub mod trajectory;
pub mod vulkan_env;
pub mod window;

pub use camera::{Camera, Projection};
pub use image::{Diff, RgbaImage, Tolerance, compare};
pub use renderer::{Gpu, Hit, Renderer, Style, UploadStats};
pub use vulkan_env::quiet_vulkan_probe;

use std::path::PathBuf;

/// For tests that draw: `true` when this machine has no graphics adapter (the software Vulkan
/// driver, `mesa-vulkan-drivers libvulkan1`, is missing), after saying on standard error that
/// test `test` was SKIPPED and why — the caller returns at once. Under `CI=true` a missing
/// adapter fails the test instead (`.ci/run` installs the driver, so every test runs there), as
/// `robosim_rules::skipped_without_clips` does for CLIPS. The adapter is probed once per
/// process.
pub fn skipped_without_vulkan(test: &str) -> bool {
    static PROBE: std::sync::OnceLock<std::result::Result<(), String>> = std::sync::OnceLock::new();
    // The reason is kept as words: the probe is cached for the process, and the error is not
    // `Clone`; its causes are in them.
    let probe = PROBE.get_or_init(|| {
        Gpu::headless()
            .map(drop)
            .map_err(|e| robosim_instance_space::error_chain(&e))
    });
    let Err(why) = probe else {
        return false;
    };
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{test}: CI=true but this machine cannot draw: {why}"
    );
    eprintln!("\n*** SKIPPED {test}: this machine cannot draw: {why} ***\n");
    true
}

/// Why drawing failed. A variant that wraps wgpu's, winit's or png's error keeps it as its
/// source ([`std::error::Error::source`]); its message names what was being done.
#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    #[error("no graphics adapter: {0}; {hint}", hint = renderer::NO_ADAPTER_HINT)]
    NoAdapter(#[source] wgpu::RequestAdapterError),
    /// The adapter refused a device.
    #[error("graphics device: {0}")]
    DeviceRequest(#[source] wgpu::RequestDeviceError),
    /// A step of drawing on the device failed (`what`: waiting for the frame, readback).
    #[error("graphics device: {what}: {source}")]
    Gpu {
        what: &'static str,
        #[source]
        source: robosim_instance_space::Cause,
    },
    /// The device cannot do what was asked (a message, not a wrapped error).
    #[error("graphics device: {0}")]
    Device(String),
    #[error("{0}")]
    Camera(String),
    #[error("{0}")]
    Size(String),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {what}")]
    Image { path: PathBuf, what: String },
    /// png could not encode or decode the image at `path`.
    #[error("{path}: {source}")]
    Png {
        path: PathBuf,
        #[source]
        source: robosim_instance_space::Cause,
    },
    #[error("{path}:{line}: {what}")]
    Trajectory {
        path: PathBuf,
        line: usize,
        what: String,
    },
    #[error("window: {0}")]
    Window(String),
    /// The window system refused `what` (create the window, its surface, the event loop).
    #[error("window: {what}: {source}")]
    WindowSystem {
        what: &'static str,
        #[source]
        source: robosim_instance_space::Cause,
    },
}

pub type Result<T> = std::result::Result<T, DisplayError>;
