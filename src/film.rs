//! Images and films: per-pixel accumulation (each sample counts for its pixel; the pixel
//! filter acts where samples and splats are made, `filter.rs`), deterministic splatting, EXR
//! output (32-bit float RGB, or half) with the render's metadata in its header, PNG
//! previews. Every file is written to a temporary name beside the target and renamed into
//! place, so a reader never sees a half-written image.

use crate::error::{Error, Result};
use crate::math::Spectrum;
use glam::{DVec3, Vec3};
use rayon::iter::IndexedParallelIterator;
use std::path::Path;

/// A linear-RGB image, row-major, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixel values, row-major.
    pub pixels: Vec<Spectrum>,
}

impl Image {
    /// A black image of the given size.
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            pixels: vec![Spectrum::ZERO; (width * height) as usize],
        }
    }

    /// Mean of each channel over the image.
    pub fn mean(&self) -> DVec3 {
        let sum: DVec3 = self.pixels.iter().map(|p| p.as_dvec3()).sum();
        sum / self.pixels.len().max(1) as f64
    }

    /// Write a 32-bit float RGB EXR with `metadata` as text attributes.
    pub fn write_exr(&self, path: &Path, metadata: &[(String, String)]) -> Result<()> {
        self.write_exr_with(path, metadata, false)
    }

    /// Write a half-float RGB EXR (for small reference images).
    pub fn write_exr_half(&self, path: &Path, metadata: &[(String, String)]) -> Result<()> {
        self.write_exr_with(path, metadata, true)
    }

    fn write_exr_with(&self, path: &Path, metadata: &[(String, String)], half: bool) -> Result<()> {
        use exr::image::{Image as ExrImage, Layer, SpecificChannels, write::WritableImage};
        use exr::math::Vec2;
        use exr::meta::attribute::{AttributeValue, Text};
        use exr::meta::header::LayerAttributes;
        use exr::prelude::{Encoding, f16};
        let (w, h) = (self.width as usize, self.height as usize);
        let mut attrs = LayerAttributes::named("rgb");
        attrs.software_name = Some(Text::from("lodestar"));
        for (k, v) in metadata {
            let key = Text::new_or_none(format!("lodestar:{k}"))
                .ok_or_else(|| Error::new(format!("metadata key '{k}' is not valid EXR text")))?;
            let val = Text::new_or_none(v).ok_or_else(|| {
                Error::new(format!("metadata value of '{k}' is not valid EXR text"))
            })?;
            attrs.other.insert(key, AttributeValue::Text(val));
        }
        let px = &self.pixels;
        atomic_write(path, |tmp| {
            let result = if half {
                let layer = Layer::new(
                    (w, h),
                    attrs.clone(),
                    Encoding::SMALL_LOSSLESS,
                    SpecificChannels::rgb(|pos: Vec2<usize>| {
                        let c = px[pos.y() * w + pos.x()];
                        (f16::from_f32(c.x), f16::from_f32(c.y), f16::from_f32(c.z))
                    }),
                );
                ExrImage::from_layer(layer).write().to_file(tmp)
            } else {
                let layer = Layer::new(
                    (w, h),
                    attrs.clone(),
                    Encoding::SMALL_LOSSLESS,
                    SpecificChannels::rgb(|pos: Vec2<usize>| {
                        let c = px[pos.y() * w + pos.x()];
                        (c.x, c.y, c.z)
                    }),
                );
                ExrImage::from_layer(layer).write().to_file(tmp)
            };
            result.map_err(|e| e.to_string())
        })
    }

    /// Read the first RGB(A) layer of an EXR and its lodestar metadata.
    pub fn read_exr(path: &Path) -> Result<(Image, Vec<(String, String)>)> {
        use exr::prelude::read_first_rgba_layer_from_file;
        let what =
            |e: exr::error::Error| Error::new(format!("{}: cannot read EXR: {e}", path.display()));
        let img = read_first_rgba_layer_from_file(
            path,
            |res, _| Image_ {
                width: res.width(),
                pixels: vec![Vec3::ZERO; res.width() * res.height()],
                height: res.height(),
            },
            |buf: &mut Image_, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = buf.width;
                buf.pixels[pos.y() * w + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .map_err(what)?;
        let mut meta = Vec::new();
        for (k, v) in &img.layer_data.attributes.other {
            let k = k.to_string();
            if let (Some(key), exr::meta::attribute::AttributeValue::Text(t)) =
                (k.strip_prefix("lodestar:"), v)
            {
                meta.push((key.to_string(), t.to_string()));
            }
        }
        meta.sort();
        let px = img.layer_data.channel_data.pixels;
        Ok((
            Image {
                width: px.width as u32,
                height: px.height as u32,
                pixels: px.pixels,
            },
            meta,
        ))
    }

    /// Write an 8-bit sRGB PNG preview, scaling radiance by 2^exposure.
    pub fn write_png(&self, path: &Path, exposure: f32) -> Result<()> {
        let scale = 2f32.powf(exposure);
        let mut bytes = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            for c in [p.x, p.y, p.z] {
                bytes.push((srgb_encode(c * scale) * 255.0 + 0.5) as u8);
            }
        }
        write_png_rgb8(path, self.width, self.height, &bytes)
    }
}

/// Write 8-bit RGB pixels (row-major, top row first, 3 bytes a pixel) as a PNG, atomically.
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    atomic_write(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| e.to_string())?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(rgb).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())
    })
}

/// Buffer used while reading an EXR.
struct Image_ {
    width: usize,
    height: usize,
    pixels: Vec<Vec3>,
}

/// sRGB transfer function of a linear value, clamped to [0, 1].
pub fn srgb_encode(x: f32) -> f32 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The directory `path` will be written into. An error naming `path` if `path` is a
/// directory, or its directory does not exist, is not a directory or does not take new files
/// (found by creating and removing an empty file there), so that a render fails before it
/// starts rather than when it writes.
pub fn output_dir(path: &Path) -> Result<&Path> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let fail = |why: String| {
        Err(Error::new(format!(
            "{}: cannot write: {why}",
            path.display()
        )))
    };
    if path.is_dir() {
        return fail("it is a directory (expected a file name)".to_string());
    }
    if !dir.exists() {
        return fail(format!("directory '{}' does not exist", dir.display()));
    }
    if !dir.is_dir() {
        return fail(format!("'{}' is not a directory", dir.display()));
    }
    static PROBES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let probe = dir.join(format!(
        ".lodestar-probe.{}.{}",
        std::process::id(),
        PROBES.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(dir)
        }
        Err(e) => fail(format!("cannot create files in '{}': {e}", dir.display())),
    }
}

/// Write through a temporary file in the target's directory, then rename it into place.
pub fn atomic_write(
    path: &Path,
    write: impl FnOnce(&Path) -> std::result::Result<(), String>,
) -> Result<()> {
    let dir = output_dir(path)?;
    let name = path
        .file_name()
        .ok_or_else(|| Error::new(format!("{}: not a file name", path.display())))?;
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Keep the extension last: some writers look at it.
    let tmp = dir.join(format!(
        ".{}.{}.tmp.{}",
        name.to_string_lossy(),
        std::process::id(),
        ext
    ));
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            Error::new(format!("{}: cannot write: {e}", path.display()))
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(Error::new(format!("{}: cannot write: {e}", path.display())))
        }
    }
}

/// Accumulates samples per pixel plus splats; f64 sums so long renders do not
/// lose precision.
#[derive(Debug, Clone)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    sum: Vec<DVec3>,
    splat: Vec<DVec3>,
    /// Per-pixel sums of the filter weights of splatted camera samples
    /// ([`Film::new_weighted`]); empty otherwise.
    weight: Vec<f64>,
}

/// `*to += v`, checked (`--check`), if `v` is finite and non-negative; whether it was.
fn add_checked(to: &mut DVec3, v: DVec3) -> bool {
    crate::check::value(crate::check::Technique::named("splat"), v.as_vec3());
    let ok = v.is_finite() && v.min_element() >= 0.0;
    if ok {
        *to += v;
    }
    ok
}

impl Film {
    /// An empty film (every sum and splat zero) of the given size.
    pub fn new(width: u32, height: u32) -> Film {
        let n = (width * height) as usize;
        Film {
            width,
            height,
            sum: vec![DVec3::ZERO; n],
            splat: vec![DVec3::ZERO; n],
            weight: Vec::new(),
        }
    }

    /// An empty film whose pixel sums are weighted (camera samples splatted with their
    /// filter weights, `camera.rs`): the image divides each pixel's sum by its weight sum
    /// rather than by the number of samples per pixel.
    pub fn new_weighted(width: u32, height: u32) -> Film {
        Film {
            weight: vec![0.0; (width * height) as usize],
            ..Film::new(width, height)
        }
    }

    /// Blocks of `rows` rows (the last may have fewer) of the per-pixel sums and weight sums,
    /// for parallel accumulation of splatted camera samples (one task per block); a weighted
    /// film only.
    pub fn par_weighted_blocks_mut(
        &mut self,
        rows: usize,
    ) -> impl IndexedParallelIterator<Item = (&mut [DVec3], &mut [f64])> {
        use rayon::prelude::*;
        assert!(!self.weight.is_empty(), "not a weighted film");
        let n = self.width as usize * rows;
        self.sum
            .par_chunks_mut(n)
            .zip(self.weight.par_chunks_mut(n))
    }

    /// Rows of the per-pixel sums, for parallel accumulation (one task per row).
    pub fn par_rows_mut(&mut self) -> rayon::slice::ChunksMut<'_, DVec3> {
        use rayon::prelude::*;
        self.sum.par_chunks_mut(self.width as usize)
    }

    /// The per-pixel sums of the pixel samples (splats not included), row-major.
    pub fn sums(&self) -> &[DVec3] {
        &self.sum
    }

    /// Add splats in the given order (callers merge per-chunk lists in chunk order, so the
    /// result does not depend on the thread count).
    /// Splats in f64 (the guider's values). Returns the number of splats left out for being
    /// non-finite or negative (as invalid pixel samples are: one would spoil its pixel for good).
    pub fn add_splats64(&mut self, splats: &[(u32, glam::DVec3)]) -> u64 {
        splats
            .iter()
            .filter(|&&(i, v)| !self.add_splat(i, v))
            .count() as u64
    }

    /// Add light-tracing splats, list after list, on rayon's threads: each task adds the
    /// splats of its own range of pixels, so every pixel's splats are summed in the same order
    /// whatever the number of threads. Returns the number left out as in
    /// [`Film::add_splats64`].
    pub fn add_splat_lists(&mut self, lists: &[&[(u32, Spectrum)]]) -> u64 {
        use rayon::prelude::*;
        let chunk = self
            .splat
            .len()
            .div_ceil(rayon::current_num_threads())
            .max(1);
        self.splat
            .par_chunks_mut(chunk)
            .enumerate()
            .map(|(c, splat)| {
                let range = c * chunk..c * chunk + splat.len();
                let mut left_out = 0;
                for &(i, v) in lists.iter().flat_map(|l| l.iter()) {
                    if range.contains(&(i as usize)) {
                        left_out +=
                            !add_checked(&mut splat[i as usize - range.start], v.as_dvec3()) as u64;
                    }
                }
                left_out
            })
            .sum()
    }

    /// One splat, checked (`--check`) and added if finite and non-negative.
    fn add_splat(&mut self, i: u32, v: glam::DVec3) -> bool {
        add_checked(&mut self.splat[i as usize], v)
    }

    /// The image: pixel sums divided by `samples_per_pixel` (by their weight sums on a
    /// weighted film, 0 where nothing landed), plus splats times `splat_scale`.
    pub fn to_image(&self, samples_per_pixel: f64, splat_scale: f64) -> Image {
        let inv = if samples_per_pixel > 0.0 {
            1.0 / samples_per_pixel
        } else {
            0.0
        };
        let scale = |i: usize| match self.weight.get(i) {
            None => inv,
            Some(&w) if w > 0.0 => 1.0 / w,
            Some(_) => 0.0,
        };
        let pixels = self
            .sum
            .iter()
            .zip(&self.splat)
            .enumerate()
            .map(|(i, (s, p))| (*s * scale(i) + *p * splat_scale).as_vec3())
            .collect();
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }

    /// Add another film of the same size, sums to sums and splats to splats.
    pub fn add(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "films of different sizes"
        );
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            *a += *b;
        }
        for (a, b) in self.splat.iter_mut().zip(&other.splat) {
            *a += *b;
        }
        for (a, b) in self.weight.iter_mut().zip(&other.weight) {
            *a += *b;
        }
    }

    /// Set every pixel sum and splat back to zero.
    pub fn clear(&mut self) {
        self.sum.fill(DVec3::ZERO);
        self.splat.fill(DVec3::ZERO);
        self.weight.fill(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trip_with_metadata() {
        let dir = std::env::temp_dir().join(format!("lodestar-film-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = Image::new(5, 3);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::new(i as f32, 0.5, 1e-3 * i as f32);
        }
        let path = dir.join("a.exr");
        let meta = vec![
            ("integrator".to_string(), "pt".to_string()),
            ("spp".to_string(), "4".to_string()),
        ];
        img.write_exr(&path, &meta).unwrap();
        let (back, m) = Image::read_exr(&path).unwrap();
        assert_eq!(back, img);
        assert_eq!(m, meta);
        // No temporary files left behind.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        img.write_png(&dir.join("a.png"), 0.0).unwrap();
        assert!(std::fs::metadata(dir.join("a.png")).unwrap().len() > 0);
        let err = img.write_exr(&dir.join("missing/a.exr"), &[]).unwrap_err();
        assert!(err.message().contains("does not exist"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
