//! The HTTP side: the page and its files, `/api/snapshot` (the current frame as JSON) and
//! `/api/stream` (frames as server-sent events), on a thread of its own with a one-thread tokio
//! runtime. The session loop hands its values to [`Viewer`] (a [`nomen_live::Observer`]), which
//! only updates the [`ViewerState`] under a lock; a ticker makes a frame from it at
//! [`ViewerOptions::frame_hz`] when it changed, and each page's stream sends the newest frame
//! when the page can take one: a slow page skips frames (counted), it never queues them.

use crate::access::{Access, COOKIE, is_loopback_host, query_token};
use crate::assets;
use crate::state::{PLAYOUT_NS, ServerStats, ViewerConfig, ViewerState};
use crate::{Result, ViewerError};
use axum::Router;
use axum::extract::{Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use nomen_core::{Registry, SkeletonObservation};
use nomen_live::health::HealthReport;
use nomen_live::session::Output;
use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};
use tokio::sync::watch;

/// How the viewer serves.
#[derive(Debug, Clone)]
pub struct ViewerOptions {
    /// Where it listens (port 0: any free port, [`Viewer::local_addr`] tells which).
    pub listen: SocketAddr,
    /// The token requests must carry; required unless `listen` is a loopback address.
    pub token: Option<String>,
    /// Frames per second made for the pages, at most (when something changed). Default 30:
    /// cameras' skeleton rate.
    pub frame_hz: f64,
    /// Pages connected to the live stream at once; more are refused (503). Default 16.
    pub max_clients: usize,
    /// What the state holds.
    pub state: ViewerConfig,
}

impl ViewerOptions {
    /// The defaults, listening on `listen`.
    pub fn new(listen: SocketAddr, token: Option<String>) -> Self {
        ViewerOptions {
            listen,
            token,
            frame_hz: 30.0,
            max_clients: 16,
            state: ViewerConfig::default(),
        }
    }
}

/// One frame as the pages get it.
#[derive(Debug)]
struct Frame {
    seq: u64,
    json: Arc<str>,
}

/// What the session loop, the ticker and the request handlers share.
#[derive(Debug)]
pub struct Shared {
    state: Mutex<ViewerState>,
    access: Access,
    frames: watch::Sender<Arc<Frame>>,
    max_clients: usize,
    num_clients: AtomicUsize,
    num_frames_skipped: AtomicU64,
}

impl Shared {
    /// Shared state for a server with this policy and these options.
    pub fn new(access: Access, options: &ViewerOptions) -> Arc<Shared> {
        let (frames, _) = watch::channel(Arc::new(Frame {
            seq: 0,
            json: Arc::from("{}"),
        }));
        Arc::new(Shared {
            state: Mutex::new(ViewerState::new(options.state)),
            access,
            frames,
            max_clients: options.max_clients,
            num_clients: AtomicUsize::new(0),
            num_frames_skipped: AtomicU64::new(0),
        })
    }

    fn state(&self) -> MutexGuard<'_, ViewerState> {
        // The state stays usable after a panic elsewhere.
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn stats(&self) -> ServerStats {
        ServerStats {
            num_clients: self.num_clients.load(Ordering::Relaxed),
            num_frames_skipped: self.num_frames_skipped.load(Ordering::Relaxed),
        }
    }

    /// The current state as the JSON of a frame numbered `seq`, presented at `present_ns`.
    fn frame_json(&self, seq: u64, present_ns: Option<i64>) -> String {
        let state = self.state();
        // Our own values always serialise (finite numbers, string keys).
        serde_json::to_string(&state.snapshot(seq, self.stats(), present_ns)).unwrap_or_default()
    }

    /// Makes a frame when the state or the presentation time changed and a page is listening.
    fn tick(&self, seq: &mut u64, last_version: &mut u64, playout: &mut Playout) {
        let (version, newest_ns) = {
            let state = self.state();
            (state.version(), state.newest_ns())
        };
        let present_ns = playout.advance(newest_ns, Instant::now());
        if (version == *last_version && present_ns == playout.shown_ns)
            || self.frames.receiver_count() == 0
        {
            return;
        }
        *last_version = version;
        playout.shown_ns = present_ns;
        *seq += 1;
        let json = Arc::from(self.frame_json(*seq, present_ns));
        self.frames
            .send_replace(Arc::new(Frame { seq: *seq, json }));
    }
}

/// The presentation time of the frames: the engine decides in batches (one per window hop), so
/// the frames run through each batch at the pace of the wall clock, at most [`PLAYOUT_NS`]
/// behind the newest decision, instead of jumping from batch to batch.
#[derive(Debug, Default)]
struct Playout {
    present: Option<(i64, Instant)>,
    shown_ns: Option<i64>,
}

impl Playout {
    fn advance(&mut self, newest_ns: Option<i64>, now: Instant) -> Option<i64> {
        let Some(newest_ns) = newest_ns else {
            self.present = None;
            return None;
        };
        let present_ns = match self.present {
            None => newest_ns,
            Some((ns, at)) => {
                let elapsed_ns =
                    i64::try_from(now.saturating_duration_since(at).as_nanos()).unwrap_or(i64::MAX);
                ns.saturating_add(elapsed_ns)
                    .max(newest_ns.saturating_sub(PLAYOUT_NS))
                    .min(newest_ns)
            }
        };
        self.present = Some((present_ns, now));
        Some(present_ns)
    }
}

/// The running viewer. Dropping it stops the server.
#[derive(Debug)]
pub struct Viewer {
    shared: Arc<Shared>,
    local_addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Viewer {
    /// Checks the access rules, binds the address and starts serving on a thread of its own.
    pub fn start(options: &ViewerOptions) -> Result<Viewer> {
        let access = Access::for_listen(options.listen, options.token.as_deref())?;
        let io = |what: String| move |source| ViewerError::Io { what, source };
        let listener = std::net::TcpListener::bind(options.listen)
            .map_err(io(format!("cannot listen on {}", options.listen)))?;
        listener
            .set_nonblocking(true)
            .map_err(io("cannot set the listener non-blocking".to_owned()))?;
        let local_addr = listener
            .local_addr()
            .map_err(io("cannot read the listening address".to_owned()))?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(io("cannot start the viewer's runtime".to_owned()))?;
        let shared = Shared::new(access, options);
        let app = router(Arc::clone(&shared));
        let period = Duration::from_secs_f64(1.0 / options.frame_hz.clamp(1.0, 120.0));
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let ticker_shared = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("nomen-viewer".to_owned())
            .spawn(move || {
                runtime.block_on(async move {
                    let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
                        return;
                    };
                    let ticker = async move {
                        let mut interval = tokio::time::interval(period);
                        interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
                        let (mut seq, mut last_version) = (0, u64::MAX);
                        let mut playout = Playout::default();
                        loop {
                            interval.tick().await;
                            ticker_shared.tick(&mut seq, &mut last_version, &mut playout);
                        }
                    };
                    tokio::select! {
                        _ = axum::serve(listener, app) => {}
                        () = ticker => {}
                        _ = stopped => {}
                    }
                });
            })
            .map_err(io("cannot start the viewer's thread".to_owned()))?;
        Ok(Viewer {
            shared,
            local_addr,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// The subjects named on screen now, sorted (what the page's `data-named` shows).
    pub fn named(&self) -> Vec<String> {
        self.shared
            .state()
            .named()
            .into_iter()
            .map(str::to_owned)
            .collect()
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl nomen_live::Observer for Viewer {
    fn registry(&mut self, registry: &Registry) {
        self.shared.state().set_registry(registry);
    }

    fn skeleton(&mut self, skeleton: &SkeletonObservation) {
        self.shared.state().push_skeleton(skeleton);
    }

    fn outputs(&mut self, outputs: &[Output]) {
        self.shared.state().apply(outputs);
    }

    fn health(&mut self, report: &HealthReport) {
        self.shared.state().set_health(report);
    }
}

/// The routes, behind the access check.
pub fn router(shared: Arc<Shared>) -> Router {
    Router::new()
        .route("/api/snapshot", get(snapshot))
        .route("/api/stream", get(stream))
        .fallback(get(asset))
        .layer(middleware::from_fn_with_state(Arc::clone(&shared), check))
        .with_state(shared)
}

/// Refuses a request to an open viewer whose `Host` is not loopback (421, see
/// [`is_loopback_host`]) and a request without the token (401), and sets the token's cookie
/// when the page is opened with `?token=`, so that its files and its stream are allowed too.
async fn check(State(shared): State<Arc<Shared>>, request: Request, next: Next) -> Response {
    let headers = request.headers();
    let text = |name| {
        headers
            .get(name)
            .and_then(|v: &HeaderValue| v.to_str().ok())
    };
    if matches!(shared.access, Access::Open) && !is_loopback_host(text(header::HOST)) {
        return (
            StatusCode::MISDIRECTED_REQUEST,
            "the viewer on loopback answers only to localhost, 127.0.0.1 or [::1]\n",
        )
            .into_response();
    }
    let query = request.uri().query();
    if !shared
        .access
        .allows(text(header::AUTHORIZATION), query, text(header::COOKIE))
    {
        return (
            StatusCode::UNAUTHORIZED,
            [(header::WWW_AUTHENTICATE, "Bearer")],
            "the viewer needs its token: ?token=TOKEN or Authorization: Bearer TOKEN\n",
        )
            .into_response();
    }
    let cookie = match (&shared.access, query_token(query)) {
        (Access::Token(_), Some(token)) => HeaderValue::from_str(&format!(
            "{COOKIE}={token}; HttpOnly; SameSite=Strict; Path=/"
        ))
        .ok(),
        _ => None,
    };
    let mut response = next.run(request).await;
    let headers = response.headers_mut();
    if let Some(cookie) = cookie {
        headers.insert(header::SET_COOKIE, cookie);
    }
    secure(headers);
    response
}

/// Headers every response gets: the page loads only its own files, and a token in its URL
/// does not leak through a referrer.
fn secure(headers: &mut HeaderMap) {
    headers.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static("default-src 'self'"),
    );
    headers.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    headers.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
}

async fn asset(request: Request) -> Response {
    match assets::find(request.uri().path()) {
        Some(asset) => (
            [
                (header::CONTENT_TYPE, asset.content_type),
                (header::CACHE_CONTROL, "no-cache"),
            ],
            asset.bytes,
        )
            .into_response(),
        None => (StatusCode::NOT_FOUND, "no such page\n").into_response(),
    }
}

async fn snapshot(State(shared): State<Arc<Shared>>) -> Response {
    let seq = shared.frames.borrow().seq;
    (
        [
            (header::CONTENT_TYPE, "application/json"),
            (header::CACHE_CONTROL, "no-store"),
        ],
        shared.frame_json(seq, None),
    )
        .into_response()
}

/// Counts a page on the live stream for as long as its stream lives.
struct ClientGuard(Arc<Shared>);

impl Drop for ClientGuard {
    fn drop(&mut self) {
        self.0.num_clients.fetch_sub(1, Ordering::Relaxed);
    }
}

async fn stream(State(shared): State<Arc<Shared>>) -> Response {
    let num_clients = shared.num_clients.fetch_add(1, Ordering::Relaxed);
    let guard = ClientGuard(Arc::clone(&shared));
    if num_clients >= shared.max_clients {
        drop(guard);
        return (
            StatusCode::SERVICE_UNAVAILABLE,
            format!("the viewer serves {} pages at most\n", shared.max_clients),
        )
            .into_response();
    }
    let mut frames = shared.frames.subscribe();
    // The page gets the current state at once, then each new frame.
    let first = Arc::new(Frame {
        seq: frames.borrow().seq,
        json: Arc::from(shared.frame_json(frames.borrow().seq, None)),
    });
    drop(frames.borrow_and_update());
    let events = futures_util::stream::unfold(
        (Some(first), frames, None::<u64>, guard),
        |(first, mut frames, last_seq, guard)| async move {
            let frame = match first {
                Some(frame) => frame,
                None => {
                    frames.changed().await.ok()?;
                    Arc::clone(&frames.borrow_and_update())
                }
            };
            if let Some(last) = last_seq {
                let skipped = frame.seq.saturating_sub(last).saturating_sub(1);
                guard
                    .0
                    .num_frames_skipped
                    .fetch_add(skipped, Ordering::Relaxed);
            }
            let event = SseEvent::default().data(&*frame.json);
            Some((
                Ok::<_, Infallible>(event),
                (None, frames, Some(frame.seq), guard),
            ))
        },
    );
    let mut response = Sse::new(events)
        .keep_alive(KeepAlive::default())
        .into_response();
    response
        .headers_mut()
        .insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    response
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::body::Body;
    use http_body_util::BodyExt;
    use tower::ServiceExt;

    const TOKEN: &str = "0123456789abcdef";

    fn app(listen: &str, token: Option<&str>) -> Router {
        let listen: SocketAddr = listen.parse().unwrap();
        let options = ViewerOptions::new(listen, token.map(str::to_owned));
        let access = Access::for_listen(listen, token).unwrap();
        router(Shared::new(access, &options))
    }

    async fn get_status(
        app: &Router,
        uri: &str,
        headers: &[(&str, &str)],
    ) -> (StatusCode, HeaderMap, String) {
        let mut request = Request::builder().uri(uri);
        for (k, v) in headers {
            request = request.header(*k, *v);
        }
        let response = app
            .clone()
            .oneshot(request.body(Body::empty()).unwrap())
            .await
            .unwrap();
        let status = response.status();
        let headers = response.headers().clone();
        let body = response.into_body().collect().await.unwrap().to_bytes();
        (status, headers, String::from_utf8_lossy(&body).into_owned())
    }

    fn block_on<F: std::future::Future>(f: F) -> F::Output {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap()
            .block_on(f)
    }

    #[test]
    fn on_loopback_the_page_and_the_snapshot_need_no_token() {
        block_on(async {
            let app = app("127.0.0.1:0", None);
            let (status, headers, body) = get_status(&app, "/", &[]).await;
            assert_eq!(status, StatusCode::OK);
            assert!(body.contains("<canvas") || body.contains("id=\"scene\""));
            assert_eq!(
                headers[header::CONTENT_SECURITY_POLICY],
                "default-src 'self'"
            );
            let (status, headers, _) = get_status(&app, "/vendor/three.module.js", &[]).await;
            assert_eq!(status, StatusCode::OK);
            assert_eq!(
                headers[header::CONTENT_TYPE],
                "text/javascript; charset=utf-8"
            );
            let (status, _, body) = get_status(&app, "/api/snapshot", &[]).await;
            assert_eq!(status, StatusCode::OK);
            let json: serde_json::Value = serde_json::from_str(&body).unwrap();
            assert_eq!(json["people"], serde_json::json!([]));
            let (status, _, _) = get_status(&app, "/nothing", &[]).await;
            assert_eq!(status, StatusCode::NOT_FOUND);
        });
    }

    #[test]
    fn elsewhere_every_request_without_the_token_gets_401() {
        block_on(async {
            let app = app("0.0.0.0:0", Some(TOKEN));
            for uri in ["/", "/viewer.js", "/api/snapshot", "/api/stream"] {
                let (status, headers, _) = get_status(&app, uri, &[]).await;
                assert_eq!(status, StatusCode::UNAUTHORIZED, "{uri}");
                assert_eq!(headers[header::WWW_AUTHENTICATE], "Bearer");
                let (status, _, _) =
                    get_status(&app, uri, &[("authorization", "Bearer wrongwrongwrongwr")]).await;
                assert_eq!(status, StatusCode::UNAUTHORIZED, "{uri}");
            }
            let (status, _, _) = get_status(
                &app,
                "/api/snapshot",
                &[("authorization", &format!("Bearer {TOKEN}"))],
            )
            .await;
            assert_eq!(status, StatusCode::OK);
            // Opened with ?token=, the page gets a cookie its files and stream then carry.
            let (status, headers, _) = get_status(&app, &format!("/?token={TOKEN}"), &[]).await;
            assert_eq!(status, StatusCode::OK);
            let cookie = headers[header::SET_COOKIE].to_str().unwrap();
            assert!(
                cookie.starts_with(&format!("{COOKIE}={TOKEN};")),
                "{cookie}"
            );
            assert!(cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"));
            let (status, _, _) = get_status(
                &app,
                "/viewer.js",
                &[("cookie", &format!("{COOKIE}={TOKEN}"))],
            )
            .await;
            assert_eq!(status, StatusCode::OK);
        });
    }

    #[test]
    fn a_slow_page_skips_frames_and_they_are_counted() {
        let listen: SocketAddr = "127.0.0.1:0".parse().unwrap();
        let options = ViewerOptions::new(listen, None);
        let shared = Shared::new(Access::Open, &options);
        block_on(async {
            let response = stream(State(Arc::clone(&shared))).await;
            assert_eq!(response.status(), StatusCode::OK);
            assert_eq!(shared.num_clients.load(Ordering::Relaxed), 1);
            let mut body = response.into_body().into_data_stream();
            use futures_util::StreamExt;
            // The current state comes at once.
            let first = body.next().await.unwrap().unwrap();
            assert!(first.starts_with(b"data: {"));
            // Ten frames made while the page reads nothing: it gets the newest only.
            let (mut seq, mut version) = (0, u64::MAX);
            let mut playout = Playout::default();
            for k in 0..10 {
                shared
                    .state()
                    .set_health(&nomen_live::health::Health::default().report(
                        f64::from(k),
                        1,
                        (0, 1),
                    ));
                shared.tick(&mut seq, &mut version, &mut playout);
            }
            let next = body.next().await.unwrap().unwrap();
            let text = String::from_utf8_lossy(&next);
            assert!(text.contains("\"seq\":10"), "{text}");
            assert_eq!(shared.num_frames_skipped.load(Ordering::Relaxed), 9);
            drop(body);
            assert_eq!(shared.num_clients.load(Ordering::Relaxed), 0);
        });
    }

    #[test]
    fn pages_beyond_the_limit_are_refused() {
        let listen: SocketAddr = "127.0.0.1:0".parse().unwrap();
        let options = ViewerOptions {
            max_clients: 1,
            ..ViewerOptions::new(listen, None)
        };
        let shared = Shared::new(Access::Open, &options);
        block_on(async {
            let first = stream(State(Arc::clone(&shared))).await;
            assert_eq!(first.status(), StatusCode::OK);
            let second = stream(State(Arc::clone(&shared))).await;
            assert_eq!(second.status(), StatusCode::SERVICE_UNAVAILABLE);
            assert_eq!(shared.num_clients.load(Ordering::Relaxed), 1);
        });
    }
}
