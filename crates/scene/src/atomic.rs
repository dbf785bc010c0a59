//! Writing a file so that a reader never finds a partial one under its final
//! name: the bytes go to a temporary file beside it (`.NAME.tmpPID`), synced,
//! then renamed into place; on error the temporary file is removed. The one
//! implementation every crate's writers use (glTF, checkpoints, JSON, PNGs,
//! and the streaming [`temp_path`] users).

use std::io::Write;
use std::path::{Path, PathBuf};

/// The temporary name beside `path` that its writer renames into place.
///
/// # Errors
/// `InvalidInput` when `path` names no file.
pub fn temp_path(path: &Path) -> std::io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{} is not a file path", path.display()),
        )
    })?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp{}", std::process::id()));
    Ok(path.with_file_name(tmp_name))
}

/// Writes `bytes` to `path` through [`temp_path`].
///
/// # Errors
/// The I/O error of creating, writing, syncing or renaming; no file is left
/// under either name then.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = temp_path(path)?;
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    };
    write().inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}
