//! The schedule's model, checks and decision, with the local time as a parameter.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;

fn t(text: &str) -> TimeOfDay {
    TimeOfDay::parse(text).unwrap()
}

fn at(text: &str) -> LocalDateTime {
    LocalDateTime::parse(text).unwrap()
}

fn window(start: &str, end: &str, program: Program) -> Window {
    Window {
        start: t(start),
        end: t(end),
        program,
    }
}

/// Open 10:00–22:00 looping every day but Sunday; Sunday every 30 minutes 12:00–14:00.
fn mall() -> Schedule {
    let mut schedule = Schedule {
        enabled: true,
        time_zone: "Europe/Zurich".to_owned(),
        ..Schedule::default()
    };
    for day in Weekday::ALL {
        *schedule.week.day_mut(day) = vec![window("10:00", "22:00", Program::Loop)];
    }
    schedule.week.sunday = vec![window("12:00", "14:00", Program::Every { minutes: 30 })];
    schedule
}

/// Runs the scheduler's side: decides at `now` and applies the action to `memory` as
/// a scheduler whose every start and end succeeds would.
fn step(schedule: &Schedule, now: &str, memory: &mut Memory) -> Action {
    let decision = decide(schedule, at(now), memory);
    match decision.action {
        Action::Start { occasion, .. } => {
            memory.started = Some(occasion);
            memory.open = Some(occasion.window_start);
            memory.run_ended = false;
        }
        Action::End { .. } => memory.open = None,
        Action::Nothing => {}
    }
    decision.action
}

#[test]
fn dates_and_times_read_write_and_count() {
    let date = Date::parse("2026-11-29").unwrap();
    assert_eq!(date.weekday(), Weekday::Sunday);
    assert_eq!(date.to_string(), "2026-11-29");
    assert_eq!(Date::from_days(date.days()), Some(date));
    assert_eq!(Date::parse("1970-01-01").unwrap().days(), 0);
    assert_eq!(
        Date::parse("2028-02-29")
            .unwrap()
            .plus_days(1)
            .unwrap()
            .to_string(),
        "2028-03-01"
    );
    assert_eq!(Date::parse("2027-02-29"), None);
    assert_eq!(Date::parse("2026-1-01"), None);
    assert_eq!(t("24:00"), TimeOfDay::END_OF_DAY);
    assert_eq!(TimeOfDay::parse("24:01"), None);
    assert_eq!(TimeOfDay::parse("9:60"), None);
    assert_eq!(t("9:05").to_string(), "09:05");
    assert_eq!(at("2026-11-29T23:59:30").to_string(), "2026-11-29 23:59:30");
    assert_eq!(
        LocalDateTime::at(date, TimeOfDay::END_OF_DAY),
        at("2026-11-30 00:00")
    );
    assert_eq!(LocalDateTime::parse("2026-11-29T24:00"), None);
    let json = serde_json::to_string(&mall()).unwrap();
    assert!(
        json.contains(r#""start":"10:00","end":"22:00","program":{"kind":"loop"}"#),
        "{json}"
    );
    assert!(json.contains(r#"{"kind":"every","minutes":30}"#), "{json}");
    assert_eq!(serde_json::from_str::<Schedule>(&json).unwrap(), mall());
    let bad = json.replace("22:00", "22:0");
    assert!(serde_json::from_str::<Schedule>(&bad).is_err());
}

#[test]
fn problems_are_coded_and_numbered() {
    let mut schedule = mall();
    assert!(problems(&schedule, |_| true).is_empty());
    schedule.week.monday = vec![
        window("10:00", "12:00", Program::Loop),
        window("11:00", "13:00", Program::Loop),
        window("14:00", "14:00", Program::Loop),
        window("15:00", "16:00", Program::Every { minutes: 0 }),
    ];
    schedule.exceptions = vec![
        Exception {
            date: Date::parse("2026-12-25").unwrap(),
            windows: Vec::new(),
            note: "Christmas".to_owned(),
        },
        Exception {
            date: Date::parse("2026-12-25").unwrap(),
            windows: Vec::new(),
            note: String::new(),
        },
    ];
    let found = problems(&schedule, |zone| zone == "UTC");
    let codes: Vec<&str> = found.iter().map(|p| p.code().as_str()).collect();
    assert_eq!(
        codes,
        [
            "schedule_unknown_time_zone",
            "schedule_end_not_after_start",
            "schedule_every_out_of_range",
            "schedule_windows_overlap",
            "schedule_exception_twice",
        ]
    );
    assert_eq!(
        found[1].to_string(),
        "monday, window 3: it ends at 14:00, not after its start 14:00"
    );
    assert_eq!(found[3].params()["first"], "1");
    assert_eq!(found[3].params()["second"], "2");
    for problem in &found {
        for name in problem.code().params() {
            assert!(
                problem.params().contains_key(*name),
                "{problem:?} lacks {name}"
            );
        }
    }
}

#[test]
fn a_window_starts_once_and_ends_once() {
    let schedule = mall();
    let mut memory = Memory::default();
    // Monday 2026-11-30.
    assert_eq!(
        step(&schedule, "2026-11-30T09:59", &mut memory),
        Action::Nothing
    );
    let decision = decide(&schedule, at("2026-11-30T09:59"), &memory);
    assert_eq!(decision.next_start, Some(at("2026-11-30T10:00")));
    assert!(matches!(
        step(&schedule, "2026-11-30T10:00", &mut memory),
        Action::Start {
            program: Program::Loop,
            again: false,
            ..
        }
    ));
    assert_eq!(
        step(&schedule, "2026-11-30T15:00", &mut memory),
        Action::Nothing
    );
    let decision = decide(&schedule, at("2026-11-30T15:00"), &memory);
    assert_eq!(decision.next_start, Some(at("2026-12-01T10:00")));
    assert_eq!(decision.wake_at, Some(at("2026-11-30T22:00")));
    // The playlist came to its end by itself: a loop starts it again.
    memory.run_ended = true;
    assert!(matches!(
        step(&schedule, "2026-11-30T16:00", &mut memory),
        Action::Start { again: true, .. }
    ));
    assert_eq!(
        step(&schedule, "2026-11-30T22:00", &mut memory),
        Action::End {
            window_start: at("2026-11-30T10:00")
        }
    );
    assert_eq!(
        step(&schedule, "2026-11-30T22:01", &mut memory),
        Action::Nothing
    );
    assert_eq!(memory.open, None);
}

#[test]
fn a_restart_in_the_middle_of_a_window_resumes_it() {
    let schedule = mall();
    // A scheduler that remembers nothing, at 15:00 on a Tuesday.
    let decision = decide(&schedule, at("2026-12-01T15:00"), &Memory::default());
    assert_eq!(
        decision.action,
        Action::Start {
            occasion: Occasion {
                window_start: at("2026-12-01T10:00"),
                at: at("2026-12-01T10:00"),
            },
            program: Program::Loop,
            again: false,
        }
    );
    // And on Sunday, the slot it is in.
    let decision = decide(&schedule, at("2026-11-29T13:10"), &Memory::default());
    assert!(matches!(
        decision.action,
        Action::Start { occasion, .. } if occasion.at == at("2026-11-29T13:00")
    ));
    assert_eq!(decision.next_start, Some(at("2026-11-29T13:30")));
}

#[test]
fn every_n_minutes_starts_each_slot_once() {
    let schedule = mall();
    let mut memory = Memory::default();
    // Sunday 2026-11-29, 12:00–14:00 every 30 minutes: 12:00, 12:30, 13:00, 13:30.
    let mut started = Vec::new();
    for minute in (11 * 60 + 50..=14 * 60 + 10).step_by(5) {
        let now = format!("2026-11-29T{:02}:{:02}", minute / 60, minute % 60);
        match step(&schedule, &now, &mut memory) {
            Action::Start {
                occasion, program, ..
            } => {
                assert_eq!(program, Program::Every { minutes: 30 });
                started.push((now, occasion.at.to_string()));
            }
            Action::End { .. } => started.push((now, "end".to_owned())),
            Action::Nothing => {}
        }
    }
    let expected = [
        ("12:00", "12:00"),
        ("12:30", "12:30"),
        ("13:00", "13:00"),
        ("13:30", "13:30"),
        ("14:00", "end"),
    ];
    assert_eq!(started.len(), expected.len(), "{started:?}");
    for ((now, what), (when, slot)) in started.iter().zip(expected) {
        assert!(now.ends_with(when), "{started:?}");
        assert!(what.ends_with(slot), "{started:?}");
    }
    // A slot that could not start at its time is still asked for within the slot.
    let mut late = Memory::default();
    step(&schedule, "2026-11-29T12:00", &mut late);
    assert!(matches!(
        decide(&schedule, at("2026-11-29T12:44"), &late).action,
        Action::Start { occasion, .. } if occasion.at == at("2026-11-29T12:30")
    ));
    // An every-N program never starts again by itself within a slot.
    late.run_ended = true;
    assert_eq!(
        decide(&schedule, at("2026-11-29T12:10"), &late).action,
        Action::Nothing
    );
}

#[test]
fn exceptions_close_a_day_or_give_it_other_windows() {
    let mut schedule = mall();
    schedule.exceptions = vec![
        Exception {
            date: Date::parse("2026-12-25").unwrap(),
            windows: Vec::new(),
            note: "closed".to_owned(),
        },
        Exception {
            date: Date::parse("2026-12-31").unwrap(),
            windows: vec![window("18:00", "24:00", Program::Every { minutes: 60 })],
            note: String::new(),
        },
    ];
    assert_eq!(
        decide(&schedule, at("2026-12-25T12:00"), &Memory::default()).action,
        Action::Nothing
    );
    assert_eq!(
        decide(&schedule, at("2026-12-25T09:00"), &Memory::default()).next_start,
        Some(at("2026-12-26T10:00"))
    );
    assert_eq!(
        decide(&schedule, at("2026-12-31T12:00"), &Memory::default()).action,
        Action::Nothing
    );
    assert_eq!(
        decide(&schedule, at("2026-12-31T12:00"), &Memory::default()).next_start,
        Some(at("2026-12-31T18:00"))
    );
    // A window the scheduler opened is ended when an exception closes its day.
    let mut memory = Memory::default();
    step(&schedule, "2026-12-24T12:00", &mut memory);
    let mut closed = schedule.clone();
    closed.exceptions[0].date = Date::parse("2026-12-24").unwrap();
    assert!(matches!(
        decide(&closed, at("2026-12-24T12:01"), &memory).action,
        Action::End { .. }
    ));
    // So is one open when the schedule is switched off.
    closed.enabled = false;
    assert!(matches!(
        decide(&closed, at("2026-12-24T12:01"), &memory).action,
        Action::End { .. }
    ));
    assert_eq!(
        decide(&closed, at("2026-12-24T12:01"), &memory).next_start,
        None
    );
}

#[test]
fn windows_that_touch_at_midnight_are_one() {
    let mut schedule = Schedule {
        enabled: true,
        ..Schedule::default()
    };
    schedule.week.friday = vec![window("20:00", "24:00", Program::Loop)];
    schedule.week.saturday = vec![
        window("00:00", "02:00", Program::Loop),
        window("02:00", "03:00", Program::Every { minutes: 20 }),
    ];
    let mut memory = Memory::default();
    // Friday 2026-12-04 20:00: starts; it plays on through midnight.
    assert!(matches!(
        step(&schedule, "2026-12-04T20:00", &mut memory),
        Action::Start { .. }
    ));
    assert_eq!(
        step(&schedule, "2026-12-05T00:00", &mut memory),
        Action::Nothing
    );
    assert_eq!(
        step(&schedule, "2026-12-05T01:59", &mut memory),
        Action::Nothing
    );
    // At 02:00 the program changes: the loop's window ends, then the next starts.
    assert!(matches!(
        step(&schedule, "2026-12-05T02:00", &mut memory),
        Action::End { .. }
    ));
    assert!(matches!(
        step(&schedule, "2026-12-05T02:00", &mut memory),
        Action::Start {
            program: Program::Every { minutes: 20 },
            ..
        }
    ));
    // A restart at 00:30 resumes the window that opened on Friday.
    let decision = decide(&schedule, at("2026-12-05T00:30"), &Memory::default());
    assert!(matches!(
        decision.action,
        Action::Start { occasion, .. } if occasion.window_start == at("2026-12-04T20:00")
    ));
    // Open all week long: one window, never ended at midnight.
    let mut always = Schedule {
        enabled: true,
        ..Schedule::default()
    };
    for day in Weekday::ALL {
        *always.week.day_mut(day) = vec![window("00:00", "24:00", Program::Loop)];
    }
    let mut memory = Memory::default();
    assert!(matches!(
        step(&always, "2026-12-01T08:00", &mut memory),
        Action::Start { .. }
    ));
    for day in 2..=28 {
        let now = format!("2026-12-{day:02}T00:00");
        assert_eq!(step(&always, &now, &mut memory), Action::Nothing, "{now}");
    }
}

#[test]
fn clocks_changing_neither_skip_nor_repeat_a_start() {
    // Europe/Zurich, 2026-03-29 (a Sunday): 02:00 jumps to 03:00. A window 02:30–04:00
    // starts when the clock shows 03:00; one of 02:00–02:45 never opens.
    let mut schedule = Schedule {
        enabled: true,
        ..Schedule::default()
    };
    schedule.week.sunday = vec![
        window("02:00", "02:45", Program::Every { minutes: 15 }),
        window("02:50", "04:00", Program::Loop),
    ];
    let mut memory = Memory::default();
    assert_eq!(
        step(&schedule, "2026-03-29T01:59:59", &mut memory),
        Action::Nothing
    );
    assert!(matches!(
        step(&schedule, "2026-03-29T03:00", &mut memory),
        Action::Start {
            program: Program::Loop,
            ..
        }
    ));
    // 2026-10-25: 03:00 goes back to 02:00. A window 01:00–02:30 every 30 minutes
    // ends at the first 02:30; in the repeated hour nothing starts or ends again.
    schedule.week.sunday = vec![window("01:00", "02:30", Program::Every { minutes: 30 })];
    let mut memory = Memory::default();
    let mut actions = Vec::new();
    for now in [
        "2026-10-25T01:00",
        "2026-10-25T01:30",
        "2026-10-25T02:00",
        "2026-10-25T02:30",
        "2026-10-25T02:59",
        // The clock goes back.
        "2026-10-25T02:00",
        "2026-10-25T02:10",
        "2026-10-25T02:30",
        "2026-10-25T02:59",
    ] {
        actions.push(match step(&schedule, now, &mut memory) {
            Action::Start { .. } => "start",
            Action::End { .. } => "end",
            Action::Nothing => "-",
        });
    }
    assert_eq!(
        actions,
        ["start", "start", "start", "end", "-", "-", "-", "-", "-"]
    );
}

#[test]
fn nothing_happens_with_the_schedule_off_or_empty() {
    let mut schedule = mall();
    schedule.enabled = false;
    let decision = decide(&schedule, at("2026-11-30T12:00"), &Memory::default());
    assert_eq!(decision.action, Action::Nothing);
    assert_eq!(decision.next_start, None);
    assert_eq!(decision.wake_at, None);
    let empty = Schedule {
        enabled: true,
        ..Schedule::default()
    };
    assert_eq!(
        decide(&empty, at("2026-11-30T12:00"), &Memory::default()).next_start,
        None
    );
}
