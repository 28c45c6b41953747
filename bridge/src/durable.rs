//! Atomic, durable file writes (`docs/architecture.md` §5): a crash or a power cut leaves either the
//! old file or the new one, never half of one.
//!
//! The bytes go to a temporary file in the same directory (its name starts with `.` and
//! ends with [`TEMP_SUFFIX`]), which is flushed to disk, renamed over the target, and
//! then the directory itself is flushed so the rename survives a power cut.
//! [`remove_temporaries`] clears what an interrupted write left behind.

use std::fs::{self, File};
use std::io::{self, Write};
use std::path::Path;

/// The end of every temporary file's name.
pub const TEMP_SUFFIX: &str = ".tmp";

/// Writes `bytes` to `dir/name` atomically and durably.
///
/// # Errors
/// Any I/O error; the target is then unchanged and the temporary file removed.
pub fn write_atomic(dir: &Path, name: &str, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(dir, name, |file| file.write_all(bytes))
}

/// Writes `dir/name` atomically and durably with what `write` writes into the
/// temporary file (a large file need not be in memory whole first).
///
/// # Errors
/// Any I/O error, `write`'s included; the target is then unchanged and the temporary
/// file removed.
pub fn write_atomic_with(
    dir: &Path,
    name: &str,
    write: impl FnOnce(&mut File) -> io::Result<()>,
) -> io::Result<()> {
    let mut random = [0u8; 8];
    getrandom::fill(&mut random).map_err(io::Error::other)?;
    let temp_name = format!(".{name}.{}{TEMP_SUFFIX}", hex(&random));
    let temp = dir.join(&temp_name);
    let result = (|| {
        let mut file = File::create_new(&temp)?;
        write(&mut file)?;
        file.sync_all()?;
        drop(file);
        fs::rename(&temp, dir.join(name))?;
        sync_dir(dir)
    })();
    if result.is_err() {
        // Best effort: the write failed already; a leftover is removed at the next start.
        let _ = fs::remove_file(&temp);
    }
    result
}

/// Removes `dir/name` durably.
///
/// # Errors
/// Any I/O error, including [`io::ErrorKind::NotFound`].
pub fn remove(dir: &Path, name: &str) -> io::Result<()> {
    fs::remove_file(dir.join(name))?;
    sync_dir(dir)
}

/// Deletes the temporary files an interrupted [`write_atomic`] left in `dir` (files
/// named `.<target>.<hex>.tmp`); returns how many. Other files, and directories, are
/// left alone.
///
/// # Errors
/// If the directory cannot be read or a temporary file cannot be removed.
pub fn remove_temporaries(dir: &Path) -> io::Result<usize> {
    let mut removed = 0;
    for entry in fs::read_dir(dir)? {
        let entry = entry?;
        let name = entry.file_name();
        if is_temporary(&name.to_string_lossy()) && entry.file_type()?.is_file() {
            fs::remove_file(entry.path())?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// Whether `name` is one of [`write_atomic`]'s temporary file names:
/// `.<target>.<hex>.tmp`.
pub fn is_temporary(name: &str) -> bool {
    let Some(inner) = name
        .strip_prefix('.')
        .and_then(|name| name.strip_suffix(TEMP_SUFFIX))
    else {
        return false;
    };
    inner.rsplit_once('.').is_some_and(|(target, random)| {
        !target.is_empty()
            && !random.is_empty()
            && random.bytes().all(|byte| byte.is_ascii_hexdigit())
    })
}

/// Flushes a directory's entries (creations, renames, removals) to disk.
fn sync_dir(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        // Windows cannot open a directory as a file; its renames are journaled.
        let _ = dir;
        Ok(())
    }
}

/// Lowercase hexadecimal of `bytes`.
pub fn hex(bytes: &[u8]) -> String {
    use std::fmt::Write as _;
    let mut text = String::with_capacity(bytes.len() * 2);
    for byte in bytes {
        // Writing to a String cannot fail.
        let _ = write!(text, "{byte:02x}");
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_replace_and_leave_no_temporaries() {
        let dir = tempfile::tempdir().expect("temp dir");
        write_atomic(dir.path(), "a.json", b"one").expect("write");
        write_atomic(dir.path(), "a.json", b"two").expect("rewrite");
        assert_eq!(fs::read(dir.path().join("a.json")).expect("read"), b"two");
        assert_eq!(fs::read_dir(dir.path()).expect("dir").count(), 1);
    }

    #[test]
    fn leftover_temporaries_are_removed() {
        let dir = tempfile::tempdir().expect("temp dir");
        fs::write(dir.path().join(".a.json.0011.tmp"), b"half").expect("write");
        fs::write(dir.path().join("b.json"), b"whole").expect("write");
        assert_eq!(remove_temporaries(dir.path()).expect("clean"), 1);
        assert_eq!(fs::read_dir(dir.path()).expect("dir").count(), 1);
    }

    #[test]
    fn only_write_atomic_temporaries_are_recognised() {
        assert!(is_temporary(".playlist.json.00112233aabbccdd.tmp"));
        assert!(is_temporary(".password.0a.tmp"));
        for name in [
            "playlist.json.0011.tmp",
            ".notes.tmp",
            ".a.json.xyz.tmp",
            "..0011.tmp",
            ".a.json.0011",
            ".tmp",
        ] {
            assert!(!is_temporary(name), "{name}");
        }
        let dir = tempfile::tempdir().expect("temp dir");
        fs::create_dir(dir.path().join(".d.0011.tmp")).expect("mkdir");
        fs::write(dir.path().join(".notes.tmp"), b"mine").expect("write");
        assert_eq!(remove_temporaries(dir.path()).expect("clean"), 0);
        assert_eq!(fs::read_dir(dir.path()).expect("dir").count(), 2);
    }

    #[test]
    fn a_failed_write_leaves_the_target_alone() {
        let dir = tempfile::tempdir().expect("temp dir");
        write_atomic(dir.path(), "a.json", b"old").expect("write");
        // Renaming a file over a non-empty directory fails.
        fs::create_dir(dir.path().join("d")).expect("mkdir");
        fs::write(dir.path().join("d").join("x"), b"x").expect("write");
        assert!(write_atomic(dir.path(), "d", b"new").is_err());
        assert_eq!(fs::read(dir.path().join("a.json")).expect("read"), b"old");
        assert_eq!(remove_temporaries(dir.path()).expect("clean"), 0);
    }

    #[test]
    fn hex_is_lowercase_pairs() {
        assert_eq!(hex(&[0x00, 0xab, 0x7f]), "00ab7f");
    }
}
