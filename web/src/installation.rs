//! The installation as the app uses and edits it (`GET` / `PUT /api/installation`):
//!
//! - [`limits_of`]: the limits the preview, its plots and the client-side validation
//!   check a show against once the bridge has said them (the defaults before);
//! - [`InstallationForm`]: the installation settings page's fields as typed, read
//!   back into an [`InstallationInfo`] with every field that cannot be read (the
//!   bridge then checks the values as `floatball check` does and lists every problem);
//! - [`format_stations`] / [`parse_stations`]: a gateway's stations as ranges
//!   (`1-50, 52`);
//! - [`health_warnings`]: the gateways whose units are not all there or not all well,
//!   which the Control page says before Start.

use floatball_shared::api::{
    GatewayKind, GatewayStatus, InstallationGateway, InstallationInfo, UnitFault,
};
use floatball_shared::show::Limits;

/// The limits of `info`'s matrix: its grid, travel, top speed and acceleration.
#[must_use]
pub fn limits_of(info: &InstallationInfo) -> Limits {
    info.limits()
}

/// Stations as ranges, in their order: `[1, 2, 3, 5]` → `1-3, 5`.
#[must_use]
pub fn format_stations(stations: &[u8]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut index = 0;
    while index < stations.len() {
        let first = stations[index];
        let mut last = first;
        while index + 1 < stations.len() && Some(stations[index + 1]) == last.checked_add(1) {
            index += 1;
            last = stations[index];
        }
        parts.push(if last == first {
            first.to_string()
        } else {
            format!("{first}-{last}")
        });
        index += 1;
    }
    parts.join(", ")
}

/// Reads stations typed as numbers and ranges separated by commas, semicolons or
/// spaces (`1-50, 52`; an en dash works as the hyphen); `None` when a part is not
/// a station number (0–255) or a range runs backwards. An empty text is no stations.
#[must_use]
pub fn parse_stations(text: &str) -> Option<Vec<u8>> {
    let mut stations = Vec::new();
    let normalised = text.replace(['–', '—'], "-");
    // Spaces around a hyphen belong to the range.
    let mut compact = normalised.replace(" -", "-");
    while compact.contains("- ") {
        compact = compact.replace("- ", "-");
    }
    for part in compact
        .split([',', ';', ' '])
        .filter(|part| !part.is_empty())
    {
        match part.split_once('-') {
            Some((first, last)) => {
                let first: u8 = first.parse().ok()?;
                let last: u8 = last.parse().ok()?;
                if last < first {
                    return None;
                }
                stations.extend(first..=last);
            }
            None => stations.push(part.parse().ok()?),
        }
    }
    Some(stations)
}

/// A number of the matrix on the installation page.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// Rows of balls.
    Rows,
    /// Columns of balls.
    Cols,
    /// Distance between balls, mm.
    Pitch,
    /// Lowest position, mm.
    Travel,
    /// Calibration, counts per mm.
    CountsPerMm,
    /// Top speed, mm/s.
    MaxSpeed,
    /// Top acceleration, mm/s².
    MaxAccel,
    /// Home position, mm.
    Home,
    /// Speed of the approach, mm/s.
    ApproachSpeed,
}

impl Field {
    /// Every field, in the page's order.
    pub const ALL: [Field; 9] = [
        Field::Rows,
        Field::Cols,
        Field::Pitch,
        Field::Travel,
        Field::CountsPerMm,
        Field::MaxSpeed,
        Field::MaxAccel,
        Field::Home,
        Field::ApproachSpeed,
    ];

    /// Its name in `floatball.toml` and in the page's `data-testid`s.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Field::Rows => "rows",
            Field::Cols => "cols",
            Field::Pitch => "pitch_mm",
            Field::Travel => "travel_mm",
            Field::CountsPerMm => "counts_per_mm",
            Field::MaxSpeed => "max_speed_mm_s",
            Field::MaxAccel => "max_accel_mm_s2",
            Field::Home => "home_mm",
            Field::ApproachSpeed => "approach_speed_mm_s",
        }
    }

    /// Whether it is a whole number (rows, columns).
    #[must_use]
    pub fn whole(self) -> bool {
        matches!(self, Field::Rows | Field::Cols)
    }

    fn of(self, info: &InstallationInfo) -> f64 {
        match self {
            Field::Rows => f64::from(info.rows),
            Field::Cols => f64::from(info.cols),
            Field::Pitch => info.pitch_mm,
            Field::Travel => info.travel_mm,
            Field::CountsPerMm => info.counts_per_mm,
            Field::MaxSpeed => info.max_speed_mm_s,
            Field::MaxAccel => info.max_accel_mm_s2,
            Field::Home => info.home_mm,
            Field::ApproachSpeed => info.approach_speed_mm_s,
        }
    }
}

/// What of a gateway is typed on the installation page.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GatewayField {
    /// Its port.
    Port,
    /// Its line speed.
    Baud,
    /// Its stations.
    Stations,
}

/// A field of the installation page that cannot be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormError {
    /// A number of the matrix.
    Matrix(Field),
    /// A field of gateway `.0` (0-based).
    Gateway(usize, GatewayField),
}

/// One gateway on the installation page, as typed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GatewayForm {
    /// Its drive family (not edited here).
    pub kind: GatewayKind,
    /// Its port.
    pub port: String,
    /// Its line speed, baud; empty for none (UDP).
    pub baud: String,
    /// Its stations as ranges ([`format_stations`]).
    pub stations: String,
}

/// The installation page's fields as typed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InstallationForm {
    /// The matrix's numbers, in [`Field::ALL`]'s order.
    pub matrix: [String; 9],
    /// Every gateway, in configuration order.
    pub gateways: Vec<GatewayForm>,
}

/// A number as the form shows it: no needless decimals.
fn format_number(value: f64) -> String {
    let text = format!("{value:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

/// Reads a number typed with a point or a comma.
fn parse_number(text: &str) -> Option<f64> {
    text.trim()
        .replace(',', ".")
        .parse::<f64>()
        .ok()
        .filter(|value| value.is_finite())
}

impl InstallationForm {
    /// The fields showing `info`.
    #[must_use]
    pub fn of(info: &InstallationInfo) -> Self {
        Self {
            matrix: Field::ALL.map(|field| format_number(field.of(info))),
            gateways: info
                .gateways
                .iter()
                .map(|gateway| GatewayForm {
                    kind: gateway.kind,
                    port: gateway.port.clone(),
                    baud: gateway
                        .baud
                        .map(|baud| baud.to_string())
                        .unwrap_or_default(),
                    stations: format_stations(&gateway.stations),
                })
                .collect(),
        }
    }

    /// The field `field` as typed.
    #[must_use]
    pub fn value(&self, field: Field) -> &str {
        &self.matrix[field as usize]
    }

    /// Sets the field `field`.
    pub fn set(&mut self, field: Field, value: String) {
        self.matrix[field as usize] = value;
    }

    /// The installation the fields say, or every field that cannot be read (the
    /// values themselves are the bridge's to check).
    ///
    /// # Errors
    /// Every [`FormError`], in the page's order.
    pub fn read(&self) -> Result<InstallationInfo, Vec<FormError>> {
        let mut errors = Vec::new();
        let mut numbers = [0.0; 9];
        for field in Field::ALL {
            let number = parse_number(self.value(field)).filter(|value| {
                !field.whole()
                    || (value.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(value))
            });
            match number {
                Some(value) => numbers[field as usize] = value,
                None => errors.push(FormError::Matrix(field)),
            }
        }
        let mut gateways = Vec::new();
        for (index, gateway) in self.gateways.iter().enumerate() {
            let port = gateway.port.trim().to_owned();
            if port.is_empty() {
                errors.push(FormError::Gateway(index, GatewayField::Port));
            }
            let baud = match gateway.baud.trim() {
                "" => None,
                text => match text.parse::<u32>() {
                    Ok(baud) => Some(baud),
                    Err(_) => {
                        errors.push(FormError::Gateway(index, GatewayField::Baud));
                        None
                    }
                },
            };
            let stations = parse_stations(&gateway.stations).unwrap_or_else(|| {
                errors.push(FormError::Gateway(index, GatewayField::Stations));
                Vec::new()
            });
            gateways.push(InstallationGateway {
                kind: gateway.kind,
                port,
                baud,
                stations,
            });
        }
        if !errors.is_empty() {
            return Err(errors);
        }
        let number = |field: Field| numbers[field as usize];
        Ok(InstallationInfo {
            rows: number(Field::Rows) as u32,
            cols: number(Field::Cols) as u32,
            pitch_mm: number(Field::Pitch),
            travel_mm: number(Field::Travel),
            max_speed_mm_s: number(Field::MaxSpeed),
            max_accel_mm_s2: number(Field::MaxAccel),
            home_mm: number(Field::Home),
            approach_speed_mm_s: number(Field::ApproachSpeed),
            counts_per_mm: number(Field::CountsPerMm),
            gateways,
        })
    }
}

/// A gateway whose units are not all there or not all well ([`health_warnings`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HealthWarning {
    /// The gateway's port.
    pub port: String,
    /// Units configured on it.
    pub expected: u32,
    /// Of those, how many answer.
    pub answering: u32,
    /// Configured stations that do not answer.
    pub missing: Vec<u8>,
    /// Stations more than one unit answers on.
    pub duplicated: Vec<u8>,
    /// The units' last errors.
    pub faults: Vec<UnitFault>,
}

/// The gateways whose units are missing, share a station or reported an error, as
/// the bridge last heard them (gateways it has not asked yet say nothing).
#[must_use]
pub fn health_warnings(gateways: &[GatewayStatus]) -> Vec<HealthWarning> {
    gateways
        .iter()
        .filter_map(|gateway| {
            let health = gateway.health.as_ref()?;
            let unwell = health.answering < health.expected
                || !health.missing.is_empty()
                || !health.duplicated.is_empty()
                || !health.faults.is_empty();
            unwell.then(|| HealthWarning {
                port: gateway.port.clone(),
                expected: health.expected,
                answering: health.answering,
                missing: health.missing.clone(),
                duplicated: health.duplicated.clone(),
                faults: health.faults.clone(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use wasm_bindgen_test::wasm_bindgen_test;

    use floatball_shared::api::{LinkState, UnitHealth};

    use super::*;

    fn info() -> InstallationInfo {
        InstallationInfo {
            rows: 10,
            cols: 10,
            pitch_mm: 500.0,
            travel_mm: 7500.0,
            max_speed_mm_s: 2000.0,
            max_accel_mm_s2: 4000.0,
            home_mm: 0.0,
            approach_speed_mm_s: 250.0,
            counts_per_mm: 100.0,
            gateways: vec![InstallationGateway {
                kind: GatewayKind::Uim2503,
                port: "sim".into(),
                baud: Some(115_200),
                stations: (1..=100).collect(),
            }],
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn limits_come_from_the_installation() {
        let mut info = info();
        info.max_speed_mm_s = 300.0;
        info.rows = 2;
        let limits = limits_of(&info);
        assert_eq!(limits.max_speed_mm_s, 300.0);
        assert_eq!((limits.rows, limits.cols), (2, 10));
        assert_eq!(limits.travel_mm, 7500.0);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn stations_read_and_write_as_ranges() {
        assert_eq!(format_stations(&[1, 2, 3, 5, 7, 8]), "1-3, 5, 7-8");
        assert_eq!(format_stations(&[]), "");
        assert_eq!(format_stations(&[254, 255]), "254-255");
        assert_eq!(format_stations(&[3, 2, 1]), "3, 2, 1", "order is kept");
        for stations in [vec![1, 2, 3, 5, 7, 8], (1..=100).collect(), vec![9, 4, 4]] {
            assert_eq!(
                parse_stations(&format_stations(&stations)),
                Some(stations.clone())
            );
        }
        assert_eq!(parse_stations("1 – 3; 9"), Some(vec![1, 2, 3, 9]));
        assert_eq!(parse_stations("4 5"), Some(vec![4, 5]));
        assert_eq!(parse_stations("  "), Some(Vec::new()));
        for bad in ["5-3", "300", "a", "1-", "-2", "1.5"] {
            assert_eq!(parse_stations(bad), None, "{bad}");
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_form_shows_and_reads_back_the_installation() {
        let info = info();
        let form = InstallationForm::of(&info);
        assert_eq!(form.value(Field::Pitch), "500");
        assert_eq!(form.gateways[0].stations, "1-100");
        assert_eq!(form.gateways[0].baud, "115200");
        assert_eq!(form.read(), Ok(info.clone()));

        let mut changed = form.clone();
        changed.set(Field::MaxSpeed, " 1250,5 ".into());
        changed.gateways[0].baud = String::new();
        let read = changed.read().expect("readable");
        assert_eq!(read.max_speed_mm_s, 1250.5);
        assert_eq!(read.gateways[0].baud, None);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn every_unreadable_field_is_listed_and_values_are_left_to_the_bridge() {
        let mut form = InstallationForm::of(&info());
        form.set(Field::Rows, "2.5".into());
        form.set(Field::Travel, "far".into());
        form.gateways[0].port = " ".into();
        form.gateways[0].baud = "fast".into();
        form.gateways[0].stations = "1-300".into();
        assert_eq!(
            form.read(),
            Err(vec![
                FormError::Matrix(Field::Rows),
                FormError::Matrix(Field::Travel),
                FormError::Gateway(0, GatewayField::Port),
                FormError::Gateway(0, GatewayField::Baud),
                FormError::Gateway(0, GatewayField::Stations),
            ])
        );
        // A negative speed reads; the bridge says what is wrong with it.
        let mut form = InstallationForm::of(&info());
        form.set(Field::MaxSpeed, "-5".into());
        assert_eq!(form.read().map(|info| info.max_speed_mm_s), Ok(-5.0));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn only_unwell_gateways_warn() {
        let gateway = |health: Option<UnitHealth>| GatewayStatus {
            index: 0,
            kind: GatewayKind::Uim2503,
            port: "/dev/ttyUSB0".into(),
            link: LinkState::Up,
            bytes_per_s: 0.0,
            lowest_water_level: None,
            error: None,
            packets_per_s: None,
            late_frames: None,
            missed_replies: None,
            drives: Vec::new(),
            baud: Some(9600),
            health,
        };
        let well = UnitHealth {
            expected: 100,
            answering: 100,
            ..UnitHealth::default()
        };
        let missing = UnitHealth {
            answering: 99,
            missing: vec![7],
            ..well.clone()
        };
        let faulty = UnitHealth {
            faults: vec![UnitFault {
                station: 3,
                error: 0x37,
                code: 0,
                index: 0,
            }],
            ..well.clone()
        };
        assert!(health_warnings(&[gateway(None), gateway(Some(well))]).is_empty());
        let warnings = health_warnings(&[gateway(Some(missing)), gateway(Some(faulty))]);
        assert_eq!(warnings.len(), 2);
        assert_eq!(warnings[0].missing, [7]);
        assert_eq!(warnings[1].faults[0].station, 3);
    }
}
