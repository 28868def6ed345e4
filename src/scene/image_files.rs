//! Guide, painting and render images on disk: PNG (sRGB-encoded, 8 or 16 bits) and
//! OpenEXR (linear), chosen by the file's extension.

use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use crate::image_io::{RgbImage, decode_exr_rgb, write_exr_rgb};
use image::{DynamicImage, ImageEncoder};
use std::path::Path;

/// The sRGB transfer function: linear [0, 1] to encoded [0, 1]; out-of-range and NaN
/// values are clipped first.
pub fn srgb_encode(linear: f32) -> f32 {
    let c = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse sRGB transfer function: encoded [0, 1] to linear [0, 1].
pub fn srgb_decode(encoded: f32) -> f32 {
    let c = encoded;
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Writes an 8-bit sRGB PNG of the linear image, clipped to [0, 1], atomically.
pub fn write_png(path: impl AsRef<Path>, image: &RgbImage) -> Result<()> {
    let path = path.as_ref();
    check_consistent(path, image)?;
    let bytes: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|rgb| rgb.map(|c| (srgb_encode(c) * 255.0).round() as u8))
        .collect();
    let (width, height) = dimensions_u32(path, image)?;
    write_atomically(path, |w| {
        image::codecs::png::PngEncoder::new(w)
            .write_image(&bytes, width, height, image::ExtendedColorType::Rgb8)
            .map_err(std::io::Error::other)
    })
}

/// Reads a PNG as linear RGB: 8- and 16-bit samples are sRGB-decoded; alpha is ignored.
pub fn read_png_linear(path: impl AsRef<Path>) -> Result<RgbImage> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_png_linear(&bytes, path, |_, _| Ok(()))
}

/// [`read_png_linear`] of a file's bytes; `path` names it in errors. `check_size` is given
/// the width and height from the header, before any pixel is decoded, and may refuse them.
pub fn decode_png_linear(
    bytes: &[u8],
    path: &Path,
    check_size: impl FnOnce(usize, usize) -> Result<()>,
) -> Result<RgbImage> {
    let not_png =
        |e: image::ImageError| Error::invalid(path, format!("not a readable PNG image ({e})"));
    let reader =
        || image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
    let (width, height) = reader().into_dimensions().map_err(not_png)?;
    check_size(width as usize, height as usize)?;
    let decoded = reader().decode().map_err(not_png)?;
    let (width, height) = (decoded.width() as usize, decoded.height() as usize);
    let pixels = match decoded {
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageRgb8(_)
        | DynamicImage::ImageRgba8(_) => {
            let table: Vec<f32> = (0..=255u8).map(|v| srgb_decode(v as f32 / 255.0)).collect();
            decoded
                .to_rgb8()
                .pixels()
                .map(|p| p.0.map(|v| table[v as usize]))
                .collect()
        }
        other => other
            .to_rgb32f()
            .pixels()
            .map(|p| p.0.map(srgb_decode))
            .collect(),
    };
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}

/// Writes a PNG (sRGB, clipped) or an EXR (linear, unclipped), as the extension says.
pub fn write_image(path: impl AsRef<Path>, image: &RgbImage) -> Result<()> {
    let path = path.as_ref();
    match format_of(path)? {
        Format::Png => write_png(path, image),
        Format::Exr => write_exr_rgb(path, image),
    }
}

/// Reads a painting of a scene's guide as linear RGB (PNG sRGB-decoded, EXR as is) and
/// checks that it is `resolution × resolution` pixels.
pub fn read_painting(path: impl AsRef<Path>, resolution: usize) -> Result<RgbImage> {
    let path = path.as_ref();
    // The name first: a file of no known format is not read at all.
    format_of(path)?;
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_painting(&bytes, path, resolution)
}

/// [`read_painting`] of a file's bytes; `path` names it in errors and its extension gives
/// the format. The size is checked from the header, before any pixel is decoded.
pub fn decode_painting(bytes: &[u8], path: &Path, resolution: usize) -> Result<RgbImage> {
    let check_size = |width: usize, height: usize| {
        if width == resolution && height == resolution {
            Ok(())
        } else {
            Err(Error::invalid(
                path,
                format!(
                    "the painting is {width} × {height} pixels but the scene's guide is \
                     {resolution} × {resolution}"
                ),
            ))
        }
    };
    match format_of(path)? {
        Format::Png => decode_png_linear(bytes, path, check_size),
        Format::Exr => decode_exr_rgb(bytes, path, check_size),
    }
}

enum Format {
    Png,
    Exr,
}

fn format_of(path: &Path) -> Result<Format> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if ext.eq_ignore_ascii_case("png") {
        Ok(Format::Png)
    } else if ext.eq_ignore_ascii_case("exr") {
        Ok(Format::Exr)
    } else {
        Err(Error::invalid(
            path,
            "unknown image format: the name must end in .png or .exr",
        ))
    }
}

fn check_consistent(path: &Path, image: &RgbImage) -> Result<()> {
    if image.pixels.len() != image.width * image.height || image.pixels.is_empty() {
        return Err(Error::invalid(
            path,
            format!(
                "cannot write an image of {} × {} with {} pixels",
                image.width,
                image.height,
                image.pixels.len()
            ),
        ));
    }
    Ok(())
}

fn dimensions_u32(path: &Path, image: &RgbImage) -> Result<(u32, u32)> {
    match (u32::try_from(image.width), u32::try_from(image.height)) {
        (Ok(w), Ok(h)) => Ok((w, h)),
        _ => Err(Error::invalid(path, "image too large for PNG")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_every_8_bit_value() {
        for v in 0..=255u8 {
            let linear = srgb_decode(v as f32 / 255.0);
            assert_eq!((srgb_encode(linear) * 255.0).round() as u8, v);
        }
        assert_eq!(srgb_encode(f32::NAN), 0.0);
        assert!((srgb_encode(7.0) - 1.0).abs() < 1e-6);
        assert!((srgb_decode(0.5) - 0.214_041_14).abs() < 1e-6);
    }

    #[test]
    fn png_round_trip_is_linear() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.PNG");
        let image = RgbImage {
            width: 3,
            height: 2,
            pixels: vec![
                [0.0, 0.5, 1.0],
                [0.214, 2.0, -1.0],
                [0.1; 3],
                [0.9; 3],
                [0.01; 3],
                [0.3; 3],
            ],
        };
        write_image(&path, &image).unwrap();
        let back = read_painting(&path, 3).unwrap_err().to_string();
        assert!(back.contains("3 × 2") && back.contains("x.PNG"), "{back}");
        let back = read_png_linear(&path).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        for (a, b) in image.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                let want = a[c].clamp(0.0, 1.0);
                assert!((b[c] - want).abs() <= 0.01 * want.max(0.05), "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn sixteen_bit_png_is_decoded() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("deep.png");
        let buffer = image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_pixel(
            2,
            2,
            image::Rgb([0, 32768, 65535]),
        );
        DynamicImage::ImageRgb16(buffer).save(&path).unwrap();
        let back = read_png_linear(&path).unwrap();
        assert_eq!(back.get(1, 1)[0], 0.0);
        assert!((back.get(1, 1)[1] - srgb_decode(32768.0 / 65535.0)).abs() < 1e-6);
        assert!((back.get(1, 1)[2] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn unknown_extension_and_junk_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let tiff = dir.path().join("x.tiff");
        let err = write_image(&tiff, &RgbImage::filled(1, 1, [0.0; 3]))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("x.tiff") && err.contains(".png or .exr"),
            "{err}"
        );
        let junk = dir.path().join("junk.png");
        std::fs::write(&junk, b"not a png").unwrap();
        let err = read_png_linear(&junk).unwrap_err().to_string();
        assert!(err.contains("junk.png") && err.contains("PNG"), "{err}");
    }
}
