//! The on-disk basis cache: one memory-mapped file per spec, checksummed, never trusted blind.

use super::Basis;
use super::build::{BasisSpec, BuildProgress, build_basis};
use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Bump when the file layout changes.
pub const FORMAT_VERSION: u32 = 3;
const MAGIC: &[u8; 8] = b"BURNBSIS";
const HEADER_LEN: usize = 256;
const KEY_OFFSET: usize = 64;
const MAX_KEY_LEN: usize = HEADER_LEN - KEY_OFFSET;

/// Where a basis came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheOutcome {
    /// Memory-mapped from a valid cache file.
    Loaded,
    /// No cache file existed, or a rebuild was asked for; built and stored.
    Built,
    /// A cache file existed but was stale, truncated or corrupt; rebuilt and replaced.
    Rebuilt { reason: String },
    /// Built and used from memory only: the cache could not be written (a read-only or full
    /// folder), so the next start builds it again. `reason` names the folder and the problem.
    NotStored { reason: String },
}

/// The folder that holds cached bases.
#[derive(Clone, Debug)]
pub struct BasisCache {
    dir: PathBuf,
}

impl BasisCache {
    /// `$BURNISH_CACHE_DIR` if set, else the user's cache folder (e.g. ~/.cache/burnish).
    pub fn default_location() -> Result<Self> {
        if let Some(dir) = std::env::var_os("BURNISH_CACHE_DIR") {
            return Ok(Self::at(PathBuf::from(dir)));
        }
        let dirs = directories::ProjectDirs::from("", "", "burnish").ok_or_else(|| {
            Error::invalid(Path::new("~"), "no home folder to put the basis cache in")
        })?;
        Ok(Self::at(dirs.cache_dir().to_path_buf()))
    }

    pub fn at(dir: PathBuf) -> Self {
        Self { dir }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The cache file for `spec`: named by a hash of every input that shapes the basis.
    pub fn path_for(&self, spec: &BasisSpec) -> PathBuf {
        let key = full_key(spec);
        self.dir.join(format!(
            "basis-k{}-{:016x}.bin",
            spec.components,
            fnv1a(key.as_bytes())
        ))
    }

    /// Loads the cached basis for `spec`. `Ok(None)` when there is no file;
    /// `Err` (naming the file and the problem) when it exists but can't be trusted.
    pub fn load(&self, spec: &BasisSpec) -> Result<Option<Basis>> {
        let path = self.path_for(spec);
        let file = match std::fs::File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(Error::io(&path, e)),
        };
        // SAFETY: the cache file is ours; it is written atomically (rename) and never modified
        // in place, so the mapping sees one complete file. Its contents are checksummed below.
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(|e| Error::io(&path, e))?;
        parse(&path, map, &full_key(spec)).map(Some)
    }

    /// Writes `basis` as the cache file of `spec`, atomically.
    pub fn store(&self, spec: &BasisSpec, basis: &Basis) -> Result<()> {
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        let path = self.path_for(spec);
        let key = full_key(spec);
        let variances: &[u8] = bytemuck::cast_slice(basis.variances());
        let data: &[u8] = bytemuck::cast_slice(basis.raw());
        let mut crc = crc32fast::Hasher::new();
        crc.update(&basis.residual_variance().to_le_bytes());
        crc.update(variances);
        crc.update(data);
        let mut header = [0u8; HEADER_LEN];
        header[..8].copy_from_slice(MAGIC);
        header[8..12].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
        header[12..16].copy_from_slice(&(basis.components() as u32).to_le_bytes());
        header[16..20].copy_from_slice(&(basis.observations() as u32).to_le_bytes());
        header[20..24].copy_from_slice(&(key.len() as u32).to_le_bytes());
        header[24..32].copy_from_slice(&((variances.len() + data.len()) as u64).to_le_bytes());
        header[32..36].copy_from_slice(&crc.finalize().to_le_bytes());
        header[40..48].copy_from_slice(&basis.residual_variance().to_le_bytes());
        header[KEY_OFFSET..KEY_OFFSET + key.len()].copy_from_slice(key.as_bytes());
        write_atomically(&path, |w| {
            w.write_all(&header)?;
            w.write_all(variances)?;
            w.write_all(data)
        })
    }

    /// The basis for `spec`: from the cache when it is valid, else built (with progress)
    /// and stored. A stale, truncated or corrupt file is rebuilt, never trusted. When the
    /// basis can't be stored, it is still returned, with [`CacheOutcome::NotStored`].
    pub fn load_or_build(
        &self,
        spec: &BasisSpec,
        rebuild: bool,
        progress: &(dyn Fn(BuildProgress) + Sync),
    ) -> Result<(Arc<Basis>, CacheOutcome)> {
        let outcome = if rebuild {
            CacheOutcome::Built
        } else {
            match self.load(spec) {
                Ok(Some(basis)) => return Ok((Arc::new(basis), CacheOutcome::Loaded)),
                Ok(None) => CacheOutcome::Built,
                Err(e) => CacheOutcome::Rebuilt {
                    reason: e.to_string(),
                },
            }
        };
        let basis = build_basis(spec, progress);
        let outcome = match self.store(spec, &basis) {
            Ok(()) => outcome,
            Err(e) => CacheOutcome::NotStored {
                reason: e.to_string(),
            },
        };
        Ok((Arc::new(basis), outcome))
    }
}

fn full_key(spec: &BasisSpec) -> String {
    let key = format!("format={FORMAT_VERSION};{}", spec.key());
    assert!(key.len() <= MAX_KEY_LEN);
    key
}

/// 64-bit FNV-1a: a stable hash for file names (the full key inside the file guards collisions).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

fn parse(path: &Path, map: memmap2::Mmap, expected_key: &str) -> Result<Basis> {
    let bad = |problem: String| Error::invalid(path, problem);
    if map.len() < HEADER_LEN {
        return Err(bad(format!(
            "basis cache truncated: {} bytes, header needs {HEADER_LEN}",
            map.len()
        )));
    }
    let u32_at = |o: usize| u32::from_le_bytes(map[o..o + 4].try_into().unwrap());
    if &map[..8] != MAGIC {
        return Err(bad("not a Burnish basis cache (bad magic)".into()));
    }
    let format = u32_at(8);
    if format != FORMAT_VERSION {
        return Err(bad(format!(
            "stale basis cache: format {format}, expected {FORMAT_VERSION}"
        )));
    }
    let components = u32_at(12) as usize;
    let observations = u32_at(16) as usize;
    let key_len = u32_at(20) as usize;
    let payload_len = u64::from_le_bytes(map[24..32].try_into().unwrap()) as usize;
    let crc_expected = u32_at(32);
    let residual_variance = f64::from_le_bytes(map[40..48].try_into().unwrap());
    if key_len > MAX_KEY_LEN || &map[KEY_OFFSET..KEY_OFFSET + key_len] != expected_key.as_bytes() {
        return Err(bad("stale basis cache: built from other inputs".into()));
    }
    if components == 0 || components > BasisSpec::MAX_COMPONENTS {
        return Err(bad(format!("corrupt basis cache: {components} components")));
    }
    let expected_payload = 8 * components + 4 * Basis::stored_len(components);
    if payload_len != expected_payload || map.len() != HEADER_LEN + expected_payload {
        return Err(bad(format!(
            "truncated or corrupt basis cache: {} bytes, expected {}",
            map.len(),
            HEADER_LEN + expected_payload
        )));
    }
    let payload = &map[HEADER_LEN..];
    let mut crc = crc32fast::Hasher::new();
    crc.update(&map[40..48]);
    crc.update(payload);
    if crc.finalize() != crc_expected {
        return Err(bad("corrupt basis cache: checksum mismatch".into()));
    }
    let variances: Vec<f64> = payload[..8 * components]
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect();
    if variances.iter().any(|v| !v.is_finite() || *v < 0.0)
        || !(residual_variance > 0.0 && residual_variance.is_finite())
    {
        return Err(bad("corrupt basis cache: invalid variances".into()));
    }
    let offset = HEADER_LEN + 8 * components;
    Ok(Basis::from_mapped(
        components,
        observations,
        variances,
        residual_variance,
        map,
        offset,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::build::{SMALL_TEST_SPEC, small_test_basis};

    fn stored() -> (tempfile::TempDir, BasisCache) {
        let dir = tempfile::tempdir().unwrap();
        let cache = BasisCache::at(dir.path().join("bases"));
        cache.store(&SMALL_TEST_SPEC, &small_test_basis()).unwrap();
        (dir, cache)
    }

    fn load_error(cache: &BasisCache, spec: &BasisSpec) -> String {
        match cache.load(spec) {
            Err(e) => e.to_string(),
            Ok(b) => panic!("expected an error, got a basis: {}", b.is_some()),
        }
    }

    /// The published FNV-1a 64 test vectors: file names must not change between builds.
    #[test]
    fn the_file_name_hash_is_fnv1a() {
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn a_stored_basis_loads_back_bit_for_bit() {
        let (_dir, cache) = stored();
        let built = small_test_basis();
        let path = cache.path_for(&SMALL_TEST_SPEC);
        assert_eq!(path.parent(), Some(cache.dir()));
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with("basis-k4-") && name.ends_with(".bin"),
            "{name}"
        );
        let loaded = cache
            .load(&SMALL_TEST_SPEC)
            .unwrap()
            .expect("the stored file");
        assert_eq!(loaded.components(), built.components());
        assert_eq!(loaded.observations(), built.observations());
        assert_eq!(loaded.variances(), built.variances());
        assert_eq!(
            loaded.residual_variance().to_bits(),
            built.residual_variance().to_bits()
        );
        assert!(
            loaded
                .raw()
                .iter()
                .zip(built.raw())
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert_eq!(loaded.raw().len(), built.raw().len());
        // The header holds the full key, so the file says what built it.
        let bytes = std::fs::read(&path).unwrap();
        let key = full_key(&SMALL_TEST_SPEC);
        assert!(key.contains(&SMALL_TEST_SPEC.key()), "{key}");
        assert_eq!(&bytes[KEY_OFFSET..KEY_OFFSET + key.len()], key.as_bytes());
    }

    #[test]
    fn no_file_is_none_and_an_unreadable_one_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let cache = BasisCache::at(dir.path().to_path_buf());
        assert!(cache.load(&SMALL_TEST_SPEC).unwrap().is_none());
        // A cache "folder" that is a file: opening inside it fails, and not as "not found".
        let file = dir.path().join("not-a-folder");
        std::fs::write(&file, b"x").unwrap();
        let cache = BasisCache::at(file);
        let error = load_error(&cache, &SMALL_TEST_SPEC);
        let path = cache.path_for(&SMALL_TEST_SPEC);
        assert!(error.contains(&path.display().to_string()), "{error}");
    }

    /// Every input of the spec names a file of its own, and a file of another spec at this
    /// spec's path is refused.
    #[test]
    fn specs_differing_in_any_input_neither_share_nor_accept_a_file() {
        let (_dir, cache) = stored();
        let base = SMALL_TEST_SPEC;
        let mut seed = base;
        seed.database.seed += 1;
        let mut size = base;
        size.database.size += 1;
        let others = [
            seed,
            size,
            BasisSpec {
                oversampling: base.oversampling + 1,
                ..base
            },
            BasisSpec {
                power_iterations: base.power_iterations + 1,
                ..base
            },
        ];
        let path = cache.path_for(&base);
        for other in others {
            assert_ne!(cache.path_for(&other), path, "{other:?}");
            assert!(cache.load(&other).unwrap().is_none(), "{other:?}");
            std::fs::copy(&path, cache.path_for(&other)).unwrap();
            let error = load_error(&cache, &other);
            assert!(error.contains("stale"), "{other:?}: {error}");
            std::fs::remove_file(cache.path_for(&other)).unwrap();
        }
    }

    /// Damaged headers are errors that name the file and the problem, never a panic or an
    /// out-of-bounds read.
    #[test]
    fn a_damaged_header_is_an_error_not_a_panic() {
        let (_dir, cache) = stored();
        let path = cache.path_for(&SMALL_TEST_SPEC);
        let pristine = std::fs::read(&path).unwrap();
        type Damage = fn(&mut Vec<u8>);
        let damages: [(&str, Damage, &str); 9] = [
            ("short", |b| b.truncate(100), "header needs 256"),
            (
                "header only",
                |b| b.truncate(HEADER_LEN),
                "truncated or corrupt",
            ),
            ("magic", |b| b[0] = b'X', "bad magic"),
            ("format", |b| b[8] += 1, "stale basis cache: format"),
            (
                "key length",
                |b| b[20..24].copy_from_slice(&u32::MAX.to_le_bytes()),
                "built from other inputs",
            ),
            (
                // Longer than a key may be, in a file too short to hold it.
                "key length past the header",
                |b| {
                    b[20..24].copy_from_slice(&250u32.to_le_bytes());
                    b.truncate(300);
                },
                "built from other inputs",
            ),
            (
                "components",
                |b| b[12..16].copy_from_slice(&0u32.to_le_bytes()),
                "0 components",
            ),
            (
                "too many components",
                |b| b[12..16].copy_from_slice(&101u32.to_le_bytes()),
                "101 components",
            ),
            (
                // As many as a basis may have, but not what the payload holds.
                "most components",
                |b| b[12..16].copy_from_slice(&100u32.to_le_bytes()),
                "truncated or corrupt",
            ),
        ];
        for (what, damage, expected) in damages {
            let mut bytes = pristine.clone();
            damage(&mut bytes);
            std::fs::write(&path, &bytes).unwrap();
            let error = load_error(&cache, &SMALL_TEST_SPEC);
            assert!(error.contains(expected), "{what}: {error}");
            assert!(
                error.contains(&path.display().to_string()),
                "{what}: {error}"
            );
        }
        // The header-only file says how long the file should be.
        let mut bytes = pristine.clone();
        bytes.truncate(HEADER_LEN);
        std::fs::write(&path, &bytes).unwrap();
        let error = load_error(&cache, &SMALL_TEST_SPEC);
        assert!(
            error.contains(&format!("expected {}", pristine.len())),
            "{error}"
        );
    }

    /// A file whose checksum holds but whose variances cannot be a basis's (written by
    /// something else, or by a bug) is refused; a zero variance is a basis's.
    #[test]
    fn invalid_variances_are_refused_even_under_a_good_checksum() {
        let (_dir, cache) = stored();
        let path = cache.path_for(&SMALL_TEST_SPEC);
        let pristine = std::fs::read(&path).unwrap();
        let rewrite = |variance: Option<f64>, residual: Option<f64>| {
            let mut bytes = pristine.clone();
            if let Some(v) = variance {
                // The last component's variance.
                let at = HEADER_LEN + 8 * (SMALL_TEST_SPEC.components - 1);
                bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
            }
            if let Some(r) = residual {
                bytes[40..48].copy_from_slice(&r.to_le_bytes());
            }
            let mut crc = crc32fast::Hasher::new();
            crc.update(&bytes[40..48]);
            crc.update(&bytes[HEADER_LEN..]);
            bytes[32..36].copy_from_slice(&crc.finalize().to_le_bytes());
            std::fs::write(&path, &bytes).unwrap();
        };
        let bad = [
            (Some(f64::NAN), None),
            (Some(f64::INFINITY), None),
            (Some(-1e-9), None),
            (None, Some(0.0)),
            (None, Some(-0.5)),
            (None, Some(f64::INFINITY)),
            (None, Some(f64::NAN)),
        ];
        for (variance, residual) in bad {
            rewrite(variance, residual);
            let error = load_error(&cache, &SMALL_TEST_SPEC);
            assert!(
                error.contains("invalid variances"),
                "{variance:?} {residual:?}: {error}"
            );
        }
        rewrite(Some(0.0), Some(0.25));
        let loaded = cache.load(&SMALL_TEST_SPEC).unwrap().unwrap();
        assert_eq!(loaded.variances()[SMALL_TEST_SPEC.components - 1], 0.0);
        assert_eq!(loaded.residual_variance(), 0.25);
    }
}
