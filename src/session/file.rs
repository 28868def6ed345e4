//! The `.burnish` file: a zip archive with these entries (views numbered from 1):
//!
//! - `session.toml`: `format_version`, `active_view` (from 0), an optional `session_path`
//!   (recovery files only: the user's own file), `[brush]`, `[basis]` and one `[[views]]`
//!   table per view with its `name`, `muted` flag, `base_dir` (the folder its scene's
//!   relative object path resolves against) and `unpainted` (`count` or `ignore`: what its
//!   unpainted pixels say; files written before it existed meant `ignore`) and `paint_range`
//!   (`hdr`, or `ldr` for paint imported from an 8-bit file, whose clipped channels are
//!   bounds; files written before it existed meant `hdr`).
//! - `views/N/scene.toml`: the view's scene, a SCENE.md file; its `object` is kept as given.
//! - `views/N/colour.exr`: the colour layer, R, G and B as 32-bit floats (linear, HDR).
//! - `views/N/coverage.exr`: the coverage layer, one 32-bit float channel `Y`.
//! - `views/N/base.exr` (optional): what the canvas shows under the paint when it is a
//!   prediction of the BRDF rather than the scene's guide, as `colour.exr`. Unpainted pixels
//!   that count as shown state it, so it is kept to give the same samples on opening.
//! - `start/table.exr` (optional, with a `[start]` table in the manifest holding its `name`
//!   and the `source` file it was opened from): the material the painting starts from, as
//!   TABLE.md's EXR table image, stored uncompressed. The whole table rather than its
//!   coefficients, so that a session reopened with another basis projects it afresh; its own
//!   copy rather than only the source path, so that the session opens without that file.
//!   Files without it start from the database's mean material.
//! - `views/N/object.obj`: for a scene with an .obj object, a copy of that file's bytes, so
//!   the session opens on a machine without the original. On opening, the original path is
//!   used where it holds these very bytes; otherwise the copy is extracted to
//!   [`object_cache_dir`]`/<hash>/<file name>` and the scene's `object` becomes that path.

use super::{
    BasisSettings, Session, SessionView, StartMaterial, ViewSettings, check_colour, check_coverage,
};
use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use crate::image_io::RgbImage;
use crate::paint::{BrushSettings, PaintLayers, UnpaintedPixels};
use crate::scene::{ObjectSource, PaintRange, Scene};
use crate::table::{DIRECTIONS, DirIndex, SymTable};
use exr::prelude::*;
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufReader, Cursor, Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use zip::ZipArchive;
use zip::write::{SimpleFileOptions, ZipWriter};

/// The file name extension of session files.
pub const EXTENSION: &str = "burnish";

/// The `format_version` this build writes and reads. A file from a newer version is refused
/// with a message saying so, never misread.
pub const FORMAT_VERSION: u32 = 1;

const MANIFEST: &str = "session.toml";

/// Entries are deflated at the fastest level: painted float layers barely compress, while
/// the background and the unpainted coverage (zeros) compress well even at level 1.
const DEFLATE_LEVEL: i64 = 1;

/// The most bytes a manifest or scene entry may inflate to; a real one is a few kilobytes.
const TEXT_LIMIT: u64 = 16 << 20;
/// The most bytes an embedded .obj may inflate to.
const OBJECT_LIMIT: u64 = 4 << 30;
/// The most bytes reserved for an entry before it is read: its recorded size is only a
/// claim, and a few bytes of archive must not allocate gigabytes. Larger entries grow as
/// their bytes actually arrive.
const PREALLOCATION_LIMIT: u64 = 64 << 20;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    format_version: u32,
    active_view: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    session_path: Option<String>,
    brush: BrushSettings,
    basis: BasisManifest,
    /// Absent when the painting starts from the database's mean material.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    start: Option<StartManifest>,
    views: Vec<ViewManifest>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StartManifest {
    name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    source: Option<String>,
}

/// The entry holding the start material's table.
const START_TABLE: &str = "start/table.exr";

/// The start table last encoded and its bytes: autosave writes the session after every
/// stroke, and the table (31 MB of floats) does not change between them.
type EncodedTable = (std::sync::Weak<SymTable>, Arc<Vec<u8>>);
static ENCODED_START: Mutex<Option<EncodedTable>> = Mutex::new(None);

/// The EXR bytes of `table` (TABLE.md), reusing the last encoding of the same table.
fn encode_start_table(table: &Arc<SymTable>) -> std::result::Result<Arc<Vec<u8>>, String> {
    let mut cached = ENCODED_START.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((weak, bytes)) = cached.as_ref()
        && weak.upgrade().is_some_and(|t| Arc::ptr_eq(&t, table))
    {
        return Ok(bytes.clone());
    }
    let image = RgbImage {
        width: DIRECTIONS,
        height: DIRECTIONS,
        pixels: (0..DIRECTIONS * DIRECTIONS)
            .map(|i| table.get((i / DIRECTIONS) as DirIndex, (i % DIRECTIONS) as DirIndex))
            .collect(),
    };
    let bytes = Arc::new(encode_colour(&image)?);
    *cached = Some((Arc::downgrade(table), bytes.clone()));
    Ok(bytes)
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BasisManifest {
    components: usize,
    materials: usize,
    /// `auto`, `gcv`, `prior:α` or `ridge:λ`.
    regularization: String,
    /// `mean`, `min` or `max`.
    policy: String,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewManifest {
    name: String,
    muted: bool,
    base_dir: String,
    /// Absent in files written before the rule existed, when only painted pixels counted.
    #[serde(default)]
    unpainted: Option<String>,
    /// `hdr` or `ldr` (paint imported from an 8-bit file); absent in files written before
    /// it existed, when every value was read as exact.
    #[serde(default)]
    paint_range: Option<String>,
}

/// What a session file's manifest says, without reading its images.
pub(crate) struct Summary {
    pub views: usize,
    pub session_path: Option<PathBuf>,
}

fn entry(view: usize, name: &str) -> String {
    format!("views/{}/{name}", view + 1)
}

/// Where extracted copies of embedded objects go: `$BURNISH_CACHE_DIR/session-objects` if that
/// variable is set, else `session-objects` in the user's cache folder (e.g. ~/.cache/burnish).
pub fn object_cache_dir() -> Result<PathBuf> {
    let base = match std::env::var_os("BURNISH_CACHE_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => directories::ProjectDirs::from("", "", "burnish")
            .ok_or_else(|| {
                Error::invalid(
                    Path::new("~"),
                    "no home folder to extract session objects into (set BURNISH_CACHE_DIR)",
                )
            })?
            .cache_dir()
            .to_path_buf(),
    };
    Ok(base.join("session-objects"))
}

impl Session {
    /// Writes the session to `path` atomically: on any failure the file there is untouched.
    /// Refuses a session that fails [`Session::check`] or whose .obj objects can't be read.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        write_session(self, path.as_ref(), None)
    }

    /// Reads and validates a session file. Embedded objects whose original file is gone or
    /// changed are extracted to [`object_cache_dir`].
    pub fn open(path: impl AsRef<Path>) -> Result<Session> {
        read_session(path.as_ref(), &object_cache_dir).map(|(session, _)| session)
    }

    /// As [`Session::open`], extracting embedded objects into `object_cache` where needed.
    pub fn open_with_object_cache(
        path: impl AsRef<Path>,
        object_cache: impl AsRef<Path>,
    ) -> Result<Session> {
        let dir = object_cache.as_ref().to_path_buf();
        read_session(path.as_ref(), &|| Ok(dir.clone())).map(|(session, _)| session)
    }

    /// [`Session::open_with_object_cache`] of a session file's bytes; `path` names it in
    /// errors.
    pub fn from_bytes(bytes: &[u8], path: &Path, object_cache: &Path) -> Result<Session> {
        let dir = object_cache.to_path_buf();
        let archive = ZipArchive::new(Cursor::new(bytes)).map_err(|e| not_a_session(path, e))?;
        read_archive(path, archive, &|| Ok(dir.clone())).map(|(session, _)| session)
    }
}

/// Writes `session` to `path`, recording `session_path` (the user's own file) if given.
pub(crate) fn write_session(
    session: &Session,
    path: &Path,
    session_path: Option<&Path>,
) -> Result<()> {
    session
        .check()
        .map_err(|problem| Error::invalid(path, format!("not saved: {problem}")))?;
    let manifest = Manifest {
        format_version: FORMAT_VERSION,
        active_view: session.active_view,
        session_path: session_path.map(|p| p.to_string_lossy().into_owned()),
        brush: session.brush.clone(),
        basis: BasisManifest {
            components: session.basis.components,
            materials: session.basis.materials,
            regularization: session.basis.regularization.to_string(),
            policy: session.basis.policy.to_string(),
        },
        start: session.start.as_ref().map(|start| StartManifest {
            name: start.name.clone(),
            source: start
                .source
                .as_ref()
                .map(|p| p.to_string_lossy().into_owned()),
        }),
        views: session
            .views
            .iter()
            .map(|v| ViewManifest {
                name: v.settings.name.clone(),
                muted: v.settings.muted,
                base_dir: v.settings.scene.base_dir.to_string_lossy().into_owned(),
                unpainted: Some(v.settings.unpainted.name().to_string()),
                paint_range: Some(v.settings.paint_range.name().to_string()),
            })
            .collect(),
    };
    let manifest =
        toml::to_string(&manifest).map_err(|e| Error::invalid(path, format!("not saved: {e}")))?;

    // Everything that can fail for reasons other than the disk happens before the write.
    let mut entries: Vec<(String, Vec<u8>)> = vec![(MANIFEST.into(), manifest.into_bytes())];
    for (i, view) in session.views.iter().enumerate() {
        let settings = &view.settings;
        entries.push((
            entry(i, "scene.toml"),
            settings.scene.to_toml().into_bytes(),
        ));
        if let ObjectSource::Obj(object) = settings.scene.object_source() {
            let bytes = std::fs::read(&object).map_err(|e| {
                Error::invalid(
                    path,
                    format!(
                        "not saved: view {} ({:?}): its object {} can't be read to embed it: {e}",
                        i + 1,
                        settings.name,
                        object.display()
                    ),
                )
            })?;
            entries.push((entry(i, "object.obj"), bytes));
        }
    }
    let images: Vec<(String, Vec<u8>)> = session
        .views
        .iter()
        .enumerate()
        .flat_map(|(i, view)| {
            [
                (entry(i, "colour.exr"), encode_colour(&view.paint.colour)),
                (
                    entry(i, "coverage.exr"),
                    encode_coverage(
                        &view.paint.coverage,
                        view.settings.scene.resolution as usize,
                    ),
                ),
            ]
            .into_iter()
            .chain(
                view.base
                    .as_ref()
                    .map(|base| (entry(i, "base.exr"), encode_colour(base))),
            )
        })
        .map(|(name, bytes)| {
            bytes
                .map(|b| (name.clone(), b))
                .map_err(|e| Error::invalid(path, format!("not saved: {name}: {e}")))
        })
        .collect::<Result<_>>()?;
    entries.extend(images);
    let start_table = session
        .start
        .as_ref()
        .map(|start| {
            encode_start_table(&start.table)
                .map_err(|e| Error::invalid(path, format!("not saved: {START_TABLE}: {e}")))
        })
        .transpose()?;

    write_atomically(path, |w| {
        let options = SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated)
            .compression_level(Some(DEFLATE_LEVEL))
            .large_file(
                entries
                    .iter()
                    .any(|(_, b)| b.len() as u64 >= u32::MAX as u64),
            );
        let mut zip = ZipWriter::new(w);
        for (name, bytes) in &entries {
            zip.start_file(name.as_str(), options)
                .map_err(std::io::Error::other)?;
            zip.write_all(bytes)?;
        }
        if let Some(bytes) = &start_table {
            // Floats barely deflate; storing them costs a checksum instead of a compression.
            let stored =
                SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
            zip.start_file(START_TABLE, stored)
                .map_err(std::io::Error::other)?;
            zip.write_all(bytes)?;
        }
        zip.finish().map_err(std::io::Error::other)?;
        Ok(())
    })
}

/// Reads and validates `path`; `object_cache` gives the folder for extracted objects and
/// is asked only when one is needed.
pub(crate) fn read_session(
    path: &Path,
    object_cache: &dyn Fn() -> Result<PathBuf>,
) -> Result<(Session, Option<PathBuf>)> {
    read_archive(path, open_archive(path)?, object_cache)
}

fn read_archive<R: Read + Seek>(
    path: &Path,
    mut archive: ZipArchive<R>,
    object_cache: &dyn Fn() -> Result<PathBuf>,
) -> Result<(Session, Option<PathBuf>)> {
    let invalid = |problem: String| Error::invalid(path, problem);
    let manifest = read_manifest(path, &mut archive)?;
    let regularization = manifest
        .basis
        .regularization
        .parse()
        .map_err(|e| invalid(format!("{MANIFEST}: basis.regularization: {e}")))?;
    let policy = manifest
        .basis
        .policy
        .parse()
        .map_err(|e| invalid(format!("{MANIFEST}: basis.policy: {e}")))?;

    let mut views = Vec::with_capacity(manifest.views.len());
    let mut embedded_objects = Vec::with_capacity(manifest.views.len());
    for (i, view) in manifest.views.iter().enumerate() {
        let scene_entry = entry(i, "scene.toml");
        let text = read_text(path, &mut archive, &scene_entry)?;
        let mut scene = Scene::parse(&text, Path::new(&scene_entry)).map_err(|e| match e {
            Error::Invalid { problem, .. } => invalid(format!("{scene_entry}: {problem}")),
            other => other,
        })?;
        scene.base_dir = PathBuf::from(&view.base_dir);
        let side = scene.resolution as usize;

        let colour_entry = entry(i, "colour.exr");
        let bytes = read_entry(path, &mut archive, &colour_entry, exr_limit(side, 3))?;
        let colour = decode_colour(&bytes, side)
            .and_then(|colour| check_colour(&colour, side).map(|()| colour))
            .map_err(|problem| invalid(format!("{colour_entry}: {problem}")))?;

        let coverage_entry = entry(i, "coverage.exr");
        let bytes = read_entry(path, &mut archive, &coverage_entry, exr_limit(side, 1))?;
        let coverage = decode_coverage(&bytes, side)
            .and_then(|coverage| check_coverage(&coverage, side).map(|()| coverage))
            .map_err(|problem| invalid(format!("{coverage_entry}: {problem}")))?;

        let base_entry = entry(i, "base.exr");
        let base = if archive.index_for_name(&base_entry).is_some() {
            let bytes = read_entry(path, &mut archive, &base_entry, exr_limit(side, 3))?;
            Some(
                decode_colour(&bytes, side)
                    .and_then(|base| check_colour(&base, side).map(|()| base))
                    .map_err(|problem| invalid(format!("{base_entry}: {problem}")))?,
            )
        } else {
            None
        };
        let unpainted = match &view.unpainted {
            None => UnpaintedPixels::Ignore,
            Some(name) => name
                .parse()
                .map_err(|e| invalid(format!("{MANIFEST}: views[{i}].unpainted: {e}")))?,
        };

        let paint_range = match &view.paint_range {
            None => PaintRange::Hdr,
            Some(name) => name
                .parse()
                .map_err(|e| invalid(format!("{MANIFEST}: views[{i}].paint_range: {e}")))?,
        };

        embedded_objects.push(match scene.object_source() {
            ObjectSource::Obj(_) => Some(read_entry(
                path,
                &mut archive,
                &entry(i, "object.obj"),
                OBJECT_LIMIT,
            )?),
            ObjectSource::Builtin(_) => None,
        });
        views.push(SessionView {
            settings: ViewSettings {
                name: view.name.clone(),
                scene,
                muted: view.muted,
                unpainted,
                paint_range,
            },
            paint: PaintLayers { colour, coverage },
            base,
        });
    }
    let start = match &manifest.start {
        Some(start) => {
            let bytes = read_entry(path, &mut archive, START_TABLE, exr_limit(DIRECTIONS, 3))?;
            let table = crate::table::exr_file::decode_table_exr(&bytes, Path::new(START_TABLE))
                .map_err(|e| match e {
                    Error::Invalid { problem, .. } => invalid(format!("{START_TABLE}: {problem}")),
                    other => invalid(format!("{START_TABLE}: {other}")),
                })?;
            Some(StartMaterial {
                name: start.name.clone(),
                source: start.source.as_ref().map(PathBuf::from),
                table: Arc::new(table),
            })
        }
        None => None,
    };
    let session = Session {
        views,
        active_view: manifest.active_view,
        brush: manifest.brush,
        basis: BasisSettings {
            components: manifest.basis.components,
            materials: manifest.basis.materials,
            regularization,
            policy,
        },
        start,
    };
    session
        .check()
        .map_err(|problem| invalid(format!("{MANIFEST}: {problem}")))?;

    // Only a valid file gets its objects extracted.
    let mut session = session;
    for (view, embedded) in session.views.iter_mut().zip(embedded_objects) {
        let scene = &mut view.settings.scene;
        if let (Some(bytes), ObjectSource::Obj(original)) = (embedded, scene.object_source())
            && !holds_bytes(&original, &bytes)
        {
            let extracted = extract_object(&object_cache()?, &original, &bytes)?;
            scene.object = extracted.to_string_lossy().into_owned();
        }
    }
    Ok((session, manifest.session_path.map(PathBuf::from)))
}

/// The view count and recorded session path of a session file, reading only its manifest.
pub(crate) fn read_summary(path: &Path) -> Result<Summary> {
    let mut archive = open_archive(path)?;
    let manifest = read_manifest(path, &mut archive)?;
    Ok(Summary {
        views: manifest.views.len(),
        session_path: manifest.session_path.map(PathBuf::from),
    })
}

/// Whether `path` is a regular file holding exactly `bytes`. Its length is compared first,
/// so that a path naming something other than a file the size of the copy (a device, a
/// pipe, a huge file) is never read.
fn holds_bytes(path: &Path, bytes: &[u8]) -> bool {
    std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() == bytes.len() as u64)
        && std::fs::read(path).is_ok_and(|b| b == bytes)
}

fn open_archive(path: &Path) -> Result<ZipArchive<BufReader<File>>> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    ZipArchive::new(BufReader::new(file)).map_err(|e| not_a_session(path, e))
}

fn not_a_session(path: &Path, e: zip::result::ZipError) -> Error {
    match e {
        zip::result::ZipError::Io(io) if io.kind() != std::io::ErrorKind::UnexpectedEof => {
            Error::io(path, io)
        }
        other => Error::invalid(
            path,
            format!("not a Burnish session file (not a readable zip archive: {other})"),
        ),
    }
}

fn read_manifest<R: Read + Seek>(path: &Path, archive: &mut ZipArchive<R>) -> Result<Manifest> {
    let text = read_text(path, archive, MANIFEST)?;
    let invalid = |problem: String| Error::invalid(path, format!("{MANIFEST}: {problem}"));
    // The version first: a newer file may have keys this build does not know.
    let table: toml::Table = toml::from_str(&text).map_err(|e| invalid(e.to_string()))?;
    match table.get("format_version").and_then(|v| v.as_integer()) {
        Some(v) if v == FORMAT_VERSION as i64 => {}
        Some(v) if v > FORMAT_VERSION as i64 => {
            return Err(invalid(format!(
                "format_version = {v}: made by a newer Burnish (this one reads version \
                 {FORMAT_VERSION})"
            )));
        }
        Some(v) => {
            return Err(invalid(format!(
                "format_version = {v} is not a version this Burnish reads ({FORMAT_VERSION})"
            )));
        }
        None => return Err(invalid("no integer format_version".into())),
    }
    toml::from_str(&text).map_err(|e| invalid(e.to_string()))
}

fn read_text<R: Read + Seek>(
    path: &Path,
    archive: &mut ZipArchive<R>,
    name: &str,
) -> Result<String> {
    let bytes = read_entry(path, archive, name, TEXT_LIMIT)?;
    String::from_utf8(bytes).map_err(|_| Error::invalid(path, format!("{name}: not UTF-8 text")))
}

/// An entry's bytes, its checksum verified; refuses entries inflating beyond `limit`.
fn read_entry<R: Read + Seek>(
    path: &Path,
    archive: &mut ZipArchive<R>,
    name: &str,
    limit: u64,
) -> Result<Vec<u8>> {
    let mut file = archive.by_name(name).map_err(|e| match e {
        zip::result::ZipError::FileNotFound => {
            Error::invalid(path, format!("the entry {name} is missing"))
        }
        other => Error::invalid(path, format!("{name}: unreadable entry ({other})")),
    })?;
    if file.size() > limit {
        return Err(Error::invalid(
            path,
            format!(
                "{name}: {} bytes is more than such an entry can hold",
                file.size()
            ),
        ));
    }
    // Deflate inflates at most about 1032-fold: a claim beyond that is not reserved.
    let plausible = file
        .compressed_size()
        .saturating_mul(1032)
        .saturating_add(4096);
    let mut bytes =
        Vec::with_capacity(file.size().min(plausible).min(PREALLOCATION_LIMIT) as usize);
    // The zip reader checks the CRC once the entry has been read to its end.
    (&mut file)
        .take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::invalid(path, format!("{name}: damaged entry ({e})")))?;
    if bytes.len() as u64 != file.size() {
        return Err(Error::invalid(
            path,
            format!(
                "{name}: damaged entry ({} bytes where {} were recorded)",
                bytes.len(),
                file.size()
            ),
        ));
    }
    Ok(bytes)
}

/// Generous bound on an uncompressed EXR of `side²` pixels and `channels` f32 channels: the
/// pixels, one offset per scan line, and a header.
fn exr_limit(side: usize, channels: usize) -> u64 {
    (side * side * channels * 4 + side * 16 + (1 << 20)) as u64
}

/// Writes an EXR image into memory. A macro, not a function: the channel closures borrow the
/// caller's pixels, and exr's writer traits can't name that lifetime in a signature.
macro_rules! encode_exr {
    ($image:expr) => {{
        let mut bytes = Cursor::new(Vec::new());
        $image
            .write()
            .to_buffered(&mut bytes)
            .map_err(|e| e.to_string())?;
        Ok(bytes.into_inner())
    }};
}

fn encode_colour(colour: &RgbImage) -> std::result::Result<Vec<u8>, String> {
    let width = colour.width;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let [r, g, b] = colour.pixels[pos.y() * width + pos.x()];
        (r, g, b)
    });
    encode_exr!(Image::from_encoded_channels(
        (colour.width, colour.height),
        Encoding::UNCOMPRESSED,
        channels,
    ))
}

fn encode_coverage(coverage: &[f32], side: usize) -> std::result::Result<Vec<u8>, String> {
    let channels = SpecificChannels::build()
        .with_channel("Y")
        .with_pixel_fn(|pos: Vec2<usize>| (coverage[pos.y() * side + pos.x()],));
    encode_exr!(Image::from_encoded_channels(
        (side, side),
        Encoding::UNCOMPRESSED,
        channels,
    ))
}

/// The named 32-bit float channels of an EXR's first layer, which must be `side × side`.
fn decode_channels(
    bytes: &[u8],
    side: usize,
    names: &[&str],
) -> std::result::Result<Vec<Vec<f32>>, String> {
    let not_exr = |e: exr::error::Error| format!("not a readable OpenEXR image ({e})");
    // The header first, so that a wrong size is reported before any pixels are decoded.
    let meta =
        exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(not_exr)?;
    let header = meta
        .headers
        .first()
        .ok_or("an OpenEXR file without layers")?;
    let size = header.layer_size;
    if (size.width(), size.height()) != (side, side) {
        return Err(format!(
            "the image is {} × {} pixels but the scene's resolution is {side}",
            size.width(),
            size.height()
        ));
    }
    for header in &meta.headers {
        crate::image_io::check_exr_data_size(header, bytes.len())?;
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(not_exr)?;
    let list = &image.layer_data.channel_data.list;
    names
        .iter()
        .map(|&name| {
            let channel = list
                .iter()
                .find(|c| c.name == *name)
                .ok_or_else(|| format!("no channel {name}"))?;
            match &channel.sample_data {
                FlatSamples::F32(samples) if samples.len() == side * side => Ok(samples.clone()),
                FlatSamples::F32(samples) => Err(format!(
                    "channel {name} has {} samples, not {side} × {side}",
                    samples.len()
                )),
                _ => Err(format!(
                    "channel {name} is not 32-bit float (a painting must be stored losslessly)"
                )),
            }
        })
        .collect()
}

/// A view's painting from the bytes of its `colour.exr` and `coverage.exr` entries, checked
/// as [`Session::open`] checks them: `side × side` pixels, finite colours, coverage in
/// [0, 1]. The problem, naming the entry, when not.
pub fn decode_paint_layers(
    colour: &[u8],
    coverage: &[u8],
    side: usize,
) -> std::result::Result<PaintLayers, String> {
    let colour = decode_colour(colour, side)
        .and_then(|c| check_colour(&c, side).map(|()| c))
        .map_err(|problem| format!("colour.exr: {problem}"))?;
    let coverage = decode_coverage(coverage, side)
        .and_then(|c| check_coverage(&c, side).map(|()| c))
        .map_err(|problem| format!("coverage.exr: {problem}"))?;
    Ok(PaintLayers { colour, coverage })
}

fn decode_colour(bytes: &[u8], side: usize) -> std::result::Result<RgbImage, String> {
    let channels = decode_channels(bytes, side, &["R", "G", "B"])?;
    let pixels = (0..side * side)
        .map(|i| [channels[0][i], channels[1][i], channels[2][i]])
        .collect();
    Ok(RgbImage {
        width: side,
        height: side,
        pixels,
    })
}

fn decode_coverage(bytes: &[u8], side: usize) -> std::result::Result<Vec<f32>, String> {
    Ok(decode_channels(bytes, side, &["Y"])?.remove(0))
}

/// Writes `bytes` (an embedded copy of `original`) to `cache/<hash>/<original's file name>`,
/// unless that file already holds them, and returns its absolute path.
fn extract_object(cache: &Path, original: &Path, bytes: &[u8]) -> Result<PathBuf> {
    let file_name = original
        .file_name()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("object.obj"));
    let dir = cache.join(format!("{:016x}", fnv1a(bytes)));
    let target = std::path::absolute(dir.join(file_name)).map_err(|e| Error::io(&dir, e))?;
    if holds_bytes(&target, bytes) {
        return Ok(target);
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    write_atomically(&target, |w| w.write_all(bytes))?;
    Ok(target)
}

/// 64-bit FNV-1a: names the folder of an extracted object after its contents, so that one
/// copy serves every session embedding the same file.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &b| {
        (hash ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start_table() -> SymTable {
        SymTable::from_fn(|lo, hi| {
            let x = lo as f32 * 1e-3 + hi as f32 * 1e-4;
            [x, 0.5 / (1.0 + x), 1.0 / (hi as f32 + 1.0)]
        })
    }

    /// The starting material survives a save and an open bit for bit, with its name and
    /// source; a session without one says nothing about it and opens without one.
    #[test]
    fn the_start_material_round_trips_and_is_optional() {
        let dir = tempfile::tempdir().unwrap();
        let mut session = Session::default();
        let plain = dir.path().join("plain.burnish");
        session.save(&plain).unwrap();
        let manifest = read_text(&plain, &mut open_archive(&plain).unwrap(), MANIFEST).unwrap();
        assert!(!manifest.contains("[start]"), "{manifest}");
        assert_eq!(Session::open(&plain).unwrap().start, None);

        let table = Arc::new(start_table());
        session.start = Some(StartMaterial {
            name: "gold.binary".into(),
            source: Some(PathBuf::from("/materials/gold.binary")),
            table: table.clone(),
        });
        let path = dir.path().join("started.burnish");
        session.save(&path).unwrap();
        // Saved twice (as autosave does): the encoding is reused, the file the same.
        let first = std::fs::read(&path).unwrap();
        session.save(&path).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), first);
        let reopened = Session::open(&path).unwrap();
        let start = reopened.start.as_ref().expect("the start material is kept");
        assert_eq!(start.name, "gold.binary");
        assert_eq!(start.source, Some(PathBuf::from("/materials/gold.binary")));
        assert!(
            start.table.pairs() == table.pairs(),
            "the table, bit for bit"
        );
        assert_eq!(reopened, session);
    }

    /// A session whose start table is missing or not a table is refused, naming the entry.
    #[test]
    fn a_damaged_start_table_is_refused_naming_the_entry() {
        let dir = tempfile::tempdir().unwrap();
        let session = Session {
            start: Some(StartMaterial {
                name: "m.exr".into(),
                source: None,
                table: Arc::new(start_table()),
            }),
            ..Session::default()
        };
        let good = dir.path().join("good.burnish");
        session.save(&good).unwrap();
        let mut archive = open_archive(&good).unwrap();
        let mut rewrite = |name: &str, table: Option<&[u8]>| {
            let out = dir.path().join(name);
            let file = File::create(&out).unwrap();
            let mut zip = ZipWriter::new(file);
            for i in 0..archive.len() {
                let mut entry = archive.by_index(i).unwrap();
                let entry_name = entry.name().unwrap().into_owned();
                let mut bytes = Vec::new();
                entry.read_to_end(&mut bytes).unwrap();
                if entry_name == START_TABLE {
                    match table {
                        Some(replacement) => bytes = replacement.to_vec(),
                        None => continue,
                    }
                }
                zip.start_file(entry_name, SimpleFileOptions::default())
                    .unwrap();
                zip.write_all(&bytes).unwrap();
            }
            zip.finish().unwrap();
            out
        };
        let missing = rewrite("missing.burnish", None);
        let small = RgbImage {
            width: 4,
            height: 4,
            pixels: vec![[0.1; 3]; 16],
        };
        let wrong = rewrite("wrong.burnish", Some(&encode_colour(&small).unwrap()));
        for (path, expected) in [
            (missing, "start/table.exr is missing"),
            (wrong, "1620 × 1620"),
        ] {
            let message = Session::open(&path).unwrap_err().to_string();
            assert!(message.contains(expected), "{message}");
            assert!(message.contains(START_TABLE), "{message}");
        }
    }
}
