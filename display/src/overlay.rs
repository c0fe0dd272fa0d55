//! The status overlay: a few lines of text in the top-left corner of a frame (white on a
//! translucent dark panel) — the simulator's time and joint values when one runs. The text is
//! rasterized on the CPU with the bundled DejaVu Sans (robosim-report's [`font`]; `ab_glyph`,
//! no system font library) into a coverage mask, uploaded as a texture only when the text
//! changes, and composited over the frame by one screen-space quad (`overlay.wgsl`).
//!
//! Entry points: [`TextMask::rasterize`], [`Overlay`] (the GPU side, owned by the renderer).
//!
//! [`font`]: robosim_report::font

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};

/// Pixel height of the overlay's font (the em size, px).
pub const FONT_PX: f32 = 14.0;
/// Margin between the frame's corner and the panel, and between the panel's edge and the
/// text (px).
pub const MARGIN_PX: u32 = 6;

/// A text's coverage: one byte per pixel (0 transparent … 255 fully covered), row-major, top
/// row first; the panel is `width` × `height` pixels, text inset by [`MARGIN_PX`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TextMask {
    pub width: u32,
    pub height: u32,
    pub alpha: Vec<u8>,
}

fn font() -> Option<&'static FontRef<'static>> {
    static FONT: std::sync::OnceLock<Option<FontRef<'static>>> = std::sync::OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(robosim_report::font::SANS_TTF).ok())
        .as_ref()
}

impl TextMask {
    /// Lays `text` out (one line per `\n`, kerning applied, [`FONT_PX`]) and rasterizes it.
    /// `None` for empty text (or if the bundled font could not be read, which its tests rule out).
    pub fn rasterize(text: &str) -> Option<TextMask> {
        let text = text.trim_end();
        if text.is_empty() {
            return None;
        }
        let font = font()?;
        let scale = PxScale::from(FONT_PX);
        let sf = font.as_scaled(scale);
        let line_h = (sf.ascent() - sf.descent() + sf.line_gap()).ceil();
        let lines: Vec<&str> = text.lines().collect();
        let advance = |line: &str| {
            let mut x = 0.0;
            let mut prev = None;
            for c in line.chars() {
                let id = sf.glyph_id(c);
                if let Some(p) = prev {
                    x += sf.kern(p, id);
                }
                x += sf.h_advance(id);
                prev = Some(id);
            }
            x
        };
        let text_w = lines.iter().map(|l| advance(l)).fold(0.0f32, f32::max);
        let width = text_w.ceil() as u32 + 2 * MARGIN_PX;
        let height = (line_h * lines.len() as f32).ceil() as u32 + 2 * MARGIN_PX;
        let mut alpha = vec![0u8; (width * height) as usize];
        for (i, line) in lines.iter().enumerate() {
            let baseline = MARGIN_PX as f32 + i as f32 * line_h + sf.ascent();
            let mut x = MARGIN_PX as f32;
            let mut prev = None;
            for c in line.chars() {
                let id = sf.glyph_id(c);
                if let Some(p) = prev {
                    x += sf.kern(p, id);
                }
                let glyph = id.with_scale_and_position(scale, point(x, baseline));
                if let Some(outline) = font.outline_glyph(glyph) {
                    let b = outline.px_bounds();
                    outline.draw(|gx, gy, cov| {
                        let px = b.min.x as i64 + gx as i64;
                        let py = b.min.y as i64 + gy as i64;
                        if (0..width as i64).contains(&px) && (0..height as i64).contains(&py) {
                            let a = &mut alpha[(py as u32 * width + px as u32) as usize];
                            *a = (*a).max((cov.clamp(0.0, 1.0) * 255.0).round() as u8);
                        }
                    });
                }
                x += sf.h_advance(id);
                prev = Some(id);
            }
        }
        Some(TextMask {
            width,
            height,
            alpha,
        })
    }
}

/// Bytes of the overlay's uniform: the panel rectangle (x, y, w, h; px) and the target size.
const RECT_BYTES: u64 = 32;

/// The GPU side of the overlay: its pipeline, and the mask texture of the current text.
pub struct Overlay {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    rect: wgpu::Buffer,
    /// The text shown, its mask size and the bind group holding its texture.
    current: Option<(String, (u32, u32), wgpu::BindGroup)>,
}

impl Overlay {
    /// The overlay's pipeline for colour targets of `format` with `samples` samples per pixel
    /// and a `depth` buffer (ignored: the overlay is drawn over everything).
    pub fn new(
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        samples: u32,
        depth: wgpu::TextureFormat,
    ) -> Overlay {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("robosim overlay shader"),
            source: wgpu::ShaderSource::Wgsl(include_str!("overlay.wgsl").into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("robosim overlay bindings"),
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
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("robosim overlay pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("robosim overlay"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_text"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: depth,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: samples,
                mask: !0,
                alpha_to_coverage_enabled: false,
            },
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_text"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let rect = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("robosim overlay rect"),
            size: RECT_BYTES,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Overlay {
            pipeline,
            layout,
            rect,
            current: None,
        }
    }

    /// The text shown, if any.
    pub fn text(&self) -> Option<&str> {
        self.current.as_ref().map(|c| c.0.as_str())
    }

    /// Shows `text` from the next frame on (`None` or empty: nothing). Rasterizes and uploads
    /// only when the text differs from what is shown.
    pub fn set_text(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, text: Option<&str>) {
        let text = text.map(str::trim_end).filter(|t| !t.is_empty());
        if text == self.text() {
            return;
        }
        self.current = text.and_then(|t| {
            let mask = TextMask::rasterize(t)?;
            let size = wgpu::Extent3d {
                width: mask.width,
                height: mask.height,
                depth_or_array_layers: 1,
            };
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("robosim overlay text"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::R8Unorm,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                &mask.alpha,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(mask.width),
                    rows_per_image: Some(mask.height),
                },
                size,
            );
            let view = texture.create_view(&Default::default());
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("robosim overlay bind group"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.rect.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                ],
            });
            Some((t.to_owned(), (mask.width, mask.height), group))
        });
    }

    /// The panel's rectangle (x, y, width, height; px from the top-left) in a frame, if text
    /// is shown.
    pub fn rect(&self) -> Option<[u32; 4]> {
        self.current
            .as_ref()
            .map(|(_, (w, h), _)| [MARGIN_PX, MARGIN_PX, *w, *h])
    }

    /// Writes the panel's placement for a `width` × `height` target (before the frame is
    /// submitted).
    pub fn prepare(&self, queue: &wgpu::Queue, width: u32, height: u32) {
        if let Some([x, y, w, h]) = self.rect() {
            let data = [
                x as f32,
                y as f32,
                w as f32,
                h as f32,
                width as f32,
                height as f32,
                0.0,
                0.0,
            ];
            queue.write_buffer(&self.rect, 0, bytemuck::cast_slice(&data));
        }
    }

    /// Draws the panel into `pass` (nothing without text).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        if let Some((_, _, group)) = &self.current {
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..6, 0..1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_rasterized_with_the_bundled_font() {
        assert!(TextMask::rasterize("").is_none());
        let one = TextMask::rasterize("t = 2.000 s").expect("mask");
        let two = TextMask::rasterize("t = 2.000 s\npuma560 q = 45.8°").expect("mask");
        assert!(two.height > one.height && two.width > one.width);
        assert_eq!(one.alpha.len(), (one.width * one.height) as usize);
        // Ink inside the margins, none on the margin itself.
        let covered = one.alpha.iter().filter(|a| **a > 128).count();
        assert!(covered > 50, "{covered} pixels covered");
        for x in 0..one.width {
            assert_eq!(one.alpha[x as usize], 0, "top margin");
        }
        // Another text is another picture.
        assert_ne!(one, TextMask::rasterize("t = 3.000 s").expect("mask"));
    }
}
