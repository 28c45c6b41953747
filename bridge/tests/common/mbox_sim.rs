//! `floatball simulate --kind mbox` as a child process: MBOX twins on loopback UDP,
//! each on a free port; their final state is printed when they stop.

use std::io::{BufRead, BufReader, Read};
use std::net::SocketAddr;
use std::process::{Child, ChildStdout, Command, Stdio};

use floatball_shared::api::SimBox;

/// The running boxes; killed when dropped.
pub struct Simulator {
    child: Child,
    stdout: BufReader<ChildStdout>,
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Simulator {
    /// Starts `boxes` boxes of `axes` axes, each on a free port, losing
    /// `drop_percent` of datagrams each way (seeded); returns their sockets.
    pub fn start(axes: u8, boxes: usize, drop_percent: u8) -> (Self, Vec<SocketAddr>) {
        let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
            .args(["simulate", "--kind", "mbox", "--listen", "127.0.0.1:0"])
            .args(["--axes", &axes.to_string(), "--boxes", &boxes.to_string()])
            .args(["--drop-percent", &drop_percent.to_string(), "--seed", "7"])
            .stdout(Stdio::piped())
            .spawn()
            .expect("start floatball simulate --kind mbox");
        let mut stdout = BufReader::new(child.stdout.take().expect("stdout"));
        let sockets = (0..boxes)
            .map(|_| {
                let mut line = String::new();
                stdout.read_line(&mut line).expect("a banner line a box");
                assert!(line.contains(&format!("{axes} axes")), "{line}");
                line.split_whitespace()
                    .last()
                    .and_then(|socket| socket.parse().ok())
                    .expect("the socket ends the line")
            })
            .collect();
        (Self { child, stdout }, sockets)
    }

    /// Its process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Stops it with SIGTERM, as an operator's Ctrl-C would; returns every box's final
    /// state.
    pub fn stop(mut self) -> Vec<SimBox> {
        let status = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .expect("kill");
        assert!(status.success());
        let mut rest = String::new();
        self.stdout.read_to_string(&mut rest).expect("final states");
        assert!(self.child.wait().expect("exit").success());
        rest.lines()
            .map(|line| serde_json::from_str(line).expect("a SimBox"))
            .collect()
    }
}
