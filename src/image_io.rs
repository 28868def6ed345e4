//! Linear RGB float images in OpenEXR files: the BRDF table, guide images and paintings.

use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use exr::prelude::*;
use std::io::Cursor;
use std::path::Path;

/// A linear RGB image, row-major with (0, 0) at the top left.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// An image with every pixel set to `value`.
    pub fn filled(width: usize, height: usize, value: [f32; 3]) -> Self {
        Self {
            width,
            height,
            pixels: vec![value; width * height],
        }
    }

    /// The pixel at column `x`, row `y`.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> [f32; 3] {
        self.pixels[y * self.width + x]
    }
}

/// Uncompressed scan lines. Float BRDF values barely compress losslessly: for a 1620 × 1620
/// anisotropic table (2 cores) this writes 31.5 MB in 0.13 s, where RLE saves nothing and
/// ZIP16 (21.6 MB) and PIZ (23.4 MB) take over a second.
const ENCODING: Encoding = Encoding::UNCOMPRESSED;

/// How many times its compressed size an EXR's pixel data may be. Deflate (ZIP) tops out
/// near 1032 : 1; RLE, PIZ, PXR24, B44A and DWA of a flat image stay below this bound.
const MAX_EXR_EXPANSION: u64 = 4096;

/// Refuses a header that declares more pixel data than a file of `file_len` bytes can
/// hold. Checked before any pixel is decoded, so that a few bytes claiming a huge image
/// never allocate gigabytes.
pub(crate) fn check_exr_data_size(
    header: &exr::meta::header::Header,
    file_len: usize,
) -> std::result::Result<(), String> {
    let size = header.layer_size;
    let bytes_per_pixel = header.channels.bytes_per_pixel.max(1) as u64;
    let declared = (size.width() as u64)
        .checked_mul(size.height() as u64)
        .and_then(|pixels| pixels.checked_mul(bytes_per_pixel));
    let expansion = match header.compression {
        exr::compression::Compression::Uncompressed => 1,
        _ => MAX_EXR_EXPANSION,
    };
    match declared {
        Some(bytes) if bytes <= file_len as u64 * expansion => Ok(()),
        _ => Err(format!(
            "the header declares a {} × {} image, more pixel data than a file of {file_len} \
             bytes can hold (truncated or corrupt)",
            size.width(),
            size.height()
        )),
    }
}

/// Reads the R, G and B channels of the first layer that has all three, converting any
/// sample type to f32 and ignoring every other channel (alpha included).
pub fn read_exr_rgb(path: impl AsRef<Path>) -> Result<RgbImage> {
    let path = path.as_ref();
    // One read into memory: the file is parsed twice (header check, then pixels).
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_exr_rgb(&bytes, path, |_, _| Ok(()))
}

/// [`read_exr_rgb`] of a file's bytes; `path` names it in errors. `check_size` is given the
/// image's width and height from the header, before any pixel is decoded, and may refuse it.
pub fn decode_exr_rgb(
    bytes: &[u8],
    path: &Path,
    check_size: impl FnOnce(usize, usize) -> Result<()>,
) -> Result<RgbImage> {
    let not_exr = |e: exr::error::Error| match e {
        exr::error::Error::Io(io) if io.kind() != std::io::ErrorKind::UnexpectedEof => {
            Error::io(path, io)
        }
        other => Error::invalid(path, format!("not a readable OpenEXR file ({other})")),
    };

    let meta =
        exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(not_exr)?;
    let has_rgb = |h: &exr::meta::header::Header| {
        ["R", "G", "B"]
            .iter()
            .all(|name| h.channels.list.iter().any(|c| c.name == **name))
    };
    let Some(header) = meta.headers.iter().find(|h| has_rgb(h)) else {
        let found: Vec<String> = meta
            .headers
            .iter()
            .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
            .collect();
        return Err(Error::invalid(
            path,
            format!(
                "no layer has R, G and B channels (channels found: {})",
                found.join(", ")
            ),
        ));
    };
    check_size(header.layer_size.width(), header.layer_size.height())?;
    for header in &meta.headers {
        check_exr_data_size(header, bytes.len())
            .map_err(|problem| Error::invalid(path, problem))?;
    }

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size, _| RgbImage::filled(size.width(), size.height(), [0.0; 3]),
            |img: &mut RgbImage, pos, (r, g, b): (f32, f32, f32)| {
                let w = img.width;
                img.pixels[pos.y() * w + pos.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(not_exr)?;
    Ok(image.layer_data.channel_data.pixels)
}

/// Writes R, G and B as 32-bit float channels, atomically.
pub fn write_exr_rgb(path: impl AsRef<Path>, image: &RgbImage) -> Result<()> {
    let path = path.as_ref();
    if image.pixels.len() != image.width * image.height {
        return Err(Error::invalid(
            path,
            format!(
                "image of {} × {} has {} pixels",
                image.width,
                image.height,
                image.pixels.len()
            ),
        ));
    }
    write_exr_rgb_with(path, image.width, image.height, |x, y| image.get(x, y))
}

/// Writes a `width` × `height` RGB image whose pixel (x, y) is `pixel(x, y)`, atomically,
/// without first gathering it into an [`RgbImage`].
pub(crate) fn write_exr_rgb_with(
    path: &Path,
    width: usize,
    height: usize,
    pixel: impl Fn(usize, usize) -> [f32; 3] + Sync,
) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::invalid(
            path,
            format!("cannot write an empty {width} × {height} image"),
        ));
    }
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let [r, g, b] = pixel(pos.x(), pos.y());
        (r, g, b)
    });
    let image = Image::from_encoded_channels((width, height), ENCODING, channels);
    write_atomically(path, |w| {
        image.write().to_buffered(w).map_err(|e| match e {
            exr::error::Error::Io(io) => io,
            other => std::io::Error::other(other.to_string()),
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(width: usize, height: usize) -> RgbImage {
        let pixels = (0..width * height)
            .map(|i| {
                let i = i as f32;
                [i * 0.25, 1.0 / (i + 1.0), 1e30 - i * 1e24]
            })
            .collect();
        RgbImage {
            width,
            height,
            pixels,
        }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.exr");
        let img = sample(7, 5);
        write_exr_rgb(&path, &img).unwrap();
        let back = read_exr_rgb(&path).unwrap();
        assert_eq!((back.width, back.height), (7, 5));
        let bits = |im: &RgbImage| -> Vec<[u32; 3]> {
            im.pixels.iter().map(|p| p.map(f32::to_bits)).collect()
        };
        assert_eq!(bits(&back), bits(&img));
        // (0, 0) is the top-left pixel, rows run down.
        assert_eq!(back.get(1, 0), img.pixels[1]);
        assert_eq!(back.get(0, 1), img.pixels[7]);
    }

    #[test]
    fn half_float_and_alpha_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rgba16.exr");
        let channels = SpecificChannels::rgba(|pos: Vec2<usize>| {
            let v = f16::from_f32(pos.x() as f32 + 0.5);
            (
                v,
                f16::from_f32(2.0),
                f16::from_f32(-1.0),
                f16::from_f32(0.25),
            )
        });
        Image::from_channels((3, 2), channels)
            .write()
            .to_file(&path)
            .unwrap();
        let img = read_exr_rgb(&path).unwrap();
        assert_eq!(img.get(2, 1), [2.5, 2.0, -1.0]);
    }

    #[test]
    fn missing_channels_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("luma.exr");
        let channels = SpecificChannels::build()
            .with_channel("Y")
            .with_pixel_fn(|_: Vec2<usize>| (0.5f32,));
        Image::from_channels((4, 4), channels)
            .write()
            .to_file(&path)
            .unwrap();
        let err = read_exr_rgb(&path).unwrap_err().to_string();
        assert!(err.contains(&*path.to_string_lossy()), "{err}");
        assert!(err.contains("R, G and B") && err.contains("Y"), "{err}");
    }

    #[test]
    fn bad_files_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.exr");
        let junk = dir.path().join("junk.exr");
        std::fs::write(&junk, b"this is not an exr file at all").unwrap();
        let cut = dir.path().join("cut.exr");
        write_exr_rgb(&cut, &sample(64, 64)).unwrap();
        let bytes = std::fs::read(&cut).unwrap();
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        for path in [&missing, &junk, &cut] {
            let err = read_exr_rgb(path).unwrap_err().to_string();
            assert!(err.contains(&*path.to_string_lossy()), "{err}");
        }
    }

    #[test]
    fn inconsistent_image_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.exr");
        let img = RgbImage {
            width: 3,
            height: 3,
            pixels: vec![[0.0; 3]; 8],
        };
        let err = write_exr_rgb(&path, &img).unwrap_err().to_string();
        assert!(err.contains("bad.exr"), "{err}");
        assert!(!path.exists());
    }
}
