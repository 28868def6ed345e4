//! Files that are damaged, cut short, far too large, or that lie about their size in a header,
//! for every reader: each gives an error naming the file and the problem, never a panic, and
//! never an allocation out of proportion to the file (a tiny file claiming a huge image must
//! not allocate it). Also: a basis cache folder that can't be written.
//!
//! The largest single allocation of each check is measured by this binary's allocator, per
//! thread, so that tests running side by side don't disturb each other's figures.

use burnish::basis::{BasisCache, BasisSpec, CacheOutcome};
use burnish::image_io::{RgbImage, decode_exr_rgb, write_exr_rgb};
use burnish::materials::database::DatabaseSpec;
use burnish::paint::{TipMask, load_preset};
use burnish::scene::{Mesh, Object, Scene, decode_painting, read_painting, write_png};
use burnish::session::Session;
use burnish::table::SymTable;
use burnish::table::exr_file::{read_table_exr, write_table_exr};
use burnish::table::merl::MerlBrdf;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;

#[path = "support/read_only.rs"]
mod read_only;

/// The system allocator, noting the largest single request made on each thread.
struct Tracking;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|largest| largest.set(largest.get().max(size)));
}

// SAFETY: every call is passed on to the system allocator unchanged.
unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Tracking = Tracking;

/// Runs `read`, which must fail naming `path` and each of `words`; returns the largest
/// single allocation it made.
fn refused<T>(path: &Path, words: &[&str], read: impl FnOnce() -> burnish::Result<T>) -> usize {
    LARGEST.with(|l| l.set(0));
    let outcome = read();
    let largest = LARGEST.with(Cell::get);
    let err = match outcome {
        Ok(_) => panic!("{} was accepted", path.display()),
        Err(e) => e.to_string(),
    };
    assert!(err.contains(&*path.to_string_lossy()), "{err}");
    for word in words {
        assert!(err.contains(word), "expected {word:?} in: {err}");
    }
    largest
}

const MB: usize = 1 << 20;

/// Every cut of `bytes` shorter than `refused_below` (at a spread of lengths, from 0) is
/// refused by `read`, naming the file; cuts past it (a format's optional trailer) may be read.
/// Every damaged copy (a run of bytes inverted at a spread of places) is read or refused,
/// naming the file. None panics or allocates more than `budget` bytes at once.
fn damaged_copies_are_refused(
    dir: &Path,
    name: &str,
    bytes: &[u8],
    budget: usize,
    refused_below: usize,
    read: impl Fn(&Path) -> burnish::Result<()>,
) {
    let path = dir.join(name);
    let n = bytes.len();
    let mut cuts: Vec<usize> = (0..12).map(|i| i * n / 12).collect();
    cuts.extend([1, 7, 8, 64, n.saturating_sub(1)]);
    for cut in cuts.into_iter().filter(|&c| c < n) {
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let largest = if cut < refused_below {
            refused(&path, &[], || read(&path))
        } else {
            LARGEST.with(|l| l.set(0));
            if let Err(e) = read(&path) {
                assert!(e.to_string().contains(name), "{e}");
            }
            LARGEST.with(Cell::get)
        };
        assert!(
            largest <= budget,
            "{name} cut to {cut} bytes allocated {largest} bytes"
        );
    }
    for i in 0..8 {
        let at = i * n / 8 + 3;
        let mut damaged = bytes.to_vec();
        for b in &mut damaged[at.min(n)..(at + 16).min(n)] {
            *b = !*b;
        }
        std::fs::write(&path, &damaged).unwrap();
        // Damage may land where it changes nothing that matters (padding, a float's value);
        // what matters is that no damage panics or allocates out of proportion.
        LARGEST.with(|l| l.set(0));
        if let Err(e) = read(&path) {
            assert!(e.to_string().contains(name), "{e}");
        }
        let largest = LARGEST.with(Cell::get);
        assert!(
            largest <= budget,
            "{name} damaged at {at} allocated {largest} bytes"
        );
    }
}

#[test]
fn damaged_scene_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let text =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/example/sphere.toml"))
            .unwrap();
    let path = dir.path().join("scene.toml");
    // A cut at a line's end leaves a valid scene (every key has a default); any other cut and
    // any damage is refused, naming the file.
    for cut in 0..text.len() {
        std::fs::write(&path, &text[..cut]).unwrap();
        match Scene::load(&path) {
            Ok(scene) => assert_eq!(scene.check(), Ok(())),
            Err(e) => assert!(e.to_string().contains("scene.toml"), "{e}"),
        }
    }
    let value_cut = text.windows(3).position(|w| w == b" = ").unwrap() + 3;
    std::fs::write(&path, &text[..value_cut]).unwrap();
    refused(&path, &["not a valid scene file"], || Scene::load(&path));
    let mut damaged = text.clone();
    damaged[value_cut] = 0xff;
    std::fs::write(&path, &damaged).unwrap();
    refused(&path, &["UTF-8"], || Scene::load(&path));
}

#[test]
fn damaged_obj_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::new();
    for i in 0..90 {
        let t = i as f64 * 0.37;
        obj += &format!("v {} {} {}\n", t.cos(), t.sin(), (t * 0.5).cos());
    }
    let faces_start = obj.len();
    for i in 0..30 {
        obj += &format!("f {} {} {}\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    let bytes = obj.into_bytes();
    Mesh::from_obj_bytes(&bytes, Path::new("whole.obj")).expect("the whole file is fine");
    let path = dir.path().join("mesh.obj");
    // Cut before its faces: between lines, and within one.
    for (cut, words) in [
        (0, &["no faces"][..]),
        (faces_start, &["no faces"]),
        (10, &[]),
        (faces_start / 2, &[]),
        (faces_start + 5, &[]),
    ] {
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let largest = refused(&path, words, || Object::from_obj(&path));
        assert!(largest <= MB, "{largest}");
    }
    // A face naming a vertex past the end.
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    refused(&path, &["mesh.obj"], || Object::from_obj(&path));
    std::fs::write(&path, [0xffu8, 0xfe, 0x00, 0x13, 0x37].repeat(100)).unwrap();
    refused(&path, &["mesh.obj"], || Object::from_obj(&path));
}

#[test]
fn damaged_merl_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.binary");
    MerlBrdf::from_fn(|_, _| [0.1, 0.2, 0.3])
        .write(&good)
        .unwrap();
    let bytes = std::fs::read(&good).unwrap();
    damaged_copies_are_refused(
        dir.path(),
        "brdf.binary",
        &bytes,
        bytes.len() + MB,
        usize::MAX,
        |p| MerlBrdf::read(p).map(drop),
    );
}

#[test]
fn damaged_table_and_painting_exrs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("table.exr");
    write_table_exr(&good, &SymTable::filled([0.2, 0.3, 0.4])).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    // The table's own pixels and a copy: what a good file needs.
    let n = bytes.len();
    damaged_copies_are_refused(dir.path(), "cut.exr", &bytes, 2 * n + MB, usize::MAX, |p| {
        read_table_exr(p).map(drop)
    });

    let painting = dir.path().join("painting.exr");
    write_exr_rgb(&painting, &RgbImage::filled(64, 64, [0.5, 0.25, 2.0])).unwrap();
    let bytes = std::fs::read(&painting).unwrap();
    damaged_copies_are_refused(dir.path(), "paint.exr", &bytes, MB, usize::MAX, |p| {
        read_painting(p, 64).map(drop)
    });
    let png = dir.path().join("painting.png");
    write_png(&png, &RgbImage::filled(64, 64, [0.5, 0.25, 1.0])).unwrap();
    let bytes = std::fs::read(&png).unwrap();
    // The last 12 bytes are the end marker, which a decoder may never look at.
    let trailer = bytes.len() - 12;
    damaged_copies_are_refused(dir.path(), "paint.png", &bytes, MB, trailer, |p| {
        read_painting(p, 64).map(drop)
    });
}

#[test]
fn damaged_brush_presets_and_tips_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let brushes = Path::new(env!("CARGO_MANIFEST_DIR")).join("brushes");
    let text = std::fs::read(brushes.join("10-chalk.toml")).unwrap();
    std::fs::copy(brushes.join("chalk.png"), dir.path().join("chalk.png")).unwrap();
    let path = dir.path().join("preset.toml");
    std::fs::write(&path, &text).unwrap();
    load_preset(&path).expect("the shipped preset loads");
    for cut in [0, 1, text.len() / 4, text.len() / 2, text.len() - 3] {
        std::fs::write(&path, &text[..cut]).unwrap();
        refused(&path, &["preset.toml"], || load_preset(&path));
    }
    let tip = std::fs::read(brushes.join("chalk.png")).unwrap();
    damaged_copies_are_refused(dir.path(), "tip.png", &tip, 8 * MB, tip.len() - 12, |p| {
        TipMask::load_png(p).map(drop)
    });
    // A preset whose tip is damaged names the preset and the tip.
    std::fs::write(dir.path().join("chalk.png"), &tip[..tip.len() / 2]).unwrap();
    std::fs::write(&path, &text).unwrap();
    refused(&path, &["preset.toml", "chalk.png"], || load_preset(&path));
}

/// The header of an uncompressed (or ZIP-compressed) scan-line EXR of `width` × `height`
/// RGB float pixels, with no pixel data after it.
fn exr_header(width: i32, height: i32, compression: u8) -> Vec<u8> {
    fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
        out.extend(name.as_bytes());
        out.push(0);
        out.extend(kind.as_bytes());
        out.push(0);
        out.extend((value.len() as i32).to_le_bytes());
        out.extend(value);
    }
    let mut channels = Vec::new();
    for name in ["B", "G", "R"] {
        channels.extend(name.as_bytes());
        channels.push(0);
        channels.extend(2i32.to_le_bytes());
        channels.extend([0, 0, 0, 0]);
        channels.extend(1i32.to_le_bytes());
        channels.extend(1i32.to_le_bytes());
    }
    channels.push(0);
    let window: Vec<u8> = [0, 0, width - 1, height - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    attribute(&mut out, "channels", "chlist", &channels);
    attribute(&mut out, "compression", "compression", &[compression]);
    attribute(&mut out, "dataWindow", "box2i", &window);
    attribute(&mut out, "displayWindow", "box2i", &window);
    attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    attribute(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    attribute(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
    out.push(0);
    out
}

/// A PNG that claims `width` × `height` 8-bit RGB pixels and holds almost none.
fn png_header(width: u32, height: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    out.extend(13u32.to_be_bytes());
    out.extend(&ihdr);
    out.extend(crc32fast::hash(&ihdr).to_be_bytes());
    // The start of its image data, so that the header reads as complete.
    let idat = b"IDAT\x78\x01";
    out.extend(2u32.to_be_bytes());
    out.extend(idat);
    out.extend(crc32fast::hash(idat).to_be_bytes());
    out
}

#[test]
fn tiny_files_claiming_huge_images_allocate_nothing_large() {
    let dir = tempfile::tempdir().unwrap();
    for (compression, name) in [(0u8, "none.exr"), (3, "zip.exr"), (4, "piz.exr")] {
        let path = dir.path().join(name);
        let bytes = exr_header(100_000, 100_000, compression);
        assert!(bytes.len() < 400);
        std::fs::write(&path, &bytes).unwrap();
        let largest = refused(&path, &[name], || {
            decode_exr_rgb(&bytes, &path, |_, _| Ok(()))
        });
        assert!(largest < MB, "{name}: {largest} bytes at once");
        let largest = refused(&path, &["1620"], || read_table_exr(&path));
        assert!(largest < MB, "{name}: {largest} bytes at once");
        let largest = refused(&path, &["512"], || read_painting(&path, 512));
        assert!(largest < MB, "{name}: {largest} bytes at once");
    }
    // The right size for a painting, and still far more than the file holds.
    let path = dir.path().join("big.exr");
    let bytes = exr_header(8192, 8192, 0);
    std::fs::write(&path, &bytes).unwrap();
    let largest = refused(&path, &["more pixel data"], || read_painting(&path, 8192));
    assert!(largest < MB, "{largest}");

    let path = dir.path().join("huge.png");
    let bytes = png_header(60_000, 60_000);
    std::fs::write(&path, &bytes).unwrap();
    let largest = refused(&path, &["huge.png"], || {
        decode_painting(&bytes, &path, 60_000)
    });
    assert!(largest < MB, "{largest}");
    let largest = refused(&path, &["huge.png", "1024"], || TipMask::load_png(&path));
    assert!(largest < MB, "{largest}");
}

#[test]
fn huge_files_are_refused_by_their_length_without_being_read() {
    let dir = tempfile::tempdir().unwrap();
    // Sparse: 16 GiB that take no disk space.
    let huge = |name: &str| {
        let path = dir.path().join(name);
        std::fs::File::create(&path)
            .unwrap()
            .set_len(16 << 30)
            .unwrap();
        path
    };
    let path = huge("scene.toml");
    assert!(refused(&path, &["bytes"], || Scene::load(&path)) < MB);
    let path = huge("preset.toml");
    assert!(refused(&path, &["bytes"], || load_preset(&path)) < MB);
    let path = huge("tip.png");
    assert!(refused(&path, &["bytes"], || TipMask::load_png(&path)) < MB);
    let path = huge("brdf.binary");
    let largest = refused(&path, &[], || MerlBrdf::read(&path));
    assert!(largest < 64 * MB, "{largest}");
}

/// A session whose embedded object claims gigabytes in the archive's directory, with a few
/// bytes behind the claim: refused without reserving the claim.
#[test]
fn a_session_entry_claiming_gigabytes_reserves_nothing_of_the_sort() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.obj"),
        "v 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let scene = Scene {
        object: "m.obj".into(),
        resolution: 4,
        base_dir: dir.path().to_path_buf(),
        ..Scene::default()
    };
    let session = Session {
        views: vec![burnish::session::SessionView::new("V", scene).unwrap()],
        ..Session::default()
    };
    let path = dir.path().join("liar.burnish");
    session.save(&path).unwrap();

    // The object's recorded size, in its local header and in the central directory, becomes
    // 4 GiB - 16; its data stays a few bytes.
    let mut bytes = std::fs::read(&path).unwrap();
    let name = b"views/1/object.obj";
    let claim = (u32::MAX - 15).to_le_bytes();
    let mut patched = 0;
    for i in 46..bytes.len() - name.len() {
        if &bytes[i..i + name.len()] != name {
            continue;
        }
        // Local header: signature 50 4b 03 04, uncompressed size at 22, name at 30.
        if bytes[i - 30..i - 26] == [0x50, 0x4b, 0x03, 0x04] {
            bytes[i - 30 + 22..i - 30 + 26].copy_from_slice(&claim);
            patched += 1;
        }
        // Central directory: signature 50 4b 01 02, uncompressed size at 24, name at 46.
        if bytes[i - 46..i - 42] == [0x50, 0x4b, 0x01, 0x02] {
            bytes[i - 46 + 24..i - 46 + 28].copy_from_slice(&claim);
            patched += 1;
        }
    }
    assert_eq!(patched, 2);
    std::fs::write(&path, &bytes).unwrap();
    let cache = dir.path().join("cache");
    let largest = refused(&path, &["views/1/object.obj"], || {
        Session::open_with_object_cache(&path, &cache)
    });
    assert!(largest < 16 * MB, "{largest} bytes at once");
    let largest = refused(&path, &["views/1/object.obj"], || {
        Session::from_bytes(&bytes, &path, &cache)
    });
    assert!(largest < 16 * MB, "{largest} bytes at once");
}

fn tiny_spec() -> BasisSpec {
    BasisSpec {
        database: DatabaseSpec { seed: 5, size: 8 },
        components: 3,
        oversampling: 4,
        power_iterations: 1,
    }
}

/// A basis cache folder that can't be written: the basis is still built and used, from
/// memory, and the outcome says why it was not cached.
#[test]
fn a_read_only_basis_cache_builds_and_uses_the_basis_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    let cache_dir = dir.path().join("cache");
    std::fs::create_dir(&cache_dir).unwrap();
    let spec = tiny_spec();
    let (components, outcome) = read_only::with_read_only_dir(&cache_dir, || {
        let (basis, outcome) = BasisCache::at(cache_dir.clone())
            .load_or_build(&spec, false, &|_| {})
            .expect("a read-only cache still gives the basis");
        (basis.components(), outcome)
    });
    assert_eq!(components, 3);
    match outcome {
        CacheOutcome::NotStored { reason } => {
            assert!(
                reason.contains("cache") && reason.contains("Permission denied"),
                "{reason}"
            );
        }
        other => panic!("expected NotStored, got {other:?}"),
    }
    assert_eq!(std::fs::read_dir(&cache_dir).unwrap().count(), 0);
    // Writable again: stored, then loaded.
    let cache = BasisCache::at(cache_dir.clone());
    assert_eq!(
        cache.load_or_build(&spec, false, &|_| {}).unwrap().1,
        CacheOutcome::Built
    );
    assert_eq!(
        cache.load_or_build(&spec, false, &|_| {}).unwrap().1,
        CacheOutcome::Loaded
    );
}
