//! Child processes with a time limit, and scratch folders that remove themselves.

use std::io::Read;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What a finished command returned.
pub struct Finished {
    /// The exit code; minus the signal's number when a signal ended it (Python's
    /// `returncode`, which the regression lines quote).
    pub code: i32,
    /// Its standard output, as text.
    pub stdout: String,
    /// Its standard error, as text.
    pub stderr: String,
}

/// Runs `command` (program and arguments) to its end, capturing both outputs. None when it
/// ran longer than `limit`: it is then killed (SIGKILL) and reaped. An error when it cannot
/// be started.
pub fn run_limited(command: &[String], limit: Duration) -> std::io::Result<Option<Finished>> {
    let mut child = Command::new(&command[0])
        .args(&command[1..])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    let stdout = drain(child.stdout.take());
    let stderr = drain(child.stderr.take());
    let status = wait_until(&mut child, Instant::now() + limit)?;
    let stdout = stdout.join().unwrap_or_default();
    let stderr = stderr.join().unwrap_or_default();
    Ok(status.map(|status| Finished {
        code: code_of(status),
        stdout,
        stderr,
    }))
}

/// The exit code, or minus the number of the signal that ended the process.
pub fn code_of(status: ExitStatus) -> i32 {
    status
        .code()
        .unwrap_or_else(|| -status.signal().unwrap_or(0))
}

fn drain<R: Read + Send + 'static>(pipe: Option<R>) -> JoinHandle<String> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(mut pipe) = pipe {
            let _ = pipe.read_to_end(&mut bytes);
        }
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

/// Waits for the child until `deadline`; past it kills and reaps it and returns None.
fn wait_until(child: &mut Child, deadline: Instant) -> std::io::Result<Option<ExitStatus>> {
    let mut pause = Duration::from_millis(1);
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(Some(status));
        }
        let now = Instant::now();
        if now >= deadline {
            let _ = child.kill();
            child.wait()?;
            return Ok(None);
        }
        std::thread::sleep(pause.min(deadline - now));
        pause = (pause * 2).min(Duration::from_millis(20));
    }
}

/// A new empty folder in the system's temporary folder, removed with everything in it when
/// dropped.
pub struct Scratch {
    path: PathBuf,
}

impl Scratch {
    /// Creates `<temp>/<prefix><unique>`.
    pub fn new(prefix: &str) -> std::io::Result<Scratch> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let base = std::env::temp_dir();
        loop {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_nanos());
            let unique = format!(
                "{prefix}{}-{}-{nanos:08x}",
                std::process::id(),
                COUNTER.fetch_add(1, Ordering::Relaxed)
            );
            let path = base.join(unique);
            match std::fs::create_dir(&path) {
                Ok(()) => return Ok(Scratch { path }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(e),
            }
        }
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Copies the tree `from` to `to` (created with its parents), following symbolic links, as
/// Python's `shutil.copytree` does by default.
pub fn copy_tree(from: &Path, to: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let source = entry.path();
        let target = to.join(entry.file_name());
        if source.is_dir() {
            copy_tree(&source, &target)?;
        } else {
            std::fs::copy(&source, &target)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn command(words: &[&str]) -> Vec<String> {
        words.iter().map(|w| w.to_string()).collect()
    }

    #[test]
    fn outputs_and_codes_are_captured_and_a_slow_child_is_stopped() {
        let done = run_limited(
            &command(&["sh", "-c", "echo out; echo err >&2; exit 3"]),
            Duration::from_secs(20),
        )
        .unwrap()
        .unwrap();
        assert_eq!(
            (done.code, done.stdout.as_str(), done.stderr.as_str()),
            (3, "out\n", "err\n")
        );
        let killed = run_limited(
            &command(&["sh", "-c", "kill -SEGV $$"]),
            Duration::from_secs(20),
        )
        .unwrap()
        .unwrap();
        assert_eq!(killed.code, -11);
        let start = Instant::now();
        let slow = run_limited(&command(&["sleep", "30"]), Duration::from_millis(200)).unwrap();
        assert!(slow.is_none());
        assert!(start.elapsed() < Duration::from_secs(10));
    }

    #[test]
    fn a_scratch_folder_goes_when_dropped() {
        let path = {
            let scratch = Scratch::new("xtask-test-").unwrap();
            std::fs::write(scratch.path().join("a"), "x").unwrap();
            scratch.path().to_path_buf()
        };
        assert!(!path.exists());
    }
}
