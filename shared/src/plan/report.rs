//! The bandwidth / feasibility report (`GET /api/plan/{name}`): for each gateway the
//! bytes per row, the preload and how long it takes, the streaming rate needed against
//! what the line carries and the lowest water level reached on paper; a verdict, and
//! when a show cannot run, why and what would make it run.

use super::schedule::{self, Simulation};
use super::{Installation, Plan, PlanError, PlanOptions, RunMode};
use crate::api::{GatewayPlan, PlanReport};
use crate::line::Line;
use crate::show::Show;

/// The baud rates a UIM2503 can be set to (`BDR=x;`, PROTOCOL §1.2), ascending.
pub const GATEWAY_BAUDS: [u32; 5] = [9600, 19_200, 38_400, 57_600, 115_200];

/// The report for `show` on `installation`. An invalid show gets a report saying so.
/// An installation of MBOX boxes gets [`super::mbox::report`]: no serial line limits
/// its shows. Nor do MOONS' drives, which play their Q programs themselves: their
/// verdict is the Start check ([`unfit_without_lines`]); how far each ball's program
/// is from the show is `GET /api/qprogram`'s.
pub fn report(show: &Show, installation: &Installation, options: PlanOptions) -> PlanReport {
    if installation.mbox_boxes().is_some() {
        return super::mbox::report(show, installation);
    }
    if !installation.gateways.is_empty()
        && installation
            .gateways
            .iter()
            .all(|gateway| gateway.kind == super::DriveKind::Scl)
    {
        let reason = unfit_without_lines(installation, show);
        return PlanReport {
            show: show.name.clone(),
            feasible: reason.is_none(),
            reason,
            fixes: Vec::new(),
            gateways: Vec::new(),
        };
    }
    match Plan::new(show, installation, options) {
        Ok(plan) => report_for(&plan, installation),
        Err(error) => refused(&show.name, &error),
    }
}

/// Why `show` cannot play on `installation` when no serial line carries it (MBOX
/// boxes, MOONS' drives), in one sentence: the first violation of its limits (and how
/// many more), or a ball count that differs. `None` when it can.
pub fn unfit_without_lines(installation: &Installation, show: &Show) -> Option<String> {
    let violations = crate::show::validate(show, &installation.limits);
    let units = installation.units.len();
    if let Some(first) = violations.first() {
        Some(if violations.len() > 1 {
            format!("{first} (and {} more problems)", violations.len() - 1)
        } else {
            first.to_string()
        })
    } else if show.tracks.len() != units {
        Some(format!(
            "the show has {} balls but the installation has {units}",
            show.tracks.len()
        ))
    } else {
        None
    }
}

/// A report for a show that cannot be planned at all.
pub fn refused(show: &str, error: &PlanError) -> PlanReport {
    let fixes = match error {
        PlanError::Invalid { violations } => violations
            .iter()
            .take(20)
            .map(ToString::to_string)
            .collect(),
        _ => Vec::new(),
    };
    PlanReport {
        show: show.to_owned(),
        feasible: false,
        reason: Some(error.to_string()),
        fixes,
        gateways: Vec::new(),
    }
}

/// The report for a plan.
pub fn report_for(plan: &Plan, installation: &Installation) -> PlanReport {
    let duration_s = (plan.duration_ms as f64 / 1000.0).max(1e-3);
    let mut gateways = Vec::with_capacity(plan.gateways.len());
    let mut reason = None;
    let mut fixes = Vec::new();
    for (index, run) in plan.gateways.iter().enumerate() {
        let Some(spec) = installation.gateways.get(run.gateway) else {
            continue;
        };
        let simulation = schedule::simulate(plan, index, run.line, run.preload_rows);
        let needed = simulation.stream_bytes as f64 / duration_s;
        let available = run.line.bytes_per_s();
        gateways.push(GatewayPlan {
            port: spec.port.clone(),
            baud: spec.baud,
            units: u32::try_from(run.units.len()).unwrap_or(u32::MAX),
            bytes_per_row: simulation.bytes_per_row,
            preload_bytes: simulation.preload_bytes,
            preload_ms: simulation.preload_ms.ceil() as u64,
            needed_bytes_per_s: needed,
            available_bytes_per_s: available,
            lowest_water_level: simulation
                .lowest_level
                .map(|level| u16::try_from(level.max(0)).unwrap_or(u16::MAX)),
        });
        if reason.is_none() && !simulation.keeps_margin() {
            reason = Some(starved(
                plan,
                run.units.len(),
                spec,
                &simulation,
                needed,
                available,
            ));
            fixes = remedies(plan, index, run.line, needed, available);
        }
    }
    PlanReport {
        show: plan.show.clone(),
        feasible: reason.is_none(),
        reason,
        fixes,
        gateways,
    }
}

fn starved(
    plan: &Plan,
    units: usize,
    spec: &super::GatewaySpec,
    simulation: &Simulation,
    needed: f64,
    available: f64,
) -> String {
    let when = simulation
        .underrun_at_ms
        .map(|ms| format!("{:.1} s into the show", ms / 1000.0))
        .unwrap_or_else(|| "during the show".to_owned());
    format!(
        "gateway {} ({} baud) cannot keep its {units} units fed: \"{}\" streams {needed:.0} B/s \
         while the line carries {available:.0} B/s, so the units' row buffers run dry {when} \
         even with a full {}-row preload",
        spec.port, spec.baud, plan.show, simulation.preload_rows
    )
}

/// What would make run `index` feasible: a faster line, fewer units per gateway,
/// longer rows.
fn remedies(plan: &Plan, index: usize, line: Line, needed: f64, available: f64) -> Vec<String> {
    let baud = line.baud();
    let mut fixes = Vec::new();
    match GATEWAY_BAUDS
        .iter()
        .copied()
        .filter(|&faster| faster > baud)
        .find(|&faster| schedule::choose_preload(plan, index, Line::new(faster)).keeps_margin())
    {
        Some(faster) => fixes.push(format!(
            "raise the line to {faster} baud (BDR={faster}; on the gateway, then `baud = {faster}` in floatball.toml)"
        )),
        None => fixes.push("no baud rate up to 115200 is enough on its own".to_owned()),
    }
    let units = plan.gateways[index].units.len();
    if let Some(fit) = most_units_that_fit(plan, index, line) {
        let gateways = units.div_ceil(fit.max(1));
        fixes.push(format!(
            "put at most {fit} of these units on each gateway at {baud} baud ({gateways} gateways for these {units})"
        ));
    }
    let unit_rows: usize = plan.gateways[index]
        .units
        .iter()
        .map(|&unit| plan.units[unit].rows.len())
        .sum();
    if unit_rows > 0 && available > 0.0 {
        let mean_row_ms = plan.duration_ms as f64 * units as f64 / unit_rows as f64;
        let wanted_ms = (mean_row_ms * needed / (available * schedule::LINE_UTILISATION)).ceil();
        if wanted_ms <= 255.0 {
            fixes.push(format!(
                "use rows of at least {wanted_ms:.0} ms (this show's rows last {mean_row_ms:.0} ms on average)"
            ));
        }
    }
    if plan.gateways[index].mode == RunMode::Fifo {
        fixes.push(format!(
            "or shorten the show to at most {} rows per ball so it loads completely before it starts",
            crate::pvt::TABLE_ROWS
        ));
    }
    fixes
}

/// The most of run `index`'s units (taken in order) one gateway on `line` can feed.
fn most_units_that_fit(plan: &Plan, index: usize, line: Line) -> Option<usize> {
    let units = plan.gateways[index].units.len();
    let fits = |count: usize| {
        let mut smaller = plan.clone();
        smaller.gateways[index].units.truncate(count);
        schedule::choose_preload(&smaller, index, line).keeps_margin()
    };
    if units <= 1 || !fits(1) {
        return None;
    }
    let (mut low, mut high) = (1, units - 1);
    while low < high {
        let middle = (low + high).div_ceil(2);
        if fits(middle) {
            low = middle;
        } else {
            high = middle - 1;
        }
    }
    Some(low)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::plan::tests::{installation, wave};

    #[test]
    fn moons_drives_get_the_start_check_without_line_figures() {
        let mut scl = installation(10, 10, 9600);
        for gateway in &mut scl.gateways {
            gateway.kind = crate::plan::DriveKind::Scl;
        }
        // Far more than a 9600-baud line carries: drives play programs, not a stream.
        let show = wave(10, 10, 600, 250);
        assert!(!report(&show, &installation(10, 10, 9600), PlanOptions::default()).feasible);
        let verdict = report(&show, &scl, PlanOptions::default());
        assert!(verdict.feasible, "{verdict:?}");
        assert!(verdict.gateways.is_empty());
        let wrong = report(&wave(1, 2, 10, 250), &scl, PlanOptions::default());
        assert_eq!(
            wrong.reason.as_deref(),
            Some(
                "the show is made for 1 rows × 2 columns of balls but the installation has 10 \
                 rows × 10 columns"
            )
        );
    }

    #[test]
    fn an_infeasible_show_says_why_with_numbers_and_how_to_fix_it() {
        let show = wave(10, 10, 600, 250);
        let report = report(&show, &installation(10, 10, 9600), PlanOptions::default());
        assert!(!report.feasible);
        let reason = report.reason.as_deref().unwrap();
        assert!(reason.contains("gateway sim (9600 baud)"), "{reason}");
        assert!(reason.contains("960 B/s"), "{reason}");
        assert!(reason.contains("run dry"), "{reason}");
        let gateway = &report.gateways[0];
        assert!(gateway.needed_bytes_per_s > gateway.available_bytes_per_s);
        assert_eq!(gateway.lowest_water_level, Some(0));
        assert!(
            report
                .fixes
                .iter()
                .any(|fix| fix.contains("units on each gateway")),
            "{:?}",
            report.fixes
        );
    }

    #[test]
    fn a_feasible_show_has_figures_and_no_reason() {
        let show = wave(2, 5, 600, 250);
        let report = report(&show, &installation(2, 5, 115_200), PlanOptions::default());
        assert!(report.feasible, "{:?}", report.reason);
        assert!(report.reason.is_none() && report.fixes.is_empty());
        let gateway = &report.gateways[0];
        assert_eq!(gateway.units, 10);
        assert!(gateway.lowest_water_level.unwrap() >= 2);
        assert!(gateway.needed_bytes_per_s < gateway.available_bytes_per_s);
        assert!(gateway.bytes_per_row > 10.0 && gateway.bytes_per_row < 40.0);
    }

    #[test]
    fn a_faster_line_is_suggested_when_it_is_enough() {
        let show = wave(5, 10, 600, 250);
        let report = report(&show, &installation(5, 10, 9600), PlanOptions::default());
        assert!(!report.feasible);
        assert!(
            report.fixes[0].starts_with("raise the line to 38400 baud"),
            "{:?}",
            report.fixes
        );
    }

    #[test]
    fn an_invalid_show_is_refused_with_its_problems() {
        let mut show = wave(1, 2, 20, 200);
        show.tracks[1].rows[5].position_mm = -50.0;
        let report = report(&show, &installation(1, 2, 115_200), PlanOptions::default());
        assert!(!report.feasible);
        assert!(report.reason.unwrap().contains("not valid"));
        assert!(!report.fixes.is_empty());
    }
}
