//! The Create page's logic as plain types, tested natively; the page only wires it.
//!
//! - [`Draft`]: the show being made — its name, its timeline of segments (pattern,
//!   parameters, duration, the blend into the next), the segment being edited, and
//!   the grid it is made for while offline. Every edit keeps it valid: at least one
//!   segment, durations within the recipe's limits, parameters of the segment's
//!   pattern only. It reads from and writes to a recipe
//!   ([`floatball_shared::create::Recipe`]) so a show can be made again, changed,
//!   and saved as a small file.
//! - [`Target`]: what the show is made for: the controller's installation while
//!   connected (its grid, pitch, travel and limits), otherwise the offline grid with
//!   the default limits.
//! - [`Made`]: a generated show with what was changed to keep it within the limits;
//!   [`Target::verdict`], the planner's bandwidth verdict when an installation is
//!   known — computed here in the browser, with the same code as the controller.
//!   (The check against the limits is the preview's, shown under the picture.)

use floatball_shared::api::{InstallationInfo, PlanReport};
use floatball_shared::create::recipe::{
    self, DEFAULT_ROW_MS, MAX_SEGMENTS, MAX_SHOW_S, MAX_TRANSITION_S, MIN_DURATION_S,
    MIN_TRANSITION_S, Recipe, Segment,
};
use floatball_shared::create::{
    self, CreateError, Grid, Note, PATTERNS, ParamKind, ParamSpec, Params, PatternSpec, Value,
};
use floatball_shared::plan::report::report;
use floatball_shared::show::{DEFAULT_PITCH_MM, DEFAULT_TRAVEL_MM, Limits, Show};
use floatball_shared::uim2503::plan::PlanOptions;

/// A new segment's length, s.
pub const DEFAULT_SEGMENT_S: f64 = 20.0;
/// The offline grid at first: rows and columns.
pub const DEFAULT_GRID: (u32, u32) = (10, 10);
/// The largest offline grid in each direction (a 100 × 100 matrix).
pub const MAX_GRID: u32 = 100;
/// The name of a new show.
pub const DEFAULT_NAME: &str = "new show";

/// The show being made.
#[derive(Debug, Clone, PartialEq)]
pub struct Draft {
    /// The show's name (and its file's, with `.json`).
    pub name: String,
    /// The timeline, at least one segment.
    segments: Vec<Segment>,
    /// The segment being edited.
    selected: usize,
    /// Every PVT row's length, ms.
    row_ms: u32,
    /// The grid while offline: rows and columns.
    grid: (u32, u32),
}

impl Default for Draft {
    fn default() -> Self {
        Self::new()
    }
}

impl Draft {
    /// A draft of one segment of the first pattern with its defaults.
    pub fn new() -> Self {
        let first = PATTERNS.first().map_or("wave", |spec| spec.name);
        Self {
            name: DEFAULT_NAME.to_owned(),
            segments: vec![new_segment(first)],
            selected: 0,
            row_ms: DEFAULT_ROW_MS,
            grid: DEFAULT_GRID,
        }
    }

    /// The timeline.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// The segment being edited (0-based).
    pub fn selected(&self) -> usize {
        self.selected
    }

    /// The segment being edited.
    pub fn current(&self) -> &Segment {
        &self.segments[self.selected]
    }

    /// Edits segment `index` (ignored beyond the timeline).
    pub fn select(&mut self, index: usize) {
        if index < self.segments.len() {
            self.selected = index;
        }
    }

    /// Adds a segment of `pattern` with its defaults after the one being edited and
    /// edits it; nothing when the timeline is full or the pattern unknown.
    pub fn add(&mut self, pattern: &str) -> bool {
        if self.segments.len() >= MAX_SEGMENTS || create::pattern(pattern).is_none() {
            return false;
        }
        self.selected += 1;
        self.segments.insert(self.selected, new_segment(pattern));
        true
    }

    /// Removes segment `index`; the last one stays.
    pub fn remove(&mut self, index: usize) -> bool {
        if self.segments.len() <= 1 || index >= self.segments.len() {
            return false;
        }
        self.segments.remove(index);
        if self.selected > index || self.selected >= self.segments.len() {
            self.selected = self.selected.saturating_sub(1);
        }
        true
    }

    /// Moves segment `index` one place earlier (`up`) or later; the edited one follows.
    pub fn move_segment(&mut self, index: usize, up: bool) -> bool {
        let Some(other) = (if up {
            index.checked_sub(1)
        } else {
            Some(index + 1)
        }) else {
            return false;
        };
        if index >= self.segments.len() || other >= self.segments.len() {
            return false;
        }
        self.segments.swap(index, other);
        if self.selected == index {
            self.selected = other;
        } else if self.selected == other {
            self.selected = index;
        }
        true
    }

    /// Gives the edited segment another pattern, with that pattern's defaults.
    pub fn set_pattern(&mut self, pattern: &str) {
        if create::pattern(pattern).is_some() && self.current().pattern != pattern {
            let segment = &mut self.segments[self.selected];
            segment.pattern = pattern.to_owned();
            segment.params = Params::new();
        }
    }

    /// Sets parameter `key` of the edited segment: a number is kept within its range,
    /// a choice must be one of its words, text is cut to its length; other keys are
    /// ignored.
    pub fn set_param(&mut self, key: &str, value: Value) {
        let Some(spec) = pattern_of(self.current()).and_then(|pattern| pattern.param(key)) else {
            return;
        };
        let value = match (spec.kind, value) {
            (ParamKind::Number { min, max, .. }, Value::Number(number)) if number.is_finite() => {
                Value::Number(number.clamp(min, max))
            }
            (ParamKind::Choice { options, .. }, Value::Text(text))
                if options.contains(&text.as_str()) =>
            {
                Value::Text(text)
            }
            (ParamKind::Text { max_chars, .. }, Value::Text(text)) => {
                Value::Text(text.chars().take(max_chars).collect())
            }
            (ParamKind::Bytes { .. }, Value::Text(text)) => Value::Text(text),
            _ => return,
        };
        self.segments[self.selected]
            .params
            .insert(key.to_owned(), value);
    }

    /// The value of parameter `spec` in the edited segment: as set, or its default.
    pub fn value(&self, spec: &ParamSpec) -> Option<Value> {
        self.current()
            .params
            .get(spec.key)
            .cloned()
            .or_else(|| spec.kind.default_value())
    }

    /// Sets the edited segment's length, s, within the recipe's limits.
    pub fn set_duration_s(&mut self, duration_s: f64) {
        if duration_s.is_finite() {
            self.segments[self.selected].duration_s = duration_s.clamp(MIN_DURATION_S, MAX_SHOW_S);
        }
    }

    /// Sets the edited segment's blend into the next, s, within the recipe's limits.
    pub fn set_transition_s(&mut self, transition_s: f64) {
        if transition_s.is_finite() {
            self.segments[self.selected].transition_s =
                transition_s.clamp(MIN_TRANSITION_S, MAX_TRANSITION_S);
        }
    }

    /// The show's length, s: the segments, the blends between them, and the start
    /// from rest and the end at rest ([`recipe::EASE_S`] in all; the show rounds it up
    /// to whole rows).
    pub fn total_s(&self) -> f64 {
        let timeline_s = self.recipe().duration_s();
        timeline_s + recipe::EASE_S.min(timeline_s)
    }

    /// The offline grid: rows and columns.
    pub fn grid(&self) -> (u32, u32) {
        self.grid
    }

    /// Sets the offline grid, each 1 to [`MAX_GRID`].
    pub fn set_grid(&mut self, rows: u32, cols: u32) {
        self.grid = (rows.clamp(1, MAX_GRID), cols.clamp(1, MAX_GRID));
    }

    /// The file the show is saved as: its name (or [`DEFAULT_NAME`]) with `.json`,
    /// without characters a file or the controller would refuse.
    pub fn file_name(&self) -> String {
        format!("{}.json", self.show_name())
    }

    /// The recipe's file: its name with `.recipe.json`.
    pub fn recipe_file_name(&self) -> String {
        format!("{}.recipe.json", self.show_name())
    }

    /// The show's name on the controller: the name, trimmed, with `/ \ : * ? " < >
    /// |` and control characters replaced by `-`.
    pub fn show_name(&self) -> String {
        let name: String = self
            .name
            .trim()
            .chars()
            .map(|c| {
                if c.is_control() || "/\\:*?\"<>|".contains(c) {
                    '-'
                } else {
                    c
                }
            })
            .collect();
        if name.is_empty() {
            DEFAULT_NAME.to_owned()
        } else {
            name
        }
    }

    /// The recipe of this draft, made for the offline grid (as the browser keeps it).
    pub fn recipe(&self) -> Recipe {
        self.recipe_for(&Target::of(None, self.grid))
    }

    /// The recipe of this draft, made for `target`'s grid (as it is downloaded).
    pub fn recipe_for(&self, target: &Target) -> Recipe {
        Recipe {
            name: self.show_name(),
            row_ms: self.row_ms,
            grid: Some(target.grid),
            segments: self.segments.clone(),
        }
    }

    /// A draft from a recipe (checked as the renderer checks it), editing its first
    /// segment; offline it is made for the recipe's rows and columns, or `grid` for a
    /// recipe without.
    ///
    /// # Errors
    /// Why the recipe cannot be used, in the renderer's words.
    pub fn from_recipe(recipe: Recipe, grid: (u32, u32)) -> Result<Self, CreateError> {
        recipe.check()?;
        let mut draft = Self {
            name: recipe.name,
            segments: recipe.segments,
            selected: 0,
            row_ms: recipe.row_ms,
            grid,
        };
        if let Some(made_for) = recipe.grid {
            draft.set_grid(made_for.rows, made_for.cols);
        }
        Ok(draft)
    }

    /// Generates the show for `target`.
    ///
    /// # Errors
    /// Why it cannot be made (a parameter of the wrong kind, a picture that cannot be
    /// read), in the renderer's words.
    pub fn make(&self, target: &Target) -> Result<Made, CreateError> {
        let generated = create::render::render(&self.recipe(), &target.grid, &target.limits)?;
        Ok(Made {
            show: generated.show,
            notes: generated.notes,
        })
    }
}

/// What a show is made for.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// The grid, pitch and travel.
    pub grid: Grid,
    /// The limits it must keep.
    pub limits: Limits,
    /// The controller's installation, for the bandwidth verdict; none offline.
    pub installation: Option<InstallationInfo>,
}

impl Target {
    /// The planner's verdict on `show` for the installation (none offline): planned
    /// in the browser exactly as the controller would. A whole plan, so the page
    /// asks for it after the picture, not on every change.
    pub fn verdict(&self, show: &Show) -> Option<PlanReport> {
        self.installation
            .as_ref()
            .map(|info| report(show, &info.installation(), PlanOptions::default()))
    }
}

impl Target {
    /// The controller's installation, or (offline) `rows` × `cols` at the default
    /// pitch, travel and limits.
    pub fn of(installation: Option<&InstallationInfo>, (rows, cols): (u32, u32)) -> Self {
        match installation {
            Some(info) => Self {
                grid: Grid::new(info.rows, info.cols, info.pitch_mm, info.travel_mm),
                limits: info.limits(),
                installation: Some(info.clone()),
            },
            None => Self {
                grid: Grid::new(rows, cols, DEFAULT_PITCH_MM, DEFAULT_TRAVEL_MM),
                limits: Limits::for_layout(rows, cols),
                installation: None,
            },
        }
    }
}

/// The planner's verdict on `recipe` (JSON) for the installation `installation`
/// (JSON, as `GET /api/installation` gives it): the show rendered and planned as the
/// page would, as `PlanReport` JSON. What `static/plan-worker.js` runs, off the page's
/// thread: planning 100 × 100 balls for a minute takes about a second.
///
/// # Errors
/// The recipe or the installation cannot be read, or the show cannot be made.
pub fn plan_recipe(recipe_json: &str, installation_json: &str) -> Result<String, String> {
    let recipe = Recipe::from_json(recipe_json).map_err(|error| error.to_string())?;
    let info: InstallationInfo = serde_json::from_str(installation_json)
        .map_err(|error| format!("the installation cannot be read: {error}"))?;
    let target = Target::of(Some(&info), (info.rows, info.cols));
    let generated = create::render::render(&recipe, &target.grid, &target.limits)
        .map_err(|error| error.to_string())?;
    let report = target.verdict(&generated.show);
    serde_json::to_string(&report).map_err(|error| error.to_string())
}

/// A generated show and what the page says about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Made {
    /// The show.
    pub show: Show,
    /// What was changed to keep it within the limits, and which parameter to change.
    pub notes: Vec<Note>,
}

/// A new segment of `pattern` with its defaults.
fn new_segment(pattern: &str) -> Segment {
    Segment {
        pattern: pattern.to_owned(),
        params: Params::new(),
        duration_s: DEFAULT_SEGMENT_S,
        transition_s: recipe::DEFAULT_TRANSITION_S,
    }
}

/// The pattern of `segment`.
pub fn pattern_of(segment: &Segment) -> Option<&'static PatternSpec> {
    create::pattern(&segment.pattern)
}

/// A number parameter's value as the page writes it: as many decimals as its step.
pub fn format_number(value: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10()).ceil().clamp(0.0, 6.0) as usize
    };
    format!("{value:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    fn numbers(draft: &Draft) -> Vec<(&'static str, f64)> {
        let pattern = pattern_of(draft.current()).unwrap();
        pattern
            .params
            .iter()
            .filter_map(|spec| match draft.value(spec) {
                Some(Value::Number(n)) => Some((spec.key, n)),
                _ => None,
            })
            .collect()
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_new_draft_is_one_segment_of_the_first_pattern_with_its_defaults() {
        let draft = Draft::new();
        assert_eq!(draft.segments().len(), 1);
        assert_eq!(draft.current().pattern, PATTERNS[0].name);
        assert!(draft.current().params.is_empty());
        for (key, value) in numbers(&draft) {
            let spec = PATTERNS[0].param(key).unwrap();
            assert_eq!(spec.kind.default_value(), Some(Value::Number(value)));
        }
        assert_eq!(draft.total_s(), DEFAULT_SEGMENT_S + recipe::EASE_S);
        assert_eq!(draft.recipe().segments.len(), 1);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn segments_are_added_after_the_edited_one_moved_and_removed_but_one_stays() {
        let mut draft = Draft::new();
        let other = PATTERNS.last().unwrap().name;
        assert!(draft.add(other));
        assert_eq!(draft.selected(), 1);
        assert!(draft.add(PATTERNS[0].name));
        assert_eq!(draft.selected(), 2);
        assert!(!draft.add("no such pattern"));
        let names = |d: &Draft| {
            d.segments()
                .iter()
                .map(|s| s.pattern.clone())
                .collect::<Vec<_>>()
        };
        assert_eq!(names(&draft), [PATTERNS[0].name, other, PATTERNS[0].name]);
        // The edited segment follows its move.
        draft.select(1);
        assert!(draft.move_segment(1, true));
        assert_eq!(draft.selected(), 0);
        assert_eq!(names(&draft)[0], other);
        assert!(!draft.move_segment(0, true));
        assert!(!draft.move_segment(2, false));
        assert!(draft.remove(0));
        assert_eq!(draft.selected(), 0);
        assert!(draft.remove(1));
        assert!(!draft.remove(0), "the last segment stays");
        assert_eq!(draft.segments().len(), 1);
        assert!(!draft.remove(5));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn parameters_stay_within_their_ranges_and_a_new_pattern_starts_from_its_defaults() {
        let mut draft = Draft::new();
        let pattern = pattern_of(draft.current()).unwrap();
        let (spec, max) = pattern
            .params
            .iter()
            .find_map(|spec| match spec.kind {
                ParamKind::Number { max, .. } => Some((spec, max)),
                _ => None,
            })
            .unwrap();
        draft.set_param(spec.key, Value::Number(max * 10.0 + 1.0));
        assert_eq!(draft.value(spec), Some(Value::Number(max)));
        draft.set_param(spec.key, Value::Number(f64::NAN));
        assert_eq!(draft.value(spec), Some(Value::Number(max)));
        draft.set_param("no_such_key", Value::Number(1.0));
        assert_eq!(draft.current().params.len(), 1);
        if let Some(choice) = pattern
            .params
            .iter()
            .find(|spec| matches!(spec.kind, ParamKind::Choice { .. }))
        {
            let before = draft.value(choice);
            draft.set_param(choice.key, Value::Text("not a choice".into()));
            assert_eq!(draft.value(choice), before);
        }
        let other = PATTERNS.iter().find(|p| p.name != pattern.name).unwrap();
        draft.set_pattern(other.name);
        assert_eq!(draft.current().pattern, other.name);
        assert!(draft.current().params.is_empty());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn durations_stay_within_the_recipe_limits() {
        let mut draft = Draft::new();
        draft.set_duration_s(1e9);
        assert_eq!(draft.current().duration_s, MAX_SHOW_S);
        draft.set_duration_s(-3.0);
        assert_eq!(draft.current().duration_s, MIN_DURATION_S);
        draft.set_transition_s(-1.0);
        assert_eq!(draft.current().transition_s, MIN_TRANSITION_S);
        draft.set_transition_s(f64::INFINITY);
        assert_eq!(draft.current().transition_s, MIN_TRANSITION_S);
        draft.set_transition_s(1e6);
        assert_eq!(draft.current().transition_s, MAX_TRANSITION_S);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn names_become_file_names_the_controller_accepts() {
        let mut draft = Draft::new();
        draft.name = "  lobby/wave: v2?  ".into();
        assert_eq!(draft.show_name(), "lobby-wave- v2-");
        assert_eq!(draft.file_name(), "lobby-wave- v2-.json");
        assert_eq!(draft.recipe_file_name(), "lobby-wave- v2-.recipe.json");
        draft.name = "   ".into();
        assert_eq!(draft.file_name(), format!("{DEFAULT_NAME}.json"));
        assert_eq!(format_number(0.25, 0.05), "0.25");
        assert_eq!(format_number(1500.0, 10.0), "1500");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_draft_round_trips_through_its_recipe() {
        let mut draft = Draft::new();
        draft.add(PATTERNS.last().unwrap().name);
        draft.set_duration_s(7.5);
        draft.name = "round trip".into();
        let json = draft.recipe().to_json().unwrap();
        let back = Draft::from_recipe(Recipe::from_json(&json).unwrap(), draft.grid()).unwrap();
        assert_eq!(back.segments(), draft.segments());
        assert_eq!(back.name, "round trip");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_recipe_carries_the_grid_it_is_made_for() {
        let mut draft = Draft::new();
        draft.set_grid(6, 7);
        // Kept in the browser: the offline grid; opened again, the draft is made for it.
        let kept = draft.recipe();
        assert_eq!(
            kept.grid,
            Some(Grid::new(6, 7, DEFAULT_PITCH_MM, DEFAULT_TRAVEL_MM))
        );
        let opened = Draft::from_recipe(kept, DEFAULT_GRID).unwrap();
        assert_eq!(opened.grid(), (6, 7));
        // Downloaded while connected: the installation's grid.
        let target = Target {
            grid: Grid::new(3, 4, 400.0, 3000.0),
            limits: Limits::for_layout(3, 4),
            installation: None,
        };
        let downloaded = draft.recipe_for(&target);
        assert_eq!(downloaded.grid, Some(target.grid));
        assert_eq!(
            Draft::from_recipe(downloaded, DEFAULT_GRID).unwrap().grid(),
            (3, 4)
        );
        // A recipe without a grid keeps the grid the page has.
        let mut bare = draft.recipe();
        bare.grid = None;
        assert_eq!(Draft::from_recipe(bare, (2, 9)).unwrap().grid(), (2, 9));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_made_show_fits_its_target_and_gets_a_verdict_for_an_installation() {
        let mut draft = Draft::new();
        draft.set_grid(4, 5);
        draft.set_duration_s(5.0);
        let offline = Target::of(None, draft.grid());
        let made = draft.make(&offline).unwrap();
        assert_eq!((made.show.layout.rows, made.show.layout.cols), (4, 5));
        let violations = floatball_shared::show::validate(&made.show, &offline.limits);
        assert!(violations.is_empty(), "{violations:?}");
        assert!(offline.verdict(&made.show).is_none());

        let installation = floatball_shared::plan::Installation::demo(3, 4, &[115_200]).unwrap();
        let info = InstallationInfo {
            rows: 3,
            cols: 4,
            pitch_mm: installation.pitch_mm,
            travel_mm: installation.limits.travel_mm,
            max_speed_mm_s: installation.limits.max_speed_mm_s,
            max_accel_mm_s2: installation.limits.max_accel_mm_s2,
            home_mm: installation.home_mm,
            approach_speed_mm_s: installation.approach_speed_mm_s,
            counts_per_mm: installation.counts_per_mm,
            gateways: vec![floatball_shared::api::InstallationGateway {
                kind: floatball_shared::api::GatewayKind::Uim2503,
                port: "sim".into(),
                baud: Some(115_200),
                stations: (1..=12).collect(),
            }],
        };
        let online = Target::of(Some(&info), draft.grid());
        assert_eq!(online.grid.rows, 3);
        let made = draft.make(&online).unwrap();
        assert_eq!((made.show.layout.rows, made.show.layout.cols), (3, 4));
        let verdict = online.verdict(&made.show).unwrap();
        assert!(verdict.feasible, "{verdict:?}");

        // The worker's planner: the same verdict from the recipe and the installation
        // as JSON; what it cannot read, said.
        let recipe = draft.recipe().to_json().unwrap();
        let installation = serde_json::to_string(&info).unwrap();
        let planned = plan_recipe(&recipe, &installation).unwrap();
        let planned: Option<PlanReport> = serde_json::from_str(&planned).unwrap();
        assert_eq!(planned, Some(verdict));
        let error = plan_recipe(&recipe, "{}").unwrap_err();
        assert!(
            error.starts_with("the installation cannot be read"),
            "{error}"
        );
        assert!(plan_recipe("{", &installation).is_err());
    }
}
