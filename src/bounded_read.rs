//! Reading whole files with a bound: a file far larger than any valid one of its kind is
//! refused by its length, never read into memory.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// The file's bytes, refused (naming the file, what it should be and its size) when it is
/// longer than `limit` bytes.
pub fn read_at_most(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let too_long = |len: u64| {
        Error::invalid(
            path,
            format!("{len} bytes is more than {what} can be (at most {limit} bytes)"),
        )
    };
    if len > limit {
        return Err(too_long(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    // The length may have grown since it was asked (or be unknown, as for a pipe).
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(too_long(bytes.len() as u64));
    }
    Ok(bytes)
}

/// [`read_at_most`] as UTF-8 text.
pub fn read_text_at_most(path: &Path, limit: u64, what: &str) -> Result<String> {
    String::from_utf8(read_at_most(path, limit, what)?)
        .map_err(|e| Error::invalid(path, format!("not UTF-8 text ({e})")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_over_the_limit_is_refused_by_its_length() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        std::fs::write(&path, vec![b'#'; 101]).unwrap();
        let err = read_at_most(&path, 100, "a scene file")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("big.toml") && err.contains("101 bytes") && err.contains("a scene file"),
            "{err}"
        );
        assert_eq!(read_at_most(&path, 101, "a scene").unwrap().len(), 101);
        std::fs::write(&path, [0xff, 0xfe]).unwrap();
        let err = read_text_at_most(&path, 100, "a scene")
            .unwrap_err()
            .to_string();
        assert!(err.contains("UTF-8"), "{err}");
    }
}
