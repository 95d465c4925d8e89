//! `tslc watch --serve ADDR`: a small local web page showing the image as
//! it refines and the diagnostics of the last build. The page listens to
//! `/events` (server-sent events: one JSON message per change) and reloads
//! `/image.png` when a new pass is written; nothing else is served.
//!
//! tiny_http parses requests on one thread; each event stream gets a thread
//! of its own that writes to its socket directly, at most
//! [`MAX_EVENT_STREAMS`] at once.

use std::io::Write;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

/// The most pages listening at once (each holds a thread and a socket).
pub const MAX_EVENT_STREAMS: usize = 16;

/// How often an idle event stream sends a comment, so a closed page is
/// noticed and its thread ends.
const KEEPALIVE: Duration = Duration::from_secs(15);

/// What the page shows, shared by the watcher and the server's threads.
pub struct Live {
    state: Mutex<State>,
    changed: Condvar,
    address: SocketAddr,
    streams: AtomicUsize,
}

#[derive(Default)]
struct State {
    /// Counts every change; streams send the state when it moves.
    version: u64,
    /// Counts the images; the page reloads `/image.png` when it moves.
    image_version: u64,
    png: Option<Arc<Vec<u8>>>,
    spp: u32,
    target_spp: u32,
    diagnostics: String,
    /// The last build failed: the image is the last good one.
    broken: bool,
}

impl Live {
    /// Binds `address` and serves the page from a thread of its own.
    pub fn start(address: SocketAddr) -> Result<Arc<Live>, String> {
        let server = tiny_http::Server::http(address).map_err(|e| format!("cannot serve on {address}: {e}"))?;
        let address = server.server_addr().to_ip().unwrap_or(address);
        let live = Arc::new(Live {
            state: Mutex::new(State::default()),
            changed: Condvar::new(),
            address,
            streams: AtomicUsize::new(0),
        });
        let serving = live.clone();
        std::thread::spawn(move || {
            for request in server.incoming_requests() {
                serving.answer(request);
            }
        });
        Ok(live)
    }

    /// The address bound (with the port chosen, for port 0).
    pub fn address(&self) -> SocketAddr {
        self.address
    }

    /// A new pass of the image, as PNG.
    pub fn image(&self, png: Vec<u8>, spp: u32, target_spp: u32) {
        self.update(|s| {
            s.png = Some(Arc::new(png));
            s.image_version += 1;
            s.spp = spp;
            s.target_spp = target_spp;
        });
    }

    /// The diagnostics of the last build (empty when it was clean), and
    /// whether it failed.
    pub fn diagnostics(&self, text: String, broken: bool) {
        self.update(|s| {
            s.diagnostics = text;
            s.broken = broken;
        });
    }

    fn update(&self, change: impl FnOnce(&mut State)) {
        if let Ok(mut state) = self.state.lock() {
            change(&mut state);
            state.version += 1;
            self.changed.notify_all();
        }
    }

    fn answer(self: &Arc<Self>, request: tiny_http::Request) {
        let path = request.url().split('?').next().unwrap_or("");
        let response = match (request.method(), path) {
            (tiny_http::Method::Get, "/") => {
                with_headers(tiny_http::Response::from_string(PAGE), &[("Content-Type", "text/html; charset=utf-8")])
            }
            (tiny_http::Method::Get, "/image.png") => {
                let png = self.state.lock().ok().and_then(|s| s.png.clone());
                match png {
                    Some(png) => with_headers(
                        tiny_http::Response::from_data(png.as_slice()),
                        &[("Content-Type", "image/png"), ("Cache-Control", "no-store")],
                    ),
                    None => tiny_http::Response::from_string("no image yet").with_status_code(404),
                }
            }
            (tiny_http::Method::Get, "/events") => {
                if self.streams.fetch_add(1, Ordering::Relaxed) >= MAX_EVENT_STREAMS {
                    self.streams.fetch_sub(1, Ordering::Relaxed);
                    tiny_http::Response::from_string("too many pages are listening").with_status_code(503)
                } else {
                    let live = self.clone();
                    let writer = request.into_writer();
                    std::thread::spawn(move || {
                        live.stream(writer);
                        live.streams.fetch_sub(1, Ordering::Relaxed);
                    });
                    return;
                }
            }
            _ => tiny_http::Response::from_string("not found").with_status_code(404),
        };
        let _ = request.respond(response);
    }

    /// Sends the state whenever it changes, until the page goes away.
    fn stream(&self, mut out: Box<dyn Write + Send>) {
        let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
                    Connection: close\r\n\r\nretry: 1000\n\n";
        if out.write_all(head.as_bytes()).and_then(|()| out.flush()).is_err() {
            return;
        }
        let mut sent = None;
        loop {
            let message = {
                let Ok(state) = self.state.lock() else { return };
                let Ok((state, _)) = self.changed.wait_timeout_while(state, KEEPALIVE, |s| Some(s.version) == sent)
                else {
                    return;
                };
                if Some(state.version) == sent {
                    ": keepalive\n\n".to_string()
                } else {
                    sent = Some(state.version);
                    let json = serde_json::json!({
                        "image": state.image_version,
                        "spp": state.spp,
                        "target_spp": state.target_spp,
                        "diagnostics": state.diagnostics,
                        "broken": state.broken,
                    });
                    format!("data: {json}\n\n")
                }
            };
            if out.write_all(message.as_bytes()).and_then(|()| out.flush()).is_err() {
                return;
            }
        }
    }
}

fn with_headers<R: std::io::Read>(
    mut response: tiny_http::Response<R>,
    headers: &[(&str, &str)],
) -> tiny_http::Response<R> {
    for (name, value) in headers {
        if let Ok(h) = tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes()) {
            response.add_header(h);
        }
    }
    response
}

/// The page: the image, its samples so far, and the diagnostics.
const PAGE: &str = r#"<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>tslc watch</title>
<style>
  body { background: #1e1e1e; color: #ddd; font: 14px system-ui, sans-serif; margin: 1em; }
  #status { margin-bottom: 0.5em; }
  #image { min-width: min(512px, 100%); max-width: 100%; image-rendering: pixelated; background: #000; }
  #diagnostics { color: #f88; white-space: pre-wrap; font: 13px ui-monospace, monospace; }
  #diagnostics:empty { display: none; }
</style>
</head>
<body>
<div id="status">waiting for the first pass</div>
<pre id="diagnostics"></pre>
<img id="image" alt="the rendered image">
<script>
  const status = document.getElementById("status");
  const image = document.getElementById("image");
  const diagnostics = document.getElementById("diagnostics");
  let shown = 0;
  const events = new EventSource("/events");
  events.onmessage = (event) => {
    const state = JSON.parse(event.data);
    if (state.image !== shown && state.image > 0) {
      shown = state.image;
      image.src = "/image.png?v=" + state.image;
      image.dataset.version = state.image;
    }
    diagnostics.textContent = state.diagnostics;
    if (state.image > 0) {
      status.textContent = state.spp + " / " + state.target_spp + " samples per pixel" +
        (state.broken ? " (the last good image: the scene has errors)" : "");
    }
  };
  events.onerror = () => { status.textContent = "disconnected from tslc watch; retrying"; };
</script>
</body>
</html>
"#;
