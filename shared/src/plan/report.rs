//! The bandwidth / feasibility report (`GET /api/plan/{name}`): for each gateway the
//! bytes per row, the preload and how long it takes, the streaming rate needed against
//! what the line carries and the lowest water level reached on paper; a verdict, and
//! when a show cannot run, why and what would make it run; when it runs but its
//! preload is long, the advice ([`preload_advice`]).
//!
//! `preload_ms` is the slowest gateway's preload. A show that cannot be planned, and
//! installations no serial line feeds (MBOX boxes take positions frame by frame;
//! MOONS' drives play Q programs, whose upload this report does not model), have no
//! gateway figures, and their `preload_ms` is 0.

use super::Installation;
use super::verdict::{Advice, Fix, LONG_PRELOAD_MS, Why, advise, verdict_report};
use crate::api::{GatewayPlan, PlanReport};
use crate::line::Line;
use crate::show::Show;
use crate::uim2503::plan::{Plan, PlanError, PlanOptions, RunMode};
use crate::uim2503::schedule::{self, Simulation};

/// The baud rates a UIM2503 can be set to (`BDR=x;`, `docs/uim2503.md` §2), ascending.
pub const GATEWAY_BAUDS: [u32; 5] = [9600, 19_200, 38_400, 57_600, 115_200];

/// The report for `show` on `installation`. An invalid show gets a report saying so.
/// An installation of MBOX boxes gets [`super::mbox::report`]: no serial line limits
/// its shows. Nor do MOONS' drives, which play their Q programs themselves: their
/// verdict is the Start check ([`unfit_verdict`]); how far each ball's program
/// is from the show is `GET /api/qprogram`'s.
pub fn report(show: &Show, installation: &Installation, options: PlanOptions) -> PlanReport {
    if let Some(report) = report_without_lines(show, installation) {
        return report;
    }
    match Plan::new(show, installation, options) {
        Ok(plan) => report_for(&plan, installation),
        Err(error) => refused(&show.name, error),
    }
}

/// [`report`], taking the show: on UIM2503 gateways it is planned as it is freed
/// ([`Plan::from_show`]), so the show and its plan are never both whole in memory.
pub fn report_of(show: Show, installation: &Installation, options: PlanOptions) -> PlanReport {
    if let Some(report) = report_without_lines(&show, installation) {
        return report;
    }
    let name = show.name.clone();
    match Plan::from_show(show, installation, options) {
        Ok(plan) => report_for(&plan, installation),
        Err(error) => refused(&name, error),
    }
}

/// The report for MBOX boxes or MOONS' drives (no serial line carries the show);
/// `None` for UIM2503 gateways.
fn report_without_lines(show: &Show, installation: &Installation) -> Option<PlanReport> {
    if installation.mbox_boxes().is_some() {
        return Some(crate::mbox::player::report(show, installation));
    }
    if !installation.gateways.is_empty()
        && installation
            .gateways
            .iter()
            .all(|gateway| gateway.kind == super::DriveKind::Scl)
    {
        let why = unfit_verdict(installation, show);
        return Some(verdict_report(
            show.name.clone(),
            why.as_ref(),
            &[],
            Vec::new(),
        ));
    }
    None
}

/// Why `show` cannot play on `installation` when no serial line carries it (MBOX
/// boxes, MOONS' drives): the first violation of its limits (and how many more), or a
/// ball count that differs. `None` when it can.
pub fn unfit_verdict(installation: &Installation, show: &Show) -> Option<Why> {
    let violations = crate::show::validate(show, &installation.limits);
    let units = installation.units.len();
    if let Some(&first) = violations.first() {
        Some(Why::Violations {
            first,
            more: violations.len() - 1,
        })
    } else if show.tracks.len() != units {
        Some(Why::BallCount {
            show_balls: show.tracks.len(),
            units,
        })
    } else {
        None
    }
}

/// A report for a show that cannot be planned at all.
pub fn refused(show: &str, error: PlanError) -> PlanReport {
    let fixes: Vec<Fix> = match &error {
        PlanError::Invalid { violations } => violations
            .iter()
            .take(20)
            .cloned()
            .map(Fix::Problem)
            .collect(),
        _ => Vec::new(),
    };
    verdict_report(
        show.to_owned(),
        Some(&Why::Refused(error)),
        &fixes,
        Vec::new(),
    )
}

/// The report for a plan.
pub fn report_for(plan: &Plan, installation: &Installation) -> PlanReport {
    let (gateways, why, fixes) = line_verdict(plan, installation);
    let advice = if why.is_none() {
        preload_advice(plan, &gateways)
    } else {
        Vec::new()
    };
    let mut report = verdict_report(plan.show.clone(), why.as_ref(), &fixes, gateways);
    advise(&mut report, &advice);
    report
}

/// The advice for a plan that runs: for each gateway whose preload takes longer than
/// [`LONG_PRELOAD_MS`], the slowest faster rate that brings it within (the fastest when
/// none does) and its preload there, or, at the fastest rate already, that it stays
/// long. `gateways` are [`line_verdict`]'s figures, in the plan's run order.
pub fn preload_advice(plan: &Plan, gateways: &[GatewayPlan]) -> Vec<Advice> {
    let mut advice = Vec::new();
    for (index, (run, figures)) in plan.gateways.iter().zip(gateways).enumerate() {
        if figures.preload_ms <= LONG_PRELOAD_MS {
            continue;
        }
        let baud = run.line.baud();
        let faster: Vec<(u32, u64)> = GATEWAY_BAUDS
            .iter()
            .copied()
            .filter(|&faster| faster > baud)
            .map(|faster| {
                let simulation = schedule::choose_preload(plan, index, Line::new(faster));
                (faster, simulation.preload_ms.ceil() as u64)
            })
            .collect();
        let chosen = faster
            .iter()
            .find(|(_, preload_ms)| *preload_ms <= LONG_PRELOAD_MS)
            .or_else(|| faster.last())
            .copied();
        advice.push(match chosen {
            Some((faster_baud, faster_preload_ms)) => Advice::LongPreload {
                gateway: figures.port.clone(),
                baud: figures.baud,
                preload_bytes: figures.preload_bytes,
                preload_ms: figures.preload_ms,
                faster_baud,
                faster_preload_ms,
            },
            None => Advice::LongPreloadFastest {
                gateway: figures.port.clone(),
                baud: figures.baud,
                preload_bytes: figures.preload_bytes,
                preload_ms: figures.preload_ms,
            },
        });
    }
    advice
}

/// A plan's figures for each gateway, why its lines cannot carry it (none: they can)
/// and what would make it run: [`report_for`]'s parts, typed, for the Start check.
pub fn line_verdict(
    plan: &Plan,
    installation: &Installation,
) -> (Vec<GatewayPlan>, Option<Why>, Vec<Fix>) {
    let duration_s = (plan.duration_ms as f64 / 1000.0).max(1e-3);
    let mut gateways = Vec::with_capacity(plan.gateways.len());
    let mut why = None;
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
        if why.is_none() && !simulation.keeps_margin() {
            why = Some(starved(
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
    (gateways, why, fixes)
}

fn starved(
    plan: &Plan,
    units: usize,
    spec: &super::GatewaySpec,
    simulation: &Simulation,
    needed: f64,
    available: f64,
) -> Why {
    Why::Starved {
        gateway: spec.port.clone(),
        baud: spec.baud,
        units,
        show: plan.show.clone(),
        needed_bytes_per_s: needed,
        available_bytes_per_s: available,
        dry_at_ms: simulation.underrun_at_ms,
        preload_rows: simulation.preload_rows,
    }
}

/// What would make run `index` feasible: a faster line, fewer units per gateway,
/// longer rows.
fn remedies(plan: &Plan, index: usize, line: Line, needed: f64, available: f64) -> Vec<Fix> {
    let baud = line.baud();
    let mut fixes = Vec::new();
    match GATEWAY_BAUDS
        .iter()
        .copied()
        .filter(|&faster| faster > baud)
        .find(|&faster| schedule::choose_preload(plan, index, Line::new(faster)).keeps_margin())
    {
        Some(faster) => fixes.push(Fix::FasterLine { baud: faster }),
        None => fixes.push(Fix::NoBaudEnough {
            max_baud: GATEWAY_BAUDS[GATEWAY_BAUDS.len() - 1],
        }),
    }
    let units = plan.gateways[index].units.len();
    if let Some(fit) = most_units_that_fit(plan, index, line) {
        let gateways = units.div_ceil(fit.max(1));
        fixes.push(Fix::FewerUnits {
            units_per_gateway: fit,
            baud,
            gateways,
            units,
        });
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
            fixes.push(Fix::LongerRows {
                row_ms: wanted_ms,
                mean_row_ms,
            });
        }
    }
    if plan.gateways[index].mode == RunMode::Fifo {
        fixes.push(Fix::FewerRows {
            rows: crate::uim2503::pvt::TABLE_ROWS,
        });
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
    use crate::uim2503::plan::tests::{installation, wave};

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
        let reason = wrong.reason_problem.expect("coded");
        assert_eq!(reason.code, "wrong_layout");
        assert_eq!(reason.params["show_cols"], "2");
        assert_eq!(reason.params["rows"], "10");
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
    fn a_starved_line_and_its_fixes_carry_codes_and_plain_numbers() {
        let show = wave(10, 10, 600, 250);
        let report = report(&show, &installation(10, 10, 9600), PlanOptions::default());
        let reason = report.reason_problem.as_ref().expect("coded");
        assert!(
            reason.code == "line_starved" || reason.code == "line_starved_during",
            "{reason:?}"
        );
        assert_eq!(reason.params["gateway"], "sim");
        assert_eq!(reason.params["baud"], "9600");
        assert_eq!(reason.params["units"], "100");
        assert_eq!(reason.params["available_bytes_per_s"], "960");
        let english = report.reason.as_deref().unwrap();
        if let Some(dry_at_s) = reason.params.get("dry_at_s") {
            assert!(
                english.contains(&format!("{dry_at_s} s into the show")),
                "{english}"
            );
        }
        let needed = &reason.params["needed_bytes_per_s"];
        assert!(
            english.contains(&format!("streams {needed} B/s")),
            "{english}"
        );
        assert_eq!(report.fix_problems.len(), report.fixes.len());
        let codes: Vec<&str> = report
            .fix_problems
            .iter()
            .map(|p| p.code.as_str())
            .collect();
        assert!(codes.contains(&"fix_fewer_units"), "{codes:?}");
        let fewer =
            &report.fix_problems[codes.iter().position(|c| *c == "fix_fewer_units").unwrap()];
        assert_eq!(fewer.params["baud"], "9600");
        assert_eq!(fewer.params["units"], "100");
        assert!(fewer.params["units_per_gateway"].parse::<usize>().is_ok());

        let faster = super::report(
            &wave(5, 10, 600, 250),
            &installation(5, 10, 9600),
            PlanOptions::default(),
        );
        assert_eq!(faster.fix_problems[0].code, "fix_faster_line");
        assert_eq!(faster.fix_problems[0].params["baud"], "38400");
    }

    #[test]
    fn every_verdict_carries_every_parameter_its_code_names() {
        use crate::codes::Coded;
        use crate::plan::verdict::{Fix, Why};
        use crate::scl::qprogram::QProgramError;
        let mut show = wave(1, 2, 20, 200);
        show.tracks[1].rows[5].position_mm = -50.0;
        let violations = crate::show::validate(&show, &installation(1, 2, 9600).limits);
        let first = violations[0];
        let whys = [
            Why::Starved {
                gateway: "g".into(),
                baud: 9600,
                units: 3,
                show: "s".into(),
                needed_bytes_per_s: 1.0,
                available_bytes_per_s: 2.0,
                dry_at_ms: Some(1500.0),
                preload_rows: 256,
            },
            Why::Starved {
                gateway: "g".into(),
                baud: 9600,
                units: 3,
                show: "s".into(),
                needed_bytes_per_s: 1.0,
                available_bytes_per_s: 2.0,
                dry_at_ms: None,
                preload_rows: 256,
            },
            Why::Violations { first, more: 2 },
            Why::BallCount {
                show_balls: 2,
                units: 4,
            },
            Why::OutputBox {
                box_index: 3,
                boxes: 1,
            },
            Why::Refused(PlanError::Invalid {
                violations: violations.clone(),
            }),
            Why::Refused(PlanError::LayoutMismatch {
                show_rows: 1,
                show_cols: 2,
                rows: 3,
                cols: 4,
            }),
            Why::Refused(PlanError::OutOfCounts {
                unit: 1,
                value_mm: 1e12,
                counts_per_mm: 100.0,
            }),
            Why::Refused(PlanError::UnitCount {
                listed: 1,
                expected: 2,
            }),
            Why::Program {
                ball: 7,
                error: QProgramError::TooFar {
                    deviation_mm: 12.34,
                    at_ms: 1500,
                    tolerance_mm: 10.0,
                },
            },
            Why::Program {
                ball: 7,
                error: QProgramError::TooFast {
                    at_ms: 1500,
                    max_speed_mm_s: 800.0,
                    max_accel_mm_s2: 4000.0,
                },
            },
            Why::Program {
                ball: 7,
                error: QProgramError::OutOfRange {
                    at_ms: 1500,
                    position_mm: f64::NAN,
                },
            },
            Why::Program {
                ball: 7,
                error: QProgramError::TooManyLines {
                    lines: 900,
                    limit: 744,
                },
            },
            Why::Program {
                ball: 7,
                error: QProgramError::InvalidConfig {
                    field: "steps_per_rev",
                    must: "at least 200",
                },
            },
        ];
        let fixes = [
            Fix::FasterLine { baud: 38_400 },
            Fix::NoBaudEnough { max_baud: 115_200 },
            Fix::FewerUnits {
                units_per_gateway: 20,
                baud: 9600,
                gateways: 5,
                units: 100,
            },
            Fix::LongerRows {
                row_ms: 120.0,
                mean_row_ms: 50.0,
            },
            Fix::FewerRows { rows: 256 },
            Fix::Problem(first),
            Fix::Tolerance {
                tolerance_mm: 13.0,
                deviation_mm: 12.34,
            },
        ];
        let coded: Vec<&dyn Coded> = whys
            .iter()
            .map(|why| why as &dyn Coded)
            .chain(fixes.iter().map(|fix| fix as &dyn Coded))
            .collect();
        for error in coded {
            let params = error.params();
            for name in error.code().params() {
                assert!(params.contains_key(*name), "{} lacks {name}", error.code());
            }
        }
        assert_eq!(whys[0].code(), crate::codes::Code::LineStarved);
        assert_eq!(whys[0].params()["dry_at_s"], "1.5");
        assert_eq!(whys[1].code(), crate::codes::Code::LineStarvedDuring);
        assert_eq!(whys[2].params()["more"], "2");
        assert!(whys[2].to_string().ends_with("(and 2 more problems)"));
        assert_eq!(whys[5].code(), crate::codes::Code::ShowUnfit);
        assert_eq!(whys[9].params()["unit"], "u7");
        assert_eq!(whys[9].params()["deviation_mm"], "12.3");
        assert_eq!(whys[9].params()["time_s"], "1.500");
        assert!(
            whys[9]
                .to_string()
                .starts_with("ball u7: the program would be 12.3 mm off")
        );
        assert_eq!(fixes[6].params()["tolerance_mm"], "13");
        assert!(
            fixes[6]
                .to_string()
                .starts_with("raise [scl] tolerance_mm to 13 mm or more")
        );
    }

    #[test]
    fn a_feasible_show_has_figures_and_no_reason() {
        let show = wave(2, 5, 600, 250);
        let report = report(&show, &installation(2, 5, 115_200), PlanOptions::default());
        assert!(report.feasible, "{:?}", report.reason);
        assert!(report.reason.is_none() && report.fixes.is_empty());
        assert!(report.reason_problem.is_none() && report.fix_problems.is_empty());
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
        let reason = report.reason_problem.expect("coded");
        assert_eq!(reason.code, "show_unfit");
        assert_eq!(reason.params["count"], report.fixes.len().to_string());
        assert_eq!(report.fix_problems.len(), report.fixes.len());
        assert_eq!(report.fix_problems[0].code, "above_top");
        assert_eq!(report.fix_problems[0].params["unit"], "u1");
    }

    // ---- arm ----

    /// The story: a 20 s wave (200 rows of 100 ms) on 10 × 10 units behind one
    /// gateway at the factory 9600 baud. The issue quotes 517,119 bytes in 9.1 min and
    /// 47 s at 115200; this planner sends 532,083 bytes (configuration, the whole
    /// single-sequence table, arming), 583.4 s at 9600 on its derated line (95 %) and
    /// 48.6 s at 115200.
    #[test]
    fn a_long_preload_is_stated_with_the_faster_rate_that_shortens_it() {
        use crate::codes::Coded;
        use crate::plan::verdict::Advice;
        let show = wave(10, 10, 200, 100);
        let slow = report(&show, &installation(10, 10, 9600), PlanOptions::default());
        assert!(slow.feasible, "{slow:?}");
        assert_eq!(slow.gateways.len(), 1);
        assert_eq!(slow.gateways[0].preload_bytes, 532_083);
        assert_eq!(slow.preload_ms, 583_425);
        assert_eq!(slow.preload_ms, slow.gateways[0].preload_ms);
        assert_eq!(slow.advice.len(), 1, "{:?}", slow.advice);
        let advice = &slow.advice[0];
        assert_eq!(advice.code, "preload_long");
        for (name, value) in [
            ("gateway", "sim"),
            ("baud", "9600"),
            ("preload_bytes", "532083"),
            ("preload_s", "584"),
            ("preload_min", "9.7"),
            // No rate brings it within 30 s: the fastest is named.
            ("faster_baud", "115200"),
            ("faster_preload_s", "49"),
        ] {
            assert_eq!(advice.params[name], value, "{name}");
        }
        let code = crate::codes::Code::parse(&advice.code).unwrap();
        for name in code.params() {
            assert!(advice.params.contains_key(*name), "{name}");
        }
        let english = Advice::LongPreload {
            gateway: "sim".into(),
            baud: 9600,
            preload_bytes: 532_083,
            preload_ms: 583_425,
            faster_baud: 115_200,
            faster_preload_ms: 48_619,
        };
        assert_eq!(crate::api::Problem::of(&english), *advice);
        assert_eq!(english.code().as_str(), "preload_long");
        assert!(
            english.to_string().starts_with(
                "gateway sim preloads 532083 bytes in 584 s (9.7 min) at 9600 baud before \
                 the show can start; at 115200 baud it takes 49 s"
            ),
            "{english}"
        );

        // At 115200 the same show preloads in 49 s: still long, and no rate is faster.
        let fast = report(
            &show,
            &installation(10, 10, 115_200),
            PlanOptions::default(),
        );
        assert_eq!(fast.preload_ms, 48_619);
        assert_eq!(fast.advice.len(), 1);
        assert_eq!(fast.advice[0].code, "preload_long_fastest");
        assert_eq!(fast.advice[0].params["preload_s"], "49");

        // A rate that brings it within 30 s is named rather than the fastest.
        let half = wave(5, 10, 100, 200);
        let smaller = report(&half, &installation(5, 10, 9600), PlanOptions::default());
        assert!(smaller.preload_ms > 30_000, "{}", smaller.preload_ms);
        let advice = &smaller.advice[0];
        assert_eq!(advice.code, "preload_long");
        let faster_s: u64 = advice.params["faster_preload_s"].parse().unwrap();
        assert!(faster_s <= 30, "{faster_s}");
        assert!(advice.params["faster_baud"] != "115200", "{advice:?}");
    }

    #[test]
    fn short_preloads_refusals_and_other_families_get_no_advice() {
        let short = report(
            &wave(2, 3, 50, 200),
            &installation(2, 3, 115_200),
            PlanOptions::default(),
        );
        assert!(short.feasible);
        assert!(short.preload_ms > 0 && short.preload_ms <= 30_000);
        assert!(short.advice.is_empty(), "{:?}", short.advice);
        // An infeasible show gets fixes, not advice, and still states its preload.
        let starved = report(
            &wave(10, 10, 600, 250),
            &installation(10, 10, 9600),
            PlanOptions::default(),
        );
        assert!(!starved.feasible);
        assert!(starved.advice.is_empty());
        assert_eq!(
            starved.preload_ms,
            starved.gateways.iter().map(|g| g.preload_ms).max().unwrap()
        );
        // A show that cannot be planned loads nothing.
        let refused = refused(
            "x",
            PlanError::Invalid {
                violations: Vec::new(),
            },
        );
        assert_eq!((refused.preload_ms, refused.advice.len()), (0, 0));
        // MOONS' drives: no line figures, no preload modelled.
        let mut scl = installation(2, 3, 9600);
        for gateway in &mut scl.gateways {
            gateway.kind = crate::plan::DriveKind::Scl;
        }
        let drives = report(&wave(2, 3, 50, 200), &scl, PlanOptions::default());
        assert_eq!((drives.preload_ms, drives.advice.len()), (0, 0));
    }
}
