//! The MERL isotropic BRDF binary of TABLE.md, as read by the MERL reference reader
//! (BRDFRead.cpp), pbrt-v2's `measured` material and Disney's BRDF Explorer.

use super::{DirIndex, PHI_BINS, SymTable, THETA_BINS, direction_index, phi_index};
use crate::brdf::Brdf;
use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::io::Write;
use std::path::Path;

/// θ_h bins (non-linear: uniform in sqrt(θ_h)).
pub const THETA_H_RES: usize = 90;
/// θ_d bins over [0, π/2].
pub const THETA_D_RES: usize = 90;
/// φ_d bins over [0, π) (reciprocity folds φ_d + π onto φ_d).
pub const PHI_D_RES: usize = 180;
/// Entries per colour channel.
pub const MERL_ENTRIES: usize = THETA_H_RES * THETA_D_RES * PHI_D_RES;
/// The dimensions in the file header, in file order.
pub const MERL_DIMS: [i32; 3] = [THETA_H_RES as i32, THETA_D_RES as i32, PHI_D_RES as i32];
/// What a reader multiplies the stored R, G, B values by to get ρ in 1/sr.
pub const MERL_SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];
/// The stored value of a bin whose centre has the light or the view below the horizon.
pub const BELOW_HORIZON: f64 = -1.0;
/// Half-vector azimuths that [`MerlBrdf::from_fn`] averages over (a power of two, so that
/// the pairwise mean of equal values is exact).
pub const HALF_AZIMUTHS: usize = 16;

const HEADER_BYTES: usize = 12;
const FILE_BYTES: usize = HEADER_BYTES + 8 * 3 * MERL_ENTRIES;

/// Half-vector / difference-vector angles (Rusinkiewicz), as in the MERL reference reader.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfDiff {
    pub theta_h: f64,
    pub phi_h: f64,
    pub theta_d: f64,
    pub phi_d: f64,
}

/// Rodrigues rotation of `v` by `angle` about the unit `axis`, as `rotate_vector` in BRDFRead.cpp.
fn rotate_vector(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (sin, cos) = angle.sin_cos();
    v * cos + axis * (axis.dot(v) * (1.0 - cos)) + axis.cross(v) * sin
}

/// The half/difference angles of light `l` (the reader's incident direction) and view `v`:
/// the difference vector is `l` rotated by −φ_h about z, then by −θ_h about y.
pub fn half_diff(l: DVec3, v: DVec3) -> HalfDiff {
    let l = l.normalize();
    let v = v.normalize();
    let h = (l + v).normalize();
    let theta_h = h.z.clamp(-1.0, 1.0).acos();
    let phi_h = h.y.atan2(h.x);
    let temp = rotate_vector(l, DVec3::Z, -phi_h);
    let diff = rotate_vector(temp, DVec3::Y, -theta_h);
    HalfDiff {
        theta_h,
        phi_h,
        theta_d: diff.z.clamp(-1.0, 1.0).acos(),
        phi_d: diff.y.atan2(diff.x),
    }
}

/// Light and view for φ_h = 0: the difference vector and its mirror image about the half
/// vector, rotated by θ_h about y. Their z does not depend on φ_h.
fn half_frame_pair(theta_h: f64, theta_d: f64, phi_d: f64) -> (DVec3, DVec3) {
    let (sd, cd) = theta_d.sin_cos();
    let (sp, cp) = phi_d.sin_cos();
    let (sh, ch) = theta_h.sin_cos();
    let rot_y = |x: f64, y: f64, z: f64| DVec3::new(x * ch + z * sh, y, z * ch - x * sh);
    (rot_y(sd * cp, sd * sp, cd), rot_y(-sd * cp, -sd * sp, cd))
}

/// Rotation about z that leaves z untouched bit for bit.
fn rotate_z(w: DVec3, phi: f64) -> DVec3 {
    let (s, c) = phi.sin_cos();
    DVec3::new(w.x * c - w.y * s, w.x * s + w.y * c, w.z)
}

/// The (light, view) pair of half/difference angles; inverse of [`half_diff`].
pub fn directions_from_half_diff(hd: HalfDiff) -> (DVec3, DVec3) {
    let (l, v) = half_frame_pair(hd.theta_h, hd.theta_d, hd.phi_d);
    (rotate_z(l, hd.phi_h), rotate_z(v, hd.phi_h))
}

/// floor(x) clamped to [0, n − 1]; NaN gives 0.
fn clamped_bin(x: f64, n: usize) -> usize {
    let f = x.floor();
    if f >= 0.0 { (f as usize).min(n - 1) } else { 0 }
}

/// The entry index of TABLE.md: i_φd + 180 · i_θd + 180 · 90 · i_θh.
pub fn merl_index(theta_h: f64, theta_d: f64, phi_d: f64) -> usize {
    let i_theta_h = clamped_bin(
        (theta_h / FRAC_PI_2).sqrt() * THETA_H_RES as f64,
        THETA_H_RES,
    );
    let i_theta_d = clamped_bin(theta_d / FRAC_PI_2 * THETA_D_RES as f64, THETA_D_RES);
    let phi_d = if phi_d < 0.0 { phi_d + PI } else { phi_d };
    let i_phi_d = clamped_bin(phi_d / PI * PHI_D_RES as f64, PHI_D_RES);
    i_phi_d + PHI_D_RES * i_theta_d + PHI_D_RES * THETA_D_RES * i_theta_h
}

/// (θ_h, θ_d, φ_d) at the centre of entry `index`.
pub fn bin_centre_angles(index: usize) -> (f64, f64, f64) {
    let i_phi_d = index % PHI_D_RES;
    let i_theta_d = (index / PHI_D_RES) % THETA_D_RES;
    let i_theta_h = index / (PHI_D_RES * THETA_D_RES);
    let u = (i_theta_h as f64 + 0.5) / THETA_H_RES as f64;
    (
        u * u * FRAC_PI_2,
        (i_theta_d as f64 + 0.5) / THETA_D_RES as f64 * FRAC_PI_2,
        (i_phi_d as f64 + 0.5) / PHI_D_RES as f64 * PI,
    )
}

/// Pairwise mean of `HALF_AZIMUTHS` samples: exact when they are all equal.
fn pairwise_mean(mut s: [[f64; 3]; HALF_AZIMUTHS]) -> [f64; 3] {
    let mut n = HALF_AZIMUTHS;
    while n > 1 {
        n /= 2;
        for i in 0..n {
            s[i] = std::array::from_fn(|c| s[2 * i][c] + s[2 * i + 1][c]);
        }
    }
    s[0].map(|x| x / HALF_AZIMUTHS as f64)
}

/// A BRDF in the MERL layout: stored values ρ / scale, R plane, then G, then B.
#[derive(Clone, PartialEq)]
pub struct MerlBrdf {
    values: Vec<f64>,
}

impl std::fmt::Debug for MerlBrdf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MerlBrdf")
            .field("entries", &MERL_ENTRIES)
            .finish()
    }
}

impl MerlBrdf {
    /// Reads a MERL binary; the dimensions must be 90, 90, 180 and the length exact.
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        use std::io::Read;
        let path = path.as_ref();
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        // A file of the wrong length is refused from its header and length alone: a huge
        // file is never read.
        let wanted = if len == FILE_BYTES as u64 {
            FILE_BYTES
        } else {
            HEADER_BYTES
        };
        let mut bytes = Vec::with_capacity(wanted);
        file.take(wanted as u64)
            .read_to_end(&mut bytes)
            .map_err(|e| Error::io(path, e))?;
        Self::parse(&bytes, len, path)
    }

    /// [`MerlBrdf::read`] of a file's bytes; `path` names it in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        Self::parse(bytes, bytes.len() as u64, path)
    }

    /// `bytes`: the file's first bytes (all of it when it is no longer than a MERL file);
    /// `len`: its length.
    fn parse(bytes: &[u8], len: u64, path: &Path) -> Result<Self> {
        if bytes.len() < HEADER_BYTES {
            return Err(Error::invalid(
                path,
                format!("{len} bytes is too short for a MERL BRDF header"),
            ));
        }
        let dims: [i32; 3] =
            std::array::from_fn(|i| i32::from_le_bytes(std::array::from_fn(|b| bytes[4 * i + b])));
        if dims != MERL_DIMS {
            return Err(Error::invalid(
                path,
                format!(
                    "MERL dimensions are {} × {} × {}, expected 90 × 90 × 180",
                    dims[0], dims[1], dims[2]
                ),
            ));
        }
        if len != FILE_BYTES as u64 || bytes.len() != FILE_BYTES {
            let why = if len > FILE_BYTES as u64 {
                "trailing data"
            } else {
                "truncated"
            };
            return Err(Error::invalid(
                path,
                format!("MERL file is {len} bytes, expected {FILE_BYTES} ({why})"),
            ));
        }
        let values = bytes[HEADER_BYTES..]
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(std::array::from_fn(|i| b[i])))
            .collect();
        Ok(Self { values })
    }

    /// Writes the MERL binary, little-endian, atomically.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        write_atomically(path.as_ref(), |w| {
            for d in MERL_DIMS {
                w.write_all(&d.to_le_bytes())?;
            }
            let mut buf = Vec::with_capacity(8 * 8192);
            for chunk in self.values.chunks(8192) {
                buf.clear();
                for v in chunk {
                    buf.extend_from_slice(&v.to_le_bytes());
                }
                w.write_all(&buf)?;
            }
            Ok(())
        })
    }

    /// Evaluates `f(l, v)` at the centre of every entry, averaged over [`HALF_AZIMUTHS`]
    /// evenly spaced half-vector azimuths (an anisotropic BRDF is averaged over φ_h).
    /// Entries whose light or view lies below the horizon store [`BELOW_HORIZON`];
    /// a negative or non-finite mean is stored as 0 so that only those entries are negative.
    pub fn from_fn(f: impl Fn(DVec3, DVec3) -> [f64; 3] + Sync) -> Self {
        let per_entry: Vec<[f64; 3]> = (0..MERL_ENTRIES)
            .into_par_iter()
            .with_min_len(PHI_D_RES)
            .map(|index| {
                let (theta_h, theta_d, phi_d) = bin_centre_angles(index);
                let (l0, v0) = half_frame_pair(theta_h, theta_d, phi_d);
                if l0.z <= 0.0 || v0.z <= 0.0 {
                    return [BELOW_HORIZON; 3];
                }
                let samples = std::array::from_fn(|k| {
                    let phi_h = (k as f64 + 0.5) * TAU / HALF_AZIMUTHS as f64;
                    f(rotate_z(l0, phi_h), rotate_z(v0, phi_h))
                });
                let mean = pairwise_mean(samples);
                std::array::from_fn(|c| {
                    let rho = mean[c];
                    if rho.is_finite() && rho > 0.0 {
                        rho / MERL_SCALE[c]
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        let mut values = vec![0.0; 3 * MERL_ENTRIES];
        for (c, plane) in values.chunks_exact_mut(MERL_ENTRIES).enumerate() {
            for (out, entry) in plane.iter_mut().zip(&per_entry) {
                *out = entry[c];
            }
        }
        Self { values }
    }

    /// Resamples a table: each evaluation takes the table bin nearest to l and v.
    pub fn from_table(table: &SymTable) -> Self {
        // Directions on or just under the horizon fall back to the last polar bin.
        let bin = |w: DVec3| {
            direction_index(w).unwrap_or_else(|| {
                (PHI_BINS * (THETA_BINS - 1) + phi_index(w.y.atan2(w.x))) as DirIndex
            })
        };
        Self::from_fn(|l, v| table.get(bin(l), bin(v)).map(f64::from))
    }

    /// The stored value (ρ / scale, negative below the horizon) of `channel` at `index`.
    pub fn get(&self, channel: usize, index: usize) -> f64 {
        assert!(
            channel < 3 && index < MERL_ENTRIES,
            "MERL entry ({channel}, {index})"
        );
        self.values[channel * MERL_ENTRIES + index]
    }

    /// ρ at entry `index`; entries below the horizon read as 0.
    pub fn rho(&self, index: usize) -> [f64; 3] {
        std::array::from_fn(|c| {
            let stored = self.get(c, index);
            if stored.is_finite() && stored > 0.0 {
                stored * MERL_SCALE[c]
            } else {
                0.0
            }
        })
    }
}

impl Brdf for MerlBrdf {
    /// The reference reader's lookup: the entry holding the half/difference angles of (l, v).
    /// Directions below the horizon give 0.
    fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
        if !(l.z > 0.0 && v.z > 0.0) {
            return [0.0; 3];
        }
        let hd = half_diff(l, v);
        self.rho(merl_index(hd.theta_h, hd.theta_d, hd.phi_d))
    }

    fn is_isotropic(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_1_PI;

    fn dir(theta_deg: f64, phi_deg: f64) -> DVec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        let (sp, cp) = phi_deg.to_radians().sin_cos();
        DVec3::new(st * cp, st * sp, ct)
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs())
    }

    /// An isotropic analytic BRDF: Lambert + Schlick-Fresnel Blinn–Phong + a term in
    /// cos θ_l cos θ_v, so that its value depends on θ_h, θ_d and φ_d.
    #[derive(Debug)]
    struct Analytic;

    const KD: [f64; 3] = [0.6, 0.3, 0.1];
    const KS: [f64; 3] = [0.5, 0.7, 0.9];
    const EXPONENT: i32 = 20;
    const KQ: [f64; 3] = [0.2, 0.05, 0.3];

    /// The value from cos θ_h, cos θ_d and cos θ_l · cos θ_v.
    fn analytic(cos_h: f64, cos_d: f64, lz_vz: f64) -> [f64; 3] {
        let n = EXPONENT as f64;
        let fresnel = 0.04 + 0.96 * (1.0 - cos_d).powi(5);
        let lobe = (n + 2.0) / (2.0 * PI) * cos_h.powi(EXPONENT) * fresnel;
        std::array::from_fn(|c| KD[c] * FRAC_1_PI + KS[c] * lobe + KQ[c] * lz_vz)
    }

    /// The analytic value at half/difference angles, computed without building l and v:
    /// cos θ_l cos θ_v = cos²θ_d cos²θ_h − sin²θ_d cos²φ_d sin²θ_h.
    fn analytic_at_angles(theta_h: f64, theta_d: f64, phi_d: f64) -> [f64; 3] {
        let (sh, ch) = theta_h.sin_cos();
        let (sd, cd) = theta_d.sin_cos();
        let cp = phi_d.cos();
        analytic(ch, cd, cd * cd * ch * ch - sd * sd * cp * cp * sh * sh)
    }

    impl Brdf for Analytic {
        fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
            let h = (l + v).normalize();
            analytic(h.z, l.dot(h), l.z * v.z)
        }
        fn is_isotropic(&self) -> bool {
            true
        }
    }

    #[test]
    fn index_follows_table_md() {
        assert_eq!(merl_index(0.0, 0.0, 0.0), 0);
        assert_eq!(merl_index(FRAC_PI_2, FRAC_PI_2, PI), MERL_ENTRIES - 1);
        assert_eq!(merl_index(-0.1, -0.1, -1e-12), 179);
        // φ_d < 0 is folded by adding π.
        assert_eq!(
            merl_index(0.3, 0.4, -PI / 2.0),
            merl_index(0.3, 0.4, PI / 2.0)
        );
        // θ_h is uniform in its square root: θ_h = (k/90)²·π/2 starts bin k.
        let th = (30.2f64 / 90.0).powi(2) * FRAC_PI_2;
        assert_eq!(merl_index(th, 0.0, 0.0), 30 * 180 * 90);
        assert_eq!(merl_index(0.0, 45.5f64.to_radians(), 0.0), 45 * 180);
        assert_eq!(merl_index(0.0, 0.0, 100.5f64.to_radians()), 100);
        for index in [0, 1, 180, 16200, 777_777, MERL_ENTRIES - 1] {
            let (a, b, c) = bin_centre_angles(index);
            assert_eq!(merl_index(a, b, c), index);
        }
    }

    #[test]
    fn half_diff_and_directions_invert_each_other() {
        for &(tl, pl, tv, pv) in &[
            (10.0, 20.0, 50.0, 200.0),
            (70.0, 300.0, 30.0, 10.0),
            (45.0, 90.0, 45.0, 100.0),
            (85.0, 5.0, 80.0, 170.0),
            (3.0, 0.0, 60.0, 359.0),
        ] {
            let (l, v) = (dir(tl, pl), dir(tv, pv));
            let hd = half_diff(l, v);
            let (l2, v2) = directions_from_half_diff(hd);
            assert!(l.distance(l2) < 1e-12 && v.distance(v2) < 1e-12, "{hd:?}");
            // The half vector's polar angle matches its definition.
            assert!(close(hd.theta_h.cos(), (l + v).normalize().z, 1e-12));
            assert!(close(hd.theta_d.cos(), l.dot((l + v).normalize()), 1e-12));
        }
        for &(th, ph, td, pd) in &[
            (0.3, 1.0, 0.5, 2.0),
            (1.2, -2.5, 0.2, -0.7),
            (0.05, 3.0, 1.0, 0.1),
        ] {
            let hd = HalfDiff {
                theta_h: th,
                phi_h: ph,
                theta_d: td,
                phi_d: pd,
            };
            let (l, v) = directions_from_half_diff(hd);
            let back = half_diff(l, v);
            for (a, b) in [
                (back.theta_h, th),
                (back.phi_h, ph),
                (back.theta_d, td),
                (back.phi_d, pd),
            ] {
                assert!((a - b).abs() < 1e-12, "{back:?} vs {hd:?}");
            }
        }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("brdf.binary");
        let merl = MerlBrdf::from_fn(|l, v| Analytic.eval(l, v));
        merl.write(&path).unwrap();

        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len(), 12 + 8 * 3 * 1_458_000);
        let header: Vec<u8> = [90i32, 90, 180]
            .iter()
            .flat_map(|d| d.to_le_bytes())
            .collect();
        assert_eq!(&bytes[..12], &header[..]);
        assert_eq!(&bytes[12..20], &merl.get(0, 0).to_le_bytes());
        let last = 12 + 8 * (3 * MERL_ENTRIES - 1);
        assert_eq!(&bytes[last..], &merl.get(2, MERL_ENTRIES - 1).to_le_bytes());

        let back = MerlBrdf::read(&path).unwrap();
        let bits = |m: &MerlBrdf| m.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&merl));
        let copy = dir.path().join("copy.binary");
        back.write(&copy).unwrap();
        assert_eq!(std::fs::read(&copy).unwrap(), bytes);
    }

    /// An anisotropic BRDF is averaged over evenly spaced half-vector azimuths: terms in
    /// cos φ_h and cos 2φ_h average out, whatever the entry.
    #[test]
    fn anisotropy_averages_out_over_the_half_vector_azimuth() {
        let merl = MerlBrdf::from_fn(|l, v| {
            let h = (l + v).normalize();
            let phi_h = h.y.atan2(h.x);
            [1.0 + 0.5 * (2.0 * phi_h).cos() + 0.25 * phi_h.cos(); 3].map(|x| x / PI)
        });
        for index in [0, 181, 16_200 + 37, 777_777, 1_000_001] {
            let rho = merl.rho(index);
            assert!(close(rho[0], 1.0 / PI, 1e-12), "{index}: {rho:?}");
        }
        let debug = format!("{merl:?}");
        assert!(
            debug.contains("MerlBrdf") && debug.contains("1458000"),
            "{debug}"
        );
        assert!(merl.is_isotropic());
        // On or below the horizon, the lookup gives nothing.
        let up = DVec3::Z;
        for below in [DVec3::X, DVec3::new(0.6, 0.0, -0.8)] {
            assert_eq!(merl.eval(below, up), [0.0; 3]);
            assert_eq!(merl.eval(up, below), [0.0; 3]);
        }
        // A negative or non-finite value is stored as 0, so that only entries below the
        // horizon are negative.
        let odd = MerlBrdf::from_fn(|_, _| [-1.0, f64::NAN, 0.5]);
        assert_eq!(odd.get(0, 0), 0.0);
        assert_eq!(odd.get(1, 0), 0.0);
        assert!(close(odd.rho(0)[2], 0.5, 1e-15));
    }

    #[test]
    fn lambertian_is_exact_above_the_horizon() {
        let a = [0.8, 0.5, 0.2];
        let rho = a.map(|x| x / PI);
        let merl = MerlBrdf::from_fn(|_, _| rho);
        let mut below = 0;
        for index in 0..MERL_ENTRIES {
            let (th, td, pd) = bin_centre_angles(index);
            let (l, v) = directions_from_half_diff(HalfDiff {
                theta_h: th,
                phi_h: 0.0,
                theta_d: td,
                phi_d: pd,
            });
            for c in 0..3 {
                let stored = merl.get(c, index);
                if l.z > 0.0 && v.z > 0.0 {
                    assert_eq!(stored, rho[c] / MERL_SCALE[c], "{index} {c}");
                } else {
                    assert_eq!(stored, BELOW_HORIZON);
                    below += 1;
                }
            }
        }
        assert!(below > 0);
        // The scales TABLE.md fixes, which outside readers multiply by: R 1/1500, G 1.15/1500,
        // B 1.66/1500.
        let stored = merl.get(0, 0);
        assert!(close(stored * (1.0 / 1500.0), rho[0], 1e-15), "{stored}");
        let stored = [1, 2].map(|c| merl.get(c, 0));
        assert!(
            close(stored[0] * 1.15 / 1500.0, rho[1], 1e-15),
            "{stored:?}"
        );
        assert!(
            close(stored[1] * 1.66 / 1500.0, rho[2], 1e-15),
            "{stored:?}"
        );
        for &(tl, pl, tv, pv) in &[
            (0.0, 0.0, 0.0, 0.0),
            (30.0, 10.0, 50.0, 250.0),
            (60.0, 0.0, 5.0, 90.0),
        ] {
            let got = merl.eval(dir(tl, pl), dir(tv, pv));
            for c in 0..3 {
                assert!(close(got[c], rho[c], 1e-15), "{got:?}");
            }
        }
    }

    #[test]
    fn analytic_brdf_at_known_angles() {
        let dir_ = tempfile::tempdir().unwrap();
        let path = dir_.path().join("analytic.binary");
        MerlBrdf::from_fn(|l, v| Analytic.eval(l, v))
            .write(&path)
            .unwrap();
        let merl = MerlBrdf::read(&path).unwrap();

        // Entries by (i_θh, i_θd, i_φd), from the specular peak out to grazing.
        for &(ih, id, ip) in &[
            (0, 0, 0),
            (5, 2, 90),
            (10, 45, 90),
            (45, 30, 17),
            (70, 10, 170),
            (89, 0, 0),
            (30, 70, 5),
        ] {
            let index = ip + 180 * id + 180 * 90 * ih;
            let th = ((ih as f64 + 0.5) / 90.0).powi(2) * FRAC_PI_2;
            let td = (id as f64 + 0.5) / 90.0 * FRAC_PI_2;
            let pd = (ip as f64 + 0.5) / 180.0 * PI;
            let want = analytic_at_angles(th, td, pd);
            for c in 0..3 {
                let got = merl.get(c, index) * MERL_SCALE[c];
                assert!(
                    close(got, want[c], 1e-12),
                    "({ih}, {id}, {ip}) {c}: {got} vs {}",
                    want[c]
                );
            }
        }
        // Light and view both near grazing on opposite sides: below the horizon.
        let index = 179 + 180 * 89 + 180 * 90 * 89;
        assert_eq!(merl.get(1, index), BELOW_HORIZON);
        assert_eq!(merl.rho(index), [0.0; 3]);

        // The standard reader's lookup gives the analytic value at the entry's centre.
        for &(tl, pl, tv, pv) in &[
            (20.0, 0.0, 20.0, 180.0),
            (35.0, 40.0, 10.0, 300.0),
            (50.0, 120.0, 45.0, 310.0),
            (75.0, 200.0, 30.0, 90.0),
            (5.0, 17.0, 65.0, 23.0),
        ] {
            let (l, v) = (dir(tl, pl), dir(tv, pv));
            let hd = half_diff(l, v);
            let (th, td, pd) = bin_centre_angles(merl_index(hd.theta_h, hd.theta_d, hd.phi_d));
            let want = analytic_at_angles(th, td, pd);
            let got = merl.eval(l, v);
            let swapped = merl.eval(v, l);
            for c in 0..3 {
                assert!(
                    close(got[c], want[c], 1e-12),
                    "{tl} {pl} {tv} {pv}: {got:?} vs {want:?}"
                );
                assert!(close(swapped[c], want[c], 1e-12), "reciprocity {swapped:?}");
            }
        }
    }

    #[test]
    fn from_table_matches_the_analytic_brdf_away_from_grazing() {
        #[derive(Debug)]
        struct Smooth;
        impl Brdf for Smooth {
            fn eval(&self, l: DVec3, v: DVec3) -> [f64; 3] {
                let h = (l + v).normalize();
                let lobe = 6.0 / (2.0 * PI) * h.z.powi(4);
                [
                    0.5 * FRAC_1_PI + lobe,
                    0.2 * FRAC_1_PI + 0.5 * lobe,
                    0.1 + 0.2 * l.z * v.z,
                ]
            }
            fn is_isotropic(&self) -> bool {
                true
            }
        }
        // The table at the bins' centres, as `materials::tabulate` makes it (without
        // importing the materials, which depend on this module).
        let table = SymTable::from_fn(|lo, hi| {
            Smooth
                .eval(crate::table::bin_centre(lo), crate::table::bin_centre(hi))
                .map(|c| c as f32)
        });
        let merl = MerlBrdf::from_table(&table);
        let (mut worst, mut sum, mut count) = (0.0f64, 0.0, 0);
        for index in (0..MERL_ENTRIES).step_by(7) {
            let (th, td, pd) = bin_centre_angles(index);
            let (l, v) = half_frame_pair(th, td, pd);
            // Away from grazing: both within 60° of the normal.
            if l.z < 0.5 || v.z < 0.5 {
                continue;
            }
            let want = Smooth.eval(l, v);
            let got = merl.rho(index);
            for c in 0..3 {
                let e = (got[c] - want[c]).abs() / want[c];
                worst = worst.max(e);
                sum += e;
                count += 1;
            }
        }
        let mean = sum / count as f64;
        // The nearest 2° × 10° table bin moves l and v by up to ~4.5° within 60° of the
        // normal, which changes this lobe by up to ~6.5% (measured: 6.4% worst, 0.5% mean).
        assert!(worst < 0.08, "worst relative error {worst}");
        assert!(mean < 0.01, "mean relative error {mean}");
        assert!(worst > 0.0);
    }

    #[test]
    fn bad_files_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("good.binary");
        MerlBrdf::from_fn(|_, _| [0.1; 3]).write(&good).unwrap();
        let bytes = std::fs::read(&good).unwrap();

        let missing = dir.path().join("missing.binary");
        let err = MerlBrdf::read(&missing).unwrap_err().to_string();
        assert!(err.contains("missing.binary"), "{err}");

        let dims = dir.path().join("dims.binary");
        let mut wrong = bytes.clone();
        wrong[8..12].copy_from_slice(&360i32.to_le_bytes());
        std::fs::write(&dims, &wrong).unwrap();
        let err = MerlBrdf::read(&dims).unwrap_err().to_string();
        assert!(
            err.contains("dims.binary") && err.contains("90 × 90 × 360"),
            "{err}"
        );

        let cut = dir.path().join("cut.binary");
        std::fs::write(&cut, &bytes[..bytes.len() - 8]).unwrap();
        let err = MerlBrdf::read(&cut).unwrap_err().to_string();
        assert!(
            err.contains("cut.binary") && err.contains("truncated"),
            "{err}"
        );

        let long = dir.path().join("long.binary");
        let mut extra = bytes.clone();
        extra.push(0);
        std::fs::write(&long, &extra).unwrap();
        let err = MerlBrdf::read(&long).unwrap_err().to_string();
        assert!(
            err.contains("long.binary") && err.contains("trailing data"),
            "{err}"
        );

        let stub = dir.path().join("stub.binary");
        std::fs::write(&stub, &bytes[..7]).unwrap();
        let err = MerlBrdf::read(&stub).unwrap_err().to_string();
        assert!(err.contains("stub.binary"), "{err}");
    }
}
