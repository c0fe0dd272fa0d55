// robosim display: the status overlay — a text mask (R8, coverage) composited over the frame
// in its top-left corner as white text on a translucent dark panel. Pixel-exact: the fragment
// reads the mask texel under it (no sampler, no scaling). Output is premultiplied alpha.

struct Rect {
    // x, y (px from the top-left), width, height (px) of the panel.
    panel: vec4<f32>,
    // xy: the target's size (px).
    target_size: vec4<f32>,
};

@group(0) @binding(0) var<uniform> rect: Rect;
@group(0) @binding(1) var mask: texture_2d<f32>;

@vertex
fn vs_text(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 0.0), vec2<f32>(0.0, 1.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0), vec2<f32>(1.0, 1.0),
    );
    let px = rect.panel.xy + corners[i] * rect.panel.zw;
    let ndc = vec2<f32>(px.x / rect.target_size.x * 2.0 - 1.0, 1.0 - px.y / rect.target_size.y * 2.0);
    return vec4<f32>(ndc, 0.0, 1.0);
}

@fragment
fn fs_text(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let local = vec2<i32>(floor(p.xy - rect.panel.xy));
    let a = textureLoad(mask, local, 0).r;
    // The panel keeps 45 % of what is behind it; the text covers it in white.
    let keep = 0.45 * (1.0 - a);
    return vec4<f32>(vec3<f32>(a), 1.0 - keep);
}
