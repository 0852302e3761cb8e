//! The page: HTML, JavaScript and CSS written for this project and embedded in the binary (it
//! works offline; no third-party code). The same page serves the emulator and the hub: it
//! learns which one it talks to from the live feed's `kind`.

use std::convert::Infallible;
use std::time::Duration;

use axum::http::{header, HeaderValue};
use axum::response::sse::{Event, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use futures_util::stream::Stream;

/// The page (`GET /`).
pub const INDEX_HTML: &str = include_str!("../assets/index.html");
/// Its script (`GET /assets/app.js`): the 3D view, the readouts, the controls, the strip chart.
pub const APP_JS: &str = include_str!("../assets/app.js");
/// Its style sheet (`GET /assets/style.css`).
pub const STYLE_CSS: &str = include_str!("../assets/style.css");

/// Period of the live feed (`GET /live`): 25 updates per second.
pub const LIVE_PERIOD: Duration = Duration::from_millis(40);

/// The page's content security policy: its own script and style only, talking only to its own
/// server, never framed (a framed Stop button could be clicked by a trick).
const CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; \
                   connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

fn asset(body: &'static str, content_type: &'static str) -> Response {
    let mut r = body.into_response();
    let h = r.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CSP),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    r
}

/// The routes of the page itself: `/`, `/assets/app.js`, `/assets/style.css`.
pub fn page_routes<S: Clone + Send + Sync + 'static>() -> Router<S> {
    Router::new()
        .route(
            "/",
            get(|| async { asset(INDEX_HTML, "text/html; charset=utf-8") }),
        )
        .route(
            "/assets/app.js",
            get(|| async { asset(APP_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/assets/style.css",
            get(|| async { asset(STYLE_CSS, "text/css; charset=utf-8") }),
        )
}

/// A server-sent-events feed: every [`LIVE_PERIOD`], one `data:` event with the JSON that
/// `next` returns. Missed ticks are skipped (a slow reader gets the newest state, not a
/// backlog). The page reads it with `fetch` (so that it can send the token header).
pub fn live_feed<F>(next: F) -> Sse<impl Stream<Item = Result<Event, Infallible>>>
where
    F: FnMut() -> String + Send + 'static,
{
    let mut interval = tokio::time::interval(LIVE_PERIOD);
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let stream =
        futures_util::stream::unfold((interval, next), |(mut interval, mut next)| async move {
            // The first tick completes at once: the page gets a state without waiting.
            interval.tick().await;
            let data = next();
            Some((Ok(Event::default().data(data)), (interval, next)))
        });
    Sse::new(stream)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assets_are_self_contained() {
        // No third-party code and no remote resources: the page works offline.
        for text in [INDEX_HTML, APP_JS, STYLE_CSS] {
            assert!(!text.contains("http://") && !text.contains("https://"));
            assert!(!text.contains("cdn"), "no CDN");
        }
        assert!(INDEX_HTML.contains("/assets/app.js") && INDEX_HTML.contains("/assets/style.css"));
        // The readouts automation reads.
        for n in 1..=6 {
            assert!(INDEX_HTML.contains(&format!("data-joint=\"{n}\"")));
        }
    }
}
