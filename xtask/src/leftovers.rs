//! What a test stage leaves running when it ends.
//!
//! [`Watch::start`] notes the processes of the kinds the tests start — Chromium and
//! its helpers, ChromeDriver, `ser2net`, `olad`, `oscdump`, and the `floatball`
//! binaries of this target directory — that already run; [`Watch::finish`], at the
//! end of the stage, looks for those that were not there before. Any it finds (after
//! a short grace for processes that are just exiting) are named with their pid and
//! command line, killed so the next stage starts clean, and fail the stage.
//!
//! It also removes what Chromium left in the temporary directory during the stage
//! (its `.org.chromium.Chromium.*` folders, and `.tmp*` folders holding a profile),
//! saying how much: a note, not a failure.
//!
//! Only this run's processes count: those in the session `cargo xtask` runs in, or
//! carrying its mark in their environment ([`RUN_MARK`], which every process the
//! xtask starts inherits; it survives a `setsid`, and Chromium's zygote, which clears
//! its environment, stays in the session). A browser or a test run of someone else's
//! on the same machine is neither killed nor reported, and a Chromium folder some
//! running process still uses is not removed.
//!
//! Processes are read from `/proc` (Linux); a process is known by its pid and start
//! time, so a pid used again is not taken for the old process.

use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::tools::Env;

/// How long processes that are exiting by themselves get before they count as left.
const GRACE_MS: u64 = 2_000;

/// How often the grace and the killing look again.
const POLL_INTERVAL_MS: u64 = 100;

/// How long the killing may take before the stage reports the survivors.
const KILL_TIMEOUT_MS: u64 = 5_000;

/// How much of a command line a report shows.
const COMMAND_LINE_CHARS: usize = 240;

/// Programs (file names, or the start of one) the test stages start.
const WATCHED_PROGRAMS: [&str; 4] = ["ser2net", "olad", "oscdump", "oscsend"];

/// The environment variable that marks the processes of one `cargo xtask` run: the
/// pid of the outermost xtask, set by [`mark_this_run`].
pub const RUN_MARK: &str = "FLOATBALL_XTASK_RUN";

/// Marks this run: sets [`RUN_MARK`] (unless an outer xtask set it), which every
/// process started from here inherits.
///
/// # Safety
/// Call it before any thread is started (it changes the process's environment).
pub unsafe fn mark_this_run() {
    if std::env::var_os(RUN_MARK).is_none() {
        // SAFETY: the caller guarantees no other thread runs yet.
        unsafe { std::env::set_var(RUN_MARK, std::process::id().to_string()) };
    }
}

/// Whose processes a [`Watch`] looks at: this run's (see the module doc).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Owner {
    /// The session this xtask runs in.
    session: Option<u32>,
    /// `RUN_MARK=<value>`, as it appears in a marked process's environment.
    mark: Option<Vec<u8>>,
}

impl Owner {
    /// This process's session and mark.
    fn this_run() -> Self {
        let session = read_process(std::process::id()).and_then(|me| me.session);
        let mark = std::env::var(RUN_MARK)
            .ok()
            .map(|value| format!("{RUN_MARK}={value}").into_bytes());
        Self { session, mark }
    }

    /// Whether `process` is this run's: in its session, or marked.
    fn owns(&self, process: &Process) -> bool {
        if self.session.is_some() && process.session == self.session {
            return true;
        }
        let Some(mark) = &self.mark else {
            return false;
        };
        std::fs::read(format!("/proc/{}/environ", process.pid)).is_ok_and(|environ| {
            environ
                .split(|&byte| byte == 0)
                .any(|variable| variable == mark.as_slice())
        })
    }
}

/// A process as `/proc` shows it.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Process {
    pid: u32,
    /// Clock ticks after boot: with the pid, names the process for good.
    start_ticks: u64,
    /// Its session (field 6 of `/proc/<pid>/stat`).
    session: Option<u32>,
    /// Its arguments, `argv[0]` first.
    args: Vec<String>,
    /// Where its executable is (`/proc/<pid>/exe`), if readable.
    exe: Option<PathBuf>,
}

impl Process {
    fn key(&self) -> (u32, u64) {
        (self.pid, self.start_ticks)
    }

    /// The command line, shortened for a report.
    fn describe(&self) -> String {
        let line = self.args.join(" ");
        if line.chars().count() <= COMMAND_LINE_CHARS {
            line
        } else {
            let short: String = line.chars().take(COMMAND_LINE_CHARS).collect();
            format!("{short}…")
        }
    }
}

/// Which processes a [`Watch`] watches (given the target directory).
type Kinds = fn(&Process, &Path) -> bool;

/// The processes (and temporary folders) there were when a stage began.
#[derive(Debug)]
pub struct Watch {
    target_dir: PathBuf,
    kinds: Kinds,
    owner: Owner,
    before: BTreeSet<(u32, u64)>,
    temp_before: BTreeSet<OsString>,
}

impl Watch {
    /// Notes what runs (and what is in the temporary directory) now.
    pub fn start(env: &Env) -> Self {
        Self::start_for(env.target_dir.clone(), is_watched)
    }

    /// [`Watch::start`] for the processes that `kinds` picks.
    fn start_for(target_dir: PathBuf, kinds: Kinds) -> Self {
        let owner = Owner::this_run();
        let before = watched(&target_dir, kinds, &owner)
            .iter()
            .map(Process::key)
            .collect();
        Self {
            target_dir,
            kinds,
            owner,
            before,
            temp_before: temp_entries(),
        }
    }

    /// Fails naming the watched processes started since [`Watch::start`] that still
    /// run, after killing them; removes what Chromium left in the temporary
    /// directory.
    ///
    /// # Errors
    /// Which processes were left running (pid and command line).
    pub fn finish(self) -> Result<(), String> {
        let result = self.finish_processes();
        self.finish_temp();
        result
    }

    fn new_processes(&self) -> Vec<Process> {
        watched(&self.target_dir, self.kinds, &self.owner)
            .into_iter()
            .filter(|process| !self.before.contains(&process.key()))
            .collect()
    }

    fn finish_processes(&self) -> Result<(), String> {
        let mut left = self.new_processes();
        let grace_end = Instant::now() + Duration::from_millis(GRACE_MS);
        while !left.is_empty() && Instant::now() < grace_end {
            std::thread::sleep(Duration::from_millis(POLL_INTERVAL_MS));
            left = self.new_processes();
        }
        if left.is_empty() {
            return Ok(());
        }
        println!(
            "xtask: {} process(es) started in this stage still run; killing them:",
            left.len()
        );
        for process in &left {
            println!("  {} {}", process.pid, process.describe());
        }
        let kill_end = Instant::now() + Duration::from_millis(KILL_TIMEOUT_MS);
        let mut survivors = left.clone();
        while !survivors.is_empty() && Instant::now() < kill_end {
            for process in &survivors {
                kill(process.pid);
            }
            std::thread::sleep(Duration::from_millis(POLL_INTERVAL_MS));
            survivors = self.new_processes();
        }
        for process in &survivors {
            println!(
                "xtask: could not kill {} {}",
                process.pid,
                process.describe()
            );
        }
        Err(format!(
            "left {} process(es) running (killed): {}",
            left.len(),
            left.iter()
                .map(|process| format!("{} {}", process.pid, process.describe()))
                .collect::<Vec<_>>()
                .join("; ")
        ))
    }

    fn finish_temp(&self) {
        let temp = std::env::temp_dir();
        let mut removed_bytes = 0;
        let mut removed = Vec::new();
        for name in temp_entries().difference(&self.temp_before) {
            let path = temp.join(name);
            if !is_chromium_leftover(&path) || in_use(&path) {
                continue;
            }
            let bytes = size_of(&path);
            if std::fs::remove_dir_all(&path).is_ok() {
                removed_bytes += bytes;
                removed.push(name.to_string_lossy().into_owned());
            }
        }
        if !removed.is_empty() {
            println!(
                "xtask: note: removed {:.1} MB that Chromium left in {}: {}",
                removed_bytes as f64 / 1e6,
                temp.display(),
                removed.join(", ")
            );
        }
    }
}

/// The running processes of `owner` (not zombies, never this one) that `kinds`
/// picks.
fn watched(target_dir: &Path, kinds: Kinds, owner: &Owner) -> Vec<Process> {
    let me = std::process::id();
    pids()
        .into_iter()
        .filter(|&pid| pid != me)
        .filter_map(read_process)
        .filter(|process| kinds(process, target_dir) && owner.owns(process))
        .collect()
}

/// The pids in `/proc`.
fn pids() -> Vec<u32> {
    std::fs::read_dir("/proc")
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .filter_map(|entry| entry.file_name().to_str()?.parse::<u32>().ok())
                .collect()
        })
        .unwrap_or_default()
}

/// Whether a running process (anyone's) names `dir` on its command line or has a
/// file under it open.
fn in_use(dir: &Path) -> bool {
    let named = dir.to_string_lossy().into_owned();
    pids().into_iter().any(|pid| {
        let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        if String::from_utf8_lossy(&cmdline).contains(named.as_str()) {
            return true;
        }
        std::fs::read_dir(format!("/proc/{pid}/fd")).is_ok_and(|fds| {
            fds.filter_map(Result::ok)
                .filter_map(|fd| std::fs::read_link(fd.path()).ok())
                .any(|target| target.starts_with(dir))
        })
    })
}

/// The process `pid`, unless it is gone or a zombie.
fn read_process(pid: u32) -> Option<Process> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let start_ticks = start_ticks(&stat)?;
    let session = session(&stat);
    let args: Vec<String> = std::fs::read(format!("/proc/{pid}/cmdline"))
        .ok()?
        .split(|&byte| byte == 0)
        .filter(|arg| !arg.is_empty())
        .map(|arg| String::from_utf8_lossy(arg).into_owned())
        .collect();
    let exe = std::fs::read_link(format!("/proc/{pid}/exe")).ok();
    Some(Process {
        pid,
        start_ticks,
        session,
        args,
        exe,
    })
}

/// Field 22 of `/proc/<pid>/stat` (`starttime`), unless the state (field 3) says the
/// process has ended (`Z`ombie, `X` dead). The fields are counted after the name's
/// last `)`: the name may hold spaces and parentheses.
fn start_ticks(stat: &str) -> Option<u64> {
    let (_, rest) = stat.rsplit_once(')')?;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    if matches!(fields.first(), Some(&("Z" | "X"))) {
        return None;
    }
    fields.get(19)?.parse().ok()
}

/// Field 6 of `/proc/<pid>/stat` (`session`), counted after the name's last `)`.
fn session(stat: &str) -> Option<u32> {
    let (_, rest) = stat.rsplit_once(')')?;
    rest.split_whitespace().nth(3)?.parse().ok()
}

/// Whether `process` is of a kind the tests start: Chromium (`chromium`, `chrome…`),
/// ChromeDriver, one of [`WATCHED_PROGRAMS`], or a `floatball` under `target_dir`.
fn is_watched(process: &Process, target_dir: &Path) -> bool {
    let paths = process
        .args
        .first()
        .map(PathBuf::from)
        .into_iter()
        .chain(process.exe.clone());
    paths.into_iter().any(|path| {
        let name = path
            .file_name()
            .map(|name| name.to_string_lossy().into_owned())
            .unwrap_or_default();
        // A binary rebuilt while it runs: `/proc/<pid>/exe` says `floatball (deleted)`.
        let floatball = name == "floatball" || name == "floatball (deleted)";
        name.starts_with("chrom")
            || WATCHED_PROGRAMS.contains(&name.as_str())
            || (floatball && path.starts_with(target_dir))
    })
}

fn kill(pid: u32) {
    let Ok(pid) = libc::pid_t::try_from(pid) else {
        return;
    };
    if pid <= 1 {
        return;
    }
    // SAFETY: `kill` only sends a signal; a process that is gone gives ESRCH.
    unsafe {
        libc::kill(pid, libc::SIGKILL);
    }
}

/// The names in the temporary directory.
fn temp_entries() -> BTreeSet<OsString> {
    std::fs::read_dir(std::env::temp_dir())
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|entry| entry.file_name())
                .collect()
        })
        .unwrap_or_default()
}

/// Whether the folder at `path` is Chromium's: one it makes itself
/// (`.org.chromium.Chromium.*`, `.com.google.Chrome.*`), or a temporary folder
/// (`.tmp*`, as the tests make them) that is a profile or holds one in `profile/`.
fn is_chromium_leftover(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|name| name.to_string_lossy().into_owned())
        .unwrap_or_default();
    if !path.is_dir() {
        return false;
    }
    name.starts_with(".org.chromium.Chromium.")
        || name.starts_with(".com.google.Chrome.")
        || (name.starts_with(".tmp") && (is_profile(path) || is_profile(&path.join("profile"))))
}

/// Whether `dir` is a Chromium profile (`--user-data-dir`), even one half removed
/// while Chromium still ran: it has `Local State` or the `Default` profile.
fn is_profile(dir: &Path) -> bool {
    dir.join("Local State").is_file() || dir.join("Default").is_dir()
}

/// The bytes of the files under `path` (links not followed).
fn size_of(path: &Path) -> u64 {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return 0;
    };
    if !meta.is_dir() {
        return meta.len();
    }
    std::fs::read_dir(path)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|entry| size_of(&entry.path()))
                .sum()
        })
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    use std::process::Command;

    fn process(args: &[&str], exe: Option<&str>) -> Process {
        Process {
            pid: 42,
            start_ticks: 7,
            session: Some(3),
            args: args.iter().map(|arg| (*arg).to_owned()).collect(),
            exe: exe.map(PathBuf::from),
        }
    }

    #[test]
    fn the_kinds_the_tests_start_are_watched() {
        let target = Path::new("/work/main/target");
        let watched = [
            process(
                &["/usr/lib/chromium/chromium", "--type=renderer"],
                Some("/usr/lib/chromium/chromium"),
            ),
            process(&["/usr/bin/chromedriver", "--port=1"], None),
            process(&["/usr/lib/chromium/chrome_crashpad_handler"], None),
            process(&["/work/main/target/debug/floatball", "--listen"], None),
            process(
                &["floatball"],
                Some("/work/main/target/debug/floatball (deleted)"),
            ),
            process(&["/usr/sbin/ser2net", "-n"], None),
            process(&["olad"], Some("/usr/bin/olad")),
        ];
        for process in &watched {
            assert!(is_watched(process, target), "{process:?}");
        }
        let unwatched = [
            process(&["/usr/bin/floatball"], Some("/usr/bin/floatball")),
            process(&["grep", "chromium"], Some("/usr/bin/grep")),
            process(&["/bin/bash"], Some("/usr/bin/bash")),
            process(&[], None),
        ];
        for process in &unwatched {
            assert!(!is_watched(process, target), "{process:?}");
        }
    }

    #[test]
    fn the_start_time_is_read_after_the_name() {
        let stat = "123 (a (b) c) S 1 123 123 0 -1 4194560 1 0 0 0 0 0 0 0 20 0 1 0 98765 1 1";
        assert_eq!(start_ticks(stat), Some(98765));
        assert_eq!(session(stat), Some(123));
        let zombie = "123 (x) Z 1 123 123 0 -1 4194560 1 0 0 0 0 0 0 0 20 0 1 0 98765 1 1";
        assert_eq!(start_ticks(zombie), None);
        assert_eq!(start_ticks("garbage"), None);
    }

    #[test]
    fn this_process_is_read_from_proc() {
        let me = read_process(std::process::id()).expect("this process");
        assert!(me.start_ticks > 0);
        assert!(!me.args.is_empty());
    }

    /// A process the watch picks, started after it began and left running, fails
    /// the watch (named) and is killed; one that ended in time does not.
    #[test]
    fn a_process_left_running_is_named_and_killed() {
        fn ours(process: &Process, _: &Path) -> bool {
            process
                .args
                .first()
                .is_some_and(|name| name == "floatball-xtask-leftover")
        }
        let target = std::env::temp_dir();
        let watch = Watch::start_for(target.clone(), ours);
        let mut quick = Command::new("bash")
            .args(["-c", "exec -a floatball-xtask-leftover sleep 0.2"])
            .spawn()
            .expect("bash");
        let mut left = Command::new("bash")
            .args(["-c", "exec -a floatball-xtask-leftover sleep 300"])
            .spawn()
            .expect("bash");
        std::thread::sleep(Duration::from_millis(100));
        // Reaped by a thread as it ends, as its parent would.
        let reaper = std::thread::spawn(move || quick.wait());
        // `finish_processes`, not `finish`: the temporary directory is not this test's.
        let error = watch
            .finish_processes()
            .expect_err("a process was left running");
        let pid = left.id();
        assert!(
            error.contains(&format!("{pid} floatball-xtask-leftover 300")),
            "{error}"
        );
        assert!(!error.contains("leftover 0.2"), "{error}");
        let status = left.wait().expect("wait");
        assert_eq!(
            std::os::unix::process::ExitStatusExt::signal(&status),
            Some(libc::SIGKILL)
        );
        reaper.join().expect("reaper").expect("wait");
        let watch = Watch::start_for(target, ours);
        assert_eq!(watch.finish_processes(), Ok(()));
    }

    /// Polls `done` every 20 ms for at most 5 s.
    fn eventually(done: impl Fn() -> bool) -> bool {
        let end = Instant::now() + Duration::from_secs(5);
        while Instant::now() < end {
            if done() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }

    /// A process in this session is this run's; one that left it (`setsid`) is this
    /// run's only if it carries the run's mark; another's is never.
    #[test]
    fn this_runs_processes_are_those_in_its_session_or_marked() {
        let value = format!("leftovers-test-{}", std::process::id());
        let owner = Owner {
            session: Owner::this_run().session,
            mark: Some(format!("{RUN_MARK}={value}").into_bytes()),
        };
        assert!(owner.session.is_some());
        let start = |marked: bool| {
            let mut command = Command::new("setsid");
            command.args(["sleep", "300"]).env_remove(RUN_MARK);
            if marked {
                command.env(RUN_MARK, &value);
            }
            command.spawn().expect("setsid")
        };
        let mut in_session = Command::new("sleep")
            .arg("300")
            .env_remove(RUN_MARK)
            .spawn()
            .expect("sleep");
        let (mut marked, mut foreign) = (start(true), start(false));
        let left_the_session = |pid: u32| {
            eventually(|| {
                read_process(pid).is_some_and(|process| {
                    process.args.first().is_some_and(|name| name == "sleep")
                        && process.session != owner.session
                })
            })
        };
        assert!(left_the_session(marked.id()) && left_the_session(foreign.id()));
        let owns = |pid: u32| owner.owns(&read_process(pid).expect("running"));
        assert!(owns(in_session.id()));
        assert!(owns(marked.id()));
        assert!(!owns(foreign.id()));
        for child in [&mut in_session, &mut marked, &mut foreign] {
            child.kill().expect("kill");
            child.wait().expect("wait");
        }
    }

    /// A folder a running process holds open (or names) is in use, and no longer
    /// once the process ended.
    #[test]
    fn a_folder_a_process_uses_is_in_use() {
        let temp = tempfile::tempdir().expect("temp dir");
        let file = temp.path().join("Singleton");
        std::fs::write(&file, b"x").expect("write");
        assert!(!in_use(temp.path()));
        let mut tail = Command::new("tail")
            .arg("-f")
            .arg(&file)
            .stdout(std::process::Stdio::null())
            .spawn()
            .expect("tail");
        assert!(eventually(|| in_use(temp.path())));
        tail.kill().expect("kill");
        tail.wait().expect("wait");
        assert!(eventually(|| !in_use(temp.path())));
    }

    #[test]
    fn chromiums_folders_are_told_from_others() {
        let temp = tempfile::tempdir().expect("temp dir");
        let make = |path: &str| {
            let path = temp.path().join(path);
            std::fs::create_dir_all(&path).expect("create");
            path
        };
        make(".tmpHalf/Default/Sessions");
        make(".tmpHarness/profile/Default");
        make(".org.chromium.Chromium.Ab12Cd");
        make(".tmpOther/data");
        make("profile/Default");
        for (name, chromiums) in [
            (".tmpHalf", true),
            (".tmpHarness", true),
            (".org.chromium.Chromium.Ab12Cd", true),
            (".tmpOther", false),
            ("profile", false),
            (".tmpMissing", false),
        ] {
            assert_eq!(
                is_chromium_leftover(&temp.path().join(name)),
                chromiums,
                "{name}"
            );
        }
        std::fs::write(temp.path().join(".tmpHalf/Default/Cookies"), [0; 10]).expect("write");
        std::fs::write(temp.path().join(".tmpHalf/Local State"), [0; 5]).expect("write");
        assert_eq!(size_of(&temp.path().join(".tmpHalf")), 15);
    }

    #[test]
    fn a_long_command_line_is_shortened() {
        let long = "x".repeat(COMMAND_LINE_CHARS * 2);
        let described = process(&[&long], None).describe();
        assert_eq!(described.chars().count(), COMMAND_LINE_CHARS + 1);
        assert!(described.ends_with('…'));
    }
}
