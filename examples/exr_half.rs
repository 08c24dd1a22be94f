//! Convert a 32-bit float EXR written by `lodestar render` to a half-float EXR (used for the
//! small reference images in `scenes/references/`), keeping its `lodestar:*` metadata.
//!
//! ```sh
//! cargo run --release --example exr_half -- IN.exr OUT.exr [key=value ...]
//! ```
//! Extra `key=value` arguments are added to the metadata (as `lodestar:key`), replacing a key of
//! the same name. Pixels that do not fit a half float (non-finite, negative or above 65504) are
//! an error rather than being clamped: a reference must not change silently. Prints the
//! per-channel means of the input and of the written file and the largest relative change of a
//! pixel (half floats keep 11 significant bits: at most 2^-11 ≈ 4.9e-4 relative).

use lodestar::film::Image;
use std::path::Path;
use std::process::ExitCode;

const HALF_MAX: f32 = 65504.0;

fn run(args: &[String]) -> Result<(), String> {
    let [input, output, extra @ ..] = args else {
        return Err("usage: exr_half IN.exr OUT.exr [key=value ...]".to_string());
    };
    let (image, mut meta) = Image::read_exr(Path::new(input)).map_err(|e| e.to_string())?;
    for kv in extra {
        let Some((k, v)) = kv.split_once('=') else {
            return Err(format!("argument '{kv}': expected key=value"));
        };
        meta.retain(|(key, _)| key != k);
        meta.push((k.to_string(), v.to_string()));
    }
    if let Some(i) = image
        .pixels
        .iter()
        .position(|p| !(p.is_finite() && p.min_element() >= 0.0 && p.max_element() <= HALF_MAX))
    {
        let (x, y) = (i as u32 % image.width, i as u32 / image.width);
        return Err(format!(
            "{input}: pixel ({x}, {y}) = {} does not fit a half float (expected finite values in [0, {HALF_MAX}])",
            image.pixels[i]
        ));
    }
    image
        .write_exr_half(Path::new(output), &meta)
        .map_err(|e| e.to_string())?;
    let (half, _) = Image::read_exr(Path::new(output)).map_err(|e| e.to_string())?;
    let worst = image
        .pixels
        .iter()
        .zip(&half.pixels)
        .map(|(a, b)| ((*a - *b).abs() / a.max(glam::Vec3::splat(1e-3))).max_element())
        .fold(0.0f32, f32::max);
    let (m, mh) = (image.mean(), half.mean());
    println!(
        "{output}: {} x {}, mean rgb ({:.5}, {:.5}, {:.5}) -> ({:.5}, {:.5}, {:.5}), largest relative pixel change {worst:.2e}",
        image.width, image.height, m.x, m.y, m.z, mh.x, mh.y, mh.z
    );
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("exr_half: {e}");
            ExitCode::FAILURE
        }
    }
}
