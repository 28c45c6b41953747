//! Which browser origins may talk to the bridge: the bridge's own, and the extra ones
//! of `allowed_origins` in `floatball.toml`, normalised by [`normalise_origin`] when the
//! configuration is checked. [`cors`] lets them call the API; [`origin_allowed`] lets
//! them open the WebSocket (`/ws`), which CORS does not protect.

use axum::http::{HeaderMap, HeaderValue, Method, header};
use tower_http::cors::{AllowOrigin, CorsLayer};

/// `scheme://host[:port]` in lower case without a trailing `/`, or `None` if `text` is
/// not an origin.
pub fn normalise_origin(text: &str) -> Option<String> {
    let lower = text.trim().trim_end_matches('/').to_ascii_lowercase();
    let rest = lower
        .strip_prefix("http://")
        .or_else(|| lower.strip_prefix("https://"))?;
    let valid = !rest.is_empty()
        && rest
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | ':' | '[' | ']' | '_'));
    valid.then_some(lower)
}

/// Whether a request's `Origin` may open the WebSocket: none (not a browser), the
/// bridge's own host (`Origin` matches `Host`), or a configured extra origin.
pub fn origin_allowed(headers: &HeaderMap, allowed_origins: &[String]) -> bool {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return true;
    };
    let Some(origin) = origin.to_str().ok().and_then(normalise_origin) else {
        return false;
    };
    if allowed_origins.contains(&origin) {
        return true;
    }
    let Some((scheme, authority)) = origin.split_once("://") else {
        return false;
    };
    let Some(host) = headers
        .get(header::HOST)
        .and_then(|host| host.to_str().ok())
    else {
        return false;
    };
    let default_port = if scheme == "https" { ":443" } else { ":80" };
    let strip = |authority: &str| -> String {
        let lower = authority.trim().to_ascii_lowercase();
        lower
            .strip_suffix(default_port)
            .map_or_else(|| lower.clone(), str::to_owned)
    };
    strip(authority) == strip(host)
}

/// CORS for the extra origins of the configuration (the bridge's own origin needs
/// none).
pub fn cors(allowed_origins: &[String]) -> CorsLayer {
    let origins: Vec<HeaderValue> = allowed_origins
        .iter()
        .filter_map(|origin| HeaderValue::from_str(origin).ok())
        .collect();
    CorsLayer::new()
        .allow_origin(AllowOrigin::list(origins))
        .allow_methods([Method::GET, Method::PUT, Method::POST, Method::DELETE])
        .allow_headers([header::AUTHORIZATION, header::CONTENT_TYPE])
        .expose_headers([header::RETRY_AFTER])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(origin: Option<&'static str>, host: &'static str) -> HeaderMap {
        let mut headers = HeaderMap::new();
        headers.insert(header::HOST, HeaderValue::from_static(host));
        if let Some(origin) = origin {
            headers.insert(header::ORIGIN, HeaderValue::from_static(origin));
        }
        headers
    }

    #[test]
    fn same_origin_and_configured_origins_are_allowed() {
        let allowed = ["http://kiosk.local:3000".to_owned()];
        assert!(origin_allowed(&headers(None, "a:8080"), &allowed));
        assert!(origin_allowed(
            &headers(Some("http://192.168.1.17:8080"), "192.168.1.17:8080"),
            &allowed
        ));
        assert!(origin_allowed(
            &headers(Some("http://Bridge.local"), "bridge.local:80"),
            &allowed
        ));
        assert!(origin_allowed(
            &headers(Some("http://kiosk.local:3000"), "192.168.1.17:8080"),
            &allowed
        ));
    }

    #[test]
    fn cross_site_origins_are_refused() {
        let allowed = ["http://kiosk.local:3000".to_owned()];
        for origin in ["http://evil.example", "http://192.168.1.17:8081", "null"] {
            assert!(
                !origin_allowed(&headers(Some(origin), "192.168.1.17:8080"), &allowed),
                "{origin}"
            );
        }
    }

    #[test]
    fn origins_are_normalised() {
        assert_eq!(
            normalise_origin("HTTP://Tablet.local:8080/").as_deref(),
            Some("http://tablet.local:8080")
        );
        assert_eq!(normalise_origin("http://a/b"), None);
        assert_eq!(normalise_origin("ftp://a"), None);
    }
}
