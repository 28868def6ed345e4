//! The table as an OpenEXR image (TABLE.md): 1620 wide (x = d_v) by 1620 high (y = d_l).

use super::{DIRECTIONS, DirIndex, SymTable};
use crate::error::{Error, Result};
use crate::image_io::{decode_exr_rgb, write_exr_rgb_with};
use std::path::Path;

/// Writes the full table, pixel (x, y) = ρ(d_l = y, d_v = x); symmetric bit for bit.
pub fn write_table_exr(path: impl AsRef<Path>, table: &SymTable) -> Result<()> {
    write_exr_rgb_with(path.as_ref(), DIRECTIONS, DIRECTIONS, |x, y| {
        table.get(y as DirIndex, x as DirIndex)
    })
}

/// Reads a table image. Every value must be finite and ≥ 0.
///
/// A table made elsewhere need not be reciprocal: each pair of entries (d_l, d_v) and
/// (d_v, d_l) is replaced by their mean (taken in f64), so that what Burnish holds is
/// reciprocal. A symmetric file, such as every one Burnish writes, reads back bit for bit.
pub fn read_table_exr(path: impl AsRef<Path>) -> Result<SymTable> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_table_exr(&bytes, path)
}

/// [`read_table_exr`] of a file's bytes; `path` names it in errors.
pub fn decode_table_exr(bytes: &[u8], path: &Path) -> Result<SymTable> {
    // The size is checked from the header, before any pixel is decoded.
    let image = decode_exr_rgb(bytes, path, |width, height| {
        if (width, height) == (DIRECTIONS, DIRECTIONS) {
            Ok(())
        } else {
            Err(Error::invalid(
                path,
                format!(
                    "a BRDF table must be {DIRECTIONS} × {DIRECTIONS} pixels, this image is \
                     {width} × {height}"
                ),
            ))
        }
    })?;
    if let Some(i) = image
        .pixels
        .iter()
        .position(|p| p.iter().any(|c| !c.is_finite() || *c < 0.0))
    {
        let (d_l, d_v) = (i / DIRECTIONS, i % DIRECTIONS);
        return Err(Error::invalid(
            path,
            format!(
                "value {:?} at d_l = {d_l}, d_v = {d_v} (pixel x = {d_v}, y = {d_l}) \
                 is not a finite, non-negative BRDF value",
                image.pixels[i]
            ),
        ));
    }
    Ok(SymTable::from_fn(|lo, hi| {
        let a = image.get(hi as usize, lo as usize);
        let b = image.get(lo as usize, hi as usize);
        // The mean of two equal f32 values is exact in f64, so symmetric files round-trip.
        std::array::from_fn(|c| ((a[c] as f64 + b[c] as f64) * 0.5) as f32)
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_io::{RgbImage, read_exr_rgb, write_exr_rgb};
    use crate::table::{PAIRS, PairIndex, pair_directions};

    /// A table whose pairs all differ, with values spread over many binades.
    fn varied_table() -> SymTable {
        let values = (0..PAIRS)
            .map(|pair| {
                let (lo, hi) = pair_directions(PairIndex::from_index(pair));
                let x = pair as f32;
                [
                    x * 1e-3,
                    (lo as f32 + 1.0) / (hi as f32 + 3.0),
                    1.0 / (x + 0.5),
                ]
            })
            .collect();
        SymTable::from_pairs(values).unwrap()
    }

    fn bits(t: &SymTable) -> Vec<[u32; 3]> {
        t.pairs().iter().map(|p| p.map(f32::to_bits)).collect()
    }

    #[test]
    fn round_trip_is_bit_exact_and_symmetric() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("table.exr");
        let table = varied_table();
        write_table_exr(&path, &table).unwrap();

        let back = read_table_exr(&path).unwrap();
        assert_eq!(bits(&back), bits(&table));

        let raw = read_exr_rgb(&path).unwrap();
        assert_eq!((raw.width, raw.height), (DIRECTIONS, DIRECTIONS));
        for y in 0..DIRECTIONS {
            for x in 0..y {
                assert_eq!(
                    raw.get(x, y).map(f32::to_bits),
                    raw.get(y, x).map(f32::to_bits)
                );
            }
        }
        // x is the view bin, y the light bin.
        let (d_l, d_v) = (700, 12);
        assert_eq!(
            raw.get(d_v, d_l),
            table.get(d_l as DirIndex, d_v as DirIndex)
        );
    }

    #[test]
    fn asymmetric_input_is_averaged() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("outside.exr");
        let mut img = RgbImage::filled(DIRECTIONS, DIRECTIONS, [0.5, 0.25, 1.0]);
        let (d_l, d_v) = (3usize, 1000usize);
        img.pixels[d_l * DIRECTIONS + d_v] = [1.0, 0.1, 0.0];
        img.pixels[d_v * DIRECTIONS + d_l] = [2.0, 0.2, 3.0];
        write_exr_rgb(&path, &img).unwrap();
        let table = read_table_exr(&path).unwrap();
        let mean = |a: f32, b: f32| ((a as f64 + b as f64) / 2.0) as f32;
        let want = [mean(1.0, 2.0), mean(0.1, 0.2), mean(0.0, 3.0)];
        assert_eq!(table.get(d_l as DirIndex, d_v as DirIndex), want);
        assert_eq!(table.get(d_v as DirIndex, d_l as DirIndex), want);
        assert_eq!(table.get(0, 1), [0.5, 0.25, 1.0]);
    }

    #[test]
    fn wrong_size_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("small.exr");
        write_exr_rgb(&path, &RgbImage::filled(1620, 1619, [0.1; 3])).unwrap();
        let err = read_table_exr(&path).unwrap_err().to_string();
        assert!(err.contains(&*path.to_string_lossy()), "{err}");
        assert!(err.contains("1620 × 1619"), "{err}");
    }

    #[test]
    fn unphysical_values_are_located() {
        let dir = tempfile::tempdir().unwrap();
        for (name, bad) in [
            ("nan.exr", f32::NAN),
            ("inf.exr", f32::INFINITY),
            ("neg.exr", -0.5),
        ] {
            let path = dir.path().join(name);
            let mut img = RgbImage::filled(DIRECTIONS, DIRECTIONS, [0.1; 3]);
            img.pixels[17 * DIRECTIONS + 1234][1] = bad;
            write_exr_rgb(&path, &img).unwrap();
            let err = read_table_exr(&path).unwrap_err().to_string();
            assert!(err.contains(&*path.to_string_lossy()), "{err}");
            assert!(err.contains("d_l = 17, d_v = 1234"), "{err}");
        }
    }

    #[test]
    fn bad_files_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("good.exr");
        write_table_exr(&good, &SymTable::filled([0.2, 0.3, 0.4])).unwrap();
        let bytes = std::fs::read(&good).unwrap();

        let corrupt = dir.path().join("corrupt.exr");
        let mut garbled = bytes.clone();
        // Overwrite the header (magic number, version, attributes).
        for b in &mut garbled[..64] {
            *b ^= 0x5a;
        }
        std::fs::write(&corrupt, &garbled).unwrap();

        let truncated = dir.path().join("truncated.exr");
        std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).unwrap();

        let missing = dir.path().join("missing.exr");
        for path in [&corrupt, &truncated, &missing] {
            let err = read_table_exr(path).unwrap_err().to_string();
            assert!(err.contains(&*path.to_string_lossy()), "{err}");
        }
    }
}
