// robosim display: flat-shaded polygons (one normal per polygon, as the seed's polygon models
// are drawn) lit by one directional light plus an ambient term, Blinn–Phong specular; and a
// line pass for the edge overlay. Per-body data live in two storage arrays indexed by the
// body's slot, which every vertex carries (all bodies' meshes share a few vertex buffers and
// are drawn by a few draws): a pose change rewrites one `transforms` entry, an appearance
// change one `materials` entry, and no vertex buffer is touched.

struct Frame {
    view_proj: mat4x4<f32>,
    // xyz: eye position (world, m); w: 1 for perspective, 0 for orthographic.
    eye: vec4<f32>,
    // xyz: direction towards the light (world, unit); w: ambient term.
    light: vec4<f32>,
    // xyz: view direction for orthographic projection; w: edge darkening factor.
    view_dir: vec4<f32>,
};

struct Material {
    // RGBA, linear 0..1.
    color: vec4<f32>,
    // x: diffuse, y: specular, z: shininess, w: highlight (1 = in collision).
    surface: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> transforms: array<mat4x4<f32>>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) slot: u32,
};

@vertex
fn vs_solid(@location(0) pos: vec3<f32>, @location(1) normal: vec3<f32>,
            @location(2) slot: u32) -> VsOut {
    let m = transforms[slot];
    let world = m * vec4<f32>(pos, 1.0);
    var out: VsOut;
    out.clip = frame.view_proj * world;
    out.world_pos = world.xyz;
    // Rigid transforms: the rotation part is its own inverse transpose.
    out.normal = (m * vec4<f32>(normal, 0.0)).xyz;
    out.slot = slot;
    return out;
}

@fragment
fn fs_solid(in: VsOut) -> @location(0) vec4<f32> {
    let mat = materials[in.slot];
    var base = mat.color.rgb;
    if (mat.surface.w > 0.5) {
        base = vec3<f32>(1.0, 0.12, 0.08);
    }
    var v: vec3<f32>;
    if (frame.eye.w > 0.5) {
        v = normalize(frame.eye.xyz - in.world_pos);
    } else {
        v = -frame.view_dir.xyz;
    }
    var n = normalize(in.normal);
    // Two-sided: a polygon seen from behind is lit as its front.
    if (dot(n, v) < 0.0) {
        n = -n;
    }
    let l = frame.light.xyz;
    let diffuse = mat.surface.x * max(dot(n, l), 0.0);
    let h = normalize(l + v);
    let spec = mat.surface.y * pow(max(dot(n, h), 0.0), max(mat.surface.z, 1.0));
    let rgb = base * (frame.light.w + diffuse) + vec3<f32>(spec);
    return vec4<f32>(rgb, mat.color.a);
}

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) slot: u32,
};

@vertex
fn vs_edge(@location(0) pos: vec3<f32>, @location(1) slot: u32) -> LineOut {
    var out: LineOut;
    out.clip = frame.view_proj * (transforms[slot] * vec4<f32>(pos, 1.0));
    out.slot = slot;
    return out;
}

@fragment
fn fs_edge(in: LineOut) -> @location(0) vec4<f32> {
    let mat = materials[in.slot];
    return vec4<f32>(mat.color.rgb * frame.view_dir.w, 1.0);
}

// The guides: ground grid and world axes, world-space lines with their own colour (linear
// RGBA), depth-tested against the model but not written to the depth buffer.
struct GuideOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vs_guide(@location(0) pos: vec3<f32>, @location(1) color: vec4<f32>) -> GuideOut {
    var out: GuideOut;
    out.clip = frame.view_proj * vec4<f32>(pos, 1.0);
    out.color = color;
    return out;
}

@fragment
fn fs_guide(in: GuideOut) -> @location(0) vec4<f32> {
    return in.color;
}
