//! Painted pixels become BRDF samples: ρ = L / (π cos θ_l) in the bins the geometry buffer
//! names (TABLE.md).

use super::gbuffer::GBuffer;
use super::image_files::read_painting;
use super::image_files::srgb_encode;
use crate::error::Result;
use crate::image_io::RgbImage;
use crate::solver::{BinChange, Bound, Bounds, Reading, SampleKey, SampleRejected, SparseTable};
use crate::table::DirIndex;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::path::Path;

/// Pixels whose cos θ_l or cos θ_v is below this (θ above about 84°) give no sample:
/// dividing by a small cos θ_l magnifies paint error (10× at the threshold, unboundedly
/// beyond), and near the silhouette one pixel spans a wide range of directions.
pub const MIN_COS: f64 = 0.1;

/// One BRDF sample from one painted pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Row-major pixel index in the guide image.
    pub pixel: u32,
    pub light_bin: DirIndex,
    pub view_bin: DirIndex,
    /// ρ in 1/sr, linear RGB, finite and ≥ 0.
    pub rho: [f64; 3],
    /// What each channel of `rho` says: the value, or a bound where LDR paint was clipped.
    pub bounds: Bounds,
    /// Half the 8-bit step of LDR paint at this pixel, in ln ρ ([`Reading::rounding`]); 0
    /// for HDR paint.
    pub rounding: f64,
}

impl Sample {
    /// What the sparse table keeps of it.
    pub fn reading(&self) -> Reading {
        Reading {
            rho: self.rho,
            bounds: self.bounds,
            rounding: self.rounding,
        }
    }
}

/// Half the rounding step of 8-bit sRGB paint at the linear value `linear` in (0, 1], in ln of
/// the value: half a code of the encoding, through the decoding's slope, over the value.
/// Dark pixels are known far more coarsely than bright ones (a half step is 2% of the value
/// at 0.03, 0.6% at 0.7).
pub fn eight_bit_log_half_step(linear: f64) -> f64 {
    let code = f64::from(srgb_encode(linear as f32));
    let slope = if code <= 0.04045 {
        1.0 / 12.92
    } else {
        2.4 / 1.055 * ((code + 0.055) / 1.055).powf(1.4)
    };
    0.5 / 255.0 * slope / linear
}

/// What a painting's pixel values can express.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PaintRange {
    /// Linear floats with no ceiling (EXR, the app's canvas): every value is exact.
    #[default]
    Hdr,
    /// [0, 1] after sRGB decoding (PNG): a channel at 1 was clipped and says only "at least
    /// this bright"; one at 0 says "darker than the first step of the 8-bit scale". A value
    /// above 1 cannot come from such a file: it is HDR paint laid over it, and exact.
    Ldr,
}

impl PaintRange {
    /// The name in session files: `hdr` or `ldr`.
    pub fn name(self) -> &'static str {
        match self {
            PaintRange::Hdr => "hdr",
            PaintRange::Ldr => "ldr",
        }
    }
}

impl std::str::FromStr for PaintRange {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "hdr" => Ok(PaintRange::Hdr),
            "ldr" => Ok(PaintRange::Ldr),
            other => Err(format!("'{other}' is not a paint range (hdr or ldr)")),
        }
    }
}

/// The linear value of half an 8-bit step above black: what a pixel stored as 0 may hide.
pub const LDR_BLACK_BOUND: f32 = 0.5 / 255.0 / 12.92;

impl PaintRange {
    /// The value and meaning of one channel of a pixel painted in this range.
    fn read(self, c: f32) -> (f32, Bound) {
        match self {
            PaintRange::Hdr => (c, Bound::Exact),
            PaintRange::Ldr if c == 1.0 => (c, Bound::AtLeast),
            PaintRange::Ldr if c > 1.0 => (c, Bound::Exact),
            PaintRange::Ldr if c <= 0.0 => (LDR_BLACK_BOUND, Bound::AtMost),
            PaintRange::Ldr => (c, Bound::Exact),
        }
    }
}

/// Why a pixel gives no sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SkipReason {
    /// Off the object.
    Background,
    /// The light does not reach it: a cast shadow, or the normal faces away from the light.
    Shadow,
    /// cos θ_l or cos θ_v below [`MIN_COS`] (including a normal turned away from the camera).
    Grazing,
    /// A usable pixel whose paint is NaN, infinite or negative.
    Invalid,
}

/// How many pixels gave a sample and how many were skipped, by reason. The five add up to
/// the number of pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleCounts {
    pub used: usize,
    pub background: usize,
    pub shadow: usize,
    pub grazing: usize,
    pub invalid: usize,
}

impl SampleCounts {
    /// Counts one pixel's outcome.
    pub fn add(&mut self, outcome: &std::result::Result<Sample, SkipReason>) {
        match outcome {
            Ok(_) => self.used += 1,
            Err(SkipReason::Background) => self.background += 1,
            Err(SkipReason::Shadow) => self.shadow += 1,
            Err(SkipReason::Grazing) => self.grazing += 1,
            Err(SkipReason::Invalid) => self.invalid += 1,
        }
    }

    fn merge(mut self, other: Self) -> Self {
        self.used += other.used;
        self.background += other.background;
        self.shadow += other.shadow;
        self.grazing += other.grazing;
        self.invalid += other.invalid;
        self
    }

    /// All pixels looked at.
    pub fn total(&self) -> usize {
        self.used + self.background + self.shadow + self.grazing + self.invalid
    }
}

/// The samples of a painting, in pixel order, and the counts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SampleSet {
    pub samples: Vec<Sample>,
    pub counts: SampleCounts,
}

impl SampleSet {
    /// Sets every sample in `table` as view `view`'s, keyed by its pixel; the bins that
    /// change are appended to `changes`. Stops at the first sample the table refuses and
    /// names its pixel.
    pub fn insert_into(
        &self,
        view: u32,
        table: &mut SparseTable,
        changes: &mut Vec<BinChange>,
    ) -> Result<(), (u32, SampleRejected)> {
        for s in &self.samples {
            let key = SampleKey {
                view,
                pixel: s.pixel,
            };
            table
                .set_reading(key, s.light_bin, s.view_bin, s.reading(), changes)
                .map_err(|e| (s.pixel, e))?;
        }
        Ok(())
    }
}

/// The sample one painted pixel gives, or why it gives none. `radiance` is linear RGB.
/// The geometry is judged first (background, shadow, grazing), the paint last, so that paint
/// outside the usable area is never counted as invalid. An index outside the image is
/// background.
pub fn sample_pixel(
    gbuffer: &GBuffer,
    pixel: usize,
    radiance: [f32; 3],
) -> Result<Sample, SkipReason> {
    sample_pixel_in(gbuffer, pixel, radiance, PaintRange::Hdr)
}

/// [`sample_pixel`] for paint of the given range.
pub fn sample_pixel_in(
    gbuffer: &GBuffer,
    pixel: usize,
    radiance: [f32; 3],
    range: PaintRange,
) -> Result<Sample, SkipReason> {
    let point = gbuffer.at(pixel).ok_or(SkipReason::Background)?;
    if !point.is_lit() {
        return Err(SkipReason::Shadow);
    }
    let cos_light = point.cos_light() as f64;
    let (Some(light_bin), Some(view_bin)) = (point.light_bin, point.view_bin) else {
        return Err(SkipReason::Grazing);
    };
    if cos_light < MIN_COS || (point.cos_view() as f64) < MIN_COS {
        return Err(SkipReason::Grazing);
    }
    if radiance.iter().any(|c| !c.is_finite() || *c < 0.0) {
        return Err(SkipReason::Invalid);
    }
    let scale = 1.0 / (PI * cos_light);
    let read = radiance.map(|c| range.read(c));
    Ok(Sample {
        pixel: pixel as u32,
        light_bin,
        view_bin,
        rho: read.map(|(c, _)| c as f64 * scale),
        bounds: read.map(|(_, b)| b),
        rounding: match range {
            PaintRange::Hdr => 0.0,
            PaintRange::Ldr => eight_bit_rounding(read),
        },
    })
}

/// The rounding of an 8-bit pixel's reading (`read`, each channel's value and bound), in
/// ln ρ: its brightest exact channel's half step, the one known most finely, which bounds
/// what the whole pixel says within rounding. 0 where no channel is an 8-bit value: values
/// above 1 are HDR paint laid over the file, and exact; bounds are not values.
fn eight_bit_rounding(read: [(f32, Bound); 3]) -> f64 {
    let least = read
        .iter()
        .filter(|(c, b)| *b == Bound::Exact && *c > 0.0 && *c <= 1.0)
        .map(|&(c, _)| eight_bit_log_half_step(f64::from(c)))
        .fold(f64::INFINITY, f64::min);
    if least.is_finite() { least } else { 0.0 }
}

/// The samples of a whole painting (linear RGB), rows in parallel.
///
/// # Panics
/// When the image is not the geometry buffer's size; [`samples_from_file`] checks that and
/// says so instead.
pub fn samples_from_image(gbuffer: &GBuffer, image: &RgbImage) -> SampleSet {
    samples_from_image_in(gbuffer, image, PaintRange::Hdr)
}

/// [`samples_from_image`] for paint of the given range.
pub fn samples_from_image_in(gbuffer: &GBuffer, image: &RgbImage, range: PaintRange) -> SampleSet {
    let n = gbuffer.resolution();
    assert!(
        image.width == n && image.height == n && image.pixels.len() == n * n,
        "painting of {} × {} for a {n} × {n} scene",
        image.width,
        image.height
    );
    if n == 0 {
        return SampleSet::default();
    }
    let rows: Vec<(Vec<Sample>, SampleCounts)> = image
        .pixels
        .par_chunks(n)
        .enumerate()
        .map(|(y, row)| {
            let mut samples = Vec::new();
            let mut counts = SampleCounts::default();
            for (x, &radiance) in row.iter().enumerate() {
                let outcome = sample_pixel_in(gbuffer, y * n + x, radiance, range);
                counts.add(&outcome);
                if let Ok(sample) = outcome {
                    samples.push(sample);
                }
            }
            (samples, counts)
        })
        .collect();
    let mut set = SampleSet {
        samples: Vec::with_capacity(rows.iter().map(|(s, _)| s.len()).sum()),
        counts: SampleCounts::default(),
    };
    for (samples, counts) in rows {
        set.samples.extend(samples);
        set.counts = set.counts.merge(counts);
    }
    set
}

/// Reads a painting (PNG: sRGB-decoded, LDR; EXR: linear, HDR) and turns it into samples; an
/// image of the wrong size is an error naming the file and both sizes.
pub fn samples_from_file(gbuffer: &GBuffer, path: impl AsRef<Path>) -> Result<SampleSet> {
    let path = path.as_ref();
    let image = read_painting(path, gbuffer.resolution())?;
    Ok(samples_from_image_in(gbuffer, &image, paint_range_of(path)))
}

/// The range a painting file can hold, by its extension: PNG is LDR, anything else HDR.
pub fn paint_range_of(path: &Path) -> PaintRange {
    let png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if png {
        PaintRange::Ldr
    } else {
        PaintRange::Hdr
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_8_bit_channel_at_its_top_or_bottom_is_a_bound_and_hdr_paint_over_it_is_exact() {
        let ldr = PaintRange::Ldr;
        assert_eq!(ldr.read(1.0), (1.0, Bound::AtLeast));
        assert_eq!(ldr.read(0.0), (LDR_BLACK_BOUND, Bound::AtMost));
        assert_eq!(ldr.read(0.5), (0.5, Bound::Exact));
        // Above 1 no 8-bit file can go: paint laid over the import in the app.
        assert_eq!(ldr.read(2.5), (2.5, Bound::Exact));
        for c in [0.0, 0.5, 1.0, 2.5] {
            assert_eq!(PaintRange::Hdr.read(c), (c, Bound::Exact));
        }
        // A white 8-bit pixel decodes to exactly 1, so it is the bound, not a value.
        assert_eq!(crate::scene::srgb_decode(1.0), 1.0);
    }

    /// Half a step is half the gap between neighbouring 8-bit codes, relative to the value:
    /// coarse for dark paint, fine for bright. A pixel's rounding is its brightest 8-bit
    /// value's; HDR paint over the file and bounds have none.
    #[test]
    fn an_8_bit_value_is_known_to_half_its_step_and_hdr_paint_exactly() {
        for code in [3u8, 20, 60, 128, 200, 254] {
            let at = |c: f64| f64::from(crate::scene::srgb_decode((c / 255.0) as f32));
            let value = at(f64::from(code));
            let gap = (at(f64::from(code) + 0.5) - at(f64::from(code) - 0.5)) / value;
            let half = eight_bit_log_half_step(value);
            assert!(
                (half - 0.5 * gap).abs() < 0.02 * half,
                "{code}: {half} {gap}"
            );
        }
        assert!(eight_bit_log_half_step(0.03) > 3.0 * eight_bit_log_half_step(0.7));

        let ldr = PaintRange::Ldr;
        let read = [0.03, 0.7, 0.2].map(|c| ldr.read(c));
        let half_step = |c: f32| eight_bit_log_half_step(f64::from(c));
        assert_eq!(eight_bit_rounding(read), half_step(0.7));
        // A clipped channel is a bound, and paint above 1 is exact HDR paint.
        let read = [1.0, 0.03, 2.5].map(|c| ldr.read(c));
        assert_eq!(eight_bit_rounding(read), half_step(0.03));
        let read = [1.0, 0.0, 2.5].map(|c| ldr.read(c));
        assert_eq!(eight_bit_rounding(read), 0.0);
    }

    #[test]
    fn paint_ranges_are_named_as_session_files_write_them() {
        for range in [PaintRange::Hdr, PaintRange::Ldr] {
            assert_eq!(range.name().parse::<PaintRange>(), Ok(range));
        }
        assert!(
            "12-bit"
                .parse::<PaintRange>()
                .unwrap_err()
                .contains("12-bit")
        );
    }
}
