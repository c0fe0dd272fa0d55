//! Images: RGBA8 pixels, PNG in and out, and the golden-image comparison.
//!
//! The comparison has to pass when another software-renderer version rasterizes an edge one
//! pixel over or rounds a shade differently, and fail when something is really different — a
//! missing object, a moved camera. So it is fuzzy in place and strict in amount: a pixel of `a`
//! *matches* if, on every channel, it lies within [`Tolerance::channel`] of the range (min to
//! max) that channel takes over the 3×3 neighbourhood of the same place in `b`. An
//! anti-aliased edge pixel is a blend of colours found next to it, so it falls inside the
//! range; a one-pixel shift keeps every colour inside the neighbourhood; a missing object
//! leaves colours with nothing like them nearby. The check runs both ways (a→b and b→a, so
//! something missing from either side counts), and the images differ if more than
//! [`Tolerance::fraction`] of the pixels fail to match. It is the "fuzzy" test of browser
//! reftests (a per-channel limit and a pixel count) with a neighbourhood range in place of
//! the same pixel. Measured margins are in docs/display.md.

use crate::{DisplayError, Result};
use std::path::Path;

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbaImage {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first, 4 bytes per pixel (sRGB).
    pub pixels: Vec<u8>,
}

impl RgbaImage {
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = ((y * self.width + x) * 4) as usize;
        [
            self.pixels[i],
            self.pixels[i + 1],
            self.pixels[i + 2],
            self.pixels[i + 3],
        ]
    }

    /// Writes the image as an 8-bit RGBA PNG at `path` (parent directories created), with the
    /// process's default file mode.
    pub fn save_png(&self, path: &Path) -> Result<()> {
        let io = |e: std::io::Error| DisplayError::Io {
            path: path.to_path_buf(),
            source: e,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        // Encoded in memory, then written by robosim_input::write_file_atomic: a FIFO, a device
        // or a link at `path` is refused, a crash leaves no half image.
        let mut bytes = Vec::new();
        self.encode_into(path, &mut bytes)?;
        robosim_input::write_file_atomic(path, &bytes).map_err(|e| DisplayError::Image {
            path: path.to_path_buf(),
            what: e.problem.to_string(),
        })
    }

    /// [`RgbaImage::save_png`] for a session's files: the file mode 0600, missing parent
    /// directories 0700 ([`crate::private`]).
    pub fn save_png_private(&self, path: &Path) -> Result<()> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            crate::private::private_dir(dir, false)?;
        }
        self.encode_into(
            path,
            std::io::BufWriter::new(crate::private::create_file(path)?),
        )
    }

    fn encode_into(&self, path: &Path, out: impl std::io::Write) -> Result<()> {
        let mut enc = png::Encoder::new(out, self.width, self.height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let png_err = |e: png::EncodingError| DisplayError::Png {
            path: path.to_path_buf(),
            source: Box::new(e),
        };
        let mut w = enc.write_header().map_err(png_err)?;
        w.write_image_data(&self.pixels).map_err(png_err)?;
        w.finish().map_err(png_err)
    }

    /// Reads an 8-bit RGB or RGBA PNG.
    pub fn load_png(path: &Path) -> Result<RgbaImage> {
        let bad = |what: String| DisplayError::Image {
            path: path.to_path_buf(),
            what,
        };
        // A regular file only (a FIFO would block the open, a device never ends).
        let (file, _) =
            robosim_input::open_regular(path, "a PNG image").map_err(|e| DisplayError::Image {
                path: path.to_path_buf(),
                what: e.reason(),
            })?;
        let decoder = png::Decoder::new(std::io::BufReader::new(file));
        let png_err = |e: png::DecodingError| DisplayError::Png {
            path: path.to_path_buf(),
            source: Box::new(e),
        };
        let mut reader = decoder.read_info().map_err(png_err)?;
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).map_err(png_err)?;
        buf.truncate(info.buffer_size());
        if info.bit_depth != png::BitDepth::Eight {
            return Err(bad(format!("bit depth {:?}; 8 expected", info.bit_depth)));
        }
        let pixels = match info.color_type {
            png::ColorType::Rgba => buf,
            png::ColorType::Rgb => buf
                .chunks_exact(3)
                .flat_map(|c| [c[0], c[1], c[2], 255])
                .collect(),
            other => return Err(bad(format!("colour type {other:?}; RGB or RGBA expected"))),
        };
        Ok(RgbaImage {
            width: info.width,
            height: info.height,
            pixels,
        })
    }
}

/// How different two images may be and still count as the same picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Largest per-channel difference (0–255) of a matching pixel.
    pub channel: u8,
    /// Largest fraction of pixels without a match.
    pub fraction: f64,
}

impl Default for Tolerance {
    /// 24 levels per channel (about 10 %), 0.3 % of the pixels.
    fn default() -> Self {
        Tolerance {
            channel: 24,
            fraction: 0.003,
        }
    }
}

/// Statistics of a comparison.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diff {
    /// Fraction of pixels (worse of the two directions) with no match in the other image.
    pub unmatched: f64,
    /// Mean absolute channel difference, same place, 0–255.
    pub mean_abs: f64,
    /// Largest same-place channel difference.
    pub max_abs: u8,
}

impl Diff {
    pub fn within(&self, tol: &Tolerance) -> bool {
        self.unmatched <= tol.fraction
    }
}

fn unmatched(a: &RgbaImage, b: &RgbaImage, channel: u8) -> usize {
    let (w, h) = (a.width as i64, a.height as i64);
    let tol = channel as i32;
    let mut count = 0;
    for y in 0..h {
        for x in 0..w {
            let p = a.pixel(x as u32, y as u32);
            let mut lo = [255_i32; 3];
            let mut hi = [0_i32; 3];
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (u, v) = (x + dx, y + dy);
                    if u >= 0 && v >= 0 && u < w && v < h {
                        let q = b.pixel(u as u32, v as u32);
                        for c in 0..3 {
                            lo[c] = lo[c].min(q[c] as i32);
                            hi[c] = hi[c].max(q[c] as i32);
                        }
                    }
                }
            }
            let inside = (0..3).all(|c| (lo[c] - tol..=hi[c] + tol).contains(&(p[c] as i32)));
            if !inside {
                count += 1;
            }
        }
    }
    count
}

/// Compares two images of the same size (an error otherwise: a size change is never a pass).
pub fn compare(a: &RgbaImage, b: &RgbaImage, tol: &Tolerance) -> Result<Diff> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(DisplayError::Size(format!(
            "images differ in size: {}×{} vs {}×{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let n = (a.width as usize * a.height as usize).max(1);
    let worst = unmatched(a, b, tol.channel).max(unmatched(b, a, tol.channel));
    let mut sum = 0_u64;
    let mut max_abs = 0_u8;
    for (p, q) in a.pixels.chunks_exact(4).zip(b.pixels.chunks_exact(4)) {
        for c in 0..3 {
            let d = p[c].abs_diff(q[c]);
            sum += d as u64;
            max_abs = max_abs.max(d);
        }
    }
    Ok(Diff {
        unmatched: worst as f64 / n as f64,
        mean_abs: sum as f64 / (n * 3) as f64,
        max_abs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn canvas(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 4]) -> RgbaImage {
        let mut pixels = Vec::new();
        for y in 0..h {
            for x in 0..w {
                pixels.extend_from_slice(&f(x, y));
            }
        }
        RgbaImage {
            width: w,
            height: h,
            pixels,
        }
    }

    fn square(x0: u32, shade: u8) -> RgbaImage {
        canvas(64, 64, |x, y| {
            if (x0..x0 + 20).contains(&x) && (20..40).contains(&y) {
                [shade, 40, 40, 255]
            } else {
                [200, 200, 200, 255]
            }
        })
    }

    #[test]
    fn one_pixel_shift_and_small_shade_change_pass_but_missing_objects_fail() {
        let tol = Tolerance::default();
        let a = square(10, 180);
        assert!(
            compare(&a, &square(11, 190), &tol)
                .expect("same size")
                .within(&tol)
        );
        // Shifted by 3 px: two 20-px columns unmatched = 40/4096 ≈ 1 %.
        let d = compare(&a, &square(13, 180), &tol).expect("same size");
        assert!(!d.within(&tol), "{d:?}");
        // The square missing altogether: found from the missing side only, so both ways count.
        let empty = canvas(64, 64, |_, _| [200, 200, 200, 255]);
        assert!(!compare(&a, &empty, &tol).expect("same size").within(&tol));
        assert!(!compare(&empty, &a, &tol).expect("same size").within(&tol));
        assert!(compare(&a, &canvas(32, 64, |_, _| [0; 4]), &tol).is_err());
    }

    #[test]
    fn png_round_trip_and_bad_files_name_the_path() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("sub/a.png");
        let a = square(5, 100);
        a.save_png(&p).expect("save");
        assert_eq!(RgbaImage::load_png(&p).expect("load"), a);
        let bad = dir.path().join("bad.png");
        std::fs::write(&bad, b"not a png").expect("write");
        let e = RgbaImage::load_png(&bad).expect_err("refused").to_string();
        assert!(e.contains("bad.png"), "{e}");
    }

    #[test]
    fn issue_34_png_save_through_a_symlink_or_onto_a_device_is_refused_and_load_of_a_device_too() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("precious");
        std::fs::write(&target, "keep me").expect("write");
        let link = dir.path().join("out.png");
        std::os::unix::fs::symlink(&target, &link).expect("symlink");
        let a = square(5, 100);
        let e = a
            .save_png(&link)
            .expect_err("a link is refused")
            .to_string();
        assert!(e.contains("it is a symbolic link"), "{e}");
        assert!(
            std::fs::symlink_metadata(&link)
                .expect("link")
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&target).expect("read"), "keep me");
        let e = a
            .save_png(Path::new("/dev/null"))
            .expect_err("a device is refused")
            .to_string();
        assert!(e.contains("it is a character device"), "{e}");
        let e = RgbaImage::load_png(Path::new("/dev/zero"))
            .expect_err("a device")
            .to_string();
        assert!(e.contains("it is a character device"), "{e}");
    }
}
