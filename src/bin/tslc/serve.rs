//! `tslc watch --serve ADDR`: a small local web page showing the image as
//! it refines and the diagnostics of the last build. The page listens to
//! `/events` (server-sent events: one JSON message per change) and reloads
//! `/image.png` when a new pass is written; nothing else is served.
//!
//! The HTTP server (`http`) bounds what clients can hold (connections,
//! threads, head sizes, time) and refuses requests that do not name the
//! address served; this module only says what each route answers.

mod http;

use http::{Body, EventSink, Reply};
use std::net::SocketAddr;
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

/// How often an idle event stream sends a comment, so a closed page is
/// noticed and its thread ends.
const KEEPALIVE: Duration = Duration::from_secs(15);

/// What the page shows, shared by the watcher and the server's threads.
pub struct Live {
    state: Mutex<State>,
    changed: Condvar,
    address: SocketAddr,
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
    /// Binds `address` and serves the page from threads of its own.
    pub fn start(address: SocketAddr) -> Result<Arc<Live>, String> {
        let server = http::Server::bind(address)?;
        let bound = server.local_addr().unwrap_or(address);
        let live = Arc::new(Live { state: Mutex::new(State::default()), changed: Condvar::new(), address: bound });
        let serving = live.clone();
        server.serve(Arc::new(move |request: &http::Request| serving.answer(&request.path)))?;
        Ok(live)
    }

    /// The address to open the page at: the one bound (with the port
    /// chosen, for port 0), or loopback when bound to every address.
    pub fn address(&self) -> SocketAddr {
        let mut address = self.address;
        if address.ip().is_unspecified() {
            address.set_ip(match address.ip() {
                std::net::IpAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
                std::net::IpAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
            });
        }
        address
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

    fn answer(self: &Arc<Self>, path: &str) -> Reply {
        match path {
            "/" => Reply::Full {
                status: 200,
                content_type: "text/html; charset=utf-8",
                body: Body::Static(PAGE.as_bytes()),
                no_store: false,
            },
            "/image.png" => match self.state.lock().ok().and_then(|s| s.png.clone()) {
                Some(png) => {
                    Reply::Full { status: 200, content_type: "image/png", body: Body::Shared(png), no_store: true }
                }
                None => Reply::text(404, "no image yet\n"),
            },
            "/events" => {
                let live = self.clone();
                Reply::Events(Box::new(move |sink| live.stream(sink)))
            }
            _ => Reply::text(404, "not found\n"),
        }
    }

    /// Sends the state whenever it changes, until the page goes away.
    fn stream(&self, sink: &mut EventSink) {
        if !sink.send("retry: 1000\n\n") {
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
            if !sink.send(&message) {
                return;
            }
        }
    }
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
