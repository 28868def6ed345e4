//! The promise "nothing the user made is lost", proved on the real program: the `burnish`
//! binary runs in a real window on a virtual X display (Xvfb), is painted on with real X
//! input (xdotool, through the window's own event loop), left idle, and killed with SIGKILL.
//! The recovery file must hold the stroke; a relaunch with `--recover` must bring it back
//! (checked by saving it with Ctrl+S and reading the file). A long stroke killed while the
//! button is still down must have been written in part already.
//!
//! Xvfb and xdotool are required (`.ci/run` installs them): without them this test fails,
//! it never skips.

use burnish::session::{Session, pending_recovery_at};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A process that is killed (SIGKILL) when dropped.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A virtual X display, `:N`, for the test's own use.
struct Display {
    name: String,
    server: Child,
}

impl Drop for Display {
    /// Ends the server with SIGTERM, so that it removes its lock file and socket.
    fn drop(&mut self) {
        // SAFETY: kill(2) on the server's own process id.
        unsafe { libc::kill(self.server.id() as libc::pid_t, libc::SIGTERM) };
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.server.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.server.kill();
        let _ = self.server.wait();
    }
}

fn start_display() -> Display {
    // A display number of its own: tests of several checkouts may run at once.
    let first = 100 + std::process::id() % 500;
    for number in first..first + 20 {
        if Path::new(&format!("/tmp/.X{number}-lock")).exists() {
            continue;
        }
        let name = format!(":{number}");
        // -noreset: an X server resets when its last client leaves, and refuses connections
        // while it does. The readiness probe below is such a client; without it the app,
        // launched right after, could land in that reset and fail to open its window (seen
        // once under load, and once on an idle machine).
        let server = Command::new("Xvfb")
            .args([
                &name,
                "-screen",
                "0",
                "1600x1000x24",
                "-nolisten",
                "tcp",
                "-noreset",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb must be installed to run this test (.ci/run installs the xvfb package)");
        let mut display = Display { name, server };
        let socket = PathBuf::from(format!("/tmp/.X11-unix/X{number}"));
        let deadline = Instant::now() + Duration::from_secs(20);
        while Instant::now() < deadline {
            if socket.exists() && xdotool_on(&display.name, &["getdisplaygeometry"]).is_some() {
                return display;
            }
            if let Ok(Some(_)) = display.server.try_wait() {
                break; // Taken after all: try the next number.
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    panic!("no virtual X display could be started");
}

/// Runs xdotool on `display`; its output when it succeeds.
fn xdotool_on(display: &str, args: &[&str]) -> Option<String> {
    let out = Command::new("xdotool")
        .args(args)
        .env("DISPLAY", display)
        .output()
        .expect("xdotool must be installed to run this test (.ci/run installs it)");
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

impl Display {
    fn xdotool(&self, args: &[&str]) -> String {
        xdotool_on(&self.name, args).unwrap_or_else(|| panic!("xdotool {args:?} failed"))
    }

    /// The Burnish window and its position and size on the screen, waiting for it to map.
    fn burnish_window(&self, app: &mut Killed, log: &Path) -> (String, [i32; 4]) {
        let deadline = Instant::now() + Duration::from_secs(120);
        loop {
            if let Some(ids) = xdotool_on(
                &self.name,
                &["search", "--onlyvisible", "--name", "^Burnish$"],
            ) && let Some(id) = ids.lines().next()
            {
                let geometry = self.xdotool(&["getwindowgeometry", "--shell", id]);
                let value = |key: &str| -> i32 {
                    geometry
                        .lines()
                        .find_map(|l| l.strip_prefix(&format!("{key}=")))
                        .and_then(|v| v.trim().parse().ok())
                        .unwrap_or_else(|| panic!("no {key} in {geometry}"))
                };
                let rect = [value("X"), value("Y"), value("WIDTH"), value("HEIGHT")];
                if rect[2] > 0 && rect[3] > 0 {
                    return (id.to_owned(), rect);
                }
            }
            if let Ok(Some(status)) = app.0.try_wait() {
                // Whether the display still answers tells a dead server from a client that
                // could not connect.
                let answers = xdotool_on(&self.name, &["getdisplaygeometry"]).is_some();
                panic!(
                    "burnish exited ({status}); display {} answers xdotool: {answers}:\n{}",
                    self.name,
                    read_log(log)
                );
            }
            assert!(
                Instant::now() < deadline,
                "the Burnish window did not appear:\n{}",
                read_log(log)
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

fn read_log(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_default()
}

/// Launches the app on `display` with `args`, its folders in `dir`, its output in `log`.
fn launch(display: &Display, dir: &Path, args: &[&str], log: &Path) -> Killed {
    let log_file = std::fs::File::create(log).unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_burnish"))
        .arg("app")
        // A small basis: it builds in seconds in the background instead of the default's
        // minute, and painting never waits for it anyway.
        .args(["--materials", "8", "--components", "4"])
        .args(args)
        .env("DISPLAY", &display.name)
        .env_remove("WAYLAND_DISPLAY")
        .env("WINIT_X11_SCALE_FACTOR", "1")
        .env("BURNISH_DATA_DIR", dir.join("data"))
        .env("BURNISH_CACHE_DIR", dir.join("cache"))
        .stdout(log_file.try_clone().unwrap())
        .stderr(log_file)
        .spawn()
        .expect("the burnish binary starts");
    Killed(child)
}

/// Screen position of a fraction (`u`, `v`) of the window.
fn at(window: [i32; 4], u: f64, v: f64) -> (i32, i32) {
    (
        window[0] + (u * window[2] as f64) as i32,
        window[1] + (v * window[3] as f64) as i32,
    )
}

/// Polls `check` every 50 ms for up to `limit`; the time it took, once true.
fn wait_for(limit: Duration, mut check: impl FnMut() -> bool) -> Option<Duration> {
    let start = Instant::now();
    while start.elapsed() < limit {
        if check() {
            return Some(start.elapsed());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    None
}

/// The first view's painted pixels in the recovery file, if it can be read yet.
fn recovered_paint(recovery: &Path) -> Option<burnish::paint::PaintLayers> {
    let info = pending_recovery_at(recovery).ok()??;
    Some(info.open().ok()?.views.into_iter().next()?.paint)
}

/// Columns (canvas x) painted in row band `rows` that carry paint.
fn painted_columns(
    paint: &burnish::paint::PaintLayers,
    rows: std::ops::Range<usize>,
) -> Vec<usize> {
    let side = paint.colour.width;
    let mut columns: Vec<usize> = rows
        .flat_map(|y| (0..side).filter(move |&x| paint.coverage[y * side + x] > 0.0))
        .collect();
    columns.sort_unstable();
    columns.dedup();
    columns
}

#[test]
fn a_sigkilled_app_loses_no_stroke_and_recovery_restores_it() {
    let dir = tempfile::tempdir().unwrap();
    let recovery = dir.path().join("data/recovery.burnish");
    let session_file = dir.path().join("work.burnish");
    // The small basis the app is launched with: a session asking for the default one would
    // start its build (a minute and gigabytes) the moment it opens.
    let mut session = Session::default();
    session.basis.materials = 8;
    session.basis.components = 4;
    session.save(&session_file).unwrap();
    let display = start_display();

    // 1. Paint one stroke, let the app idle, kill it.
    let log = dir.path().join("first.log");
    let mut app = launch(
        &display,
        dir.path(),
        &["--session", session_file.to_str().unwrap()],
        &log,
    );
    let (_, window) = display.burnish_window(&mut app, &log);
    // The window needs a few frames (and lavapipe its first pipelines) before input counts.
    std::thread::sleep(Duration::from_secs(3));
    let (x0, y) = at(window, 0.36, 0.58);
    let (x1, _) = at(window, 0.46, 0.58);
    let mut stroke = vec![
        "mousemove".to_owned(),
        x0.to_string(),
        y.to_string(),
        "sleep".into(),
        "0.2".into(),
        "mousedown".into(),
        "1".into(),
    ];
    for i in 1..=20 {
        let x = x0 + (x1 - x0) * i / 20;
        stroke.extend(["mousemove".into(), x.to_string(), y.to_string()]);
        stroke.extend(["sleep".into(), "0.03".into()]);
    }
    stroke.extend(["mouseup".into(), "1".into()]);
    display.xdotool(&stroke.iter().map(String::as_str).collect::<Vec<_>>());
    let released = Instant::now();
    // Idle: no input at all from here. The stroke must reach the disk on its own. (The
    // wait is generous for a loaded CI machine, where the window may lag its input.)
    let idle = Duration::from_secs(8);
    let on_disk = wait_for(idle, || {
        recovered_paint(&recovery).is_some_and(|p| p.painted_count() > 0)
    });
    std::thread::sleep(idle.saturating_sub(released.elapsed()));
    drop(app); // SIGKILL
    let first = recovered_paint(&recovery).unwrap_or_else(|| {
        panic!(
            "no readable recovery file after the kill:\n{}",
            read_log(&log)
        )
    });
    let painted = first.painted_count();
    assert!(
        painted > 200,
        "the recovery file holds the stroke ({painted} painted pixels):\n{}",
        read_log(&log)
    );
    // A figure for the record (timing is not asserted: tests are not benchmarks).
    eprintln!(
        "stroke on disk {} after its release (idle, no input); {painted} pixels",
        on_disk.map_or("only after the kill's wait".into(), |t| format!(
            "{:.0} ms",
            t.as_secs_f64() * 1e3
        ))
    );
    let info = pending_recovery_at(&recovery).unwrap().unwrap();
    assert_eq!(info.session_path.as_deref(), Some(session_file.as_path()));

    // 2. Relaunch and recover; Ctrl+S saves the recovered session to its own file.
    let log = dir.path().join("second.log");
    let mut app = launch(&display, dir.path(), &["--recover"], &log);
    let (id, window) = display.burnish_window(&mut app, &log);
    std::thread::sleep(Duration::from_secs(3));
    let saved_before = std::fs::metadata(&session_file)
        .unwrap()
        .modified()
        .unwrap();
    display.xdotool(&["windowfocus", &id]);
    std::thread::sleep(Duration::from_millis(300));
    display.xdotool(&["key", "--clearmodifiers", "ctrl+s"]);
    let saved = wait_for(Duration::from_secs(20), || {
        std::fs::metadata(&session_file)
            .and_then(|m| m.modified())
            .is_ok_and(|t| t != saved_before)
    });
    assert!(
        saved.is_some(),
        "Ctrl+S saved the recovered session:\n{}",
        read_log(&log)
    );
    let restored = Session::open(&session_file).unwrap();
    assert!(
        restored.views[0].paint == first,
        "recovery restored the stroke exactly as the recovery file held it"
    );

    // 3. A long stroke, killed with the button still down: what it painted more than a few
    // seconds before the kill is on disk already.
    let (sx0, sy) = at(window, 0.34, 0.50);
    let (sx1, _) = at(window, 0.48, 0.50);
    display.xdotool(&["mousemove", &sx0.to_string(), &sy.to_string()]);
    display.xdotool(&["mousedown", "1"]);
    let steps = 80;
    let started = Instant::now();
    let mut times = Vec::with_capacity(steps + 1);
    for i in 0..=steps {
        let x = sx0 + (sx1 - sx0) * i as i32 / steps as i32;
        display.xdotool(&["mousemove", &x.to_string(), &sy.to_string()]);
        times.push((x, started.elapsed()));
        std::thread::sleep(Duration::from_millis(100));
    }
    let killed_at = started.elapsed();
    drop(app); // SIGKILL, the button still down
    let last = recovered_paint(&recovery).expect("a readable recovery file");
    // The long stroke's own rows: those of the first stroke are left out.
    let side = last.colour.width;
    let rows_of = |p: &burnish::paint::PaintLayers| -> Vec<usize> {
        (0..side)
            .filter(|&y| (0..side).any(|x| p.coverage[y * side + x] > 0.0))
            .collect()
    };
    let first_rows = rows_of(&first);
    let new_rows: Vec<usize> = rows_of(&last)
        .into_iter()
        .filter(|y| !first_rows.contains(y))
        .collect();
    assert!(
        !new_rows.is_empty(),
        "part of the stroke still under way was autosaved before the kill:\n{}",
        read_log(&log)
    );
    // How far it got on disk, in screen pixels: the first stroke gives the canvas scale
    // (its painted width is its screen length times the scale plus one brush diameter).
    let columns = painted_columns(&last, new_rows[0]..new_rows[new_rows.len() - 1] + 1);
    let first_columns =
        painted_columns(&first, first_rows[0]..first_rows[first_rows.len() - 1] + 1);
    let brush = restored.brush.size as f64; // in canvas pixels
    let scale = (first_columns.len() as f64 - brush).max(1.0) / (x1 - x0) as f64;
    let saved_screen = sx0 as f64 + (columns.len() as f64 - brush).max(0.0) / scale;
    let saved_time = times
        .iter()
        .find(|(x, _)| *x as f64 >= saved_screen)
        .map_or(killed_at, |(_, t)| *t);
    eprintln!(
        "long stroke: {:.1} s painted, killed with the button down; about {:.1} s of it lost",
        killed_at.as_secs_f64(),
        (killed_at.saturating_sub(saved_time)).as_secs_f64()
    );
}
