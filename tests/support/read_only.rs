//! A folder that can't be written, for real: its mode is set to read-only, and where the
//! tests run as root (which ignores modes) the thread running the check gives up the
//! capabilities that let it override them. Shared by the test binaries that need it.
#![allow(dead_code)]

use std::path::Path;

/// Runs `check` on a thread of its own (and the threads it starts) that can't create,
/// replace or remove files in `dir`; `dir` is writable again afterwards. Fails when the
/// folder turns out writable after all, so that no test passes without the fault.
pub fn with_read_only_dir<T: Send>(dir: &Path, check: impl FnOnce() -> T + Send) -> T {
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(dir).unwrap().permissions().mode();
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o555)).unwrap();
    let outcome = std::thread::scope(|scope| {
        scope
            .spawn(|| {
                drop_file_capabilities();
                let probe = dir.join(".write-probe");
                assert!(
                    std::fs::File::create(&probe).is_err(),
                    "{} is still writable: the fault would not happen",
                    dir.display()
                );
                check()
            })
            .join()
    });
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(mode)).unwrap();
    outcome.unwrap_or_else(|panic| std::panic::resume_unwind(panic))
}

/// Removes CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH from the calling thread's effective
/// capabilities (capabilities are per thread on Linux; threads it starts inherit them). A
/// no-op for a process that doesn't have them (not root).
#[cfg(target_os = "linux")]
fn drop_file_capabilities() {
    #[repr(C)]
    struct Header {
        version: u32,
        pid: i32,
    }
    #[repr(C)]
    #[derive(Clone, Copy, Default)]
    struct Data {
        effective: u32,
        permitted: u32,
        inheritable: u32,
    }
    const VERSION_3: u32 = 0x2008_0522;
    const CAP_DAC_OVERRIDE: u32 = 1;
    const CAP_DAC_READ_SEARCH: u32 = 2;
    let mut header = Header {
        version: VERSION_3,
        pid: 0,
    };
    let mut data = [Data::default(); 2];
    // SAFETY: capget/capset with a version-3 header read and write two `Data` records, which
    // `data` holds; pid 0 is the calling thread.
    unsafe {
        assert_eq!(
            libc::syscall(libc::SYS_capget, &mut header, data.as_mut_ptr()),
            0,
            "capget"
        );
        data[0].effective &= !((1 << CAP_DAC_OVERRIDE) | (1 << CAP_DAC_READ_SEARCH));
        assert_eq!(
            libc::syscall(libc::SYS_capset, &mut header, data.as_ptr()),
            0,
            "capset"
        );
    }
}

#[cfg(not(target_os = "linux"))]
fn drop_file_capabilities() {}
