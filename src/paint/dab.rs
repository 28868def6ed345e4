//! Brush dabs: one stamp of the brush, rasterised by tiny-skia into an 8-bit mask over the
//! dab's bounding box (a round dab with a radial falloff, or a tip image scaled to size).

use super::changes::PixelRect;
use crate::error::{Error, Result};
use std::path::Path;
use tiny_skia::{
    Color, FillRule, FilterQuality, GradientStop, Paint, PathBuilder, Pixmap, PixmapPaint, Point,
    RadialGradient, Shader, SpreadMode, Transform,
};

/// Tip images larger than this on a side are refused: a tip is scaled to the brush size, so
/// more detail than this is never seen and would only slow every dab.
pub const MAX_TIP_SIDE: u32 = 1024;

/// How many gradient segments approximate the smooth falloff of a soft dab.
const FALLOFF_STOPS: usize = 12;

/// A brush tip: a greyscale image used as the dab's mask (white paints fully, black not at
/// all), scaled so that its longer side spans the brush diameter.
#[derive(Clone, Debug, PartialEq)]
pub struct TipMask {
    /// Premultiplied white with the tip value as alpha, ready for tiny-skia to draw.
    pixmap: Pixmap,
}

impl TipMask {
    /// A tip from row-major grey values (0 = no paint, 255 = full paint). `None` when the
    /// size is zero, too large or does not match `values`.
    pub fn from_grey(width: u32, height: u32, values: &[u8]) -> Option<Self> {
        if width == 0 || height == 0 || width > MAX_TIP_SIDE || height > MAX_TIP_SIDE {
            return None;
        }
        if values.len() != width as usize * height as usize {
            return None;
        }
        let mut pixmap = Pixmap::new(width, height)?;
        for (dst, &v) in pixmap.data_mut().chunks_exact_mut(4).zip(values) {
            dst.copy_from_slice(&[v; 4]);
        }
        Some(Self { pixmap })
    }

    /// Reads a PNG tip. Colour images are reduced to luminance; transparency multiplies in, so
    /// a transparent pixel never paints. A tip with no paint at all is refused.
    pub fn load_png(path: &Path) -> Result<Self> {
        // A 16-bit RGBA PNG of the largest tip, stored, with room for its chunks.
        let limit = 8 * (MAX_TIP_SIDE as u64 + 1) * MAX_TIP_SIDE as u64 + (1 << 20);
        let bytes = crate::bounded_read::read_at_most(path, limit, "a brush tip PNG")?;
        Self::from_png(&bytes, path)
    }

    /// [`TipMask::load_png`] of a file's bytes; `path` names it in errors.
    pub fn from_png(bytes: &[u8], path: &Path) -> Result<Self> {
        let not_png =
            |e: image::ImageError| Error::invalid(path, format!("not a readable PNG image: {e}"));
        let reader = || {
            image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png)
        };
        // The size from the header first: a huge tip is refused before it is decoded.
        let (width, height) = reader().into_dimensions().map_err(not_png)?;
        if width > MAX_TIP_SIDE || height > MAX_TIP_SIDE {
            return Err(Error::invalid(
                path,
                format!("tip is {width}×{height}; at most {MAX_TIP_SIDE} pixels a side"),
            ));
        }
        let image = reader().decode().map_err(not_png)?.to_luma_alpha8();
        let (width, height) = image.dimensions();
        let values: Vec<u8> = image
            .pixels()
            .map(|p| ((u16::from(p[0]) * u16::from(p[1]) + 127) / 255) as u8)
            .collect();
        if values.iter().all(|&v| v == 0) {
            return Err(Error::invalid(
                path,
                "tip is black (or transparent) everywhere, so it would paint nothing",
            ));
        }
        Self::from_grey(width, height, &values)
            .ok_or_else(|| Error::invalid(path, "tip image has no pixels"))
    }

    pub fn width(&self) -> u32 {
        self.pixmap.width()
    }

    pub fn height(&self) -> u32 {
        self.pixmap.height()
    }

    /// The tip's value at column `x`, row `y`, in [0, 1].
    pub fn value(&self, x: u32, y: u32) -> f32 {
        self.pixmap
            .pixel(x, y)
            .map_or(0.0, |p| f32::from(p.alpha()) / 255.0)
    }
}

/// A rasterised dab: mask values in [0, 1] over `rect` (row-major), already clipped to the
/// canvas.
pub(crate) struct DabMask {
    pub rect: PixelRect,
    pub values: Vec<f32>,
}

impl DabMask {
    #[inline]
    pub fn at(&self, x: u32, y: u32) -> f32 {
        let i =
            (y - self.rect.y0) as usize * self.rect.width() as usize + (x - self.rect.x0) as usize;
        self.values[i]
    }
}

/// The shape of a dab: a round one of the given hardness, or a tip image.
#[derive(Clone, Copy)]
pub(crate) enum DabShape<'a> {
    Round { hardness: f32 },
    Tip(&'a TipMask),
}

/// Rasterises a dab of `diameter` centred on (`cx`, `cy`) (canvas pixels; pixel (i, j)
/// covers [i, i+1) × [j, j+1)) onto a `width` × `height` canvas. `None` when it misses the
/// canvas entirely or paints nothing.
pub(crate) fn rasterise(
    cx: f32,
    cy: f32,
    diameter: f32,
    shape: DabShape,
    width: u32,
    height: u32,
) -> Option<DabMask> {
    let (half_w, half_h) = match shape {
        DabShape::Round { .. } => (diameter / 2.0, diameter / 2.0),
        DabShape::Tip(tip) => {
            let scale = diameter / tip.width().max(tip.height()) as f32;
            (
                tip.width() as f32 * scale / 2.0,
                tip.height() as f32 * scale / 2.0,
            )
        }
    };
    // One pixel of margin for antialiasing and bilinear filtering.
    let lo_x = (cx - half_w - 1.0).floor().max(0.0);
    let lo_y = (cy - half_h - 1.0).floor().max(0.0);
    let hi_x = (cx + half_w + 1.0).ceil().min(width as f32);
    let hi_y = (cy + half_h + 1.0).ceil().min(height as f32);
    if !(lo_x < hi_x && lo_y < hi_y) {
        return None;
    }
    let rect = PixelRect::new(lo_x as u32, lo_y as u32, hi_x as u32, hi_y as u32);
    let mut pixmap = Pixmap::new(rect.width(), rect.height())?;
    // The dab centre in the pixmap's own coordinates.
    let (px, py) = (cx - lo_x, cy - lo_y);
    match shape {
        DabShape::Round { hardness } => {
            let radius = diameter / 2.0;
            let path = PathBuilder::from_circle(px, py, radius)?;
            let paint = Paint {
                shader: round_falloff(px, py, radius, hardness),
                anti_alias: true,
                ..Paint::default()
            };
            pixmap.fill_path(
                &path,
                &paint,
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
        DabShape::Tip(tip) => {
            let scale = diameter / tip.width().max(tip.height()) as f32;
            let transform = Transform::from_row(scale, 0.0, 0.0, scale, px - half_w, py - half_h);
            let paint = PixmapPaint {
                quality: FilterQuality::Bilinear,
                ..PixmapPaint::default()
            };
            pixmap.draw_pixmap(0, 0, tip.pixmap.as_ref(), &paint, transform, None);
        }
    }
    let values: Vec<f32> = pixmap
        .pixels()
        .iter()
        .map(|p| f32::from(p.alpha()) / 255.0)
        .collect();
    if values.iter().all(|&v| v == 0.0) {
        return None;
    }
    Some(DabMask { rect, values })
}

/// The dab's alpha as a shader: opaque inside `hardness × radius`, then a smoothstep down to
/// nothing at the radius. Hardness 1 is a solid colour; the circle's antialiased edge is then
/// the only falloff (one pixel wide).
fn round_falloff(cx: f32, cy: f32, radius: f32, hardness: f32) -> Shader<'static> {
    let opaque = Color::WHITE;
    if hardness >= 1.0 {
        return Shader::SolidColor(opaque);
    }
    let mut stops = Vec::with_capacity(FALLOFF_STOPS + 2);
    stops.push(GradientStop::new(0.0, opaque));
    for i in 0..=FALLOFF_STOPS {
        let s = i as f32 / FALLOFF_STOPS as f32;
        let alpha = 1.0 - s * s * (3.0 - 2.0 * s);
        let mut colour = opaque;
        colour.set_alpha(alpha);
        stops.push(GradientStop::new(hardness + (1.0 - hardness) * s, colour));
    }
    let centre = Point::from_xy(cx, cy);
    RadialGradient::new(
        centre,
        0.0,
        centre,
        radius,
        stops,
        SpreadMode::Pad,
        Transform::identity(),
    )
    .unwrap_or(Shader::SolidColor(opaque))
}
