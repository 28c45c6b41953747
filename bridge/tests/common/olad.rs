//! Debian's `olad` (the Open Lighting Architecture) as a real peer: started with only
//! the plugins a test names, as `nobody` when the test runs as root (olad refuses
//! root), its output discarded, killed when dropped.

use std::os::unix::fs::PermissionsExt;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Every plugin of Debian's `olad` 0.10 but those a test enables: off, so nothing
/// probes serial ports or USB.
const PLUGINS: [&str; 20] = [
    "dummy",
    "e131",
    "espnet",
    "ftdidmx",
    "gpio",
    "karate",
    "kinet",
    "milinst",
    "opendmx",
    "openpixelcontrol",
    "osc",
    "pathport",
    "renard",
    "sandnet",
    "shownet",
    "spi",
    "stageprofi",
    "uartdmx",
    "usbdmx",
    "usbserial",
];

/// A running `olad`.
pub struct Olad {
    child: Child,
    _config: tempfile::TempDir,
}

impl Olad {
    /// Starts `olad` with the plugins `enabled` (each `(name, its conf file's text)`,
    /// e.g. `("artnet", "enabled = true\n…")`) and every other one off, and waits (at
    /// most 10 s) until `ready` says it is.
    ///
    /// # Panics
    /// It cannot start, or is not ready in time.
    pub fn start(enabled: &[(&str, &str)], ready: impl Fn() -> bool) -> Self {
        let config = tempfile::tempdir().expect("a config dir");
        let dir = config.path();
        for (plugin, conf) in enabled {
            std::fs::write(dir.join(format!("ola-{plugin}.conf")), conf).expect("a plugin's conf");
        }
        for plugin in PLUGINS {
            if !enabled.iter().any(|(name, _)| *name == plugin) {
                std::fs::write(dir.join(format!("ola-{plugin}.conf")), "enabled = false\n")
                    .expect("a plugin's conf");
            }
        }
        // olad runs as nobody: it must read and write its configuration.
        for entry in std::fs::read_dir(dir).expect("the config dir") {
            let path = entry.expect("an entry").path();
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o666)).expect("chmod");
        }
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o777)).expect("chmod");
        let root = Command::new("id")
            .arg("-u")
            .output()
            .is_ok_and(|out| out.stdout.trim_ascii() == b"0");
        let mut command = if root {
            let mut command = Command::new("setpriv");
            command.args(["--reuid=65534", "--regid=65534", "--clear-groups", "olad"]);
            command
        } else {
            Command::new("olad")
        };
        let child = command
            .arg("-c")
            .arg(dir)
            .args(["--no-http", "-l", "1"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("olad starts");
        let olad = Self {
            child,
            _config: config,
        };
        let since = Instant::now();
        while !ready() {
            assert!(
                since.elapsed() < Duration::from_secs(10),
                "olad did not start"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        olad
    }
}

impl Drop for Olad {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
