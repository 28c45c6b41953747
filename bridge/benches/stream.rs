//! Line utilisation while the player streams: a 10 × 10 show loading into the
//! in-process simulated gateway at 115200 baud, the line's bytes/s read from the link
//! status once a second. Run with `cargo bench -p floatball-bridge --bench stream`.

use std::time::Duration;

use floatball_bridge::playback::Playback;
use floatball_bridge::ports::uim2503::{Link, LinkConfig};
use floatball_shared::api::{LinkState, PlayerState};
use floatball_shared::plan::Installation;
use floatball_shared::show::Show;
use floatball_shared::show::demo::Wave;
use floatball_shared::uim2503::player::Entry;

/// A 10 × 10 wave of `row_count` rows of 250 ms.
fn wave(row_count: usize) -> Show {
    Wave {
        period_s: 8.0,
        col_phase: 0.3,
        row_phase: 3.0,
        tenths: false,
        ..Wave::new(10, 10, row_count, 250)
    }
    .show()
}

fn main() {
    let smoke = std::env::args().any(|arg| arg == "--test");
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("runtime");
    runtime.block_on(async {
        let baud = 115_200;
        let installation = Installation::demo(10, 10, &[baud]).expect("installation");
        let link = Link::open(0, LinkConfig::new("sim", baud));
        let mut link_status = link.status();
        link_status
            .wait_for(|status| status.state == LinkState::Up)
            .await
            .expect("link up");
        let playback = Playback::spawn(installation, vec![link]);
        playback
            .start(
                vec![Entry {
                    show: wave(120),
                    delay_ms: 0,
                    cycles: 1,
                }],
                false,
            )
            .await
            .expect("start");
        let mut status = playback.status();
        status
            .wait_for(|status| status.state == PlayerState::Loading)
            .await
            .expect("loading");
        // Skip the first window (the line was idle before).
        tokio::time::sleep(Duration::from_millis(1500)).await;
        let seconds = if smoke { 2 } else { 10 };
        let mut rates = Vec::new();
        for _ in 0..seconds {
            tokio::time::sleep(Duration::from_secs(1)).await;
            let status = playback.status().borrow().clone();
            if status.state != PlayerState::Loading {
                break;
            }
            rates.push(status.gateways[0].bytes_per_s);
        }
        playback.estop();
        let available = floatball_shared::line::Line::new(baud).bytes_per_s();
        let mean = rates.iter().sum::<f64>() / rates.len().max(1) as f64;
        let lowest = rates.iter().copied().fold(f64::INFINITY, f64::min);
        println!(
            "line utilisation while streaming rows at {baud} baud: mean {mean:.0} B/s = {:.1}% \
             (lowest second {:.1}%) of the {available:.0} B/s the line carries, over {} s",
            100.0 * mean / available,
            100.0 * lowest / available,
            rates.len()
        );
    });
}
