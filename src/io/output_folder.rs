//! The output folder of a run: made ready before any work starts, and the free space on its
//! file system.
//!
//! `--output-dir` names a folder that need not exist yet: like `mkdir -p`, the run creates it
//! with its missing parents. Peridigm has no such option: it creates each results file where
//! its `Output Filename` says and stops with an Exodus error code when that folder is missing
//! or unwritable, after the whole setup. peridyn checks the folder before the mesh is
//! searched, by creating and removing a probe file in it, so a folder it cannot write to is a
//! clear error at once (exit code [`EXIT_CODE`]) instead of a failure after the setup.

use std::path::{Path, PathBuf};

/// Exit code of a run whose output folder cannot be created or written to (nothing was
/// written).
pub const EXIT_CODE: u8 = 5;

/// Why the output folder cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// Creating the folder (or one of its parents) failed.
    #[error("cannot create the output folder {path}: {source}. Give --output-dir a folder you can write to")]
    Create {
        /// The folder.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// The folder exists but a file cannot be created in it.
    #[error("the output folder {path} is not writable: {source}. Make it writable (chmod u+w) or give --output-dir another folder")]
    NotWritable {
        /// The folder.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
}

/// Creates `dir` with its parents when missing and checks that a file can be created in it
/// (a probe file, removed at once).
pub fn prepare(dir: &Path) -> Result<(), FolderError> {
    std::fs::create_dir_all(dir).map_err(|source| FolderError::Create {
        path: dir.to_path_buf(),
        source,
    })?;
    let probe = dir.join(format!(".peridyn-write-probe-{}", std::process::id()));
    let not_writable = |source| FolderError::NotWritable {
        path: dir.to_path_buf(),
        source,
    };
    std::fs::File::create(&probe).map_err(not_writable)?;
    std::fs::remove_file(&probe).map_err(not_writable)
}

/// Bytes an unprivileged user may still write on the file system that holds `dir` (or, when
/// `dir` does not exist yet, its nearest existing parent): `statvfs`'s available blocks times
/// the fragment size. `None` where the system cannot say.
pub fn available_bytes(dir: &Path) -> Option<u64> {
    let absolute = std::path::absolute(dir).ok()?;
    let existing = absolute.ancestors().find(|p| p.exists())?;
    free_space(existing)
}

#[cfg(unix)]
fn free_space(path: &Path) -> Option<u64> {
    let stat = rustix::fs::statvfs(path).ok()?;
    stat.f_bavail.checked_mul(stat.f_frsize)
}

#[cfg(not(unix))]
fn free_space(_path: &Path) -> Option<u64> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_folder_is_created_with_its_parents() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("a/b/c");
        prepare(&target).unwrap();
        assert!(target.is_dir());
        assert_eq!(
            std::fs::read_dir(&target).unwrap().count(),
            0,
            "probe removed"
        );
    }

    #[test]
    fn a_folder_under_a_file_cannot_be_created() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("file"), b"x").unwrap();
        let error = prepare(&dir.path().join("file/out")).unwrap_err();
        assert!(matches!(error, FolderError::Create { .. }), "{error}");
        assert!(error.to_string().contains("--output-dir"), "{error}");
    }

    #[cfg(unix)]
    #[test]
    fn free_space_is_found_for_a_folder_not_yet_made() {
        let dir = tempfile::tempdir().unwrap();
        let here = available_bytes(dir.path()).expect("statvfs answers on the temp folder");
        let later = available_bytes(&dir.path().join("not/yet")).expect("parent's file system");
        // Same file system, read moments apart: other processes may write in between, so only
        // the order of magnitude is compared.
        assert!(here > 0 && later > 0);
        assert!(later <= here.saturating_mul(2) && here <= later.saturating_mul(2));
    }
}
