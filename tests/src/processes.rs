//! The processes a test starts, and every process they start in turn, ended when the
//! test ends — also when it fails or panics.
//!
//! A [`ProcessTree`] starts its program in a process group of its own and, when it
//! is dropped (or [`ProcessTree::end`] is called), kills the whole tree: the program,
//! every process of its group, every descendant of it found in `/proc`, and every
//! process whose command line names the tree's marker (a browser's profile
//! directory), so a process that left the group and lost its parent is found too.
//! The tree is first frozen (`SIGSTOP`: a stopped process starts no more), looked
//! over again until nothing new appears, then killed (`SIGKILL`); the drop waits until
//! every process is gone, then removes the tree's temporary directory.
//!
//! ChromeDriver alone is not enough to kill: the Chromium it starts outlives it, with
//! some 300 MB each and its profile in the temporary directory, and a WebDriver
//! session's `close()` never runs when the test panics before it.
//!
//! The functions below read `/proc` (Linux): [`descendants`], [`mentioning`] and
//! [`is_alive`] let a test check that what it started has ended.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::{Duration, Instant};

use tokio::process::{Child, Command};

/// How long [`ProcessTree::end`] waits for the killed processes to be gone.
const END_TIMEOUT_MS: u64 = 5_000;

/// How often [`ProcessTree::end`] looks again while it waits.
const POLL_INTERVAL_MS: u64 = 10;

/// A started program and every process it starts; all killed when dropped, then its
/// temporary directory (if it owns one) removed. See the module doc.
#[derive(Debug)]
pub struct ProcessTree {
    child: Child,
    /// The program's pid, which is also its process group's id.
    pid: u32,
    /// Text in the command line of every process of the tree (an absolute path that
    /// only this tree uses), if there is such a text.
    marker: Option<String>,
    /// Removed once every process has ended.
    dir: Option<tempfile::TempDir>,
    ended: bool,
}

impl ProcessTree {
    /// Starts `command` in a process group of its own. `marker`: see
    /// [`ProcessTree::with_marker`]; `dir`: removed after the processes have ended.
    ///
    /// # Errors
    /// The program could not be started.
    pub fn spawn(
        command: &mut Command,
        marker: Option<String>,
        dir: Option<tempfile::TempDir>,
    ) -> std::io::Result<Self> {
        let child = command.process_group(0).kill_on_drop(true).spawn()?;
        let pid = child
            .id()
            .ok_or_else(|| std::io::Error::other("the child has no pid"))?;
        Ok(Self {
            child,
            pid,
            marker,
            dir,
            ended: false,
        })
    }

    /// The program's pid.
    pub fn pid(&self) -> u32 {
        self.pid
    }

    /// The started program, e.g. to take its output.
    pub fn child_mut(&mut self) -> &mut Child {
        &mut self.child
    }

    /// The tree's temporary directory, if it owns one.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_ref().map(tempfile::TempDir::path)
    }

    /// The pids of the tree's processes that are alive now: the program, its
    /// process group, its descendants, and those whose command line has the marker.
    pub fn members(&self) -> BTreeSet<u32> {
        if self.ended {
            return BTreeSet::new();
        }
        members(self.pid, self.marker.as_deref())
    }

    /// Kills every process of the tree and waits (up to a few seconds) until they
    /// are gone; removes the temporary directory. Does nothing the second time.
    pub fn end(&mut self) {
        if self.ended {
            return;
        }
        let mut frozen = BTreeSet::new();
        // Freeze until a look finds nothing new: a stopped process forks no more.
        loop {
            let found = members(self.pid, self.marker.as_deref());
            let new: Vec<u32> = found.difference(&frozen).copied().collect();
            if new.is_empty() {
                break;
            }
            for pid in new {
                signal(pid, libc::SIGSTOP);
                frozen.insert(pid);
            }
        }
        // The group's id is the program's pid, which stays ours until `try_wait`
        // reaps it below: this signal cannot reach an unrelated group.
        // SAFETY: `killpg` only sends a signal; a group that is gone gives ESRCH.
        unsafe {
            libc::killpg(pid_t(self.pid), libc::SIGKILL);
        }
        let deadline = Instant::now() + Duration::from_millis(END_TIMEOUT_MS);
        loop {
            for &pid in &frozen {
                signal(pid, libc::SIGKILL);
            }
            let _ = self.child.start_kill();
            let _ = self.child.try_wait();
            let alive = members(self.pid, self.marker.as_deref());
            let frozen_alive = frozen.iter().any(|&pid| is_alive(pid));
            if alive.is_empty() && !frozen_alive {
                break;
            }
            if Instant::now() >= deadline {
                eprintln!(
                    "floatball-e2e: processes of {} still alive after {END_TIMEOUT_MS} ms: {alive:?}",
                    self.pid
                );
                break;
            }
            frozen.extend(alive);
            std::thread::sleep(Duration::from_millis(POLL_INTERVAL_MS));
        }
        self.ended = true;
        if let Some(dir) = self.dir.take() {
            let path = dir.path().to_path_buf();
            if dir.close().is_err() && std::fs::remove_dir_all(&path).is_err() && path.exists() {
                eprintln!("floatball-e2e: cannot remove {}", path.display());
            }
        }
    }
}

impl Drop for ProcessTree {
    fn drop(&mut self) {
        self.end();
    }
}

fn pid_t(pid: u32) -> libc::pid_t {
    libc::pid_t::try_from(pid).unwrap_or(libc::pid_t::MAX)
}

/// Kills `pid` (`SIGKILL`), never this process; a process that is gone is no error.
pub fn kill(pid: u32) {
    signal(pid, libc::SIGKILL);
}

/// Sends `signal` to `pid`, never to this process.
fn signal(pid: u32, signal: libc::c_int) {
    if pid == std::process::id() || pid <= 1 {
        return;
    }
    // SAFETY: `kill` only sends a signal; a process that is gone gives ESRCH.
    unsafe {
        libc::kill(pid_t(pid), signal);
    }
}

/// What `/proc/<pid>/stat` says of a process.
#[derive(Debug, Clone, Copy)]
struct Stat {
    ppid: u32,
    pgid: u32,
    /// `Z` (zombie) or `X` (dead): ended, only not yet reaped.
    ended: bool,
}

/// `/proc/<pid>/stat`: `pid (comm) state ppid pgrp …`; the name may hold spaces and
/// parentheses, so the fields are read after its last `)`.
fn stat(pid: u32) -> Option<Stat> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let (_, rest) = text.rsplit_once(')')?;
    let mut fields = rest.split_whitespace();
    let state = fields.next()?;
    let ppid = fields.next()?.parse().ok()?;
    let pgid = fields.next()?.parse().ok()?;
    Some(Stat {
        ppid,
        pgid,
        ended: matches!(state, "Z" | "X"),
    })
}

/// Every process's stat, by pid.
fn all_processes() -> BTreeMap<u32, Stat> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return BTreeMap::new();
    };
    entries
        .filter_map(Result::ok)
        .filter_map(|entry| entry.file_name().to_str()?.parse::<u32>().ok())
        .filter_map(|pid| Some((pid, stat(pid)?)))
        .collect()
}

/// The command line of `pid`, its arguments joined by spaces (empty if it is gone).
pub fn command_line(pid: u32) -> String {
    std::fs::read(format!("/proc/{pid}/cmdline"))
        .map(|bytes| {
            String::from_utf8_lossy(&bytes)
                .split('\0')
                .filter(|arg| !arg.is_empty())
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_default()
}

/// Whether `pid` is running (a zombie, ended but not yet reaped, is not).
pub fn is_alive(pid: u32) -> bool {
    stat(pid).is_some_and(|stat| !stat.ended)
}

/// The pids of the living processes whose command line contains `text`, never this
/// process.
pub fn mentioning(text: &str) -> BTreeSet<u32> {
    let me = std::process::id();
    all_processes()
        .into_iter()
        .filter(|(pid, stat)| !stat.ended && *pid != me && command_line(*pid).contains(text))
        .map(|(pid, _)| pid)
        .collect()
}

/// The pids of the living descendants of `pid` (children, their children…).
pub fn descendants(pid: u32) -> BTreeSet<u32> {
    let processes = all_processes();
    let mut found = BTreeSet::new();
    add_descendants(&processes, &mut found, &[pid]);
    found
}

/// Adds to `found` the living descendants of `roots` among `processes`.
fn add_descendants(processes: &BTreeMap<u32, Stat>, found: &mut BTreeSet<u32>, roots: &[u32]) {
    let mut children: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for (&pid, stat) in processes {
        children.entry(stat.ppid).or_default().push(pid);
    }
    let mut queue: Vec<u32> = roots.to_vec();
    while let Some(parent) = queue.pop() {
        for &child in children.get(&parent).into_iter().flatten() {
            if !processes[&child].ended && found.insert(child) {
                queue.push(child);
            }
        }
    }
}

/// The living processes of the tree of `root` (see [`ProcessTree::members`]), never
/// this process.
fn members(root: u32, marker: Option<&str>) -> BTreeSet<u32> {
    let processes = all_processes();
    let me = std::process::id();
    let mut found: BTreeSet<u32> = processes
        .iter()
        .filter(|(pid, stat)| {
            !stat.ended
                && (**pid == root
                    || stat.pgid == root
                    || marker.is_some_and(|marker| command_line(**pid).contains(marker)))
        })
        .map(|(pid, _)| *pid)
        .collect();
    let roots: Vec<u32> = found.iter().copied().collect();
    add_descendants(&processes, &mut found, &roots);
    found.remove(&me);
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shell that starts a child which stays in its group, and an orphan which left
    /// it (`setsid`, its parent gone) with a child of its own: dropping the tree ends
    /// all of them, and its directory is removed.
    #[tokio::test]
    async fn a_dropped_tree_ends_every_process_and_removes_its_directory() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().to_path_buf();
        let marker = path.join("marker").display().to_string();
        let script = format!(
            "(setsid sh -c 'sleep 300; true' {marker} </dev/null >/dev/null 2>&1 &); \
             sleep 301 & echo started; wait"
        );
        let mut command = Command::new("sh");
        command
            .args(["-c", &script])
            .stdout(std::process::Stdio::piped());
        let mut tree = ProcessTree::spawn(&mut command, Some(marker), Some(dir)).expect("spawn");
        let stdout = tree.child_mut().stdout.take().expect("stdout");
        let mut lines = tokio::io::AsyncBufReadExt::lines(tokio::io::BufReader::new(stdout));
        assert_eq!(
            lines.next_line().await.expect("read").as_deref(),
            Some("started")
        );
        let deadline = Instant::now() + Duration::from_secs(5);
        let pids = loop {
            let pids = tree.members();
            if pids.len() >= 4 || Instant::now() > deadline {
                break pids;
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        };
        assert!(pids.len() >= 4, "{pids:?}");
        drop(tree);
        for pid in pids {
            assert!(!is_alive(pid), "{pid} ({}) is alive", command_line(pid));
        }
        assert!(!path.exists());
    }

    #[test]
    fn this_process_is_alive_and_not_its_own_descendant() {
        let me = std::process::id();
        assert!(is_alive(me));
        assert!(!descendants(me).contains(&me));
        assert!(!command_line(me).is_empty());
        assert!(!mentioning(&command_line(me)).contains(&me));
    }
}
