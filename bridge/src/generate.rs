//! `floatball generate`: shows made from patterns or recipes on the command line, for
//! scripting (issue 19; the same generators as the app's Create page, in
//! `floatball_shared::create`).
//!
//! - `floatball generate <pattern> [--<param> <value>]... --out FILE` renders one
//!   pattern for `--duration-s` seconds; `--recipe-out FILE` also writes its recipe;
//! - `floatball generate --recipe FILE --out FILE` renders a recipe.
//!
//! The grid and limits are `--rows`, `--cols`, `--pitch-mm`, `--travel-mm` with the
//! default limits, or an installation's (`--config floatball.toml`). The command line is
//! built from [`PATTERNS`]: every pattern is a subcommand, every parameter a flag
//! named by its key as in recipes with hyphens (`--speed-m-s`; `--speed_m_s` works
//! too), so `--help` lists them all with unit, range and default. A file parameter (a picture) takes a path.
//!
//! Notes (values clamped to keep the show within the limits) go to stderr; a summary
//! and the planner's verdict on the installation to stdout.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Arg, ArgAction, ArgMatches, Command};
use floatball_shared::create::params::{ParamKind, ParamSpec, encode_base64};
use floatball_shared::create::{Grid, PATTERNS, Params, PatternSpec, Recipe, Value, render};
use floatball_shared::plan::report::report;
use floatball_shared::plan::{GatewaySpec, Installation, MAX_UNITS_PER_GATEWAY};
use floatball_shared::show::{DEFAULT_PITCH_MM, DEFAULT_TRAVEL_MM, Limits};
use floatball_shared::uim2503::plan::PlanOptions;

use crate::config::{self, Config, Overrides};

/// A pattern rendered alone lasts this long unless `--duration-s` says, s.
pub const DEFAULT_DURATION_S: f64 = 60.0;

/// A parameter's range and default in words: `[m/s, 0–5, default 0.5]`.
fn range_words(kind: &ParamKind) -> String {
    match *kind {
        ParamKind::Number {
            min,
            max,
            default,
            unit,
            ..
        } => {
            let unit = if unit.is_empty() {
                String::new()
            } else {
                format!("{unit}, ")
            };
            format!("[{unit}{min}–{max}, default {default}]")
        }
        ParamKind::Choice { options, default } => {
            format!("[{}; default {default}]", options.join(" | "))
        }
        ParamKind::Text { default, max_chars } => {
            format!("[text, at most {max_chars} characters, default \"{default}\"]")
        }
        ParamKind::Bytes { max_bytes } => format!("[a file's path, at most {max_bytes} bytes]"),
    }
}

/// A parameter's flag.
fn param_arg(spec: &ParamSpec) -> Arg {
    let arg = Arg::new(spec.key)
        .long(flag(spec.key))
        .alias(spec.key)
        .help(format!("{} {}", spec.help, range_words(&spec.kind)))
        .action(ArgAction::Set);
    match spec.kind {
        ParamKind::Number { .. } => arg
            .value_name("NUMBER")
            .allow_negative_numbers(true)
            .value_parser(clap::value_parser!(f64)),
        ParamKind::Choice { options, .. } => arg
            .value_name("CHOICE")
            .value_parser(clap::builder::PossibleValuesParser::new(options)),
        ParamKind::Text { .. } => arg.value_name("TEXT"),
        ParamKind::Bytes { .. } => arg
            .value_name("FILE")
            .value_parser(clap::value_parser!(PathBuf)),
    }
}

/// The flag of the parameter `key`: hyphens for the recipe key's underscores, like
/// the other options (`--speed-m-s`; the key itself, `--speed_m_s`, is accepted too).
fn flag(key: &str) -> String {
    key.replace('_', "-")
}

/// One pattern's subcommand.
fn pattern_command(pattern: &PatternSpec) -> Command {
    Command::new(pattern.name)
        .about(pattern.help)
        .args(pattern.params.iter().map(param_arg))
}

/// Every pattern and its parameters, for `floatball generate --help`.
fn catalogue_words() -> String {
    let mut text = String::from("Patterns and their parameters:\n");
    for pattern in PATTERNS {
        let _ = writeln!(text, "\n  {}: {}", pattern.name, pattern.help);
        for param in pattern.params {
            let _ = writeln!(
                text,
                "    --{} {}: {} {}",
                flag(param.key),
                param.label,
                param.help,
                range_words(&param.kind)
            );
        }
    }
    text
}

/// The `generate` subcommand, built from [`PATTERNS`].
#[must_use]
pub fn command() -> Command {
    let global = |arg: Arg| arg.global(true);
    Command::new("generate")
        .about(
            "Generate a show from a pattern or a recipe (a timeline of patterns) and write \
             it as a native show file; `floatball generate <pattern> --help` lists a \
             pattern's parameters",
        )
        .after_long_help(catalogue_words())
        .args_conflicts_with_subcommands(true)
        .arg(
            Arg::new("recipe")
                .long("recipe")
                .value_name("FILE")
                .value_parser(clap::value_parser!(PathBuf))
                .help("Render this recipe (JSON, see docs/create.md) instead of one pattern"),
        )
        .arg(global(
            Arg::new("out")
                .long("out")
                .value_name("FILE")
                .value_parser(clap::value_parser!(PathBuf))
                .help("Where to write the show (native JSON, as uploads)"),
        ))
        .arg(global(
            Arg::new("recipe-out")
                .long("recipe-out")
                .value_name("FILE")
                .value_parser(clap::value_parser!(PathBuf))
                .help("Also write the recipe that regenerates the show"),
        ))
        .arg(global(
            Arg::new("config")
                .long("config")
                .value_name("FILE")
                .value_parser(clap::value_parser!(PathBuf))
                .conflicts_with_all(["rows", "cols", "pitch-mm", "travel-mm"])
                .help(
                    "Generate for this installation (floatball.toml): its grid, limits and \
                     gateways",
                ),
        ))
        .arg(global(
            Arg::new("rows")
                .long("rows")
                .value_name("N")
                .value_parser(clap::value_parser!(u32).range(1..=1000))
                .help("Rows of balls [default: the recipe's grid, else 10]"),
        ))
        .arg(global(
            Arg::new("cols")
                .long("cols")
                .value_name("N")
                .value_parser(clap::value_parser!(u32).range(1..=1000))
                .help("Balls in each row [default: the recipe's grid, else 10]"),
        ))
        .arg(global(
            Arg::new("pitch-mm")
                .long("pitch-mm")
                .value_name("MM")
                .value_parser(clap::value_parser!(f64))
                .help(format!(
                    "Distance between balls, mm [default: the recipe's grid, else {DEFAULT_PITCH_MM}]"
                )),
        ))
        .arg(global(
            Arg::new("travel-mm")
                .long("travel-mm")
                .value_name("MM")
                .value_parser(clap::value_parser!(f64))
                .help(format!(
                    "Lowest position a ball may reach, mm below the top [default: the recipe's grid, \
                     else {DEFAULT_TRAVEL_MM}]"
                )),
        ))
        .arg(global(
            Arg::new("duration-s")
                .long("duration-s")
                .value_name("SECONDS")
                .value_parser(clap::value_parser!(f64))
                .help(format!(
                    "How long the pattern runs, s (with a pattern) [default {DEFAULT_DURATION_S}]"
                )),
        ))
        .arg(global(
            Arg::new("row-ms")
                .long("row-ms")
                .value_name("MS")
                .value_parser(clap::value_parser!(u32))
                .help("Every PVT row's length, ms, 10–255 (with a pattern) [default 200]"),
        ))
        .arg(global(
            Arg::new("name")
                .long("name")
                .value_name("NAME")
                .help("The show's name (with a pattern) [default the pattern's name]"),
        ))
        .subcommands(PATTERNS.iter().map(pattern_command))
}

/// The parameters given on the command line for `pattern`.
fn params_of(pattern: &PatternSpec, matches: &ArgMatches) -> anyhow::Result<Params> {
    let mut params = Params::new();
    for spec in pattern.params {
        let value = match spec.kind {
            ParamKind::Number { .. } => matches.get_one::<f64>(spec.key).map(|v| Value::Number(*v)),
            ParamKind::Choice { .. } | ParamKind::Text { .. } => matches
                .get_one::<String>(spec.key)
                .map(|text| Value::Text(text.clone())),
            ParamKind::Bytes { .. } => match matches.get_one::<PathBuf>(spec.key) {
                Some(path) => {
                    let bytes = std::fs::read(path)
                        .with_context(|| format!("cannot read {}", path.display()))?;
                    Some(Value::Text(encode_base64(&bytes)))
                }
                None => None,
            },
        };
        if let Some(value) = value {
            params.insert(spec.key.to_owned(), value);
        }
    }
    Ok(params)
}

/// The recipe asked for: read from `--recipe`, or one pattern with its flags.
fn recipe_of(matches: &ArgMatches) -> anyhow::Result<Recipe> {
    if let Some(path) = matches.get_one::<PathBuf>("recipe") {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read the recipe {}", path.display()))?;
        return Recipe::from_json(&text).with_context(|| format!("recipe {}", path.display()));
    }
    let Some((name, pattern_matches)) = matches.subcommand() else {
        bail!(
            "give a pattern ({}) or --recipe FILE; see floatball generate --help",
            floatball_shared::create::catalogue::names()
        );
    };
    let Some(pattern) = floatball_shared::create::pattern(name) else {
        bail!("there is no pattern {name}");
    };
    let duration_s = matches
        .get_one::<f64>("duration-s")
        .copied()
        .unwrap_or(DEFAULT_DURATION_S);
    let show_name = matches
        .get_one::<String>("name")
        .cloned()
        .unwrap_or_else(|| pattern.name.to_owned());
    let mut recipe = Recipe::single(
        &show_name,
        pattern.name,
        params_of(pattern, pattern_matches)?,
        duration_s,
    );
    if let Some(row_ms) = matches.get_one::<u32>("row-ms") {
        recipe.row_ms = *row_ms;
    }
    Ok(recipe)
}

/// The installation the show is made for, its grid, and how to name it in the
/// verdict: `--config`'s, else the grid of `--rows`, `--cols`, `--pitch-mm` and
/// `--travel-mm`, each defaulting to the recipe's grid (`made_for`) or the defaults.
fn installation_of(
    matches: &ArgMatches,
    made_for: Option<Grid>,
) -> anyhow::Result<(Installation, Grid, String)> {
    if let Some(path) = matches.get_one::<PathBuf>("config") {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let config = Config::parse(path, &text, &Overrides::default())?;
        let installation = config.installation;
        let limits = installation.limits;
        let grid = Grid::new(
            limits.rows,
            limits.cols,
            installation.pitch_mm,
            limits.travel_mm,
        );
        return Ok((
            installation,
            grid,
            format!("the installation in {}", path.display()),
        ));
    }
    let made_for = made_for.unwrap_or(Grid::new(10, 10, DEFAULT_PITCH_MM, DEFAULT_TRAVEL_MM));
    let rows = matches
        .get_one::<u32>("rows")
        .copied()
        .unwrap_or(made_for.rows);
    let cols = matches
        .get_one::<u32>("cols")
        .copied()
        .unwrap_or(made_for.cols);
    let pitch_mm = matches
        .get_one::<f64>("pitch-mm")
        .copied()
        .unwrap_or(made_for.pitch_mm);
    let travel_mm = matches
        .get_one::<f64>("travel-mm")
        .copied()
        .unwrap_or(made_for.travel_mm);
    let mut limits = Limits::for_layout(rows, cols);
    limits.travel_mm = travel_mm;
    let units = rows as usize * cols as usize;
    let gateways = units.div_ceil(MAX_UNITS_PER_GATEWAY);
    // As the default floatball.toml: simulated gateways at their default speed.
    let baud = config::DEFAULT_SIM_BAUD;
    let mut installation = Installation::row_major(
        limits,
        100.0,
        vec![GatewaySpec::uim2503("sim", baud); gateways],
        1,
    )?;
    installation.pitch_mm = pitch_mm;
    let grid = Grid::new(rows, cols, pitch_mm, travel_mm);
    Ok((
        installation,
        grid,
        format!(
            "the default installation ({gateways} simulated UIM2503 gateway(s) at {baud} \
             baud; --config for yours)"
        ),
    ))
}

fn write_file(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let file =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut writer = std::io::BufWriter::new(file);
    write(&mut writer)?;
    writer
        .flush()
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Runs `floatball generate` with its matches.
///
/// # Errors
/// A recipe or configuration that cannot be read, a pattern or parameter refused, a
/// file that cannot be written — in words for the person who typed the command.
pub fn run(matches: &ArgMatches) -> anyhow::Result<()> {
    let Some(out) = matches.get_one::<PathBuf>("out") else {
        bail!("give --out FILE: where to write the show");
    };
    let mut recipe = recipe_of(matches)?;
    let (installation, grid, installation_words) = installation_of(matches, recipe.grid)?;
    // Render the recipe as its file holds it, with the grid it is made for, so the file
    // regenerates this show.
    recipe.grid = Some(grid);
    let recipe_json = recipe.to_json()?;
    let recipe = Recipe::from_json(&recipe_json)?;
    let grid = recipe.grid.unwrap_or(grid);
    let generated = render(&recipe, &grid, &installation.limits)?;
    for note in &generated.notes {
        eprintln!("note: {note}");
    }
    let show = generated.show;
    write_file(out, |writer| Ok(show.write_json(writer)?))?;
    if let Some(path) = matches.get_one::<PathBuf>("recipe-out") {
        write_file(path, |writer| Ok(writer.write_all(recipe_json.as_bytes())?))?;
    }
    let rows = show.tracks.first().map_or(0, |track| track.rows.len());
    println!(
        "wrote {}: {} balls ({} × {}), {:.1} s, {rows} rows of {} ms each, {} bytes",
        out.display(),
        show.tracks.len(),
        grid.rows,
        grid.cols,
        show.duration_ms() as f64 / 1000.0,
        recipe.row_ms,
        show.json_bytes()
    );
    let verdict = report(&show, &installation, PlanOptions::default());
    if verdict.feasible {
        println!("verdict on {installation_words}: it can run");
    } else {
        println!(
            "verdict on {installation_words}: it cannot run: {}",
            verdict.reason.unwrap_or_default()
        );
        for fix in verdict.fixes {
            println!("  fix: {fix}");
        }
    }
    Ok(())
}
