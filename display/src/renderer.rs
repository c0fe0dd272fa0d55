//! The GPU side: one wgpu device, two pipelines (shaded polygons, edge overlay), and per body a
//! slot in two storage arrays (transform, material) plus a range in the shared mesh buffers
//! ([`crate::arena`]: every body's triangles in one of a few large vertex buffers, its edges in
//! another, each vertex carrying its body's slot) — the seed's display list with one segment
//! per body (§2.1), packed so that the number of GPU resources does not grow with the number
//! of bodies. [`Renderer::sync`] brings the GPU copy up to a snapshot and uploads only what
//! differs: a moved body's 64-byte transform, a recoloured body's 32-byte material, a
//! re-shaped body's mesh. Every byte written is counted ([`UploadStats`]). A frame draws each
//! shared buffer's live runs (one draw per run between freed ranges, not one per body).
//!
//! Besides the model a frame may show the guides (ground grid and world axes, [`Style::grid`];
//! [`crate::guides`]) and a status overlay ([`Renderer::set_status`]; [`crate::overlay`]).
//! Neither is model data: their uploads are not in [`UploadStats`].

use crate::arena::{Arena, Span};
use crate::camera::Camera;
use crate::guides::{GuideVertex, Guides};
use crate::image::RgbaImage;
use crate::mesh::CpuMesh;
use crate::overlay::Overlay;
use crate::{DisplayError, Result};
use nalgebra::{Matrix4, Point3, Vector3};
use robosim_instance_space::{Change, Id, Snapshot, aspect, layout::flags};
use std::collections::HashMap;
use std::mem::size_of;
use wgpu::util::DeviceExt;

/// Bytes of one body's transform on the GPU (a 4×4 f32 matrix).
pub const TRANSFORM_BYTES: u64 = 64;
/// Bytes of one body's material (colour + surface).
pub const MATERIAL_BYTES: u64 = 32;
const FRAME_BYTES: u64 = 112;
/// Vertices a shared mesh buffer starts with (it doubles when full).
const ARENA_INITIAL: u32 = 1 << 12;

/// One vertex of the shared triangle buffers: the mesh's vertex and its body's slot (the
/// index of its transform and material).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SlotVertex {
    pub pos: [f32; 3],
    pub normal: [f32; 3],
    pub slot: u32,
}

/// One end of an edge line in the shared edge buffers.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SlotPoint {
    pub pos: [f32; 3],
    pub slot: u32,
}
const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A [`DisplayError::Gpu`] for `what`, keeping wgpu's error.
fn gpu_err<E: Into<robosim_instance_space::Cause>>(
    what: &'static str,
) -> impl FnOnce(E) -> DisplayError {
    move |e| DisplayError::Gpu {
        what,
        source: e.into(),
    }
}

/// What to do when no Vulkan adapter is found: the software driver is the one system package
/// the display needs.
pub const NO_ADAPTER_HINT: &str = "robosim draws with Vulkan; on a machine without a GPU \
     install Mesa's software Vulkan driver: sudo apt-get install mesa-vulkan-drivers libvulkan1 \
     (Debian/Ubuntu; Fedora: sudo dnf install mesa-vulkan-drivers)";

/// The device everything is drawn with.
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// A device with no window: Vulkan, any adapter (Mesa's llvmpipe on a machine without a
    /// GPU). `WGPU_ADAPTER_NAME` / `WGPU_BACKEND` are honoured (wgpu's own variables).
    pub fn headless() -> Result<Gpu> {
        let instance = wgpu::Instance::new(instance_descriptor(None));
        Self::with_instance(instance, None)
    }

    /// A device for `instance` that can present to `surface` if given.
    pub fn with_instance(
        instance: wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Gpu> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            apply_limit_buckets: false,
        }))
        .map_err(DisplayError::NoAdapter)?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("robosim display"),
            required_features: wgpu::Features::empty(),
            // The adapter's largest buffer (the shared mesh buffers grow up to it; beyond it
            // another one is added).
            required_limits: wgpu::Limits {
                max_buffer_size: adapter.limits().max_buffer_size,
                ..wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits())
            },
            ..Default::default()
        }))
        .map_err(DisplayError::DeviceRequest)?;
        Ok(Gpu {
            instance,
            adapter,
            device,
            queue,
        })
    }

    /// "name (backend, device type)" of the adapter.
    pub fn describe(&self) -> String {
        let i = self.adapter.get_info();
        format!("{} ({:?}, {:?})", i.name, i.backend, i.device_type)
    }
}

/// Vulkan only (the one backend the build enables), environment overrides applied.
pub fn instance_descriptor(
    display: Option<Box<dyn wgpu::wgt::WgpuHasDisplayHandle>>,
) -> wgpu::InstanceDescriptor {
    let mut d = match display {
        Some(h) => wgpu::InstanceDescriptor::new_with_display_handle(h),
        None => wgpu::InstanceDescriptor::new_without_display_handle(),
    };
    d.backends = wgpu::Backends::VULKAN;
    d.with_env()
}

/// The bounding sphere (centre, radius) of the bodies of `snap` (objects with geometry) at
/// their world poses — what a renderer synced to `snap` reports as [`Renderer::bounds`],
/// without a device (to place a camera before one exists).
pub fn scene_bounds(snap: &Snapshot) -> (Point3<f64>, f64) {
    let bodies: Vec<([f64; 12], [f64; 6])> = (0..snap.len())
        .filter_map(|i| Some((snap.world_pose(i), snap.geometry(i)?.header.bbox)))
        .collect();
    sphere_around(bodies.iter().map(|(w, b)| (w, b)))
}

/// The sphere around the world boxes of bodies given as (world pose, body-frame bbox centre
/// and half-diagonal); the unit sphere for none.
fn sphere_around<'a>(
    bodies: impl Iterator<Item = (&'a [f64; 12], &'a [f64; 6])>,
) -> (Point3<f64>, f64) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (w, bbox) in bodies {
        let (l, h) = world_box(w, bbox);
        for r in 0..3 {
            lo[r] = lo[r].min(l[r]);
            hi[r] = hi[r].max(h[r]);
        }
    }
    sphere_of_box(lo, hi)
}

/// The world axis-aligned box (low, high corners) of a body-frame box (centre and
/// half-diagonal) at world pose `w`.
fn world_box(w: &[f64; 12], bbox: &[f64; 6]) -> ([f64; 3], [f64; 3]) {
    let c = Vector3::new(bbox[0], bbox[1], bbox[2]);
    let h = Vector3::new(bbox[3], bbox[4], bbox[5]);
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for r in 0..3 {
        let center = w[r * 4] * c.x + w[r * 4 + 1] * c.y + w[r * 4 + 2] * c.z + w[r * 4 + 3];
        let half = w[r * 4].abs() * h.x + w[r * 4 + 1].abs() * h.y + w[r * 4 + 2].abs() * h.z;
        lo[r] = center - half;
        hi[r] = center + half;
    }
    (lo, hi)
}

/// The sphere around a box; the unit sphere for an empty (or non-finite) one.
fn sphere_of_box(lo: [f64; 3], hi: [f64; 3]) -> (Point3<f64>, f64) {
    if !(lo.iter().all(|v| v.is_finite()) && hi.iter().all(|v| v.is_finite())) {
        return (Point3::origin(), 1.0);
    }
    let (lo, hi) = (Vector3::from(lo), Vector3::from(hi));
    let center = Point3::from((lo + hi) / 2.0);
    (center, ((hi - lo) / 2.0).norm().max(1e-6))
}

/// Every slot's world box and a binary tree of their unions, so that the scene's box is the
/// root and a body's move updates the boxes on its way up (O(log bodies)) instead of every
/// frame going over every body. Min and max are exact, so the root is the box a pass over all
/// bodies finds ([`scene_bounds`]).
struct BoxTree {
    /// Leaves (a power of two); node `k`'s children are `2k` and `2k + 1`, leaf `i` is node
    /// `leaves + i`.
    leaves: usize,
    lo: Vec<[f64; 3]>,
    hi: Vec<[f64; 3]>,
}

impl BoxTree {
    const EMPTY_LO: [f64; 3] = [f64::INFINITY; 3];
    const EMPTY_HI: [f64; 3] = [f64::NEG_INFINITY; 3];

    fn new() -> BoxTree {
        BoxTree {
            leaves: 1,
            lo: vec![Self::EMPTY_LO; 2],
            hi: vec![Self::EMPTY_HI; 2],
        }
    }

    fn join(&mut self, k: usize) {
        let (a, b) = (2 * k, 2 * k + 1);
        self.lo[k] = std::array::from_fn(|r| self.lo[a][r].min(self.lo[b][r]));
        self.hi[k] = std::array::from_fn(|r| self.hi[a][r].max(self.hi[b][r]));
    }

    /// Sets slot `slot`'s box (`EMPTY_*`: no body there).
    fn set(&mut self, slot: u32, lo: [f64; 3], hi: [f64; 3]) {
        let slot = slot as usize;
        if slot >= self.leaves {
            let mut leaves = self.leaves;
            while leaves <= slot {
                leaves *= 2;
            }
            let mut lo_v = vec![Self::EMPTY_LO; 2 * leaves];
            let mut hi_v = vec![Self::EMPTY_HI; 2 * leaves];
            lo_v[leaves..leaves + self.leaves].copy_from_slice(&self.lo[self.leaves..]);
            hi_v[leaves..leaves + self.leaves].copy_from_slice(&self.hi[self.leaves..]);
            self.leaves = leaves;
            self.lo = lo_v;
            self.hi = hi_v;
            for k in (1..leaves).rev() {
                self.join(k);
            }
        }
        let mut k = self.leaves + slot;
        self.lo[k] = lo;
        self.hi[k] = hi;
        // Up to the root, or to the first node the change leaves as it was (its ancestors
        // are then unchanged too): a body moving inside the scene's box touches a few nodes.
        while k > 1 {
            k /= 2;
            let before = (self.lo[k], self.hi[k]);
            self.join(k);
            if (self.lo[k], self.hi[k]) == before {
                break;
            }
        }
    }

    fn clear(&mut self, slot: u32) {
        if (slot as usize) < self.leaves {
            self.set(slot, Self::EMPTY_LO, Self::EMPTY_HI);
        }
    }

    fn root(&self) -> ([f64; 3], [f64; 3]) {
        (self.lo[1], self.hi[1])
    }
}

/// The smallest sphere holding spheres `a` and `b` (centre, radius).
fn sphere_union(a: (Point3<f64>, f64), b: (Point3<f64>, f64)) -> (Point3<f64>, f64) {
    let d = (b.0 - a.0).norm();
    if d + b.1 <= a.1 {
        return a;
    }
    if d + a.1 <= b.1 {
        return b;
    }
    let r = (d + a.1 + b.1) / 2.0;
    (a.0 + (b.0 - a.0) * ((r - a.1) / d), r)
}

/// Bytes and items written to the GPU by one [`Renderer::sync`] (or summed over many).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct UploadStats {
    /// Body transforms written.
    pub transforms: u64,
    pub transform_bytes: u64,
    /// Body materials written.
    pub materials: u64,
    pub material_bytes: u64,
    /// Meshes (their triangle and edge vertices) uploaded.
    pub meshes: u64,
    pub mesh_bytes: u64,
    /// Times the per-body arrays grew and were rewritten whole, or a shared mesh buffer grew
    /// (its contents copied on the GPU, not uploaded again).
    pub regrowths: u64,
    /// Times a shared mesh buffer was compacted (its live ranges copied together on the GPU).
    pub compactions: u64,
}

impl UploadStats {
    pub fn total_bytes(&self) -> u64 {
        self.transform_bytes + self.material_bytes + self.mesh_bytes
    }
    pub fn add(&mut self, o: &UploadStats) {
        self.transforms += o.transforms;
        self.transform_bytes += o.transform_bytes;
        self.materials += o.materials;
        self.material_bytes += o.material_bytes;
        self.meshes += o.meshes;
        self.mesh_bytes += o.mesh_bytes;
        self.regrowths += o.regrowths;
        self.compactions += o.compactions;
    }
}

/// What a frame shows besides the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Style {
    /// Draw every polygon edge over the shading.
    pub edges: bool,
    /// Draw the ground grid (z = 0) and the world axes ([`crate::guides`]).
    pub grid: bool,
    /// Linear RGB background.
    pub background: [f64; 3],
    /// Ambient term (0..1) added to every surface.
    pub ambient: f32,
}

impl Default for Style {
    fn default() -> Self {
        Style {
            edges: false,
            grid: false,
            background: [0.62, 0.68, 0.75],
            ambient: 0.22,
        }
    }
}

/// Where a body's vertices are in a [`Pool`]: page and range (in vertices).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Place {
    page: u32,
    span: Span,
}

/// One shared vertex buffer and the allocator of its space.
struct Page {
    arena: Arena,
    buffer: wgpu::Buffer,
}

/// Meshes of one kind (triangles, or edge lines) packed into shared vertex buffers: a page
/// grows by doubling (a bigger buffer, the live part copied on the GPU) up to the device's
/// largest buffer, and another page is added beyond that.
struct Pool {
    label: &'static str,
    /// Bytes per vertex.
    stride: u64,
    /// The most vertices one page (buffer) may hold.
    max_elems: u32,
    pages: Vec<Page>,
}

/// Which buffer a queued write goes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Target {
    Transforms,
    Materials,
    Tri(u32),
    Edge(u32),
}

struct Body {
    slot: u32,
    /// Its index in the snapshot last synced in full (valid while only poses change since:
    /// `sync_changes` checks the record's id before using it).
    index: usize,
    world: [f64; 12],
    material: [f32; 8],
    geom_gen: u64,
    /// bbox centre and half-diagonal, body frame.
    bbox: [f64; 6],
    /// The mesh on the CPU (for picking and for the counts).
    cpu: CpuMesh,
    /// Its triangles and edges in the shared buffers (`None`: it has none).
    tri: Option<Place>,
    edge: Option<Place>,
}

struct Targets {
    size: (u32, u32),
    color: wgpu::Texture,
    msaa: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

/// A hit of [`Renderer::pick`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub id: Id,
    /// Index of the polygon in the object's geometry.
    pub polygon: u32,
    /// Distance from the camera along the ray (m).
    pub distance: f64,
    pub point: Point3<f64>,
}

pub struct Renderer {
    gpu: Gpu,
    format: wgpu::TextureFormat,
    samples: u32,
    solid: wgpu::RenderPipeline,
    edge: wgpu::RenderPipeline,
    guide: wgpu::RenderPipeline,
    /// The guides drawn for the current bounds, their line vertices and count.
    guides: Option<(Guides, wgpu::Buffer, u32)>,
    overlay: Overlay,
    layout: wgpu::BindGroupLayout,
    frame: wgpu::Buffer,
    transforms: wgpu::Buffer,
    materials: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    capacity: u32,
    /// Every body's triangles, and every body's edge lines, in shared buffers.
    tris: Pool,
    edges: Pool,
    /// Writes not yet handed to the queue: contiguous writes to one buffer are merged (a
    /// first sync of 10⁵ bodies makes a few large writes, not 10⁵ small ones). Flushed at
    /// the end of every sync and before any buffer is replaced.
    writes: Vec<(Target, u64, Vec<u8>)>,
    /// Triangles of all bodies.
    triangles: usize,
    /// Every body's world box, and their union ([`Renderer::bounds`]).
    boxes: BoxTree,
    bodies: HashMap<Id, Body>,
    free: Vec<u32>,
    next_slot: u32,
    highlight: std::collections::HashSet<Id>,
    /// Every object's children as of the last full sync (for change-driven syncs).
    children: HashMap<Id, Vec<Id>>,
    /// (version, epoch) the last sync reached.
    synced: Option<(u64, u64)>,
    last: UploadStats,
    total: UploadStats,
    version: u64,
    targets: Option<Targets>,
    pub camera: Camera,
    pub style: Style,
}

fn transform_f32(p: &[f64; 12]) -> [f32; 16] {
    // Column-major 4×4 from row-major 3×4.
    [
        p[0] as f32,
        p[4] as f32,
        p[8] as f32,
        0.0,
        p[1] as f32,
        p[5] as f32,
        p[9] as f32,
        0.0,
        p[2] as f32,
        p[6] as f32,
        p[10] as f32,
        0.0,
        p[3] as f32,
        p[7] as f32,
        p[11] as f32,
        1.0,
    ]
}

fn mat4_f32(m: &Matrix4<f64>) -> [f32; 16] {
    let mut out = [0.0; 16];
    for (o, v) in out.iter_mut().zip(m.iter()) {
        *o = *v as f32;
    }
    out
}

impl Pool {
    fn new(label: &'static str, stride: u64, max_buffer: u64) -> Pool {
        let mut p = Pool {
            label,
            stride,
            max_elems: 0,
            pages: Vec::new(),
        };
        p.set_limit(max_buffer);
        p
    }

    /// The largest buffer to make, in bytes (at most 2 GiB: a page's offsets are u32
    /// vertices, and no scene needs more per buffer).
    fn set_limit(&mut self, bytes: u64) {
        self.max_elems = (bytes.min(1 << 31) / self.stride).max(1) as u32;
    }

    fn buffer(&self, device: &wgpu::Device, elems: u32) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(self.label),
            size: elems as u64 * self.stride,
            usage: wgpu::BufferUsages::VERTEX
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    /// `n` vertices in the first page with room (a hole or above its top), without growing.
    fn try_alloc(&mut self, n: u32) -> Option<Place> {
        self.pages.iter_mut().enumerate().find_map(|(k, p)| {
            p.arena.alloc(n).map(|start| Place {
                page: k as u32,
                span: Span { start, len: n },
            })
        })
    }

    /// Makes room for `n` vertices — the last page grown (up to [`Pool::max_elems`]), else a
    /// new page — and allocates them there. The caller has flushed its queued writes.
    fn make_room(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        n: u32,
        stats: &mut UploadStats,
    ) -> Option<Place> {
        let max = self.max_elems as u64;
        let growable = self.pages.last().and_then(|p| {
            let needed = p.arena.needed_for(n);
            (needed <= max).then(|| (p.arena.capacity() as u64 * 2).max(needed).min(max) as u32)
        });
        let page = match growable {
            Some(capacity) => {
                let k = self.pages.len() - 1;
                let buffer = self.buffer(device, capacity);
                let p = &mut self.pages[k];
                let live = p.arena.top() as u64 * self.stride;
                if live > 0 {
                    let mut enc = device.create_command_encoder(&Default::default());
                    enc.copy_buffer_to_buffer(&p.buffer, 0, &buffer, 0, live);
                    // Submitted now: writes queued for the new buffer from here on belong to
                    // the next submission, which runs after this copy.
                    queue.submit([enc.finish()]);
                }
                p.buffer = buffer;
                p.arena.grow(capacity);
                stats.regrowths += 1;
                k
            }
            None => {
                let capacity = (n.next_power_of_two() as u64)
                    .max(ARENA_INITIAL as u64)
                    .min(max) as u32;
                let buffer = self.buffer(device, capacity);
                self.pages.push(Page {
                    arena: Arena::new(capacity),
                    buffer,
                });
                self.pages.len() - 1
            }
        };
        let start = self.pages[page].arena.alloc(n)?;
        Some(Place {
            page: page as u32,
            span: Span { start, len: n },
        })
    }

    /// Compacts page `page` into a new buffer (half as big again as what is live, at least
    /// the initial size): every live run copied on the GPU, submitted at once.
    fn compact(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        page: u32,
    ) -> crate::arena::Compaction {
        let used = self.pages[page as usize].arena.used() as u64;
        let capacity = (used + used / 2)
            .max(ARENA_INITIAL as u64)
            .min(self.max_elems as u64)
            .max(used) as u32;
        let buffer = self.buffer(device, capacity);
        let stride = self.stride;
        let p = &mut self.pages[page as usize];
        let c = p.arena.compact();
        p.arena.set_capacity(capacity);
        let mut enc = device.create_command_encoder(&Default::default());
        for &(src, dst, len) in &c.copies {
            enc.copy_buffer_to_buffer(
                &p.buffer,
                src as u64 * stride,
                &buffer,
                dst as u64 * stride,
                len as u64 * stride,
            );
        }
        queue.submit([enc.finish()]);
        p.buffer = buffer;
        c
    }
}

/// ROBOSIM_DISPLAY_SAMPLES=1 turns multisampling off (a different rasterization of the same
/// scene: the golden-image tolerance is checked against it); otherwise 4 where the adapter
/// allows it for both the colour `format` and the depth format, else 1.
fn sample_count(gpu: &Gpu, format: wgpu::TextureFormat) -> u32 {
    let forced = std::env::var("ROBOSIM_DISPLAY_SAMPLES").ok();
    if forced.as_deref() == Some("1") {
        return 1;
    }
    let c = gpu.adapter.get_texture_format_features(format);
    let d = gpu.adapter.get_texture_format_features(DEPTH_FORMAT);
    if c.flags.sample_count_supported(4) && d.flags.sample_count_supported(4) {
        4
    } else {
        1
    }
}

/// The shader's bindings: the frame uniform (0) and the bodies' transforms and materials (1,
/// 2, read-only storage).
fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let storage = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("robosim display bindings"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            storage(1),
            storage(2),
        ],
    })
}

/// What the renderer's three pipelines share: the shader, the pipeline layout, multisampling
/// and the colour target.
struct PipelineParts {
    shader: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    multisample: wgpu::MultisampleState,
    target: [Option<wgpu::ColorTargetState>; 1],
}

impl PipelineParts {
    fn new(
        device: &wgpu::Device,
        bindings: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> PipelineParts {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("robosim display shader"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("robosim display pipeline layout"),
            bind_group_layouts: &[Some(bindings)],
            immediate_size: 0,
        });
        PipelineParts {
            shader,
            layout,
            multisample: wgpu::MultisampleState {
                count: samples,
                mask: !0,
                alpha_to_coverage_enabled: false,
            },
            target: [Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }
    }

    /// The solids: triangles writing depth, pushed back a little so the edges win the test.
    fn solid_pipeline(&self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("robosim solids"),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &self.shader,
                entry_point: Some("vs_solid"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<SlotVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Uint32],
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                // Reversed-Z (camera.rs): nearer is larger.
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                // Push polygons back a little (towards 0) so the edge overlay wins the test.
                bias: wgpu::DepthBiasState {
                    constant: -2,
                    slope_scale: -1.0,
                    clamp: 0.0,
                },
            }),
            multisample: self.multisample,
            fragment: Some(wgpu::FragmentState {
                module: &self.shader,
                entry_point: Some("fs_solid"),
                compilation_options: Default::default(),
                targets: &self.target,
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// A line list drawn over the solids without writing depth (the edges, the guides):
    /// `label`, the shader's `vs`/`fs` entry points, the vertex's `stride` and `attributes`.
    fn line_pipeline(
        &self,
        device: &wgpu::Device,
        label: &str,
        (vs, fs): (&str, &str),
        stride: usize,
        attributes: &[wgpu::VertexAttribute],
    ) -> wgpu::RenderPipeline {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &self.shader,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: stride as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes,
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::LineList,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: self.multisample,
            fragment: Some(wgpu::FragmentState {
                module: &self.shader,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: &self.target,
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}

/// The frame's uniform buffer (camera, light, style), written each frame.
fn frame_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("robosim frame"),
        size: FRAME_BYTES,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The shared vertex pools: every body's triangles, and every body's edges.
fn shared_pools(device: &wgpu::Device) -> (Pool, Pool) {
    let max_buffer = device.limits().max_buffer_size;
    let tris = Pool::new(
        "robosim shared triangles",
        size_of::<SlotVertex>() as u64,
        max_buffer,
    );
    let edges = Pool::new(
        "robosim shared edges",
        size_of::<SlotPoint>() as u64,
        max_buffer,
    );
    (tris, edges)
}

impl Renderer {
    /// A renderer drawing into textures of `format` (the window's surface format, or
    /// [`Renderer::headless`]'s RGBA8 sRGB), with 4× multisampling where the adapter allows it.
    pub fn new(gpu: Gpu, format: wgpu::TextureFormat) -> Renderer {
        let samples = sample_count(&gpu, format);
        let device = &gpu.device;
        let layout = bind_group_layout(device);
        let parts = PipelineParts::new(device, &layout, format, samples);
        let solid = parts.solid_pipeline(device);
        let edge = parts.line_pipeline(
            device,
            "robosim edges",
            ("vs_edge", "fs_edge"),
            size_of::<SlotPoint>(),
            &wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32],
        );
        let guide = parts.line_pipeline(
            device,
            "robosim guides",
            ("vs_guide", "fs_guide"),
            size_of::<GuideVertex>(),
            &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4],
        );
        let overlay = Overlay::new(device, format, samples, DEPTH_FORMAT);
        let frame = frame_buffer(device);
        let capacity = 64;
        let (transforms, materials) = Self::body_arrays(device, capacity);
        let bind_group = Self::bind(device, &layout, &frame, &transforms, &materials);
        let (tris, edges) = shared_pools(device);
        Renderer {
            gpu,
            format,
            samples,
            solid,
            edge,
            guide,
            guides: None,
            overlay,
            layout,
            frame,
            transforms,
            materials,
            bind_group,
            capacity,
            tris,
            edges,
            writes: Vec::new(),
            triangles: 0,
            boxes: BoxTree::new(),
            bodies: HashMap::new(),
            free: Vec::new(),
            next_slot: 0,
            highlight: Default::default(),
            children: HashMap::new(),
            synced: None,
            last: UploadStats::default(),
            total: UploadStats::default(),
            version: 0,
            targets: None,
            camera: Camera::framing(Point3::origin(), 1.0),
            style: Style::default(),
        }
    }

    /// A renderer for PNG output on a headless device.
    pub fn headless() -> Result<Renderer> {
        Ok(Renderer::new(Gpu::headless()?, OFFSCREEN_FORMAT))
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// Samples per pixel (4 where supported, else 1).
    pub fn samples(&self) -> u32 {
        self.samples
    }

    fn body_arrays(device: &wgpu::Device, capacity: u32) -> (wgpu::Buffer, wgpu::Buffer) {
        let mk = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        (
            mk("robosim transforms", capacity as u64 * TRANSFORM_BYTES),
            mk("robosim materials", capacity as u64 * MATERIAL_BYTES),
        )
    }

    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        frame: &wgpu::Buffer,
        transforms: &wgpu::Buffer,
        materials: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("robosim display bind group"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: frame.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: transforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: materials.as_entire_binding(),
                },
            ],
        })
    }

    /// What the last [`Renderer::sync`] uploaded.
    pub fn last_upload(&self) -> UploadStats {
        self.last
    }

    /// Everything uploaded since the renderer was made.
    pub fn total_upload(&self) -> UploadStats {
        self.total
    }

    /// The model version last synced.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Bodies (objects with geometry) on the GPU.
    pub fn body_count(&self) -> usize {
        self.bodies.len()
    }

    /// Triangles on the GPU.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// The shared mesh buffers: (triangle buffers, edge buffers, draws a frame makes for the
    /// triangles with [`Style::edges`] off). Does not grow with the number of bodies.
    pub fn mesh_buffers(&self) -> (usize, usize, usize) {
        let draws = self.tris.pages.iter().map(|p| p.arena.runs().count()).sum();
        (self.tris.pages.len(), self.edges.pages.len(), draws)
    }

    /// Caps every shared mesh buffer at `bytes` (tests: many pages with small meshes). Takes
    /// effect for buffers made or grown from now on.
    #[doc(hidden)]
    pub fn set_mesh_buffer_limit(&mut self, bytes: u64) {
        self.tris.set_limit(bytes);
        self.edges.set_limit(bytes);
    }

    /// Where each body's triangles are in the shared buffers: (id, page, first vertex,
    /// vertices); for tests, checking that no two bodies overlap.
    #[doc(hidden)]
    pub fn mesh_ranges(&self) -> Vec<(Id, u32, u32, u32)> {
        let mut v: Vec<_> = self
            .bodies
            .iter()
            .filter_map(|(&id, b)| b.tri.map(|p| (id, p.page, p.span.start, p.span.len)))
            .collect();
        v.sort_by_key(|r| (r.1, r.2));
        v
    }

    /// Objects drawn in the collision colour from the next sync on.
    pub fn set_highlight(&mut self, ids: impl IntoIterator<Item = Id>) {
        let new: std::collections::HashSet<Id> = ids.into_iter().collect();
        if new != self.highlight {
            self.highlight = new;
            // Materials carry the highlight: the next sync compares them all.
            self.synced = None;
        }
    }

    fn alloc_slot(&mut self) -> u32 {
        self.free.pop().unwrap_or_else(|| {
            self.next_slot += 1;
            self.next_slot - 1
        })
    }

    fn buffer(&self, t: Target) -> &wgpu::Buffer {
        match t {
            Target::Transforms => &self.transforms,
            Target::Materials => &self.materials,
            Target::Tri(p) => &self.tris.pages[p as usize].buffer,
            Target::Edge(p) => &self.edges.pages[p as usize].buffer,
        }
    }

    /// Queues `bytes` for `target` at `offset`, merged with the previous write to the same
    /// buffer when it ends where this one begins.
    fn queue_write(&mut self, target: Target, offset: u64, bytes: &[u8]) {
        if let Some(k) = self.writes.iter().position(|w| w.0 == target) {
            let w = &mut self.writes[k];
            if w.1 + w.2.len() as u64 == offset {
                w.2.extend_from_slice(bytes);
                return;
            }
            let (t, o, data) = self.writes.swap_remove(k);
            self.gpu.queue.write_buffer(self.buffer(t), o, &data);
        }
        self.writes.push((target, offset, bytes.to_vec()));
    }

    /// Hands every queued write to the queue (the next submission carries them).
    fn flush_writes(&mut self) {
        for (t, o, data) in std::mem::take(&mut self.writes) {
            self.gpu.queue.write_buffer(self.buffer(t), o, &data);
        }
    }

    fn write_transform(&mut self, slot: u32, world: &[f64; 12], stats: &mut UploadStats) {
        self.queue_write(
            Target::Transforms,
            slot as u64 * TRANSFORM_BYTES,
            bytemuck::cast_slice(&transform_f32(world)),
        );
        stats.transforms += 1;
        stats.transform_bytes += TRANSFORM_BYTES;
    }

    fn write_material(&mut self, slot: u32, material: &[f32; 8], stats: &mut UploadStats) {
        self.queue_write(
            Target::Materials,
            slot as u64 * MATERIAL_BYTES,
            bytemuck::cast_slice(material),
        );
        stats.materials += 1;
        stats.material_bytes += MATERIAL_BYTES;
    }

    /// Places a body's mesh in the shared buffers (growing or adding one when full) and
    /// queues its vertices, each tagged with the body's slot. A mesh larger than the device's
    /// largest buffer is not drawn (said on stderr).
    fn upload_mesh(
        &mut self,
        slot: u32,
        cpu: &CpuMesh,
        stats: &mut UploadStats,
    ) -> (Option<Place>, Option<Place>) {
        let tri_bytes: Vec<SlotVertex> = cpu
            .vertices
            .iter()
            .map(|v| SlotVertex {
                pos: v.pos,
                normal: v.normal,
                slot,
            })
            .collect();
        let edge_bytes: Vec<SlotPoint> = cpu
            .edge_points
            .iter()
            .map(|&pos| SlotPoint { pos, slot })
            .collect();
        let tri = self.place(
            false,
            tri_bytes.len(),
            bytemuck::cast_slice(&tri_bytes),
            stats,
        );
        let edge = self.place(
            true,
            edge_bytes.len(),
            bytemuck::cast_slice(&edge_bytes),
            stats,
        );
        stats.meshes += 1;
        stats.mesh_bytes += (std::mem::size_of_val(tri_bytes.as_slice())
            + std::mem::size_of_val(edge_bytes.as_slice())) as u64;
        (tri, edge)
    }

    fn place(
        &mut self,
        edges: bool,
        n: usize,
        bytes: &[u8],
        stats: &mut UploadStats,
    ) -> Option<Place> {
        let pool = if edges {
            &mut self.edges
        } else {
            &mut self.tris
        };
        if n == 0 {
            return None;
        }
        if n > pool.max_elems as usize {
            eprintln!(
                "display: a mesh of {n} vertices is larger than the device's largest buffer ({} vertices); not drawn",
                pool.max_elems
            );
            return None;
        }
        let n = n as u32;
        let place = match pool.try_alloc(n) {
            Some(p) => p,
            None => {
                // Growing copies a buffer's live part on the GPU: what is queued for it must
                // be written first.
                self.flush_writes();
                let pool = if edges {
                    &mut self.edges
                } else {
                    &mut self.tris
                };
                pool.make_room(&self.gpu.device, &self.gpu.queue, n, stats)?
            }
        };
        let stride = if edges {
            self.edges.stride
        } else {
            self.tris.stride
        };
        let target = if edges {
            Target::Edge(place.page)
        } else {
            Target::Tri(place.page)
        };
        self.queue_write(target, place.span.start as u64 * stride, bytes);
        Some(place)
    }

    /// Frees a body's ranges in the shared buffers.
    fn release(&mut self, tri: Option<Place>, edge: Option<Place>) {
        if let Some(p) = tri {
            self.tris.pages[p.page as usize].arena.free(p.span);
        }
        if let Some(p) = edge {
            self.edges.pages[p.page as usize].arena.free(p.span);
        }
    }

    /// Compacts every shared buffer whose holes have become many or large
    /// ([`Arena::wants_compaction`]): its live ranges are copied together into a new buffer
    /// on the GPU and the bodies' ranges follow.
    fn compact_pools(&mut self, stats: &mut UploadStats) {
        for edges in [false, true] {
            let pool = if edges { &self.edges } else { &self.tris };
            let due: Vec<u32> = (0..pool.pages.len() as u32)
                .filter(|&p| pool.pages[p as usize].arena.wants_compaction())
                .collect();
            if due.is_empty() {
                continue;
            }
            self.flush_writes();
            for page in due {
                let pool = if edges {
                    &mut self.edges
                } else {
                    &mut self.tris
                };
                let c = pool.compact(&self.gpu.device, &self.gpu.queue, page);
                stats.compactions += 1;
                for b in self.bodies.values_mut() {
                    let place = if edges { &mut b.edge } else { &mut b.tri };
                    if let Some(p) = place
                        && p.page == page
                    {
                        p.span.start = c.moved(p.span.start);
                    }
                }
            }
        }
    }

    /// Grows the per-body arrays to hold slot `needed` and rewrites them whole.
    fn grow(&mut self, needed: u32, stats: &mut UploadStats) {
        self.flush_writes();
        let mut capacity = self.capacity;
        while capacity <= needed {
            capacity *= 2;
        }
        let (t, m) = Self::body_arrays(&self.gpu.device, capacity);
        self.transforms = t;
        self.materials = m;
        self.capacity = capacity;
        self.bind_group = Self::bind(
            &self.gpu.device,
            &self.layout,
            &self.frame,
            &self.transforms,
            &self.materials,
        );
        let mut all: Vec<(u32, [f64; 12], [f32; 8])> = self
            .bodies
            .values()
            .map(|b| (b.slot, b.world, b.material))
            .collect();
        // In slot order: the writes merge into one per array.
        all.sort_by_key(|b| b.0);
        for (slot, world, material) in all {
            self.write_transform(slot, &world, stats);
            self.write_material(slot, &material, stats);
        }
        stats.regrowths += 1;
    }

    /// Brings the GPU copy up to `snap`: new bodies get a slot, mesh, transform and
    /// material; for known bodies only what differs is written (world transform compared
    /// bit for bit, geometry by its generation, appearance by value); bodies gone are freed.
    /// Returns (and records as [`Renderer::last_upload`]) what was uploaded.
    pub fn sync(&mut self, snap: &Snapshot) -> UploadStats {
        let mut stats = UploadStats::default();
        let mut seen = std::collections::HashSet::with_capacity(self.bodies.len());
        self.children.clear();
        for rec in snap.objects() {
            self.children.entry(rec.parent).or_default().push(rec.id);
        }
        for i in 0..snap.len() {
            let rec = snap.rec(i);
            // Fully transparent (alpha 0) is not drawn: an imported URDF link's collision
            // solids when it has visuals (file-io's urdf_session), kept for collision only.
            if rec.flags & flags::HAS_GEOMETRY == 0 || rec.color[3] <= 0.0 {
                continue;
            }
            let Some(g) = snap.geometry(i) else { continue };
            let id = rec.id;
            seen.insert(id);
            let world = snap.world_pose(i);
            let hl = if self.highlight.contains(&id) {
                1.0
            } else {
                0.0
            };
            let s = rec.surface;
            let material = [
                rec.color[0],
                rec.color[1],
                rec.color[2],
                rec.color[3],
                s[0],
                s[1],
                s[2],
                hl,
            ];
            match self.bodies.get(&id) {
                Some(b) => {
                    let (slot, old_world, old_material, old_gen) =
                        (b.slot, b.world, b.material, b.geom_gen);
                    if old_gen != rec.geom_gen {
                        // New geometry: the old ranges are freed first, so a mesh of the same
                        // size or smaller goes back where it was.
                        let (tri, edge) = (b.tri, b.edge);
                        let old_tris = b.cpu.triangles();
                        self.release(tri, edge);
                        let cpu = CpuMesh::from_geometry(&g);
                        let (tri, edge) = self.upload_mesh(slot, &cpu, &mut stats);
                        self.triangles = self.triangles - old_tris + cpu.triangles();
                        let (lo, hi) = world_box(&world, &g.header.bbox);
                        self.boxes.set(slot, lo, hi);
                        if let Some(b) = self.bodies.get_mut(&id) {
                            b.cpu = cpu;
                            b.tri = tri;
                            b.edge = edge;
                            b.geom_gen = rec.geom_gen;
                            b.bbox = g.header.bbox;
                        }
                    }
                    if old_world != world {
                        self.write_transform(slot, &world, &mut stats);
                        let bbox = self.bodies.get(&id).map_or(g.header.bbox, |b| b.bbox);
                        let (lo, hi) = world_box(&world, &bbox);
                        self.boxes.set(slot, lo, hi);
                    }
                    if old_material != material {
                        self.write_material(slot, &material, &mut stats);
                    }
                    if let Some(b) = self.bodies.get_mut(&id) {
                        b.world = world;
                        b.material = material;
                        b.index = i;
                    }
                }
                None => {
                    let slot = self.alloc_slot();
                    if slot >= self.capacity {
                        self.grow(slot, &mut stats);
                    }
                    let cpu = CpuMesh::from_geometry(&g);
                    let (tri, edge) = self.upload_mesh(slot, &cpu, &mut stats);
                    self.write_transform(slot, &world, &mut stats);
                    self.write_material(slot, &material, &mut stats);
                    self.triangles += cpu.triangles();
                    let (lo, hi) = world_box(&world, &g.header.bbox);
                    self.boxes.set(slot, lo, hi);
                    self.bodies.insert(
                        id,
                        Body {
                            slot,
                            index: i,
                            world,
                            material,
                            geom_gen: rec.geom_gen,
                            bbox: g.header.bbox,
                            cpu,
                            tri,
                            edge,
                        },
                    );
                }
            }
        }
        if seen.len() != self.bodies.len() {
            let gone: Vec<Id> = self
                .bodies
                .keys()
                .filter(|id| !seen.contains(id))
                .copied()
                .collect();
            for id in gone {
                if let Some(b) = self.bodies.remove(&id) {
                    self.release(b.tri, b.edge);
                    self.triangles -= b.cpu.triangles();
                    self.boxes.clear(b.slot);
                    self.free.push(b.slot);
                }
            }
        }
        self.compact_pools(&mut stats);
        self.finish(snap, stats)
    }

    fn finish(&mut self, snap: &Snapshot, stats: UploadStats) -> UploadStats {
        self.flush_writes();
        self.version = snap.version();
        self.synced = Some((snap.version(), snap.epoch()));
        self.last = stats;
        self.total.add(&stats);
        stats
    }

    /// [`Renderer::sync`] driven by the change records since the last sync (the seed's Display
    /// Control: "recalculates those of its internal descriptor structures which have been
    /// affected by the changes"). When every record is pose-only and they run without a gap
    /// from the last synced version to `snap`'s, only the changed objects and what hangs
    /// below them are looked at — O(changed), not O(model). Anything else (structure,
    /// geometry, appearance, a gap, a keeper restart) falls back to the full comparison.
    pub fn sync_changes(&mut self, snap: &Snapshot, changes: &[Change]) -> UploadStats {
        let contiguous = self.synced.is_some_and(|(v, e)| {
            e == snap.epoch()
                && changes.first().is_some_and(|c| c.version == v + 1)
                && changes.windows(2).all(|w| w[1].version == w[0].version + 1)
                && changes.last().is_some_and(|c| c.version == snap.version())
        });
        let pose_only = changes.iter().all(|c| c.aspects & !aspect::POSE == 0);
        if !(contiguous && pose_only) {
            return self.sync(snap);
        }
        let mut stats = UploadStats::default();
        let mut stack: Vec<Id> = changes.iter().flat_map(|c| c.ids.iter().copied()).collect();
        let mut visited = std::collections::HashSet::new();
        while let Some(id) = stack.pop() {
            if !visited.insert(id) {
                continue;
            }
            if let Some(kids) = self.children.get(&id) {
                stack.extend(kids.iter().copied());
            }
            let Some(b) = self.bodies.get_mut(&id) else {
                continue;
            };
            // Its index as of the last full sync (the structure has not changed since), else
            // looked up.
            let i = if snap.objects().get(b.index).is_some_and(|r| r.id == id) {
                b.index
            } else {
                match snap.index_of(id) {
                    Some(i) => i,
                    // Not in this snapshot after all: a structure change slipped through.
                    None => return self.sync(snap),
                }
            };
            let world = snap.world_pose(i);
            if b.world != world {
                b.world = world;
                let (slot, (lo, hi)) = (b.slot, world_box(&world, &b.bbox));
                self.write_transform(slot, &world, &mut stats);
                self.boxes.set(slot, lo, hi);
            }
        }
        self.finish(snap, stats)
    }

    /// The world bounding sphere of everything drawn (centre, radius); the unit sphere when
    /// nothing is.
    pub fn bounds(&self) -> (Point3<f64>, f64) {
        let (lo, hi) = self.boxes.root();
        sphere_of_box(lo, hi)
    }

    /// The ids of the bodies drawn now.
    pub fn body_ids(&self) -> std::collections::BTreeSet<Id> {
        self.bodies.keys().copied().collect()
    }

    /// The world bounding sphere (centre, radius) of the bodies `ids` among those drawn;
    /// `None` when none of them is drawn.
    pub fn bounds_of(&self, ids: &std::collections::BTreeSet<Id>) -> Option<(Point3<f64>, f64)> {
        let bodies: Vec<_> = ids
            .iter()
            .filter_map(|id| self.bodies.get(id))
            .map(|b| (&b.world, &b.bbox))
            .collect();
        (!bodies.is_empty()).then(|| sphere_around(bodies.into_iter()))
    }

    /// Bodies drawn now that were not drawn when `shown` was taken ([`Renderer::body_ids`]),
    /// when `shown` had any: what was added to a model already on screen (an instance, an
    /// imported robot), which a session display frames — framed on the whole Space Station, a
    /// robot just added is a few pixels (issue 39 item 8). `None` when nothing was added, or
    /// for the model's first bodies (framed whole).
    pub fn added_since(
        &self,
        shown: &std::collections::BTreeSet<Id>,
    ) -> Option<std::collections::BTreeSet<Id>> {
        if shown.is_empty() {
            return None;
        }
        let added: std::collections::BTreeSet<Id> = self
            .bodies
            .keys()
            .filter(|id| !shown.contains(id))
            .copied()
            .collect();
        (!added.is_empty()).then_some(added)
    }

    /// Points the camera at the bodies `ids` (see [`Renderer::added_since`]), from the default
    /// direction, keeping the projection; nothing changes when none of them is drawn.
    pub fn frame_on(&mut self, ids: &std::collections::BTreeSet<Id>) {
        if let Some((c, r)) = self.bounds_of(ids) {
            let projection = self.camera.projection;
            self.camera = Camera {
                projection,
                ..Camera::framing(c, r)
            };
        }
    }

    /// Points the camera at everything drawn, from the default direction.
    pub fn frame_all(&mut self) {
        let (c, r) = self.bounds();
        let projection = self.camera.projection;
        self.camera = Camera {
            projection,
            ..Camera::framing(c, r)
        };
    }

    /// The guides for what is drawn now, when [`Style::grid`] is on.
    pub fn guides(&self) -> Option<Guides> {
        self.style.grid.then(|| {
            let (c, r) = self.bounds();
            Guides::around(c, r)
        })
    }

    /// Shows `text` (lines separated by `\n`) in the frame's top-left corner from the next
    /// frame on; `None`: nothing. Rasterized and uploaded only when it changes.
    pub fn set_status(&mut self, text: Option<&str>) {
        self.overlay
            .set_text(&self.gpu.device, &self.gpu.queue, text);
    }

    /// The status text shown, if any.
    pub fn status(&self) -> Option<&str> {
        self.overlay.text()
    }

    /// Where the status panel is drawn: x, y, width, height in pixels from the top-left.
    pub fn status_rect(&self) -> Option<[u32; 4]> {
        self.overlay.rect()
    }

    /// Brings the guides' vertex buffer up to the current bounds (rebuilt only when the grid's
    /// step, centre or size changes) and places the overlay for a `width` × `height` target.
    fn prepare_extras(&mut self, width: u32, height: u32) {
        match self.guides() {
            None => self.guides = None,
            Some(g) if self.guides.as_ref().is_some_and(|c| c.0 == g) => {}
            Some(g) => {
                let v = g.vertices();
                let buf = self
                    .gpu
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("robosim guides"),
                        contents: bytemuck::cast_slice(&v),
                        usage: wgpu::BufferUsages::VERTEX,
                    });
                self.guides = Some((g, buf, v.len() as u32));
            }
        }
        self.overlay.prepare(&self.gpu.queue, width, height);
    }

    fn write_frame(&self, width: u32, height: u32) {
        // The depth range holds the model and, when drawn, the guides.
        let (center, radius) = match &self.guides {
            Some((g, _, _)) => sphere_union(self.bounds(), g.bounds()),
            None => self.bounds(),
        };
        let aspect = width as f64 / height.max(1) as f64;
        let c = &self.camera;
        let vp = c.projection_matrix(aspect, &center, radius) * c.view();
        let forward = (c.at - c.from).normalize();
        let right = forward.cross(&c.up).normalize();
        let up = right.cross(&forward);
        // A key light over the viewer's left shoulder: every view is lit.
        let light = (-forward * 0.55 + up * 0.65 - right * 0.45).normalize();
        let persp = matches!(c.projection, crate::camera::Projection::Perspective);
        let mut data = [0.0_f32; 28];
        data[..16].copy_from_slice(&mat4_f32(&vp));
        data[16..20].copy_from_slice(&[
            c.from.x as f32,
            c.from.y as f32,
            c.from.z as f32,
            if persp { 1.0 } else { 0.0 },
        ]);
        data[20..24].copy_from_slice(&[
            light.x as f32,
            light.y as f32,
            light.z as f32,
            self.style.ambient,
        ]);
        data[24..28].copy_from_slice(&[forward.x as f32, forward.y as f32, forward.z as f32, 0.35]);
        self.gpu
            .queue
            .write_buffer(&self.frame, 0, bytemuck::cast_slice(&data));
    }

    fn make_targets(&self, width: u32, height: u32, offscreen: bool) -> Targets {
        let device = &self.gpu.device;
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let tex = |label, format, samples, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = tex(
            "robosim color",
            self.format,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | if offscreen {
                    wgpu::TextureUsages::COPY_SRC
                } else {
                    wgpu::TextureUsages::empty()
                },
        );
        let msaa = (self.samples > 1).then(|| {
            tex(
                "robosim msaa color",
                self.format,
                self.samples,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            )
            .create_view(&Default::default())
        });
        let depth = tex(
            "robosim depth",
            DEPTH_FORMAT,
            self.samples,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        )
        .create_view(&Default::default());
        Targets {
            size: (width, height),
            color,
            msaa,
            depth,
        }
    }

    /// Records the frame's draw commands into `view` (resolving multisampling into it).
    fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        msaa: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        let bg = self.style.background;
        let (attach, resolve) = match msaa {
            Some(m) => (m, Some(view)),
            None => (view, None),
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("robosim frame"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: attach,
                depth_slice: None,
                resolve_target: resolve,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: bg[0],
                        g: bg[1],
                        b: bg[2],
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        // Each shared buffer's live runs: one draw per run, whatever the number of bodies
        // (every vertex carries its body's slot).
        let draw_pool = |pass: &mut wgpu::RenderPass<'_>, pool: &Pool| {
            for p in &pool.pages {
                if p.arena.top() == 0 {
                    continue;
                }
                pass.set_vertex_buffer(0, p.buffer.slice(..));
                for run in p.arena.runs() {
                    pass.draw(run.start..run.end(), 0..1);
                }
            }
        };
        pass.set_pipeline(&self.solid);
        draw_pool(&mut pass, &self.tris);
        if self.style.edges {
            pass.set_pipeline(&self.edge);
            draw_pool(&mut pass, &self.edges);
        }
        // After the model: its depth hides the guides behind it.
        if let Some((_, buf, n)) = &self.guides {
            pass.set_pipeline(&self.guide);
            pass.set_vertex_buffer(0, buf.slice(..));
            pass.draw(0..*n, 0..1);
        }
        self.overlay.draw(&mut pass);
    }

    /// (Re)makes the colour, multisample and depth targets when the size changes.
    fn ensure_targets(&mut self, width: u32, height: u32, offscreen: bool) {
        if self
            .targets
            .as_ref()
            .is_none_or(|t| t.size != (width, height))
        {
            self.targets = Some(self.make_targets(width, height, offscreen));
        }
    }

    /// Draws a frame into a window's surface texture.
    pub fn render_to(&mut self, view: &wgpu::TextureView, width: u32, height: u32) {
        self.ensure_targets(width, height, false);
        self.prepare_extras(width, height);
        self.write_frame(width, height);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        if let Some(t) = &self.targets {
            self.encode(&mut encoder, view, t.msaa.as_ref(), &t.depth);
        }
        self.gpu.queue.submit([encoder.finish()]);
    }

    /// Encodes a frame into the off-screen targets (made or remade for this size).
    fn encode_offscreen(&mut self, width: u32, height: u32) -> Result<wgpu::CommandEncoder> {
        if width == 0 || height == 0 || width > 8192 || height > 8192 {
            return Err(DisplayError::Size(format!(
                "image size {width}×{height} outside 1..=8192"
            )));
        }
        self.camera.validate().map_err(DisplayError::Camera)?;
        if self.format != OFFSCREEN_FORMAT {
            return Err(DisplayError::Size(format!(
                "this renderer draws {:?} for a window; images need a headless renderer",
                self.format
            )));
        }
        self.ensure_targets(width, height, true);
        self.prepare_extras(width, height);
        self.write_frame(width, height);
        let Some(t) = &self.targets else {
            return Err(DisplayError::Device("no render target".into()));
        };
        let view = t.color.create_view(&Default::default());
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.encode(&mut encoder, &view, t.msaa.as_ref(), &t.depth);
        Ok(encoder)
    }

    fn wait(&self) -> Result<()> {
        self.gpu
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(gpu_err("waiting for the frame"))?;
        Ok(())
    }

    /// Submits the uploads written since the last frame without drawing (a frame does this
    /// itself; the upload benchmark, which draws no frames, calls it between updates as the
    /// display's frames would).
    pub fn flush_uploads(&self) {
        self.gpu.queue.submit([]);
    }

    /// Encodes a frame off screen and submits it without waiting (the CPU part of a frame;
    /// `robosim bench display` times it and then [`Renderer::wait_idle`]s).
    pub fn submit_frame(&mut self, width: u32, height: u32) -> Result<()> {
        let encoder = self.encode_offscreen(width, height)?;
        self.gpu.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Waits for everything submitted to finish.
    pub fn wait_idle(&self) -> Result<()> {
        self.wait()
    }

    /// Draws a frame off screen and waits for the device to finish it, reading nothing back
    /// (what a window's frame costs before presentation; used by `robosim bench display`).
    pub fn draw_and_wait(&mut self, width: u32, height: u32) -> Result<()> {
        let encoder = self.encode_offscreen(width, height)?;
        self.gpu.queue.submit([encoder.finish()]);
        self.wait()
    }

    /// Draws a frame off screen and reads it back.
    pub fn render_image(&mut self, width: u32, height: u32) -> Result<RgbaImage> {
        let mut encoder = self.encode_offscreen(width, height)?;
        let Some(t) = &self.targets else {
            return Err(DisplayError::Device("no render target".into()));
        };
        let row = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let readback = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("robosim readback"),
            size: row as u64 * height as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &t.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        self.gpu.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        readback.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(gpu_err("readback"))?
            .map_err(gpu_err("readback"))?;
        let mapped = readback.get_mapped_range(..).map_err(gpu_err("readback"))?;
        let mut pixels = Vec::with_capacity((width * height * 4) as usize);
        for y in 0..height as usize {
            let start = y * row as usize;
            pixels.extend_from_slice(&mapped[start..start + width as usize * 4]);
        }
        drop(mapped);
        readback.unmap();
        Ok(RgbaImage {
            width,
            height,
            pixels,
        })
    }

    /// The nearest body under pixel (`x`, `y`) of a `width` × `height` view: CPU ray cast
    /// against every body's triangles in its own frame (the seed's picking, §2.1: which
    /// segment and which polygon).
    pub fn pick(&self, x: f64, y: f64, width: u32, height: u32) -> Option<Hit> {
        let (origin, dir) = self.camera.ray(x, y, width, height);
        let mut best: Option<Hit> = None;
        for (&id, b) in &self.bodies {
            let w = &b.world;
            // Into the body frame: Rᵀ (p − t).
            let t = [w[3], w[7], w[11]];
            let rt = |v: [f64; 3]| {
                [
                    w[0] * v[0] + w[4] * v[1] + w[8] * v[2],
                    w[1] * v[0] + w[5] * v[1] + w[9] * v[2],
                    w[2] * v[0] + w[6] * v[1] + w[10] * v[2],
                ]
            };
            let o = rt([origin.x - t[0], origin.y - t[1], origin.z - t[2]]);
            let d = rt([dir.x, dir.y, dir.z]);
            if let Some((dist, polygon)) = b.cpu.raycast(o, d)
                && best.is_none_or(|h| dist < h.distance)
            {
                best = Some(Hit {
                    id,
                    polygon,
                    distance: dist,
                    point: origin + dir * dist,
                });
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tree's root is the box a pass over every body finds, through moves, removals and
    /// growth of the slot range.
    #[test]
    fn the_box_tree_root_is_the_union_of_the_live_boxes() {
        let mut t = BoxTree::new();
        let mut live: HashMap<u32, ([f64; 12], [f64; 6])> = HashMap::new();
        let mut rng = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % 10_000) as f64 / 100.0 - 50.0
        };
        for step in 0..3_000u32 {
            let slot = (next().abs() * 3.0) as u32;
            if step % 4 == 3 {
                t.clear(slot);
                live.remove(&slot);
            } else {
                let mut w = [0.0; 12];
                // A rotation about z by a random angle, a random translation.
                let a = next() / 10.0;
                w[0] = a.cos();
                w[1] = -a.sin();
                w[4] = a.sin();
                w[5] = a.cos();
                w[10] = 1.0;
                w[3] = next();
                w[7] = next();
                w[11] = next();
                let bbox = [next() / 10.0, 0.0, 0.5, 1.0, next().abs() / 10.0, 0.25];
                let (lo, hi) = world_box(&w, &bbox);
                t.set(slot, lo, hi);
                live.insert(slot, (w, bbox));
            }
            let brute = sphere_around(live.values().map(|(w, b)| (w, b)));
            let (lo, hi) = t.root();
            assert_eq!(sphere_of_box(lo, hi), brute, "step {step}");
        }
    }
}
