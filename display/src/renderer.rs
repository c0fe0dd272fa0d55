//! The GPU side: one wgpu device, two pipelines (shaded polygons, edge overlay), and per body a
//! slot in two storage arrays (transform, material) plus its own vertex buffers — the seed's
//! display list with one segment per body (§2.1). [`Renderer::sync`] brings the GPU copy up to
//! a snapshot and uploads only what differs: a moved body's 64-byte transform, a recoloured
//! body's 32-byte material, a re-shaped body's mesh. Every byte written is counted
//! ([`UploadStats`]).
//!
//! Besides the model a frame may show the guides (ground grid and world axes, [`Style::grid`];
//! [`crate::guides`]) and a status overlay ([`Renderer::set_status`]; [`crate::overlay`]).
//! Neither is model data: their uploads are not in [`UploadStats`].

use crate::camera::Camera;
use crate::guides::{GuideVertex, Guides};
use crate::image::RgbaImage;
use crate::mesh::{CpuMesh, Vertex};
use crate::overlay::Overlay;
use crate::{DisplayError, Result};
use nalgebra::{Matrix4, Point3, Vector3};
use robosim_instance_space::{Change, Id, Snapshot, aspect, layout::flags};
use std::collections::HashMap;
use wgpu::util::DeviceExt;

/// Bytes of one body's transform on the GPU (a 4×4 f32 matrix).
pub const TRANSFORM_BYTES: u64 = 64;
/// Bytes of one body's material (colour + surface).
pub const MATERIAL_BYTES: u64 = 32;
const FRAME_BYTES: u64 = 112;
const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

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
        .map_err(|e| DisplayError::NoAdapter(format!("{e}; {NO_ADAPTER_HINT}")))?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("robosim display"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| DisplayError::Device(e.to_string()))?;
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
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for (w, bbox) in bodies {
        let c = Vector3::new(bbox[0], bbox[1], bbox[2]);
        let h = Vector3::new(bbox[3], bbox[4], bbox[5]);
        for r in 0..3 {
            let center = w[r * 4] * c.x + w[r * 4 + 1] * c.y + w[r * 4 + 2] * c.z + w[r * 4 + 3];
            let half = w[r * 4].abs() * h.x + w[r * 4 + 1].abs() * h.y + w[r * 4 + 2].abs() * h.z;
            lo[r] = lo[r].min(center - half);
            hi[r] = hi[r].max(center + half);
        }
    }
    if !(lo.iter().all(|v| v.is_finite()) && hi.iter().all(|v| v.is_finite())) {
        return (Point3::origin(), 1.0);
    }
    let center = Point3::from((lo + hi) / 2.0);
    (center, ((hi - lo) / 2.0).norm().max(1e-6))
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
    /// Meshes (vertex + edge buffers) uploaded.
    pub meshes: u64,
    pub mesh_bytes: u64,
    /// Times the per-body arrays grew and were rewritten whole.
    pub regrowths: u64,
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

struct GpuMesh {
    cpu: CpuMesh,
    vertices: wgpu::Buffer,
    edges: Option<wgpu::Buffer>,
}

struct Body {
    slot: u32,
    world: [f64; 12],
    material: [f32; 8],
    geom_gen: u64,
    /// bbox centre and half-diagonal, body frame.
    bbox: [f64; 6],
    mesh: GpuMesh,
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

impl Renderer {
    /// A renderer drawing into textures of `format` (the window's surface format, or
    /// [`Renderer::headless`]'s RGBA8 sRGB), with 4× multisampling where the adapter allows it.
    pub fn new(gpu: Gpu, format: wgpu::TextureFormat) -> Renderer {
        // ROBOSIM_DISPLAY_SAMPLES=1 turns multisampling off (a different rasterization of the
        // same scene: the golden-image tolerance is checked against it).
        let forced = std::env::var("ROBOSIM_DISPLAY_SAMPLES").ok();
        let samples = if forced.as_deref() == Some("1") {
            1
        } else {
            let c = gpu.adapter.get_texture_format_features(format);
            let d = gpu.adapter.get_texture_format_features(DEPTH_FORMAT);
            if c.flags.sample_count_supported(4) && d.flags.sample_count_supported(4) {
                4
            } else {
                1
            }
        };
        let device = &gpu.device;
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("robosim display shader"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
        });
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
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
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
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("robosim display pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let multisample = wgpu::MultisampleState {
            count: samples,
            mask: !0,
            alpha_to_coverage_enabled: false,
        };
        let target = [Some(wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let solid = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("robosim solids"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_solid"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<Vertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
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
            multisample,
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_solid"),
                compilation_options: Default::default(),
                targets: &target,
            }),
            multiview_mask: None,
            cache: None,
        });
        let edge = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("robosim edges"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_edge"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: 12,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3],
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
            multisample,
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_edge"),
                compilation_options: Default::default(),
                targets: &target,
            }),
            multiview_mask: None,
            cache: None,
        });
        let guide = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("robosim guides"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_guide"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<GuideVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4],
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
            multisample,
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_guide"),
                compilation_options: Default::default(),
                targets: &target,
            }),
            multiview_mask: None,
            cache: None,
        });
        let overlay = Overlay::new(device, format, samples, DEPTH_FORMAT);
        let frame = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("robosim frame"),
            size: FRAME_BYTES,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let capacity = 64;
        let (transforms, materials) = Self::body_arrays(device, capacity);
        let bind_group = Self::bind(device, &layout, &frame, &transforms, &materials);
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
        self.bodies.values().map(|b| b.mesh.cpu.triangles()).sum()
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

    fn write_transform(&mut self, slot: u32, world: &[f64; 12], stats: &mut UploadStats) {
        self.gpu.queue.write_buffer(
            &self.transforms,
            slot as u64 * TRANSFORM_BYTES,
            bytemuck::cast_slice(&transform_f32(world)),
        );
        stats.transforms += 1;
        stats.transform_bytes += TRANSFORM_BYTES;
    }

    fn write_material(&mut self, slot: u32, material: &[f32; 8], stats: &mut UploadStats) {
        self.gpu.queue.write_buffer(
            &self.materials,
            slot as u64 * MATERIAL_BYTES,
            bytemuck::cast_slice(material),
        );
        stats.materials += 1;
        stats.material_bytes += MATERIAL_BYTES;
    }

    fn upload_mesh(&self, cpu: CpuMesh, stats: &mut UploadStats) -> GpuMesh {
        let device = &self.gpu.device;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("robosim body vertices"),
            contents: bytemuck::cast_slice(&cpu.vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let edges = (!cpu.edge_points.is_empty()).then(|| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("robosim body edges"),
                contents: bytemuck::cast_slice(&cpu.edge_points),
                usage: wgpu::BufferUsages::VERTEX,
            })
        });
        stats.meshes += 1;
        stats.mesh_bytes += cpu.gpu_bytes();
        GpuMesh {
            cpu,
            vertices,
            edges,
        }
    }

    /// Grows the per-body arrays to hold slot `needed` and rewrites them whole.
    fn grow(&mut self, needed: u32, stats: &mut UploadStats) {
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
        let all: Vec<(u32, [f64; 12], [f32; 8])> = self
            .bodies
            .values()
            .map(|b| (b.slot, b.world, b.material))
            .collect();
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
            let rec = &snap.objects()[i];
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
                        let mesh = self.upload_mesh(CpuMesh::from_geometry(&g), &mut stats);
                        if let Some(b) = self.bodies.get_mut(&id) {
                            b.mesh = mesh;
                            b.geom_gen = rec.geom_gen;
                            b.bbox = g.header.bbox;
                        }
                    }
                    if old_world != world {
                        self.write_transform(slot, &world, &mut stats);
                    }
                    if old_material != material {
                        self.write_material(slot, &material, &mut stats);
                    }
                    if let Some(b) = self.bodies.get_mut(&id) {
                        b.world = world;
                        b.material = material;
                    }
                }
                None => {
                    let slot = self.alloc_slot();
                    if slot >= self.capacity {
                        self.grow(slot, &mut stats);
                    }
                    let mesh = self.upload_mesh(CpuMesh::from_geometry(&g), &mut stats);
                    self.write_transform(slot, &world, &mut stats);
                    self.write_material(slot, &material, &mut stats);
                    self.bodies.insert(
                        id,
                        Body {
                            slot,
                            world,
                            material,
                            geom_gen: rec.geom_gen,
                            bbox: g.header.bbox,
                            mesh,
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
                    self.free.push(b.slot);
                }
            }
        }
        self.finish(snap, stats)
    }

    fn finish(&mut self, snap: &Snapshot, stats: UploadStats) -> UploadStats {
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
            let Some(slot) = self.bodies.get(&id).map(|b| b.slot) else {
                continue;
            };
            let Some(i) = snap.index_of(id) else {
                // Not in this snapshot after all: a structure change slipped through.
                return self.sync(snap);
            };
            let world = snap.world_pose(i);
            if self.bodies.get(&id).is_some_and(|b| b.world != world) {
                self.write_transform(slot, &world, &mut stats);
                if let Some(b) = self.bodies.get_mut(&id) {
                    b.world = world;
                }
            }
        }
        self.finish(snap, stats)
    }

    /// The world bounding sphere of everything drawn (centre, radius); the unit sphere when
    /// nothing is.
    pub fn bounds(&self) -> (Point3<f64>, f64) {
        sphere_around(self.bodies.values().map(|b| (&b.world, &b.bbox)))
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
        pass.set_pipeline(&self.solid);
        for b in self.bodies.values() {
            let n = b.mesh.cpu.vertices.len() as u32;
            if n > 0 {
                pass.set_vertex_buffer(0, b.mesh.vertices.slice(..));
                pass.draw(0..n, b.slot..b.slot + 1);
            }
        }
        if self.style.edges {
            pass.set_pipeline(&self.edge);
            for b in self.bodies.values() {
                if let Some(e) = &b.mesh.edges {
                    pass.set_vertex_buffer(0, e.slice(..));
                    pass.draw(0..b.mesh.cpu.edge_points.len() as u32, b.slot..b.slot + 1);
                }
            }
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
            .map_err(|e| DisplayError::Device(format!("waiting for the frame: {e}")))?;
        Ok(())
    }

    /// Submits the uploads written since the last frame without drawing (a frame does this
    /// itself; the upload benchmark, which draws no frames, calls it between updates as the
    /// display's frames would).
    pub fn flush_uploads(&self) {
        self.gpu.queue.submit([]);
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
            .map_err(|e| DisplayError::Device(format!("readback: {e}")))?
            .map_err(|e| DisplayError::Device(format!("readback: {e}")))?;
        let mapped = readback
            .get_mapped_range(..)
            .map_err(|e| DisplayError::Device(format!("readback: {e:?}")))?;
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
            if let Some((dist, polygon)) = b.mesh.cpu.raycast(o, d)
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
