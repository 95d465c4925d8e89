//! `tslc watch` as an editor's user meets it: the image appears, an edit
//! that breaks the scene prints diagnostics and keeps the image, a fix or an
//! edit to an imported file or a texture renders again, an edit cancels the
//! pass in progress, and `--serve` answers the page, its events and the image.
//! Small images and few samples: each test takes a few seconds.

use std::io::{BufRead, BufReader, Read, Write};
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
    let mut stream = std::net::TcpStream::connect(address).unwrap();
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
    let mut events = std::net::TcpStream::connect(&address).unwrap();
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
