//! `tslc watch` as an editor's user meets it: the image appears, an edit
//! that breaks the scene prints diagnostics and keeps the image, a fix or an
//! edit to an imported file or a texture renders again, an edit cancels the
//! pass in progress, and `--serve` answers the page, its events and the image.
//! Then as a careless or hostile neighbour meets it: folders deleted and
//! created again (a `git checkout`), inputs named like the output, and
//! clients of the page that lie about its address, dawdle, hoard
//! connections or pipeline requests.
//! Small images and few samples: each test takes a few seconds (those that
//! wait out the server's 10 s request-head timeout, a little more).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// Long enough for a debug build on a busy machine; a hang fails the test.
const PATIENCE: Duration = Duration::from_secs(120);

/// A running `tslc watch`, its stderr read line by line; killed on drop.
struct Watch {
    child: Child,
    lines: Receiver<String>,
    log: Vec<String>,
}

impl Watch {
    fn start(dir: &Path, args: &[&str]) -> Watch {
        let mut child = Command::new(env!("CARGO_BIN_EXE_tslc"))
            .arg("watch")
            .args(args)
            .current_dir(dir)
            .env("NO_COLOR", "1")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("tslc runs");
        let stderr = child.stderr.take().unwrap();
        let (send, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if send.send(line).is_err() {
                    break;
                }
            }
        });
        Watch { child, lines, log: Vec::new() }
    }

    /// Reads lines until one contains `text`; returns it.
    fn wait_for(&mut self, text: &str) -> String {
        let deadline = Instant::now() + PATIENCE;
        loop {
            match self.lines.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
                Ok(line) => {
                    self.log.push(line.clone());
                    if line.contains(text) {
                        return line;
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    panic!("no line with `{text}`; stderr so far:\n{}", self.log.join("\n"))
                }
                Err(RecvTimeoutError::Disconnected) => {
                    panic!("tslc watch exited before `{text}`; stderr:\n{}", self.log.join("\n"))
                }
            }
        }
    }

    /// The lines read since `from`, joined.
    fn since(&self, from: usize) -> String {
        self.log[from..].join("\n")
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tslc-watch-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A sphere on a floor, its gray `level` from `lib.tsl`, `kd` from the scene.
fn scene(kd: &str) -> String {
    format!(
        r#"import "lib.tsl";
material sphere = lambert(kd: {kd});
scene {{
    camera {{ from (0, 1, -4); to (0, 1, 0); fov 40; }}
    render {{ width 16; height 12; spp 4; }}
    light point {{ at (2, 4, -3); intensity gray(60); }}
    object sphere {{ center (0, 1, 0); radius 1; material sphere; }}
    object plane {{ point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(level())); }}
}}
"#
    )
}

fn lib(level: f32) -> String {
    format!("float level() {{ return {level}; }}\n")
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap()
}

#[test]
fn edits_render_again_and_a_broken_edit_prints_diagnostics_and_keeps_the_image() {
    let dir = scratch("edits");
    std::fs::write(dir.join("lib.tsl"), lib(0.5)).unwrap();
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.2)")).unwrap();
    let out = dir.join("out.png");
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.png", "--threads", "1"]);
    // Passes of 1, 1 and 2 samples; the image after each.
    watch.wait_for("1/4 spp");
    watch.wait_for("4/4 spp");
    watch.wait_for("done");
    let first = read(&out);
    let decoded = image::load_from_memory(&first).unwrap();
    assert_eq!((decoded.width(), decoded.height()), (16, 12));

    // A syntax error: diagnostics as `tslc check` prints them; the image stays.
    let from = watch.log.len();
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.2")).unwrap();
    watch.wait_for("could not check due to");
    watch.wait_for("keeping the last image");
    let printed = watch.since(from);
    assert!(printed.contains("scene.tsl:2:") && printed.contains("error: expected"), "{printed}");
    assert_eq!(read(&out), first, "a broken edit must keep the last image");

    // Fixed, with another color: rendered again.
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.8)")).unwrap();
    watch.wait_for("4/4 spp");
    watch.wait_for("done");
    let brighter = read(&out);
    assert_ne!(brighter, first);

    // An edit to the imported file renders again too.
    std::fs::write(dir.join("lib.tsl"), lib(0.9)).unwrap();
    let changed = watch.wait_for("changed:");
    assert!(changed.contains("lib.tsl"), "{changed}");
    watch.wait_for("4/4 spp");
    watch.wait_for("done");
    assert_ne!(read(&out), brighter);
    // A file the scene does not read changes nothing: no build follows.
    std::fs::write(dir.join("notes.txt"), "unrelated").unwrap();
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.3)")).unwrap();
    let changed = watch.wait_for("changed:");
    assert!(changed.contains("scene.tsl") && !changed.contains("notes.txt"), "{changed}");
}

#[test]
fn an_edit_cancels_the_pass_in_progress() {
    let dir = scratch("cancel");
    std::fs::write(dir.join("lib.tsl"), lib(0.5)).unwrap();
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.2)")).unwrap();
    // Refining to 2^20 spp: the later passes would take minutes, so the
    // test finishes only if the edit stops the one in progress.
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.png", "--threads", "1", "--spp", "1048576"]);
    watch.wait_for("256/1048576 spp");
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.7)")).unwrap();
    let cancelled = watch.wait_for("cancelled the pass");
    assert!(!cancelled.contains("1048576/1048576"), "{cancelled}");
    watch.wait_for("stopped in");
    watch.wait_for("changed:");
    watch.wait_for("1/1048576 spp");
}

#[test]
fn a_changed_texture_is_read_again() {
    let dir = scratch("texture");
    let texture = |value: u8| {
        let pixels = vec![value; 4 * 4 * 3];
        image::save_buffer(dir.join("t.png"), &pixels, 4, 4, image::ColorType::Rgb8).unwrap();
    };
    texture(40);
    std::fs::write(dir.join("lib.tsl"), lib(0.5)).unwrap();
    std::fs::write(dir.join("scene.tsl"), scene("texture(\"t.png\")")).unwrap();
    let out = dir.join("out.png");
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.png", "--threads", "1"]);
    watch.wait_for("done");
    let dark = read(&out);
    texture(220);
    let changed = watch.wait_for("changed:");
    assert!(changed.contains("t.png"), "{changed}");
    watch.wait_for("done");
    assert_ne!(read(&out), dark, "the new texture was not used");
}

/// One HTTP/1.0 GET to the watch's server: (status line, body).
fn get(address: &str, path: &str) -> (String, Vec<u8>) {
    let mut stream = TcpStream::connect(address).unwrap();
    write!(stream, "GET {path} HTTP/1.0\r\nHost: {address}\r\n\r\n").unwrap();
    let mut response = Vec::new();
    stream.read_to_end(&mut response).unwrap();
    let split = response.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&response[..split]).into_owned();
    (head.lines().next().unwrap_or("").to_string(), response[split + 4..].to_vec())
}

#[test]
fn serve_answers_the_page_the_events_and_the_image() {
    let dir = scratch("serve");
    std::fs::write(dir.join("lib.tsl"), lib(0.5)).unwrap();
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.2)")).unwrap();
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.exr", "--threads", "1", "--serve", "127.0.0.1:0"]);
    let serving = watch.wait_for("serving http://");
    let address = serving.split("http://").nth(1).unwrap().trim_end_matches('/').to_string();
    watch.wait_for("done");

    let (status, page) = get(&address, "/");
    assert!(status.contains("200"), "{status}");
    assert!(String::from_utf8_lossy(&page).contains("new EventSource(\"/events\")"));
    let (status, png) = get(&address, "/image.png");
    assert!(status.contains("200"), "{status}");
    let image = image::load_from_memory(&png).unwrap();
    assert_eq!((image.width(), image.height()), (16, 12));
    assert!(get(&address, "/nothing").0.contains("404"));

    // The event stream sends the state at once, then each change.
    let mut events = TcpStream::connect(&address).unwrap();
    write!(events, "GET /events HTTP/1.1\r\nHost: {address}\r\n\r\n").unwrap();
    let mut events = BufReader::new(events);
    let mut next_data = || loop {
        let mut line = String::new();
        assert!(events.read_line(&mut line).unwrap() > 0, "the event stream closed");
        if let Some(json) = line.strip_prefix("data: ") {
            return serde_json::from_str::<serde_json::Value>(json).unwrap();
        }
    };
    let state = next_data();
    assert_eq!(state["spp"], 4);
    assert_eq!(state["diagnostics"], "");
    assert_eq!(state["broken"], false);
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.2")).unwrap();
    let broken = loop {
        let state = next_data();
        if state["diagnostics"] != "" {
            break state;
        }
    };
    assert_eq!(broken["broken"], true);
    let text = broken["diagnostics"].as_str().unwrap();
    assert!(text.contains("scene.tsl:2:") && text.contains("could not check"), "{text}");
    assert_eq!(broken["image"], state["image"], "a broken build keeps the image");
}

// ---- Folders deleted and created again; inputs named like the output ----

/// The paths a `watch: changed: ...` line names.
fn changed_paths(line: &str) -> Vec<String> {
    let list = line.split("changed: ").nth(1).unwrap_or("");
    list.split(", ").map(str::to_string).collect()
}

/// Writes a 4x4 gray PNG of `value` at `path`, creating its folder.
fn gray_png(path: &Path, value: u8) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image::save_buffer(path, &[value; 4 * 4 * 3], 4, 4, image::ColorType::Rgb8).unwrap();
}

#[test]
fn a_deleted_and_recreated_scene_folder_is_still_watched() {
    let dir = scratch("scene-folder");
    let scenes = dir.join("scenes");
    let write_scenes = |kd: &str| {
        std::fs::create_dir_all(&scenes).unwrap();
        std::fs::write(scenes.join("lib.tsl"), lib(0.5)).unwrap();
        std::fs::write(scenes.join("scene.tsl"), scene(kd)).unwrap();
    };
    write_scenes("gray(0.2)");
    let out = dir.join("out.png");
    let mut watch = Watch::start(&dir, &["scenes/scene.tsl", "-o", "out.png", "--threads", "1"]);
    watch.wait_for("done");
    let first = read(&out);

    // Deleted: the build fails and keeps the image; created again: rendered.
    std::fs::remove_dir_all(&scenes).unwrap();
    watch.wait_for("keeping the last image");
    write_scenes("gray(0.8)");
    watch.wait_for("done");
    let second = read(&out);
    assert_ne!(second, first, "the re-created scene was not rendered");
    // ... and an edit in the new folder is seen.
    std::fs::write(scenes.join("scene.tsl"), scene("gray(0.3)")).unwrap();
    let changed = watch.wait_for("changed:");
    assert!(changed.contains("scene.tsl"), "{changed}");
    watch.wait_for("done");

    // Deleted and created again at once, as `git checkout` does (the
    // watcher may see both in one batch, or only the folder's removal).
    std::fs::remove_dir_all(&scenes).unwrap();
    write_scenes("gray(0.6)");
    watch.wait_for("done");
    std::fs::write(scenes.join("scene.tsl"), scene("gray(0.4)")).unwrap();
    let changed = watch.wait_for("changed:");
    assert!(changed.contains("scene.tsl"), "{changed}");
    watch.wait_for("done");
}

#[test]
fn recreated_import_and_texture_folders_are_still_watched() {
    let dir = scratch("input-folders");
    std::fs::create_dir_all(dir.join("lib")).unwrap();
    std::fs::write(dir.join("lib/lib.tsl"), lib(0.5)).unwrap();
    gray_png(&dir.join("maps/2k/t.png"), 40);
    let source = scene("texture(\"maps/2k/t.png\")").replace("import \"lib.tsl\"", "import \"lib/lib.tsl\"");
    std::fs::write(dir.join("scene.tsl"), source).unwrap();
    let out = dir.join("out.png");
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.png", "--threads", "1"]);
    watch.wait_for("done");
    let first = read(&out);

    // The import's folder, deleted and written again at once.
    std::fs::remove_dir_all(dir.join("lib")).unwrap();
    std::fs::create_dir_all(dir.join("lib")).unwrap();
    std::fs::write(dir.join("lib/lib.tsl"), lib(0.9)).unwrap();
    watch.wait_for("done");
    let second = read(&out);
    assert_ne!(second, first, "the re-created import was not read");

    // The texture's folder two levels up, deleted (the build fails), then
    // created again level by level.
    std::fs::remove_dir_all(dir.join("maps")).unwrap();
    watch.wait_for("keeping the last image");
    gray_png(&dir.join("maps/2k/t.png"), 220);
    watch.wait_for("done");
    assert_ne!(read(&out), second, "the re-created texture was not read");

    // Edits in both new folders are seen.
    std::fs::write(dir.join("lib/lib.tsl"), lib(0.1)).unwrap();
    let changed = watch.wait_for("changed:");
    assert!(changed.contains("lib.tsl"), "{changed}");
    watch.wait_for("done");
    gray_png(&dir.join("maps/2k/t.png"), 90);
    let changed = watch.wait_for("changed:");
    assert!(changed.contains("t.png"), "{changed}");
    watch.wait_for("done");
}

#[test]
fn inputs_named_like_the_output_trigger_and_the_output_never_does() {
    let dir = scratch("output-name");
    // One texture with the output's name in another folder, one named as
    // the image writer's temporaries once were, next to the output.
    let decoy = ".out.png.tmp-1-1.png";
    gray_png(&dir.join("tex/out.png"), 40);
    gray_png(&dir.join(decoy), 200);
    std::fs::write(dir.join("lib.tsl"), lib(0.5)).unwrap();
    std::fs::write(dir.join("scene.tsl"), scene(&format!("texture(\"tex/out.png\") * texture(\"{decoy}\")"))).unwrap();
    let out = dir.join("out.png");
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.png", "--threads", "1"]);
    watch.wait_for("done");
    let first = read(&out);

    gray_png(&dir.join("tex/out.png"), 220);
    let changed = watch.wait_for("changed:");
    // Only the texture: the passes written to out.png started no build.
    assert!(changed_paths(&changed).iter().all(|p| p.ends_with("tex/out.png")), "{changed}");
    watch.wait_for("done");
    let second = read(&out);
    assert_ne!(second, first, "the texture named out.png was not read again");

    gray_png(&dir.join(decoy), 100);
    let changed = watch.wait_for("changed:");
    assert!(changed_paths(&changed).iter().all(|p| p.ends_with(decoy)), "{changed}");
    watch.wait_for("done");
    assert_ne!(read(&out), second, "the texture named like a temporary was not read again");
    assert!(
        !watch
            .log
            .iter()
            .any(|l| l.contains("changed:") && changed_paths(l).iter().any(|p| *p == out.display().to_string()))
    );
}

#[test]
fn an_environment_image_named_like_the_output_triggers() {
    let dir = scratch("output-name-env");
    let sky = |value: f32| {
        std::fs::create_dir_all(dir.join("env")).unwrap();
        let image = tsl::image_io::RenderedImage {
            full_width: 8,
            full_height: 4,
            x0: 0,
            y0: 0,
            width: 8,
            height: 4,
            color: vec![[value; 3]; 32],
            albedo: None,
            normal: None,
            depth: None,
            object: None,
        };
        tsl::image_io::write_image(&dir.join("env/out.exr"), &image).unwrap();
    };
    sky(0.5);
    std::fs::write(dir.join("lib.tsl"), lib(0.5)).unwrap();
    let source = scene("gray(0.5)").replace("scene {", "scene {\n    light environment { file \"env/out.exr\"; }");
    std::fs::write(dir.join("scene.tsl"), source).unwrap();
    let out = dir.join("out.exr");
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.exr", "--threads", "1"]);
    watch.wait_for("done");
    let first = read(&out);
    sky(2.0);
    let changed = watch.wait_for("changed:");
    assert!(changed_paths(&changed).iter().all(|p| p.ends_with("env/out.exr")), "{changed}");
    watch.wait_for("done");
    assert_ne!(read(&out), first, "the environment image was not read again");
}

// ---- The page's server as other clients meet it ----

/// Starts `tslc watch --serve ADDR` on a small scene and waits for its
/// first image; returns the watch and the address it says it serves.
fn serve_scene(name: &str, bind: &str) -> (Watch, String) {
    let dir = scratch(name);
    std::fs::write(dir.join("lib.tsl"), lib(0.5)).unwrap();
    std::fs::write(dir.join("scene.tsl"), scene("gray(0.2)")).unwrap();
    let mut watch = Watch::start(&dir, &["scene.tsl", "-o", "out.png", "--threads", "1", "--serve", bind]);
    let serving = watch.wait_for("serving http://");
    let address = serving.split("http://").nth(1).unwrap().trim_end_matches('/').to_string();
    watch.wait_for("done");
    (watch, address)
}

/// A GET request for HTTP/1.1 with the given `Host` field (none for `None`)
/// and other header lines.
fn request(path: &str, host: Option<&str>, more: &str) -> String {
    let host = host.map(|h| format!("Host: {h}\r\n")).unwrap_or_default();
    format!("GET {path} HTTP/1.1\r\n{host}{more}\r\n")
}

/// One connection to the page's server, reading responses one at a time.
struct Client {
    stream: TcpStream,
    received: Vec<u8>,
}

impl Client {
    fn connect(address: &str) -> Client {
        let stream = TcpStream::connect(address).unwrap();
        stream.set_read_timeout(Some(PATIENCE)).unwrap();
        Client { stream, received: Vec::new() }
    }

    fn send(&mut self, bytes: &str) {
        self.stream.write_all(bytes.as_bytes()).unwrap();
    }

    /// Reads more; false when the server closed (or reset) the connection.
    /// Panics when nothing comes within [`PATIENCE`].
    fn read_more(&mut self) -> bool {
        let mut buffer = [0u8; 16384];
        match self.stream.read(&mut buffer) {
            Ok(0) => false,
            Ok(n) => {
                self.received.extend_from_slice(&buffer[..n]);
                true
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                panic!("the server neither answered nor closed; so far: {:?}", String::from_utf8_lossy(&self.received))
            }
            Err(_) => false,
        }
    }

    /// The next response, (status, body) by its `Content-Length`; `None`
    /// when the connection closes first.
    fn response(&mut self) -> Option<(u16, Vec<u8>)> {
        loop {
            if let Some(end) = self.received.windows(4).position(|w| w == b"\r\n\r\n") {
                let head = String::from_utf8_lossy(&self.received[..end]).into_owned();
                let status = head.split(' ').nth(1).and_then(|s| s.parse().ok());
                let status = status.unwrap_or_else(|| panic!("not a response: {head}"));
                let length: usize = head
                    .lines()
                    .find_map(|l| {
                        l.to_ascii_lowercase().strip_prefix("content-length:").map(|v| v.trim().parse().unwrap())
                    })
                    .unwrap_or_else(|| panic!("no Content-Length: {head}"));
                if self.received.len() >= end + 4 + length {
                    let body = self.received[end + 4..end + 4 + length].to_vec();
                    self.received.drain(..end + 4 + length);
                    return Some((status, body));
                }
            }
            if !self.read_more() {
                assert!(self.received.is_empty(), "cut short: {:?}", String::from_utf8_lossy(&self.received));
                return None;
            }
        }
    }

    /// Whether the server closes the connection with nothing more sent.
    fn closes(&mut self) -> bool {
        self.received.is_empty() && !self.read_more()
    }
}

/// One request on a new connection: its answer's (status, body).
fn ask(address: &str, bytes: &str) -> (u16, Vec<u8>) {
    let mut client = Client::connect(address);
    client.send(bytes);
    client.response().expect("an answer")
}

/// Sends `bytes` on a new connection; the answer must be `status`, and
/// the connection closed after it.
fn assert_refused(address: &str, bytes: &str, status: u16, what: &str) {
    let mut client = Client::connect(address);
    client.send(bytes);
    let answer = client.response().map(|(status, _)| status);
    assert_eq!(answer, Some(status), "{what}");
    assert!(client.closes(), "{what}: the connection stays open after the {status}");
}

/// Opens the event stream with `fields`; the first `data:` line, or the
/// whole answer when the stream was refused.
fn open_events(address: &str, fields: &str) -> Result<String, Vec<u8>> {
    let mut stream = TcpStream::connect(address).unwrap();
    stream.write_all(request("/events", Some(address), fields).as_bytes()).unwrap();
    stream.set_read_timeout(Some(PATIENCE)).unwrap();
    let mut reader = BufReader::new(stream);
    let mut status = String::new();
    reader.read_line(&mut status).unwrap();
    if !status.contains(" 200 ") {
        let mut rest = status.into_bytes();
        let _ = reader.read_to_end(&mut rest);
        return Err(rest);
    }
    loop {
        let mut line = String::new();
        assert!(reader.read_line(&mut line).unwrap() > 0, "the event stream closed");
        if line.starts_with("data: ") {
            return Ok(line);
        }
    }
}

#[test]
fn serve_answers_only_requests_for_its_own_address() {
    let (_watch, address) = serve_scene("serve-host", "127.0.0.1:0");
    let port: u16 = address.rsplit(':').next().unwrap().parse().unwrap();
    let other = if port == 65535 { port - 1 } else { port + 1 };
    for host in [address.clone(), format!("localhost:{port}"), format!("LOCALHOST:{port}")] {
        for path in ["/", "/image.png"] {
            assert_eq!(ask(&address, &request(path, Some(&host), "")).0, 200, "{host} {path}");
        }
    }
    // A name that is not this address (DNS rebinding), another port, no
    // port, no Host or two: refused, for the diagnostics and the image too.
    let misdirected = [
        "evil.example".to_string(),
        format!("evil.example:{port}"),
        format!("localhost.evil.example:{port}"),
        format!("127.0.0.1.nip.io:{port}"),
        format!("127.0.0.1:{other}"),
        "127.0.0.1".to_string(),
        format!("127.0.0.2:{port}"),
    ];
    for path in ["/", "/image.png", "/events"] {
        for host in &misdirected {
            assert_refused(&address, &request(path, Some(host), ""), 421, &format!("{host} {path}"));
        }
        assert_refused(&address, &request(path, None, ""), 400, &format!("no Host, {path}"));
        let two = request(path, Some(&address), "Host: evil.example\r\n");
        assert_refused(&address, &two, 400, &format!("two Hosts, {path}"));
        let old = format!("GET {path} HTTP/1.0\r\n\r\n");
        assert_refused(&address, &old, 400, &format!("HTTP/1.0 without Host, {path}"));
    }
    // The event stream (and the rest) refuse other sites' pages.
    assert!(open_events(&address, &format!("Origin: http://{address}\r\n")).is_ok());
    assert!(open_events(&address, &format!("Origin: http://localhost:{port}\r\n")).is_ok());
    for origin in
        ["http://evil.example", "null", &format!("https://{address}"), &format!("http://{address}.evil.example")]
    {
        let answer = open_events(&address, &format!("Origin: {origin}\r\n")).expect_err(origin);
        assert!(String::from_utf8_lossy(&answer).starts_with("HTTP/1.1 403 "), "{origin}");
    }
    assert_refused(&address, &request("/", Some(&address), "Origin: http://evil.example\r\n"), 403, "Origin on /");
}

#[test]
fn serve_on_every_address_answers_ip_addresses_not_names() {
    let (_watch, address) = serve_scene("serve-any", "0.0.0.0:0");
    assert!(address.starts_with("127.0.0.1:"), "the page's address to open: {address}");
    let port: u16 = address.rsplit(':').next().unwrap().parse().unwrap();
    for host in [address.clone(), format!("localhost:{port}")] {
        assert_eq!(ask(&address, &request("/", Some(&host), "")).0, 200, "{host}");
    }
    for host in [format!("evil.example:{port}"), format!("this-machine:{port}"), format!("127.0.0.1:{}", port ^ 1)] {
        assert_refused(&address, &request("/", Some(&host), ""), 421, &host);
    }
}

#[test]
fn slow_and_oversized_request_heads_are_cut_off_without_stalling_others() {
    let (_watch, address) = serve_scene("serve-slow", "127.0.0.1:0");
    // A client sending its head a byte every 100 ms, never finishing it.
    let mut slow = Client::connect(&address);
    let mut drip = slow.stream.try_clone().unwrap();
    let host = address.clone();
    let dripping = std::thread::spawn(move || {
        let started = Instant::now();
        let head = format!("GET / HTTP/1.1\r\nHost: {host}\r\nX-Slow: ");
        for byte in head.bytes().chain(std::iter::repeat(b'z')) {
            if drip.write_all(&[byte]).is_err() || started.elapsed() > PATIENCE {
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    });
    // Meanwhile others are answered, one after another.
    for path in ["/", "/image.png", "/"] {
        assert_eq!(ask(&address, &request(path, Some(&address), "")).0, 200, "{path}");
    }
    // Heads over the bound: a long field, many fields, a long path.
    let long_field = request("/", Some(&address), &format!("X-Long: {}\r\n", "a".repeat(16 * 1024)));
    let many_fields: String = (0..200).map(|i| format!("X-Field-{i}: {i}\r\n")).collect();
    let many_fields = request("/", Some(&address), &many_fields);
    let long_path = request(&format!("/{}", "a".repeat(16 * 1024)), Some(&address), "");
    for head in [long_field, many_fields, long_path] {
        assert_refused(&address, &head, 431, &head[..60]);
    }
    // The slow client is answered 408 and closed at the server's deadline.
    assert_eq!(slow.response().map(|(status, _)| status), Some(408));
    assert!(slow.closes());
    dripping.join().unwrap();
}

/// The threads of process `pid` (Linux: its `/proc` entries).
#[cfg(target_os = "linux")]
fn threads(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/task")).unwrap().count()
}

#[cfg(target_os = "linux")]
#[test]
fn a_thousand_idle_connections_hold_a_bounded_number_of_threads() {
    // serve::http::MAX_CONNECTIONS: the most connections (so threads) held.
    const MAX_CONNECTIONS: usize = 64;
    // A connection's thread frees its slot just before it ends: a few of
    // those may still be there when the threads are counted.
    const ENDING: usize = 4;
    let (watch, address) = serve_scene("serve-idle", "127.0.0.1:0");
    let before = threads(watch.child.id());
    let mut idle = Vec::new();
    for _ in 0..1000 {
        match TcpStream::connect(&address) {
            Ok(stream) => idle.push(stream),
            Err(_) => break, // out of file descriptors: enough
        }
    }
    assert!(idle.len() >= 200, "only {} connections opened", idle.len());
    // A new page load is still answered: the idlest connections make room.
    for path in ["/", "/image.png"] {
        assert_eq!(ask(&address, &request(path, Some(&address), "")).0, 200, "{path}");
    }
    assert!(open_events(&address, "").is_ok());
    let during = threads(watch.child.id());
    assert!(
        during <= before + MAX_CONNECTIONS + ENDING,
        "{before} threads before, {during} with {} connections open",
        idle.len()
    );
}

#[test]
fn pipelined_requests_are_answered_in_order_and_stall_no_one() {
    let (_watch, address) = serve_scene("serve-pipeline", "127.0.0.1:0");
    let get = |path: &str, more: &str| request(path, Some(&address), more);
    // A request pipelined behind an event stream waits on that connection
    // alone (the stream never ends); others are answered.
    let mut stream = TcpStream::connect(&address).unwrap();
    stream.write_all([get("/events", ""), get("/", "")].concat().as_bytes()).unwrap();
    stream.set_read_timeout(Some(PATIENCE)).unwrap();
    let mut events = BufReader::new(stream);
    let first_event = loop {
        let mut line = String::new();
        assert!(events.read_line(&mut line).unwrap() > 0, "the event stream closed");
        if line.starts_with("data: ") {
            break line;
        }
    };
    assert!(first_event.contains("\"spp\":4"), "{first_event}");
    assert_eq!(ask(&address, &get("/", "")).0, 200);

    // Four requests in one write, answered in order on the one connection,
    // which closes after the one that asks it to.
    let mut client = Client::connect(&address);
    client
        .send(&[get("/", ""), get("/image.png", ""), get("/nothing", ""), get("/", "Connection: close\r\n")].concat());
    let answers: Vec<(u16, Vec<u8>)> = (0..4).map_while(|_| client.response()).collect();
    let statuses: Vec<u16> = answers.iter().map(|(status, _)| *status).collect();
    assert_eq!(statuses, [200, 200, 404, 200]);
    assert!(String::from_utf8_lossy(&answers[0].1).contains("new EventSource"));
    image::load_from_memory(&answers[1].1).unwrap();
    assert_eq!(answers[0].1, answers[3].1);
    assert!(client.closes());

    // A refused request closes its connection: what follows is not read.
    let batch = [request("/", Some("evil.example"), ""), get("/", "")].concat();
    assert_refused(&address, &batch, 421, "a misdirected request with another behind it");

    // A client pipelining thousands of requests and reading no answer is
    // cut off at its own connection; others are answered.
    let hoarder = TcpStream::connect(&address).unwrap();
    let mut writer = hoarder.try_clone().unwrap();
    let requests = get("/image.png", "").repeat(5000);
    let hoarding = std::thread::spawn(move || {
        let _ = writer.write_all(requests.as_bytes());
    });
    for _ in 0..3 {
        assert_eq!(ask(&address, &get("/image.png", "")).0, 200);
    }
    let _ = hoarder.shutdown(std::net::Shutdown::Both);
    hoarding.join().unwrap();
}
