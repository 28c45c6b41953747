//! One ball's Q program for MOONS' drives over HTTP (`docs/api.md`, "Q programs").
//!
//! - `GET /api/qprogram/{show}?unit=N`: 200 [`QProgramListing`] (the listing and the
//!   compiler's report) for ball `N` (row-major, as the CSV's `uN`);
//!   `&format=text` answers the listing alone as `text/plain`, with a
//!   `Content-Disposition` naming the file `<show>-unit<N>.q` for download. 400 without
//!   a unit or with a bad query, 404 for an unknown show or a unit the show does not
//!   have, 422 when the show cannot be compiled (over the tolerance, with the figure;
//!   a move faster than the limits, with its time).
//!
//! Needs a [`Session`]. The compiling runs on a blocking thread. The compiler's
//! settings come from the installation through
//! [`qprogram_config`](crate::config::scl::qprogram_config), the one place that builds
//! them.

use axum::extract::{RawQuery, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use floatball_shared::api::QProgramListing;
use floatball_shared::codes::Code;
use floatball_shared::params;
use floatball_shared::plan::verdict::Why;
use floatball_shared::scl::drive::fire_from_program;
use floatball_shared::scl::qprogram::{QProgramError, Streaming, compile_for_drive};

use super::library::{NameParam, store_failure};
use super::session::Session;
use super::{Failure, blocking};
use crate::config::scl::{overrides, qprogram_config};
use crate::state::AppState;

/// The query: the ball and whether to answer text.
fn parse_query(query: Option<&str>) -> Result<(usize, bool), Failure> {
    let bad = |reason: String| {
        Failure::from_template(
            StatusCode::BAD_REQUEST,
            Code::BadQuery,
            params! {"reason" => reason},
        )
    };
    let mut unit = None;
    let mut text = false;
    for pair in query
        .unwrap_or_default()
        .split('&')
        .filter(|pair| !pair.is_empty())
    {
        let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
        match key {
            "unit" => {
                unit = Some(value.parse::<usize>().map_err(|_| {
                    bad(format!(
                        "unit must be a ball's number (0, 1, …), not \"{value}\""
                    ))
                })?);
            }
            "format" => match value {
                "text" => text = true,
                "json" => text = false,
                _ => return Err(bad(format!("format must be text or json, not \"{value}\""))),
            },
            _ => return Err(bad(format!("unknown query parameter \"{key}\""))),
        }
    }
    let unit = unit.ok_or_else(|| bad("say which ball: ?unit=N (0 is the first)".to_owned()))?;
    Ok((unit, text))
}

/// 422 for a show the compiler refuses (500 for settings it cannot use).
fn compile_failure(error: QProgramError, ball: usize) -> Failure {
    match error {
        QProgramError::InvalidConfig { .. } => {
            Failure::internal("the Q program settings are invalid", &error)
        }
        other => Failure::from_template(
            StatusCode::UNPROCESSABLE_ENTITY,
            Code::QprogramRefused,
            params! {"reason" => other},
        )
        .with_problems([&Why::Program { ball, error: other }]),
    }
}

/// A file name for the download: the show's name with anything but letters, digits,
/// `.`, `-` and `_` made `_`.
fn file_name(show: &str, unit: usize) -> String {
    let safe: String = show
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("{safe}-unit{unit}.q")
}

/// `GET /api/qprogram/{show}?unit=N[&format=text]`.
pub async fn qprogram(
    State(state): State<AppState>,
    _session: Session,
    NameParam(name): NameParam,
    RawQuery(query): RawQuery,
) -> Result<Response, Failure> {
    let (unit, text) = parse_query(query.as_deref())?;
    let compiling = state.clone();
    let listing = blocking(move || {
        let show = compiling.shows().load(&name).map_err(store_failure)?;
        let track = show.tracks.get(unit).ok_or_else(|| {
            Failure::from_template(
                StatusCode::NOT_FOUND,
                Code::NoSuchUnit,
                params! {"name" => name, "unit" => unit, "units" => show.tracks.len()},
            )
        })?;
        let config = compiling.config();
        let settings = qprogram_config(&config.installation, &overrides(&config));
        // As Start sends it: stored (or queued), or streamed when no stored program
        // follows the show (`programs`).
        let streaming = config
            .scl()
            .map_or(Streaming::Never, |scl| scl.programs.streaming());
        let mut program = compile_for_drive(track, &settings, streaming)
            .map_err(|error| compile_failure(error, unit))?;
        // The trigger drive's ball fires the common start from its own line 1 (as
        // Start uploads it): a stored program must do the same.
        if let Some(scl) = config.scl()
            && let Some((_, output)) = scl.trigger
            && let Some(place) = config.installation.units.get(unit)
            && place.gateway == 0
            && scl.trigger_drive() == Some(usize::from(place.station.saturating_sub(1)))
        {
            fire_from_program(&mut program.segments, output);
        }
        Ok::<_, Failure>(QProgramListing {
            unit,
            show: show.name.clone(),
            text: program.text(),
            segments: program.segments.len(),
            lines: program.lines(),
            moves: program.report.moves,
            max_deviation_mm: program.report.max_deviation_mm,
            at_ms: program.report.at_ms,
        })
    })
    .await??;
    if text {
        let disposition = format!(
            "attachment; filename=\"{}\"",
            file_name(&listing.show, unit)
        );
        Ok((
            [
                (header::CONTENT_TYPE, "text/plain; charset=utf-8".to_owned()),
                (header::CONTENT_DISPOSITION, disposition),
            ],
            listing.text,
        )
            .into_response())
    } else {
        Ok(axum::Json(listing).into_response())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_query_names_a_unit_and_maybe_text() {
        assert_eq!(parse_query(Some("unit=3")).unwrap(), (3, false));
        assert_eq!(parse_query(Some("unit=0&format=text")).unwrap(), (0, true));
        for bad in [
            None,
            Some(""),
            Some("unit=x"),
            Some("unit=1&format=pdf"),
            Some("u=1"),
        ] {
            assert_eq!(
                parse_query(bad).unwrap_err().status,
                StatusCode::BAD_REQUEST
            );
        }
    }

    #[test]
    fn the_download_name_is_safe() {
        assert_eq!(file_name("wave", 7), "wave-unit7.q");
        assert_eq!(file_name("a \"b\"/ç", 0), "a__b___-unit0.q");
    }
}
