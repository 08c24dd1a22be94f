//! Textures: a reflectance that varies over a surface with its texture coordinates, as
//! Mitsuba 3 defines them.
//!
//! * [`Texture::Bitmap`]: an image (PNG, JPEG or OpenEXR). 8- and 16-bit images are sRGB
//!   decoded to linear values unless `raw`; EXR values are linear. Looked up at
//!   `to_uv(u, v)` with the image's top row at v = 0 (Mitsuba's convention; its OBJ reader
//!   flips `vt` to match, as lodestar's does); `bilinear` (default) or `nearest` filtering;
//!   `repeat` (default), `mirror` or `clamp` wrapping.
//! * [`Texture::Checkerboard`]: `color0` where the fractional parts of both coordinates lie on
//!   the same side of 1/2, `color1` elsewhere (defaults 0.4 and 0.2).
//!
//! Texture coordinates come from the mesh (OBJ `vt`, PLY `u, v`, Mitsuba's serialized
//! meshes), from the analytic shapes (`rectangle`: its local (x, y) mapped from [-1, 1]² to
//! [0, 1]²; `sphere`: (φ / 2π, θ / π) about its z axis), and are a triangle's barycentric
//! coordinates (b1, b2) on meshes without them, as in Mitsuba.

use crate::error::{Error, Result};
use crate::math::{Spectrum, luminance};
use glam::{Affine2, Vec2};
use std::path::Path;

/// How lookups outside [0, 1] are brought back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// Tile the image.
    Repeat,
    /// Tile the image, every other copy mirrored.
    Mirror,
    /// The nearest edge texel.
    Clamp,
}

impl Wrap {
    /// The texel index `i` brought into `0 .. n`.
    #[inline]
    fn texel(self, i: i64, n: i64) -> usize {
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        }) as usize
    }
}

/// A bitmap's texels (linear RGB, row 0 at the top) and how it is looked up.
#[derive(Debug, Clone, PartialEq)]
pub struct Bitmap {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Row-major, `width * height`.
    pub texels: Vec<Spectrum>,
    /// Bilinear (true) or nearest-texel lookups.
    pub bilinear: bool,
    /// Lookups outside [0, 1]².
    pub wrap: Wrap,
    /// The smallest and largest channel value of any texel, and the mean texel (computed
    /// once: roulette asks for the largest at every vertex).
    lo: f32,
    hi: f32,
    mean: Spectrum,
}

impl Bitmap {
    /// A bitmap of `width * height` row-major texels, bilinear and repeating.
    pub fn new(width: u32, height: u32, texels: Vec<Spectrum>) -> Bitmap {
        let (lo, hi) = texels.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), t| {
            (lo.min(t.min_element()), hi.max(t.max_element()))
        });
        let mean = texels.iter().copied().sum::<Spectrum>() / texels.len().max(1) as f32;
        Bitmap {
            width,
            height,
            texels,
            bilinear: true,
            wrap: Wrap::Repeat,
            lo,
            hi,
            mean,
        }
    }

    /// The texel at column `x`, row `y`, brought into the image by the wrap mode.
    #[inline]
    fn texel(&self, x: i64, y: i64) -> Spectrum {
        let (w, h) = (self.width as i64, self.height as i64);
        self.texels[self.wrap.texel(y, h) * self.width as usize + self.wrap.texel(x, w)]
    }

    /// The bilinear cell of image coordinates `uv`: the texel whose centre lies at or before
    /// `uv` in both axes, and `uv`'s fractional position towards the next centres.
    #[inline]
    fn bilinear_cell(&self, uv: Vec2) -> (i64, i64, Vec2) {
        let p = uv * Vec2::new(self.width as f32, self.height as f32) - 0.5;
        let c = p.floor();
        (c.x as i64, c.y as i64, p - c)
    }

    /// The value at texture coordinates `uv` (image space: u right, v down, the image in
    /// [0, 1]²), as Mitsuba's `bitmap` filters it: texel centres at `(i + 1/2) / width`.
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        if !self.bilinear {
            let p = uv * Vec2::new(self.width as f32, self.height as f32);
            return self.texel(p.x.floor() as i64, p.y.floor() as i64);
        }
        let (x0, y0, f) = self.bilinear_cell(uv);
        let top = self.texel(x0, y0) * (1.0 - f.x) + self.texel(x0 + 1, y0) * f.x;
        let bottom = self.texel(x0, y0 + 1) * (1.0 - f.x) + self.texel(x0 + 1, y0 + 1) * f.x;
        top * (1.0 - f.y) + bottom * f.y
    }

    /// The gradient of the texels' luminance at image coordinates `uv` (as in [`Self::eval`])
    /// with respect to `uv`: the derivative of the bilinear interpolation (Mitsuba's
    /// `eval_1_grad`), zero for nearest-texel lookups (constant between texel edges).
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        if !self.bilinear {
            return Vec2::ZERO;
        }
        let (x0, y0, f) = self.bilinear_cell(uv);
        let at = |x, y| luminance(self.texel(x, y));
        let (f00, f10) = (at(x0, y0), at(x0 + 1, y0));
        let (f01, f11) = (at(x0, y0 + 1), at(x0 + 1, y0 + 1));
        // Per texel, then per unit of `uv` (a texel is 1 / width across).
        let d_dx = (f10 - f00) * (1.0 - f.y) + (f11 - f01) * f.y;
        let d_dy = (f01 - f00) * (1.0 - f.x) + (f11 - f10) * f.x;
        Vec2::new(d_dx * self.width as f32, d_dy * self.height as f32)
    }

    /// Read an image file: PNG, JPEG or OpenEXR, told apart by their first bytes; 8- and
    /// 16-bit values sRGB-decoded unless `raw`. Errors name the file.
    pub fn read(path: &Path, raw: bool) -> Result<Bitmap> {
        let err = |what: String| Error::new(format!("{}: {what}", path.display()));
        let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read texture: {e}")))?;
        let (width, height, texels) = if bytes.starts_with(b"\x76\x2f\x31\x01") {
            let (img, _) = crate::film::Image::read_exr(path)?;
            (img.width, img.height, img.pixels)
        } else if bytes.starts_with(b"\x89PNG") {
            read_png(&bytes, raw).map_err(err)?
        } else if bytes.starts_with(b"\xff\xd8") {
            read_jpeg(&bytes, raw).map_err(err)?
        } else {
            return Err(err("not a PNG, JPEG or OpenEXR image".into()));
        };
        if width == 0 || height == 0 {
            return Err(err("the image is empty".into()));
        }
        Ok(Bitmap::new(width, height, texels))
    }
}

/// sRGB's transfer function, inverted: an encoded value in [0, 1] to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Texels from 8- or 16-bit channels (`gray`, `gray + alpha`, `rgb` or `rgba`; alpha ignored).
fn texels_from(channels: usize, values: impl Iterator<Item = f32>, raw: bool) -> Vec<Spectrum> {
    let decode = |c: f32| if raw { c } else { srgb_to_linear(c) };
    let values: Vec<f32> = values.map(decode).collect();
    values
        .chunks_exact(channels)
        .map(|t| match channels {
            1 | 2 => Spectrum::splat(t[0]),
            _ => Spectrum::new(t[0], t[1], t[2]),
        })
        .collect()
}

fn read_png(bytes: &[u8], raw: bool) -> std::result::Result<(u32, u32, Vec<Spectrum>), String> {
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    // Palettes become RGB(A), and bit depths below 8 become 8.
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec
        .read_info()
        .map_err(|e| format!("cannot read PNG: {e}"))?;
    let mut buf = vec![0; reader.output_buffer_size().ok_or("PNG too large")?];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("cannot read PNG: {e}"))?;
    let channels = info.color_type.samples();
    let bytes = &buf[..info.buffer_size()];
    let texels = match info.bit_depth {
        png::BitDepth::Sixteen => texels_from(
            channels,
            bytes
                .chunks_exact(2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]) as f32 / 65535.0),
            raw,
        ),
        _ => texels_from(channels, bytes.iter().map(|&b| b as f32 / 255.0), raw),
    };
    Ok((info.width, info.height, texels))
}

fn read_jpeg(bytes: &[u8], raw: bool) -> std::result::Result<(u32, u32, Vec<Spectrum>), String> {
    let mut dec = jpeg_decoder::Decoder::new(std::io::Cursor::new(bytes));
    let data = dec.decode().map_err(|e| format!("cannot read JPEG: {e}"))?;
    let info = dec.info().ok_or("cannot read JPEG: no image")?;
    let channels = match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => 1,
        jpeg_decoder::PixelFormat::RGB24 => 3,
        other => {
            return Err(format!(
                "JPEG pixel format {other:?} is not read (expected gray or RGB)"
            ));
        }
    };
    let texels = texels_from(channels, data.iter().map(|&b| b as f32 / 255.0), raw);
    Ok((info.width as u32, info.height as u32, texels))
}

/// A reflectance over texture coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Texture {
    /// An image.
    Bitmap {
        /// The image, shared by every texture that reads the file.
        bitmap: std::sync::Arc<Bitmap>,
        /// Texture coordinates to the image's (Mitsuba's `to_uv`).
        to_uv: Affine2,
    },
    /// Two colours in a checker pattern of 2 x 2 squares per unit of texture coordinates.
    Checkerboard {
        /// Where both coordinates' fractional parts lie on the same side of 1/2.
        color0: Spectrum,
        /// Elsewhere.
        color1: Spectrum,
        /// Texture coordinates to the pattern's.
        to_uv: Affine2,
    },
}

impl Texture {
    /// The value at the surface's texture coordinates `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        match self {
            Texture::Bitmap { bitmap, to_uv } => bitmap.eval(to_uv.transform_point2(uv)),
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let q = to_uv.transform_point2(uv);
                let (a, b) = (q.x - q.x.floor() > 0.5, q.y - q.y.floor() > 0.5);
                if a == b { *color0 } else { *color1 }
            }
        }
    }

    /// The gradient of the texture's luminance with respect to the surface's texture
    /// coordinates at `uv` (what a bump map tilts the normal by): a bilinear bitmap's through
    /// `to_uv` (the chain rule: the transform's transpose times the image-space gradient);
    /// zero for nearest-texel bitmaps and checkerboards, constant between their edges.
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Bitmap { bitmap, to_uv } => {
                let g = bitmap.gradient(to_uv.transform_point2(uv));
                to_uv.matrix2.transpose() * g
            }
            Texture::Checkerboard { .. } => Vec2::ZERO,
        }
    }

    /// The largest channel value anywhere (for Russian roulette, which must not depend on
    /// where on the surface a path is).
    pub fn max(&self) -> f32 {
        match self {
            Texture::Bitmap { bitmap, .. } => bitmap.hi,
            Texture::Checkerboard { color0, color1, .. } => {
                color0.max_element().max(color1.max_element())
            }
        }
    }

    /// The mean value over the texture (per channel).
    pub fn mean(&self) -> Spectrum {
        match self {
            Texture::Bitmap { bitmap, .. } => bitmap.mean,
            Texture::Checkerboard { color0, color1, .. } => (*color0 + *color1) * 0.5,
        }
    }

    /// The smallest and largest channel value anywhere.
    pub fn range(&self) -> (f32, f32) {
        match self {
            Texture::Bitmap { bitmap, .. } => (bitmap.lo, bitmap.hi),
            Texture::Checkerboard { color0, color1, .. } => {
                (color0.min_element().min(color1.min_element()), self.max())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bitmap(w: u32, h: u32, wrap: Wrap, bilinear: bool) -> Bitmap {
        Bitmap {
            bilinear,
            wrap,
            ..Bitmap::new(
                w,
                h,
                (0..w * h).map(|i| Spectrum::splat(i as f32)).collect(),
            )
        }
    }

    #[test]
    fn bilinear_lookups_hit_texel_centres_and_interpolate_between_them() {
        let b = bitmap(4, 2, Wrap::Clamp, true);
        // Texel (1, 0) has value 1, its centre at ((1 + 1/2) / 4, (0 + 1/2) / 2).
        assert_eq!(b.eval(Vec2::new(0.375, 0.25)).x, 1.0);
        assert_eq!(b.eval(Vec2::new(0.625, 0.75)).x, 6.0);
        // Halfway between texels (1, 0) and (2, 1): the mean of the four around it.
        assert!((b.eval(Vec2::new(0.5, 0.5)).x - (1.0 + 2.0 + 5.0 + 6.0) / 4.0).abs() < 1e-6);
        // A quarter of the way from (0, 0)'s centre to (1, 0)'s.
        assert!((b.eval(Vec2::new(0.125 + 0.0625, 0.25)).x - 0.25).abs() < 1e-6);
    }

    /// The gradient against central differences of `eval`'s luminance, inside texel cells
    /// (away from the kinks at texel centres), through a non-trivial `to_uv`, across the wrap.
    #[test]
    fn gradients_are_the_derivative_of_the_bilinear_lookup() {
        let mut b = bitmap(5, 3, Wrap::Repeat, true);
        for (i, t) in b.texels.iter_mut().enumerate() {
            *t = Spectrum::new((i * 7 % 5) as f32, (i * 3 % 4) as f32, (i % 3) as f32);
        }
        let t = Texture::Bitmap {
            bitmap: std::sync::Arc::new(b),
            to_uv: Affine2::from_mat2_translation(
                glam::Mat2::from_cols_array(&[2.0, 0.5, -0.25, 1.5]),
                Vec2::new(0.3, -0.2),
            ),
        };
        let lum = |uv: Vec2| luminance(t.eval(uv)) as f64;
        let h = 1e-3f32;
        let mut checked = 0;
        for k in 0..200 {
            let uv = Vec2::new(
                (k as f32 * 0.618_034).fract() * 3.0 - 1.0,
                (k as f32 * 0.414_214).fract() * 3.0 - 1.0,
            );
            let g = t.gradient(uv);
            let dx = (lum(uv + Vec2::X * h) - lum(uv - Vec2::X * h)) / (2.0 * h as f64);
            let dy = (lum(uv + Vec2::Y * h) - lum(uv - Vec2::Y * h)) / (2.0 * h as f64);
            // A texel centre (where the interpolation's cell changes) within h either side
            // makes the difference a mixture of two cells.
            let cell = |q: Vec2| {
                let Texture::Bitmap { to_uv, .. } = &t else {
                    unreachable!()
                };
                (to_uv.transform_point2(q) * Vec2::new(5.0, 3.0) - 0.5).floor()
            };
            let corners = [(h, h), (h, -h), (-h, h), (-h, -h)].map(|(a, b)| uv + Vec2::new(a, b));
            if corners.iter().any(|&q| cell(q) != cell(uv)) {
                continue;
            }
            let tol = 2e-2 * (1.0 + g.length() as f64);
            assert!(
                (dx - g.x as f64).abs() < tol && (dy - g.y as f64).abs() < tol,
                "at {uv}: gradient {g}, differences ({dx}, {dy})"
            );
            checked += 1;
        }
        assert!(checked > 100, "only {checked} points away from kinks");
        let nearest = Texture::Bitmap {
            bitmap: std::sync::Arc::new(bitmap(5, 3, Wrap::Repeat, false)),
            to_uv: Affine2::IDENTITY,
        };
        assert_eq!(nearest.gradient(Vec2::new(0.3, 0.3)), Vec2::ZERO);
    }

    #[test]
    fn nearest_lookups_take_the_texel_under_the_point() {
        let b = bitmap(4, 2, Wrap::Repeat, false);
        assert_eq!(b.eval(Vec2::new(0.3, 0.1)).x, 1.0);
        let t = Texture::Bitmap {
            bitmap: std::sync::Arc::new(b.clone()),
            to_uv: Affine2::IDENTITY,
        };
        assert_eq!((t.max(), t.range(), t.mean().x), (7.0, (0.0, 7.0), 3.5));
        assert_eq!(b.eval(Vec2::new(0.99, 0.99)).x, 7.0);
        // Repeat: one period on.
        assert_eq!(b.eval(Vec2::new(1.3, -0.9)).x, 1.0);
    }

    #[test]
    fn wrap_modes_fold_texel_indices_as_mitsuba_does() {
        let n = 4;
        let got = |w: Wrap| (-5..9).map(|i| w.texel(i, n)).collect::<Vec<_>>();
        assert_eq!(
            got(Wrap::Repeat),
            [3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]
        );
        assert_eq!(got(Wrap::Clamp), [0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3]);
        assert_eq!(
            got(Wrap::Mirror),
            [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]
        );
    }

    #[test]
    fn the_checkerboard_takes_color0_where_both_coordinates_agree() {
        let t = Texture::Checkerboard {
            color0: Spectrum::splat(0.4),
            color1: Spectrum::splat(0.2),
            to_uv: Affine2::from_scale(Vec2::splat(2.0)),
        };
        let at = |u: f32, v: f32| t.eval(Vec2::new(u, v)).x;
        assert_eq!(at(0.1, 0.1), 0.4);
        assert_eq!(at(0.3, 0.1), 0.2);
        assert_eq!(at(0.3, 0.3), 0.4);
        assert_eq!(at(0.6, 0.1), 0.4);
        assert_eq!(at(0.1, 0.8), 0.2);
        assert_eq!(t.max(), 0.4);
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
    }

    #[test]
    fn png_files_read_as_linear_texels_with_the_top_row_first() {
        let dir = std::env::temp_dir().join(format!("lodestar-texture-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        let mut enc = png::Encoder::new(std::fs::File::create(&path).unwrap(), 2, 2);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().unwrap();
        w.write_image_data(&[255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128])
            .unwrap();
        drop(w);
        let b = Bitmap::read(&path, false).unwrap();
        assert_eq!((b.width, b.height), (2, 2));
        assert_eq!(b.texels[0], Spectrum::new(1.0, 0.0, 0.0));
        assert_eq!(b.texels[2], Spectrum::new(0.0, 0.0, 1.0));
        assert!((b.texels[3].x - srgb_to_linear(128.0 / 255.0)).abs() < 1e-6);
        let raw = Bitmap::read(&path, true).unwrap();
        assert!((raw.texels[3].x - 128.0 / 255.0).abs() < 1e-6);
        std::fs::write(dir.join("bad.png"), b"not an image").unwrap();
        let e = Bitmap::read(&dir.join("bad.png"), false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.png") && e.contains("not a PNG"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
